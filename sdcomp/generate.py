"""``python -m sdcomp.generate``: the generator's command line (:mod:`sdcomp.cli.generate`).

Also the names an earlier ``sdcomp.generate`` module offered, from their new homes.
"""

import sys

from .cli.generate import build_parser, config_from_args, main
from .errors import run_cli

__all__ = ["build_parser", "config_from_args", "main"]

if __name__ == "__main__":
    sys.exit(run_cli(main))
