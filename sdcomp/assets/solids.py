"""Building blocks of the built-in meshes: manifold3d primitives placed in metres, painted,
and turned into a :class:`~sdcomp.assets.mesh.ColoredMesh`.

Frame: metres, x forward, y port (left), z up. Colours are recorded by *painting*: a part
made a new manifold "original" (:func:`paint`, :meth:`Painter.paint`) keeps its original id
through later booleans, so its faces, and the faces a painted tool cuts, take the part's
colour in :func:`finish`. Every helper returns a closed solid (``manifold3d.Manifold``) or a
2-D section (``manifold3d.CrossSection``). Lofted and swept solids are in
:mod:`~sdcomp.assets.lofts`, waterlines by displacement in :mod:`~sdcomp.assets.flotation`.

Default circle resolutions differ by helper (each says its own): the BlueROV2's round parts
use :data:`SEGMENTS`, the search-and-rescue objects' parts, a few pixels across at drone
range, 8 to 12.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence

import manifold3d as m3
import numpy as np

from .mesh import ColoredMesh, centred

RGB = tuple[int, int, int]
Part = tuple[m3.Manifold, RGB]
Vec = Sequence[float] | np.ndarray  # a point or vector, metres
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


# --------------------------------------------------------------------------- primitives

def box_at(size: Vec, centre: Vec) -> m3.Manifold:
    """An axis-aligned box of ``size`` (x, y, z metres) centred on ``centre``."""
    return m3.Manifold.cube(list(size), center=True).translate(list(centre))


def box_between(lo: Vec, hi: Vec) -> m3.Manifold:
    """An axis-aligned box from corner ``lo`` to corner ``hi`` (metres); ValueError unless
    every coordinate of ``hi`` exceeds that of ``lo``."""
    size = [b - a for a, b in zip(lo, hi, strict=True)]
    if min(size) <= 0:
        raise ValueError(f"box corners must be increasing, got {lo} -> {hi}")
    return m3.Manifold.cube(size).translate(list(lo))


def sphere(centre: Vec, radius: float, segments: int = 12) -> m3.Manifold:
    """A sphere of ``radius`` metres centred on ``centre``."""
    return m3.Manifold.sphere(radius, segments).translate(list(centre))


def ellipsoid(semi_axes: Vec, segments: int = SEGMENTS, centre: Vec | None = None
              ) -> m3.Manifold:
    """An axis-aligned ellipsoid with the given (x, y, z) semi-axes (metres), centred on the
    origin or on ``centre``."""
    solid = m3.Manifold.sphere(1.0, segments).scale(list(semi_axes))
    return solid if centre is None else solid.translate(list(centre))


def frame_from_z(axis: np.ndarray) -> np.ndarray:
    """(3, 3) rotation whose third column is the unit vector along ``axis`` (the others: a
    right-handed completion, chosen stably)."""
    w = axis / np.linalg.norm(axis)
    helper = np.array([1.0, 0.0, 0.0]) if abs(w[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    u = np.cross(helper, w)
    u /= np.linalg.norm(u)
    v = np.cross(w, u)
    return np.stack([u, v, w], axis=1)


def place(manifold: m3.Manifold, rotation: np.ndarray, origin: Vec
          ) -> m3.Manifold:
    """``manifold`` rotated by the (3, 3) matrix ``rotation``, then moved to ``origin``."""
    mat = np.concatenate([np.asarray(rotation, float), np.asarray(origin, float)[:, None]], 1)
    return manifold.transform(mat.tolist())


def cylinder(p0: Vec, p1: Vec, r0: float, r1: float | None = None,
             segments: int = 12) -> m3.Manifold:
    """A cylinder (or a cone frustum, radius ``r0`` at ``p0`` to ``r1`` at ``p1``) on any
    axis (metres)."""
    a, b = np.asarray(p0, float), np.asarray(p1, float)
    length = float(np.linalg.norm(b - a))
    c = m3.Manifold.cylinder(length, r0, r0 if r1 is None else r1, segments)
    return place(c, frame_from_z(b - a), a)


def cylinder_x(radius: float, x0: float, x1: float, y: float = 0.0, z: float = 0.0,
               segments: int = SEGMENTS, radius_end: float | None = None) -> m3.Manifold:
    """A cylinder (or a cone to ``radius_end``) on an x-parallel axis from x0 to x1 through
    (y, z)."""
    r1 = radius if radius_end is None else radius_end
    c = m3.Manifold.cylinder(x1 - x0, radius, r1, segments)  # z from 0 to length
    # rotate +90 about y: (x, y, z) -> (z, y, -x): the cylinder now runs along +x.
    return c.rotate([0, 90, 0]).translate([x0, y, z])


def cylinder_z(radius: float, z0: float, z1: float, x: float = 0.0, y: float = 0.0,
               segments: int = SEGMENTS, radius_end: float | None = None) -> m3.Manifold:
    """A cylinder (or a cone to ``radius_end``) on a vertical axis through (x, y), from z0
    to z1."""
    r1 = radius if radius_end is None else radius_end
    return m3.Manifold.cylinder(z1 - z0, radius, r1, segments).translate([x, y, z0])


def capsule(p0: Vec, p1: Vec, r0: float, r1: float | None = None,
            segments: int = 8) -> m3.Manifold:
    """A (tapered) capsule: the convex hull of spheres of radius ``r0`` at ``p0`` and ``r1``
    at ``p1`` (metres)."""
    r1 = r0 if r1 is None else r1
    return m3.Manifold.batch_hull([sphere(p0, r0, segments), sphere(p1, r1, segments)])


def capsule_path(points: Sequence[Vec], radius: float | Sequence[float],
                 segments: int = 12) -> m3.Manifold:
    """A cable or a limb: capsules joining consecutive ``points`` (one radius, or one per
    point)."""
    r = ([float(x) for x in radius] if isinstance(radius, Sequence)
         else [float(radius)] * len(points))
    links = [capsule(points[i], points[i + 1], r[i], r[i + 1], segments)
             for i in range(len(points) - 1)]
    return m3.Manifold.batch_boolean(links, m3.OpType.Add)


def hull(parts: Iterable[m3.Manifold]) -> m3.Manifold:
    """The convex hull of several solids (e.g. ellipsoids making a torso)."""
    return m3.Manifold.batch_hull(list(parts))


def union(parts: Iterable[m3.Manifold]) -> m3.Manifold:
    """The boolean union of several solids (empty ones are skipped)."""
    solids = [p for p in parts if not p.is_empty()]
    return m3.Manifold.batch_boolean(solids, m3.OpType.Add)


# --------------------------------------------------------------------------- 2-D sections

def rounded_rect(x0: float, x1: float, y0: float, y1: float, r: float,
                 segments: int = SEGMENTS_SMALL) -> m3.CrossSection:
    """A rectangle [x0, x1] x [y0, y1] with corners rounded by radius ``r`` as a 2-D
    cross-section (``r`` is capped just under half the shorter side)."""
    r = min(r, (x1 - x0) / 2 * 0.999, (y1 - y0) / 2 * 0.999)
    inner = m3.CrossSection.square([x1 - x0 - 2 * r, y1 - y0 - 2 * r]).translate([x0 + r, y0 + r])
    return inner.offset(r, m3.JoinType.Round, circular_segments=segments)


def polygon(points: Iterable[Vec], round_r: float = 0.0,
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


def ellipse_points(a: float, b: float, n: int, phase: float = 0.0) -> np.ndarray:
    """(n, 2) counter-clockwise points of an ellipse with semi-axes ``a`` (u) and ``b`` (v),
    starting at angle ``phase`` (radians)."""
    t = phase + np.linspace(0.0, 2 * np.pi, n, endpoint=False)
    return np.stack([a * np.cos(t), b * np.sin(t)], axis=1)


def plate_xz(cs: m3.CrossSection, y_centre: float, thickness: float) -> m3.Manifold:
    """Extrude a cross-section drawn in (x, z) into a plate of ``thickness`` centred on y."""
    # rotate +90 about x: (X, Y, Z) -> (X, -Z, Y): the section's Y becomes z, the
    # extrusion (0..t along Z) becomes y in [-t, 0].
    return cs.extrude(thickness).rotate([90, 0, 0]).translate([0, y_centre + thickness / 2, 0])


def plate_xy(cs: m3.CrossSection, z_centre: float, thickness: float) -> m3.Manifold:
    """Extrude a cross-section drawn in (x, y) into a plate of ``thickness`` centred on z."""
    return cs.extrude(thickness).translate([0, 0, z_centre - thickness / 2])


def extrude_z(cs: m3.CrossSection, z0: float, z1: float) -> m3.Manifold:
    """A section drawn in (x, y) extruded from z0 up to z1 (:func:`plate_xy` by its ends)."""
    return cs.extrude(z1 - z0).translate([0, 0, z0])


def extrude_x(cs: m3.CrossSection, x0: float, x1: float) -> m3.Manifold:
    """A section drawn in (y, z) extruded along x from x0 to x1."""
    # rotate [90, 0, 90]: section X -> y, section Y -> z, extrusion Z -> x
    return cs.extrude(x1 - x0).rotate([90, 0, 90]).translate([x0, 0, 0])


def extrude_y(cs: m3.CrossSection, y0: float, y1: float) -> m3.Manifold:
    """A section drawn in (x, z) extruded along y from y0 to y1 (:func:`plate_xz` by its
    ends)."""
    # rotate +90 about x: (X, Y, Z) -> (X, -Z, Y): section Y -> z, extrusion -> -y
    return cs.extrude(y1 - y0).rotate([90, 0, 0]).translate([0, y1, 0])


def revolve(profile: Iterable[Vec], segments: int = SEGMENTS_SMALL) -> m3.Manifold:
    """A solid of revolution about z from a closed (r, z) ``profile`` (r >= 0, metres)."""
    return polygon(np.asarray(list(profile), dtype=float)).revolve(segments)


# --------------------------------------------------------------------------- paint and finish

def finish(solid: m3.Manifold, colours: dict[int, RGB], waterline: float, name: str,
           default: RGB | None = None) -> ColoredMesh:
    """Turn a painted solid into a closed :class:`ColoredMesh` centred on its bounding box;
    faces whose original was not painted take ``default`` (ValueError for such faces
    without one, or for an empty or invalid solid).

    ``waterline`` is z of the water surface in the solid's frame; it is re-expressed in the
    centred frame.
    """
    if solid.status() != m3.Error.NoError or solid.is_empty():
        raise ValueError(f"{name}: the solid is empty or invalid ({solid.status()})")
    mesh = solid.to_mesh()
    verts = np.asarray(mesh.vert_properties, dtype=np.float64)[:, :3]
    faces = np.asarray(mesh.tri_verts, dtype=np.int64)
    run_index = np.asarray(mesh.run_index) // 3
    face_colors = np.zeros((len(faces), 3), np.uint8)
    for rid, start, end in zip(mesh.run_original_id, run_index[:-1], run_index[1:],
                               strict=True):
        colour = colours.get(int(rid), default)
        if colour is None:
            raise ValueError(f"{name}: faces from an unpainted solid (original {rid})")
        face_colors[start:end] = colour
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


class Painter:
    """Paints solids (:func:`paint` with its own colour table) and turns the painted union
    into a :class:`ColoredMesh` where every face must come from a painted solid."""

    def __init__(self) -> None:
        self.colours: dict[int, RGB] = {}

    def paint(self, manifold: m3.Manifold, colour: Iterable[int]) -> m3.Manifold:
        """``manifold`` as a new original whose faces take the sRGB ``colour``."""
        r, g, b = (int(c) for c in colour)
        return paint(manifold, (r, g, b), self.colours)

    def paint_split(self, manifold: m3.Manifold, region: m3.Manifold, inside: Iterable[int],
                    outside: Iterable[int]) -> m3.Manifold:
        """``manifold`` coloured ``inside`` where it lies in ``region``, else ``outside``
        (bands, stripes, antifouling under a boot top)."""
        return union([self.paint(manifold ^ region, inside),
                      self.paint(manifold - region, outside)])

    def finish(self, solid: m3.Manifold, waterline: float, name: str) -> ColoredMesh:
        """:func:`finish` with this painter's colours and no default colour."""
        return finish(solid, self.colours, waterline, name)
