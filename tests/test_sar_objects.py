"""Search-and-rescue kinds as objects and clutter: the config (weights, categories, clutter
kinds that are objects), the scenes drawn from it (variants, shades, proportions), and that
configs of one-mesh objects draw the scenes they drew before these kinds existed."""

from __future__ import annotations

import math
from collections import Counter
from dataclasses import replace

import numpy as np
import pytest

from sdcomp import GeneratorConfig
from sdcomp.assets import sar
from sdcomp.errors import SettingError, UserError
from sdcomp.scene.camera import PITCH_RANGE
from sdcomp.scene.config import MAX_INSTANCES, ObjectSpec
from sdcomp.scene.objects import (
    CLUTTER_KINDS,
    DEFAULT_CLUTTER_KINDS,
    clutter_assets,
    clutter_mesh_name,
    footprint_radius,
    object_assets,
)
from sdcomp.scene.presets import SDS_CLASSES, preset
from sdcomp.scene.sample import VARIANT_TINT, sample_scene, view_share
from sdcomp.scene.scene import Role


def _placements(config: GeneratorConfig, n: int, role: Role = Role.OBJECT) -> list:
    return [p for i in range(n) for p in sample_scene(config, i).placements if p.role is role]


def test_asset_keys_of_kinds_variants_meshes_and_clutter():
    assert object_assets("swimmer") == sar.variant_names("swimmer")
    assert object_assets("boat-03") == ("boat-03",)
    assert object_assets("bluerov2") == ("bluerov2",)
    assert object_assets("my/boat.stl") == ("my/boat.stl",)
    assert clutter_assets("buoy") == tuple(f"clutter:buoy-{v:02d}" for v in range(10))
    assert clutter_assets("log") == ("clutter:log",)
    # a variant's clutter atlas has its own file name, beside its object atlas
    assert clutter_mesh_name("clutter:boat-03") == "clutter-boat-03"
    assert clutter_mesh_name("clutter:foam") == "foam"
    assert set(CLUTTER_KINDS) == set(DEFAULT_CLUTTER_KINDS) | set(sar.KINDS)


def test_a_kind_object_is_each_of_its_variants_in_a_shade_of_its_own():
    config = GeneratorConfig(objects=["jetski"], count=20, clutter=0, seed=2)
    placed = _placements(config, 10)
    assert {p.asset for p in placed} == set(sar.variant_names("jetski"))
    lo, hi, jitter = VARIANT_TINT
    tints = np.array([p.tint for p in placed])
    assert np.all(tints >= lo * (1 - jitter)) and np.all(tints <= hi * (1 + jitter))
    assert len({p.tint for p in placed}) == len(placed)  # every one its own
    assert {p.category_id for p in placed} == {1}


def test_weights_set_the_class_proportions():
    config = GeneratorConfig(objects=[{"mesh": "swimmer", "weight": 3},
                                      {"mesh": "buoy", "weight": 1}], count=40, clutter=0)
    counts = Counter(p.category_id for p in _placements(config, 100))
    share = counts[1] / (counts[1] + counts[2])
    assert abs(share - 0.75) < 0.03, counts


def test_equal_weights_draw_as_without_weights():
    a = GeneratorConfig(objects=["bluerov2", "bluerov2-heavy"], count="1-5", seed=4)
    b = replace(a, objects=(ObjectSpec("bluerov2", weight=2.5),
                            ObjectSpec("bluerov2-heavy", weight=2.5)))
    for i in range(20):
        assert sample_scene(a, i) == sample_scene(b, i)


def test_one_mesh_objects_draw_the_scenes_they_drew_before_kinds():
    """(kind, asset, x, y, heading) of the first scene and the seeds drawn last, recorded
    with sdcomp before the search-and-rescue kinds (commit aad2b9a, with the
    physically based water): the BlueROV2's placements and the clutter's places are the same draws;
    the clutter boat and buoy are now variants of those kinds, chosen by the draw that chose
    the old ones' paint."""
    before = [("object", "bluerov2", 7.512362, -0.541531, 123.4787),
              ("object", "bluerov2", -4.457094, -5.522882, 124.9442),
              ("clutter", "clutter:buoy", -7.015063, -0.868259, 20.7691),
              ("clutter", "clutter:buoy", 7.314866, -8.597587, 356.982),
              ("clutter", "clutter:log", -7.969311, 2.417629, 220.8747)]
    scene = sample_scene(GeneratorConfig(seed=5, count="2-4", clutter=2.0), 0)
    now = scene.placements
    assert len(now) == len(before)
    for p, (role, asset, x, y, heading) in zip(now, before, strict=True):
        assert p.role.value == role and p.asset.startswith(asset)
        assert (round(p.x, 6), round(p.y, 6), round(p.heading, 4)) == (x, y, heading)
    # the water's last draw (before the placements) and the scene's last (after the
    # camera's look, blur and quality) in place too
    assert scene.water.seed == 423409760 and scene.seeds.land == (1181678423, 3)


def test_clutter_of_a_kind_is_its_variants_unshaded():
    config = GeneratorConfig(clutter=6, clutter_kinds=["life_saving_appliances"], seed=1)
    placed = _placements(config, 10, Role.CLUTTER)
    assert {p.asset for p in placed} == set(clutter_assets("life_saving_appliances"))
    assert {p.tint for p in placed} == {(1.0, 1.0, 1.0)}
    assert {p.category_id for p in placed} == {0}


def test_a_kind_is_never_object_and_clutter_in_one_run():
    # the default clutter list drops the kinds that are objects (a variant counts)
    assert GeneratorConfig(objects=["boat"]).clutter_kinds == ("buoy", "log", "foam")
    assert GeneratorConfig(objects=["buoy-03", "boat"]).clutter_kinds == ("log", "foam")
    assert GeneratorConfig().clutter_kinds == DEFAULT_CLUTTER_KINDS
    # a list the user gives that names one is refused, saying what to write instead
    with pytest.raises(SettingError, match=r"clutter_kinds boat is also an --object, "
                                           r"annotated there: leave it out \(e\.g\. "
                                           r"clutter_kinds log\)"):
        GeneratorConfig(objects=["boat-07"], clutter_kinds=["boat", "log"])
    with pytest.raises(SettingError, match="or set --clutter 0"):
        GeneratorConfig(objects=["swimmer"], clutter_kinds=["swimmer"])
    with pytest.raises(SettingError, match="'rock' is unknown; use some of buoy, log"):
        GeneratorConfig(clutter_kinds=["rock"])
    # other kinds are fine, and a resolved config reads back to itself
    c = GeneratorConfig(objects=["swimmer"], clutter_kinds=["jetski", "log"])
    assert GeneratorConfig.from_mapping(c.to_dict()) == c
    d = GeneratorConfig(objects=["boat"])
    assert GeneratorConfig.from_mapping(d.to_dict()) == d


def test_weights_are_checked_and_kept_in_config_files():
    for bad in (0, -1, "x", float("nan"), float("inf"), True, None):
        with pytest.raises(SettingError, match="weight .* must be a positive number"):
            ObjectSpec("boat", weight=bad)
    c = GeneratorConfig(objects=[{"mesh": "boat", "weight": 2}, "buoy"])
    assert c.to_dict()["objects"] == [{"mesh": "boat", "category": "boat", "weight": 2.0},
                                      {"mesh": "buoy", "category": "buoy"}]
    assert GeneratorConfig.from_mapping({"objects": c.to_dict()["objects"]}) == c
    with pytest.raises(UserError,
                       match="unknown key 'colour'; use mesh, category, weight, frame, size and "
                             "size_weight"):
        GeneratorConfig(objects=[{"mesh": "boat", "colour": "red"}])


def test_box_sizes_are_checked_and_kept_in_config_files():
    for bad in ([0.01], [0.02, 0.01], [0.0, 0.1], [0.1, 1.0], "x", [0.01, "a"], 0.02):
        with pytest.raises(SettingError, match="size .* must be at least two box sizes"):
            ObjectSpec("boat", size=bad)
    c = GeneratorConfig(objects=[{"mesh": "boat", "frame": [0, 0, 1, 1],
                                  "size": [0.01, 0.02, 0.05]}])
    assert c.to_dict()["objects"][0]["size"] == [0.01, 0.02, 0.05]
    assert GeneratorConfig.from_mapping(c.to_dict()) == c


def test_size_weights_are_checked_kept_and_drawn_by():
    """``size_weight``: one positive weight per interval between neighbouring sizes, kept
    in config files; each interval is drawn as often as its share of the weights, evenly
    within it, and without weights the draw is the quantiles' own (linear between them)."""
    from sdcomp.scene.objects import draw_size

    size = (0.01, 0.02, 0.05)
    for bad in ([1.0], [1.0, 2.0, 3.0], [1.0, 0.0], [1.0, -2.0], [1.0, float("inf")],
                [1.0, float("nan")], "x", [1.0, "a"]):
        with pytest.raises(SettingError, match="size_weight .* must be 2 positive numbers"):
            ObjectSpec("boat", size=size, size_weight=bad)
    with pytest.raises(SettingError, match=r"size_weight .* positive numbers \(with size given\)"):
        ObjectSpec("boat", size_weight=[1.0, 2.0])
    c = GeneratorConfig(objects=[{"mesh": "boat", "size": list(size), "size_weight": [3, 1]}])
    assert c.to_dict()["objects"][0]["size_weight"] == [3.0, 1.0]
    assert GeneratorConfig.from_mapping(c.to_dict()) == c
    assert "size_weight" not in GeneratorConfig(objects=[{"mesh": "boat", "size": list(
        size)}]).to_dict()["objects"][0]
    t = (np.arange(4000) + 0.5) / 4000
    even = np.array([draw_size(size, None, x) for x in t])
    assert np.allclose(even, np.interp(t, [0, 0.5, 1], size))
    weighted = np.array([draw_size(size, (3.0, 1.0), x) for x in t])
    assert abs(np.mean(weighted < 0.02) - 0.75) < 1e-3  # the first interval: 3 of 4
    low = weighted[weighted < 0.02]
    assert abs(np.median(low) - 0.015) < 1e-4 and low.min() >= 0.01  # even within it
    assert weighted.max() <= 0.05 and np.all(np.diff(weighted) >= 0)  # monotone in t


def test_objects_with_box_sizes_are_placed_where_they_show_them(sprites_dir):
    """In oblique views an object with box-size quantiles stands on the row where its box
    shows a size drawn from them: the labelled boxes of narrow size bands (a motorboat, a
    jet ski: long, their boxes depend on their headings) come out within the slack of what
    each band asks; a view straight down that cannot show a band draws
    another object in its place (here none: the one object cannot)."""
    from sdcomp import Generator
    from sdcomp.scene.sample import SIZE_SLACK

    def sides(mesh, size, pitch, n=0, altitude=40):
        c = GeneratorConfig(objects=[{"mesh": mesh, "frame": [0, 0, 1, 1], "size": size}],
                            count="2", altitude=altitude, pitch=pitch, width=960, height=540,
                            clutter=0, look="clean", motion_blur=0, defocus_blur=0)
        if not n:
            return [p for i in range(30) for p in sample_scene(c, i).placements]
        g = Generator(c, sprites_dir)
        fx = c.camera_model().fx
        return np.array([math.sqrt(o.bbox[2] * o.bbox[3]) / fx for i in range(n)
                         for o in g.render(i).objects if not o.truncated])

    for mesh, band, altitude in (("boat-00", [0.040, 0.048], 40),
                                 ("boat-00", [0.060, 0.072], 40),
                                 ("jetski-01", [0.030, 0.036], 40)):
        got = sides(mesh, band, 30, n=12, altitude=altitude)
        assert len(got) >= 12, (mesh, band)
        # the slack, and a few percent for what the mask rule and the pixel grid take
        lo, hi = band[0] / SIZE_SLACK * 0.93, band[1] * SIZE_SLACK * 1.07
        inside = (got > lo) & (got < hi)
        assert np.mean(inside) >= 0.9, (mesh, band, np.round(got, 4))
        # the median on the band's middle (0.98-1.01 measured; the heading-averaged
        # footprint this replaced put a boat's at 0.89, a jet ski's at 0.86)
        assert abs(float(np.median(got)) / np.mean(band) - 1.0) < 0.06, (mesh, band, got)
    # straight down from 40 m a motorboat shows one size, far from 0.04 of fx
    assert len(sides("boat-00", [0.040, 0.048], 90)) == 0


def test_seadronessee_preset_has_its_categories_and_distributions():
    c = GeneratorConfig.from_mapping(preset("seadronessee"))
    assert [(k["id"], k["name"], k["supercategory"]) for k in c.categories] == [
        (1, "swimmer", "person"), (2, "boat", "boat"), (3, "jetski", "boat"),
        (4, "life_saving_appliances", "object"), (5, "buoy", "object")]
    assert [o.weight for o in c.objects] == [float(n) for _, n in SDS_CLASSES]
    assert (c.width, c.height) == (3840, 2160)
    model = c.camera_model()
    assert abs(model.fx - 2987) < 2 and model.fx == model.fy  # the Mavic 2 Pro's 4K video
    assert c.pair_pitch and len(c.altitude.values) == len(c.pitch.values) == 100
    assert min(c.pitch.values) == PITCH_RANGE[0] == 2 and float(np.median(c.altitude.values)) == 36
    assert set(c.clutter_kinds).isdisjoint(sar.KINDS)
    assert GeneratorConfig().categories[0]["supercategory"] == "object"  # BlueROV2: as before


def test_seadronessee_preset_draws_green_coastal_water():
    """The preset's water is the green coastal water of SeaDronesSee's frames (Lake
    Constance near the shore: chlorophyll 1.4-4 mg/m^3, Secchi depth 2.5-6 m), not ocean
    blue or a brown river: the coastal type at turbidity 0.5-1.0, deep water but for a
    sandy bottom in about 10 % of the frames."""
    c = GeneratorConfig.from_mapping(preset("seadronessee"))
    waters = [sample_scene(c, i).water for i in range(200)]
    assert {w.water_type for w in waters} == {"coastal"}
    chl = np.array([w.chl for w in waters])
    # each constituent within +-0.15 of the turbidity drawn: 0.35-1.0 of the type's ranges
    assert 1.0 <= chl.min() and chl.max() <= 4.0 and 2.0 < float(np.median(chl)) < 3.0
    assert max(w.tsm for w in waters) <= 4.0  # no sediment-laden water
    shallow = np.mean([w.depth is not None for w in waters])
    assert 0.04 < shallow < 0.18, shallow


def test_no_two_objects_share_the_water():
    """Objects and clutter keep their footprints' discs apart (a swimmer is not drawn
    inside a boat nor a log through a swimmer); foam patches, flat on the water, may lie
    under them. Before, placements were drawn independently: 11 of these 120 preset frames
    held two overlapping discs, 29 of the 120 crowded ones."""
    c = GeneratorConfig.from_mapping(preset("seadronessee"))
    crowded = GeneratorConfig.from_mapping({**preset("seadronessee"), "count": 12,
                                            "clutter": 2.0})
    placed = 0
    for config in (c, crowded):
        for i in range(120):
            discs = [(p.x, p.y, footprint_radius(p.asset))
                     for p in sample_scene(config, i).placements
                     if not p.asset.endswith("foam")]
            placed += len(discs)
            for k, (x, y, r) in enumerate(discs):
                for x2, y2, r2 in discs[k + 1:]:
                    assert math.hypot(x - x2, y - y2) >= r + r2 - 1e-9, (i, discs)
    assert placed > 1500
    assert footprint_radius("boat-00") > 4 * footprint_radius("swimmer-00")


def test_a_narrower_view_holds_fewer_of_the_presets_objects():
    """The preset's counts are a 4K frame's (``count_view``): a 416 px window at the same
    focal length (a twelfth of its area) draws about a twelfth as many objects and as much
    clutter, at least one object drawn; the preset's own frame and a resized one (the same view)
    keep the counts; a count per image (``count_view`` 0, the default) ignores the view."""
    frame = GeneratorConfig.from_mapping({**preset("seadronessee"), "clutter": 3.0})
    window = GeneratorConfig.from_mapping({**preset("seadronessee"), "clutter": 3.0,
                                           "camera": "custom", "fov": 22.9,
                                           "sensor_px": [416, 416], "width": 416,
                                           "height": 416})
    resized = GeneratorConfig.from_mapping({**preset("seadronessee"), "width": 1920,
                                            "height": 1080})
    share = view_share(window, window.camera_model())
    assert share == pytest.approx((416 / 1452.6) ** 2 / 0.929, rel=0.01)
    assert view_share(resized, resized.camera_model()) == pytest.approx(1.0, abs=1e-3)

    def counts(config: GeneratorConfig, role: Role) -> np.ndarray:
        return np.array([sum(p.role is role for p in sample_scene(config, i).placements)
                         for i in range(300)])

    asked = float(np.mean(frame.count.values))
    many, few = counts(frame, Role.OBJECT), counts(window, Role.OBJECT)
    # at least one drawn; a few cannot be placed (no size of theirs fits the view, or a
    # flat view's window is sky and far water): 14.5 % in 1000 draws, 9 % while the flat
    # views (12 % of the preset's) were drawn at 15 degrees
    assert float(np.mean(few == 0)) < 0.2 and few.max() <= 3
    # rounded at random: the mean is the scaled one, lifted a little by the floor of one
    assert asked * share <= float(few.mean()) <= asked * share + 0.6
    assert float(many.mean()) > 0.8 * asked  # (placements the view cannot hold drop out)
    assert float(counts(window, Role.CLUTTER).mean()) < 0.25 * float(
        counts(frame, Role.CLUTTER).mean())
    # a view far wider than the count's: at most MAX_INSTANCES objects, clutter bounded
    wide_view = GeneratorConfig(count=50, count_view=0.01, clutter=50.0, width=416,
                                height=416)
    drawn = sample_scene(wide_view, 0).placements
    assert sum(p.role is Role.OBJECT for p in drawn) == MAX_INSTANCES
    assert sum(p.role is Role.CLUTTER for p in drawn) < 100
    per_image = GeneratorConfig(count=3, width=416, height=416, seed=4)
    wide = replace(per_image, camera="custom", fov=120.0, sensor_px=(416, 416))
    assert per_image.count_view == 0.0 and view_share(wide, wide.camera_model()) == 1.0
    assert all(sum(p.role is Role.OBJECT for p in sample_scene(c, i).placements) <= 3
               for c in (per_image, wide) for i in range(20))


def test_paired_pitch_draws_the_pitch_at_the_altitudes_place():
    pairs = [(10, 20), (30, 45), (60, 80), (30, 90)]
    alts, pitches = [a for a, _ in pairs], [p for _, p in pairs]
    paired = GeneratorConfig(altitude=alts, pitch=pitches, pair_pitch=True, seed=3)
    apart = replace(paired, pair_pitch=False)
    seen = set()
    for i in range(60):
        a, b = sample_scene(paired, i), sample_scene(apart, i)
        seen.add((a.camera.altitude, a.camera.pitch))
        assert a.camera.heading == b.camera.heading  # the draws after it stay in place
        # the water is drawn before the placements (its exposure after them, by the look)
        assert replace(a.water, exposure_target=0.0) == replace(b.water, exposure_target=0.0)
    assert seen == set(pairs)
    with pytest.raises(SettingError) as err:
        GeneratorConfig(altitude=alts, pitch="20-90", pair_pitch=True)
    assert err.value.as_flag() == ("--pair-pitch needs --altitude and --pitch as lists of one "
                                   "length (--altitude is a list of 4, --pitch not a list): "
                                   "give both as lists, or add --no-pair-pitch")


def test_paired_pitch_draws_the_heading_and_sun_of_the_same_frame():
    """Heading and sun given as lists of the flight log's length are drawn at the place the
    altitude was (a frame's view of the sun: how far it looks from the sun's glitter); the
    draws stay where they were, and a list of another length is drawn apart (a preset's
    sun kept under the user's own flight log)."""
    log = [(10, 20, 0, 30), (30, 45, 90, 45), (60, 80, 180, 60), (30, 90, 270, 75)]
    paired = GeneratorConfig(altitude=[f[0] for f in log], pitch=[f[1] for f in log],
                             heading=[f[2] for f in log], sun_elevation=[f[3] for f in log],
                             sun_azimuth=0, pair_pitch=True, seed=5)
    apart = replace(paired, heading="0-360", sun_elevation="25-80")
    seen = set()
    for i in range(60):
        a, b = sample_scene(paired, i), sample_scene(apart, i)
        seen.add((a.camera.altitude, a.camera.pitch, a.camera.heading, a.water.sun_elevation))
        assert (a.camera.altitude, a.camera.pitch) == (b.camera.altitude, b.camera.pitch)
        assert a.water.wind == b.water.wind and a.water.sky == b.water.sky
    assert seen == set(log)
    other = replace(paired, sun_elevation=[30, 40])
    drawn = {(sc.camera.altitude, sc.water.sun_elevation)
             for sc in (sample_scene(other, i) for i in range(60))}
    assert {e for _, e in drawn} == {30, 40} and len(drawn) > 4  # not tied to the altitude


def test_seadronessee_preset_views_the_sun_as_its_frames_did():
    """The preset's heading relative to the sun and the sun's elevation are those of the
    frames its altitudes and pitches come from (tools/sds_sun_geometry.py): August middays
    (43-51 degrees) and few views towards the sun."""
    c = GeneratorConfig.from_mapping(preset("seadronessee"))
    assert len(c.heading.values) == len(c.sun_elevation.values) == 100
    assert 43 <= min(c.sun_elevation.values) and max(c.sun_elevation.values) <= 51
    towards = [abs((h + 180) % 360 - 180) < 30 for h in c.heading.values]
    assert sum(towards) < 17  # a uniform heading: 17 in 100
    scenes = [sample_scene(c, i) for i in range(40)]
    for s in scenes:
        k = [j for j, (a, p) in enumerate(zip(c.altitude.values, c.pitch.values, strict=True))
             if (a, p) == (s.camera.altitude, s.camera.pitch)]
        assert any((c.heading.values[j], c.sun_elevation.values[j])
                   == (s.camera.heading, s.water.sun_elevation) for j in k)
        assert s.water.sun_azimuth == 0.0


def test_no_variant_taller_than_half_the_altitude():
    """A sailboat (mast 12-16 m above the water) is not drawn under a drone at 10 m: the
    renderer would scale it for its middle, far too large; at 50 m it is."""
    tall = {n for n in sar.variant_names("boat") if sar.top_above_water("boat",
                                                                          int(n[-2:])) > 5}
    assert tall == {"boat-02", "boat-08"}
    low = GeneratorConfig(objects=["boat"], altitude=10, count=20, clutter=6,
                          clutter_kinds=["jetski"], seed=3)
    assets = {p.asset for p in _placements(low, 20)}
    assert assets == set(sar.variant_names("boat")) - tall
    assert tall <= {p.asset for p in _placements(replace(low, altitude=50), 20)}
    clutter = replace(low, altitude=50, clutter_kinds=("boat",),
                      objects=(ObjectSpec("jetski"),))
    tall_clutter = {"clutter:" + n for n in tall}
    assert tall_clutter <= {p.asset for p in _placements(clutter, 20, Role.CLUTTER)}
    assert not tall_clutter & {p.asset for p in _placements(replace(clutter, altitude=10), 20,
                                                            Role.CLUTTER)}
