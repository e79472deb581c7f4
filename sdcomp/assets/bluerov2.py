"""Procedural BlueROV2 (standard and heavy) built from primitives and booleans in manifold3d.

Dimensions, positions and colours follow the vendor's published geometry (BlueROV2 frame:
side panels, bottom plate, thruster decks, buoyancy foam, electronics and battery tubes, T200
thrusters, lights; the heavy adds side wings with vertical thrusters). Parts are placed in the
vendor's body frame (metres, x forward, y port, z up), united into one closed mesh whose faces
keep the colour of the part they come from, then re-centred on the bounding box.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import manifold3d as m3

from .mesh import ColoredMesh
from .solids import (
    Part,
    box_at,
    capsule_path,
    cylinder_x,
    cylinder_z,
    plate_xy,
    plate_xz,
    polygon,
    rounded_rect,
    unite,
)

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



# --------------------------------------------------------------------------- parts

PANEL_OUTLINE = (  # (x, z) of a side panel, vendor frame, metres
    (0.195, 0.087), (0.195, -0.100), (0.119, -0.1587), (-0.148, -0.1587),
    (-0.243, -0.100), (-0.2534, -0.085), (-0.2534, 0.026), (-0.231, 0.076),
    (-0.212, 0.0942), (0.053, 0.0942), (0.137, 0.087),
)
PANEL_T = 0.014
PANEL_Y = 0.162


def _side_panels(dx: float) -> list[Part]:
    outline = polygon(PANEL_OUTLINE, round_r=0.008)
    window = rounded_rect(-0.200, 0.150, -0.122, 0.003, 0.025)
    slot_a = rounded_rect(-0.175, -0.050, 0.030, 0.066, 0.012)
    slot_b = rounded_rect(0.020, 0.150, 0.030, 0.066, 0.012)
    handle = rounded_rect(-0.030, 0.010, 0.050, 0.080, 0.008)  # carry-handle hole
    section = outline - window - slot_a - slot_b - handle
    parts = []
    for s in (1, -1):
        parts.append((plate_xz(section, s * PANEL_Y, PANEL_T).translate([dx, 0, 0]), BLACK))
    return parts


def _bottom_plate(dx: float, thruster_openings: bool) -> list[Part]:
    """Bottom plate with three skids under it and, where ``thruster_openings`` (the
    standard), openings under the central vertical thrusters."""
    plate = plate_xy(rounded_rect(-0.140, 0.110, -0.160, 0.160, 0.010), -0.1425, 0.015)
    skids = [box_at([0.267, w, 0.012], [-0.0145, y, -0.1527])
             for y, w in ((-0.135, 0.065), (0.0, 0.050), (0.135, 0.065))]
    body = m3.Manifold.batch_boolean([plate, *skids], m3.OpType.Add)
    if thruster_openings:
        holes = [cylinder_z(0.046, -0.2, 0.0, -0.013, y) for y in (-0.11, 0.11)]
        body = body - m3.Manifold.batch_boolean(holes, m3.OpType.Add)
    return [(body.translate([dx, 0, 0]), BLACK)]


def _decks(xs: Sequence[float], dx: float) -> list[Part]:
    parts = []
    for x in xs:
        for y in (0.11, -0.11):
            deck = plate_xy(rounded_rect(x - 0.0915, x + 0.0915, y - 0.0505, y + 0.0505,
                                           0.006), 0.011, 0.013)
            parts.append((deck.translate([dx, 0, 0]), BLACK))
    return parts


def _foam_block(x0: float, x1: float, y: float) -> m3.Manifold:
    """A foam block 99 mm wide, 74 mm high, top at z = 0.091, rounded edges."""
    w, z0, z1 = 0.099, 0.017, 0.091
    plan = plate_xy(rounded_rect(x0, x1, y - w / 2, y + w / 2, 0.016), (z0 + z1) / 2, z1 - z0)
    prof = rounded_rect(y - w / 2, y + w / 2, z0 - 0.02, z1, 0.014)  # in (y, z)
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
    tube = cylinder_x(r, -0.151, 0.128, 0.0, z)
    front_flange = cylinder_x(r + 0.0025, 0.128, 0.147, 0.0, z)
    # the dome is a little smaller than the tube and seated in the front flange
    dome = m3.Manifold.sphere(0.047, _SEG).translate([0.143, 0, z]) ^ box_at(
        [0.06, 0.12, 0.12], [0.143 + 0.03, 0, z])
    rear = cylinder_x(r + 0.0025, -0.185, -0.151, 0.0, z)
    pens = [cylinder_x(0.009, -0.213, -0.184, y, z + dz, _SEG_S)
            for y in (-0.030, -0.010, 0.010, 0.030) for dz in (0.018, -0.018)]
    return [
        (tube, ACRYLIC),
        (dome, DOME),
        (m3.Manifold.batch_boolean([front_flange, rear, *pens], m3.OpType.Add), METAL),
    ]


def _battery_tube() -> list[Part]:
    z, r = -0.085, 0.045
    body = cylinder_x(r, -0.117, 0.077, 0.0, z)
    caps = (cylinder_x(r + 0.002, -0.131, -0.117, 0.0, z)
            + cylinder_x(r + 0.002, 0.077, 0.091, 0.0, z))
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
    struts = [box_at([0.005, ri * 2 + 0.002, 0.012], [0, 0, -h / 2 + 0.006]).rotate([0, 0, a])
              for a in (0, 90)]
    blades = [box_at([0.024, 0.020, 0.004], [0.029, 0, 0.006]).rotate([30, 0, 0])
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
            body = cylinder_x(0.019, 0.147, 0.198, y, z, _SEG_S)
            bracket = box_at([0.020, 0.030, 0.010], [0.160, y - math.copysign(0.015, y), z])
            lens = cylinder_x(0.016, 0.198, 0.2065, y, z, _SEG_S)
            parts.append(((body + bracket).translate([dx, 0, 0]), BLACK))
            parts.append((lens.translate([dx, 0, 0]), LENS))
        # the cable from the upper light loops down outside the panel to the lower one
        cable = capsule_path([(0.150, y, 0.069), (0.110, y * 0.985, 0.010),
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
        outline = polygon(pts, round_r=0.004)
        y0, y1 = sorted((s * 0.160, s * 0.268))
        window = rounded_rect(-0.055, 0.058, y0, y1, 0.020)
        holes = [m3.CrossSection.circle(0.049, _SEG).translate([x, s * 0.217])
                 for x in (0.12, -0.12)]
        section = outline - window
        for h in holes:
            section = section - h
        parts.append((plate_xy(section, 0.011, 0.013), BLACK))
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
    return unite(parts, variant, WATERLINE_Z, BLACK)
