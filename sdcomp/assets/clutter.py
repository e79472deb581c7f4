"""Procedural floating clutter: distractors that float near the target and are never annotated.

Four kinds, built from manifold3d primitives and booleans like :mod:`sdcomp.bluerov2`, at
real-world sizes (metres, x forward, y port, z up):

- ``buoy``: a mooring buoy, an orange-red sphere 0.45 m across with a white band and a dark
  steel eye on top (0.55 m high in all); floats with 40 % of the sphere's volume under water.
- ``log``: a driftwood log 2.2 m long and about 0.3 m thick, slightly bent and tapered, brown
  bark with lighter saw-cut ends; floats half submerged.
- ``boat``: a small open dinghy, 3.3 m hull with a transom plus a 0.26 m outboard motor
  (3.56 m in all), 1.4 m wide: a hollow white hull, a dark floor, two wooden thwarts; draws
  0.15 m of water (hull bottom to waterline).
- ``foam``: a flat irregular foam patch about 1.5 m across and 25 mm thick, with two holes;
  its top stands 10 mm above the water.

Three kinds of mooring (:data:`MOORINGS`), drawn beside moored boats and jet skis
(:mod:`sdcomp.scene.moorings`) rather than at random:

- ``dock``: a fixed walkway 8 m long and 1.5 m wide, its deck 0.45 m above the water: 42
  light grey composite boards across two stringers, on 10 posts; lake docks are mostly
  aluminium frames with white or grey decking.
- ``canopy``: a boat lift 7.2 m long and 3.3 m wide under a white fabric canopy, the
  canopy's crown 3.6 m above the water (a vinyl sheet on an arched frame over four corner
  posts, the lift's cradle under it): from the air a white rounded roof and its shadow.
- ``port``: a drive-on jet ski port 3.4 m long and 1.7 m wide, moulded black polyethylene
  floating 0.15 m proud: a rim of floats round a cradle whose two rows of keel rollers
  hold the hull out of the water; from the air a dark frame round the jet ski on it.

Every mesh is deterministic, closed (watertight) and re-centred on its bounding box; each face
keeps the sRGB colour of the part it comes from.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import manifold3d as m3
import numpy as np

from ..errors import UserError
from .mesh import ColoredMesh
from .solids import RGB, box_between, ellipsoid, finish, paint

KINDS = ("buoy", "log", "boat", "foam", "dock", "canopy", "port")
#: the kinds that are moorings, drawn beside moored objects instead of as random clutter
MOORINGS = ("dock", "canopy", "port")

# sRGB colours of the parts.
BUOY_RED = (230, 80, 30)
BUOY_WHITE = (240, 240, 235)
STEEL = (55, 55, 58)
BARK = (110, 80, 55)
CUT_WOOD = (170, 140, 100)
HULL = (225, 225, 220)
FLOOR = (90, 95, 100)
THWART = (160, 120, 80)
MOTOR = (60, 60, 62)
FOAM = (235, 235, 230)
DECK = (196, 196, 188)
DOCK_FRAME = (150, 152, 150)
CANOPY = (236, 236, 230)
LIFT_FRAME = (170, 172, 170)
PORT = (38, 39, 42)
ROLLER = (90, 92, 95)

_SEG = 48  # circular segments for large round parts
_SEG_S = 16  # ... for small ones


# --------------------------------------------------------------------------- buoy

BUOY_R = 0.225


def _sphere_cap_height(volume_fraction: float) -> float:
    """Height (in radii) of a sphere cap holding ``volume_fraction`` of the sphere's volume.

    Solves u**2 * (3 - u) / 4 = fraction for u in [0, 2] by bisection.
    """
    lo, hi = 0.0, 2.0
    for _ in range(60):
        mid = (lo + hi) / 2
        lo, hi = (mid, hi) if mid * mid * (3 - mid) / 4 < volume_fraction else (lo, mid)
    return (lo + hi) / 2


def _buoy() -> ColoredMesh:
    """Sphere (centre at z = 0) with a white band above the water and a steel eye on top."""
    colours: dict[int, RGB] = {}
    r = BUOY_R
    ball = paint(m3.Manifold.sphere(r, _SEG), BUOY_RED, colours)
    band = m3.Manifold.sphere(r + 0.004, _SEG) ^ box_between([-1, -1, 0.02], [1, 1, 0.09])
    pad = m3.Manifold.cylinder(0.03, 0.045, 0.04, _SEG_S).translate([0, 0, r - 0.01])
    # the eye: a ring (torus, 35 mm radius, 10 mm bar) standing in the x-z plane on the pad
    ring = (m3.CrossSection.circle(0.010, _SEG_S).translate([0.035, 0]).revolve(_SEG_S * 2)
            .rotate([90, 0, 0]).translate([0, 0, r + 0.055]))
    solid = m3.Manifold.batch_boolean(
        [ball, paint(band, BUOY_WHITE, colours), paint(pad + ring, STEEL, colours)],
        m3.OpType.Add)
    waterline = -r + r * _sphere_cap_height(0.40)
    return finish(solid, colours, waterline, "buoy")


# --------------------------------------------------------------------------- log

LOG_LENGTH = 2.2
# Sections along the axis: x, y and z of the centre, radius (metres). A slight bend and taper.
LOG_SECTIONS = (
    (-1.25, 0.000, 0.000, 0.150),
    (-0.75, 0.012, 0.008, 0.148),
    (-0.25, 0.020, 0.000, 0.145),
    (0.25, 0.012, -0.006, 0.140),
    (0.75, -0.005, 0.004, 0.132),
    (1.25, -0.020, 0.000, 0.122),
)


def _log() -> ColoredMesh:
    """Chain of hulls of spheres along x, sawn off square at x = +-LOG_LENGTH / 2."""
    colours: dict[int, RGB] = {}
    balls = [m3.Manifold.sphere(r, _SEG).translate([x, y, z]) for x, y, z, r in LOG_SECTIONS]
    links = [m3.Manifold.batch_hull([a, b]) for a, b in zip(balls[:-1], balls[1:], strict=True)]
    trunk = paint(m3.Manifold.batch_boolean(links, m3.OpType.Add), BARK, colours)
    half = LOG_LENGTH / 2
    saw = paint(box_between([-half, -1, -1], [half, 1, 1]), CUT_WOOD, colours)
    return finish(trunk ^ saw, colours, 0.0, "log")


# --------------------------------------------------------------------------- boat

BOAT_SEMI_AXES = (1.9, 0.7, 0.5)  # hull ellipsoid: half length, half beam, depth (metres)
BOAT_TRANSOM_X = -1.4
BOAT_WALL = 0.04
BOAT_DRAFT = 0.15


def _boat() -> ColoredMesh:
    """Lower half of an ellipsoid (gunwale at z = 0) cut square at the transom, hollowed by an
    inset ellipsoid, with a floor, two thwarts and an outboard motor on the transom."""
    colours: dict[int, RGB] = {}
    a, b, c = BOAT_SEMI_AXES
    t = BOAT_WALL
    outer = ellipsoid((a, b, c), 64)
    hull = paint(outer ^ box_between([BOAT_TRANSOM_X, -1, -1], [2, 1, 0]), HULL, colours)
    inner = ellipsoid((a - t, b - t, c - t), 64) ^ box_between([BOAT_TRANSOM_X + t, -1, -1],
                                                               [2, 1, 1])
    hull = hull - paint(inner, HULL, colours)
    floor = outer ^ box_between([BOAT_TRANSOM_X, -1, -c], [a, 1, -c + 0.12])
    thwarts = [box_between([x - 0.12, -1, -0.14], [x + 0.12, 1, -0.11]) for x in (-0.9, 0.3)]
    thwarts = outer ^ m3.Manifold.batch_boolean(thwarts, m3.OpType.Add)
    x0 = BOAT_TRANSOM_X
    motor = m3.Manifold.batch_boolean([
        box_between([x0 - 0.26, -0.15, 0.02], [x0 - 0.02, 0.15, 0.34]),  # cowling
        box_between([x0 - 0.06, -0.05, -0.10], [x0, 0.05, 0.05]),  # transom bracket
        box_between([x0 - 0.18, -0.04, -0.55], [x0 - 0.10, 0.04, 0.02]),  # shaft and leg
        box_between([x0 - 0.26, -0.05, -0.55], [x0 - 0.02, 0.05, -0.47]),  # gearcase
    ], m3.OpType.Add)
    solid = m3.Manifold.batch_boolean(
        [hull, paint(floor, FLOOR, colours), paint(thwarts, THWART, colours),
         paint(motor, MOTOR, colours)], m3.OpType.Add)
    return finish(solid, colours, -c + BOAT_DRAFT, "boat")


# --------------------------------------------------------------------------- foam

FOAM_RADIUS = 0.70
FOAM_THICKNESS = 0.025
FOAM_FREEBOARD = 0.010
# (harmonic, relative amplitude, phase in radians) of the outline's radius
FOAM_OUTLINE = ((2, 0.06, 0.4), (3, 0.10, 1.9), (5, 0.06, 0.7), (7, 0.04, 2.8), (11, 0.025, 1.2))


def _noisy_circle(radius: float, harmonics: Sequence[tuple[int, float, float]],
                  n: int = 120) -> np.ndarray:
    """(n, 2) counter-clockwise outline whose radius is ``radius`` times
    (1 + sum of amplitude * cos(harmonic * angle + phase))."""
    theta = np.linspace(0.0, 2 * math.pi, n, endpoint=False)
    rho = np.ones_like(theta)
    for k, amp, phase in harmonics:
        rho += amp * np.cos(k * theta + phase)
    return radius * np.stack([rho * np.cos(theta), rho * np.sin(theta)], axis=1)


def _foam() -> ColoredMesh:
    """An irregular patch with two holes, extruded FOAM_THICKNESS from z = 0 up."""
    colours: dict[int, RGB] = {}
    patch = m3.CrossSection([_noisy_circle(FOAM_RADIUS, FOAM_OUTLINE)])
    for (x, y), r in (((0.30, 0.15), 0.10), ((-0.25, -0.30), 0.07)):
        hole = _noisy_circle(r, ((3, 0.15, 0.3), (5, 0.08, 1.0)), 32) + [x, y]
        patch = patch - m3.CrossSection([hole])
    slab = paint(patch.extrude(FOAM_THICKNESS), FOAM, colours)
    return finish(slab, colours, FOAM_THICKNESS - FOAM_FREEBOARD, "foam")


# --------------------------------------------------------------------------- moorings

DOCK_LENGTH, DOCK_WIDTH, DOCK_DECK = 8.0, 1.5, 0.45  # metres; deck top above the water
DOCK_BOARD, DOCK_GAP = 0.17, 0.02  # boards across the walkway, the gaps between them
CANOPY_LENGTH, CANOPY_WIDTH, CANOPY_CROWN = 7.2, 3.3, 3.6  # metres; crown above the water
CANOPY_RISE = 0.55  # metres from the canopy's eaves to its crown
POST_DEPTH = 1.0  # metres: how far posts reach under the water (their feet do not show)


def _dock() -> ColoredMesh:
    """Boards across two stringers (z = 0 is the water) on five pairs of posts."""
    colours: dict[int, RGB] = {}
    half_l, half_w, top = DOCK_LENGTH / 2, DOCK_WIDTH / 2, DOCK_DECK
    pitch = DOCK_BOARD + DOCK_GAP
    n = int(DOCK_LENGTH // pitch)
    x0 = -n * pitch / 2 + DOCK_GAP / 2
    boards = [box_between([x0 + i * pitch, -half_w, top - 0.03],
                          [x0 + i * pitch + DOCK_BOARD, half_w, top]) for i in range(n)]
    deck = paint(m3.Manifold.batch_boolean(boards, m3.OpType.Add), DECK, colours)
    frame = [box_between([-half_l, s * half_w - 0.06, top - 0.2], [half_l, s * half_w + 0.06,
                                                                  top - 0.03])
             for s in (-1, 1)]
    frame += [box_between([x - 0.06, s * (half_w - 0.1) - 0.06, -POST_DEPTH],
                          [x + 0.06, s * (half_w - 0.1) + 0.06, top - 0.2])
              for x in np.linspace(-half_l + 0.2, half_l - 0.2, 5) for s in (-1, 1)]
    legs = paint(m3.Manifold.batch_boolean(frame, m3.OpType.Add), DOCK_FRAME, colours)
    return finish(m3.Manifold.batch_boolean([deck, legs], m3.OpType.Add), colours, 0.0, "dock")


def _canopy() -> ColoredMesh:
    """An arched shell (a slice of a cylinder along x) on four posts, a cradle of two bunks
    under it (z = 0 is the water)."""
    colours: dict[int, RGB] = {}
    half_l, half_w = CANOPY_LENGTH / 2, CANOPY_WIDTH / 2
    # the arch through the eaves (+-half_w, crown - rise) and the crown (0, crown)
    r = (half_w ** 2 + CANOPY_RISE ** 2) / (2 * CANOPY_RISE)
    axis_z = CANOPY_CROWN - r
    outer = m3.Manifold.cylinder(2 * half_l, r, r, 96).rotate([0, 90, 0]).translate(
        [-half_l, 0, axis_z])
    inner = m3.Manifold.cylinder(2 * half_l + 0.2, r - 0.04, r - 0.04, 96).rotate(
        [0, 90, 0]).translate([-half_l - 0.1, 0, axis_z])
    eaves = CANOPY_CROWN - CANOPY_RISE
    shell = (outer - inner) ^ box_between([-half_l, -half_w, eaves], [half_l, half_w,
                                                                      CANOPY_CROWN + 0.1])
    roof = paint(shell, CANOPY, colours)
    posts = [box_between([sx * (half_l - 0.1) - 0.05, sy * (half_w - 0.1) - 0.05, -POST_DEPTH],
                         [sx * (half_l - 0.1) + 0.05, sy * (half_w - 0.1) + 0.05, eaves + 0.05])
             for sx in (-1, 1) for sy in (-1, 1)]
    posts += [box_between([-half_l + 0.3, s * 0.65 - 0.08, 0.15], [half_l - 0.3, s * 0.65 + 0.08,
                                                                   0.3])
              for s in (-1, 1)]
    posts += [box_between([sx * (half_l - 0.1) - 0.05, -half_w + 0.05, 0.05],
                          [sx * (half_l - 0.1) + 0.05, half_w - 0.05, 0.15]) for sx in (-1, 1)]
    frame = paint(m3.Manifold.batch_boolean(posts, m3.OpType.Add), LIFT_FRAME, colours)
    return finish(roof + frame, colours, 0.0, "canopy")


PORT_LENGTH, PORT_WIDTH, PORT_FREEBOARD = 3.4, 1.7, 0.15  # metres
PORT_DEPTH = 0.25  # metres of float under the water


def _port() -> ColoredMesh:
    """A rim of floats round an open cradle, two rows of keel rollers in it (z = 0 is the
    water)."""
    colours: dict[int, RGB] = {}
    half_l, half_w, top = PORT_LENGTH / 2, PORT_WIDTH / 2, PORT_FREEBOARD
    rim = box_between([-half_l, -half_w, -PORT_DEPTH], [half_l, half_w, top]) - box_between(
        [-half_l + 0.3, -half_w + 0.3, -1.0], [half_l - 0.5, half_w - 0.3, 1.0])
    floor = box_between([-half_l + 0.2, -half_w + 0.2, -PORT_DEPTH],
                        [half_l - 0.4, half_w - 0.2, -0.05])
    body = paint(rim + floor, PORT, colours)
    rollers = [box_between([x - 0.09, s * 0.18 - 0.07, -0.05], [x + 0.09, s * 0.18 + 0.07,
                                                                0.08])
               for x in np.linspace(-half_l + 0.5, half_l - 0.8, 5) for s in (-1, 1)]
    wheels = paint(m3.Manifold.batch_boolean(rollers, m3.OpType.Add), ROLLER, colours)
    return finish(body + wheels, colours, 0.0, "port")


_BUILDERS = {"buoy": _buoy, "log": _log, "boat": _boat, "foam": _foam, "dock": _dock,
             "canopy": _canopy, "port": _port}


def build(kind: str) -> ColoredMesh:
    """Build the clutter mesh ``kind`` (one of :data:`KINDS`).

    Returns a closed :class:`ColoredMesh` in metres (x forward, y port, z up) centred on its
    bounding box, with ``waterline`` at the z where the object floats.

    Raises:
        UserError: ``kind`` is not one of :data:`KINDS`.
    """
    if kind not in _BUILDERS:
        raise UserError(f"unknown clutter kind {kind!r}; choose one of {', '.join(KINDS)}")
    return _BUILDERS[kind]()
