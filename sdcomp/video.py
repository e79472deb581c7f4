"""``python -m sdcomp.video``: video sequences with tracked objects (:mod:`sdcomp.cli.video`)."""

import sys

from .cli.video import main
from .errors import run_cli

__all__ = ["main"]

if __name__ == "__main__":
    sys.exit(run_cli(main))
