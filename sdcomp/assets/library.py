"""Choosing a mesh: a built-in one by name, or a user's file with how to read it.

:class:`MeshSpec` is what an ``--object`` or ``--mesh`` names; :meth:`MeshSpec.load` builds
the built-in mesh (:mod:`sdcomp.assets.bluerov2`) or reads the file
(:mod:`sdcomp.assets.meshfile`).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import UserError
from . import bluerov2
from .mesh import ColoredMesh
from .meshfile import check_read_options, load_mesh_file

BUILTIN = bluerov2.VARIANTS


@dataclass(frozen=True)
class MeshSpec:
    """Which mesh to use and how to read it; validated on construction.

    Attributes:
        source: a built-in name (``bluerov2``, ``bluerov2-heavy``) or a mesh file path.
        units: length unit of a file (m, dm, cm, mm).
        up: up axis of a file (auto, x, y, z, -x, -y, -z).
        color: one sRGB colour for all faces of a file, or None for the file's colours.
        waterline: waterline height above a file mesh's lowest point (m), None for default.
    """

    source: str = "bluerov2"
    units: str = "m"
    up: str = "auto"
    color: tuple[int, int, int] | None = None
    waterline: float | None = None

    def __post_init__(self) -> None:
        check_read_options(self.units, self.up)
        if self.waterline is not None and not np.isfinite(self.waterline):
            raise UserError(f"--waterline {self.waterline} must be a finite number of metres")

    @property
    def is_builtin(self) -> bool:
        return self.source in BUILTIN

    def load(self) -> ColoredMesh:
        """Build or read the mesh (UserError for a bad file or name)."""
        if self.is_builtin:
            return bluerov2.build(self.source)
        path = Path(self.source)
        if not path.exists() and not path.suffix:
            raise UserError(f"mesh {self.source!r} is neither a built-in mesh "
                            f"({', '.join(BUILTIN)}) nor an existing file")
        return load_mesh_file(path, units=self.units, up=self.up, color=self.color,
                              waterline=self.waterline)
