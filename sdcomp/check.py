"""``python -m sdcomp.check``: check a generated dataset (:mod:`sdcomp.cli.check`)."""

import sys

from .cli.check import main
from .errors import run_cli

if __name__ == "__main__":
    sys.exit(run_cli(main))
