"""Personal watercraft (sit-down jet skis), with or without a seated rider.

Sub-types by size class (``params["sub_type"]``): ``compact`` (Sea-Doo Spark class),
``recreation`` (Sea-Doo GTI / Yamaha VX class), ``performance`` (Sea-Doo RXP / Yamaha GP
class, narrower seat, sharper nose), ``touring`` (Yamaha FX / Kawasaki Ultra class). Even
variants carry a rider (hands on the grips, feet in the footwells, usually a life vest), odd
ones are empty.

Parts: a deep-V lofted hull, a deck band with footwells either side of a pedestal, a long
saddle, a hood rising to the handlebar pod, handlebars with black grips, a small visor, a
rear boarding platform and the jet nozzle. The waterline comes from the mass balance of the
hull (dry mass + fuel + rider) in sea water.
"""

from __future__ import annotations

import math

import manifold3d as m3
import numpy as np

from ..flotation import waterline_for_mass
from ..mesh import ColoredMesh
from ..solids import Painter, box_between, capsule, cylinder_x, ellipsoid, hull, union
from . import palette
from .common import SEG_S, SEG_XS, jitter, pick, rng_for
from .hull import HullSpec, deck_band, hull_solid
from .person import Body, Outfit, Pose, build_person

SUB_TYPES = ("compact", "recreation", "performance", "touring")
NOZZLE = 0.18  # the jet nozzle sticks out this far behind the transom (metres)

# length, width, height ranges (metres) and dry mass (kg) per class
CLASSES = {
    "compact": ((2.75, 3.00), (1.14, 1.20), (1.00, 1.08), (190, 230)),
    "recreation": ((3.20, 3.40), (1.20, 1.26), (1.10, 1.20), (330, 370)),
    "performance": ((3.05, 3.35), (1.18, 1.26), (1.05, 1.15), (330, 380)),
    "touring": ((3.40, 3.65), (1.22, 1.28), (1.15, 1.24), (370, 430)),
}


def _r(x: float, nd: int = 3) -> float:
    return round(float(x), nd)


def draw(rng: np.random.Generator, variant: int) -> dict:
    """The drawn parameters of jet ski ``variant`` (JSON-able; metres, kg, sRGB)."""
    sub = SUB_TYPES[(variant // 2) % len(SUB_TYPES)]
    (l0, l1), (w0, w1), (h0, h1), (m0, m1) = CLASSES[sub]
    primary = jitter(pick(rng, palette.PWC), rng, 0.04)
    trim = jitter(pick(rng, palette.PWC_TRIM), rng, 0.04)
    rider = variant % 2 == 0
    colours = _colours(rng_for("jetski-colours", variant),
                       palette.PWC_DECK[variant % len(palette.PWC_DECK)],
                       palette.PWC_ACCENT[variant % len(palette.PWC_ACCENT)])
    params = {
        "kind": "jetski", "sub_type": sub, "length": _r(rng.uniform(l0, l1)),
        "width": _r(rng.uniform(w0, w1)), "height": _r(rng.uniform(h0, h1)),
        "dry_mass": _r(rng.uniform(m0, m1), 0), "fuel_mass": _r(rng.uniform(20, 60), 0),
        "rider": None,
        "colours": colours,
    }
    # the draws the colours once made here, kept so the sizes and riders stay the same
    pick(rng, (primary, palette.WHITE, palette.BLACK, trim))
    jitter(pick(rng, (palette.BLACK, palette.DARK_GREY, (200, 200, 195))), rng, 0.04)
    if rider:
        params["rider"] = {
            "stature": _r(np.clip(rng.normal(1.74, 0.08), 1.55, 1.95)),
            "mass": _r(rng.uniform(60, 100), 0),
            "skin": list(jitter(palette.skin(int(rng.integers(10))), rng, 0.04)),
            "top": list(jitter(pick(rng, palette.WETSUIT + palette.SHIRTS), rng)),
            "bottom": list(jitter(pick(rng, palette.WETSUIT + palette.TROUSERS), rng)),
            "vest": list(jitter(pick(rng, palette.VESTS + palette.WETSUIT), rng))
            if rng.random() < 0.9 else None,
            "hair": list(palette.wet_hair(pick(rng, palette.HAIR))),
            "helmet": list(jitter(pick(rng, palette.SWIM_CAPS), rng)) if rng.random() < 0.2
            else None,
            "lean": _r(rng.uniform(10, 25), 1),
        }
    return params


def _colours(rng: np.random.Generator, deck_rgb, accent_rgb) -> dict:
    """The paint of a jet ski of deck colour ``deck_rgb`` and accent ``accent_rgb`` (sRGB
    lists): seen from above, personal watercraft are mostly a white or light grey deck
    and hull (the hull the deck's colour on three in five, white or dark grey otherwise)
    with one bright accent on the hood, the pod and the side panels
    (:data:`~.palette.PWC_ACCENT`), a black or grey saddle and dark footwell mats."""
    deck = jitter(deck_rgb, rng, 0.03)
    accent = jitter(accent_rgb, rng, 0.04)
    hull = pick(rng, (deck, deck, deck, palette.WHITE, palette.DARK_GREY))
    seat = jitter(pick(rng, palette.PWC_SEAT), rng, 0.04)
    return {"deck": list(deck), "hull": list(hull), "trim": list(accent), "seat": list(seat),
            "mat": list(palette.DARK_GREY)}


def _hull_spec(params: dict) -> HullSpec:
    L, W = params["length"] - NOZZLE, params["width"] - 0.03
    sharp = params["sub_type"] == "performance"
    return HullSpec(L, W, 0.40, "v", 21.0 if sharp else 19.0, transom=0.78, max_at=0.36,
                    sheer_bow=0.14, bow_rise=0.55, forefoot=0.45, chine=0.82)


def _topside(p: Painter, params: dict, spec: HullSpec) -> list[m3.Manifold]:
    """Pedestal and saddle, hood, handlebar pod, visor, platform and nozzle."""
    c = params["colours"]
    L, H = params["length"], params["height"]
    D = spec.depth
    seat_top = H * 0.80
    x_seat0, x_seat1 = -0.47 * L, 0.02 * L
    half_seat = 0.22 if params["sub_type"] != "performance" else 0.19
    pedestal = hull([
        ellipsoid((0.2, half_seat + 0.12, 0.08), SEG_S, (x_seat0 + 0.2, 0, D + 0.02)),
        ellipsoid((0.25, half_seat + 0.16, 0.08), SEG_S, (x_seat1, 0, D + 0.02)),
        ellipsoid((0.2, half_seat + 0.02, 0.06), SEG_S, (x_seat0 + 0.2, 0, seat_top - 0.12)),
        ellipsoid((0.25, half_seat + 0.05, 0.06), SEG_S, (x_seat1 - 0.05, 0, seat_top - 0.12)),
    ])
    saddle = hull([ellipsoid((0.25, half_seat, 0.07), SEG_S,
                             (x_seat0 + 0.25, 0, seat_top - 0.07)),
                   ellipsoid((0.25, half_seat * 0.95, 0.07), SEG_S,
                             (x_seat1 - 0.2, 0, seat_top - 0.05))])
    x_bar = 0.06 * L
    bar_z = H * 0.93
    hood = hull([
        ellipsoid((0.15, half_seat + 0.12, 0.12), SEG_S, (x_seat1 + 0.05, 0, seat_top - 0.1)),
        ellipsoid((0.2, 0.33, 0.12), SEG_S, (x_bar + 0.08, 0, bar_z - 0.12)),
        ellipsoid((0.2, 0.22, 0.1), SEG_S, (0.33 * L, 0, D + 0.12)),
    ])
    bow_cap = hull([ellipsoid((0.15, 0.25, 0.08), SEG_S,
                              (spec.x(0.80), 0, spec.sheer(0.8) - 0.02)),
                    ellipsoid((0.05, 0.05, 0.04), SEG_S, (spec.x(0.95), 0, spec.sheer(0.95)))])
    pod = ellipsoid((0.12, 0.14, 0.07), SEG_S, (x_bar, 0, bar_z - 0.04))
    bars = capsule((x_bar - 0.02, 0.36, bar_z + 0.02), (x_bar - 0.02, -0.36, bar_z + 0.02),
                   0.017, 0.017, SEG_XS)
    grips = [capsule((x_bar - 0.02, s * 0.26, bar_z + 0.02), (x_bar - 0.02, s * 0.38,
                                                               bar_z + 0.02), 0.022, 0.022,
                     SEG_XS) for s in (1, -1)]
    visor = hull([ellipsoid((0.03, 0.2, 0.05), SEG_XS, (x_bar + 0.17, 0, bar_z + 0.02)),
                  ellipsoid((0.03, 0.22, 0.03), SEG_XS, (x_bar + 0.25, 0, bar_z - 0.06))])
    x_tr = spec.x(0.0)
    nozzle = cylinder_x(0.08, x_tr - NOZZLE, x_tr + 0.1, 0.0, 0.16, SEG_S)
    platform = box_between((x_tr - 0.02, -0.45, D - 0.08), (x_tr + 0.35, 0.45, D - 0.02))
    return [p.paint(union([pedestal, platform]), c["deck"]), p.paint(saddle, c["seat"]),
            p.paint(union([hood, pod]), c["trim"]), p.paint(bow_cap, c["deck"]),
            p.paint(union([bars, *grips]), palette.BLACK), p.paint(visor, palette.GLASS),
            p.paint(nozzle, palette.DARK_GREY)]


def _rider(p: Painter, params: dict) -> m3.Manifold:
    """A rider astride the saddle, hands on the grips, feet in the footwells."""
    r = params["rider"]
    L, H = params["length"], params["height"]
    s = r["stature"]
    body = Body(stature=s, shoulders=0.236 * s, hips=0.2 * s)
    skin = tuple(r["skin"])
    top, bottom = tuple(r["top"]), tuple(r["bottom"])
    head = r["helmet"] or r["hair"]
    outfit = Outfit(skin=skin, chest=top, hips=bottom, upper_arm=top, forearm=skin, hand=skin,
                    thigh=bottom, shin=bottom, foot=palette.BLACK, neck=skin,
                    hair=tuple(head), hair_style="helmet" if r["helmet"] else "short",
                    vest=None if r["vest"] is None else tuple(r["vest"]))
    lean = r["lean"]
    seat = np.array([-0.16 * L, 0.0, H * 0.80 + 0.06])
    x_bar, bar_z = 0.06 * L, H * 0.93 + 0.02
    rot = np.array([[math.cos(math.radians(-lean)), 0, math.sin(math.radians(-lean))],
                    [0, 1, 0],
                    [-math.sin(math.radians(-lean)), 0, math.cos(math.radians(-lean))]])
    grips = [rot @ (np.array([x_bar - 0.02, sgn * 0.32, bar_z]) - seat) for sgn in (1, -1)]
    legs = (((0.55, 0.55, -0.62), (0.35, 0.12, -0.93)), ((0.55, -0.55, -0.62),
                                                         (0.35, -0.12, -0.93)))
    pose = Pose(legs=legs, feet=((1.0, 0.1, -0.1), (1.0, -0.1, -0.1)), pitch=lean,
                hand_targets=tuple(grips), elbow_pole=((0.0, 1.0, -0.6), (0.0, -1.0, -0.6)))
    solid, _ = build_person(p, body, pose, outfit)
    return solid.translate(seat.tolist())


def make(params: dict, name: str) -> ColoredMesh:
    """Build the jet ski described by ``params`` (from :func:`draw`)."""
    p = Painter()
    solid, wl = _build(params, p)
    return p.finish(solid, wl, name)


def draft(params: dict) -> float:
    """Hull draft (metres, keel to waterline)."""
    return float(_build(params, Painter())[1])  # the keel is at z = 0 in the build frame


def _build(params: dict, p: Painter) -> tuple[m3.Manifold, float]:
    c = params["colours"]
    spec = _hull_spec(params)
    outer = hull_solid(spec)
    mass = params["dry_mass"] + params["fuel_mass"]
    if params["rider"]:
        mass += params["rider"]["mass"]
    parts = [p.paint(outer, c["hull"]), p.paint(deck_band(spec, 0.06, 0.02, 0.015), c["deck"])]
    solid = union(parts)
    # footwells: recesses either side of the pedestal, dark mats
    L = params["length"]
    for s in (1, -1):
        well = box_between((-0.40 * L, min(s * 0.27, s * 0.62), spec.depth - 0.06),
                           (0.10 * L, max(s * 0.27, s * 0.62), spec.depth + 0.2))
        solid = solid - p.paint(well ^ outer.scale([1, 0.9, 2.0]), c["mat"])
    extra = _topside(p, params, spec)
    if params["rider"]:
        extra.append(_rider(p, params))
    wl = waterline_for_mass(union([outer, *extra[:1]]), mass)
    return union([solid, *extra]), wl
