"""Waterlines are plausible for each kind: a swimmer mostly submerged with the head out, boats
and jet skis at their draft, life-saving appliances floating high, buoys at their drawn
submerged fraction."""

from __future__ import annotations

import numpy as np
import pytest

from sdcomp.assets.sar import VARIANTS, boat, describe_variant, jetski

from .sar_meshes import all_variants, build_cached, fraction_below, variant_id

# Fraction of the mesh volume under water, per (kind, sub_type): (lo, hi).
SUBMERGED = {
    ("swimmer", "*"): (0.75, 0.99),  # < 25 % of the body out of the water
    ("boat", "*"): (0.03, 0.6),
    ("jetski", "*"): (0.05, 0.5),
    ("life_saving_appliances", "ring_buoy"): (0.05, 0.35),
    ("life_saving_appliances", "life_raft"): (0.01, 0.3),
    ("life_saving_appliances", "rescue_tube"): (0.05, 0.4),
    ("life_saving_appliances", "rescue_can"): (0.05, 0.4),
    ("life_saving_appliances", "life_jacket"): (0.03, 0.4),
    ("buoy", "*"): (0.08, 0.8),
}


def _band(kind: str, sub: str) -> tuple[float, float]:
    return SUBMERGED.get((kind, sub), SUBMERGED.get((kind, "*")))


#: a swimmer's life jacket or rescue tube is foam that floats mostly out of the water (70-150
#: N of buoyancy: 7-15 litres, most of it above the waterline): with it, the mesh (body and
#: gear) has up to 35 % of its volume out, the body itself still under a quarter
WITH_GEAR = (0.65, 0.99)


@pytest.mark.parametrize("kv", all_variants(), ids=variant_id)
def test_submerged_fraction_in_band(kv):
    kind, v = kv
    params = describe_variant(kind, v)
    sub = params["sub_type"]
    lo, hi = _band(kind, sub)
    if kind == "swimmer" and (params["vest"] is not None or params["tube"] is not None):
        lo, hi = WITH_GEAR
    frac = fraction_below(build_cached(kind, v))
    assert lo <= frac <= hi, f"{kind}-{v:02d} {sub}: {frac:.3f} under water"


@pytest.mark.parametrize("v", range(VARIANTS["swimmer"]))
def test_swimmer_head_out_body_in(v):
    """Something stands out of the water (the head; for crawl at least the back and the back
    of the head, a few centimetres), the feet are well under it."""
    m = build_cached("swimmer", v)
    p = describe_variant("swimmer", v)
    top = m.bounds[1, 2] - m.waterline
    assert top > (0.03 if p["sub_type"] == "crawl" else 0.08)
    # feet well under: a quarter metre for upright ones, a crawl's kick or a back float's
    # heels hang at least 0.18 m down
    flat = p["sub_type"] in ("crawl", "back")
    assert m.bounds[0, 2] - m.waterline < (-0.18 if flat else -0.25)
    if p["sub_type"] in ("tread", "wave", "distress"):  # upright: most of the height below
        assert (m.waterline - m.bounds[0, 2]) / m.extents[2] > 0.6


@pytest.mark.parametrize("v", range(VARIANTS["boat"]))
def test_boat_freeboard(v):
    """The sheer stands clear of the water: the waterline lies in the lower half of the hull
    depth for decked boats, and under the gunwale for open ones."""
    p = describe_variant("boat", v)
    d = boat.draft(p)
    depth = p.get("depth", 0.45 + 0.03 * p["length"])
    assert 0 < d < 0.75 * depth


@pytest.mark.parametrize("v", range(VARIANTS["jetski"]))
def test_jetski_draft_with_and_without_rider(v):
    p = describe_variant("jetski", v)
    d = jetski.draft(p)
    assert 0.12 < d < 0.40
    if p["rider"]:
        empty = dict(p, rider=None)
        assert jetski.draft(empty) < d  # the rider pushes it down


@pytest.mark.parametrize("v", range(VARIANTS["buoy"]))
def test_buoy_submerged_as_drawn(v):
    """Buoys float at the submerged volume fraction drawn for them (of the float body, so the
    whole mesh, with topmarks and towers in the air, sits a little lower than the number)."""
    p = describe_variant("buoy", v)
    frac = fraction_below(build_cached("buoy", v))
    assert frac <= p["submerged_fraction"] + 0.02
    assert frac >= p["submerged_fraction"] * 0.6
    if p["sub_type"] == "spar":
        m = build_cached("buoy", v)
        assert (m.waterline - m.bounds[0, 2]) / m.extents[2] > 0.5  # most of the pole under


def test_ring_buoy_rides_high_but_wet():
    """A 2.5-4 kg ring of ~20-35 L displaces 10-20 % of its volume: the water reaches a
    fifth to two fifths of the way up the ring's thickness."""
    for v in range(VARIANTS["life_saving_appliances"]):
        p = describe_variant("life_saving_appliances", v)
        if p["sub_type"] != "ring_buoy":
            continue
        m = build_cached("life_saving_appliances", v)
        t = p["thickness"]
        depth = m.waterline - (-t / 2)  # ring centred on z = 0, only the ring below it
        assert 0.15 * t < depth < 0.5 * t


def test_swimmer_mix_is_what_sar_footage_shows():
    """Of the twenty swimmer variants: still on 14 (treading 9, floating on the back 5),
    dark full wetsuits on 9, bare arms and legs (a shorty or swimwear) on 8, a life jacket
    on 8 (the 5 on their backs among them), a swim cap on 2, wet hair dark on most of the rest
    (mean sRGB under 60 on at least 12 of the 18), a rescue tube on 2."""
    ps = [describe_variant("swimmer", v) for v in range(VARIANTS["swimmer"])]
    assert sum(p["sub_type"] == "tread" for p in ps) == 9
    assert sum(p["sub_type"] == "back" for p in ps) == 5
    assert sum(p["sub_type"] in ("tread", "wave", "distress", "back") for p in ps) == 17
    assert sum(p["outfit"] == "wetsuit" for p in ps) == 9
    assert sum(p["outfit"] in ("shorty", "swimwear") for p in ps) == 8
    assert sum(p["vest"] is not None for p in ps) == 8
    assert sum(p["vest"] is not None for p in ps if p["sub_type"] == "back") == 5
    assert sum(p["hair_style"] == "cap" for p in ps) == 2
    hair = [sum(p["hair"]) / 3 for p in ps if p["hair_style"] != "cap"]
    assert sum(h < 60 for h in hair) >= 12, hair
    assert sum(p["tube"] is not None for p in ps) == 2


@pytest.mark.parametrize("v", [v for v in range(VARIANTS["swimmer"])
                               if describe_variant("swimmer", v)["tube"] is not None])
def test_a_rescue_tube_floats_across_the_chest(v):
    """The tube's faces (its colour) lie around the waterline, half out of the water, and
    span about its metre across, wider than the shoulders."""
    m = build_cached("swimmer", v)
    colour = describe_variant("swimmer", v)["tube"]
    faces = (m.face_colors == np.asarray(colour, np.uint8)).all(axis=1)
    assert faces.sum() > 20
    pts = m.vertices[np.unique(m.faces[faces])]
    z = pts[:, 2] - m.waterline
    assert abs(float(z.mean())) < 0.03 and z.min() < -0.05 and z.max() > 0.05
    span = float(np.linalg.norm(np.ptp(pts[:, :2], axis=0)))
    assert 0.95 < span < 1.3
