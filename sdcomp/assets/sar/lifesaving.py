"""Life-saving appliances: ring buoys, life rafts, rescue tubes, rescue cans, life jackets.

Sub-types (``params["sub_type"]``, cycling with the variant index):

- ``ring_buoy``: a flattened torus (outer diameter 0.61, 0.65, 0.72 or 0.76 m) in orange,
  red, or white with four red bands, with four retro-reflective tape patches and a grab line
  in festoons around the outside.
- ``life_raft``: an inflatable raft: two stacked buoyancy tubes (round or octagonal plan),
  a floor, and usually an orange canopy on an arch with a dark entrance; a light on top.
- ``rescue_tube``: a ~1 m foam rescue tube (rounded-rectangle section), straight or curled
  as if clipped round someone, with its snap hook, ring and a short trailing lanyard.
- ``rescue_can``: a hard-plastic torpedo buoy (~0.7 m) with moulded side grips.
- ``life_jacket``: an empty floating jacket: a foam vest lying flat, or an inflated
  horseshoe (collar and two lobes) with its waist belt.

All float by mass balance in sea water (foam and air make them float high).
"""

from __future__ import annotations

import math

import manifold3d as m3
import numpy as np

from ..flotation import waterline_for_mass
from ..lofts import sweep
from ..mesh import ColoredMesh
from ..solids import (
    Painter,
    box_at,
    box_between,
    capsule,
    cylinder_z,
    ellipse_points,
    ellipsoid,
    extrude_z,
    hull,
    polygon,
    union,
)
from . import palette
from .common import SEG_S, SEG_XS, jitter, pick

SUB_TYPES = ("ring_buoy", "life_raft", "rescue_tube", "rescue_can", "life_jacket")
RING_OD = (0.61, 0.65, 0.72, 0.76)  # 24-in USCG; 650 mm and 720/750 mm EN ISO; 30-in USCG


def _r(x: float, nd: int = 3) -> float:
    return round(float(x), nd)


def _col(rng, options, amount=0.04) -> list[int]:
    return list(jitter(pick(rng, options), rng, amount))


# --------------------------------------------------------------------------- drawing

def _draw_ring(rng) -> dict:
    od = float(pick(rng, RING_OD))
    scheme = pick(rng, ("orange", "red", "white_red", "white_red", "orange"))
    body = {"orange": palette.ORANGE, "red": palette.RED, "white_red": palette.WHITE}[scheme]
    return {"outer_diameter": od, "inner_diameter": _r(od * rng.uniform(0.55, 0.60)),
            "thickness": _r(od * rng.uniform(0.13, 0.15)), "scheme": scheme,
            "grab_line": bool(rng.random() < 0.85), "mass": _r(rng.uniform(2.5, 4.0), 2),
            "colours": {"body": list(jitter(body, rng, 0.03)), "band": list(palette.RED),
                        "tape": list(palette.REFLECTIVE), "rope": _col(rng, palette.ROPE)}}


def _draw_raft(rng) -> dict:
    persons = int(pick(rng, (4, 6, 8, 10, 12)))
    diameter = 1.55 + 0.13 * persons * rng.uniform(0.95, 1.05)
    return {"persons": persons, "diameter": _r(diameter),
            "tube_diameter": _r(0.26 + 0.008 * persons), "plan": pick(rng, ("round", "octagon")),
            "canopy": bool(rng.random() < 0.75),
            "canopy_height": _r(rng.uniform(1.05, 1.35)),
            "mass": _r(25 + 5.5 * persons + rng.uniform(0, 15), 1),
            "colours": {"tubes": _col(rng, ((40, 40, 44), (40, 40, 44), palette.ORANGE,
                                            palette.YELLOW, (90, 92, 96))),
                        "canopy": _col(rng, (palette.ORANGE, palette.ORANGE, (230, 70, 25))),
                        "floor": list(palette.DARK_GREY), "door": list(palette.BLACK),
                        "tape": list(palette.REFLECTIVE)}}


def _draw_tube(rng) -> dict:
    return {"length": _r(rng.uniform(0.95, 1.05)), "width": _r(rng.uniform(0.14, 0.16)),
            "thickness": _r(rng.uniform(0.075, 0.095)), "curl": pick(rng, ("straight", "u")),
            "mass": _r(rng.uniform(0.5, 0.8), 2),
            "colours": {"body": _col(rng, (palette.RED, palette.RED, palette.ORANGE,
                                           palette.YELLOW)),
                        "strap": _col(rng, ((30, 30, 32), palette.YELLOW, palette.RED)),
                        "metal": list(palette.STEEL)}}


def _draw_can(rng) -> dict:
    return {"length": _r(rng.uniform(0.64, 0.72)), "width": _r(rng.uniform(0.16, 0.19)),
            "height": _r(rng.uniform(0.13, 0.16)), "mass": _r(rng.uniform(1.0, 1.5), 2),
            "colours": {"body": _col(rng, (palette.RED, palette.RED, palette.ORANGE,
                                           palette.YELLOW)),
                        "strap": _col(rng, ((30, 30, 32), palette.YELLOW))}}


def _draw_jacket(rng) -> dict:
    style = pick(rng, ("vest", "vest", "inflated"))
    return {"style": style, "height": _r(rng.uniform(0.50, 0.62)),
            "width": _r(rng.uniform(0.50, 0.60)),
            "thickness": _r(rng.uniform(0.05, 0.07) if style == "vest"
                            else rng.uniform(0.11, 0.14)),
            "mass": _r(rng.uniform(0.6, 1.1), 2),
            "colours": {"body": _col(rng, (palette.ORANGE, palette.ORANGE, palette.YELLOW,
                                           palette.RED)),
                        "strap": list(palette.BLACK), "tape": list(palette.REFLECTIVE)}}


_DRAW = {"ring_buoy": _draw_ring, "life_raft": _draw_raft, "rescue_tube": _draw_tube,
         "rescue_can": _draw_can, "life_jacket": _draw_jacket}


def draw(rng: np.random.Generator, variant: int) -> dict:
    """The drawn parameters of life-saving appliance ``variant`` (JSON-able; metres, kg)."""
    sub = SUB_TYPES[variant % len(SUB_TYPES)]
    return {"kind": "life_saving_appliances", "sub_type": sub, **_DRAW[sub](rng)}


# --------------------------------------------------------------------------- ring buoy

def _ring(params: dict, p: Painter):
    c = params["colours"]
    od, idm, t = params["outer_diameter"], params["inner_diameter"], params["thickness"]
    rm = (od + idm) / 4
    w = (od - idm) / 4  # half the radial width
    sec = _superellipse(w, t / 2, 12, 3.0)
    n = 36
    path = [(rm * math.cos(a), rm * math.sin(a), 0.0)
            for a in np.linspace(0, 2 * math.pi, n, endpoint=False)]
    ring = sweep(path, sec, closed=True)
    body = p.paint(ring, c["body"])
    if params["scheme"] == "white_red":
        bands = union([_sector(a, 0.42, od) for a in (45, 135, 225, 315)])
        body = p.paint_split(ring, bands, c["band"], c["body"])
    tape = union([_sector(a, 0.10, od) for a in (0, 90, 180, 270)])
    shell = sweep(path, sec * 1.015, closed=True)
    parts = [body, p.paint(shell ^ tape, c["tape"])]
    if params["grab_line"]:
        parts.append(p.paint(_grab_line(od / 2, t), c["rope"]))
    solid = union(parts)
    return solid, waterline_for_mass(ring, params["mass"])


def _superellipse(a: float, b: float, n: int, e: float) -> np.ndarray:
    """(n, 2) points of |u/a|^e + |v/b|^e = 1 (a rounded rectangle for e > 2)."""
    t = np.linspace(0, 2 * math.pi, n, endpoint=False) + math.pi / n
    c, s = np.cos(t), np.sin(t)
    return np.stack([a * np.sign(c) * np.abs(c) ** (2 / e), b * np.sign(s) * np.abs(s) ** (2 / e)],
                    axis=1)


def _sector(angle_deg: float, width_rad: float, od: float) -> m3.Manifold:
    """A wedge about z, centred on ``angle_deg``, ``width_rad`` wide, reaching past ``od``."""
    a = math.radians(angle_deg)
    r = od
    pts = [(0, 0), (r * math.cos(a - width_rad / 2), r * math.sin(a - width_rad / 2)),
           (r * math.cos(a + width_rad / 2), r * math.sin(a + width_rad / 2))]
    return extrude_z(polygon(pts), -1, 1)


def _grab_line(r_out: float, t: float) -> m3.Manifold:
    """A rope in four festoons round the outside, seized to the ring at 45, 135, ... degrees."""
    pts = []
    for a in np.linspace(0, 2 * math.pi, 48, endpoint=False):
        sag = abs(math.sin(2 * (a - math.pi / 4)))
        rad = r_out - 0.006 + 0.06 * sag
        pts.append((rad * math.cos(a), rad * math.sin(a), -0.01 * sag))
    return sweep(pts, ellipse_points(0.006, 0.006, 5), closed=True)


# --------------------------------------------------------------------------- life raft

def _raft(params: dict, p: Painter):
    c = params["colours"]
    d, td = params["diameter"], params["tube_diameter"]
    rm = d / 2 - td / 2
    n = 8 if params["plan"] == "octagon" else 28
    sec = ellipse_points(td / 2, td / 2, 12)
    tubes = []
    for k in range(2):
        z = td / 2 + k * td * 0.92
        path = _ngon_path(rm / math.cos(math.pi / 8), 8, z) if n == 8 else _ngon_path(
            rm, 64, z, samples=28, round_frac=1.0)
        tubes.append(sweep(path, sec, closed=True))
    floor = extrude_z(polygon(ellipse_points(rm, rm, 24)), td * 0.12, td * 0.12 + 0.04)
    tube_solid = union([*tubes, floor])
    parts = [p.paint(union(tubes), c["tubes"]), p.paint(floor, c["floor"])]
    top = td * 1.92
    tape = union([box_between((-d, -0.03, 0), (d, 0.03, 3)),
                  box_between((-0.03, -d, 0), (0.03, d, 3))])
    parts.append(p.paint(tape ^ tubes[1].scale([1.01, 1.01, 1.0]), c["tape"]))
    if params["canopy"]:
        h = params["canopy_height"]
        dome = ellipsoid((rm + td * 0.2, rm + td * 0.2, h), 24, (0, 0, top - 0.1))
        dome = dome ^ box_between((-d, -d, top - 0.1), (d, d, top + h))
        door = box_between((rm * 0.3, -0.35, top - 0.2), (d, 0.35, top + h * 0.75))
        parts.append(p.paint_split(dome, door, c["door"], c["canopy"]))
        arch = sweep([(0.0, rm * math.cos(a), top - 0.1 + h * 1.01 * math.sin(a))
                      for a in np.linspace(0.05, math.pi - 0.05, 16)],
                     ellipse_points(0.09, 0.09, 8), up=(1.0, 0.0, 0.0))
        parts.append(p.paint(arch, c["canopy"]))
        parts.append(p.paint(cylinder_z(0.05, top + h * 0.95, top + h + 0.12, 0, 0, SEG_XS),
                             palette.WHITE))
    else:
        line = sweep(_ngon_path(rm + td * 0.55, 64, top * 0.8, samples=36, round_frac=1.0),
                     ellipse_points(0.008, 0.008, 5), closed=True)
        parts.append(p.paint(line, palette.WHITE))
    return union(parts), waterline_for_mass(tube_solid, params["mass"])


def _ngon_path(r: float, n: int, z: float, samples: int = 40,
               round_frac: float = 0.94) -> list:
    """``samples`` points round a regular ``n``-gon of circumradius ``r`` at height ``z``,
    its corners cut round at ``round_frac`` of the circumradius (metres)."""
    theta = np.linspace(0, 2 * math.pi, samples, endpoint=False)
    sector = 2 * math.pi / n
    rad = r * math.cos(math.pi / n) / np.cos(np.mod(theta, sector) - math.pi / n)
    rad = np.minimum(rad, r * round_frac)
    return [(float(a * math.cos(t)), float(a * math.sin(t)), z) for a, t in zip(rad, theta,
                                                                            strict=True)]


# --------------------------------------------------------------------------- rescue tube

def _tube(params: dict, p: Painter):
    c = params["colours"]
    L, w, t = params["length"], params["width"], params["thickness"]
    sec = _superellipse(w / 2, t / 2, 12, 3.0)
    n = 14
    if params["curl"] == "u":
        r = L / (math.pi + 0.8)
        path = []
        for s in np.linspace(0, L, n):
            if s < 0.4 * r:
                path.append((-r, 0.4 * r - s, 0.0))
            elif s < 0.4 * r + math.pi * r:
                a = math.pi + (s - 0.4 * r) / r
                path.append((r * math.cos(a), r * math.sin(a), 0.0))
            else:
                path.append((r, s - 0.4 * r - math.pi * r, 0.0))
        path = [(x, -y, z) for x, y, z in path]
    else:
        path = [(s - L / 2, 0.03 * math.sin(s * 3), 0.0) for s in np.linspace(0, L, n)]
    body = sweep(path, sec, end_extend=w * 0.25)
    end = np.array(path[-1])
    start = np.array(path[0])
    d_end = (end - np.array(path[-2]))
    d_end /= np.linalg.norm(d_end)
    hook = capsule(end + d_end * 0.04, end + d_end * 0.12, 0.012, 0.012, 6)
    d_start = np.array(path[1]) - start
    ring_pos = start - d_start / np.linalg.norm(d_start) * 0.06
    ring = capsule(ring_pos, ring_pos + [0.0, 0.0, 0.001], 0.02, 0.02, 6)
    # lanyard from the ring end, lying on the water in a lazy curve
    lanyard = [ring_pos + [-0.06 * k, 0.08 * math.sin(k * 0.45), 0.0] for k in range(1, 9)]
    strap = sweep(lanyard, _superellipse(0.012, 0.004, 6, 4.0))
    parts = [p.paint(body, c["body"]), p.paint(union([hook, ring]), c["metal"]),
             p.paint(strap, c["strap"])]
    return union(parts), waterline_for_mass(body, params["mass"])


# --------------------------------------------------------------------------- rescue can

def _can(params: dict, p: Painter):
    c = params["colours"]
    L, w, h = params["length"], params["width"], params["height"]
    core = hull([ellipsoid((L * 0.30, w * 0.27, h / 2), SEG_S, (0.0, 0, 0)),
                 ellipsoid((L * 0.22, w * 0.24, h * 0.42), SEG_S, (L * 0.28, 0, 0)),
                 ellipsoid((L * 0.18, w * 0.22, h * 0.40), SEG_S, (-L * 0.32, 0, 0))])
    flange = extrude_z(polygon(ellipse_points(L * 0.42, w / 2, 24)), -h * 0.12, h * 0.12)
    holes = [extrude_z(polygon(ellipse_points(0.05, 0.012, 10) + [x, s * (w / 2 - 0.027)]),
                       -h, h) for x in (-0.17 * L / 0.68, 0.0, 0.17 * L / 0.68) for s in (1, -1)]
    body = union([core, flange]) - union(holes)
    strap = capsule((-L / 2 - 0.02, 0, 0), (-L / 2 - 0.15, 0.04, -0.005), 0.01, 0.01, 6)
    solid = union([p.paint(body, c["body"]), p.paint(strap, c["strap"])])
    return solid, waterline_for_mass(body, params["mass"])


# --------------------------------------------------------------------------- life jacket

def _jacket(params: dict, p: Painter):
    c = params["colours"]
    h, w, t = params["height"], params["width"], params["thickness"]
    if params["style"] == "vest":
        outline = [(-h / 2, -w / 2), (h * 0.18, -w / 2), (h * 0.25, -w * 0.30),
                   (h / 2, -w * 0.30), (h / 2, -w * 0.12), (h * 0.30, -w * 0.07),
                   (h * 0.30, w * 0.07), (h / 2, w * 0.12), (h / 2, w * 0.30),
                   (h * 0.25, w * 0.30), (h * 0.18, w / 2), (-h / 2, w / 2)]
        cs = polygon(outline, round_r=0.03, segments=6)
        body = extrude_z(cs, -t / 2, t / 2)
        straps = union([box_between((x - 0.02, -w / 2 - 0.005, t / 2 - 0.004),
                                    (x + 0.02, w / 2 + 0.005, t / 2 + 0.006))
                        for x in (-0.3 * h, 0.0)])
        zip_line = box_between((-h / 2, -0.008, t / 2 - 0.003), (h * 0.30, 0.008, t / 2 + 0.004))
        tape = union([box_at((h * 0.09, w * 0.16, 0.008), (h * 0.425, s * w * 0.21, t / 2))
                      for s in (1, -1)])
        parts = [p.paint(body, c["body"]), p.paint(union([straps, zip_line]), c["strap"]),
                 p.paint(tape ^ box_between((-1, -1, -1), (1, 1, 1)), c["tape"])]
        float_body = body
    else:
        r = t / 2
        path = []
        for a in np.linspace(-0.62 * math.pi, 0.62 * math.pi, 15):
            rad = w * 0.32 if abs(a) < 0.35 * math.pi else w * 0.36
            path.append((rad * math.cos(a) * 0.9 + h * 0.1, rad * math.sin(a), 0.0))
        lobes = [ellipsoid((h * 0.28, w * 0.14, r), SEG_S, (-h * 0.2, s * w * 0.22, 0))
                 for s in (1, -1)]
        collar = sweep(path, ellipse_points(r, r, 10), end_extend=r * 0.5)
        body = union([collar, *lobes])
        belt = sweep([(-h * 0.45, -w * 0.55, 0.0), (-h * 0.5, 0.0, 0.01), (-h * 0.45, w * 0.55,
                                                                             0.0)],
                     _superellipse(0.02, 0.004, 6, 4.0))
        tape = box_between((h * 0.05, -w, r * 0.6), (h * 0.2, w, r * 2))
        parts = [p.paint_split(body, tape, c["tape"], c["body"]), p.paint(belt, c["strap"])]
        float_body = body
    return union(parts), waterline_for_mass(float_body, params["mass"])


_MAKE = {"ring_buoy": _ring, "life_raft": _raft, "rescue_tube": _tube, "rescue_can": _can,
         "life_jacket": _jacket}


def make(params: dict, name: str) -> ColoredMesh:
    """Build the appliance described by ``params`` (from :func:`draw`)."""
    p = Painter()
    solid, wl = _MAKE[params["sub_type"]](params, p)
    return p.finish(solid, wl, name)
