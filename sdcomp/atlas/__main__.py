"""``python -m sdcomp.atlas build|info``: see :mod:`sdcomp.cli.atlas`."""

import sys

from ..cli.atlas import main
from ..errors import run_cli

sys.exit(run_cli(main))
