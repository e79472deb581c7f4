"""Every variant's sizes lie within the real range of its kind and sub-type
(sdcomp.assets.sar.dimensions.REAL, with sources); the sizes span the range, not one value."""

from __future__ import annotations

import numpy as np
import pytest

from sdcomp.assets.sar import KINDS, VARIANTS, boat, describe_variant, jetski
from sdcomp.assets.sar.dimensions import REAL, ranges

from .sar_meshes import build_cached


def measure(kind: str, variant: int, name: str) -> float:
    """The measure ``name`` (see dimensions.MEASURES) of (kind, variant)."""
    mesh = build_cached(kind, variant)
    p = describe_variant(kind, variant)
    ext = mesh.extents
    if name in ("stature", "biacromial", "head_breadth"):
        key = {"biacromial": "shoulders"}.get(name, name)
        return p["body"][key]
    if name == "span":
        return float(ext.max())
    if name == "length":
        return float(ext[0])
    if name == "width":
        return float(ext[1])
    if name == "height":
        return float(ext[2])
    if name == "diameter":
        return float(ext[:2].max())
    if name == "beam":
        return p["beam"]
    if name == "hull_length":
        return p["length"]
    if name == "outer_diameter":
        return p["outer_diameter"]
    if name == "draft":
        return (boat.draft if kind == "boat" else jetski.draft)(p)
    raise KeyError(name)


def test_every_sub_type_has_a_sourced_range():
    for kind in KINDS:
        for v in range(VARIANTS[kind]):
            table = ranges(kind, describe_variant(kind, v)["sub_type"])
            assert table, (kind, v)
            for lo, hi, source in table.values():
                assert 0 < lo < hi and len(source) > 20


@pytest.mark.parametrize(("kind", "variant", "name"), [
    (k, v, n) for k in KINDS for v in range(VARIANTS[k])
    for n in ranges(k, describe_variant(k, v)["sub_type"])
])
def test_within_real_range(kind, variant, name):
    sub = describe_variant(kind, variant)["sub_type"]
    if kind == "jetski" and name == "height" and describe_variant(kind, variant)["rider"]:
        pytest.skip("the published height is without a rider")
    lo, hi, source = ranges(kind, sub)[name]
    got = measure(kind, variant, name)
    assert lo <= got <= hi, f"{kind}-{variant:02d} {sub} {name} = {got:.3f} not in " \
                            f"[{lo}, {hi}] ({source})"


def test_jetski_published_classes():
    """Riderless jet skis match their class's published length, width and height to 5 %."""
    for v in range(VARIANTS["jetski"]):
        p = describe_variant("jetski", v)
        (l0, l1), (w0, w1), (h0, h1), _ = jetski.CLASSES[p["sub_type"]]
        ext = build_cached("jetski", v).extents
        assert l0 * 0.97 <= ext[0] <= l1 * 1.03
        assert w0 * 0.97 <= ext[1] <= w1 * 1.03
        if not p["rider"]:
            assert h0 * 0.95 <= ext[2] <= h1 * 1.05


def test_ring_buoy_sizes_are_standard():
    """Ring buoys use the USCG 24/30-in or EN 650/720 mm sizes; the mesh is that wide (plus
    grab line) and the inner diameter is at least the SOLAS 400 mm."""
    for v in range(VARIANTS["life_saving_appliances"]):
        p = describe_variant("life_saving_appliances", v)
        if p["sub_type"] != "ring_buoy":
            continue
        assert p["outer_diameter"] in (0.61, 0.65, 0.72, 0.76)
        assert p["inner_diameter"] >= 0.33  # 24-in rings are ~14 in inside
        ext = build_cached("life_saving_appliances", v).extents
        assert p["outer_diameter"] - 0.01 <= ext[:2].min() <= p["outer_diameter"] + 0.13


def test_swimmer_head_is_head_sized():
    """The swimmer's head (the upper half of the head of an upright swimmer, above the
    waterline) is about a head across seen from above: 0.13-0.30 m (head breadth, plus
    hair or cap)."""
    for v in range(VARIANTS["swimmer"]):
        p = describe_variant("swimmer", v)
        if p["sub_type"] not in ("tread", "distress"):
            continue
        m = build_cached("swimmer", v)
        tri = m.vertices[m.faces]
        # the head's upper half (the shoulders may stand out of the water too)
        above = tri[..., 2].min(axis=1) > max(m.waterline + 0.02, m.bounds[1, 2] - 0.11)
        pts = tri[above].reshape(-1, 3)
        near = np.linalg.norm(pts[:, :2] - pts[:, :2].mean(0), axis=1) < 0.3
        width = np.ptp(pts[near][:, 1])
        assert 0.13 <= width <= 0.30, (v, width)


@pytest.mark.parametrize("kind", KINDS)
def test_sizes_spread_over_the_range(kind):
    """Variants of a kind do not all share one size: the largest horizontal extent varies by
    at least 15 % over the kind, and varies within some sub-type too."""
    by_sub: dict[str, list[float]] = {}
    for v in range(VARIANTS[kind]):
        sub = describe_variant(kind, v)["sub_type"]
        by_sub.setdefault(sub, []).append(float(build_cached(kind, v).extents[:2].max()))
    sizes = [x for xs in by_sub.values() for x in xs]
    assert max(sizes) / min(sizes) > 1.15
    assert max(max(x) / min(x) for x in by_sub.values() if len(x) > 1) > 1.02
    assert REAL  # the table is importable and non-empty
