"""``python -m sdcomp.merge``: joining shard folders (:mod:`sdcomp.cli.merge`).

Also the names an earlier ``sdcomp.merge`` module offered, from their new homes.
"""

import sys

from .cli.merge import main
from .errors import run_cli
from .run.merge import check_shards, merge, read_shard

__all__ = ["check_shards", "main", "merge", "read_shard"]

if __name__ == "__main__":
    sys.exit(run_cli(main))
