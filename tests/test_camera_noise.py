"""The drone camera's sensor noise (sdcomp.render.camera.sensor): variance ``a x + b`` in
linear light, carried through the tone curve's slope; the noise tile and its windows."""

from __future__ import annotations

import numpy as np
import pytest

from sdcomp.render.camera import photometric as P
from sdcomp.render.camera import sensor as S
from sdcomp.render.camera.scale import scaled_noise
from sdcomp.util.colour import srgb_to_linear

CURVES = [dict(), dict(contrast=1.3, gamma=1.1), dict(flat=0.8, contrast=0.8, knee=0.7)]


def measured(level: int, t: P.Photometric, sigma: np.ndarray, tile: np.ndarray, oy: int):
    """Mean and variance per channel of a flat 256 x 256 patch of ``level`` through the
    table with noise."""
    img = np.full((256, 256, 3), level, np.uint8)
    win = S.noise_window(tile, 256, 256, oy, 17)
    out = S.apply_lut_noise(img, t, sigma, win).astype(float)
    return out.mean(axis=(0, 1)), out.var(axis=(0, 1))


def curve_slope(x: float, d: float, args: dict) -> float:
    """d(255 V) / dx of the tone curve at x by a central difference (float64 x)."""
    hi = P.tone_curve(np.array([x + d]), **args)[0]
    lo = P.tone_curve(np.array([x - d]), **args)[0]
    return 255 * float(hi - lo) / (2 * d)


@pytest.mark.parametrize("curve", CURVES)
def test_variance_matches_shot_read_model_through_the_curve(curve):
    a, b, gain = 4e-4, 1e-6, 1.3
    wb = P.white_balance_gains(1.1, 0.9, 1.0)
    args = dict(knee=1.0, flat=0.0, contrast=1.0, gamma=1.0, black=0.0) | curve
    t = P.photometric_tables(gain, wb, **args)
    sigma = S.noise_sigma(t, a, b)
    tile = S.make_noise_tile((5,), 256, 256)
    checked = 0
    for level in (12, 40, 90, 140, 190):
        mean, var = measured(level, t, sigma, tile, level)
        for c in range(3):
            x = gain * wb[c] * float(srgb_to_linear(level / 255))
            if x >= min(args["knee"], 1.0) * 0.98:
                continue
            # the slope over a step small against sigma yet far above rounding
            slope = curve_slope(x, 1e-4 * max(x, 1e-3), args)
            want = (a * x + b) * slope**2 + 1 / 12  # + rounding to integer levels
            # sampling error of a variance of 65536 values (correlation-free tile): ~0.6 %;
            # the tile's 1/32 quantisation and the curve's curvature within +-sigma: ~2 %
            assert abs(var[c] / want - 1) < 0.05, (level, c, var[c], want)
            assert abs(mean[c] - t.levels[level, c]) < 0.1 + 0.02 * np.sqrt(want)
            checked += 1
    assert checked >= 9


def test_noise_is_stronger_in_the_shadows_in_srgb():
    t = P.photometric_tables(1.0, np.ones(3), 1.0, 0.0, 1.0, 1.0, 0.0)
    sigma = S.noise_sigma(t, 3e-4, 1e-6)
    # pure shot noise grows like sqrt(x) in linear light, but the sRGB slope falls faster
    assert sigma[20, 1] > sigma[120, 1] > sigma[240, 1] > 0
    # clipped highlights carry no noise: a level above white after +2 stops
    t2 = P.photometric_tables(4.0, np.ones(3), 1.0, 0.0, 1.0, 1.0, 0.0)
    assert S.noise_sigma(t2, 3e-4, 1e-6)[250, 1] == 0.0


def test_downscaling_averages_noise():
    t = P.photometric_tables(1.0, np.ones(3), 1.0, 0.0, 1.0, 1.0, 0.0)
    s1 = S.noise_sigma(t, 3e-4, 1e-6)
    s4 = S.noise_sigma(t, 3e-4, 1e-6, 4.0, 4.0)
    assert np.allclose(s4, s1 / 4)
    assert np.allclose(scaled_noise(2.0, 9.0, 4.0), 2.0 / 6.0)
    # measured: the mean of 4 x 4 independent native pixels has 1/4 of their sd
    rng = np.random.default_rng(0)
    native = rng.normal(0.0, 1.0, (1024, 1024))
    reduced = native.reshape(256, 4, 256, 4).mean(axis=(1, 3))
    assert reduced.std() == pytest.approx(float(scaled_noise(1.0, 4.0, 4.0)), rel=0.02)


def test_noise_tile_is_unit_normal_and_seeded():
    tile = S.make_noise_tile((1,), 100, 120)
    assert tile.shape == (1121, 1151, 3) and tile.dtype == np.uint8
    n = (tile.astype(float) - 128) / S.NOISE_SCALE
    assert abs(n.mean()) < 0.01 and abs(n.std() - 1) < 0.01
    # standard normal quantiles (rounding to 1/32 only)
    assert abs(np.mean(np.abs(n) < 1.0) - 0.6827) < 0.01
    # channels and neighbours independent
    assert abs(np.corrcoef(n[..., 0].ravel(), n[..., 1].ravel())[0, 1]) < 0.01
    assert abs(np.corrcoef(n[:, :-1, 0].ravel(), n[:, 1:, 0].ravel())[0, 1]) < 0.01
    assert np.array_equal(S.make_noise_tile((1,), 100, 120), tile)
    assert not np.array_equal(S.make_noise_tile((1, 2), 100, 120), tile)


def test_noise_window_view_wrap_and_determinism():
    tile = S.make_noise_tile((1,), 100, 120)
    w1 = S.noise_window(tile, 100, 120, 123456, 654321)
    assert np.shares_memory(w1, tile)
    assert np.array_equal(w1, S.noise_window(tile, 100, 120, 123456, 654321))
    big = S.noise_window(tile, 2500, 2600, 7, 9)
    assert big.shape == (2500, 2600, 3)
    assert np.array_equal(big[:10, :10], tile[7:17, 9:19])
    assert np.array_equal(big[1121 - 7:1121 - 7 + 5, :5], tile[:5, 9:14])


def test_pipeline_sigma_is_the_secant_version_of_noise_sigma():
    args = dict(knee=0.8, flat=0.3, contrast=1.2, gamma=0.9, black=0.01)
    wb = P.white_balance_gains(1.2, 0.9, 1.0)
    t = P.photometric_tables(1.5, wb, *args.values(), noise=(3e-4, 1e-6, 2.0, 3.0))
    want = S.noise_sigma(t, 3e-4, 1e-6, 2.0, 3.0, curve=args)
    # the table interpolates the curve between its 256 levels (and not beyond the last)
    assert np.allclose(t.sigma[:240], want[:240], rtol=0.01)
    tangent = S.noise_sigma(t, 3e-4, 1e-6, 2.0, 3.0)
    mid = slice(60, 200)  # away from black and the shoulder: secant = tangent
    assert np.allclose(t.sigma[mid], tangent[mid], rtol=0.02)


def test_sigma_present_reads_the_frame_levels():
    sigma = np.zeros((256, 3))
    sigma[:, 1] = np.arange(256) / 255.0
    thumb = np.zeros((4, 4, 3), np.uint8)
    thumb[..., 1] = 100
    thumb[0, 0, 1] = 140
    assert S.sigma_present(sigma, thumb) == pytest.approx(140 / 255)
