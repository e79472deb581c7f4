"""Solids made from triangles by hand: lofts over rings of points and sweeps along paths
(boat hulls, RIB tubes, grab lines, rescue tubes).

Frame and units: metres, x forward, y port (left), z up. The results are closed
``manifold3d.Manifold`` solids, painted and finished like the primitives of
:mod:`~sdcomp.assets.solids`.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import manifold3d as m3
import numpy as np

from .solids import Vec


def solid_from_arrays(verts: np.ndarray, faces: np.ndarray) -> m3.Manifold:
    """A manifold from a closed triangle mesh (vertices (V, 3) metres, faces (F, 3)
    indices), re-oriented so that its volume is positive; ValueError if it is not a closed
    manifold."""
    tri = verts[faces]
    signed = np.einsum("ij,ij->i", tri[:, 0], np.cross(tri[:, 1], tri[:, 2])).sum() / 6.0
    if signed < 0:
        faces = faces[:, ::-1]
    mesh = m3.Mesh(vert_properties=np.ascontiguousarray(verts, np.float32),
                   tri_verts=np.ascontiguousarray(faces, np.uint32))
    solid = m3.Manifold(mesh)
    if solid.status() != m3.Error.NoError:
        raise ValueError(f"hand-made mesh is not manifold: {solid.status()}")
    return solid


def loft(rings: Sequence[np.ndarray], closed: bool = False,
         apexes: tuple[Vec | None, Vec | None] = (None, None)) -> m3.Manifold:
    """A solid skinned over ``rings`` ((N, 3) points each, the same N and winding, metres).

    Consecutive rings are joined by quads; unless ``closed`` (the last ring joins the first,
    a torus-like loop), each end is capped by a fan from the ring's centroid (or from the
    given ``apexes`` point: a cone), so end rings must be star-shaped about that point.
    Rings must not cross each other.
    """
    rings = [np.asarray(r, dtype=float) for r in rings]
    n, k = len(rings[0]), len(rings)
    verts = [np.concatenate(rings)]
    faces = []
    j = np.arange(n)
    jn = (j + 1) % n
    for i in range(k if closed else k - 1):
        a, b = i * n, ((i + 1) % k) * n
        faces.append(np.stack([a + j, a + jn, b + jn], 1))
        faces.append(np.stack([a + j, b + jn, b + j], 1))
    if not closed:
        c0, c1 = k * n, k * n + 1
        a0, a1 = apexes
        verts.append(np.stack([rings[0].mean(0) if a0 is None else np.asarray(a0, float),
                               rings[-1].mean(0) if a1 is None else np.asarray(a1, float)]))
        faces.append(np.stack([np.full(n, c0), jn, j], 1))
        last = (k - 1) * n
        faces.append(np.stack([np.full(n, c1), last + j, last + jn], 1))
    return solid_from_arrays(np.concatenate(verts), np.concatenate(faces))


def sweep(path: Sequence[Vec], section: np.ndarray | Callable[[int], np.ndarray],
          closed: bool = False, up: Vec = (0.0, 0.0, 1.0),
          end_extend: float = 0.0) -> m3.Manifold:
    """A tube along ``path`` ((P, 3) metres) with a 2-D ``section``.

    ``section`` is an (M, 2) array of (side, up) offsets in metres, or a function of the
    path index giving one; side is horizontal and perpendicular to the path, up completes
    the frame with ``up`` as reference (the path must never run parallel to ``up``).
    ``closed`` joins the end to the start (a ring); otherwise the ends are capped, and
    ``end_extend`` > 0 moves each cap's centre that far beyond the end along the path (a
    rounded-looking cone).
    """
    pts = np.asarray(path, dtype=float)
    ref = np.asarray(up, dtype=float)
    if closed:
        tang = np.roll(pts, -1, 0) - np.roll(pts, 1, 0)
    else:
        tang = np.gradient(pts, axis=0)
    tang /= np.linalg.norm(tang, axis=1, keepdims=True)
    side = np.cross(ref, tang)
    side /= np.linalg.norm(side, axis=1, keepdims=True)
    upv = np.cross(tang, side)
    rings = []
    for i in range(len(pts)):
        sec = np.asarray(section(i) if callable(section) else section, dtype=float)
        rings.append(pts[i] + sec[:, :1] * side[i] + sec[:, 1:2] * upv[i])
    if closed or end_extend <= 0:
        return loft(rings, closed=closed)
    return loft(rings, apexes=(pts[0] - tang[0] * end_extend, pts[-1] + tang[-1] * end_extend))
