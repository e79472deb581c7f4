"""Detector benchmark harness: the paper's ablation grid, trained and scored end to end.

``python -m sdcomp.bench grid --preset smoke --out results/`` generates each cell's dataset
with sdcomp (cached by config hash), trains a torchvision Faster R-CNN on it (resumable),
scores it with pycocotools on a test set (the user's real frames, or a held-out synthetic
"field" set) and writes one JSON per cell, markdown tables beside the paper's figures and PNG
plots. Modules, one job each:

- :mod:`.grid`: named presets (``paper``, ``paper-table1`` ... ``paper-table5``, ``smoke``),
  the cells of each table and the :class:`~.grid.GridSpec` / :class:`~.grid.Cell` configs.
- :mod:`.datasets`: cell datasets and test sets through the generator, cached by config hash.
- :mod:`.detector`: Faster R-CNN with a selectable backbone and ``--weights``.
- :mod:`.train`: the training loop (the paper's schedule by default) with checkpoints.
- :mod:`.evaluate`: COCOeval metrics (AP, AP50, AP75, APs, APm, APl, AR100).
- :mod:`.runner`: one cell start to finish, skipped when done, resumed when interrupted.
- :mod:`.report`: markdown tables with the paper's figures, PNG plots.
- :mod:`.cli`: ``grid``, ``train``, ``eval``, ``report`` subcommands.

torch and torchvision are imported only through :func:`require_torch`, when a command
trains or scores (``grid --list``, ``report`` and the configs do without); where they are
missing the commands say ``pip install -e ".[bench]"``.
"""

from __future__ import annotations

from ..errors import UserError

INSTALL_HINT = 'pip install -e ".[bench]"'


def require_torch():
    """Import and return ``(torch, torchvision)``, or raise a one-line :class:`UserError`."""
    try:
        import torch
        import torchvision
    except ImportError as e:
        raise UserError(f"the detector benchmark needs torch and torchvision ({e.name} is "
                        f"missing): {INSTALL_HINT}") from None
    return torch, torchvision
