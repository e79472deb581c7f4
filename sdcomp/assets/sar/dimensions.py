"""Real-world dimensions the variants are drawn within, with their sources.

``REAL[(kind, sub_type)][measure] = (lo, hi, source)``, metres unless the measure says
otherwise. The tests (``tests/test_sar_dimensions.py``) check every variant's parameters and mesh
extents against these ranges; how each measure is taken from a mesh is written next to it
(``MEASURES``).

Sources marked "(verified)" were checked against the quoted document during this work; the
others are manufacturers' published figures or standard references quoted from memory (no web
access besides a small search index), rounded, and the ranges are set wide enough to hold
the whole class, not one model.
"""

from __future__ import annotations

ANSUR = ("ANSUR II 2012 (Gordon et al. 2014, US Army NATICK/TR-15/007) means +- ~2.5 SD: "
         "stature W 1629 / M 1756 mm; biacromial W 366 / M 415 mm; head breadth W 147 / M "
         "155 mm; head length W 189 / M 199 mm")
WINTER = ("segment lengths as fractions of stature: Drillis & Contini (1966) via Winter, "
          "Biomechanics and Motor Control of Human Movement, 2009")

MEASURES = {
    "stature": "params body.stature",
    "biacromial": "params body.shoulders (acromion to acromion)",
    "head_breadth": "params body.head_breadth",
    "span": "largest mesh extent (pose dependent)",
    "length": "mesh x extent (overall, with engines, nozzles, overhangs)",
    "beam": "params beam/width (hull or tubes, without oars)",
    "width": "mesh y extent",
    "height": "mesh z extent",
    "diameter": "largest horizontal mesh extent",
    "draft": "waterline minus the hull's keel (without fin keels, rudders, engine legs)",
    "outer_diameter": "params outer_diameter",
    "hull_length": "params length (hull / body only)",
}

REAL: dict[tuple[str, str], dict[str, tuple[float, float, str]]] = {
    # ----------------------------------------------------------------- swimmer
    ("swimmer", "*"): {
        "stature": (1.50, 1.95, ANSUR),
        "biacromial": (0.32, 0.46, ANSUR),
        "head_breadth": (0.135, 0.170, ANSUR),
        "span": (1.0, 2.6, "stature plus reach overhead (" + WINTER + ")"),
    },
    # ----------------------------------------------------------------- boats
    ("boat", "motorboat"): {
        "length": (4.5, 10.0, "trailerable centre consoles, bowriders and cuddies 4.5-9 m "
                              "hull (e.g. Boston Whaler 170 Montauk 5.2 x 2.1 m; Quicksilver "
                              "Activ 555 5.5 x 2.3 m) plus up to 0.9 m of outboard"),
        "beam": (1.9, 3.6, "beam ~0.34-0.40 L + 0.35 m for planing runabouts (same models)"),
        "draft": (0.2, 0.7, "planing hulls at rest: 0.25-0.6 m hull draft (same models)"),
    },
    ("boat", "rib"): {
        "length": (4.0, 9.4, "RNLI D-class 5.0 x 2.0 m; RNLI Atlantic 85 8.4 x 2.85 m; "
                             "Zodiac/Brig 4-8.5 m RIBs; plus the outboard"),
        "beam": (1.9, 2.9, "as above (overall beam over the tubes)"),
        "draft": (0.2, 0.6, "as above; deep-V RIB hulls at rest"),
    },
    ("boat", "sailboat"): {
        "length": (5.5, 12.2, "J/24 class: LOA 7.32 m, beam 2.71 m, draft 1.22 m; cruising "
                              "keelboats 6-12 m (B/L 0.30-0.36)"),
        "beam": (1.9, 4.5, "as for the length above"),
        "height": (7.0, 19.5, "mast ~1.15-1.35 LOA above the deck plus keel (J/24 mast "
                              "~9 m on 7.3 m)"),
        "draft": (0.2, 0.8, "canoe-body draft of fin keelers (total with keel 1.2-2.0 m)"),
    },
    ("boat", "cabin_cruiser"): {
        "length": (7.0, 12.8, "7-12 m motor cruisers (e.g. Bayliner/Sea Ray/Jeanneau "
                              "Merry Fisher ranges) plus swim platform"),
        "beam": (2.4, 4.5, "as above (B ~0.30-0.34 L + 0.3 m)"),
        "draft": (0.4, 1.1, "as for the length above"),
    },
    ("boat", "rowing"): {
        "length": (2.5, 4.7, "rowing dinghies and skiffs 2.5-4.6 m (e.g. Linder 410: "
                             "4.1 x 1.56 m; Walker Bay 8: 2.4 x 1.3 m)"),
        "beam": (1.1, 1.7, "as for the length above"),
        "draft": (0.08, 0.35, "as above, one or two aboard"),
    },
    ("boat", "paddle"): {
        "length": (2.7, 5.6, "recreational kayaks 2.7-3.7 m x 0.7-0.8 m; sea kayaks "
                             "4.5-5.5 m x 0.53-0.6 m; canoes e.g. Old Town Discovery 169: "
                             "5.1 x 0.94 m"),
        "beam": (0.5, 0.96, "as for the length above"),
        "draft": (0.04, 0.25, "as above, loaded with paddlers"),
    },
    # ----------------------------------------------------------------- jet skis
    ("jetski", "*"): {
        "length": (2.75, 3.70, "Sea-Doo Spark 2-up 2.79 m; Sea-Doo GTI 3.30-3.45 m; Yamaha "
                               "VX 3.37 m; Yamaha FX 3.58 m; Kawasaki Ultra 3.6 m"),
        "width": (1.10, 1.30, "Spark 1.18 m; GTI 1.25 m; VX 1.24 m; FX 1.27 m"),
        "height": (0.95, 1.28, "Spark 1.04 m; GTI 1.14 m; VX 1.22 m; FX 1.23 m "
                               "(without rider)"),
        "draft": (0.12, 0.40, "deep-V PWC hulls at rest, rider aboard or not"),
    },
    # ----------------------------------------------------------------- life-saving
    ("life_saving_appliances", "ring_buoy"): {
        "outer_diameter": (0.58, 0.80, "46 CFR 160.050-2 Table (verified): 30, 24, 20 in "
                                       "rings +- 5 %; SOLAS LSA Code 2.1.1: outer diameter "
                                       "<= 800 mm, inner >= 400 mm, mass >= 2.5 kg"),
        "diameter": (0.58, 0.94, "as above, plus the grab line festoons (up to 6 cm)"),
        "height": (0.07, 0.13, "ring thickness ~0.13-0.15 OD (USCG/EN rings)"),
    },
    ("life_saving_appliances", "life_raft"): {
        "diameter": (1.7, 3.3, "4-12 person inflatable rafts (ISO 9650 / SOLAS), floor "
                               "area ~0.37 m^2 per person (LSA Code), two buoyancy tubes"),
        "height": (0.5, 2.1, "as above; canopy 1.0-1.4 m over the floor"),
    },
    ("life_saving_appliances", "rescue_tube"): {
        "hull_length": (0.9, 1.1, "lifeguard rescue tubes: ~100 x 15 x 9 cm foam with a "
                                  "1.8 m lanyard (USLA-style; manufacturers' catalogues)"),
        "diameter": (0.7, 1.8, "tube plus snap hook and a short trailing lanyard"),
    },
    ("life_saving_appliances", "rescue_can"): {
        "hull_length": (0.62, 0.74, "Burnham-style rescue cans (torpedo buoys) 64-71 cm"),
        "diameter": (0.62, 0.95, "can plus its short strap stub"),
    },
    ("life_saving_appliances", "life_jacket"): {
        "diameter": (0.45, 0.75, "adult foam vests (ISO 12402-5) and inflated 150 N "
                                 "jackets (ISO 12402-3), laid flat"),
        "height": (0.04, 0.16, "foam 5-7 cm; inflated bladders 11-14 cm"),
    },
    # ----------------------------------------------------------------- buoys
    ("buoy", "can"): {
        "diameter": (0.4, 1.05, "small plastic lateral buoys 0.4-1.0 m (IALA Guideline "
                                "1006 Plastic Buoys, verified title; makers' ranges)"),
        "height": (0.6, 2.6, "body 1.3-1.8 x diameter, plus eye and topmark"),
    },
    ("buoy", "sphere"): {
        "diameter": (0.38, 1.25, "spherical mooring buoys 0.4-1.2 m (inflatable A-series "
                                 "and foam-filled steel/plastic moorings)"),
        "height": (0.4, 1.9, "sphere plus eye or through rod"),
    },
    ("buoy", "spar"): {
        "height": (2.5, 4.8, "spar buoys 2.5-4 m poles 0.2-0.4 m across, plus topmark"),
        "diameter": (0.18, 0.5, "as for the length above"),
    },
    ("buoy", "marker"): {
        "diameter": (0.24, 1.9, "swim-area floats 0.25-0.45 m; inflatable triathlon "
                                "cylinders/pyramids 1.0-1.8 m across, 1.5-2.5 m high"),
        "height": (0.24, 3.2, "as above, plus a ballast skirt under the big ones"),
    },
    ("buoy", "pillar"): {
        "diameter": (1.15, 1.85, "IALA pillar buoys: float 1.2-1.8 m across, focal plane "
                                 "2-3 m above water (IALA Maritime Buoyage System)"),
        "height": (3.0, 7.0, "as above, with tail tube and topmark"),
    },
}


def ranges(kind: str, sub_type: str) -> dict[str, tuple[float, float, str]]:
    """The measures of (kind, sub_type), falling back to (kind, "*")."""
    return REAL.get((kind, sub_type), REAL.get((kind, "*"), {}))
