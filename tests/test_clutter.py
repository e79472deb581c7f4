"""Procedural floating clutter: sizes, flotation, colours, determinism and top-down sprites."""

from __future__ import annotations

import math
import time

import manifold3d as m3
import numpy as np
import pytest

from sdcomp.assets import clutter
from sdcomp.atlas.raster import render
from sdcomp.errors import UserError

# Stated real-world sizes (x, y, z extents, metres); None where the spec gives no size.
EXTENTS = {
    "buoy": (0.45, 0.45, 0.55),  # sphere 0.45 m plus the eye on top
    "log": (2.2, 0.3, 0.3),
    "boat": (3.5, 1.4, None),
    "foam": (1.5, 1.5, 0.025),
    "dock": (8.0, 1.62, 1.45),  # the deck 0.45 m up on posts 1 m down
    "canopy": (7.2, 3.3, 4.6),  # the crown 3.6 m up, posts 1 m down
    "port": (3.4, 1.7, 0.4),  # 0.15 m proud, 0.25 m of float under the water
}
# Top-down silhouette area expected from the stated sizes, m^2.
FOOTPRINT = {
    "buoy": math.pi * 0.225**2,
    "log": 2.2 * 0.3,
    "boat": math.pi / 4 * 3.5 * 1.4,  # an ellipse in the hull's bounding box
    "foam": math.pi / 4 * 1.5**2,
    "dock": 8.0 * 1.5 * 0.9,  # boards with 2 cm gaps between them (17 cm boards)
    "canopy": 7.2 * 3.3,
    "port": 3.4 * 1.7,  # its rim, and the cradle floor seen in the hole
}
# Colour that dominates the surface area, and colours that must be present.
DOMINANT = {"buoy": clutter.BUOY_RED, "log": clutter.BARK, "boat": clutter.HULL,
            "foam": clutter.FOAM, "dock": clutter.DECK, "canopy": clutter.CANOPY,
            "port": clutter.PORT}
PRESENT = {
    "buoy": {clutter.BUOY_RED, clutter.BUOY_WHITE, clutter.STEEL},
    "log": {clutter.BARK, clutter.CUT_WOOD},
    "boat": {clutter.HULL, clutter.FLOOR, clutter.THWART, clutter.MOTOR},
    "foam": {clutter.FOAM},
    "dock": {clutter.DECK, clutter.DOCK_FRAME},
    "canopy": {clutter.CANOPY, clutter.LIFT_FRAME},
    "port": {clutter.PORT, clutter.ROLLER},
}


@pytest.fixture(scope="module", params=clutter.KINDS)
def mesh(request):
    return clutter.build(request.param)


def _face_areas(m) -> np.ndarray:
    tri = m.vertices[m.faces]
    return 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)


def _area_by_colour(m) -> dict[tuple[int, int, int], float]:
    colours, inverse = np.unique(m.face_colors, axis=0, return_inverse=True)
    sums = np.bincount(inverse.ravel(), weights=_face_areas(m))
    return {tuple(int(v) for v in c): float(a) for c, a in zip(colours, sums, strict=True)}


def _submerged_fraction(m) -> float:
    """Fraction of the mesh's volume below its waterline."""
    solid = m3.Manifold(m3.Mesh(vert_properties=m.vertices.astype(np.float32),
                                tri_verts=m.faces.astype(np.uint32)))
    below = solid.trim_by_plane([0.0, 0.0, -1.0], -m.waterline)  # keeps z <= waterline
    return below.volume() / solid.volume()


def _top_view(m):
    mpp = 1.25 * float(m.extents[:2].max()) / 64
    return render(m, 0.0, 0.0, size=64, metres_per_pixel=mpp), mpp


def test_extents_match_stated_sizes(mesh):
    for got, want in zip(mesh.extents, EXTENTS[mesh.name], strict=True):
        if want is not None:
            assert got == pytest.approx(want, rel=0.10)


def test_centred_on_bounding_box(mesh):
    np.testing.assert_allclose(mesh.bounds.sum(axis=0), 0.0, atol=1e-9)


def test_waterline_cuts_the_mesh(mesh):
    assert mesh.bounds[0, 2] < mesh.waterline < mesh.bounds[1, 2]


def test_closed_small_and_well_formed(mesh):
    assert mesh.closed
    tm = mesh.to_trimesh()
    assert tm.is_watertight and tm.is_winding_consistent and tm.volume > 0
    assert 0 < len(mesh.faces) < 5000
    f = mesh.faces
    assert f.min() >= 0 and f.max() < len(mesh.vertices)
    assert np.all((f[:, 0] != f[:, 1]) & (f[:, 1] != f[:, 2]) & (f[:, 0] != f[:, 2]))
    assert _face_areas(mesh).min() > 1e-10


def test_colours(mesh):
    areas = _area_by_colour(mesh)
    assert set(areas) == PRESENT[mesh.name]
    assert max(areas, key=areas.get) == DOMINANT[mesh.name]


def test_deterministic_and_fast(mesh):
    t0 = time.perf_counter()
    again = clutter.build(mesh.name)
    assert time.perf_counter() - t0 < 0.5
    assert again.content_hash() == mesh.content_hash()
    np.testing.assert_array_equal(again.face_colors, mesh.face_colors)


def test_top_down_sprite_footprint(mesh):
    sprite, mpp = _top_view(mesh)
    assert sprite.mask.any()
    assert not sprite.mask[[0, -1], :].any() and not sprite.mask[:, [0, -1]].any()  # fits
    area = float(sprite.alpha.sum()) * mpp**2
    assert area == pytest.approx(FOOTPRINT[mesh.name], rel=0.25)


def test_buoy_floats_forty_percent_submerged():
    buoy = clutter.build("buoy")
    assert _submerged_fraction(buoy) == pytest.approx(0.40, abs=0.04)
    sprite, _ = _top_view(buoy)
    colours, counts = np.unique(sprite.albedo[sprite.alpha == 1], axis=0, return_counts=True)
    assert tuple(colours[counts.argmax()]) == clutter.BUOY_RED


def test_log_floats_half_submerged():
    log = clutter.build("log")
    assert _submerged_fraction(log) == pytest.approx(0.5, abs=0.05)
    # not a CAD pipe: the radius varies along the log
    v = log.vertices
    ends = [np.ptp(v[np.abs(v[:, 0] - x) < 0.01, 2]) for x in log.bounds[:, 0]]
    assert abs(ends[0] - ends[1]) > 0.02


def test_boat_draft_and_open_interior():
    boat = clutter.build("boat")
    hull = (boat.face_colors == clutter.HULL).all(axis=1)
    keel = boat.vertices[boat.faces[hull]][..., 2].min()
    assert boat.waterline - keel == pytest.approx(0.15, abs=0.02)
    # from above, the floor and thwarts inside the hull are visible
    sprite, _ = _top_view(boat)
    seen = {tuple(int(v) for v in c) for c in np.unique(sprite.albedo[sprite.alpha == 1], axis=0)}
    assert {clutter.FLOOR, clutter.THWART, clutter.HULL} <= seen
    # the floor lies below the water outside, the gunwale well above it
    floor = sprite.height[(sprite.albedo == clutter.FLOOR).all(axis=-1) & (sprite.alpha == 1)]
    assert floor.max() < 0.05
    assert sprite.height.max() > 0.3


def test_foam_top_just_above_water():
    foam = clutter.build("foam")
    assert 0.005 <= foam.bounds[1, 2] - foam.waterline <= 0.03
    sprite, _ = _top_view(foam)
    assert 0.005 <= np.median(sprite.height[sprite.alpha == 1]) <= 0.03


def test_unknown_kind_names_the_valid_ones():
    with pytest.raises(UserError) as err:
        clutter.build("nope")
    assert "nope" in str(err.value)
    for kind in clutter.KINDS:
        assert kind in str(err.value)
