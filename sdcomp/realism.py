"""``python -m sdcomp.realism``: the realism report of a dataset (:mod:`sdcomp.cli.realism`)."""

import sys

from .cli.realism import main
from .errors import run_cli

if __name__ == "__main__":
    sys.exit(run_cli(main))
