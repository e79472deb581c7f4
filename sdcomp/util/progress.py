"""A progress bar on stderr (tqdm): shown on a terminal, silent in logs and CI.

``generate: 45%|████▌     | 1350/3000 [00:04<00:05, 291.9img/s]``: the bar, the percentage,
done/total, elapsed time, the time left and the rate.
"""

from __future__ import annotations

import sys

from tqdm import tqdm


class Progress:
    """``Progress(total, label)``; call :meth:`update` per item, :meth:`close` at the end.

    Drawn by tqdm (at most 10 redraws a second) only when stderr is a terminal, or when
    ``enabled`` is True; ``enabled=False`` draws nothing.
    """

    def __init__(self, total: int, label: str, enabled: bool | None = None, unit: str = "it"):
        self.total, self.label, self.unit = total, label, unit
        self.enabled = sys.stderr.isatty() if enabled is None else enabled
        self.done = 0
        self._bar = (tqdm(total=total, desc=label, unit=unit, file=sys.stderr,
                          mininterval=0.1, dynamic_ncols=True, leave=True)
                     if self.enabled else None)

    def update(self, n: int = 1) -> None:
        self.done += n
        if self._bar is not None:
            self._bar.update(n)

    def close(self) -> None:
        if self._bar is not None:
            self._bar.close()
            self._bar = None
