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
holds it out of the water) and with :data:`PAIR_CHANCE` the image's next jet ski moved
alongside it. Where the image has a shore within :data:`SHORE_REACH` of the object, the
dock runs out from it (its root :data:`ROOT` metres on the land, the object alongside it,
bow to the shore), as the photos' docks do, when the object stays in view there. Moored
objects lie at rest (no wake, no wave tilt). The moorings are
clutter: never annotated, drawn through the same sprite, light, shadow and camera stages
as any object.

Frames: metres on the sea (x, y), headings in degrees as :class:`~.scene.Placement`'s; a
mooring's rectangle is its mesh's footprint (:mod:`sdcomp.assets.clutter`).
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from ..assets import clutter
from .camera import CameraModel, CameraPose, project
from .objects import CLUTTER_PREFIX, footprint_radius, keel_depth, object_kind, visible_hull
from .scene import Placement, Role, Shore, on_land

#: the kinds of objects of interest that are moored
MOORED_KINDS = ("boat", "jetski")
#: chance that a moored object has a canopied lift on the side away from its dock
CANOPY_CHANCE = 0.6
#: chance that a moored jet ski lies on a drive-on port, out of the water
PORT_CHANCE = 0.5
#: chance that a moored jet ski has the image's next jet ski moored beside it
PAIR_CHANCE = 0.5
PORT_CLEARANCE = 0.08  # metres from the water up to the keel of a jet ski on its port
GAP = (0.1, 0.5)  # metres of water between an object's side and the dock or lift beside it
SHORE_REACH = 25.0  # metres from the coast within which a moored object's dock is rooted
ROOT = 0.8  # metres of a rooted dock on the land
#: half length and half width (metres) of each mooring's footprint
HALF_SIZE = {"dock": (clutter.DOCK_LENGTH / 2, clutter.DOCK_WIDTH / 2),
             "canopy": (clutter.CANOPY_LENGTH / 2, clutter.CANOPY_WIDTH / 2),
             "port": (clutter.PORT_LENGTH / 2, clutter.PORT_WIDTH / 2)}
#: the asset keys the moorings are drawn from
ASSETS = tuple(CLUTTER_PREFIX + name for name in clutter.MOORINGS)


def half_beam(asset: str) -> float:
    """Metres: the largest |y| of the visible hull of the object drawn from ``asset``."""
    return float(np.abs(visible_hull(asset)[:, 1]).max())


def half_length(asset: str) -> float:
    """Metres: the largest |x| of the visible hull of the object drawn from ``asset``."""
    return float(np.abs(visible_hull(asset)[:, 0]).max())


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


def _beam(asset: str, on_port: bool) -> float:
    """Metres from the centre line of a moored ``asset`` to its side, or its port's."""
    return max(half_beam(asset), HALF_SIZE["port"][1] if on_port else 0.0)


def _neighbour(placements: tuple[Placement, ...], i: int, done: set[int]) -> int | None:
    """The index of the first jet ski after ``i`` among ``placements`` not yet moored."""
    return next((k for k, q in enumerate(placements) if k > i and k not in done
                 and q.role is Role.OBJECT and object_kind(q.asset) == "jetski"), None)


def in_view(model: CameraModel, pose: CameraPose, x: float, y: float) -> bool:
    """Whether the sea point (x, y) metres is inside the image of ``model`` at ``pose``."""
    uv, depth = project(model, pose, np.array([[x, y, 0.0]]))
    u, v = uv[0]
    return bool(depth[0] > 0 and 0 <= u < model.width and 0 <= v < model.height)


def _at_shore(p: Placement, shore: Shore, shift: float, dock_across: float, others: list,
              rects: list[Rect], view: tuple[CameraModel, CameraPose] | None
              ) -> tuple[Placement, float] | None:
    """``p`` moved beside a dock rooted on the coast of ``shore`` (bow to the land, the
    dock ``dock_across`` metres to its side, along the coast's normal, its root
    :data:`ROOT` past the coast there; the object ``shift`` (0-1) of the way out along
    it) and the dock's centre along the moved object (metres); None when ``p`` lies over
    :data:`SHORE_REACH` from the coast, or would leave the ``view`` ((model, pose)), touch
    ``others`` ((x, y, radius) discs), the moorings placed (``rects``) or the land."""
    along, off = (float(v) for v in shore.local(p.x, p.y))
    coast = float(shore.coast(along))
    if coast - off > SHORE_REACH:
        return None
    # bow to the land, the object's body y runs along the coast: the dock's place on it
    root = float(shore.coast(along + dock_across)) + ROOT
    length = half_length(p.asset)
    room = max(clutter.DOCK_LENGTH - ROOT - 2 * length - 1.0, 0.0)
    across = min(coast, root - ROOT) - (0.5 + length + room * shift)  # the object's centre
    x, y = shore.sea(along, across)
    q = replace(p, x=x, y=y, heading=shore.angle)
    bow, stern = _world(q, length, 0.0), _world(q, -length, 0.0)
    seen = view is None or in_view(view[0], view[1], x, y)
    body = (x, y, q.heading, (length, half_beam(p.asset)))
    if not seen or on_land(shore, *bow) or on_land(shore, *stern) or not clear(
            *body, others) or any(overlap(body, r) for r in rects):
        return None
    return q, root - clutter.DOCK_LENGTH / 2 - across


def _dock_place(p: Placement, shore: Shore | None, shift: float, dock_across: float,
                others: list, rects: list[Rect], view: tuple[CameraModel, CameraPose] | None
                ) -> tuple[Placement, float]:
    """(the moored object, its dock's centre along it, metres): beside a dock rooted on
    the shore where :func:`_at_shore` finds room, else where it is, the dock ``shift``
    (0-1) of 4 m along it."""
    rooted = None if shore is None else _at_shore(p, shore, shift, dock_across, others,
                                                  rects, view)
    return rooted if rooted is not None else (p, (shift - 0.5) * 4.0)


def moor(rng: np.random.Generator, moored: float, placements: tuple[Placement, ...],
         shore: Shore | None = None,
         view: tuple[CameraModel, CameraPose] | None = None) -> tuple[Placement, ...]:
    """``placements`` with each boat and jet ski moored with chance ``moored``: at rest,
    level, with a dock beside it, perhaps a canopied lift on its other side and, for a jet
    ski, a drive-on port under it that holds it out of the water, and on half of them the
    image's next jet ski moved alongside, on the side away from the dock (clutter
    placements appended after all the others). A mooring or neighbour that would overlap
    another object's disc (:func:`~.objects.footprint_radius`), another mooring or land is
    left out. Near a ``shore``, the object moves beside a dock rooted on it
    (:func:`_at_shore`) where it stays in ``view`` ((model, pose) of the image).

    Draws from ``rng`` (a stream of its own) seven numbers per boat or jet ski, whatever
    is moored, so one object's draws never shift another's."""
    if moored <= 0:
        return placements
    out = list(placements)
    discs = {i: (p.x, p.y, footprint_radius(p.asset)) for i, p in enumerate(placements)
             if p.asset.removeprefix(CLUTTER_PREFIX) != "foam"}
    added: list[Placement] = []
    rects: list[Rect] = []
    done: set[int] = set()
    for i, p in enumerate(placements):
        if p.role is not Role.OBJECT or object_kind(p.asset) not in MOORED_KINDS:
            continue
        chance, side, shift, gap, canopy, port, pair = rng.random(7)
        if chance >= moored or i in done:
            continue
        done.add(i)
        sign = 1.0 if side < 0.5 else -1.0
        on_port = object_kind(p.asset) == "jetski" and port < PORT_CHANCE
        beam = _beam(p.asset, on_port)
        wide = GAP[0] + (GAP[1] - GAP[0]) * gap
        dock_across = sign * (beam + wide + HALF_SIZE["dock"][1])
        p, dock_along = _dock_place(p, shore, shift, dock_across,
                                    [d for k, d in discs.items() if k != i], rects, view)
        discs[i] = (p.x, p.y, discs[i][2])
        group = [(i, p)]
        far = -sign * beam  # the group's side away from the dock, across the first
        j = _neighbour(placements, i, done) if (object_kind(p.asset) == "jetski"
                                                and pair < PAIR_CHANCE) else None
        if j is not None:
            q, side_j = placements[j], _beam(placements[j].asset, on_port)
            x, y = _world(p, 0.0, far - sign * (wide + side_j))
            rest = [d for k, d in discs.items() if k not in (i, j)]
            rect = (x, y, p.heading, (half_length(q.asset), side_j))
            if (clear(x, y, p.heading, rect[3], rest) and not on_land(shore, x, y)
                    and not any(overlap(rect, r) for r in rects)):
                group.append((j, replace(q, x=x, y=y, heading=p.heading)))
                discs[j] = (x, y, discs[j][2])
                done.add(j)
                far -= sign * (wide + 2 * side_j)
        others = [d for k, d in discs.items() if k not in {g for g, _ in group}]
        spots = [("port", q, 0.0, 0.0) for _, q in group if on_port]
        spots += [("dock", p, dock_across, dock_along)]
        if canopy < CANOPY_CHANCE:
            spots += [("canopy", p, far - sign * (wide + HALF_SIZE["canopy"][1]), 0.0)]
        raised: set[int] = set()  # the ids of the group's placements on a port
        for kind, at, across, along in spots:
            x, y = _world(at, along, across)
            rect = (x, y, p.heading, HALF_SIZE[kind])
            if (not clear(x, y, p.heading, HALF_SIZE[kind], others) or on_land(shore, x, y)
                    or any(overlap(rect, r) for r in rects)):
                continue
            added.append(Placement(Role.CLUTTER, CLUTTER_PREFIX + kind, 0, x, y, p.heading,
                                   0.0, 0.0, 0.0))
            rects.append(rect)
            if kind == "port":  # on its rollers, out of the water
                raised.add(id(at))
        for k, q in group:
            draft = -(keel_depth(q.asset) + PORT_CLEARANCE) if id(q) in raised else q.draft
            out[k] = replace(q, roll=0.0, pitch=0.0, speed=0.0, draft=draft)
    return tuple(out + added)
