"""Boats: motor boats, rescue RIBs, sailboats, cabin cruisers, rowing boats, kayaks and canoes.

This module draws a variant's parameters (:func:`draw`) and builds its mesh (:func:`make`);
the decked boats are made in :mod:`~sdcomp.assets.sar.boat_decked`, the open ones (rowing
boats, kayaks, canoes, with their crews) in :mod:`~sdcomp.assets.sar.boat_open`. Every boat
is a lofted hull (:mod:`~sdcomp.assets.sar.hull`) plus deck, cockpit, superstructure and
engines. The waterline comes from a mass balance: the boat's loaded mass (drawn from a
per-type range, kg) divided by the density of sea water is the volume the closed outer hull
displaces below it (:func:`sdcomp.assets.flotation.waterline_for_mass`); :func:`draft` is
the resulting hull draft (keel to waterline, without fin keels, rudders or engine legs).

Frame: metres, x forward, y port, z up; built with the keel amidships at z = 0, then centred
on the bounding box by :meth:`~sdcomp.assets.solids.Painter.finish`.
"""

from __future__ import annotations

import numpy as np

from ..mesh import ColoredMesh
from ..solids import Painter
from . import boat_decked, boat_open, palette
from .common import jitter, pick, rng_for

SUB_TYPES = ("motorboat", "rib", "sailboat", "cabin_cruiser", "rowing", "paddle")
#: the sub-type of variant ``v`` is ``SUB_TYPE_CYCLE[v % len(SUB_TYPE_CYCLE)]``: weighted as
#: boats on a lake or coast in summer are seen from a drone, decked motor and sail boats most
#: (motorboats 4 in 12, sailboats and cabin cruisers 2 each), rescue and tender RIBs 2, a
#: rowing boat and a kayak or canoe one each
SUB_TYPE_CYCLE = ("motorboat", "rib", "sailboat", "cabin_cruiser", "rowing", "paddle",
                  "motorboat", "rib", "sailboat", "cabin_cruiser", "motorboat", "motorboat")


def _r(x: float, nd: int = 3) -> float:
    return round(float(x), nd)


def _col(rng, options, amount=0.05) -> list[int]:
    return list(jitter(pick(rng, options), rng, amount))


# --------------------------------------------------------------------------- drawing

def _draw_motorboat(rng) -> dict:
    length = rng.uniform(4.5, 9.0)
    style = pick(rng, ("console", "bowrider", "cuddy"))
    return {
        "length": _r(length), "beam": _r(length * rng.uniform(0.34, 0.40) + 0.35),
        "depth": _r(0.75 + 0.075 * length * rng.uniform(0.9, 1.1)),
        "deadrise": _r(rng.uniform(16, 22), 1), "style": style,
        "engines": 1 if length < 7 else int(rng.integers(1, 3)),
        "t_top": bool(style == "console" and rng.random() < 0.5),
        "mass": _r(rng.uniform(7.0, 10.0) * length ** 3 * 0.85 + 150, 0),
        "antifouling": bool(rng.random() < 0.4),
        "colours": {"hull": _col(rng, palette.HULLS), "bottom": _col(rng, palette.ANTIFOULING),
                    "deck": _col(rng, palette.DECKS, 0.03), "sole": _col(rng, palette.DECKS),
                    "console": list(palette.WHITE), "cushion": _col(rng, palette.SEAT_CUSHIONS),
                    "engine": _col(rng, palette.ENGINE, 0.03),
                    "canvas": _col(rng, palette.CANVAS)},
    }


def _draw_rib(rng) -> dict:
    length = rng.uniform(4.0, 8.5)
    tube_d = 0.40 + 0.02 * length * rng.uniform(0.9, 1.2)
    rescue = bool(rng.random() < 0.5)
    tubes = list(palette.ORANGE) if rescue else _col(rng, palette.RIB_TUBES, 0.03)
    return {
        "length": _r(length), "beam": _r(1.25 + 0.17 * length * rng.uniform(0.95, 1.1)),
        "tube_diameter": _r(tube_d), "deadrise": _r(rng.uniform(20, 26), 1),
        "engines": 1 if length < 7 else 2, "a_frame": bool(rng.random() < 0.6),
        "mass": _r(30 * length ** 2 * rng.uniform(0.85, 1.15) + 100, 0), "rescue": rescue,
        "colours": {"tubes": tubes, "hull": _col(rng, ((238, 238, 232), (90, 92, 96),
                                                       (40, 42, 46))),
                    "sole": list(palette.DARK_GREY), "console": _col(rng, ((238, 238, 232),
                                                                          (90, 92, 96))),
                    "engine": _col(rng, palette.ENGINE, 0.03), "seat": list(palette.BLACK),
                    "frame": list(palette.STEEL)},
    }


def _draw_sailboat(rng) -> dict:
    length = rng.uniform(5.5, 12.0)
    return {
        "length": _r(length), "beam": _r(length * rng.uniform(0.30, 0.35) + 0.2),
        "depth": _r(0.55 + 0.06 * length), "keel_depth": _r(0.75 + 0.09 * length),
        "mast": _r(length * rng.uniform(1.15, 1.35)),
        "sail": pick(rng, ("furled", "furled", "main", "main_jib")),
        "sail_angle": _r(rng.uniform(-30, 30), 1),
        "mass": _r(4.2 * length ** 3 * rng.uniform(0.85, 1.15), 0),
        "colours": {"hull": _col(rng, palette.HULLS), "bottom": _col(rng, palette.ANTIFOULING),
                    "deck": _col(rng, palette.DECKS, 0.03), "cockpit": list(palette.TEAK),
                    "cover": _col(rng, palette.CANVAS), "mast": list(palette.MAST),
                    "sail": list(palette.SAIL), "window": list(palette.GLASS)},
    }


def _draw_cabin_cruiser(rng) -> dict:
    length = rng.uniform(7.0, 12.0)
    return {
        "length": _r(length), "beam": _r(length * rng.uniform(0.30, 0.34) + 0.3),
        "depth": _r(1.0 + 0.08 * length), "deadrise": _r(rng.uniform(14, 20), 1),
        "flybridge": bool(length > 9.0 and rng.random() < 0.6),
        "mass": _r(5.0 * length ** 3 * rng.uniform(0.85, 1.15), 0),
        "colours": {"hull": _col(rng, palette.HULLS), "bottom": _col(rng, palette.ANTIFOULING),
                    "deck": _col(rng, palette.DECKS, 0.03), "cabin": list(palette.WHITE),
                    "window": list(palette.GLASS), "cockpit": _col(rng, (palette.TEAK,
                                                                        (200, 200, 195))),
                    "canvas": _col(rng, palette.CANVAS), "cushion": _col(rng,
                                                                        palette.SEAT_CUSHIONS)},
    }


def _draw_rowing(rng) -> dict:
    length = rng.uniform(2.5, 4.6)
    wooden = bool(rng.random() < 0.4)
    hull = list(palette.WOOD) if wooden else _col(rng, ((238, 238, 232), (30, 100, 60),
                                                         (40, 80, 150), (200, 60, 40),
                                                         (90, 95, 100)))
    return {
        "length": _r(length), "beam": _r(0.9 + 0.14 * length * rng.uniform(0.95, 1.1)),
        "depth": _r(rng.uniform(0.42, 0.58)), "shape": pick(rng, ("round", "v")),
        "oars": pick(rng, ("out", "in", "none")), "rower": bool(rng.random() < 0.5),
        "mass": _r(25 * length + rng.uniform(60, 180), 0),
        "colours": {"hull": hull, "inside": _col(rng, ((225, 222, 210), palette.WOOD)),
                    "thwart": list(palette.WOOD), "oar": _col(rng, (palette.WOOD,
                                                                    (200, 200, 195)))},
    }


def _draw_paddle(rng) -> dict:
    canoe = bool(rng.random() < 0.4)
    if canoe:
        length = rng.uniform(4.3, 5.5)
        beam = rng.uniform(0.80, 0.95)
        depth = rng.uniform(0.33, 0.38)
        crew = int(rng.integers(0, 3))
    else:
        length = rng.uniform(2.7, 5.3)
        beam = float(np.interp(length, [2.7, 5.3], [0.78, 0.56])) * rng.uniform(0.95, 1.05)
        depth = rng.uniform(0.30, 0.36)
        crew = int(rng.random() < 0.75)
    return {
        "craft": "canoe" if canoe else pick(rng, ("sit_in", "sit_on_top")),
        "length": _r(length), "beam": _r(beam), "depth": _r(depth), "crew": crew,
        "mass": _r(20 + 4 * length + crew * rng.uniform(70, 95), 0),
        "colours": {"hull": _col(rng, palette.KAYAKS), "cockpit": list(palette.BLACK),
                    "paddle": _col(rng, ((30, 30, 32), (240, 200, 30), (200, 40, 40),
                                         (235, 235, 230))),
                    "thwart": list(palette.WOOD)},
    }


def _draw_crew(rng, n: int) -> list[dict]:
    """Seated people: skin, clothes, life vest colours and size."""
    crew = []
    for _ in range(n):
        crew.append({
            "stature": _r(np.clip(rng.normal(1.72, 0.08), 1.55, 1.95)),
            "skin": list(jitter(palette.skin(int(rng.integers(10))), rng, 0.04)),
            "shirt": _col(rng, palette.SHIRTS), "trousers": _col(rng, palette.TROUSERS),
            "vest": _col(rng, palette.VESTS) if rng.random() < 0.7 else None,
            "hair": list(palette.wet_hair(pick(rng, palette.HAIR))),
            "hat": _col(rng, palette.SWIM_CAPS) if rng.random() < 0.3 else None,
        })
    return crew


_DRAW = {"motorboat": _draw_motorboat, "rib": _draw_rib, "sailboat": _draw_sailboat,
         "cabin_cruiser": _draw_cabin_cruiser, "rowing": _draw_rowing, "paddle": _draw_paddle}


#: people aboard a decked boat: (chance of 0, 1, 2, ... seated people) per sub-type, as
#: boats out on a lake or coast in summer carry them (leisure boats mostly two or three,
#: a rescue RIB its crew of one to three)
ABOARD = {"motorboat": (0.15, 0.25, 0.30, 0.20, 0.10), "rib": (0.0, 0.4, 0.4, 0.2),
          "cabin_cruiser": (0.3, 0.3, 0.3, 0.1), "sailboat": (0.3, 0.4, 0.3)}
#: a motor boat without a T-top has a bimini (a canvas sun top over the cockpit) on 3 in 5;
#: its canvas colour the motor boat's turn in this cycle (its count among the variants
#: before it), ordered so that any few variants show the common colours first: navy most,
#: then grey, white, tan and black, burgundy, red and the pink of lake rental boats once
BIMINI_SHARE = 0.6
BIMINI: tuple[tuple[int, int, int], ...] = (
    (35, 50, 95), (150, 150, 148), (225, 225, 218), (35, 50, 95), (190, 176, 142),
    (35, 35, 38), (150, 150, 148), (35, 50, 95), (120, 35, 45), (225, 225, 218),
    (195, 35, 40), (220, 45, 120),
)


def draw(rng: np.random.Generator, variant: int) -> dict:
    """The drawn parameters of boat ``variant`` (JSON-able; metres, kg, degrees, sRGB).

    The people aboard a decked boat and a motor boat's bimini come from a generator of
    their own (``boat-aboard``, variant): the hull and its fittings are drawn as before."""
    sub = SUB_TYPE_CYCLE[variant % len(SUB_TYPE_CYCLE)]
    params = {"kind": "boat", "sub_type": sub, **_DRAW[sub](rng)}
    n_crew = {"rowing": int(params.get("rower", False)),
              "paddle": params.get("crew", 0)}.get(sub, 0)
    params["people"] = _draw_crew(rng, n_crew)
    if sub in ABOARD:
        aboard = rng_for("boat-aboard", variant)
        share = np.asarray(ABOARD[sub])
        params["people"] = _draw_crew(aboard, int(aboard.choice(len(share),
                                                                 p=share / share.sum())))
        if sub == "motorboat":
            top = not params["t_top"] and aboard.random() < BIMINI_SHARE
            turn = SUB_TYPE_CYCLE[:variant % len(SUB_TYPE_CYCLE)].count("motorboat")
            turn += variant // len(SUB_TYPE_CYCLE) * SUB_TYPE_CYCLE.count("motorboat")
            canvas = BIMINI[turn % len(BIMINI)]
            params["bimini"] = list(jitter(canvas, aboard, 0.04)) if top else None
    return params


# --------------------------------------------------------------------------- building

_MAKE = {"motorboat": boat_decked.motorboat, "rib": boat_decked.rib,
         "sailboat": boat_decked.sailboat, "cabin_cruiser": boat_decked.cabin_cruiser,
         "rowing": boat_open.rowing, "paddle": boat_open.paddle}


def make(params: dict, name: str) -> ColoredMesh:
    """Build the boat described by ``params`` (from :func:`draw`)."""
    p = Painter()
    solid, wl = _MAKE[params["sub_type"]](params, p)
    return p.finish(solid, wl, name)


def draft(params: dict) -> float:
    """Hull draft (metres, keel to waterline; without fin keels, rudders, engine legs)."""
    _, wl = _MAKE[params["sub_type"]](params, Painter())
    return float(wl)  # the keel is at z = 0 in the build frame
