"""The water renderer (sdcomp.render.water.surface): API, determinism, geometry conventions,
exposure, the shading against a per-pixel exact reference, whitecaps, realism metric
targets."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from sdcomp.errors import UserError
from sdcomp.render.water import WaterLight, WaterTextures, auto_exposure, render_water
from sdcomp.render.water import textures as textures_module
from sdcomp.render.water.geometry import RESOLVE, horizon_row, view_plan
from sdcomp.render.water.sky import clear_diffuse_fraction, make_sky
from sdcomp.render.water.surface import view_water
from sdcomp.render.water.textures import N_LEVELS, pitch
from sdcomp.render.water.waves import level_continuous
from sdcomp.scene import camera
from sdcomp.scene.camera import CameraModel, CameraPose, ground_points
from sdcomp.scene.config import GeneratorConfig
from sdcomp.scene.sample import sample_water
from sdcomp.scene.water import WATER_PRESETS, WATER_TYPES, WaterParams, parse_water

from .water_reference import (
    REAL,
    highpass,
    luma,
    patch_stats,
    render_reference,
    summarise,
)

CONFIG = GeneratorConfig()


def _params(seed: int, config: GeneratorConfig = CONFIG, **changes) -> WaterParams:
    """The water of the generator's default ranges drawn with seed ``seed``, with
    ``changes``."""
    return replace(sample_water(np.random.default_rng(seed), config), **changes)


def test_sea_mask_matches_sdcomp_rays(water_textures):
    model = CameraModel(width=200, height=160)
    pose = CameraPose(30.0, 18.0, 40.0)
    img, info = render_water(model, pose, _params(3), water_textures)
    v, u = np.mgrid[0:160, 0:200] + 0.5
    _, hit = ground_points(model, pose, u, v)
    assert (info["sea_mask"] == hit).mean() > 0.999
    want = 80 - model.fy * math.tan(math.radians(18.0))
    assert horizon_row(160, model.fy, 18.0) == pytest.approx(want)
    assert camera.horizon_row(model, 18.0) == pytest.approx(want)


@pytest.mark.parametrize("size,pitch_deg", [((416, 416), 90.0), ((416, 416), 35.0),
                                             ((320, 180), 60.0), ((416, 416), 16.0)])
def test_render_api(water_textures, size, pitch_deg):
    model = CameraModel(width=size[0], height=size[1])
    p = _params(5)
    pose = CameraPose(25.0, pitch_deg, 10.0)
    img, info = render_water(model, pose, p, water_textures)
    assert img.shape == (size[1], size[0], 3) and img.dtype == np.uint8
    assert info["sea_mask"].shape == (size[1], size[0]) and info["sea_mask"].dtype == bool
    assert info["gain"] > 0 and np.all(np.isfinite(info["water_srgb"]))
    light = info["light"]
    assert isinstance(light, WaterLight) and light.gain == info["gain"]
    assert light.sun.shape == (3,) and abs(np.linalg.norm(light.sun) - 1) < 1e-9
    assert light.sun[2] == pytest.approx(math.sin(math.radians(p.sun_elevation)))
    assert np.all(light.beam_attenuation > light.absorption)
    assert np.all(light.water_radiance > 0)
    rad = light.sky.radiance(np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.01]]))
    assert rad.shape == (2, 3) and np.all(rad > 0)
    # the waves run along the tile direction nearest the wind (4 sets: within 22.5 degrees)
    off = (info["wind_dir_drawn"] - p.wind_dir) % 180.0
    assert min(off, 180.0 - off) <= 22.5 + 1e-9
    if pitch_deg > 30:
        assert info["sea_mask"].all()
    else:
        assert not info["sea_mask"][0].any() and info["sea_mask"][-1].all()
    out = np.empty_like(img)
    img2, _ = render_water(model, pose, p, water_textures, out=out)
    assert img2 is out and np.array_equal(img2, img)
    with pytest.raises(ValueError):
        render_water(model, pose, p, water_textures, shading="nope")


def test_light_at_follows_the_grids(water_textures):
    """WaterLight.at interpolates the coarse grids: at the image centre it is the
    centre's values, and a view of uniform water (no patches, no shallows, no cloud
    shadows) gives the same light everywhere."""
    model = CameraModel(width=416, height=416)
    p = _params(8, sky="clear", cloud_cover=0.0, patchiness=0.0, depth=None)
    _, info = render_water(model, CameraPose(30.0, 90.0, 0.0), p, water_textures)
    light = info["light"]
    for u, v in ((0.0, 0.0), (208.0, 208.0), (415.0, 100.0)):
        sun, l_w = light.at(u, v)
        np.testing.assert_allclose(sun, light.sun_irradiance, rtol=1e-5)
        np.testing.assert_allclose(l_w, light.water_radiance, rtol=1e-4)


def test_deterministic(water_textures):
    model = CameraModel(width=416, height=416)
    for pitch_deg in (90.0, 40.0):
        p = _params(9)
        a, _ = render_water(model, CameraPose(20.0, pitch_deg, 0.0), p, water_textures)
        b, _ = render_water(model, CameraPose(20.0, pitch_deg, 0.0), p, water_textures)
        assert a.tobytes() == b.tobytes()
        c, _ = render_water(model, CameraPose(20.0, pitch_deg, 0.0), replace(p, seed=p.seed + 1),
                            water_textures)
        assert a.tobytes() != c.tobytes()


def test_textures_deterministic(water_textures):
    # a tile built up front and one built on first use are the same, and so are the
    # noise and the clouds of the same seed
    a = WaterTextures.build(1, levels=range(4, 5), sets=(2,))
    b = water_textures
    assert a.levels[2][4] is not None and a.levels[2][5] is None
    assert np.array_equal(a.ensure(2, 4), b.ensure(2, 4))
    assert np.array_equal(a.uc_stack, b.uc_stack)
    assert np.array_equal(a.noise, b.noise) and np.array_equal(a.clouds.stack, b.clouds.stack)
    other = textures_module._noise(2)
    assert not np.array_equal(a.noise, other)


def test_sample_water_deterministic_and_presets():
    a = sample_water(np.random.default_rng(1), CONFIG)
    b = sample_water(np.random.default_rng(1), CONFIG)
    assert a == b and isinstance(a, WaterParams)
    for preset, types in WATER_PRESETS.items():
        config = GeneratorConfig(water=(preset,))
        got = [sample_water(np.random.default_rng(i), config) for i in range(30)]
        assert {p.water_type for p in got} <= set(types)
        assert {p.name for p in got} == {preset}
        for p in got:  # constituents within the drawn type's ranges
            for value, (lo, hi) in zip((p.chl, p.cdom, p.tsm), WATER_TYPES[p.water_type],
                                       strict=True):
                assert lo * (1 - 1e-9) <= value <= hi * (1 + 1e-9)
    with pytest.raises(UserError):
        GeneratorConfig(water=("purple",))
    assert parse_water("12,34,56") == ("12,34,56", ("coastal",), (12, 34, 56))
    with pytest.raises(UserError):
        parse_water("12,34,300")


def test_sample_water_follows_the_config():
    config = GeneratorConfig(water=("ocean",), wind="2-3", shallow=0.0, sky=("overcast",),
                             sun_elevation="30-40", turbidity=0.0)
    for i in range(20):
        p = sample_water(np.random.default_rng(i), config)
        assert p.water_type == "ocean" and p.depth is None and p.sky == "overcast"
        assert 2.0 <= p.wind <= 3.0 and 30.0 <= p.sun_elevation <= 40.0
        assert p.cloud_cover == 1.0
        assert p.slicks == 0.0 or p.wind < 6.0  # slicks only on calm water
    # turbidity 1: the murkiest of the type (constituents at the top of their ranges)
    clear = sample_water(np.random.default_rng(0), replace(config, turbidity=0.0))
    murky = sample_water(np.random.default_rng(0), replace(config, turbidity=1.0))
    assert murky.tsm > clear.tsm and murky.chl > clear.chl
    shallow = GeneratorConfig(shallow=1.0, floor_depth="2-4")
    depths = [sample_water(np.random.default_rng(i), shallow).depth for i in range(10)]
    assert all(d is not None and 2.0 <= d <= 4.0 for d in depths)


def test_auto_exposure():
    lum = np.array([0.01, 0.02, 0.05, 2.0])
    w = np.ones(4)
    g = auto_exposure(lum, w, 0.18)
    assert abs(np.mean(np.minimum(g * lum, 1.0)) - 0.18) < 1e-3
    g2 = auto_exposure(lum, w, 0.18, fixed=np.array([0.0, 0.0, 0.0, 0.5]))
    assert g2 < g and abs(np.mean(np.minimum(g2 * lum + [0, 0, 0, .5], 1.0)) - 0.18) < 2e-3
    # weights: metering only the first value exposes it to the target
    g3 = auto_exposure(lum, np.array([1.0, 0, 0, 0]), 0.18)
    assert g3 * lum[0] == pytest.approx(0.18, rel=1e-3)


def test_exposure_lands_on_target(water_textures):
    model = CameraModel(width=416, height=416)
    for i in range(4):  # no glitter in view (sun behind, low), overcast or clear
        p = _params(40 + i, sun_elevation=30.0, exposure_target=0.18)
        img, info = render_water(model, CameraPose(30.0, 90.0, p.sun_azimuth + 180), p,
                                 water_textures, glint="none")
        lin = (img / 255.0) ** 2.2
        y = (lin * [0.2126, 0.7152, 0.0722]).sum(-1).mean()
        assert 0.12 < y < 0.26


def test_no_texture_magnified():
    # the drawn level's shortest wave spans at least RESOLVE pixels everywhere it is drawn
    model = CameraModel(width=416, height=416)
    for pitch_deg in (25.0, 45.0, 70.0):
        plan = view_plan(416, 416, model.fx, model.fy, pitch_deg)
        geo = plan.row_geometry(20.0)
        fp = np.maximum(geo["across"], geo["along"])
        flev = level_continuous(np.where(geo["ok"], fp, 1.0))
        lev = np.clip(np.ceil(flev - 1e-9), 0, N_LEVELS).astype(int)
        ok = geo["ok"] & (lev < N_LEVELS)
        assert ok.sum() > 100  # most sea rows draw waves
        finest = 4 * pitch(0) * 2.0 ** lev[ok]
        assert np.all(finest >= RESOLVE * fp[ok] * (1 - 1e-6))


@pytest.mark.parametrize("elevation", [30.0, 60.0])
def test_clear_sky_irradiance_is_the_integral_of_its_radiance(elevation):
    """A clear sky's irradiance on a horizontal surface is the integral of its radiance
    times cos(zenith) over the hemisphere, and its share of the global irradiance (with
    the sun's E cos Z) is the clear-sky diffuse fraction."""
    sky = make_sky("clear", elevation, 40.0, 0.0, None, 1500.0, 12.0, (0.0, 0.0), 0.9, 2e4)
    n = 200
    th = (np.arange(n) + 0.5) / n * math.pi / 2
    ph = (np.arange(2 * n) + 0.5) / (2 * n) * 2 * math.pi
    t, f = np.meshgrid(th, ph, indexing="ij")
    d = np.stack([np.sin(t) * np.cos(f), np.sin(t) * np.sin(f), np.cos(t)], -1)
    rad = sky.radiance(d.reshape(-1, 3)).reshape(n, 2 * n, 3)
    w = np.cos(t) * np.sin(t) * (math.pi / 2 / n) * (math.pi / n)
    e = (rad * w[..., None]).sum((0, 1))
    np.testing.assert_allclose(e, sky.e_sky_rgb, rtol=0.03)  # (quadrature, horizon haze)
    direct = sky.e_sun * math.sin(math.radians(elevation))
    assert sky.e_sky / (sky.e_sky + direct) == pytest.approx(
        clear_diffuse_fraction(elevation), rel=1e-6)
    # bluer overhead than at the horizon
    zen = sky.radiance(np.array([0.0, 0.0, 1.0]))
    hor = sky.radiance(np.array([-1.0, 0.0, 0.0]))
    assert zen[2] / zen[0] > hor[2] / hor[0]


def test_custom_colour_keeps_its_hue(water_textures):
    """A custom water colour R,G,B is the water body's colour: straight down under an
    overcast sky (its grey reflection added) the sea keeps the colour's channel order."""
    model = CameraModel(width=256, height=256)
    for rgb in ((40, 90, 60), (120, 80, 40), (30, 60, 120)):
        config = GeneratorConfig(water=(",".join(map(str, rgb)),), sky=("overcast",))
        p = replace(sample_water(np.random.default_rng(0), config), patchiness=0.0, depth=None)
        assert p.rgb == rgb
        _, info = render_water(model, CameraPose(30.0, 90.0, 0.0), p, water_textures,
                               glint="none")
        assert list(np.argsort(info["water_srgb"])) == list(np.argsort(rgb))


# ------------------------------------------------------------------ shading vs reference

SCENES = [  # (water type, sky, wind m/s, pitch, heading): the textured cases
    ("ocean", "clear", 4.0, 90.0, 0.0), ("lake", "clear", 5.0, 90.0, 120.0),
    ("coastal", "clear", 3.0, 90.0, 250.0), ("ocean", "broken", 6.0, 90.0, 40.0),
    ("lake", "overcast", 5.0, 90.0, 300.0), ("ocean", "clear", 4.0, 60.0, 30.0),
    ("coastal", "clear", 6.0, 45.0, 200.0), ("lake", "broken", 3.0, 70.0, 100.0)]


@pytest.fixture(scope="module")
def shaded(water_textures) -> list[dict]:
    """Per scene of SCENES (320 px, 25 m, no glitter, no whitecaps): the luminance of the
    fast and the per-pixel linearised ("exact") shading and of the exact reference, and the
    sea mask."""
    model = CameraModel(width=320, height=320)
    out = []
    for i, (wtype, sky, wind, pitch_deg, heading) in enumerate(SCENES):
        (c0, c1), (g0, g1), (t0, t1) = WATER_TYPES[wtype]
        p = WaterParams(name=wtype, water_type=wtype, chl=math.sqrt(c0 * c1),
                        cdom=math.sqrt(g0 * g1), tsm=math.sqrt(t0 * t1), wind=wind,
                        wind_dir=37.0 * i, sky=sky,
                        cloud_cover={"clear": 0.0, "broken": 0.4, "overcast": 1.0}[sky],
                        sun_elevation=50.0, sun_azimuth=80.0 * i, foam_scale=0.0, seed=i + 1)
        pose = CameraPose(25.0, pitch_deg, heading)
        fast, info = render_water(model, pose, p, water_textures, glint="none")
        exact, _ = render_water(model, pose, p, water_textures, glint="none", shading="exact")
        ref, _ = render_reference(model, pose, p, water_textures)
        out.append({"fast": luma(fast), "exact": luma(exact), "ref": luma(ref),
                    "mask": info["sea_mask"], "rgb": (fast, ref)})
    return out


def _hp_corr(a: np.ndarray, b: np.ndarray, mask: np.ndarray) -> float:
    return float(np.corrcoef(highpass(a)[mask], highpass(b)[mask])[0, 1])


def test_linearised_shading_matches_the_exact_reference(shaded):
    """The shading is linear in the drawn slopes about the coarse grid's mean normal: per
    pixel (``shading="exact"``) its waves are the reference's (the same slopes through the
    exact reflection and transmission), as strong within a factor of 2 (the second-order
    terms weaken it most in steep oblique views, where Fresnel's reflectance curves within
    one slope standard deviation), the mean within those terms (a few levels)."""
    for s in shaded:
        m = s["mask"]
        hp_ref = highpass(s["ref"])[m].std()
        assert hp_ref > 0.5  # these scenes have visible waves
        assert _hp_corr(s["exact"], s["ref"], m) > 0.5
        assert 0.5 < highpass(s["exact"])[m].std() / hp_ref < 2.0
        assert abs((s["exact"] - s["ref"])[m].mean()) < 3.0


def test_fast_shading_matches_the_reference_in_strength_and_colour(shaded):
    """The fast path (one slope direction per image, uint8 passes): the texture's strength
    within a factor of 2 of the reference, the mean colour within 3 levels per channel."""
    for s in shaded:
        m = s["mask"]
        ratio = highpass(s["fast"])[m].std() / highpass(s["ref"])[m].std()
        assert 0.5 < ratio < 2.0
        fast, ref = s["rgb"]
        assert np.all(np.abs(fast[m].mean(0) - ref[m].mean(0)) < 3.0)


def test_fast_shading_has_the_sign_of_the_reference(shaded):
    """The fast path draws the same waves as the exact shading, bright where the
    reference is bright: its high-pass correlates positively with the reference's (one
    slope direction per image cannot follow every scene: none clearly negative, most
    clearly positive)."""
    corr = [_hp_corr(s["fast"], s["ref"], s["mask"]) for s in shaded]
    assert min(corr) > -0.2 and np.mean(corr) > 0.3, corr


# ------------------------------------------------------------------ whitecaps

def _foam_added(water_textures, foam_scale: float, wind: float = 8.0):
    """(brightening of each pixel by whitecaps (H, W) levels, whitecap cover, the view)
    at pitch 20 degrees (the horizon in view), overcast, fully developed sea."""
    model = CameraModel(width=416, height=416)
    p = WaterParams(water_type="ocean", chl=0.3, cdom=0.02, tsm=0.3, wind=wind,
                    wave_age=0.84, sky="overcast", cloud_cover=1.0, foam_scale=foam_scale,
                    visibility=40000.0, seed=3)
    pose = CameraPose(30.0, 20.0, 0.0)
    view = view_water(model, pose, p, water_textures)
    a, _ = render_water(model, pose, p, water_textures, glint="none")
    b, _ = render_water(model, pose, replace(p, foam_scale=0.0), water_textures, glint="none")
    added = (a.astype(np.int16) - b).max(axis=2).astype(float)
    return added, view.waves.foam * foam_scale, view


@pytest.mark.parametrize("wind,foam_scale", [(8.0, 1.0), (8.0, 5.0), (12.0, 1.0)])
def test_whitecaps_cover_their_fraction_of_the_drawn_sea(water_textures, wind, foam_scale):
    """Monahan's coverage W: the fraction of (drawn) sea pixels that whitecaps brighten is
    about W (soft edges widen it; the foam field is one random realisation)."""
    added, cover, view = _foam_added(water_textures, foam_scale, wind)
    rows = np.arange(added.shape[0])
    drawn = (rows >= view.plan.sea_row0) & (view.levels_rows < N_LEVELS)
    frac = float((added[drawn] > 0).mean())
    assert 0.2 * cover < frac < 2 * cover, (frac, cover)


def test_whitecaps_do_not_fill_the_undrawn_horizon_rows(water_textures):
    """Rows too far to draw waves get whitecaps as a fraction of the sea too, not as a
    solid band: their mean brightening stays within a few times W of full foam's."""
    added, cover, view = _foam_added(water_textures, 5.0)
    rows = np.arange(added.shape[0])
    far = (rows >= view.plan.sea_row0) & (view.levels_rows >= N_LEVELS)
    assert far.sum() >= 8  # the view has such rows
    assert added[far].mean() < 5 * cover * added.max() + 1.0


# ------------------------------------------------------------------ realism metrics

def test_patch_metrics_follow_their_definition():
    """The test helper's metrics against a direct per-patch computation (numpy padding for
    the 9 x 9 box mean, loops over patches)."""
    rng = np.random.default_rng(0)
    img = (rng.random((200, 300, 3)) ** 2 * 255).astype(np.uint8)
    valid = np.ones((200, 300), bool)
    valid[:40] = False
    got = patch_stats(img, valid)
    f = img.astype(np.float64)
    y = 0.299 * f[..., 0] + 0.587 * f[..., 1] + 0.114 * f[..., 2]
    pad = np.pad(y, 4, mode="reflect")  # reflect without the edge: BORDER_REFLECT_101
    box = sum(pad[i:i + 200, j:j + 300] for i in range(9) for j in range(9)) / 81
    hp = y - box
    mx, mn = f.max(2), f.min(2)
    sat = np.where(mx > 0, (mx - mn) / np.maximum(mx, 1), 0.0)
    want = {k: [] for k in got}
    for r in range(1, 3):  # patch row 0 holds invalid pixels
        for c in range(4):
            sl = np.s_[r * 64:(r + 1) * 64, c * 64:(c + 1) * 64]
            want["saturation"].append(sat[sl].mean())
            want["luminance"].append(y[sl].mean())
            want["highpass_std"].append(hp[sl].std())
            want["glint_fraction"].append((y[sl] >= 230).mean())
    for k in got:
        np.testing.assert_allclose(got[k], want[k], rtol=1e-4, atol=1e-4)


#: the generator's default waters and skies, one config per (preset, sky) pair: drawn in turn
#: (stratified), they give the default mix with less sampling noise than free draws
STRATA = [GeneratorConfig(water=(w,), sky=(k,)) for w in CONFIG.water for k in CONFIG.sky]


@pytest.fixture(scope="module")
def metric_summary(water_textures):
    """Metrics of 72 renders of the generator's default water and light (every preset
    under every sky in turn; altitude 10-50 m, every other one straight down, the rest at
    pitch 20-90 degrees, any heading)."""
    model = CameraModel(width=416, height=416)
    rng = np.random.default_rng([0, 19])
    stats = []
    for k in range(72):
        alt = float(rng.uniform(10, 50))
        pitch_deg = 90.0 if k % 2 == 0 else float(rng.uniform(20, 90))
        pose = CameraPose(alt, pitch_deg, float(rng.uniform(0, 360)))
        params = sample_water(rng, STRATA[k % len(STRATA)])
        img, info = render_water(model, pose, params, water_textures)
        stats.append(patch_stats(img, info["sea_mask"]))
    return summarise(stats)


def test_metric_targets(metric_summary):
    s = metric_summary
    assert s["luminance"]["n"] > 2500
    assert 0.10 <= s["saturation"]["median"] <= 0.25
    assert 100 <= s["luminance"]["median"] <= 150
    assert s["highpass_std"]["p90"] > 15
    # spreads at least as wide as the real frames'
    real_sat = REAL["saturation"][2] - REAL["saturation"][1]
    assert s["saturation"]["p90"] - s["saturation"]["p10"] >= real_sat
    real_hp = REAL["highpass_std"][2] - REAL["highpass_std"][1]
    assert s["highpass_std"]["p90"] - s["highpass_std"]["p10"] >= real_hp
    # glint: none in most patches, whole glitter fields in some
    assert s["glint_fraction"]["p10"] == 0.0 and s["glint_fraction"]["p90"] > 0.05


@pytest.mark.xfail(reason="noise-free renders: median high-pass ~2.5-4.5 levels over 72 "
                          "renders (the real frames' 6.2 include sensor noise and JPEG)",
                   strict=False)
def test_metric_highpass_median(metric_summary):
    assert 4 <= metric_summary["highpass_std"]["median"] <= 8
