"""Shared by the search-and-rescue mesh tests: each variant built once per session, and
measurements of a ColoredMesh."""

from __future__ import annotations

import manifold3d as m3
import numpy as np

from sdcomp.assets import sar
from sdcomp.assets.mesh import ColoredMesh

_CACHE: dict[tuple[str, int], ColoredMesh] = {}


def build_cached(kind: str, variant: int) -> ColoredMesh:
    """Variant ``variant`` of ``kind``, built once per test session."""
    key = (kind, variant)
    if key not in _CACHE:
        _CACHE[key] = sar.build(kind, variant)
    return _CACHE[key]


def all_variants() -> list[tuple[str, int]]:
    """(kind, variant) of every variant of every kind."""
    return [(k, v) for k in sar.KINDS for v in range(sar.VARIANTS[k])]


def variant_id(kv: tuple[str, int]) -> str:
    return sar.mesh_name(*kv)


def as_manifold(mesh: ColoredMesh) -> m3.Manifold:
    """The mesh as a manifold3d solid (its vertices are shared, so it is manifold)."""
    return m3.Manifold(m3.Mesh(vert_properties=np.ascontiguousarray(mesh.vertices, np.float32),
                               tri_verts=np.ascontiguousarray(mesh.faces, np.uint32)))


def fraction_below(mesh: ColoredMesh) -> float:
    """Fraction of the mesh's volume under its waterline."""
    solid = as_manifold(mesh)
    below = solid.trim_by_plane([0.0, 0.0, -1.0], -mesh.waterline)
    return below.volume() / solid.volume()


def face_areas(mesh: ColoredMesh) -> np.ndarray:
    """(F,) triangle areas, m^2."""
    tri = mesh.vertices[mesh.faces]
    return 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
