"""Built-in search-and-rescue objects: procedural, parameterised meshes of SeaDronesSee's five
classes (swimmer, boat, jetski, life_saving_appliances, buoy).

Each kind has a fixed set of variant meshes, deterministic from (kind, variant index)::

    from sdcomp.assets import sar
    mesh = sar.build("swimmer", 3)               # ColoredMesh named "swimmer-03"
    params = sar.describe_variant("swimmer", 3)  # the drawn parameters (JSON-able)
    sar.variant_names("buoy")                    # ("buoy-00", ..., "buoy-09")

Variant parameters come from a NumPy PCG64 generator seeded by (CRC-32 of the kind, variant)
(:func:`~sdcomp.assets.sar.common.rng_for`); the sub-type cycles with the variant index, so
every sub-type is in the set. ``build`` is a pure function of ``describe_variant``'s
dictionary (:func:`build_from_params`). Meshes: metres, x forward, y port, z up, centred on
the bounding box, ``waterline`` = z of the sea surface, closed (watertight), one sRGB colour
per face. Real dimensions and their sources: :mod:`~sdcomp.assets.sar.dimensions`.
"""

from __future__ import annotations

import re
from types import ModuleType

import numpy as np

from ...errors import UserError
from ..mesh import ColoredMesh, centred
from . import boat, buoy, jetski, lifesaving, swimmer
from .common import rng_for

KINDS = ("swimmer", "boat", "jetski", "life_saving_appliances", "buoy")
VARIANTS = {"swimmer": 20, "boat": 12, "jetski": 8, "life_saving_appliances": 10, "buoy": 10}

_MODULES: dict[str, ModuleType] = {
    "swimmer": swimmer, "boat": boat, "jetski": jetski, "life_saving_appliances": lifesaving,
    "buoy": buoy,
}
_NAME = re.compile(r"^([a-z_]+)-(\d\d)$")


def _check(kind: str, variant: int) -> None:
    if kind not in _MODULES:
        raise UserError(f"unknown object kind {kind!r}; use one of {', '.join(KINDS)}")
    if not isinstance(variant, int) or isinstance(variant, bool) or not (
            0 <= variant < VARIANTS[kind]):
        raise UserError(f"{kind} variant {variant!r} does not exist; use 0 to "
                        f"{VARIANTS[kind] - 1}")


def describe_variant(kind: str, variant: int = 0) -> dict:
    """The drawn parameters of (``kind``, ``variant``): sub-type, sizes (metres), masses
    (kg), angles (degrees), colours (sRGB 0-255 lists). JSON-able; the same on every run."""
    _check(kind, variant)
    return _MODULES[kind].draw(rng_for(kind, variant), variant)


def mesh_name(kind: str, variant: int) -> str:
    """File-name-safe mesh name of a variant, e.g. ``"buoy-07"``."""
    return f"{kind}-{variant:02d}"


def variant_names(kind: str) -> tuple[str, ...]:
    """The mesh names of every variant of ``kind``, in variant order."""
    _check(kind, 0)
    return tuple(mesh_name(kind, v) for v in range(VARIANTS[kind]))


def parse_name(name: str) -> tuple[str, int] | None:
    """(kind, variant) of a variant's mesh name (``"buoy-07"``), None for any other text."""
    m = _NAME.match(name)
    if m is None or m.group(1) not in VARIANTS or int(m.group(2)) >= VARIANTS[m.group(1)]:
        return None
    return m.group(1), int(m.group(2))


def build_from_params(params: dict, name: str) -> ColoredMesh:
    """Build the mesh that a :func:`describe_variant` dictionary describes."""
    return _MODULES[params["kind"]].make(params, name)


def build(kind: str, variant: int = 0) -> ColoredMesh:
    """Build variant ``variant`` of ``kind``: a closed :class:`ColoredMesh` named
    :func:`mesh_name` (metres, x forward, y port, z up, centred on its bounding box,
    waterline at the sea surface). UserError for an unknown kind or variant."""
    return build_from_params(describe_variant(kind, variant), mesh_name(kind, variant))


_TOPS: dict[tuple[str, int], float] = {}


def top_known(kind: str, variant: int) -> bool:
    """Whether :func:`top_above_water` of the variant is kept already (no build needed)."""
    return (kind, variant) in _TOPS


def top_above_water(kind: str, variant: int, mesh: ColoredMesh | None = None) -> float:
    """Height (metres) of the variant's highest point above its waterline, kept once
    known: from ``mesh`` when given (the variant's, built by the caller anyway), else from
    a mesh built for it."""
    key = (kind, variant)
    if key not in _TOPS:
        m = mesh if mesh is not None else build(kind, variant)
        _TOPS[key] = float(m.bounds[1, 2] - m.waterline)
    return _TOPS[key]


def sub_types(kind: str) -> tuple[str, ...]:
    """The sub-types of ``kind`` (e.g. a boat's motorboat, rib, sailboat, ...)."""
    _check(kind, 0)
    return tuple(_MODULES[kind].SUB_TYPES)


def lineup(kind: str, gap: float = 0.3) -> ColoredMesh:
    """Every variant of ``kind`` side by side in one mesh named ``kind``, for looking at
    them together (``python -m sdcomp.mesh export swimmer swimmers.glb``): variant 0 first,
    each next one ``gap`` times the widest variant's width further to starboard (-y),
    waterlines at z = 0; metres, x forward, centred on the bounding box."""
    meshes = [build(kind, v) for v in range(VARIANTS[kind])]
    step = (1 + gap) * max(float(m.extents[1]) for m in meshes)
    verts, faces, colours, offset = [], [], [], 0
    for i, m in enumerate(meshes):
        verts.append(m.vertices + [0.0, -i * step, -m.waterline])
        faces.append(m.faces + offset)
        colours.append(m.face_colors)
        offset += len(m.vertices)
    v, wl = centred(np.concatenate(verts), 0.0)
    return ColoredMesh(v, np.concatenate(faces), np.concatenate(colours), wl, kind,
                       closed=True)
