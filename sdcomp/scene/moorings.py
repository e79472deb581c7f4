"""Moored boats and jet skis: a dock beside them, and often a canopied boat lift, as lake
and marina footage shows them (``--moored``).

Real lake photos from the air (Roboflow's aerial-maritime set: 74 photos of a lake from
120 m) hold jet skis and boats mostly at their owners' docks: a walkway on one side, boat
lifts under white canopies beside them, the object parked parallel to both; the object
detector's window around such a box is as much dock and canopy as water. Nothing of the
kind appears in open water, so moorings are not random clutter: :func:`moor` gives each
boat or jet ski, with the config's ``moored`` chance, a dock alongside (either side, the
object anywhere along it), with :data:`CANOPY_CHANCE`, a canopied lift on its other
side, and a jet ski with :data:`PORT_CHANCE` on a drive-on port (a dark float frame that
holds it out of the water). Moored objects lie at rest (no wake, no wave tilt). The
moorings are clutter: never annotated, drawn through the same sprite, light, shadow and
camera stages as any object.

Frames: metres on the sea (x, y), headings in degrees as :class:`~.scene.Placement`'s; a
mooring's rectangle is its mesh's footprint (:mod:`sdcomp.assets.clutter`).
"""

from __future__ import annotations

import functools
import math
from dataclasses import replace

import numpy as np

from ..assets import clutter, sar
from .objects import CLUTTER_PREFIX, footprint_radius, object_kind, visible_hull
from .scene import Placement, Role, Shore, on_land

#: the kinds of objects of interest that are moored
MOORED_KINDS = ("boat", "jetski")
#: chance that a moored object has a canopied lift on the side away from its dock
CANOPY_CHANCE = 0.6
#: chance that a moored jet ski lies on a drive-on port, out of the water
PORT_CHANCE = 0.5
PORT_CLEARANCE = 0.08  # metres from the water up to the keel of a jet ski on its port
GAP = (0.1, 0.5)  # metres of water between an object's side and the dock or lift beside it
#: half length and half width (metres) of each mooring's footprint
HALF_SIZE = {"dock": (clutter.DOCK_LENGTH / 2, clutter.DOCK_WIDTH / 2),
             "canopy": (clutter.CANOPY_LENGTH / 2, clutter.CANOPY_WIDTH / 2),
             "port": (clutter.PORT_LENGTH / 2, clutter.PORT_WIDTH / 2)}
#: the asset keys the moorings are drawn from
ASSETS = tuple(CLUTTER_PREFIX + name for name in clutter.MOORINGS)


def half_beam(asset: str) -> float:
    """Metres: the largest |y| of the visible hull of the object drawn from ``asset``."""
    return float(np.abs(visible_hull(asset)[:, 1]).max())


@functools.cache
def keel_depth(asset: str) -> float:
    """Metres from the waterline down to the lowest point of the variant ``asset``."""
    parsed = sar.parse_name(asset.removeprefix(CLUTTER_PREFIX))
    if parsed is None:
        return 0.0
    mesh = sar.build(*parsed)
    return float(mesh.waterline - mesh.vertices[:, 2].min())


def _world(p: Placement, along: float, across: float) -> tuple[float, float]:
    """(x, y) metres of the point ``along`` (body x) and ``across`` (body y) of ``p``."""
    h = math.radians(p.heading)
    c, s = math.cos(h), math.sin(h)
    return p.x + along * c - across * s, p.y + along * s + across * c


def clear(x: float, y: float, heading: float, half: tuple[float, float],
          discs: list[tuple[float, float, float]]) -> bool:
    """Whether the rectangle of half sides ``half`` (along, across metres) centred on
    (``x``, ``y``) and turned by ``heading`` degrees overlaps none of ``discs``
    ((x, y, radius) metres)."""
    h = math.radians(heading)
    c, s = math.cos(h), math.sin(h)
    for dx, dy, r in discs:
        u, v = (dx - x) * c + (dy - y) * s, -(dx - x) * s + (dy - y) * c
        nu, nv = max(abs(u) - half[0], 0.0), max(abs(v) - half[1], 0.0)
        if nu * nu + nv * nv < r * r:
            return False
    return True


Rect = tuple[float, float, float, tuple[float, float]]  # x, y, heading, half sides


def _corners(rect: Rect) -> np.ndarray:
    """(4, 2) metres: the corners of ``rect``."""
    x, y, heading, (a, b) = rect
    h = math.radians(heading)
    axes = np.array([[math.cos(h), math.sin(h)], [-math.sin(h), math.cos(h)]])
    signs = np.array([[1, 1], [1, -1], [-1, -1], [-1, 1]], float) * (a, b)
    return np.array([x, y]) + signs @ axes


def overlap(r1: Rect, r2: Rect) -> bool:
    """Whether two turned rectangles overlap (no separating axis among their sides')."""
    c1, c2 = _corners(r1), _corners(r2)
    for heading in (r1[2], r2[2]):
        h = math.radians(heading)
        for axis in ((math.cos(h), math.sin(h)), (-math.sin(h), math.cos(h))):
            p1, p2 = c1 @ axis, c2 @ axis
            if p1.max() <= p2.min() or p2.max() <= p1.min():
                return False
    return True


def moor(rng: np.random.Generator, moored: float, placements: tuple[Placement, ...],
         shore: Shore | None = None) -> tuple[Placement, ...]:
    """``placements`` with each boat and jet ski moored with chance ``moored``: at rest,
    level, with a dock beside it, perhaps a canopied lift on its other side and, for a jet
    ski, a drive-on port under it that holds it out of the water (clutter placements
    appended after all the others). A mooring that would overlap another object's disc
    (:func:`~.objects.footprint_radius`), another mooring or land is left out.

    Draws from ``rng`` (a stream of its own) six numbers per boat or jet ski, whatever is
    moored, so one object's draws never shift another's."""
    if moored <= 0:
        return placements
    out = list(placements)
    discs = [(p.x, p.y, footprint_radius(p.asset)) for p in placements
             if p.asset.removeprefix(CLUTTER_PREFIX) != "foam"]
    added: list[Placement] = []
    rects: list[Rect] = []
    for i, p in enumerate(placements):
        if p.role is not Role.OBJECT or object_kind(p.asset) not in MOORED_KINDS:
            continue
        chance, side, shift, gap, canopy, port = rng.random(6)
        if chance >= moored:
            continue
        others = [d for j, d in enumerate(discs) if j != i]
        sign = 1.0 if side < 0.5 else -1.0
        on_port = object_kind(p.asset) == "jetski" and port < PORT_CHANCE
        beam = max(half_beam(p.asset), HALF_SIZE["port"][1] if on_port else 0.0)
        wide = GAP[0] + (GAP[1] - GAP[0]) * gap
        draft = p.draft
        for kind, across, along in (
                ("port", 0.0, 0.0),
                ("dock", sign * (beam + wide + HALF_SIZE["dock"][1]), (shift - 0.5) * 4.0),
                ("canopy", -sign * (beam + wide + HALF_SIZE["canopy"][1]), 0.0)):
            if (kind == "port" and not on_port) or (kind == "canopy"
                                                    and canopy >= CANOPY_CHANCE):
                continue
            x, y = _world(p, along, across)
            rect = (x, y, p.heading, HALF_SIZE[kind])
            if (not clear(x, y, p.heading, HALF_SIZE[kind], others) or on_land(shore, x, y)
                    or any(overlap(rect, r) for r in rects)):
                continue
            added.append(Placement(Role.CLUTTER, CLUTTER_PREFIX + kind, 0, x, y, p.heading,
                                   0.0, 0.0, 0.0))
            rects.append(rect)
            if kind == "port":  # on its rollers, out of the water
                draft = -(keel_depth(p.asset) + PORT_CLEARANCE)
        out[i] = replace(p, roll=0.0, pitch=0.0, speed=0.0, draft=draft)
    return tuple(out + added)
