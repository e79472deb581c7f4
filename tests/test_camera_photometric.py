"""The drone camera's photometric stage (sdcomp.render.camera.photometric): exposure, white
balance, tone curve and saturation as tables."""

from __future__ import annotations

import numpy as np
import pytest

from sdcomp.render.camera import photometric as P
from sdcomp.util.colour import linear_to_srgb, srgb_to_linear

IDENTITY = dict(knee=1.0, flat=0.0, contrast=1.0, gamma=1.0, black=0.0)


def tables(gain=1.0, wb=(1.0, 1.0, 1.0), **kw):
    args = {**IDENTITY, **kw}
    return P.photometric_tables(gain, np.array(wb), args["knee"], args["flat"],
                                args["contrast"], args["gamma"], args["black"])


def srgb_decode(v):
    """sRGB [0, 1] -> linear, float64 (the standard's formula)."""
    v = np.asarray(v, np.float64)
    return np.where(v <= 0.04045, v / 12.92, ((v + 0.055) / 1.055) ** 2.4)


def srgb_encode(x):
    """linear [0, 1] -> sRGB, float64 (the standard's formula)."""
    x = np.clip(np.asarray(x, np.float64), 0.0, 1.0)
    return np.where(x <= 0.0031308, x * 12.92, 1.055 * x ** (1 / 2.4) - 0.055)


def test_identity_table_maps_every_level_to_itself():
    t = tables()
    assert t.identity
    assert np.array_equal(t.lut[:, 0, 0], np.arange(256))
    # the identity tone curve is the sRGB curve
    x = np.linspace(0, 1, 1001)
    assert np.abs(P.tone_curve(x) - srgb_encode(x)).max() < 1e-6


@pytest.mark.parametrize("stops", [1.0, -1.0, 2.0])
def test_exposure_stops_scale_linear_values(stops):
    """+1 stop doubles the linear value: decode the output level with the sRGB formula and
    compare with 2^stops x the input's linear value, within the rounding of one level."""
    t = tables(gain=2.0**stops)
    lvl = np.arange(256)
    x = srgb_decode(lvl / 255) * 2.0**stops
    # unclipped; input level 255 is the renderer's clip, which stays white at any exposure
    ok = (x < 1.0) & (lvl < 255)
    out = t.lut[:, 0, 1].astype(float)
    # the output level is the rounded sRGB encoding of the doubled linear value
    assert np.abs(out[ok] - 255 * srgb_encode(x[ok])).max() <= 0.5 + 1e-3
    # and decodes to it within the linear width of half a level there
    dec = srgb_decode(out / 255)
    half = srgb_decode(np.minimum(out + 0.5, 255) / 255) - dec
    assert np.all(np.abs(dec[ok] - x[ok]) <= half[ok] + 1e-6)
    if stops > 0:
        assert np.all(out[~ok] == 255)
    assert out[255] == 255  # the renderer's clip stays white
    assert not t.identity


def test_white_balance_keeps_grey_luminance_and_casts_colour():
    g = P.white_balance_gains(1.2, 0.8, 1.0)
    assert abs(float(P.LUMA @ g) - 1) < 1e-12
    assert g[0] > g[1] > g[2]
    t = tables(wb=g)
    lin = srgb_decode(t.lut[128, 0].astype(float) / 255)
    np.testing.assert_allclose(lin / srgb_decode(128 / 255), g, rtol=0.02)


def test_tone_curve_is_float64():
    for kw in ({}, {"contrast": 1.5}, {"flat": 0.5, "gamma": 0.75}):
        assert P.tone_curve(np.array([0.0, 0.3, 1.0]), **kw).dtype == np.float64


@pytest.mark.parametrize("kw", [
    dict(contrast=0.75),
    dict(contrast=1.5),
    dict(gamma=0.75),
    dict(gamma=1.35),
    dict(flat=1.0), dict(knee=0.6), dict(black=0.06),
    dict(knee=0.6, flat=0.5, contrast=0.75, gamma=0.75, black=0.05)])
def test_tone_curve_is_monotonic_bounded_and_finite_slope(kw):
    x = np.unique(np.concatenate([np.linspace(0, 0.01, 1001), np.linspace(0.01, 4, 4000)]))
    v = P.tone_curve(x, **kw)
    assert np.all(np.diff(v) >= -1e-12) and v.min() >= 0 and v.max() <= 1
    slope = np.diff(v) / np.diff(x)
    assert np.isfinite(slope).all() and slope.max() < 200  # no infinite toe


def test_soft_pow_has_finite_slope_at_black():
    v = np.array([0.0, 1e-6, 0.5, 1.0])
    for e in (0.5, 0.75, 1.35):
        s = P.soft_pow(v, e)
        assert s[0] == 0.0 and s[-1] == pytest.approx(1.0)
        assert (s[1] - s[0]) / 1e-6 < 100  # v ** 0.5 would have slope 1000 here
    assert P.soft_pow(v, 1.0) is v


def test_highlight_knee_compresses_smoothly_towards_white():
    knee = 0.7
    x = np.array([0.5, 0.7, 1.0, 2.0, 8.0])
    v = P.tone_curve(x, knee=knee)
    np.testing.assert_allclose(v[:2], srgb_encode(x[:2]), atol=1e-6)  # below the knee: sRGB
    assert np.all(np.diff(v) > 0) and v[-1] < 1.0 + 1e-12  # above: rising towards white
    xs = knee + (1 - knee) * (1 - np.exp(-(2.0 - knee) / (1 - knee)))
    assert v[3] == pytest.approx(float(srgb_encode(xs)), abs=1e-6)


def test_contrast_steepens_mid_tones_and_flat_lifts_shadows():
    x = np.array([0.18])
    d = 1e-4
    s1 = (P.tone_curve(x + d, contrast=1.4) - P.tone_curve(x - d, contrast=1.4)) / (2 * d)
    s0 = (P.tone_curve(x + d) - P.tone_curve(x - d)) / (2 * d)
    assert s1 > s0
    lo, hi = np.array([0.0, 0.005]), np.array([0.9, 1.0])
    assert np.all(P.tone_curve(lo, flat=1.0) > P.tone_curve(lo))  # lifted blacks
    assert np.all(P.tone_curve(hi, flat=1.0) < P.tone_curve(hi) - 0.15)  # dull whites
    ratio = P.tone_curve(np.array([0.9]), flat=1.0) / P.tone_curve(np.array([0.02]), flat=1.0)
    assert ratio < 0.7 * P.tone_curve(np.array([0.9])) / P.tone_curve(np.array([0.02]))
    # the log profile: black at LOG_BLACK, 18 % grey at ~0.45, white at ~0.75
    assert P.tone_curve(np.array([0.0]), flat=1.0)[0] == pytest.approx(P.LOG_BLACK)
    assert P.tone_curve(np.array([0.18]), flat=1.0)[0] == pytest.approx(0.45, abs=0.03)
    assert P.tone_curve(np.array([1.0]), flat=1.0)[0] == pytest.approx(0.75, abs=0.03)


def test_auto_exposure_brings_grey_to_target():
    img = np.full((64, 64, 3), 60, np.uint8)
    wb = P.white_balance_gains(1, 1, 1)
    mean = P.mean_luminance(P.thumbnail(img), wb)
    assert abs(mean - srgb_decode(60 / 255)) < 1e-6
    gain = P.exposure_gain(mean, 0.18, 1.0, 0.0)
    t = tables(gain=gain)
    out = P.apply_lut(img, t)
    assert abs(srgb_decode(out[0, 0, 1] / 255) - 0.18) < 0.003
    assert P.exposure_gain(mean, 0.18, 0.0, 1.0) == 2.0  # strength 0: only the bias
    # half strength: half way in stops; the gain is clamped
    assert P.exposure_gain(mean, 0.18, 0.5, 0.0) == pytest.approx(gain ** 0.5)
    assert P.exposure_gain(1e-9, 0.18, 1.0, 0.0) == 32.0


def test_colour_matrix_keeps_greys_and_scales_chroma():
    m = P.colour_matrix(1.4)
    assert np.allclose(m.sum(axis=1), 1)
    img = np.zeros((2, 2, 3), np.uint8)
    img[0, 0] = (100, 100, 100)
    img[1, 1] = (150, 100, 80)
    out = P.apply_colour(img, m).astype(float)
    assert np.array_equal(out[0, 0], [100, 100, 100])
    y_in = P.LUMA @ img[1, 1]
    assert abs(P.LUMA @ out[1, 1] - y_in) < 1.0
    assert np.ptp(out[1, 1]) > np.ptp(img[1, 1])
    # saturation 0: grey of the same luma
    grey = P.apply_colour(img, P.colour_matrix(0.0)).astype(float)
    assert np.ptp(grey[1, 1]) <= 1 and abs(grey[1, 1, 0] - y_in) < 1.0


def test_package_srgb_helpers_match_the_standard():
    # the stage's tables decode levels with sdcomp.util.colour
    x = np.linspace(0, 1, 256)
    assert np.abs(srgb_to_linear(x) - srgb_decode(x)).max() < 1e-6
    assert np.abs(linear_to_srgb(x) - srgb_encode(x)).max() < 1e-6
