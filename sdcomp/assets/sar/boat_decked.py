"""Decked boats: motor boats (centre console, bowrider, cuddy), rescue RIBs, sailboats and
cabin cruisers, each built from the parameters :func:`sdcomp.assets.sar.boat.draw` draws.

Each builder takes (params, painter) and returns (the painted solid, z of the waterline),
in metres: x forward, y port, z up, keel amidships at z = 0.
"""

from __future__ import annotations

import math

import manifold3d as m3
import numpy as np

from ..flotation import waterline_for_mass
from ..lofts import sweep
from ..solids import (
    Painter,
    box_at,
    box_between,
    capsule,
    capsule_path,
    cylinder,
    cylinder_z,
    ellipse_points,
    extrude_y,
    extrude_z,
    polygon,
    rounded_rect,
    union,
)
from . import palette
from .boat_open import seated
from .common import SEG_S, SEG_XS
from .hull import HullSpec, deck_band, hull_solid, plan_inset, stations

PERSON_KG = 80.0  #: mass of each person aboard, kg (in the waterline's mass balance)

# --------------------------------------------------------------------------- shared parts

def _hull_paint(p: Painter, solid: m3.Manifold, waterline: float, hull: list, bottom: list,
                antifouling: bool) -> m3.Manifold:
    """The hull coloured ``hull`` above, ``bottom`` (antifouling) below the boot top."""
    if not antifouling:
        return p.paint(solid, hull)
    below = box_between((-50, -50, -50), (50, 50, waterline + 0.05))
    return p.paint_split(solid, below, bottom, hull)


def _outboard(p: Painter, x_transom: float, z_mount: float, keel_z: float, y: float,
              size: float, colour) -> m3.Manifold:
    """An outboard motor hung on the transom at (x_transom, y): cowling above ``z_mount``,
    leg down to 0.35 m under the keel line ``keel_z``. ``size`` ~ 0.5 (small) to 1 (300 hp)."""
    cl, cw, ch = 0.35 + 0.4 * size, 0.28 + 0.25 * size, 0.40 + 0.35 * size
    xc = x_transom - 0.12 - cl / 2
    cowl = extrude_z(rounded_rect(xc - cl / 2, xc + cl / 2, y - cw / 2, y + cw / 2, cw * 0.35,
                                  SEG_S), z_mount, z_mount + ch)
    cap = capsule((xc - cl * 0.25, y, z_mount + ch), (xc + cl * 0.2, y, z_mount + ch),
                  cw * 0.4, cw * 0.4, SEG_S).scale([1, 1, 0.5])
    cap = cap.translate([0, 0, (z_mount + ch) * 0.5])
    leg_bottom = keel_z - 0.35
    leg = box_between((xc - 0.10, y - 0.05, leg_bottom), (xc + 0.12, y + 0.05, z_mount + 0.05))
    skeg = box_between((xc - 0.20, y - 0.06, leg_bottom), (xc + 0.18, y + 0.06, leg_bottom + 0.12))
    bracket = box_between((x_transom - 0.14, y - 0.12, z_mount - 0.25), (x_transom + 0.01, y + 0.12,
                                                                 z_mount + 0.1))
    return p.paint(union([cowl, cap, leg, skeg, bracket]), colour)


def _console(p: Painter, x: float, z: float, width: float, length: float, height: float,
             colour, glass) -> list[m3.Manifold]:
    """A centre console: rounded box with a sloped windscreen on its front top."""
    x0, x1 = x - length / 2, x + length / 2
    side = extrude_y(polygon([(x0, z), (x1, z), (x1, z + height - 0.3),
                              (x1 - 0.35, z + height), (x0, z + height)]),
                     -width / 2 - 0.05, width / 2 + 0.05)
    body = side ^ extrude_z(rounded_rect(x0, x1, -width / 2, width / 2, 0.08, SEG_S), z - 0.01,
                            z + height + 0.01)
    screen_s = extrude_y(polygon([(x + length / 2 - 0.31, z + height - 0.013),
                                  (x + length / 2 - 0.05, z + height - 0.25),
                                  (x + length / 2 - 0.02, z + height - 0.25),
                                  (x + length / 2 - 0.27, z + height + 0.32)]),
                         -width / 2 - 0.02, width / 2 + 0.02)
    return [p.paint(body, colour), p.paint(screen_s, glass)]


Seat = tuple  # (x, y, z metres, facing +1 or -1, hands: ((x, y, z), (x, y, z)) or None)


def crew(p: Painter, people: list[dict], seats: list[Seat]) -> list[m3.Manifold]:
    """The seated ``people`` on the first of ``seats`` ((x, y, z of the buttocks, facing +1
    forward or -1 aft, hands (left, right) object-frame points or None for the lap))."""
    out = []
    for person, (x, y, z, facing, hands) in zip(people, seats, strict=False):
        if hands is None:  # on the lap: forward of the hips, either side of the thighs
            hands = ((x + facing * 0.38, y + 0.15, z + 0.2), (x + facing * 0.38, y - 0.15,
                                                              z + 0.2))
        out.append(seated(p, person, (x, y, z), hands, facing))
    return out


def _bimini(p: Painter, spec: HullSpec, u0: float, u1: float, z: float, colour
            ) -> list[m3.Manifold]:
    """A bimini over the cockpit between stations ``u0`` and ``u1``: a canvas top ``z``
    metres up, arched across the beam (faceted: a darker and a lighter side under the sun),
    on two steel bows from the gunwales."""
    x0, x1 = spec.x(u0), spec.x(u1)
    half = min(spec.half_beam(u0), spec.half_beam(u1)) - 0.08
    slabs = [box_between((x0, -half, z), (x1, half, z + 0.03)),
             box_between((x0 + 0.04, -0.65 * half, z + 0.10), (x1 - 0.04, 0.65 * half,
                                                               z + 0.13)),
             box_between((x0 + 0.08, -0.25 * half, z + 0.15), (x1 - 0.08, 0.25 * half,
                                                               z + 0.17))]
    top = m3.Manifold.batch_hull(slabs)
    bows = [capsule_path([(x, s * half, spec.sheer(u) - 0.05), (x, s * half, z)], 0.02,
                         SEG_XS) for u, x in ((u0 + 0.02, x0 + 0.1), (u1 - 0.02, x1 - 0.1))
            for s in (1, -1)]
    return [p.paint(top, colour), p.paint(union(bows), palette.STEEL)]


# --------------------------------------------------------------------------- motor boat

def motorboat(params: dict, p: Painter) -> tuple[m3.Manifold, float]:
    """The motorboat of ``params``: (painted solid, waterline z)."""
    c = params["colours"]
    L, B, D = params["length"], params["beam"], params["depth"]
    spec = HullSpec(L, B, D, "v", params["deadrise"], transom=0.86, max_at=0.42,
                    sheer_bow=0.12 + 0.02 * L, bow_rise=0.6, forefoot=0.5)
    outer = hull_solid(spec)
    people = params.get("people", [])
    wl = waterline_for_mass(outer, params["mass"] + PERSON_KG * len(people))
    parts = [_hull_paint(p, outer, wl, c["hull"], c["bottom"], params["antifouling"])]
    parts.append(p.paint(deck_band(spec, 0.05, 0.015), c["deck"]))
    style = params["style"]
    # cockpit well: most of the boat for console/bowrider, the aft half for a cuddy
    u0 = 0.06
    u1 = {"console": 0.80, "bowrider": 0.86, "cuddy": 0.52}[style]
    sole = D * 0.45
    well = plan_inset(spec, 0.16, u0, u1, sole, D + 0.5, n=12)
    solid = union(parts) - p.paint(well, c["sole"])
    extra = []
    x_mid = spec.x(0.45)

    def side(u: float) -> float:  # a seat's offset from the centreline at station u
        return max(spec.half_beam(u) - 0.42, 0.2)

    aft: list[Seat] = [(spec.x(0.13), s * side(0.13), sole + 0.45, 1, None) for s in (1, -1)]
    bow: list[Seat] = [(spec.x(0.72), s * side(0.72) * 0.8, sole + 0.4, -1, None)
                       for s in (1, -1)]
    seats: list[Seat]
    if style == "console":
        c_len = 0.7 + 0.03 * L
        x_helm = x_mid - c_len / 2 + 0.05
        helm = [(x_mid - 0.75, 0.0, sole + 0.7, 1, ((x_helm, 0.2, sole + 0.98),
                                                    (x_helm, -0.2, sole + 0.98)))]
        seats = helm + aft + bow
        top_span = (0.2, 0.52)
        extra += _console(p, x_mid, sole, 0.75 + 0.03 * L, c_len, 1.05,
                          c["console"], palette.GLASS)
        extra.append(p.paint(box_at((0.55, 0.8, 0.7), (x_mid - 0.75, 0, sole + 0.35)),
                             c["cushion"]))
        if params["t_top"]:
            extra += _t_top(p, x_mid - 0.2, sole, 1.4 + 0.05 * L, 1.3 + 0.05 * L, 2.05,
                            c["canvas"])
    elif style == "bowrider":
        xs = spec.x(0.56)
        seats = [(xs - 0.5, s * B * 0.27, sole + 0.6, 1, None) for s in (1, -1)] + aft + bow
        top_span = (0.14, 0.5)
        extra += _windscreen(p, spec, 0.56, D, palette.GLASS)
        extra.append(p.paint(box_at((0.6, 0.55, 0.6), (xs - 0.5, B * 0.27, sole + 0.3)),
                             c["cushion"]))
        extra.append(p.paint(box_at((0.6, 0.55, 0.6), (xs - 0.5, -B * 0.27, sole + 0.3)),
                             c["cushion"]))
        extra.append(p.paint(plan_inset(spec, 0.18, 0.08, 0.22, sole, sole + 0.45),
                             c["cushion"]))
        extra.append(p.paint(plan_inset(spec, 0.17, 0.66, 0.84, sole, sole + 0.4),
                             c["cushion"]))
    else:  # cuddy: cabin trunk forward with a sloped screen
        seats = [(spec.x(0.38), s * side(0.38) * 0.7, sole + 0.45, 1, None)
                 for s in (1, -1)] + aft
        top_span = (0.1, 0.46)
        extra += _cabin(p, spec, 0.52, 0.86, D, 0.55 + 0.02 * L, 0.22, c["deck"],
                        palette.GLASS)
        extra.append(p.paint(plan_inset(spec, 0.17, 0.08, 0.2, sole, sole + 0.45),
                             c["cushion"]))
    x_tr = spec.x(0.0)
    n_eng = params["engines"]
    size = float(np.clip((L - 4) / 5, 0.3, 1.0))
    for i in range(n_eng):
        y = 0.0 if n_eng == 1 else (0.33 if i == 0 else -0.33)
        extra.append(_outboard(p, x_tr, D - 0.05, 0.0, y, size, c["engine"]))
    extra += crew(p, people, seats)
    if params.get("bimini"):
        extra += _bimini(p, spec, *top_span, sole + 1.85, params["bimini"])
    return union([solid, *extra]), wl


def _t_top(p: Painter, x: float, z: float, length: float, width: float, height: float,
           canvas) -> list[m3.Manifold]:
    """A T-top: a flat canvas roof on four posts."""
    roof = extrude_z(rounded_rect(x - length / 2, x + length / 2, -width / 2, width / 2, 0.15,
                                  SEG_S), z + height, z + height + 0.08)
    posts = [cylinder_z(0.025, z, z + height, x + sx * (length / 2 - 0.12),
                        sy * (width / 2 - 0.25), SEG_XS) for sx in (1, -1) for sy in (1, -1)]
    return [p.paint(roof, canvas), p.paint(union(posts), palette.STEEL)]


def _windscreen(p: Painter, spec: HullSpec, u: float, z: float, glass) -> list[m3.Manifold]:
    """A low windscreen across the boat at ``u``, leaning aft, with a walk-through gap."""
    b = spec.half_beam(u) - 0.1
    x = spec.x(u)
    prof = polygon([(x - 0.02, z), (x + 0.02, z), (x - 0.2, z + 0.42), (x - 0.24, z + 0.42)])
    parts = [extrude_y(prof, 0.25, b), extrude_y(prof, -b, -0.25)]
    return [p.paint(union(parts), glass)]


def _cabin(p: Painter, spec: HullSpec, u0: float, u1: float, z: float, height: float,
           inset: float, colour, glass, taper: float = 0.08) -> list[m3.Manifold]:
    """A cabin trunk over [u0, u1] with a band of dark windows and a sloped front."""
    trunk = plan_inset(spec, inset, u0, u1, z - 0.05, z + height, n=10, taper=taper)
    x_front = spec.x(u1)
    slope = extrude_y(polygon([(x_front - height * 1.4, z + height + 0.01),
                               (x_front + 0.5, z + height + 0.01),
                               (x_front + 0.5, z + 0.02)]), -5, 5)
    trunk = trunk - slope
    band = box_between((-50, -50, z + height * 0.45), (50, 50, z + height * 0.8))
    return [p.paint_split(trunk, band, glass, colour)]


# --------------------------------------------------------------------------- cabin cruiser

def cabin_cruiser(params: dict, p: Painter) -> tuple[m3.Manifold, float]:
    """The cabin cruiser of ``params``: (painted solid, waterline z)."""
    c = params["colours"]
    L, B, D = params["length"], params["beam"], params["depth"]
    spec = HullSpec(L, B, D, "v", params["deadrise"], transom=0.9, max_at=0.45,
                    sheer_bow=0.15 + 0.02 * L, bow_rise=0.6, forefoot=0.5, chine=0.9)
    outer = hull_solid(spec)
    people = params.get("people", [])
    wl = waterline_for_mass(outer, params["mass"] + PERSON_KG * len(people))
    parts = [_hull_paint(p, outer, wl, c["hull"], c["bottom"], True),
             p.paint(deck_band(spec, 0.05, 0.015), c["deck"])]
    sole = D - 0.45
    well = plan_inset(spec, 0.14, 0.03, 0.32, sole, D + 0.5, n=8)
    solid = union(parts) - p.paint(well, c["cockpit"])
    cab_h = 0.85 + 0.03 * L
    extra = _cabin(p, spec, 0.30, 0.78, D, cab_h, 0.30, c["cabin"], c["window"], taper=0.15)
    # swim platform
    x_tr = spec.x(0.0)
    extra.append(p.paint(box_between((x_tr - 0.55, -B * 0.4, sole - 0.25), (x_tr + 0.05, B * 0.4,
                                                                     sole - 0.17)), c["cockpit"]))
    extra.append(p.paint(plan_inset(spec, 0.2, 0.04, 0.12, sole, sole + 0.45), c["cushion"]))
    if params["flybridge"]:
        z = D + cab_h
        fly = plan_inset(spec, 0.55, 0.32, 0.58, z - 0.05, z + 0.85, n=6, taper=0.05)
        fly = fly - plan_inset(spec, 0.65, 0.34, 0.52, z + 0.1, z + 1.0, n=6)
        extra.append(p.paint(fly, c["cabin"]))
        extra.append(p.paint(plan_inset(spec, 0.7, 0.36, 0.44, z + 0.05, z + 0.5, n=4),
                             c["cushion"]))
    # stern-drive leg under the transom
    extra.append(p.paint(box_between((x_tr - 0.45, -0.1, -0.35), (x_tr + 0.05, 0.1, 0.25)),
                         palette.DARK_GREY))
    seats = [(spec.x(0.09), s * B * 0.22, sole + 0.45, 1, None) for s in (1, -1)]
    seats.append((spec.x(0.24), B * 0.25, sole + 0.05, -1, None))
    if params["flybridge"]:
        seats.insert(0, (spec.x(0.4), 0.3, D + cab_h + 0.5, 1, None))
    extra += crew(p, people, seats)
    return union([solid, *extra]), wl


# --------------------------------------------------------------------------- RIB

def rib(params: dict, p: Painter) -> tuple[m3.Manifold, float]:
    """The RIB of ``params``: (painted solid, waterline z)."""
    c = params["colours"]
    L, B = params["length"], params["beam"]
    td = params["tube_diameter"]
    tr = td / 2
    hull_beam = B - 1.3 * td
    D = 0.45 + 0.03 * L
    spec = HullSpec(L * 0.96, hull_beam, D, "v", params["deadrise"], transom=0.82, max_at=0.4,
                    sheer_bow=0.10, bow_rise=0.55, forefoot=0.45, chine=0.95)
    outer = hull_solid(spec)
    parts = [p.paint(outer, c["hull"])]
    tube = _rib_tube(spec, tr, L)
    parts.append(p.paint(tube, c["tubes"]))
    buoyant = union([outer, tube])
    people = params.get("people", [])
    wl = waterline_for_mass(buoyant, params["mass"] + PERSON_KG * len(people))
    solid = union(parts)
    well = plan_inset(spec, 0.06, 0.03, 0.85, D - 0.3, D + 1.0, n=10)
    solid = solid - p.paint(well, c["sole"])
    extra = []
    xm = spec.x(0.5)
    extra += _console(p, xm, D - 0.3, 0.55 + 0.03 * L, 0.55 + 0.02 * L, 0.95, c["console"],
                      palette.GLASS)
    extra.append(p.paint(box_at((0.5, 0.5, 0.8), (xm - 0.8, 0, D - 0.3 + 0.4)), c["seat"]))
    x_helm = xm - (0.55 + 0.02 * L) / 2 + 0.05
    seats: list[Seat] = [(xm - 0.8, 0.0, D + 0.5, 1, ((x_helm, 0.18, D + 0.62),
                                                      (x_helm, -0.18, D + 0.62)))]
    seats += [(spec.x(u), s * (hull_beam / 2 + 0.05), D + 0.15, 1, None)
              for u, s in ((0.72, 1), (0.3, -1), (0.3, 1))]
    extra += crew(p, people, seats)
    x_tr = spec.x(0.0)
    if params["a_frame"]:
        legs = [capsule_path([(x_tr + 0.4, s * (hull_beam / 2 - 0.1), D),
                              (x_tr + 0.25, s * (hull_beam / 2 - 0.2), D + 1.6),
                              (x_tr + 0.25, 0.0, D + 1.7)], 0.03, SEG_XS) for s in (1, -1)]
        extra.append(p.paint(union(legs), c["frame"]))
    n_eng = params["engines"]
    size = float(np.clip((L - 3.5) / 5, 0.3, 1.0))
    for i in range(n_eng):
        y = 0.0 if n_eng == 1 else (0.3 if i == 0 else -0.3)
        extra.append(_outboard(p, x_tr, D - 0.05, 0.0, y, size, c["engine"]))
    return union([solid, *extra]), wl


def _rib_tube(spec: HullSpec, r: float, overall: float) -> m3.Manifold:
    """The buoyancy tube: a horseshoe along the sheer from past the transom around the bow,
    its stern ends tapering to cones at x = -overall / 2."""
    us = stations(12, 0.0, 0.97)

    def side(sign: int) -> list[tuple[float, float, float]]:
        seq = [(spec.x(u), sign * (spec.half_beam(u) + r * 0.45), spec.sheer(u) + r * 0.35)
               for u in us]
        return [(-overall / 2 + 0.05, seq[0][1], seq[0][2] + 0.03), *seq]

    nose = (spec.x(1.0) + r * 0.3, 0.0, spec.sheer(1.0) + r * 0.35)
    path = side(1) + [nose] + side(-1)[::-1]
    section = ellipse_points(r, r, 10, phase=math.pi / 10)
    return sweep(path, section, end_extend=r * 0.6)


# --------------------------------------------------------------------------- sailboat

def sailboat(params: dict, p: Painter) -> tuple[m3.Manifold, float]:
    """The sailboat of ``params``: (painted solid, waterline z)."""
    c = params["colours"]
    L, B, D = params["length"], params["beam"], params["depth"]
    spec = HullSpec(L, B, D, "round", transom=0.7, max_at=0.55, sheer_bow=0.15 + 0.015 * L,
                    sheer_stern=0.05, bow_rise=0.7, forefoot=0.55, fullness=2.4)
    outer = hull_solid(spec)
    keel_d = params["keel_depth"]
    xk = spec.x(0.5)
    fin = extrude_y(polygon([(xk - 0.18 * L * 0.5, 0.05), (xk + 0.12 * L * 0.5, 0.05),
                             (xk + 0.02 * L, -keel_d), (xk - 0.05 * L, -keel_d)]),
                    -0.07, 0.07)
    xr = spec.x(0.08)
    rudder = extrude_y(polygon([(xr - 0.1, 0.1), (xr + 0.25, 0.1), (xr + 0.15, -keel_d * 0.75),
                                (xr - 0.1, -keel_d * 0.7)]), -0.03, 0.03)
    buoyant = union([outer, fin, rudder])
    people = params.get("people", [])
    wl = waterline_for_mass(buoyant, params["mass"] + PERSON_KG * len(people))
    parts = [_hull_paint(p, outer, wl, c["hull"], c["bottom"], True),
             p.paint(union([fin, rudder]), c["bottom"]),
             p.paint(deck_band(spec, 0.04, 0.015), c["deck"])]
    solid = union(parts)
    well = plan_inset(spec, 0.3, 0.02, 0.30, D - 0.45, D + 0.5, n=8)
    solid = solid - p.paint(well, c["cockpit"])
    extra = _cabin(p, spec, 0.30, 0.68, D, 0.35 + 0.025 * L, 0.35, c["deck"], c["window"],
                   taper=0.1)
    bench = max(spec.half_beam(0.15) - 0.45, 0.25)
    extra += crew(p, people, [(spec.x(0.12), bench, D - 0.05, 1, None),
                              (spec.x(0.2), -bench, D - 0.05, -1, None)])
    xm = spec.x(0.6)
    mast_top = D + params["mast"]
    extra.append(p.paint(cylinder_z(0.04 + 0.004 * L, D, mast_top, xm, 0.0, SEG_XS), c["mast"]))
    boom_z = D + 0.35 + 0.025 * L + 0.45
    boom_len = 0.42 * L
    angle = math.radians(params["sail_angle"])
    end = (xm - boom_len * math.cos(angle), boom_len * math.sin(angle), boom_z)
    extra.append(p.paint(cylinder((xm, 0, boom_z), end, 0.035 + 0.003 * L, None, SEG_XS),
                         c["mast"]))
    sail = params["sail"]
    if sail == "furled":
        cover = capsule((xm - 0.1 * math.cos(angle), 0.1 * math.sin(angle), boom_z + 0.12),
                        (end[0] + 0.3 * math.cos(angle), end[1] - 0.3 * math.sin(angle),
                         boom_z + 0.08), 0.12 + 0.006 * L, 0.05, SEG_XS)
        extra.append(p.paint(cover, c["cover"]))
    else:
        extra.append(p.paint(_sail((xm - 0.05, 0, boom_z + 0.05), (xm - 0.05, 0, mast_top - 0.3),
                                   (end[0], end[1], boom_z + 0.05)), c["sail"]))
        if sail == "main_jib":
            bow = (spec.x(0.985), 0.0, spec.sheer(1.0) + 0.1)
            clew = (xm - 0.15 * L, (0.35 * B) * (1 if angle >= 0 else -1), D + 0.5)
            extra.append(p.paint(_sail(bow, (xm + 0.05, 0, mast_top * 0.85), clew),
                                 c["sail"]))
    return union([solid, *extra]), wl


def _sail(a, b, c, thickness: float = 0.012) -> m3.Manifold:
    """A flat triangular sail through points ``a``, ``b``, ``c``, ``thickness`` thick."""
    pts = np.array([a, b, c], dtype=float)
    n = np.cross(pts[1] - pts[0], pts[2] - pts[0])
    n = n / np.linalg.norm(n) * thickness / 2
    return m3.Manifold.hull_points(np.concatenate([pts + n, pts - n]).tolist())

