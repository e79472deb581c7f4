"""Building blocks of the built-in meshes: manifold3d primitives placed in metres, painted,
and turned into a :class:`~sdcomp.assets.mesh.ColoredMesh`.

Frame: metres, x forward, y port (left), z up. Colours are recorded by *painting*: a part
made a new manifold "original" (:func:`paint`) keeps its original id through later booleans,
so its faces, and the faces a painted tool cuts, take the part's colour in :func:`finish`.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence

import manifold3d as m3
import numpy as np

from .mesh import ColoredMesh, centred

RGB = tuple[int, int, int]
Part = tuple[m3.Manifold, RGB]
SEGMENTS = 48  # circular segments for large round parts
SEGMENTS_SMALL = 24  # ... for small ones


def paint(manifold: m3.Manifold, colour: RGB, colours: dict[int, RGB]) -> m3.Manifold:
    """``manifold`` as a new original whose faces take ``colour`` (recorded in ``colours``).

    Faces keep their original through later booleans, so a cut made with a painted tool
    takes the tool's colour.
    """
    painted = manifold.as_original()
    colours[painted.original_id()] = colour
    return painted


def box_at(size: Sequence[float], centre: Sequence[float]) -> m3.Manifold:
    """An axis-aligned box of ``size`` (x, y, z metres) centred on ``centre``."""
    return m3.Manifold.cube(list(size), center=True).translate(list(centre))


def box_between(lo: Sequence[float], hi: Sequence[float]) -> m3.Manifold:
    """An axis-aligned box from corner ``lo`` to corner ``hi`` (metres)."""
    size = [b - a for a, b in zip(lo, hi, strict=True)]
    return m3.Manifold.cube(size).translate(list(lo))


def ellipsoid(semi_axes: Sequence[float], segments: int = SEGMENTS) -> m3.Manifold:
    """An ellipsoid centred on the origin with the given (x, y, z) semi-axes (metres)."""
    return m3.Manifold.sphere(1.0, segments).scale(list(semi_axes))


def cylinder_x(radius: float, x0: float, x1: float, y: float, z: float,
               segments: int = SEGMENTS, radius_end: float | None = None) -> m3.Manifold:
    """A cylinder (or a cone to ``radius_end``) on an x-parallel axis from x0 to x1 through
    (y, z)."""
    r1 = radius if radius_end is None else radius_end
    c = m3.Manifold.cylinder(x1 - x0, radius, r1, segments)  # z from 0 to length
    # rotate +90 about y: (x, y, z) -> (z, y, -x): the cylinder now runs along +x.
    return c.rotate([0, 90, 0]).translate([x0, y, z])


def cylinder_z(radius: float, z0: float, z1: float, x: float, y: float,
               segments: int = SEGMENTS) -> m3.Manifold:
    """A cylinder on a vertical axis through (x, y), from z0 to z1."""
    return m3.Manifold.cylinder(z1 - z0, radius, radius, segments).translate([x, y, z0])


def capsule_path(points: Sequence[Sequence[float]], radius: float) -> m3.Manifold:
    """A cable: capsules (hulls of two spheres) joining consecutive ``points``."""
    balls = [m3.Manifold.sphere(radius, 12).translate(list(p)) for p in points]
    links = [m3.Manifold.batch_hull([a, b]) for a, b in zip(balls[:-1], balls[1:], strict=True)]
    return m3.Manifold.batch_boolean(links, m3.OpType.Add)


def rounded_rect(x0: float, x1: float, y0: float, y1: float, r: float,
                 segments: int = SEGMENTS_SMALL) -> m3.CrossSection:
    """A rectangle with rounded corners of radius ``r`` as a 2-D cross-section."""
    inner = m3.CrossSection.square([x1 - x0 - 2 * r, y1 - y0 - 2 * r]).translate([x0 + r, y0 + r])
    return inner.offset(r, m3.JoinType.Round, circular_segments=segments)


def polygon(points: Iterable[Sequence[float]], round_r: float = 0.0,
            segments: int = SEGMENTS_SMALL) -> m3.CrossSection:
    """A simple polygon (either winding) with its convex corners rounded by ``round_r``."""
    pts = np.asarray(list(points), dtype=float)
    x, y = pts[:, 0], pts[:, 1]
    if np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)) < 0:  # clockwise
        pts = pts[::-1]
    cs = m3.CrossSection([pts])
    if round_r > 0:
        cs = cs.offset(-round_r, m3.JoinType.Round, circular_segments=segments)
        cs = cs.offset(round_r, m3.JoinType.Round, circular_segments=segments)
    return cs


def plate_xz(cs: m3.CrossSection, y_centre: float, thickness: float) -> m3.Manifold:
    """Extrude a cross-section drawn in (x, z) into a plate of ``thickness`` centred on y."""
    # rotate +90 about x: (X, Y, Z) -> (X, -Z, Y): the section's Y becomes z, the
    # extrusion (0..t along Z) becomes y in [-t, 0].
    return cs.extrude(thickness).rotate([90, 0, 0]).translate([0, y_centre + thickness / 2, 0])


def plate_xy(cs: m3.CrossSection, z_centre: float, thickness: float) -> m3.Manifold:
    """Extrude a cross-section drawn in (x, y) into a plate of ``thickness`` centred on z."""
    return cs.extrude(thickness).translate([0, 0, z_centre - thickness / 2])


def finish(solid: m3.Manifold, colours: dict[int, RGB], waterline: float, name: str,
           default: RGB | None = None) -> ColoredMesh:
    """Turn a painted solid into a closed :class:`ColoredMesh` centred on its bounding box;
    faces whose original was not painted take ``default`` (none may be missing without).

    ``waterline`` is z of the water surface in the solid's frame; it is re-expressed in the
    centred frame.
    """
    mesh = solid.to_mesh()
    verts = np.asarray(mesh.vert_properties, dtype=np.float64)[:, :3]
    faces = np.asarray(mesh.tri_verts, dtype=np.int64)
    run_index = np.asarray(mesh.run_index) // 3
    face_colors = np.zeros((len(faces), 3), np.uint8)
    for rid, start, end in zip(mesh.run_original_id, run_index[:-1], run_index[1:],
                               strict=True):
        face_colors[start:end] = colours[int(rid)] if default is None else colours.get(
            int(rid), default)
    verts, wl = centred(verts, waterline)
    return ColoredMesh(verts, faces, face_colors, wl, name, closed=True)


def unite(parts: list[Part], name: str, waterline: float, default: RGB) -> ColoredMesh:
    """Union coloured parts into one closed mesh; each face keeps the colour of its part
    (``default`` where none is recorded)."""
    originals = []
    colours: dict[int, RGB] = {}
    for manifold, colour in parts:
        if manifold.is_empty():
            continue
        originals.append(paint(manifold, colour, colours))
    united = m3.Manifold.batch_boolean(originals, m3.OpType.Add)
    return finish(united, colours, waterline, name, default)
