"""A minimal progress line on stderr: shown on a terminal, silent in logs and CI."""

from __future__ import annotations

import sys
import time


class Progress:
    """``Progress(total, label)``; call :meth:`update` per item, :meth:`close` at the end.

    Redraws at most 10 times a second, only when stderr is a terminal (or ``enabled=True``).
    """

    def __init__(self, total: int, label: str, enabled: bool | None = None, unit: str = "it"):
        self.total, self.label, self.unit = total, label, unit
        self.enabled = sys.stderr.isatty() if enabled is None else enabled
        self.done = 0
        self.start = time.perf_counter()
        self._last = 0.0

    def update(self, n: int = 1) -> None:
        self.done += n
        now = time.perf_counter()
        if self.enabled and (now - self._last > 0.1 or self.done >= self.total):
            self._last = now
            rate = self.done / max(now - self.start, 1e-9)
            sys.stderr.write(f"\r{self.label}: {self.done}/{self.total} "
                             f"({rate:.1f} {self.unit}/s)")
            sys.stderr.flush()

    def close(self) -> None:
        if self.enabled:
            sys.stderr.write("\n")
            sys.stderr.flush()
