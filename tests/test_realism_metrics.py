"""The realism metrics on constructed inputs: the per-patch statistics and the empty-water
selector, the luminance power spectrum, and the classifier's parts."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from sdcomp.report.realism import classifier as clf
from sdcomp.report.realism.patches import (
    boxes_mask,
    concat_stats,
    empty_water,
    highpass,
    image_maps,
    luminance,
    patch_origins,
    patch_stats,
    saturation,
    summarise,
    to_patches,
)
from sdcomp.report.realism.spectrum import (
    SpectrumAccumulator,
    metre_edges,
    patch_power,
    plot_spectra,
)


def grey(value, h=64, w=64):
    return np.full((h, w, 3), value, np.uint8)


def test_flat_grey_patch():
    s = patch_stats(grey(100))
    assert s["saturation"].tolist() == [0.0]
    assert s["highpass_std"].tolist() == [0.0]
    assert s["glint_fraction"].tolist() == [0.0]
    assert s["luminance"][0] == pytest.approx(100.0, abs=1e-4)
    m = image_maps(grey(100, 130, 200))
    assert np.all(m.hp == 0) and np.all(m.s == 0)


def test_checkerboard():
    """A 1-px black/white checkerboard: a 9x9 window holds 41 of its centre's colour, so the
    high-pass is +-255 * 40 / 81 everywhere (reflect-101 borders keep the parity)."""
    yy, xx = np.mgrid[0:128, 0:128]
    img = np.repeat((((xx + yy) % 2) * 255).astype(np.uint8)[..., None], 3, axis=2)
    s = patch_stats(img)
    assert len(s["luminance"]) == 4
    np.testing.assert_allclose(s["highpass_std"], 255 * 40 / 81, rtol=1e-5)
    np.testing.assert_allclose(s["luminance"], 127.5, rtol=1e-5)
    np.testing.assert_allclose(s["glint_fraction"], 0.5)
    np.testing.assert_allclose(s["saturation"], 0.0)
    hp = highpass(luminance(img))
    assert hp[0, 0] == pytest.approx(-255 * 40 / 81, rel=1e-5)
    assert hp[0, 1] == pytest.approx(255 * 40 / 81, rel=1e-5)


@pytest.mark.parametrize("k", [0, 1, 37, 4096])
def test_glint_fraction_counts_saturated_pixels(k):
    img = grey(100)
    img.reshape(-1, 3)[np.random.default_rng(k).choice(4096, k, replace=False)] = 255
    assert patch_stats(img)["glint_fraction"][0] == k / 4096


def test_glint_threshold_is_luminance_230():
    assert patch_stats(grey(230))["glint_fraction"][0] == 1.0
    assert patch_stats(grey(229))["glint_fraction"][0] == 0.0
    red = np.zeros((64, 64, 3), np.uint8)
    red[..., 0] = 255  # Y = 76: bright red is not glint
    assert patch_stats(red)["glint_fraction"][0] == 0.0


def test_saturation_of_pure_colours():
    red = np.zeros((64, 64, 3), np.uint8)
    red[..., 0] = 255
    s = patch_stats(red)
    assert s["saturation"][0] == 1.0
    assert s["luminance"][0] == pytest.approx(0.299 * 255, rel=1e-6)
    assert patch_stats(grey(0))["saturation"][0] == 0.0  # max = 0
    px = np.array([[[200, 100, 50]]], np.uint8)
    assert saturation(px)[0, 0] == pytest.approx(150 / 200)


def test_highpass_is_computed_on_the_whole_image():
    """A step at the boundary between two patches shows in both patches' high-pass (the blur
    sees across), while each patch alone is flat."""
    img = grey(0, 64, 128)
    img[:, 64:] = 200
    s = patch_stats(img)
    assert np.all(s["highpass_std"] > 1.0)
    assert patch_stats(img[:, :64])["highpass_std"][0] == 0.0


def test_grid_and_patches():
    a = np.arange(130 * 200).reshape(130, 200)
    p = to_patches(a)
    assert p.shape == (6, 64, 64)  # 2 rows x 3 columns; remainders dropped
    o = patch_origins(130, 200)
    assert o.tolist() == [[0, 0], [64, 0], [128, 0], [0, 64], [64, 64], [128, 64]]
    for (x, y), patch in zip(o, p, strict=True):
        np.testing.assert_array_equal(patch, a[y:y + 64, x:x + 64])
    rgb = np.zeros((130, 200, 3), np.uint8)
    assert to_patches(rgb).shape == (6, 64, 64, 3)


def test_empty_water_excludes_mask_pixels():
    inst = np.zeros((128, 192), np.uint16)
    inst[10, 70] = 3  # patch row 0, column 1
    keep = empty_water(inst.shape, instances=inst)
    assert keep.tolist() == [True, False, True, True, True, True]


def test_empty_water_excludes_boxes_touching_patches():
    shape = (128, 192)
    assert empty_water(shape, boxes=[(60, 60, 10, 10)]).tolist() == [
        False, False, True, False, False, True]
    # a box ending exactly at x = 64 touches only the first column
    assert empty_water(shape, boxes=[(0, 0, 64, 10)]).tolist() == [
        False, True, True, True, True, True]
    # a zero-size box still keeps its pixel clear; boxes outside the image mark nothing
    assert empty_water(shape, boxes=[(130.5, 100.2, 0, 0)]).tolist() == [
        True, True, True, True, True, False]
    assert empty_water(shape, boxes=[(500, 500, 10, 10), (-20, -20, 5, 5)]).all()
    assert boxes_mask((4, 4), [(1, 1, 1.5, 1)]).sum() == 2


def test_empty_water_excludes_invalid_pixels():
    valid = np.ones((128, 128), bool)
    valid[127, 0] = False
    assert empty_water(valid.shape, valid=valid).tolist() == [True, True, False, True]
    with pytest.raises(ValueError):
        empty_water((64, 64), instances=np.zeros((32, 32)))


def test_stats_use_only_kept_patches():
    img = grey(50, 64, 128)
    img[:, 64:] = 150
    s = patch_stats(img, keep=np.array([False, True]))
    assert s["luminance"].tolist() == pytest.approx([150.0])


def test_summarise():
    s = summarise({"saturation": np.arange(1, 101) / 100, "luminance": np.arange(1, 101),
                   "highpass_std": np.zeros(0), "glint_fraction": np.zeros(5)})
    assert s["luminance"]["median"] == pytest.approx(50.5)
    assert s["luminance"]["p10"] == pytest.approx(10.9)
    assert s["luminance"]["p90"] == pytest.approx(90.1)
    assert s["luminance"]["n"] == 100
    assert s["highpass_std"]["n"] == 0 and np.isnan(s["highpass_std"]["median"])
    both = concat_stats([patch_stats(grey(10)), patch_stats(grey(20))])
    assert both["luminance"].tolist() == pytest.approx([10, 20])


def test_bad_image_rejected():
    with pytest.raises(ValueError):
        patch_stats(np.zeros((64, 64, 3), np.float32))


def noise_patches(n=300, sigma=10.0, seed=0):
    return np.random.default_rng(seed).normal(128, sigma, (n, 64, 64))


def test_white_noise_is_flat_at_its_variance():
    acc = SpectrumAccumulator()
    acc.add(noise_patches())
    sp = acc.per_pixel()
    assert sp.unit == "cycles/px"
    assert sp.centres[0] > 1 / 64 * 0.99 and sp.centres[-1] < 0.5
    assert np.all(np.isfinite(sp.power))
    np.testing.assert_allclose(sp.power, 100.0, rtol=0.15)  # sigma^2 in every bin
    assert sp.power.max() / sp.power.min() < 1.3


def test_blurred_noise_falls_off():
    blurred = np.stack([cv2.GaussianBlur(p.astype(np.float32), (0, 0), 2.0)
                        for p in noise_patches(100)])
    acc = SpectrumAccumulator()
    acc.add(blurred)
    p = acc.per_pixel().power
    assert p[-1] < 1e-3 * p[0]
    assert np.all(np.diff(p[2:]) < 0)  # decreasing beyond the lowest bins


def test_constant_patch_has_no_power():
    assert np.all(patch_power(np.full((2, 64, 64), 77.0)) < 1e-20)


def test_per_metre_rescales_frequencies():
    acc = SpectrumAccumulator()
    acc.add(noise_patches(50), gsd=0.1)
    px, m = acc.per_pixel(), acc.per_metre(bins=10)
    np.testing.assert_allclose(m.centres, px.centres / 0.1, rtol=1e-9)
    np.testing.assert_allclose(m.power, px.power, rtol=1e-9)
    assert SpectrumAccumulator().per_metre() is None
    # two sets on common edges covering both GSDs
    other = SpectrumAccumulator()
    other.add(noise_patches(20, seed=1), gsd=0.05)
    e = metre_edges(acc, other)
    assert e[0] <= 1 / 64 / 0.1 and e[-1] >= 0.5 / 0.05


def test_plot_writes_png(tmp_path):
    a, b = SpectrumAccumulator(), SpectrumAccumulator()
    a.add(noise_patches(20), 0.1)
    b.add(noise_patches(20, seed=2))
    plot_spectra(tmp_path / "s.png", a, b)
    assert cv2.imread(str(tmp_path / "s.png")) is not None


def test_bad_shape():
    with pytest.raises(ValueError):
        patch_power(np.zeros((64, 64)))


def test_features_shape_and_names():
    rgb = np.random.default_rng(0).integers(0, 256, (5, 64, 64, 3), dtype=np.uint8)
    f = clf.patch_features(rgb)
    assert f.shape == (5, len(clf.feature_names())) == (5, 45)
    assert np.isfinite(f).all()
    assert clf.patch_features(rgb[:0]).shape == (0, 45)
    flat = clf.patch_features(np.full((1, 64, 64, 3), 90, np.uint8))
    names = clf.feature_names()
    assert flat[0, names.index("hp_std")] == 0.0
    assert flat[0, names.index("hsv_S_mean")] == 0.0


def test_logistic_regression_separates_and_signs():
    rng = np.random.default_rng(1)
    x = rng.normal(size=(400, 3))
    y = (x[:, 0] - 0.5 * x[:, 1] > 0).astype(int)
    m = clf.fit_logistic(x, y, l2=0.1)
    assert (m.predict(x) == y).mean() > 0.97
    assert m.w[0] > 0 and m.w[1] < 0 and abs(m.w[2]) < 0.3 * m.w[0]


def test_wilson_interval():
    lo, hi = clf.wilson_interval(50, 100)
    assert lo == pytest.approx(0.4038, abs=1e-3) and hi == pytest.approx(0.5962, abs=1e-3)
    assert clf.wilson_interval(0, 0) == (0.0, 1.0)


def test_folds_split_by_image_and_hold_both_classes():
    rng = np.random.default_rng(2)
    groups = np.concatenate([rng.integers(0, 30, 500), 10**7 + rng.integers(0, 20, 300)])
    y = (groups >= 10**7).astype(int)
    folds = clf.group_folds(groups, y, 5)
    for g in np.unique(groups):
        assert len(np.unique(folds[groups == g])) == 1
    for f in range(5):
        assert set(y[folds == f]) == {0, 1}


def test_balance():
    y = np.array([0] * 10 + [1] * 3)
    keep = clf.balance(y)
    assert (y[keep] == 0).sum() == (y[keep] == 1).sum() == 3


def test_same_distribution_random_features_near_chance():
    rng = np.random.default_rng(3)
    groups = np.repeat(np.arange(60), 20)
    x = rng.normal(size=(1200, 10)) + rng.normal(size=(60, 10))[groups]  # image effects
    y = (groups >= 30).astype(int)
    groups = groups + y * 10**7
    r = clf.cross_validate(x, y, groups, 5, names=[f"f{i}" for i in range(10)])
    assert r.ci_images[0] <= 0.5 <= r.ci_images[1]
    assert abs(r.accuracy - 0.5) < 0.15
    assert r.n_patches == (600, 600)


def test_box_blur_stack_matches_opencv():
    a = np.random.default_rng(4).uniform(0, 255, (3, 64, 64)).astype(np.float32)
    want = np.stack([cv2.blur(p, (9, 9), borderType=cv2.BORDER_REFLECT_101) for p in a])
    np.testing.assert_allclose(clf.box_blur_stack(a), want, atol=1e-3)
