"""Choosing a mesh: a built-in one by name, or a user's file with how to read it.

Built-in names: the BlueROV2 (``bluerov2``, ``bluerov2-heavy``), the search-and-rescue kinds
(``swimmer``, ``boat``, ``jetski``, ``life_saving_appliances``, ``buoy``: each a set of
variants, :mod:`sdcomp.assets.sar`) and their single variants (``swimmer-03``). An
``--object`` of a kind stands for all its variants (:func:`variants`); a ``--mesh`` of a
kind, for the command lines that take one mesh, is the lineup of them
(:func:`sdcomp.assets.sar.lineup`).

:class:`MeshSpec` is what an ``--object`` or ``--mesh`` names; :meth:`MeshSpec.load` builds
the built-in mesh or reads the file (:mod:`sdcomp.assets.meshfile`).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import UserError
from . import bluerov2, sar
from .mesh import ColoredMesh
from .meshfile import check_read_options, load_mesh_file

#: names of the built-in meshes and kinds (plus each kind's variants, ``KIND-NN``)
BUILTIN = (*bluerov2.VARIANTS, *sar.KINDS)


def is_builtin(name: str) -> bool:
    """Whether ``name`` is a built-in mesh, kind or variant."""
    return name in BUILTIN or sar.parse_name(name) is not None


def variants(name: str) -> tuple[str, ...]:
    """The meshes an object named ``name`` is drawn from: a kind's variant names
    (``swimmer-00`` ...), else ``name`` itself (a built-in mesh, a variant or a file)."""
    return sar.variant_names(name) if name in sar.KINDS else (name,)


def kind_of(name: str) -> str | None:
    """The search-and-rescue kind a kind or variant name belongs to (None for others)."""
    if name in sar.KINDS:
        return name
    parsed = sar.parse_name(name)
    return None if parsed is None else parsed[0]


def build_builtin(name: str) -> ColoredMesh:
    """The built-in mesh ``name``: a BlueROV2, a variant, or a kind's lineup."""
    if name in bluerov2.VARIANTS:
        return bluerov2.build(name)
    if name in sar.KINDS:
        return sar.lineup(name)
    parsed = sar.parse_name(name)
    if parsed is None:
        raise UserError(f"{name!r} is not a built-in mesh; use one of {', '.join(BUILTIN)} "
                        f"or a variant such as swimmer-03")
    return sar.build(*parsed)


@dataclass(frozen=True)
class MeshSpec:
    """Which mesh to use and how to read it; validated on construction.

    Attributes:
        source: a built-in name (:data:`BUILTIN`, or a variant like ``swimmer-03``) or a
            mesh file path.
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
        return is_builtin(self.source)

    def load(self) -> ColoredMesh:
        """Build or read the mesh (UserError for a bad file or name)."""
        if self.is_builtin:
            return build_builtin(self.source)
        path = Path(self.source)
        if not path.exists() and not path.suffix:
            raise UserError(f"mesh {self.source!r} is neither a built-in mesh "
                            f"({', '.join(BUILTIN)}, or a variant such as swimmer-03) nor "
                            f"an existing file")
        return load_mesh_file(path, units=self.units, up=self.up, color=self.color,
                              waterline=self.waterline)
