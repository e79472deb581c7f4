"""``python -m sdcomp.show``: contact sheets of a dataset (:mod:`sdcomp.cli.show`).

Also the names an earlier ``sdcomp.show`` module offered, from their new homes.
"""

import sys

from .cli.show import main
from .errors import run_cli
from .io.layout import load_dataset
from .report.sheet import contact_sheet, render_cell, select_indices, write_sheet

__all__ = ["contact_sheet", "load_dataset", "main", "render_cell", "select_indices", "write_sheet"]

if __name__ == "__main__":
    sys.exit(run_cli(main))
