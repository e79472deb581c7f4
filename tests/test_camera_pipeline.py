"""The drone camera stage as a whole (sdcomp.render.camera.pipeline.apply_camera) and its
per-image look (sdcomp.scene.look, sdcomp.scene.look_table): the clean preset, determinism,
looks, switches, the scale rule, huge frames."""

from __future__ import annotations

import json
import math
from dataclasses import replace

import numpy as np
import pytest

from sdcomp.render.camera import STAGES, apply_camera, pipeline
from sdcomp.render.camera import lens as L
from sdcomp.render.camera.photometric import (
    apply_colour,
    apply_lut,
    colour_matrix,
    photometric_tables,
    white_balance_gains,
)
from sdcomp.render.camera.scale import SHARPEN_SIGMA_MIN, scaled_blur, scaled_sharpen
from sdcomp.render.camera.sensor import make_noise_tile
from sdcomp.render.effects import motion_blur
from sdcomp.scene.look import H265_GAIN, PRESETS, CameraLook, quality_for_bpp
from sdcomp.scene.look_table import PARAMS, clean_look, sample_look

from .conftest import squares, water_like

CAMERAS = [p for p in PRESETS if p != "clean"]
#: the stages a look without a site grade runs (the grade: tests/test_site_grade.py)
UNGRADED = [s for s in STAGES if s != "grade"]


def test_clean_preset_is_exactly_the_identity(frame416):
    img, ins = frame416
    amodal = np.stack([ins == k for k in (1, 2, 3)])
    tile = make_noise_tile((0,), 416, 416)
    for seed in range(5):
        look = sample_look("clean", np.random.default_rng(seed), 416, 416)
        out, oins, oam, info = apply_camera(img, ins, look, tile, amodal)
        assert np.array_equal(out, img) and out is not img
        assert np.array_equal(oins, ins) and oins is not ins
        assert np.array_equal(oam, amodal)
        assert info["stages"] == [] and info["zoom"] == 1.0
    big = np.tile(water_like(270, 480, 2), (8, 8, 1))  # 4K
    out, _, _, info = apply_camera(big, np.zeros((2160, 3840), np.uint16),
                                   clean_look(3840, 2160), None)
    assert np.array_equal(out, big) and info["stages"] == []


@pytest.mark.parametrize("preset", CAMERAS)
@pytest.mark.parametrize("w,h", [(416, 416), (640, 360)])
def test_same_look_same_bytes(preset, w, h):
    img = water_like(h, w, 5)
    ins = squares(h, w, [(50, 50, 20), (200, 100, 25)])
    tile = make_noise_tile((3,), h, w)
    # native scale so every stage runs
    look = replace(sample_look(preset, np.random.default_rng(9), w, h), native_width=w,
                   native_height=h, motion_px=6.0)
    a = apply_camera(img, ins, look, tile)
    L.clear_caches()
    b = apply_camera(img.copy(), ins.copy(), CameraLook.from_dict(json.loads(look.to_json())),
                     tile.copy())
    assert a[0].tobytes() == b[0].tobytes() and a[1].tobytes() == b[1].tobytes()
    assert set(a[3]["stages"]) == set(UNGRADED)
    assert a[0].dtype == np.uint8 and a[0].shape == (h, w, 3)
    assert a[1].dtype == np.uint16 and a[1].shape == (h, w)
    assert not np.array_equal(a[0], img)


def test_input_is_not_modified(frame416):
    img, ins = frame416
    keep_img, keep_ins = img.copy(), ins.copy()
    look = replace(sample_look("zenmuse-x5", np.random.default_rng(3), 416, 416),
                   native_width=416, native_height=416)
    apply_camera(img, ins, look, make_noise_tile((0,), 416, 416))
    assert np.array_equal(img, keep_img) and np.array_equal(ins, keep_ins)


@pytest.mark.parametrize("preset", list(PRESETS))
def test_looks_are_drawn_within_their_ranges_and_json_round_trip(preset):
    for seed in range(30):
        look = sample_look(preset, np.random.default_rng(seed), 416, 416)
        d = look.to_dict()
        assert CameraLook.from_dict(json.loads(json.dumps(d))) == look
        for name, spec in PARAMS.items():
            r = spec.range_for(preset)
            v = d[name]
            if preset == "clean":
                assert v == spec.identity
            elif r.dist == "choice":
                assert v in r.choices or name == "codec"
            elif name != "jpeg_quality" and v != spec.identity:
                hi = r.hi * (H265_GAIN if name == "codec_efficiency" else 1)
                assert r.lo - 1e-12 <= v <= hi + 1e-12, (name, v)
                if r.step:
                    assert abs(v / r.step - round(v / r.step)) < 1e-6
    assert sample_look(preset, np.random.default_rng(1), 416, 416) == sample_look(
        preset, np.random.default_rng(1), 416, 416)


def test_motion_probability_switches_motion_blur():
    never = [sample_look("mavic2pro", np.random.default_rng(i), 416, 416, motion=0.0)
             for i in range(20)]
    always = [sample_look("mavic2pro", np.random.default_rng(i), 416, 416, motion=1.0)
              for i in range(20)]
    assert all(lk.motion_px == 0.0 for lk in never)
    assert all(lk.motion_px > 0.0 for lk in always)
    with pytest.raises(ValueError):
        sample_look("nope", np.random.default_rng(0), 416, 416)


def test_exposure_and_white_balance_set_by_the_user():
    """--exposure-bias, --wb-red, --wb-blue, --contrast, --saturation, --shot-noise and
    --sharpening replace the look's draws of exposure_ev, wb_red, wb_blue, contrast,
    saturation, noise_a and sharpen_amount (a range, a value or a list, whatever the
    preset, clean too); every other parameter and the scene's other draws stay those of
    the default config."""
    import sdcomp.scene.sample as S
    from sdcomp.errors import SettingError
    from sdcomp.scene.config import GeneratorConfig

    base = GeneratorConfig()
    mine = GeneratorConfig.from_mapping({"exposure_bias": "-1:-0.5", "wb_red": 1.4,
                                         "wb_blue": [0.7, 0.8], "contrast": 1.7,
                                         "saturation": "0.4-0.6", "shot_noise": 0.02,
                                         "sharpening": 0})
    changed = {"exposure_ev", "wb_red", "wb_blue", "contrast", "saturation", "noise_a",
               "sharpen_amount"}
    targets = []
    for i in range(40):
        a, b = S.sample_scene(base, i), S.sample_scene(mine, i)
        assert a.placements == b.placements and a.camera == b.camera
        for name in PARAMS:
            if name not in changed:
                assert getattr(a.look, name) == getattr(b.look, name), name
        assert b.look.wb_red == 1.4 and b.look.wb_blue in (0.7, 0.8)
        assert b.look.contrast == 1.7 and 0.4 <= b.look.saturation <= 0.6
        assert b.look.noise_a == 0.02 and b.look.sharpen_amount == 0.0
        # the bias is folded into the water's exposure target (sample.expose)
        targets.append(math.log2(b.water.exposure_target / b.look.ae_target))
    assert -1.0 - 1e-9 <= min(targets) < -0.9 and -0.6 < max(targets) <= -0.5 + 1e-9
    lk = sample_look("clean", np.random.default_rng(0), 64, 64,
                     overrides={"wb_red": mine.wb_red, "exposure_ev": None})
    assert lk.wb_red == 1.4 and lk.exposure_ev == 0.0
    again = GeneratorConfig.from_mapping(json.loads(json.dumps(mine.to_dict())))
    assert again == mine and "wb_red = 1.4" in mine.to_toml()
    with pytest.raises(SettingError, match="0.2 to 5"):
        GeneratorConfig.from_mapping({"wb_red": 0.0})
    with pytest.raises(SettingError, match="0.5 to 2.5"):
        GeneratorConfig.from_mapping({"contrast": 3})
    with pytest.raises(SettingError, match="0 to 0.1"):
        GeneratorConfig.from_mapping({"shot_noise": 0.5})
    with pytest.raises(SettingError, match="0 to 3"):
        GeneratorConfig.from_mapping({"sharpening": -1})


def test_camera_off_leaves_stages_out_of_a_generated_image(sprites_dir):
    """--camera-off: the same scene and look draws, the same labels; the stages named do not
    run (the others' bytes are those of apply_camera without them); names are checked and
    put in the stages' order."""
    from sdcomp import Generator, GeneratorConfig
    from sdcomp.errors import SettingError

    base = GeneratorConfig(width=1280, height=720, clutter=0, look="mavic2pro")
    off = GeneratorConfig.from_mapping({**base.to_dict(), "camera_off": "Compression, noise"})
    assert off.camera_off == ("noise", "compression") and base.camera_off == ()
    a, b = Generator(base, sprites_dir), Generator(off, sprites_dir)
    fa, fb = a.render(1), b.render(1)
    assert fb.scene.look == replace(fa.scene.look, off=("noise", "compression"))
    assert "compression" in fa.camera["stages"]
    assert fb.camera["stages"] == [s for s in fa.camera["stages"]
                                   if s not in ("noise", "compression")]
    assert np.array_equal(fa.instances, fb.instances)
    assert not np.array_equal(fa.image, fb.image)
    drawn = b.compositor.render(fb.scene)
    by_hand = apply_camera(drawn.image, fb.instances, fa.scene.look,
                           b.compositor.noise_tile(fb.scene.model, fb.scene.seeds.noise_tile),
                           enabled=fb.camera["stages"])[0]
    assert np.array_equal(fb.image, by_hand)
    with pytest.raises(SettingError, match="'blocks' is unknown"):
        GeneratorConfig(camera_off=("lens", "blocks"))


def test_video_quality_comes_from_bits_per_pixel():
    look = sample_look("mavic2pro", np.random.default_rng(0), 416, 416)
    assert (look.native_width, look.native_height) == (3840, 2160)
    bpp = look.bitrate_mbps * 1e6 / (look.fps * 3840 * 2160)
    assert look.target_bpp == pytest.approx(bpp)
    assert look.jpeg_quality == quality_for_bpp(bpp * look.codec_efficiency)
    photo = sample_look("phantom4pro", np.random.default_rng(0), 416, 416, recording="photo")
    assert (photo.native_width, photo.codec) == (5472, "jpeg") and 88 <= photo.jpeg_quality <= 96
    # the focal length: the preset's diagonal field of view over the frame (photo frame)
    fx = math.hypot(5472, 3648) / 2 / math.tan(math.radians(84.0) / 2) * 416 / 5472
    assert photo.fx == pytest.approx(fx)


def test_all_switches_off_is_the_identity(frame416):
    img, ins = frame416
    look = sample_look("zenmuse-x5", np.random.default_rng(2), 416, 416)
    out, oins, _, info = apply_camera(img, ins, look, make_noise_tile((0,), 416, 416),
                                      enabled=[])
    assert np.array_equal(out, img) and np.array_equal(oins, ins) and info["stages"] == []
    with pytest.raises(ValueError):
        apply_camera(img, ins, look, None, enabled=["nope"])
    with pytest.raises(ValueError):  # the look is for another frame size
        apply_camera(img[:200], ins[:200], look, None)


def test_one_stage_alone_is_that_stage(frame416):
    """Switching on the photometric stage alone applies the look's table (exposure from
    the metered mean, white balance, tone curve) and nothing else."""
    img, ins = frame416
    look = sample_look("phantom4pro", np.random.default_rng(6), 416, 416)
    out, oins, _, info = apply_camera(img, ins, look, None, enabled=["photometric"])
    assert info["stages"] == ["photometric"] and np.array_equal(oins, ins)
    wb = white_balance_gains(look.wb_red, look.wb_blue, look.wb_tint)
    table = photometric_tables(info["exposure_gain"], wb, look.highlight_knee, look.flat,
                               look.contrast, look.gamma, look.black_lift)
    assert np.array_equal(out, apply_lut(img, table))
    out, _, _, info = apply_camera(img, ins, look, None, enabled=["colour"])
    assert info["stages"] == ["colour"]
    assert np.array_equal(out, apply_colour(img, colour_matrix(look.saturation)))


def test_stages_the_look_leaves_out_do_not_run(frame416):
    """A look's ``off`` stages (the user's --camera-off) are left out whatever ``enabled``
    says; the rest give the bytes of the same stages switched on by hand; an unknown name in
    ``off`` is refused."""
    img, ins = frame416
    tile = make_noise_tile((0,), 416, 416)
    look = replace(sample_look("phantom4pro", np.random.default_rng(4), 416, 416),
                   native_width=416, native_height=416, motion_px=5.0)
    full, _, _, info = apply_camera(img, ins, look, tile)
    assert info["stages"] == UNGRADED
    for stage in UNGRADED:  # each one alone left out, the rest run
        _, _, _, info = apply_camera(img, ins, replace(look, off=(stage,)), tile)
        assert info["stages"] == [s for s in UNGRADED if s != stage]
    off = replace(look, off=("noise", "compression"))
    out, oins, _, info = apply_camera(img, ins, off, tile)
    assert info["stages"] == [s for s in UNGRADED if s not in off.off]
    rest = [s for s in UNGRADED if s not in off.off]
    by_hand, hins, _, _ = apply_camera(img, ins, look, tile, enabled=rest)
    assert np.array_equal(out, by_hand) and np.array_equal(oins, hins)
    assert not np.array_equal(out, full)
    out, _, _, info = apply_camera(img, ins, off, tile, enabled=["noise", "colour"])
    assert info["stages"] == ["colour"]
    assert CameraLook.from_dict(json.loads(off.to_json())) == off
    with pytest.raises(ValueError, match="blocks"):
        apply_camera(img, ins, replace(look, off=("blocks",)), tile)


def test_scale_rule_far_from_native_keeps_the_look_only(frame416):
    """416 px standing for a 5472 x 3648 photo (f = 13): no noise, no demosaicing blur, no
    compression; the geometry and photometric look remain."""
    img, ins = frame416
    tile = make_noise_tile((0,), 416, 416)
    for seed in range(6):
        look = sample_look("mavic2pro", np.random.default_rng(seed), 416, 416,
                           recording="photo")
        _, _, _, info = apply_camera(img, ins, look, tile)
        assert not {"demosaic", "compression"} & set(info["stages"])
        assert "photometric" in info["stages"] and "lens" in info["stages"]
        assert ("noise" in info["stages"]) == (info["noise_sigma_max"] >= 0.5)
        amount, sigma = info["sharpen"]
        assert amount < 0.25 * look.sharpen_amount
        sx, sy = info["scale"]
        assert info["motion_px"] == pytest.approx(look.motion_px * math.hypot(
            math.cos(math.radians(look.motion_angle)) / sx,
            math.sin(math.radians(look.motion_angle)) / sy))


def test_scale_rule_at_native_runs_everything(frame416):
    img, ins = frame416
    look = replace(sample_look("phantom4pro", np.random.default_rng(4), 416, 416),
                   native_width=416, native_height=416, motion_px=5.0)
    _, _, _, info = apply_camera(img, ins, look, make_noise_tile((0,), 416, 416))
    assert set(info["stages"]) == set(UNGRADED)
    assert info["stages"] == [s for s in STAGES if s in info["stages"]]  # in order
    assert info["sharpen"] == (look.sharpen_amount, look.sharpen_radius)
    assert info["bpp_jpeg"] > 0 and info["compression_factor"] == (1, 1)


def test_effective_camera_is_reported(frame416):
    img, ins = frame416
    look = sample_look("zenmuse-x5", np.random.default_rng(1), 416, 416)
    _, _, _, info = apply_camera(img, ins, look, None)
    z = info["zoom"]
    assert z > 1  # barrel distortion (k1 < 0): zoomed in so no border is empty
    assert info["K"][0][0] == pytest.approx(look.fx * z) and info["dist"][:2] == [look.k1,
                                                                                look.k2]
    assert info["K"][0][2] == pytest.approx((416 - 1) / 2)


def test_huge_frames_get_the_point_wise_stages_only():
    """A frame over HUGE_SIDE px (a mosaic) is changed in place, band by band, by the
    photometric table and the saturation only: no lens geometry (its labels stay)."""
    w, h = pipeline.HUGE_SIDE + 8, 600
    assert w * h > pipeline.HUGE_BAND_PIXELS  # more than one band
    img = np.ascontiguousarray(np.tile(water_like(h, 1050, 7), (1, 8, 1))[:, :w])
    ins = squares(h, w, [(100, 100, 30), (8000, 500, 40)])
    look = sample_look("zenmuse-x5", np.random.default_rng(5), w, h)
    assert look.k1 < 0 and abs(look.saturation - 1) > 0.01
    want_in = img.copy()
    out, oins, _, info = apply_camera(img, ins, look, None)
    assert out is img  # in place: a mosaic of gigabytes is not copied
    assert set(info["stages"]) == {"photometric", "colour"} and info["zoom"] == 1.0
    assert oins is ins  # the pinhole geometry: the labels are not copied either
    wb = white_balance_gains(look.wb_red, look.wb_blue, look.wb_tint)
    table = photometric_tables(info["exposure_gain"], wb, look.highlight_knee, look.flat,
                               look.contrast, look.gamma, look.black_lift)
    want = apply_colour(apply_lut(want_in, table), colour_matrix(look.saturation))
    assert np.array_equal(out, want)


def test_scaled_sharpen_rule():
    a, s = scaled_sharpen(1.0, 1.2, 1.0, 1.0)
    assert (a, s) == (1.0, 1.2)
    a, s = scaled_sharpen(1.0, 1.2, 13.0, 13.0)
    assert s == SHARPEN_SIGMA_MIN and 0 < a < 0.1
    amounts = [scaled_sharpen(1.0, 1.2, f, f)[0] for f in (1, 2, 4, 8, 16)]
    assert amounts == sorted(amounts, reverse=True)
    # below the narrowest mask: the same boost at the output's Nyquist frequency
    sig = 1.2 / 4.0
    boost = 1 - math.exp(-(math.pi * sig) ** 2 / 2)
    a, s = scaled_sharpen(1.0, 1.2, 4.0, 4.0)
    assert a * (1 - math.exp(-(math.pi * s) ** 2 / 2)) == pytest.approx(boost)
    assert scaled_blur(2.0, 4.0, 2.0) == (0.5, 1.0)  # Gaussians scale exactly


def test_motion_blur_spreads_a_dot_along_the_angle():
    img = np.zeros((81, 81, 3), np.uint8)
    img[40, 40] = 255
    for length, angle in ((5.0, 0.0), (5.0, 90.0), (12.0, 30.0), (20.0, 135.0)):
        out = motion_blur(img, length, angle)[..., 0].astype(float)
        ys, xs = np.nonzero(out)
        wts = out[ys, xs]
        cx, cy = (xs * wts).sum() / wts.sum(), (ys * wts).sum() / wts.sum()
        assert abs(cx - 40) < 0.6 and abs(cy - 40) < 0.6
        d = np.array([np.cos(np.radians(angle)), np.sin(np.radians(angle))])
        along = ((xs - 40) * d[0] + (ys - 40) * d[1])
        across = (-(xs - 40) * d[1] + (ys - 40) * d[0])
        assert np.ptp(along) >= length - 2.5 and np.abs(across).max() <= 1.5 + length / 8
