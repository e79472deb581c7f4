"""A parameterised human body from capsules and ellipsoids: swimmers, riders, paddlers.

The body is built in a *local* frame (metres): origin between the hip joints, z up the spine,
x out of the chest, y to the body's left. A :class:`Pose` gives the direction of every limb
segment in that frame (or hand targets solved by two-bone IK), the head's tilt and turn, and
the rotation that takes the local frame to the object frame (x forward, y port, z up), e.g.
pitch 90 degrees lays the body face down with the head towards +x.

Segment lengths follow Drillis & Contini's proportions of stature (Winter, *Biomechanics and
Motor Control of Human Movement*, 4th ed., 2009, fig. 4.1); breadths follow ANSUR II (Gordon
et al. 2014, NATICK/TR-15/007); see :mod:`sdcomp.assets.sar.dimensions`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import manifold3d as m3
import numpy as np

from ..solids import RGB, Painter, capsule, ellipsoid, hull, place, union
from .common import SEG_S, SEG_XS

# Segment lengths as fractions of stature (Drillis & Contini via Winter 2009).
UPPER_ARM = 0.186
FOREARM = 0.146
HAND = 0.108
THIGH = 0.245
SHANK = 0.246
FOOT = 0.152
SHOULDER_Z = 0.288  # shoulder joint above the hip joints (0.818 - 0.530)
CHIN_Z = 0.340  # chin above the hip joints (0.870 - 0.530)
HEAD_H = 0.130  # chin to vertex


@dataclass(frozen=True)
class Body:
    """Anthropometry of one person (metres; ``girth`` scales limb and trunk radii)."""

    stature: float = 1.75
    shoulders: float = 0.40  # biacromial breadth
    hips: float = 0.34  # bitrochanteric breadth
    head_breadth: float = 0.155
    head_length: float = 0.195
    girth: float = 1.0


@dataclass(frozen=True)
class Pose:
    """Limb directions (unit-ish vectors, local frame) and body orientation (degrees).

    ``arms``/``legs``: ((upper, lower), ...) for the left then the right side; an arm may
    instead be a hand target point (local frame, metres) given in ``hand_targets``.
    ``pitch`` tips the body forward about y (90 = face down, head to +x); ``roll`` then turns
    it about the object's x; ``flip`` yaws it 180 degrees first (for lying on the back).
    """

    arms: tuple = (((0, 1, 0), (0, 1, 0)), ((0, -1, 0), (0, -1, 0)))
    legs: tuple = (((0, 0.1, -1), (0, 0, -1)), ((0, -0.1, -1), (0, 0, -1)))
    feet: tuple = ((0.3, 0, -1), (0.3, 0, -1))
    head_pitch: float = 0.0  # + looks down (chin to chest)
    head_yaw: float = 0.0  # + turns the face to the left
    pitch: float = 0.0
    roll: float = 0.0
    flip: bool = False
    hand_targets: tuple = (None, None)
    elbow_pole: tuple = ((0, 1, -0.3), (0, -1, -0.3))
    knee_targets: tuple = (None, None)


@dataclass
class Outfit:
    """sRGB colour of every body part, plus hair and a life vest (None where absent)."""

    skin: RGB
    chest: RGB
    hips: RGB
    upper_arm: RGB
    forearm: RGB
    hand: RGB
    thigh: RGB
    shin: RGB
    foot: RGB
    neck: RGB
    hair: RGB | None = None
    hair_style: str = "short"  # short, long, bald, cap, helmet
    vest: RGB | None = None
    vest_style: str = "foam"  # foam (jacket) or yoke (inflated collar)


def _unit(v) -> np.ndarray:
    v = np.asarray(v, dtype=float)
    return v / np.linalg.norm(v)


def rot_x(deg: float) -> np.ndarray:
    a = math.radians(deg)
    return np.array([[1, 0, 0], [0, math.cos(a), -math.sin(a)], [0, math.sin(a), math.cos(a)]])


def rot_y(deg: float) -> np.ndarray:
    a = math.radians(deg)
    return np.array([[math.cos(a), 0, math.sin(a)], [0, 1, 0], [-math.sin(a), 0, math.cos(a)]])


def rot_z(deg: float) -> np.ndarray:
    a = math.radians(deg)
    return np.array([[math.cos(a), -math.sin(a), 0], [math.sin(a), math.cos(a), 0], [0, 0, 1]])


def body_rotation(pose: Pose) -> np.ndarray:
    """(3, 3) rotation from the local body frame to the object frame."""
    r = rot_y(pose.pitch)
    if pose.flip:
        r = rot_z(180.0) @ r
    return rot_x(pose.roll) @ r


def two_bone(root, target, l1: float, l2: float, pole) -> np.ndarray:
    """Middle joint (elbow/knee) of a two-segment limb from ``root`` reaching ``target``,
    bending towards ``pole`` (a direction); the target is pulled in if out of reach."""
    root, target = np.asarray(root, float), np.asarray(target, float)
    d = target - root
    dist = float(np.clip(np.linalg.norm(d), abs(l1 - l2) + 1e-3, l1 + l2 - 1e-3))
    u = d / np.linalg.norm(d)
    pole = np.asarray(pole, float)
    w = pole - np.dot(pole, u) * u
    w = _unit(w) if np.linalg.norm(w) > 1e-6 else _unit(np.cross(u, [0, 0, 1]))
    a = (l1 * l1 - l2 * l2 + dist * dist) / (2 * dist)
    h = math.sqrt(max(l1 * l1 - a * a, 0.0))
    return root + a * u + h * w


def skeleton(body: Body, pose: Pose) -> dict[str, np.ndarray]:
    """Joint positions (local frame, metres) of ``body`` in ``pose``."""
    s = body.stature
    j: dict[str, np.ndarray] = {"pelvis": np.zeros(3)}
    j["neck"] = np.array([0.0, 0.0, SHOULDER_Z * s + 0.02])
    j["chin"] = np.array([0.02 * s, 0.0, CHIN_Z * s])
    for k, side in enumerate((1, -1)):
        tag = "l" if side > 0 else "r"
        sh = np.array([0.0, side * (body.shoulders / 2 - 0.035), SHOULDER_Z * s])
        j[f"shoulder_{tag}"] = sh
        target = pose.hand_targets[k]
        if target is not None:
            wrist = np.asarray(target, float)
            elbow = two_bone(sh, wrist, UPPER_ARM * s, FOREARM * s, pose.elbow_pole[k])
            hand_dir = _unit(wrist - elbow)
        else:
            up, low = pose.arms[k]
            elbow = sh + UPPER_ARM * s * _unit(up)
            wrist = elbow + FOREARM * s * _unit(low)
            hand_dir = _unit(low)
        j[f"elbow_{tag}"], j[f"wrist_{tag}"] = elbow, wrist
        j[f"hand_{tag}"] = wrist + 0.75 * HAND * s * hand_dir
        hip = np.array([0.0, side * (body.hips / 2 - 0.07), 0.0])
        j[f"hip_{tag}"] = hip
        thigh, shank = pose.legs[k]
        knee = hip + THIGH * s * _unit(thigh)
        ankle = knee + SHANK * s * _unit(shank)
        j[f"knee_{tag}"], j[f"ankle_{tag}"] = knee, ankle
        j[f"toe_{tag}"] = ankle + 0.8 * FOOT * s * _unit(pose.feet[k])
    return j


def _head(p: Painter, body: Body, pose: Pose, outfit: Outfit, neck_top: np.ndarray):
    """Head, nose and hair/cap, tilted and turned about the top of the neck."""
    s = body.stature
    a, b, c = body.head_length / 2, body.head_breadth / 2, HEAD_H * s / 2
    rot = rot_z(pose.head_yaw) @ rot_y(pose.head_pitch)
    centre = neck_top + rot @ np.array([0.012, 0.0, c * 0.85])
    unit = m3.Manifold.sphere(1.0, SEG_S)
    skull = place(unit.scale([a, b, c]), rot, centre)
    nose = place(unit.scale([0.02, 0.014, 0.025]), rot, centre + rot @ [a * 0.95, 0, -c * 0.15])
    parts = [p.paint(skull + nose, outfit.skin)]
    style = outfit.hair_style
    if style != "bald" and outfit.hair is not None:
        grow = {"cap": 1.07, "helmet": 1.35}.get(style, 1.05)
        shell = place(unit.scale([a * grow, b * grow, c * grow]), rot, centre)
        # keep what lies above a plane rising towards the forehead: top and back of the head
        tilt = {"cap": 30.0, "helmet": 20.0}.get(style, 38.0)
        low = {"cap": -0.20, "helmet": -0.35}.get(style, 0.05)
        cut = place(m3.Manifold.cube([4 * a, 4 * b, 4 * c], center=True)
                    .translate([0, 0, 2 * c + low * c]).rotate([0, -tilt, 0]), rot, centre)
        hair = shell ^ cut
        if style == "long":
            tail = place(unit.scale([a * 0.55, b * 0.9, c * 0.9]), rot,
                         centre + rot @ [-a * 0.75, 0, -c * 0.55])
            hair = hair + tail
        parts.append(p.paint(hair, outfit.hair))
    return parts


def _torso(p: Painter, body: Body, outfit: Outfit) -> list[m3.Manifold]:
    """Chest (shoulders to waist) and hips (waist to crotch) as hulls of ellipsoids."""
    s, g = body.stature, body.girth
    half_sh = body.shoulders / 2
    sz = SHOULDER_Z * s
    chest = hull([
        ellipsoid((0.07 * g, half_sh - 0.015, 0.05), SEG_S, (0.0, 0.0, sz - 0.01)),
        ellipsoid((0.11 * g, half_sh * 0.78 * g, 0.09), SEG_S, (0.015, 0.0, sz - 0.12)),
        ellipsoid((0.095 * g, body.hips / 2 * 0.82 * g, 0.06), SEG_S, (0.005, 0.0, 0.16 * s * 0.6)),
    ])
    hips = hull([
        ellipsoid((0.095 * g, body.hips / 2 * 0.82 * g, 0.05), SEG_S, (0.005, 0.0, 0.16 * s * 0.6)),
        ellipsoid((0.10 * g, body.hips / 2 * g, 0.085), SEG_S, (-0.01, 0.0, 0.0)),
    ])
    return [p.paint(chest - hips, outfit.chest), p.paint(hips, outfit.hips)]


def capsule_path_pts(offsets, origin) -> list[np.ndarray]:
    """Offsets (metres) added to ``origin``: a path for :func:`capsule_from`."""
    return [np.asarray(origin, float) + np.asarray(o, float) for o in offsets]


def capsule_from(points, radius: float) -> m3.Manifold:
    """Capsules of ``radius`` joining consecutive ``points``."""
    return union(capsule(a, b, radius, radius, SEG_XS) for a, b in zip(points[:-1], points[1:],
                                                                      strict=True))


def _vest(p: Painter, body: Body, outfit: Outfit, j: dict) -> list[m3.Manifold]:
    """A foam jacket around the chest, or an inflated yoke (collar and two front lobes)."""
    if outfit.vest is None:
        return []
    s, g = body.stature, body.girth
    half_sh = body.shoulders / 2
    sz = SHOULDER_Z * s
    if outfit.vest_style == "yoke":
        neck = j["neck"]
        collar = capsule_path_pts([(-0.07, 0.09, 0.03), (-0.09, 0.0, 0.05), (-0.07, -0.09, 0.03)],
                                  neck)
        lobes = [ellipsoid((0.06, 0.075, 0.13), SEG_S, (0.12 * g, side * 0.07, sz - 0.09))
                 for side in (1, -1)]
        shape = union([capsule_from(collar, 0.05), *lobes])
    else:
        shape = hull([
            ellipsoid((0.10 * g, half_sh * 0.8, 0.05), SEG_S, (0.0, 0.0, sz - 0.005)),
            ellipsoid((0.15 * g, half_sh * 0.9 * g, 0.10), SEG_S, (0.02, 0.0, sz - 0.13)),
            ellipsoid((0.135 * g, body.hips / 2 * 0.95 * g, 0.05), SEG_S,
                      (0.01, 0.0, 0.16 * s * 0.7)),
        ])
    return [p.paint(shape, outfit.vest)]


def _limbs(p: Painter, body: Body, outfit: Outfit, j: dict) -> list[m3.Manifold]:
    s, g = body.stature, body.girth
    k = s / 1.75
    parts = []
    for tag in ("l", "r"):
        sh, el, wr, ha = (j[f"{n}_{tag}"] for n in ("shoulder", "elbow", "wrist", "hand"))
        hip, kn, an, toe = (j[f"{n}_{tag}"] for n in ("hip", "knee", "ankle", "toe"))
        parts.append(p.paint(capsule(sh, el, 0.050 * g * k, 0.040 * g * k), outfit.upper_arm))
        parts.append(p.paint(capsule(el, wr, 0.039 * g * k, 0.028 * g * k), outfit.forearm))
        mid = (wr + ha) / 2
        d = _unit(ha - wr)
        hand = capsule(wr + 0.01 * d, mid + 0.03 * d, 0.032 * k, 0.026 * k, SEG_XS)
        parts.append(p.paint(hand, outfit.hand))
        parts.append(p.paint(capsule(hip, kn, 0.085 * g * k, 0.056 * g * k), outfit.thigh))
        parts.append(p.paint(capsule(kn, an, 0.055 * g * k, 0.034 * g * k), outfit.shin))
        parts.append(p.paint(capsule(an, toe, 0.036 * k, 0.028 * k, SEG_XS), outfit.foot))
    return parts


def build_person(p: Painter, body: Body, pose: Pose, outfit: Outfit,
                 extra_local: list[m3.Manifold] | None = None
                 ) -> tuple[m3.Manifold, dict[str, np.ndarray]]:
    """The painted person in the object frame, and its joints in the object frame.

    ``extra_local``: painted solids in the local body frame that move with the body (a paddle
    in the hands). The origin stays between the hip joints.
    """
    j = skeleton(body, pose)
    s = body.stature
    neck_top = j["neck"] + np.array([0.01, 0.0, 0.055 * s])
    neck = capsule(j["neck"] - [0, 0, 0.03], neck_top, 0.056 * body.girth, 0.052, SEG_XS)
    parts = [p.paint(neck, outfit.neck)]
    parts += _head(p, body, pose, outfit, neck_top)
    parts += _torso(p, body, outfit)
    parts += _limbs(p, body, outfit, j)
    parts += _vest(p, body, outfit, j)
    parts += extra_local or []
    rot = body_rotation(pose)
    solid = place(union(parts), rot, (0.0, 0.0, 0.0))
    j["head_top"] = neck_top + rot_z(pose.head_yaw) @ rot_y(pose.head_pitch) @ [0, 0, HEAD_H * s]
    j["nose"] = neck_top + rot_z(pose.head_yaw) @ rot_y(pose.head_pitch) @ [
        body.head_length / 2, 0, HEAD_H * s * 0.35]
    j["neck_top"] = neck_top
    world = {k: rot @ v for k, v in j.items()}
    return solid, world
