"""``python -m sdcomp.fitting``: ``sdcomp fit`` (:mod:`sdcomp.cli.fit`)."""

import sys

from ..cli.fit import main
from ..errors import run_cli

if __name__ == "__main__":
    sys.exit(run_cli(main))
