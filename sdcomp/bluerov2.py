"""Procedural BlueROV2 (standard and heavy) built from primitives and booleans in manifold3d.

Dimensions, positions and colours follow the vendor's published geometry (BlueROV2 frame:
side panels, bottom plate, thruster decks, buoyancy foam, electronics and battery tubes, T200
thrusters, lights; the heavy adds side wings with vertical thrusters). Parts are placed in the
vendor's body frame (metres, x forward, y port, z up), united into one closed mesh whose faces
keep the colour of the part they come from, then re-centred on the bounding box.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence

import manifold3d as m3
import numpy as np

from .coloredmesh import ColoredMesh, centred

# sRGB colours of the parts.
BLACK = (39, 39, 39)
FOAM = (43, 165, 231)
ACRYLIC = (231, 231, 231)
DOME = (222, 222, 222)
METAL = (87, 87, 87)
PROPELLER = (30, 120, 215)
LENS = (231, 231, 231)

VARIANTS = ("bluerov2", "bluerov2-heavy")

# Waterline in the vendor frame: foam tops (z = 0.091) and the electronics tube top
# (z = 0.079) stand a few centimetres above the water when the vehicle floats.
WATERLINE_Z = 0.060

_SEG = 48  # circular segments for large round parts
_SEG_S = 24  # ... for small ones
YAW = 45.0  # horizontal thruster yaw, degrees (the vendor convention; the CAD shows 30-33)

Part = tuple[m3.Manifold, tuple[int, int, int]]


def _box(size: Sequence[float], centre: Sequence[float]) -> m3.Manifold:
    return m3.Manifold.cube(list(size), center=True).translate(list(centre))


def _along_x(radius: float, x0: float, x1: float, y: float, z: float,
             segments: int = _SEG, radius_end: float | None = None) -> m3.Manifold:
    """A cylinder or cone on an x-parallel axis from x0 to x1 through (y, z)."""
    r1 = radius if radius_end is None else radius_end
    c = m3.Manifold.cylinder(x1 - x0, radius, r1, segments)  # z from 0 to length
    # rotate +90 about y: (x, y, z) -> (z, y, -x): the cylinder now runs along +x.
    return c.rotate([0, 90, 0]).translate([x0, y, z])


def _along_z(radius: float, z0: float, z1: float, x: float, y: float,
             segments: int = _SEG) -> m3.Manifold:
    return m3.Manifold.cylinder(z1 - z0, radius, radius, segments).translate([x, y, z0])


def _capsule_path(points: Sequence[Sequence[float]], radius: float) -> m3.Manifold:
    """A cable: capsules (hulls of two spheres) joining consecutive ``points``."""
    balls = [m3.Manifold.sphere(radius, 12).translate(list(p)) for p in points]
    links = [m3.Manifold.batch_hull([a, b]) for a, b in zip(balls[:-1], balls[1:], strict=True)]
    return m3.Manifold.batch_boolean(links, m3.OpType.Add)


def _rounded_rect(x0: float, x1: float, y0: float, y1: float, r: float) -> m3.CrossSection:
    """A rectangle with rounded corners of radius ``r`` as a 2-D cross-section."""
    inner = m3.CrossSection.square([x1 - x0 - 2 * r, y1 - y0 - 2 * r]).translate([x0 + r, y0 + r])
    return inner.offset(r, m3.JoinType.Round, circular_segments=_SEG_S)


def _polygon(points: Iterable[Sequence[float]], round_r: float = 0.0) -> m3.CrossSection:
    """A simple polygon (either winding) with its convex corners rounded by ``round_r``."""
    pts = np.asarray(list(points), dtype=float)
    x, y = pts[:, 0], pts[:, 1]
    if np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)) < 0:  # clockwise
        pts = pts[::-1]
    cs = m3.CrossSection([pts])
    if round_r > 0:
        cs = cs.offset(-round_r, m3.JoinType.Round, circular_segments=_SEG_S)
        cs = cs.offset(round_r, m3.JoinType.Round, circular_segments=_SEG_S)
    return cs


def _plate_xz(cs: m3.CrossSection, y_centre: float, thickness: float) -> m3.Manifold:
    """Extrude a cross-section drawn in (x, z) into a plate of ``thickness`` centred on y."""
    # rotate +90 about x: (X, Y, Z) -> (X, -Z, Y): the section's Y becomes z, the
    # extrusion (0..t along Z) becomes y in [-t, 0].
    return cs.extrude(thickness).rotate([90, 0, 0]).translate([0, y_centre + thickness / 2, 0])


def _plate_xy(cs: m3.CrossSection, z_centre: float, thickness: float) -> m3.Manifold:
    return cs.extrude(thickness).translate([0, 0, z_centre - thickness / 2])


# --------------------------------------------------------------------------- parts

PANEL_OUTLINE = (  # (x, z) of a side panel, vendor frame, metres
    (0.195, 0.087), (0.195, -0.100), (0.119, -0.1587), (-0.148, -0.1587),
    (-0.243, -0.100), (-0.2534, -0.085), (-0.2534, 0.026), (-0.231, 0.076),
    (-0.212, 0.0942), (0.053, 0.0942), (0.137, 0.087),
)
PANEL_T = 0.014
PANEL_Y = 0.162


def _side_panels(dx: float) -> list[Part]:
    outline = _polygon(PANEL_OUTLINE, round_r=0.008)
    window = _rounded_rect(-0.200, 0.150, -0.122, 0.003, 0.025)
    slot_a = _rounded_rect(-0.175, -0.050, 0.030, 0.066, 0.012)
    slot_b = _rounded_rect(0.020, 0.150, 0.030, 0.066, 0.012)
    handle = _rounded_rect(-0.030, 0.010, 0.050, 0.080, 0.008)  # carry-handle hole
    section = outline - window - slot_a - slot_b - handle
    parts = []
    for s in (1, -1):
        parts.append((_plate_xz(section, s * PANEL_Y, PANEL_T).translate([dx, 0, 0]), BLACK))
    return parts


def _bottom_plate(dx: float, thruster_openings: bool) -> list[Part]:
    """Bottom plate with three skids under it and, where ``thruster_openings`` (the
    standard), openings under the central vertical thrusters."""
    plate = _plate_xy(_rounded_rect(-0.140, 0.110, -0.160, 0.160, 0.010), -0.1425, 0.015)
    skids = [_box([0.267, w, 0.012], [-0.0145, y, -0.1527])
             for y, w in ((-0.135, 0.065), (0.0, 0.050), (0.135, 0.065))]
    body = m3.Manifold.batch_boolean([plate, *skids], m3.OpType.Add)
    if thruster_openings:
        holes = [_along_z(0.046, -0.2, 0.0, -0.013, y) for y in (-0.11, 0.11)]
        body = body - m3.Manifold.batch_boolean(holes, m3.OpType.Add)
    return [(body.translate([dx, 0, 0]), BLACK)]


def _decks(xs: Sequence[float], dx: float) -> list[Part]:
    parts = []
    for x in xs:
        for y in (0.11, -0.11):
            deck = _plate_xy(_rounded_rect(x - 0.0915, x + 0.0915, y - 0.0505, y + 0.0505,
                                           0.006), 0.011, 0.013)
            parts.append((deck.translate([dx, 0, 0]), BLACK))
    return parts


def _foam_block(x0: float, x1: float, y: float) -> m3.Manifold:
    """A foam block 99 mm wide, 74 mm high, top at z = 0.091, rounded edges."""
    w, z0, z1 = 0.099, 0.017, 0.091
    plan = _plate_xy(_rounded_rect(x0, x1, y - w / 2, y + w / 2, 0.016), (z0 + z1) / 2, z1 - z0)
    prof = _rounded_rect(y - w / 2, y + w / 2, z0 - 0.02, z1, 0.014)  # in (y, z)
    # extrude the (y, z) profile along x: rotate so section X->y, Y->z, extrusion->x
    prof3 = prof.extrude(x1 - x0 + 0.02).rotate([90, 0, 90]).translate([x0 - 0.01, 0, 0])
    return plan ^ prof3


def _foam(heavy: bool, dx: float) -> list[Part]:
    parts = []
    for y in (0.11, -0.11):
        if heavy:
            parts.append((_foam_block(-0.229, 0.199, y).translate([dx, 0, 0]), FOAM))
        else:
            for xc in (0.11, -0.14):
                parts.append((_foam_block(xc - 0.089, xc + 0.089, y).translate([dx, 0, 0]), FOAM))
    return parts


def _electronics_tube() -> list[Part]:
    z, r = 0.022, 0.057
    tube = _along_x(r, -0.151, 0.128, 0.0, z)
    front_flange = _along_x(r + 0.0025, 0.128, 0.147, 0.0, z)
    # the dome is a little smaller than the tube and seated in the front flange
    dome = m3.Manifold.sphere(0.047, _SEG).translate([0.143, 0, z]) ^ _box(
        [0.06, 0.12, 0.12], [0.143 + 0.03, 0, z])
    rear = _along_x(r + 0.0025, -0.185, -0.151, 0.0, z)
    pens = [_along_x(0.009, -0.213, -0.184, y, z + dz, _SEG_S)
            for y in (-0.030, -0.010, 0.010, 0.030) for dz in (0.018, -0.018)]
    return [
        (tube, ACRYLIC),
        (dome, DOME),
        (m3.Manifold.batch_boolean([front_flange, rear, *pens], m3.OpType.Add), METAL),
    ]


def _battery_tube() -> list[Part]:
    z, r = -0.085, 0.045
    body = _along_x(r, -0.117, 0.077, 0.0, z)
    caps = _along_x(r + 0.002, -0.131, -0.117, 0.0, z) + _along_x(r + 0.002, 0.077, 0.091, 0.0, z)
    return [(body, ACRYLIC), (caps, BLACK)]


def _thruster(centre: Sequence[float], yaw_deg: float, pitch_deg: float) -> list[Part]:
    """A T200: duct (nozzle) 100 mm across, motor hub, three blue blades, four stator struts.

    Built along +z at the origin, then tilted by ``pitch_deg`` about y (90 = horizontal) and
    yawed by ``yaw_deg`` about z, then moved to ``centre``.
    """
    ro, ri, h = 0.050, 0.040, 0.062
    duct = (m3.Manifold.cylinder(h, ro, ro, _SEG, True)
            - m3.Manifold.cylinder(h + 0.01, ri, ri, _SEG, True))
    hub = m3.Manifold.cylinder(0.100, 0.021, 0.017, _SEG_S, True)
    struts = [_box([0.005, ri * 2 + 0.002, 0.012], [0, 0, -h / 2 + 0.006]).rotate([0, 0, a])
              for a in (0, 90)]
    blades = [_box([0.024, 0.020, 0.004], [0.029, 0, 0.006]).rotate([30, 0, 0])
              .rotate([0, 0, a]) for a in (0, 120, 240)]
    body = m3.Manifold.batch_boolean([duct, hub, *struts], m3.OpType.Add)
    prop = m3.Manifold.batch_boolean(blades, m3.OpType.Add) - hub

    def place(m: m3.Manifold) -> m3.Manifold:
        return m.rotate([0, pitch_deg, 0]).rotate([0, 0, yaw_deg]).translate(list(centre))

    return [(place(body), BLACK), (place(prop), PROPELLER)]


def _horizontal_thrusters(xs: Sequence[float], dx: float) -> list[Part]:
    parts = []
    for x, fore in ((xs[0], True), (xs[1], False)):
        for y in (0.097, -0.097):
            # vectored: each axis YAW degrees off the x axis, pointing out of the frame
            yaw = (YAW if y > 0 else -YAW) if fore else (180 - YAW if y > 0 else YAW - 180)
            parts += _thruster([x + dx, y, -0.042], yaw, 90.0)
    return parts


def _lights(dx: float) -> list[Part]:
    parts = []
    for y in (0.1875, -0.1875):
        for z in (0.069, -0.096):
            body = _along_x(0.019, 0.147, 0.198, y, z, _SEG_S)
            bracket = _box([0.020, 0.030, 0.010], [0.160, y - math.copysign(0.015, y), z])
            lens = _along_x(0.016, 0.198, 0.2065, y, z, _SEG_S)
            parts.append(((body + bracket).translate([dx, 0, 0]), BLACK))
            parts.append((lens.translate([dx, 0, 0]), LENS))
        # the cable from the upper light loops down outside the panel to the lower one
        cable = _capsule_path([(0.150, y, 0.069), (0.110, y * 0.985, 0.010),
                               (0.075, y * 0.95, -0.035), (0.150, y, -0.096)], 0.0035)
        parts.append((cable.translate([dx, 0, 0]), BLACK))
    return parts


WING_OUTLINE = (  # (x, y) of the port wing, heavy frame, metres
    (0.195, 0.168), (0.195, 0.200), (0.180, 0.230), (0.160, 0.262), (0.140, 0.277),
    (0.120, 0.2835), (0.070, 0.2865), (-0.080, 0.2865), (-0.120, 0.283), (-0.140, 0.281),
    (-0.159, 0.275), (-0.169, 0.263), (-0.189, 0.237), (-0.209, 0.205), (-0.215, 0.168),
)


def _wings() -> list[Part]:
    parts = []
    for s in (1, -1):
        pts = [(x, s * y) for x, y in WING_OUTLINE]
        outline = _polygon(pts, round_r=0.004)
        window = _rounded_rect(-0.055, 0.058, *sorted((s * 0.160, s * 0.268)), 0.020)
        holes = [m3.CrossSection.circle(0.049, _SEG).translate([x, s * 0.217])
                 for x in (0.12, -0.12)]
        section = outline - window
        for h in holes:
            section = section - h
        parts.append((_plate_xy(section, 0.011, 0.013), BLACK))
        for x in (0.12, -0.12):
            parts += _thruster([x, s * 0.217, 0.020], 0.0, 0.0)
    return parts


def build(variant: str = "bluerov2") -> ColoredMesh:
    """Build the procedural BlueROV2 ``variant`` ('bluerov2' or 'bluerov2-heavy').

    Returns a closed :class:`ColoredMesh` in metres, body frame centred on its bounding box,
    with the waterline just under the foam tops and the electronics tube top.
    """
    if variant not in VARIANTS:
        raise ValueError(f"unknown BlueROV2 variant {variant!r}; choose one of {VARIANTS}")
    heavy = variant == "bluerov2-heavy"
    # The heavy's CAD frame sits 16.7 mm further forward than the standard's: the frame
    # parts (panels, tubes, decks, lights) are shifted by dx, its own parts are given in it.
    dx = 0.0167 if heavy else 0.0
    parts: list[Part] = []
    parts += _side_panels(dx)
    parts += _bottom_plate(dx, thruster_openings=not heavy)
    parts += _decks((0.11, -0.14), dx)
    parts += _foam(heavy, dx)
    parts += [(m.translate([dx, 0, 0]), c) for m, c in _electronics_tube() + _battery_tube()]
    parts += _lights(dx)
    if heavy:
        parts += _horizontal_thrusters((0.136 - dx, -0.146 - dx), dx)
        parts += _wings()
    else:
        parts += _horizontal_thrusters((0.12, -0.16), dx)
        for y in (0.11, -0.11):
            parts += _thruster([-0.013, y, 0.040], 0.0, 0.0)
    return _unite(parts, variant, WATERLINE_Z)


def _unite(parts: list[Part], name: str, waterline: float) -> ColoredMesh:
    """Union the parts into one closed mesh; each face keeps the colour of its part."""
    originals = []
    colour_of: dict[int, tuple[int, int, int]] = {}
    for manifold, colour in parts:
        if manifold.is_empty():
            continue
        o = manifold.as_original()
        colour_of[o.original_id()] = colour
        originals.append(o)
    united = m3.Manifold.batch_boolean(originals, m3.OpType.Add)
    mesh = united.to_mesh()
    verts = np.asarray(mesh.vert_properties, dtype=np.float64)[:, :3]
    faces = np.asarray(mesh.tri_verts, dtype=np.int64)
    run_ids = np.asarray(mesh.run_original_id)
    run_index = np.asarray(mesh.run_index)
    colours = np.zeros((len(faces), 3), np.uint8)
    for rid, start, end in zip(run_ids, run_index[:-1] // 3, run_index[1:] // 3, strict=True):
        colours[start:end] = colour_of.get(int(rid), BLACK)
    verts, wl = centred(verts, waterline)
    return ColoredMesh(verts, faces, colours, wl, name, closed=True)
