"""Wave statistics (sdcomp.render.water.spectrum, .waves, .textures, .geometry): Cox-Munk
slopes, the Elfouhaily spectrum in octave bands, the level tiles and the choice of the level
drawn per pixel."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sdcomp.render.water import spectrum, wave_state
from sdcomp.render.water.geometry import RESOLVE, level_for
from sdcomp.render.water.textures import (
    DELTA,
    LEVEL_BANDS,
    N_LEVELS,
    N_TILE,
    SET_ANGLES,
    SLOPE_SCALE,
    pitch,
)


def test_cox_munk_totals():
    # Cox & Munk (1954), clean sea: upwind 3.16e-3 U, crosswind 0.003 + 1.92e-3 U
    for u in (0.0, 1.0, 5.0, 10.0):
        cu, cc = spectrum.cox_munk(u)
        assert abs((cu + cc) - (0.003 + 5.08e-3 * u)) < 1e-9  # the fits' sum
        assert abs((cu + cc) - (0.003 + 5.12e-3 * u)) < 0.001 * max(u, 1)
        assert cu == pytest.approx(3.16e-3 * u) and cc == pytest.approx(0.003 + 1.92e-3 * u)
    # slick-covered sea: (0.005 + 0.78e-3 U, 0.003 + 0.84e-3 U), smoother than clean
    su, sc = spectrum.cox_munk(5.0, slick=1.0)
    assert (su, sc) == pytest.approx((0.005 + 0.78e-3 * 5, 0.003 + 0.84e-3 * 5))
    assert su + sc < sum(spectrum.cox_munk(5.0))


def test_spectrum_mss_close_to_cox_munk():
    # Elfouhaily et al. (1997) reproduce Cox-Munk's clean-sea mss within ~30 % above 3 m/s
    for u in (3.0, 5.0, 8.0, 12.0):
        bu, bc = spectrum.band_slope_variance(u, spectrum.FULLY_DEVELOPED)
        cm = sum(spectrum.cox_munk(u))
        assert 0.7 < (bu.sum() + bc.sum()) / cm < 1.4


def test_spectral_peak_moves_with_wind():
    # deep-water dispersion at the peak (c_p = U / omega): lambda_p = 2 pi U^2 / (g omega^2)
    for u, om in ((3.0, 0.84), (8.0, 2.0)):
        assert spectrum.peak_wavelength(u, om) == pytest.approx(2 * math.pi * u ** 2 / (
            9.81 * om ** 2))
    assert spectrum.peak_wavelength(8.0) > spectrum.peak_wavelength(3.0) > 1.0
    b3 = np.add(*spectrum.band_slope_variance(3.0, 2.0))
    b8 = np.add(*spectrum.band_slope_variance(8.0, 2.0))
    assert b8[12] > 10 * b3[12]  # long bands carry slope only in stronger wind


def test_wave_state_partitions_cox_munk():
    for u, om in ((1.5, 3.0), (5.0, 1.0), (8.0, 2.0)):
        ws = wave_state(u, om)
        cu, cc = spectrum.cox_munk(u)
        bu, bc = spectrum.band_slope_variance(u, om)
        f = (cu + cc) / (bu.sum() + bc.sum())
        # bands scaled to Cox-Munk: all bands + the sub-cm rest = the Cox-Munk total
        assert abs(ws.band_u.sum() + ws.band_c.sum() + f * (bu[0] + bc[0]) - (cu + cc)) < 1e-12
        for lev in range(N_LEVELS):
            # a level tile's sd is the root of its two bands' variances
            np.testing.assert_allclose(ws.group_sd[lev] ** 2,
                                       [ws.band_u[lev:lev + 2].sum(),
                                        ws.band_c[lev:lev + 2].sum()])
            # drawn (resolved) + unresolved + long waves >= Cox-Munk per direction
            res = ws.resolved_sd(lev) ** 2
            long_u = ws.band_u[lev + 6:].sum()
            long_c = ws.band_c[lev + 6:].sum()
            assert res[0] + ws.unres[lev][0] + long_u >= cu * 0.999
            assert res[1] + ws.unres[lev][1] + long_c >= cc * 0.999
            # at least 10 % of Cox-Munk's stays unresolved
            assert ws.unres[lev][0] >= 0.1 * cu - 1e-15 and ws.unres[lev][1] >= 0.1 * cc - 1e-15
        # the layer weights are the layers' shares of the drawn variance
        lw = ws.layer_weights[3]
        np.testing.assert_allclose((lw ** 2).sum(0), 1.0, rtol=1e-9)


def test_whitecaps_younger_seas_whiten_less():
    full = wave_state(10.0, spectrum.FULLY_DEVELOPED).foam
    assert full == pytest.approx(spectrum.whitecap_fraction(10.0))
    assert wave_state(10.0, 4.0).foam == pytest.approx(
        full * (spectrum.FULLY_DEVELOPED / 4.0) ** 0.8)


def test_tile_variance_per_band(water_textures):
    # each level tile holds two bands of unit slope variance each: the decoded tile's
    # variance (codes / SLOPE_SCALE times the per-channel sd) sums to 2
    tex = water_textures
    for s in (0, 1):
        for lev in (2, 5, 9):
            tile = tex.ensure(s, lev)
            sd = tex.level_sd[s][lev]
            codes = tile[:N_TILE, :N_TILE, :2].astype(np.float64)
            t = (codes - 128.0) / SLOPE_SCALE
            var = (t.var(axis=(0, 1)) * sd ** 2).sum()
            assert abs(var - LEVEL_BANDS) < 0.02 * LEVEL_BANDS
            share = tex.level_share(s, lev)
            np.testing.assert_allclose(share.sum(1), 1.0, rtol=1e-9)
            # the tile is periodic: its extra row and column repeat the first ones
            assert np.array_equal(tile[N_TILE, :N_TILE], tile[0, :N_TILE])
            assert np.array_equal(tile[:, N_TILE], tile[:, 0])


def test_tile_spreading_follows_the_wind(water_textures):
    # the waves of direction set s run along SET_ANGLES[s] with power 1 + DELTA cos 2 phi:
    # the upwind share of each band's slope variance is the mean of cos^2 phi under that
    # weight, (1 + DELTA / 2) / 2 (~4800 random modes per band: within a few %)
    want = (1 + DELTA / 2) / 2
    for s in range(len(SET_ANGLES)):
        for lev in (0, 5, 12):
            share = water_textures.level_share(s, lev)
            assert np.all(np.abs(share[:, 0] - want) < 0.03), (s, lev, share)


def test_levels_share_bands(water_textures):
    # nested construction: band l+1 is the same realisation in tiles l and l+1. The
    # difference of the two tiles (both in world units) holds only bands l and l+2.
    lev = 4
    tex = water_textures
    a = tex.ensure(0, lev)[:N_TILE, :N_TILE, 0].astype(np.float64) - 128.0
    b = tex.ensure(0, lev + 1)[:N_TILE, :N_TILE, 0].astype(np.float64) - 128.0
    # sample tile l+1 on tile l's grid (its texels are twice as large; columns centred)
    ys, xs = np.mgrid[0:N_TILE, 0:N_TILE]
    bx = ((xs - N_TILE // 2) / 2.0 + N_TILE // 2) % N_TILE
    by = (ys / 2.0) % N_TILE
    b_on_a = b[by.astype(int), bx.astype(int)]
    sa, sb = tex.level_sd[0][lev][0], tex.level_sd[0][lev + 1][0]
    corr = np.corrcoef((a * sa).ravel(), (b_on_a * sb).ravel())[0, 1]
    # band l+1 carries about half of each tile's variance: correlation ~ 0.5 (nearest
    # sampling of the coarser tile blurs it a little)
    assert 0.3 < corr < 0.7
    # unrelated levels (no shared band) are uncorrelated
    c = tex.ensure(0, lev + 3)[:N_TILE, :N_TILE, 0].astype(np.float64) - 128.0
    assert abs(np.corrcoef(a.ravel(), c.ravel())[0, 1]) < 0.1


@pytest.mark.parametrize("fp", [0.001, 0.004, 0.01, 0.03, 0.1, 0.4, 1.5])
def test_selection_never_draws_unresolved_waves(fp):
    lev = int(level_for(fp))
    assert lev < N_LEVELS  # footprints of drone views all have a level
    finest = 4 * pitch(lev)  # the shortest wave the level tile holds
    assert finest >= RESOLVE * fp * (1 - 1e-9)  # resolved by the footprint
    if lev > 0:  # and the next finer tile would not be
        assert 4 * pitch(lev - 1) < RESOLVE * fp


def test_whitecaps():
    # Monahan & O'Muircheartaigh (1980): W = 3.84e-6 U^3.41
    assert spectrum.whitecap_fraction(0.0) == 0.0
    assert abs(spectrum.whitecap_fraction(10.0) - 3.84e-6 * 10 ** 3.41) < 1e-12
    assert spectrum.whitecap_fraction(5.0) < 0.002 < spectrum.whitecap_fraction(8.0) * 3
    assert math.isclose(spectrum.whitecap_fraction(100.0), 0.2)
