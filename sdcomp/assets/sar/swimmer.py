"""Swimmers: a whole person in the water, mostly submerged, in one of six poses.

Poses (``params["pose"]["name"]``):

- ``tread``: upright, treading water, hands sculling a few decimetres under the surface;
  the waterline at the neck or through the shoulders (at the chest in a life jacket).
- ``wave``: upright, one arm raised straight up (the distress wave); neck above water.
- ``distress``: instinctive drowning response: upright, head tilted back, arms pressing
  sideways at the surface; only the face above water.
- ``crawl``: face down, one arm reaching forward, the other pulling under the body or
  recovering above the water; the back just awash.
- ``breast``: breaststroke, body inclined 55-70 degrees, head up, arms sweeping, frog legs.
- ``back``: floating on the back, arms spread or at the sides, face and chest awash.

The whole body is modelled (the renderer shows submerged parts through the water, which in
coastal and turbid water leaves little of what lies deeper than a few decimetres). The
waterline follows the pose (head- or shoulder-referenced), not a buoyancy balance: a swimmer
holds the head up by effort, a life jacket lifts the chest. Poses are weighted as search-and-
rescue footage shows people in the water (:data:`POSE_CYCLE`: still on seven in ten, upright
or floating on the back). Outfits, all wet (darker, :data:`WET`): dark wetsuits on nine of
twenty, shorties and swimwear on four each, clothes (a person overboard) on three; a foam
life jacket or an inflated yoke on eight of twenty; wet hair, mostly dark, or a swim cap; a
lifeguard's rescue tube held across the chest on two of twenty. The mix follows what real
boxes of people in the water show (docs/sar.md): the saturated orange or red of a jacket,
tube or board in two in five, bare skin (face, hands, arms, legs) in most. The earlier mix
(dark wetsuits on three in four, jackets on three in twenty) made dark shapes: a detector
trained on them found the real swimmers in orange jackets and missed most others.
"""

from __future__ import annotations

import math

import manifold3d as m3
import numpy as np

from ..mesh import ColoredMesh
from ..solids import Painter, capsule, union
from . import palette
from .common import jitter, pick
from .person import Body, Outfit, Pose, build_person

POSES = ("tread", "wave", "crawl", "breast", "back", "distress")
SUB_TYPES = POSES
#: the pose of variant ``v`` is ``POSE_CYCLE[v % len(POSE_CYCLE)]``: weighted as people in
#: the water are seen in search-and-rescue footage and exercises, mostly still, heads and
#: shoulders out or floating in a jacket (treading water 45 %, floating on the back 25 %,
#: waving 10 %, in distress 5 %), the rest swimming (crawl 10 %, breaststroke 5 %)
POSE_CYCLE = ("tread", "back", "tread", "back", "wave", "tread", "tread", "crawl", "back",
              "tread", "tread", "breast", "tread", "wave", "back", "distress", "tread",
              "back", "crawl", "tread")
#: the poses that swim (under way); the others drift
SWIMMING = ("crawl", "breast")
OUTFITS = ("swimwear", "wetsuit", "shorty", "clothes")
#: the outfit of variant ``v`` is ``OUTFIT_CYCLE[v % len(OUTFIT_CYCLE)]`` (a cycle, like
#: the poses, so the twenty variants hold the mix exactly): dark full wetsuits on nine
#: (open-water swimmers, surfers, divers, the volunteers of SAR exercises), a shorty on
#: four and swimwear on four (arms and legs bare: the skin that most real boxes show),
#: a person overboard in clothes on three
OUTFIT_CYCLE = ("wetsuit", "swimwear", "shorty", "wetsuit", "clothes", "wetsuit", "shorty",
                "swimwear", "wetsuit", "wetsuit", "shorty", "wetsuit", "swimwear", "wetsuit",
                "clothes", "wetsuit", "shorty", "swimwear", "wetsuit", "clothes")
#: hair: variant ``v`` has ``HAIR_DRAW[v % len(HAIR_DRAW)]`` (a cycle): wet hair mostly, a
#: swim cap on two of the twenty variants
HAIR = ("short", "long", "bald", "cap")
HAIR_DRAW = ("short", "short", "long", "short", "long", "bald", "long", "cap")
#: the variants in a life jacket (of each twenty): eight in twenty, as the saturated orange
#: and red of a jacket, tube or board shows in two in five real boxes: the five floating on
#: the back (a jacket turns its wearer face up), the three in clothes (a person overboard
#: from a boat; one of them on the back) and one treading water
VESTED = (0, 1, 3, 4, 8, 14, 17, 19)
#: the variants holding a rescue tube (of each twenty): a lifeguard's foam torpedo buoy,
#: 1 m long and 15 cm thick, across the chest and under the arms, floating half out of the
#: water in front of them
TUBE_HOLDERS = (9, 12)
TUBE_LENGTH, TUBE_RADIUS = 1.0, 0.075  # metres
#: wet skin and fabric are darker than dry (water fills the surface's pores and fibres and
#: cuts its diffuse reflectance; Lekner & Dorf 1988): albedo factor of wet clothing and skin
WET = 0.8
#: metres an upright swimmer in a life jacket floats higher than without (the jacket's
#: 70-150 N of buoyancy lifts the shoulders out: ISO 12402)
VEST_LIFT = 0.08
#: metres an upright swimmer in a suit floats higher than in swimwear: the foam neoprene's
#: own buoyancy (a 5 mm full suit displaces some 6-8 litres more than it weighs: 40-60 N,
#: half a light jacket's) brings the shoulders to the surface; a shorty's, half that
SUIT_LIFT = {"wetsuit": 0.04, "shorty": 0.02}


def _dir(rng: np.random.Generator, v, deg: float = 10.0) -> list[float]:
    """Unit vector ``v`` turned by up to ``deg`` degrees in a random direction (3 decimals)."""
    v = np.asarray(v, dtype=float)
    v = v / np.linalg.norm(v)
    off = rng.normal(size=3)
    off -= np.dot(off, v) * v
    off /= max(float(np.linalg.norm(off)), 1e-9)
    t = math.radians(rng.uniform(0.0, deg))
    out = v * math.cos(t) + off * math.sin(t)
    return [round(float(x), 3) for x in out]


def _mirror(v) -> list[float]:
    return [v[0], -v[1], v[2]]


def _sym(rng, upper, lower, deg=10.0):
    """(left, right) limb: the right mirrors the left in y, each jittered on its own."""
    left = [_dir(rng, upper, deg), _dir(rng, lower, deg)]
    right = [_dir(rng, _mirror(upper), deg), _dir(rng, _mirror(lower), deg)]
    return [left, right]


def _pose(name: str, rng: np.random.Generator) -> dict:
    """Limb directions (local body frame), orientation and waterline rule of a pose."""
    side = int(rng.integers(2))  # which arm does the odd thing
    legs_hang = _sym(rng, (0.05, 0.10, -1.0), (0.0, 0.05, -1.0), 8)
    feet_pointed = [_dir(rng, (0.2, 0.1, -1), 10), _dir(rng, (0.2, -0.1, -1), 10)]
    p: dict = {"name": name, "head_pitch": 0.0, "head_yaw": 0.0, "roll": 0.0, "flip": False}
    if name in ("tread", "wave"):
        # upper arms down and a little out, the forearms either sculling in front of the
        # chest (the hands 0.3-0.4 m down, within a forearm of the body) or reaching up to
        # the surface in front (holding on): seen from above, close to the body, not a
        # starfish of limbs spread half a metre out
        if rng.random() < 0.5:  # sculling in front of the chest, hands a hand's depth down
            arms = _sym(rng, (0.35, 0.45, -0.82), (0.85, 0.35, -0.40))
        else:  # hands at the surface in front, holding on (a jacket's straps, each other)
            arms = _sym(rng, (0.45, 0.35, -0.82), (0.80, -0.25, 0.55))
        legs = [[_dir(rng, (0.55, 0.25, -0.8)), _dir(rng, (-0.3, 0.15, -0.95))],
                [_dir(rng, (0.15, -0.25, -0.95)), _dir(rng, (-0.45, -0.1, -0.88))]]
        if name == "wave":
            up = (0.05, 0.30, 0.95) if side == 0 else (0.05, -0.30, 0.95)
            arms[side] = [_dir(rng, up, 8), _dir(rng, (0.05, 0.1 - 0.2 * side, 1.0), 12)]
        p.update(arms=arms, legs=legs, feet=[_dir(rng, (0.6, 0.1, -0.8)),
                                             _dir(rng, (0.3, -0.1, -0.9))],
                 pitch=round(float(rng.uniform(5, 20)), 1),
                 head_pitch=round(float(rng.uniform(-12, 5)), 1),
                 head_yaw=round(float(rng.uniform(-30, 30)), 1),
                 water="chin" if name == "wave" else "shoulders",
                 water_offset=round(float(rng.uniform(-0.06, 0.02) if name == "tread"
                                          else rng.uniform(-0.09, -0.03)), 3))
    elif name == "distress":
        p.update(arms=_sym(rng, (0.15, 0.95, 0.0), (0.25, 0.9, -0.15)), legs=legs_hang,
                 feet=feet_pointed, pitch=round(float(rng.uniform(-5, 8)), 1),
                 head_pitch=round(float(rng.uniform(-40, -25)), 1),
                 water="chin", water_offset=round(float(rng.uniform(0.04, 0.07)), 3))
    elif name == "crawl":
        lead = [_dir(rng, (0.10, 0.22, 0.97), 6), _dir(rng, (0.05, 0.12, 0.99), 6)]
        if rng.random() < 0.5:  # pulling under the body (local +x points down)
            other = [_dir(rng, (0.85, -0.2, 0.45), 10), _dir(rng, (0.9, 0.05, -0.4), 10)]
        else:  # recovering above the water, elbow high
            other = [_dir(rng, (-0.6, -0.65, -0.45), 10), _dir(rng, (0.45, -0.2, 0.85), 10)]
        arms = [lead, other] if side == 0 else [[_mirror(other[0]), _mirror(other[1])],
                                                [_mirror(lead[0]), _mirror(lead[1])]]
        kick = float(rng.uniform(0.08, 0.2))
        legs = [[_dir(rng, (kick, 0.05, -1.0), 4), _dir(rng, (kick * 0.5, 0.03, -1.0), 4)],
                [_dir(rng, (-kick, -0.05, -1.0), 4), _dir(rng, (-kick, -0.03, -1.0), 4)]]
        p.update(arms=arms, legs=legs, feet=[_dir(rng, (-0.3, 0.05, -1), 8),
                                             _dir(rng, (-0.3, -0.05, -1), 8)],
                 pitch=round(float(rng.uniform(76, 86)), 1),
                 head_pitch=round(float(rng.uniform(-5, 10)), 1),
                 head_yaw=round(float(pick(rng, (0.0, 0.0, 60.0, -60.0))), 1),
                 roll=round(float(rng.uniform(-15, 15)), 1),
                 water="back", water_offset=round(float(rng.uniform(-0.08, -0.04)), 3))
    elif name == "breast":
        if rng.random() < 0.5:  # out-sweep
            arms = _sym(rng, (0.35, 0.70, 0.62), (0.55, 0.35, 0.75))
        else:  # glide, arms forward
            arms = _sym(rng, (0.30, 0.28, 0.91), (0.25, 0.12, 0.96), 6)
        if rng.random() < 0.5:  # frog kick, knees out, heels to the seat
            legs = _sym(rng, (-0.05, 0.55, -0.83), (-0.75, 0.35, -0.55), 8)
        else:
            legs = _sym(rng, (-0.05, 0.2, -1.0), (-0.05, 0.1, -1.0), 6)
        pitch = float(rng.uniform(55, 72))
        p.update(arms=arms, legs=legs, feet=[_dir(rng, (0.0, 0.6, -0.8)),
                                             _dir(rng, (0.0, -0.6, -0.8))],
                 pitch=round(pitch, 1), head_pitch=round(-pitch + float(rng.uniform(5, 20)), 1),
                 water="chin", water_offset=round(float(rng.uniform(-0.02, 0.02)), 3))
    elif name == "back":
        if rng.random() < 0.6:  # star float
            arms = _sym(rng, (0.0, 0.85, 0.45), (0.05, 0.8, 0.55), 10)
            legs = _sym(rng, (0.0, 0.30, -1.0), (0.0, 0.15, -1.0), 6)
        else:
            arms = _sym(rng, (-0.1, 0.3, -0.95), (0.0, 0.25, -0.95), 8)
            legs = _sym(rng, (0.0, 0.08, -1.0), (0.0, 0.04, -1.0), 5)
        p.update(arms=arms, legs=legs, feet=[_dir(rng, (0.4, 0.1, -1)),
                                             _dir(rng, (0.4, -0.1, -1))],
                 pitch=round(float(rng.uniform(-85, -70)), 1), flip=True,
                 head_pitch=round(float(rng.uniform(-15, 5)), 1),
                 water="nose", water_offset=round(float(rng.uniform(-0.12, -0.08)), 3))
    else:
        raise ValueError(f"unknown pose {name!r}")
    return p


def _wet(rgb) -> tuple[int, int, int]:
    """``rgb`` (sRGB 0-255) darkened as wet (:data:`WET`, applied in linear light)."""
    return palette.darken(rgb, WET)


def _outfit(rng: np.random.Generator, kind: str, hair_style: str, vested: bool) -> dict:
    """Colours (sRGB lists) of every part, hair and vest of an outfit of ``kind``
    (:data:`OUTFITS`) with hair ``hair_style`` (:data:`HAIR`) and a life jacket when
    ``vested``, all wet; JSON-able."""
    tone = int(rng.integers(len(palette.SKIN_MONK)))
    skin = _wet(jitter(palette.skin(tone), rng, 0.04))
    c = dict.fromkeys(("chest", "hips", "upper_arm", "forearm", "hand", "thigh", "shin",
                       "foot", "neck"), skin)
    if kind == "swimwear":
        c["hips"] = _wet(jitter(pick(rng, palette.SWIMWEAR), rng))
        if rng.random() < 0.4:  # swimsuit
            c["chest"] = c["hips"]
    elif kind in ("wetsuit", "shorty"):
        suit = _wet(jitter(pick(rng, palette.WETSUIT), rng, 0.08))
        parts: tuple[str, ...] = ("chest", "hips", "upper_arm", "thigh", "neck")
        if kind == "wetsuit":
            parts += ("forearm", "shin", "foot")
        for k in parts:
            c[k] = suit
        if kind == "wetsuit" and rng.random() < 0.1:  # coloured chest panel
            c["chest"] = _wet(jitter(pick(rng, palette.SWIMWEAR), rng))
    else:
        shirt = _wet(jitter(pick(rng, palette.SHIRTS), rng))
        trousers = _wet(jitter(pick(rng, palette.TROUSERS), rng))
        c.update(chest=shirt, upper_arm=shirt, hips=trousers, thigh=trousers, shin=trousers)
        if rng.random() < 0.5:
            c["forearm"] = shirt
        c["foot"] = _wet(jitter(pick(rng, palette.SHOES), rng))
    hair = (jitter(pick(rng, palette.SWIM_CAPS), rng) if hair_style == "cap"
            else jitter(palette.wet_hair(palette.draw_hair(rng)), rng))
    vest = None
    vest_style = "foam"
    if vested:
        vest = jitter(pick(rng, palette.VESTS), rng)
        vest_style = pick(rng, ("foam", "foam", "yoke"))
    return {"outfit": kind, "skin_tone_mst": tone + 1, "skin": list(skin),
            "parts": {k: list(v) for k, v in c.items()},
            "hair_style": hair_style, "hair": list(hair),
            "vest": None if vest is None else list(vest), "vest_style": vest_style}


def draw(rng: np.random.Generator, variant: int) -> dict:
    """The drawn parameters of swimmer ``variant`` (JSON-able; metres, degrees, sRGB)."""
    pose = POSE_CYCLE[variant % len(POSE_CYCLE)]
    female = bool(rng.random() < 0.45)
    stature = float(rng.normal(1.63, 0.06) if female else rng.normal(1.76, 0.07))
    stature = float(np.clip(stature, 1.50, 1.95))
    shoulders = float(np.clip(stature * (0.225 if female else 0.236) * rng.normal(1, 0.04),
                              0.32, 0.46))
    hips = float(np.clip(stature * (0.21 if female else 0.195) * rng.normal(1, 0.04),
                         0.28, 0.40))
    body = {"stature": round(stature, 3), "shoulders": round(shoulders, 3),
            "hips": round(hips, 3),
            "head_breadth": round(float(np.clip(rng.normal(0.147 if female else 0.155, 0.005),
                                                0.135, 0.170)), 3),
            "head_length": round(float(np.clip(rng.normal(0.189 if female else 0.199, 0.007),
                                               0.170, 0.215)), 3),
            "girth": round(float(rng.uniform(0.9, 1.15)), 3), "female": female}
    out = {"kind": "swimmer", "sub_type": pose, "body": body, "pose": _pose(pose, rng),
           **_outfit(rng, OUTFIT_CYCLE[variant % len(OUTFIT_CYCLE)],
                     HAIR_DRAW[variant % len(HAIR_DRAW)], variant % 20 in VESTED)}
    # drawn last: the other variants' draws stay as they were
    out["tube"] = (list(jitter(pick(rng, palette.RESCUE_TUBES), rng))
                   if variant % 20 in TUBE_HOLDERS else None)
    return out


def _to_pose(p: dict) -> Pose:
    return Pose(arms=tuple(tuple(map(tuple, a)) for a in p["arms"]),
                legs=tuple(tuple(map(tuple, leg)) for leg in p["legs"]),
                feet=tuple(map(tuple, p["feet"])), head_pitch=p["head_pitch"],
                head_yaw=p["head_yaw"], pitch=p["pitch"], roll=p["roll"], flip=p["flip"])


def make(params: dict, name: str) -> ColoredMesh:
    """Build the swimmer described by ``params`` (from :func:`draw`)."""
    b = params["body"]
    body = Body(b["stature"], b["shoulders"], b["hips"], b["head_breadth"], b["head_length"],
                b["girth"])
    parts = {k: tuple(v) for k, v in params["parts"].items()}
    outfit = Outfit(skin=tuple(params["skin"]), hair=tuple(params["hair"]),
                    hair_style=params["hair_style"],
                    vest=None if params["vest"] is None else tuple(params["vest"]),
                    vest_style=params["vest_style"], **parts)
    pose = params["pose"]
    painter = Painter()
    solid, joints = build_person(painter, body, _to_pose(pose), outfit)
    back = max(joints[k][2] for k in ("pelvis", "neck", "shoulder_l", "shoulder_r")) + 0.10
    shoulders = max(joints["shoulder_l"][2], joints["shoulder_r"][2])
    ref = {"chin": joints["chin"][2], "nose": joints["nose"][2], "back": back,
           "shoulders": shoulders}[pose["water"]]
    # an upright body in a life jacket floats higher: the waterline at the chest
    lift = VEST_LIFT if params["vest"] is not None and pose["water"] == "shoulders" else 0.0
    if pose["name"] in ("tread", "wave"):  # upright and still: the suit's float shows
        lift = max(lift, SUIT_LIFT.get(params["outfit"], 0.0))
    waterline = ref + pose["water_offset"] - lift
    if params.get("tube") is not None:
        solid = union([solid, _tube(painter, joints, waterline, params["tube"])])
    return painter.finish(solid, waterline, name)


def _tube(painter: Painter, joints: dict[str, np.ndarray], waterline: float, colour
          ) -> m3.Manifold:
    """A rescue tube (:data:`TUBE_LENGTH` x :data:`TUBE_RADIUS` metres, ``colour`` sRGB)
    floating on the ``waterline`` (z, object frame) across the front of the chest of the
    person with ``joints`` (object frame): level, at right angles to the way the body faces,
    its axis a hand's breadth in front of the shoulders."""
    across = joints["shoulder_l"] - joints["shoulder_r"]
    across[2] = 0.0
    across /= max(float(np.linalg.norm(across)), 1e-9)
    front = np.array([across[1], -across[0], 0.0])  # horizontal, at right angles to it
    mid = (joints["shoulder_l"] + joints["shoulder_r"]) / 2
    if float(np.dot(joints["nose"] - mid, front)) < 0:
        front = -front
    centre = np.array([mid[0], mid[1], waterline]) + front * 0.2
    half = across * TUBE_LENGTH / 2
    return painter.paint(capsule(centre - half, centre + half, TUBE_RADIUS, TUBE_RADIUS),
                         colour)
