"""Buoys: channel can/nun buoys, pillar buoys with topmarks, spar buoys, spherical mooring
buoys and swim-area / race markers.

Sub-types (``params["sub_type"]``, cycling with the variant index):

- ``can``: a lateral mark, cylindrical (can, port hand in IALA region A: red) or with a
  conical top (nun/cone, starboard: green), sometimes with a small topmark of its shape.
- ``sphere``: a spherical mooring buoy 0.4-1.2 m across, with a steel eye or a through rod
  and sometimes a white or reflective band.
- ``spar``: a ballasted pole 2.5-4 m long standing upright, most of it under water, coloured
  top, optional topmark.
- ``marker``: a swim-area or race marker: a small yellow/orange sphere, or a large inflatable
  cylinder or pyramid (triathlon turn buoys).
- ``pillar``: an IALA pillar buoy: float body, lattice superstructure and topmark, in a
  lateral, cardinal, special-mark, safe-water or isolated-danger scheme.

Heights above water follow the submerged volume fraction drawn per sub-type (ballast and
mooring load make these buoys float deeper than their material would).
"""

from __future__ import annotations

import math

import manifold3d as m3
import numpy as np

from ..flotation import waterline_for_fraction
from ..mesh import ColoredMesh
from ..solids import Painter, box_between, cylinder, cylinder_z, revolve, sphere, union
from . import palette
from .common import SEG, SEG_S, SEG_XS, jitter, pick

SUB_TYPES = ("can", "sphere", "spar", "marker", "pillar")
BLACK = palette.BLACK
SCHEMES = {  # body bands bottom to top, topmark shape, topmark colour
    "port": ((palette.RED,), "can", palette.RED),
    "starboard": ((palette.GREEN,), "cone_up", palette.GREEN),
    "north": ((palette.YELLOW, BLACK), "cones_up", BLACK),
    "south": ((BLACK, palette.YELLOW), "cones_down", BLACK),
    "east": ((BLACK, palette.YELLOW, BLACK), "cones_apart", BLACK),
    "west": ((palette.YELLOW, BLACK, palette.YELLOW), "cones_together", BLACK),
    "special": ((palette.YELLOW,), "cross", palette.YELLOW),
    "safe_water": ((palette.RED, palette.WHITE), "sphere", palette.RED),
    "isolated_danger": ((BLACK, palette.RED, BLACK), "spheres", BLACK),
}


def _r(x: float, nd: int = 3) -> float:
    return round(float(x), nd)


def _col(rng, options, amount=0.04) -> list[int]:
    return list(jitter(pick(rng, options), rng, amount))


# --------------------------------------------------------------------------- drawing

def _scheme(rng, scheme: str) -> dict:
    """The scheme's band and topmark colours, each weathered a little (+-5 %)."""
    bands, _, mark = SCHEMES[scheme]
    return {"bands": [list(jitter(b, rng, 0.05)) for b in bands],
            "topmark": list(jitter(mark, rng, 0.05))}


def _draw_can(rng) -> dict:
    side = pick(rng, ("port", "starboard", "special"))
    shape = {"port": "can", "starboard": "nun", "special": pick(rng, ("can", "nun"))}[side]
    d = rng.uniform(0.45, 1.0)
    return {"scheme": side, "shape": shape, "diameter": _r(d),
            "height": _r(d * rng.uniform(1.3, 1.8)), "topmark": bool(rng.random() < 0.5),
            "submerged_fraction": _r(rng.uniform(0.45, 0.6), 2), "colours": _scheme(rng, side)}


def _draw_sphere(rng) -> dict:
    return {"diameter": _r(rng.uniform(0.4, 1.2)),
            "fitting": pick(rng, ("eye", "eye", "rod")),
            "band": pick(rng, ("none", "white", "reflective")),
            "submerged_fraction": _r(rng.uniform(0.35, 0.55), 2),
            "colours": {"body": _col(rng, (palette.WHITE, palette.ORANGE, palette.YELLOW,
                                           palette.RED, (30, 80, 170), (235, 110, 160)))}}


def _draw_spar(rng) -> dict:
    scheme = pick(rng, ("port", "starboard", "special", "north", "south"))
    return {"scheme": scheme,
            "length": _r(rng.uniform(2.5, 4.0)), "diameter": _r(rng.uniform(0.2, 0.4)),
            "topmark": bool(rng.random() < 0.6),
            "submerged_fraction": _r(rng.uniform(0.55, 0.68), 2), "colours": _scheme(rng, scheme)}


def _draw_marker(rng) -> dict:
    shape = pick(rng, ("small_sphere", "small_sphere", "cylinder", "pyramid"))
    size = {"small_sphere": (0.25, 0.45), "cylinder": (1.0, 1.5), "pyramid": (1.2, 1.8)}[shape]
    d = rng.uniform(*size)
    return {"shape": shape, "diameter": _r(d),
            "height": _r(d if shape == "small_sphere" else d * rng.uniform(1.3, 1.7)),
            "submerged_fraction": _r(rng.uniform(0.3, 0.45) if shape == "small_sphere"
                                     else rng.uniform(0.08, 0.15), 2),
            "colours": {"body": _col(rng, (palette.YELLOW, palette.ORANGE, (245, 140, 20))),
                        "band": _col(rng, (palette.WHITE, palette.BLACK, (30, 80, 170)))}}


def _draw_pillar(rng) -> dict:
    d = rng.uniform(1.2, 1.8)
    scheme = pick(rng, tuple(SCHEMES))
    return {"scheme": scheme, "colours": _scheme(rng, scheme), "diameter": _r(d),
            "body_height": _r(d * rng.uniform(0.55, 0.75)),
            "tower": _r(rng.uniform(1.6, 2.6)), "tail": _r(rng.uniform(0.8, 1.6)),
            "submerged_fraction": _r(rng.uniform(0.45, 0.55), 2)}


_DRAW = {"can": _draw_can, "sphere": _draw_sphere, "spar": _draw_spar, "marker": _draw_marker,
         "pillar": _draw_pillar}


def draw(rng: np.random.Generator, variant: int) -> dict:
    """The drawn parameters of buoy ``variant`` (JSON-able; metres, sRGB)."""
    sub = SUB_TYPES[variant % len(SUB_TYPES)]
    return {"kind": "buoy", "sub_type": sub, **_DRAW[sub](rng)}


# --------------------------------------------------------------------------- shared parts

def _bands(p: Painter, solid: m3.Manifold, colours, z0: float, z1: float,
           vertical: bool = False) -> m3.Manifold:
    """``solid`` painted in equal horizontal bands of ``colours`` between z0 and z1 (bottom to
    top; below z0 the first colour, above z1 the last), or in vertical stripes (safe water)."""
    if len(colours) == 1:
        return p.paint(solid, colours[0])
    if vertical:
        return p.paint_split(solid, _sectors(4), colours[0], colours[1])
    parts = []
    edges = np.linspace(z0, z1, len(colours) + 1)
    edges[0], edges[-1] = -100.0, 100.0
    for k, colour in enumerate(colours):
        piece = solid ^ box_between((-100, -100, edges[k]), (100, 100, edges[k + 1]))
        if not piece.is_empty():
            parts.append(p.paint(piece, colour))
    return union(parts)


def _sectors(n: int) -> m3.Manifold:
    """Every other one of 2n equal wedges about the z axis (vertical stripes)."""
    wedges = []
    for k in range(n):
        a0 = 2 * math.pi * (2 * k) / (2 * n)
        a1 = 2 * math.pi * (2 * k + 1) / (2 * n)
        pts = [(0.0, 0.0)] + [(50 * math.cos(a), 50 * math.sin(a))
                              for a in np.linspace(a0, a1, 4)]
        wedges.append(m3.CrossSection([np.array(pts)]).extrude(200).translate([0, 0, -100]))
    return union(wedges)


def _topmark(p: Painter, kind: str, colour, z: float, size: float) -> m3.Manifold:
    """An IALA topmark of ``size`` (metres across) standing on a short post from ``z``."""
    post = cylinder_z(size * 0.06, z, z + size * 0.5, 0, 0, SEG_XS)
    zc = z + size * 0.5
    r = size / 2

    def cone(z0, up):
        return m3.Manifold.cylinder(size * 0.8, r if up else 0.0, 0.0 if up else r, SEG_S) \
            .translate([0, 0, z0])

    if kind == "can":
        shape = cylinder_z(r * 0.8, zc, zc + size, 0, 0, SEG_S)
    elif kind == "cone_up":
        shape = cone(zc, True)
    elif kind == "cones_up":
        shape = union([cone(zc, True), cone(zc + size * 0.95, True)])
    elif kind == "cones_down":
        shape = union([cone(zc, False), cone(zc + size * 0.95, False)])
    elif kind == "cones_apart":  # east: base to base
        shape = union([cone(zc, False), cone(zc + size * 0.85, True)])
    elif kind == "cones_together":  # west: point to point
        shape = union([cone(zc, True), cone(zc + size * 0.85, False)])
    elif kind == "cross":
        bar = box_between((-r, -size * 0.06, -size * 0.06), (r, size * 0.06, size * 0.06))
        shape = union([bar.rotate([0, 45, 0]), bar.rotate([0, -45, 0])]).translate(
            [0, 0, zc + r])
    elif kind == "sphere":
        shape = sphere((0, 0, zc + r * 0.9), r * 0.9, SEG_S)
    else:  # two spheres
        shape = union([sphere((0, 0, zc + r * 0.8), r * 0.75, SEG_S),
                       sphere((0, 0, zc + r * 2.5), r * 0.75, SEG_S)])
    return union([p.paint(post, palette.DARK_GREY), p.paint(shape, colour)])


# --------------------------------------------------------------------------- can / nun

def _can(params: dict, p: Painter):
    d, h = params["diameter"], params["height"]
    r = d / 2
    if params["shape"] == "can":
        prof = [(0, -h * 0.5), (r * 0.85, -h * 0.5), (r, -h * 0.42), (r, h * 0.5),
                (0, h * 0.5)]
    else:
        prof = [(0, -h * 0.5), (r * 0.85, -h * 0.5), (r, -h * 0.42), (r, h * 0.1),
                (r * 0.12, h * 0.5), (0, h * 0.5)]
    body = revolve(prof, SEG)
    wl = waterline_for_fraction(body, params["submerged_fraction"])
    colours, mark_colour = params["colours"]["bands"], params["colours"]["topmark"]
    parts = [_bands(p, body, colours, wl, h / 2)]
    # lifting eye / radar-reflector stub on top, mooring eye below
    top = h * 0.5
    parts.append(p.paint(union([cylinder_z(0.03, top - 0.02, top + 0.08, 0, 0, SEG_XS),
                                cylinder_z(0.04, -h * 0.5 - 0.1, -h * 0.5 + 0.02, 0, 0, SEG_XS)]),
                         palette.DARK_GREY))
    if params["topmark"]:
        kind = "can" if params["shape"] == "can" else "cone_up"
        parts.append(_topmark(p, kind, mark_colour, top + 0.05, d * 0.4))
    return union(parts), wl


# --------------------------------------------------------------------------- sphere

def _sphere(params: dict, p: Painter):
    d = params["diameter"]
    r = d / 2
    c = params["colours"]
    ball = sphere((0, 0, 0), r, 28)
    wl = waterline_for_fraction(ball, params["submerged_fraction"])
    band = params["band"]
    if band == "none":
        body = p.paint(ball, c["body"])
    else:
        colour = palette.REFLECTIVE if band == "reflective" else palette.WHITE
        if band == "white" and c["body"][0] > 200 and c["body"][2] > 200:  # white body
            colour = (30, 80, 170)
        region = box_between((-r * 2, -r * 2, r * 0.25), (r * 2, r * 2, r * 0.45))
        body = p.paint_split(ball, region, colour, c["body"])
    parts = [body]
    if params["fitting"] == "eye":
        pad = cylinder_z(r * 0.2, r * 0.8, r + 0.03, 0, 0, SEG_XS)
        eye = _eye(r + 0.03 + r * 0.12, r * 0.12, 0.012 + r * 0.015)
        parts.append(p.paint(union([pad, eye]), palette.STEEL))
    else:
        rod = cylinder_z(0.02 + r * 0.02, -r - 0.15, r + 0.15, 0, 0, SEG_XS)
        rings = [_eye(r + 0.15 + 0.06, 0.06, 0.014), _eye(-r - 0.15 - 0.06, 0.06, 0.014)]
        parts.append(p.paint(union([rod, *rings]), palette.STEEL))
    return union(parts), wl


def _eye(z: float, radius: float, bar: float) -> m3.Manifold:
    """A steel ring (torus) standing in the x-z plane, centred at height ``z``."""
    return (m3.CrossSection.circle(bar, 6).translate([radius, 0]).revolve(12)
            .rotate([90, 0, 0]).translate([0, 0, z]))


# --------------------------------------------------------------------------- spar

def _spar(params: dict, p: Painter):
    L, d = params["length"], params["diameter"]
    pole = union([cylinder_z(d / 2, -L / 2 + d * 0.3, L / 2 - d * 0.2, 0, 0, SEG_S),
                  sphere((0, 0, -L / 2 + d * 0.3), d / 2, SEG_S).scale([1, 1, 0.6])
                  .translate([0, 0, (-L / 2 + d * 0.3) * 0.4]),
                  cylinder_z(d / 2, L / 2 - d * 0.2, L / 2, 0, 0, SEG_S, d * 0.35)])
    wl = waterline_for_fraction(pole, params["submerged_fraction"])
    mark = SCHEMES[params["scheme"]][1]
    colours, mark_colour = params["colours"]["bands"], params["colours"]["topmark"]
    z_top = L / 2
    painted = _bands(p, pole, colours, wl, z_top)
    below = box_between((-5, -5, -50), (5, 5, wl - 0.3))
    parts = [painted - p.paint(below, palette.DARK_GREY), p.paint(pole ^ below, palette.DARK_GREY)]
    if params["topmark"]:
        parts.append(_topmark(p, mark, mark_colour, z_top, max(0.3, d * 1.2)))
    return union(parts), wl


# --------------------------------------------------------------------------- markers

def _marker(params: dict, p: Painter):
    c = params["colours"]
    d, h = params["diameter"], params["height"]
    shape = params["shape"]
    if shape == "small_sphere":
        body = sphere((0, 0, 0), d / 2, 20)
        wl = waterline_for_fraction(body, params["submerged_fraction"])
        eye = _eye(d / 2 + 0.03, 0.03, 0.008)
        rope = cylinder((0, 0, -d / 2 - 0.3), (0, 0, -d / 2 + 0.01), 0.006, None, 5)
        solid = union([p.paint(body, c["body"]), p.paint(union([eye, rope]), palette.STEEL)])
        return solid, wl
    if shape == "cylinder":
        r = d / 2
        prof = [(0, 0), (r * 0.9, 0), (r, 0.08), (r, h - 0.1), (r * 0.9, h), (0, h)]
        body = revolve(prof, 28)
    else:
        body = m3.Manifold.cylinder(h, d / 2 * 1.2, 0.05, 4).rotate([0, 0, 45])
        body = body ^ box_between((-d, -d, 0), (d, d, h * 0.97))
    # ballast skirt: a water bag under the buoy
    skirt = cylinder_z(d * 0.3, -0.35, 0.02, 0, 0, SEG_S)
    wl = waterline_for_fraction(union([body, skirt]), params["submerged_fraction"])
    band = box_between((-d, -d, h * 0.55), (d, d, h * 0.68))
    parts = [p.paint_split(body, band, c["band"], c["body"]), p.paint(skirt, c["body"])]
    return union(parts), wl


# --------------------------------------------------------------------------- pillar

def _pillar(params: dict, p: Painter):
    d, bh = params["diameter"], params["body_height"]
    tower, tail = params["tower"], params["tail"]
    r = d / 2
    prof = [(0, -bh * 0.5), (r * 0.75, -bh * 0.5), (r, -bh * 0.2), (r, bh * 0.35),
            (r * 0.8, bh * 0.5), (0, bh * 0.5)]
    body = revolve(prof, 28)
    tail_tube = cylinder_z(0.11, -bh * 0.5 - tail, -bh * 0.45, 0, 0, SEG_S)
    float_body = union([body, tail_tube])
    wl = waterline_for_fraction(float_body, params["submerged_fraction"])
    mark = SCHEMES[params["scheme"]][1]
    colours, mark_colour = params["colours"]["bands"], params["colours"]["topmark"]
    vertical = params["scheme"] == "safe_water"
    top = bh * 0.5
    # lattice superstructure: four legs leaning in, two rings, a solid day-mark panel band
    legs = []
    for k in range(4):
        a = math.pi / 4 + k * math.pi / 2
        base = (r * 0.55 * math.cos(a), r * 0.55 * math.sin(a), top - 0.05)
        head = (r * 0.22 * math.cos(a), r * 0.22 * math.sin(a), top + tower)
        legs.append(cylinder(base, head, 0.035, 0.03, 6))
    panel = m3.Manifold.cylinder(tower * 0.55, r * 0.48, r * 0.3, SEG_S).translate(
        [0, 0, top + tower * 0.3])
    super_body = union([*legs, panel])
    superstructure = _bands(p, super_body, colours, top, top + tower, vertical)
    lantern = cylinder_z(0.09, top + tower, top + tower + 0.25, 0, 0, SEG_XS)
    parts = [_bands(p, body, colours, wl, top, vertical), superstructure,
             p.paint(tail_tube, palette.DARK_GREY), p.paint(lantern, palette.DARK_GREY),
             _topmark(p, mark, mark_colour, top + tower + 0.25, 0.45)]
    return union(parts), wl


_MAKE = {"can": _can, "sphere": _sphere, "spar": _spar, "marker": _marker, "pillar": _pillar}


def make(params: dict, name: str) -> ColoredMesh:
    """Build the buoy described by ``params`` (from :func:`draw`)."""
    p = Painter()
    solid, wl = _MAKE[params["sub_type"]](params, p)
    return p.finish(solid, wl, name)
