"""``python -m sdcomp.mesh``: exporting or describing a mesh (:mod:`sdcomp.cli.mesh`).

Also the names an earlier ``sdcomp.mesh`` module offered, from their new homes.
"""

import sys

from .assets.export import describe, export_mesh
from .assets.library import MeshSpec
from .cli.mesh import main, parse_color
from .errors import run_cli

__all__ = ["MeshSpec", "describe", "export_mesh", "main", "parse_color"]

if __name__ == "__main__":
    sys.exit(run_cli(main))
