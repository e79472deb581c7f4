"""``python -m sdcomp.stats``: statistics of a dataset (:mod:`sdcomp.cli.stats`).

Also the names an earlier ``sdcomp.stats`` module offered, from their new homes.
"""

import sys

from .cli.stats import main
from .errors import run_cli
from .report.stats import dataset_stats, format_table, plot_stats

__all__ = ["dataset_stats", "format_table", "main", "plot_stats"]

if __name__ == "__main__":
    sys.exit(run_cli(main))
