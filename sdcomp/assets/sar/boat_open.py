"""Open boats: rowing boats (with oars and a rower) and paddle craft (kayaks, sit-on-tops,
canoes, with their paddlers), built from the parameters :func:`sdcomp.assets.sar.boat.draw`
draws; and the seated people aboard.

Each builder takes (params, painter) and returns (the painted solid, z of the waterline),
in metres: x forward, y port, z up, keel amidships at z = 0.
"""

from __future__ import annotations

import math

import manifold3d as m3
import numpy as np

from ..flotation import waterline_for_mass
from ..solids import (
    Painter,
    box_between,
    capsule,
    ellipse_points,
    extrude_z,
    polygon,
    union,
)
from . import palette
from .hull import HullSpec, hull_solid, interior, plan_inset, usable_span
from .person import Body, Outfit, Pose, build_person

# --------------------------------------------------------------------------- rowing boat

def rowing(params: dict, p: Painter) -> tuple[m3.Manifold, float]:
    """The rowing boat of ``params``: (painted solid, waterline z)."""
    c = params["colours"]
    L, B, D = params["length"], params["beam"], params["depth"]
    shape = params["shape"]
    spec = HullSpec(L, B, D, shape, 12.0, transom=0.6, max_at=0.5, sheer_bow=0.12,
                    sheer_stern=0.04, bow_rise=0.55, forefoot=0.5, fullness=2.6, chine=0.8)
    outer = hull_solid(spec)
    wl = waterline_for_mass(outer, params["mass"] + 80 * len(params["people"]))
    wall = 0.025
    u0, u1 = usable_span(spec, 0.05, wall / L, 1.0)
    hollow = interior(spec, wall, 0.06, u0, min(u1, 0.97))
    solid = p.paint(outer, c["hull"]) - p.paint(hollow, c["inside"])
    extra = []
    for u in (0.2, 0.52, 0.8)[: 2 + (L > 3.4)]:
        b = spec.half_beam(u)
        x = spec.x(u)
        z = D - 0.18
        thwart = box_between((x - 0.11, -b, z - 0.025), (x + 0.11, b, z + 0.01))
        extra.append(p.paint(thwart ^ outer, c["thwart"]))
    seat_x = spec.x(0.52)
    lock_x, lock_z = seat_x + 0.28, spec.sheer(0.55) + 0.06
    lock_b = spec.half_beam(0.55)
    oar_len = 2.0 + 0.3 * B
    handles = [(seat_x - 0.35, s * 0.22, lock_z + 0.12) for s in (1, -1)]
    if params["oars"] == "out":  # in the rowlocks, blades out on the water
        for (hx, hy, hz), s in zip(handles, (1, -1), strict=True):
            h = np.array([hx, hy, hz])
            lock = np.array([lock_x, s * lock_b, lock_z])
            d = (lock - h) / np.linalg.norm(lock - h)
            tip = h + d * oar_len
            tip[2] = min(tip[2], 0.25)  # blades at the water
            extra.append(p.paint(_oar(h, tip), c["oar"]))
    elif params["oars"] == "in":  # shipped along the thwarts
        for s in (1, -1):
            extra.append(p.paint(_oar((spec.x(0.85), s * 0.18, D - 0.13),
                                      (spec.x(0.85) - oar_len, s * 0.25, D - 0.13)), c["oar"]))
    solid = union([solid, *extra])
    if params["people"]:
        person = params["people"][0]
        grips = handles if params["oars"] == "out" else [
            (seat_x - 0.3, s * 0.2, D) for s in (1, -1)]
        solid = union([solid, seated(p, person, (seat_x, 0.0, D - 0.17), grips,
                                      facing=-1)])
    return solid, wl


def _oar(inner, tip) -> m3.Manifold:
    """An oar from the handle end ``inner`` to the blade tip ``tip``: shaft and flat blade."""
    a, b = np.asarray(inner, float), np.asarray(tip, float)
    d = (b - a) / np.linalg.norm(b - a)
    shaft = capsule(a, b - 0.5 * d, 0.022, 0.022, 6)
    blade = capsule(b - 0.55 * d, b, 0.03, 0.03, 6).scale([1, 1, 1])
    flat = m3.Manifold.hull_points(np.concatenate([
        np.array([b - 0.55 * d + [0, 0, 0.07], b - 0.55 * d - [0, 0, 0.07],
                  b + [0, 0, 0.08], b - [0, 0, 0.08]]) + [0.01, 0, 0],
        np.array([b - 0.55 * d + [0, 0, 0.07], b - 0.55 * d - [0, 0, 0.07],
                  b + [0, 0, 0.08], b - [0, 0, 0.08]]) - [0.01, 0, 0]]).tolist())
    return union([shaft, blade, flat])


# --------------------------------------------------------------------------- kayak / canoe

def paddle(params: dict, p: Painter) -> tuple[m3.Manifold, float]:
    """The kayak or canoe of ``params``: (painted solid, waterline z)."""
    c = params["colours"]
    L, B, D = params["length"], params["beam"], params["depth"]
    craft = params["craft"]
    canoe = craft == "canoe"
    spec = HullSpec(L, B, D, "round", transom=0.02, max_at=0.5, sheer_bow=0.12 if canoe else 0.02,
                    sheer_stern=0.12 if canoe else 0.0, bow_rise=0.75 if canoe else 0.5,
                    stern_rise=0.75 if canoe else 0.45, forefoot=0.62,
                    fullness=2.6 if canoe else 2.2)
    outer = hull_solid(spec, n=20)
    wl = waterline_for_mass(outer, params["mass"])
    solid = p.paint(outer, c["hull"])
    extra = []
    seats = []
    if canoe:
        u0, u1 = usable_span(spec, 0.06, 0.02, 0.98)
        solid = solid - p.paint(interior(spec, 0.02, 0.03, u0, u1, n=16), c["hull"])
        for u in (0.2, 0.5, 0.8):
            b = spec.half_beam(u)
            x = spec.x(u)
            thwart = box_between((x - 0.05, -b, D - 0.07), (x + 0.05, b, D - 0.03))
            extra.append(p.paint(thwart ^ outer, c["thwart"]))
        seats = [(spec.x(0.22), 0.0, D - 0.1), (spec.x(0.75), 0.0, D - 0.1)]
    else:
        xc = spec.x(0.45)
        if craft == "sit_in":
            deck = plan_inset(spec, 0.0, 0.0, 1.0, D - 0.01, D + 0.06, n=16, taper=0.07)
            solid = union([solid, p.paint(deck ^ outer.scale([1, 1, 1.2]), c["hull"])])
            hole = extrude_z(polygon(ellipse_points(0.42, 0.22, 16) + [xc, 0]), 0.08, D + 0.5)
            rim = extrude_z(polygon(ellipse_points(0.46, 0.26, 16) + [xc, 0]), D - 0.05, D + 0.1)
            solid = union([solid, p.paint(rim, palette.BLACK)]) - p.paint(hole, c["cockpit"])
        else:
            well = plan_inset(spec, 0.08, 0.3, 0.62, D - 0.12, D + 0.5, n=8)
            darker = [round(v * 0.72) for v in c["hull"]]
            solid = solid - p.paint(well, darker)
            backrest = box_between((xc - 0.45, -0.2, D - 0.13), (xc - 0.35, 0.2, D + 0.15))
            extra.append(p.paint(backrest, palette.BLACK))
        seats = [(xc - 0.1, 0.0, D - 0.22 if craft == "sit_in" else D - 0.1)]
    people = params["people"][: len(seats)]
    for k, person in enumerate(people):
        seat = seats[k]
        paddle_kind = "single" if canoe else "double"
        solid_p = seated(p, person, seat, None, facing=1,
                          paddle=(paddle_kind, c["paddle"], k))
        extra.append(solid_p)
    return union([solid, *extra]), wl


# --------------------------------------------------------------------------- people aboard

def seated(p: Painter, person: dict, seat, grips, facing: int,
            paddle=None) -> m3.Manifold:
    """A seated person on ``seat`` (x, y, z of the buttocks, metres) facing +x (``facing`` 1)
    or -x (-1), hands on ``grips`` (object frame) or holding a paddle."""
    s = person["stature"]
    body = Body(stature=s, shoulders=0.235 * s, hips=0.2 * s)
    skin = tuple(person["skin"])
    shirt, trousers = tuple(person["shirt"]), tuple(person["trousers"])
    outfit = Outfit(skin=skin, chest=shirt, hips=trousers, upper_arm=shirt, forearm=skin,
                    hand=skin, thigh=trousers, shin=trousers, foot=palette.BLACK, neck=skin,
                    hair=tuple(person["hat"] or person["hair"]),
                    hair_style="cap" if person["hat"] else "short",
                    vest=None if person["vest"] is None else tuple(person["vest"]))
    sx, sy, sz = seat
    hip_z = 0.09  # hip joints above the seat
    local_seat = np.array([sx, sy, sz + hip_z])
    lean = 12.0

    def to_local(pt):
        q = (np.asarray(pt, float) - local_seat) * [facing, facing, 1]
        c, s_ = math.cos(math.radians(-lean)), math.sin(math.radians(-lean))
        return np.array([c * q[0] + s_ * q[2], q[1], -s_ * q[0] + c * q[2]])

    leg_dirs = (((0.97, 0.12, 0.1), (0.97, 0.03, -0.2)), ((0.97, -0.12, 0.1), (0.97, -0.03, -0.2)))
    extra_local = []
    targets: tuple = (None, None)
    if grips is not None:
        targets = (to_local(grips[0]), to_local(grips[1]))
    elif paddle is not None:
        kind, colour, k = paddle
        shoulder_z = 0.288 * s
        hand_l = np.array([0.42, 0.30, shoulder_z - 0.12])
        hand_r = np.array([0.38, -0.30, shoulder_z - 0.05])
        if kind == "single":
            hand_l = np.array([0.40, 0.25, shoulder_z + 0.05])
            hand_r = np.array([0.42, 0.30, shoulder_z - 0.35])
        targets = (hand_l, hand_r)
        extra_local.append(p.paint(_paddle_tool(kind, hand_l, hand_r), colour))
    pose = Pose(legs=leg_dirs, feet=((0.2, 0.1, 1.0), (0.2, -0.1, 1.0)), pitch=lean,
                hand_targets=targets, elbow_pole=((0.0, 1.0, -1.0), (0.0, -1.0, -1.0)))
    solid, _ = build_person(p, body, pose, outfit, extra_local=extra_local)
    if facing < 0:
        solid = solid.rotate([0, 0, 180])
    return solid.translate(local_seat.tolist())


def _paddle_tool(kind: str, hand_l, hand_r) -> m3.Manifold:
    """A kayak paddle (two blades) or a canoe paddle (one blade) through the two hands."""
    a, b = np.asarray(hand_l, float), np.asarray(hand_r, float)
    d = (b - a) / np.linalg.norm(b - a)
    if kind == "double":
        p0, p1 = a - 0.65 * d, b + 0.65 * d
        shaft = capsule(p0, p1, 0.016, 0.016, 6)
        blades = [capsule(q - 0.2 * dd, q + 0.12 * dd, 0.05, 0.05, 6).scale([1, 1, 1])
                  for q, dd in ((p0, -d), (p1, d))]
        return union([shaft, *blades])
    p0, p1 = a - 0.05 * d, b + 0.75 * d
    shaft = capsule(p0, p1, 0.016, 0.016, 6)
    blade = capsule(p1 - 0.15 * d, p1 + 0.35 * d, 0.07, 0.06, 6)
    return union([shaft, blade])

