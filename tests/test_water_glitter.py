"""Sun glitter (sdcomp.render.water.glitter): the sparkle statistics and their density
against the Cox-Munk slope distribution."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from sdcomp.render.water import glitter, surface
from sdcomp.render.water.base import (
    FACET,
    GLINT_LN0,
    GLINT_LN_STEP,
    SPARKLE_DENSITY,
    SUN_DISC,
)
from sdcomp.render.water.coarse import N_REF
from sdcomp.render.water.layers import _neutral
from sdcomp.render.water.optics import fresnel
from sdcomp.render.water.textures import N_LEVELS, pitch
from sdcomp.render.water.waves import masking, slope_pdf
from sdcomp.scene.camera import CameraModel, CameraPose, camera_basis
from sdcomp.scene.config import GeneratorConfig
from sdcomp.scene.sample import sample_water


def _row(lam: float) -> int:
    """The glint table's row of ``lam`` sparkles per pixel (nearest ln lam)."""
    return int(round((math.log(lam) - GLINT_LN0) / GLINT_LN_STEP))


def _draw(lam, noise):
    """The renderer's draw: the glint table's row nearest ln(lam), column = noise."""
    table = glitter._glint_table()
    row = np.clip(np.rint((np.log(lam) - GLINT_LN0) / GLINT_LN_STEP), 0,
                  table.shape[0] - 1).astype(int)
    col = np.clip(np.rint(noise), 0, table.shape[1] - 1).astype(int)
    return table[row, col]


def test_glint_table_is_quantiles():
    # rows: ln lam in steps of GLINT_LN_STEP; columns: rising quantiles of the glint
    table = glitter._glint_table()
    assert np.all(np.diff(table, axis=1) >= 0)  # each row is a quantile function
    assert table.min() >= 0
    # the chance of no sparkle at all, exp(-lam), falls with lam: the first column with a
    # sparkle moves left row by row (Monte Carlo noise only in the tail's values)
    first = np.argmax(table > 0, axis=1)
    assert np.all(np.diff(first[first > 0]) <= 0)


@pytest.mark.parametrize("lam", [0.002, 0.02, 0.2, 1.0, 5.0])
def test_sparkle_count_statistics(water_textures, lam):
    # a pixel holds at least one sparkle with probability 1 - exp(-lam) (Poisson)
    noise = water_textures.noise
    lam_q = math.exp(GLINT_LN0 + GLINT_LN_STEP * _row(lam))  # the table's row
    s = _draw(np.full(noise.shape, lam), noise)
    frac = float((s > 0).mean())
    # the table's row: its first column with a sparkle; nearest-column lookup of the
    # noise coordinate c (exceedance 10**(-6 c / 255)) makes that column's probability
    row = glitter._glint_table()[_row(lam)]
    c_min = int(np.argmax(row > 0))
    p = 10 ** (-6 * max(c_min - 0.5, 0.0) / 255)
    sd = math.sqrt(p * (1 - p) / s.size)
    assert abs(frac - p) < 4 * sd + 1e-4
    # and that is Poisson's 1 - exp(-lam) up to the columns' spacing (5 % near p = 1)
    assert abs(p - (1 - math.exp(-lam_q))) < 0.03 + 0.12 * (1 - math.exp(-lam_q))


def test_sparkle_mean_is_lambda(water_textures):
    # compound Poisson of mean-1 intensities: E[S] = lam (the heavy tail makes the mean
    # noisy: compare medians of means over blocks)
    noise = water_textures.noise
    for lam in (0.5, 3.0, 20.0):
        s = _draw(np.full(noise.shape, lam), noise)
        blocks = s.reshape(64, -1).mean(1)
        assert 0.75 * lam < np.median(blocks) < 1.1 * lam


def test_slope_pdf_normalised_with_variances():
    su2, sc2 = 0.02, 0.012
    x = np.linspace(-2.5, 2.5, 1201)
    dx = x[1] - x[0]
    u, c = np.meshgrid(x, x)
    p = slope_pdf(u, c, su2, sc2)
    assert abs(p.sum() * dx * dx - 1) < 2e-3
    assert abs((p * u * u).sum() * dx * dx / su2 - 1) < 0.03
    assert abs((p * c * c).sum() * dx * dx / sc2 - 1) < 0.03
    assert abs((p * u * c).sum() * dx * dx) < 1e-6  # no correlation along the wind axes
    # Gaussian limit
    g = np.exp(-0.5 * (u ** 2 / su2 + c ** 2 / sc2)) / (2 * math.pi * math.sqrt(su2 * sc2))
    assert np.max(np.abs(slope_pdf(u, c, su2, sc2, nu=1e6) - g)) < 1e-3 * g.max()
    # heavier tails than the Gaussian (Cox-Munk's peakedness)
    assert slope_pdf(0.5, 0.0, su2, sc2) > g[600, np.argmin(abs(x - 0.5))]


def _flat_layers(wave_layers):
    """``wave_layers`` with its three texture layers replaced by a flat surface (slope
    codes 128): each pixel's slope is then the long waves' only."""
    def flat(plan, textures, alt, frame, world_off, row_geo):
        out = wave_layers(plan, textures, alt, frame, world_off, row_geo)
        for k in ("a4", "b4", "c4"):
            a = np.empty_like(out[k])
            a[:] = _neutral(a.shape[1])
            out[k] = a
        return out
    return flat


def _expected_sparkles(model: CameraModel, pose: CameraPose, params, info) -> np.ndarray:
    """(H, W) expected sparkles per pixel from the exact view ray of each pixel: the
    Cox-Munk glint ``E_sun R(omega) p(z) / (4 cos theta_v cos^4 beta)`` of the facet slope
    ``z`` that mirrors the sun (Student-t PDF of the unresolved slopes around a flat mean),
    hazed, SPARKLE_DENSITY sparkles per unit glint radiance in the reference frame, scaled by
    the facets per pixel, at most one per facet."""
    sky, waves = info["sky"], info["waves"]
    w, h = model.width, model.height
    u = (np.arange(w) + 0.5 - w / 2) / model.fx
    v = (np.arange(h) + 0.5 - h / 2) / model.fy
    uu, vv = np.meshgrid(u, v)
    d = np.stack([uu, vv, np.ones_like(uu)], -1) @ camera_basis(pose.pitch, pose.heading)
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    vdir = -d
    hv = vdir + sky.sun  # the facet normal that mirrors the sun into the camera
    hv /= np.linalg.norm(hv, axis=-1, keepdims=True)
    zx, zy = -hv[..., 0] / hv[..., 2], -hv[..., 1] / hv[..., 2]
    wind = math.radians(info["wind_dir_drawn"])
    e_u = np.array([math.cos(wind), math.sin(wind)])
    du = zx * e_u[0] + zy * e_u[1]
    dc = -zx * e_u[1] + zy * e_u[0]
    fp = max(pose.altitude / model.fx, pose.altitude / model.fy)
    flev = float(np.clip(np.log2(fp / pitch(0)), 0.0, N_LEVELS - 1.0))
    un = waves.unres_at(flev)
    geo = sky.e_sun * fresnel(np.clip((hv * sky.sun).sum(-1), 0, 1)) / (
        4 * vdir[..., 2] * hv[..., 2] ** 4)
    haze = np.exp(-(pose.altitude / vdir[..., 2]) / params.visibility)
    n_fac = min(max((fp / FACET) ** 2, 0.25), 1e5)
    dens = SPARKLE_DENSITY * n_fac / N_REF
    lam = dens * geo * haze * slope_pdf(du, dc, un[0], un[1])
    return n_fac * -np.expm1(-lam / n_fac)


def test_sparkle_density_tracks_cox_munk(water_textures, monkeypatch):
    """Straight down over flat drawn layers (codes 128: the pixel's slope is the long
    waves', negligible at 2 m/s), the fraction of pixels that sparkle follows
    ``1 - exp(-lam)`` with ``lam`` proportional to the Cox-Munk glint of the facet slope
    that mirrors the sun into that pixel (Student-t PDF of the unresolved slopes; at most
    one sparkle per facet), within sampling error."""
    monkeypatch.setattr(surface, "wave_layers", _flat_layers(surface.wave_layers))
    monkeypatch.setattr(glitter, "SPARKLE_BLUR", False)  # one pixel per sparkle
    model = CameraModel(width=416, height=416)
    assert SUN_DISC * math.sqrt(model.fx * model.fy) > 1.5  # (the blur would be on)
    config = GeneratorConfig()
    obs, exp_ = [], []
    for i, (elev, az, alt) in enumerate(((70.0, 10.0, 30.0), (60.0, 200.0, 20.0),
                                         (78.0, 95.0, 40.0), (55.0, 300.0, 25.0))):
        p = replace(sample_water(np.random.default_rng(i), config), sky="clear",
                    cloud_cover=0.0, wind=2.0, wave_age=3.0, slicks=0.0, swell_height=0.0,
                    sun_elevation=elev, sun_azimuth=az, depth=None)
        pose = CameraPose(alt, 90.0, 0.0)
        with_g, info = surface.render_water(model, pose, p, water_textures, glint="sparkles")
        without, _ = surface.render_water(model, pose, p, water_textures, glint="none")
        sparkle = (with_g.astype(int) - without).max(axis=2) > 0
        obs.append(sparkle.ravel())
        exp_.append(_expected_sparkles(model, pose, p, info).ravel())
    obs = np.concatenate(obs)
    lam = np.concatenate(exp_)
    edges = np.exp(np.arange(-6.0, 3.1, 0.75))
    checked = 0
    for lo, hi in zip(edges[:-1], edges[1:], strict=True):
        sel = (lam >= lo) & (lam < hi)
        if sel.sum() < 400:
            continue
        p_exp = float(np.mean(1 - np.exp(-lam[sel])))
        p_obs = float(obs[sel].mean())
        sd = math.sqrt(p_exp * (1 - p_exp) / sel.sum())
        # sampling error + the coarse grid's interpolation of the smooth terms and the
        # table's 0.25 steps in ln(lam)
        assert abs(p_obs - p_exp) < 4 * sd + 0.2 * p_exp, (lo, hi, p_obs, p_exp)
        checked += 1
    assert checked >= 5
    # and far from the sun's mirror direction nothing sparkles
    assert obs[lam < 1e-4].mean() < 1e-3


def _with_and_without_glitter(model, pose, p, textures):
    """(water with sparkles, the same water without glitter, the first one's info)."""
    a, info = surface.render_water(model, pose, p, textures, glint="sparkles")
    b, _ = surface.render_water(model, pose, p, textures, glint="none")
    return a, b, info


def test_no_glitter_without_direct_sun(water_textures):
    """Under an overcast sky (no direct sun) no pixel sparkles, whatever the view."""
    model = CameraModel(width=256, height=256)
    p = replace(sample_water(np.random.default_rng(3), GeneratorConfig()), sky="overcast",
                cloud_cover=1.0, wind=5.0, sun_elevation=60.0, sun_azimuth=0.0)
    pose = CameraPose(30.0, 60.0, 0.0)  # facing the sun
    a, b, info = _with_and_without_glitter(model, pose, p, water_textures)
    assert info["glitter_box"] is None and np.array_equal(a, b)


def test_glitter_reaches_the_near_rows_of_a_low_view(water_textures):
    """Looking low (15 degrees) towards the sun, the glitter path runs from the horizon to
    the frame's bottom edge: near the camera a pixel holds fewer facets and one sparkle is
    brighter, so the rows there are drawn too (a single threshold, the far rows', cut the
    path off at a hard line 2/3 of the way down)."""
    model = CameraModel(width=416, height=416)
    p = replace(sample_water(np.random.default_rng(3), GeneratorConfig()), sky="clear",
                wind=5.5, sun_elevation=40.0, sun_azimuth=2.0)
    pose = CameraPose(17.0, 15.0, 27.0)
    a, b, info = _with_and_without_glitter(model, pose, p, water_textures)
    x0, y0, x1, y1 = info["glitter_box"]
    assert y1 == model.height
    bottom = (a[-40:].astype(int) - b[-40:]).sum(axis=2)
    assert np.count_nonzero(bottom > 30) > 100  # sparkles in the 40 rows nearest the camera


def test_glitter_beyond_the_table_scales_with_the_count(water_textures):
    """A pixel expecting more sparkles than the glint table's last row (ln lam 7: ~1100;
    a far pixel near the sun's mirror point holds up to 1e5) gets lam / lam_top times that
    row's draw: the draws' mean stays lam (they were clamped at the last row: 1100 at
    most, which cut a low sun's glitter path off short of the horizon in a flat band),
    and the smooth glint's mean follows likewise."""
    noise = water_textures.noise[:64, :256]
    top = glitter._glint_table().shape[0] - 1
    for ln_lam in (5.0, 9.0, 11.5):
        e = np.full(noise.shape, (ln_lam - GLINT_LN0) / GLINT_LN_STEP, np.float32)
        gain = glitter._beyond_table(e)
        assert float(e.max()) <= top  # clamped to the table
        s = _draw(np.exp(GLINT_LN0 + GLINT_LN_STEP * e), noise)
        if gain is not None:
            s = s * gain
        assert (gain is None) == (ln_lam <= GLINT_LN0 + top * GLINT_LN_STEP)
        assert 0.9 < float(np.median(s.reshape(16, -1).mean(1))) / math.exp(ln_lam) < 1.1
    q = 1e-6  # a far pixel's share of white per sparkle: 1e5 sparkles give 0.1
    got = glitter.expected_clipped(np.array([1e5]), np.array([0.0]), np.array([q]))[0]
    assert got == pytest.approx(1e5 * q, rel=0.05)


def test_a_low_suns_glitter_path_reaches_the_horizon(water_textures):
    """Looking at a low sun (8 degrees) from 10 degrees pitch, the glitter path runs up to
    the horizon, where the sun's mirror point is, narrowing there: the rows just under the
    horizon glint (they stayed dim while the count was clamped at the table's last row)."""
    model = CameraModel(width=320, height=180)
    p = replace(sample_water(np.random.default_rng(3), GeneratorConfig()), sky="clear",
                wind=5.0, sun_elevation=8.0, sun_azimuth=0.0)
    pose = CameraPose(40.0, 10.0, 0.0)
    a, b, info = _with_and_without_glitter(model, pose, p, water_textures)
    glint = (a.astype(int) - b).sum(axis=2) / 3.0  # levels added per pixel
    r0 = int(np.argmax(info["sea_mask"][:, 0]))  # the first sea row (under the horizon)
    near_horizon = glint[r0 + 2:r0 + 12].mean(axis=0)
    bottom = glint[-10:].mean(axis=0)
    assert near_horizon.max() > 100, near_horizon.max()
    width = [np.count_nonzero(g > 40) for g in (near_horizon, bottom)]
    assert 0 < width[0] < width[1], width  # a wedge, widening towards the camera


@pytest.mark.parametrize("lam,base,q", [(0.01, 0.1, 0.5), (0.3, 0.2, 0.3), (2.0, 0.05, 0.2),
                                        (0.05, 0.0, 1.0)])
def test_mean_glint_is_the_expected_clipped_glitter(lam, base, q):
    """The smooth glint (glitter off) is E[min(b + q S, 1)] for the compound Poisson glint S:
    Poisson(lam) sparkles of Pareto(1.5) intensities with mean 1, checked against a direct
    Monte Carlo of that sum (within its sampling error and the table's quantisation)."""
    rng = np.random.default_rng(7)
    n = 400_000
    k = rng.poisson(lam, n)
    s = np.zeros(n)
    xm = (1.5 - 1) / 1.5
    for j in range(int(k.max())):
        sel = k > j
        s[sel] += xm * (1 - rng.random(int(sel.sum()))) ** (-1 / 1.5)
    want = float(np.minimum(base + q * s, 1.0).mean())
    got = float(glitter.expected_clipped(np.array([lam]), np.array([base]),
                                         np.array([q]))[0])
    assert got == pytest.approx(want, rel=0.03, abs=2e-4)


def test_at_most_one_sparkle_per_facet():
    """saturate_rows turns a pixel's expected count lam into N (1 - exp(-lam / N)) for its
    row's N facets, in glint-table row units, as the float64 formula does to within 1e-4
    row (the series below SATURATE_SERIES, the exact form above)."""
    rows = np.linspace(-40.0, 80.0, 2401, dtype=np.float32)  # ln lam from -19 to 11
    e = np.tile(rows, (4, 1))
    ln_n = np.log(np.array([[1.0], [30.0], [1e3], [1e5]], np.float32))
    lam = np.exp(e.astype(np.float64) * GLINT_LN_STEP + GLINT_LN0)
    n = np.exp(ln_n.astype(np.float64))
    want = (np.log(n * -np.expm1(-lam / n)) - GLINT_LN0) / GLINT_LN_STEP
    got = e.copy()
    glitter.saturate_rows(got, ln_n)
    assert np.abs(got - want).max() < 1e-4
    x = lam / n
    assert x.min() < 1e-6 and x.max() > 1e3  # both forms and the saturated end are tested
    assert np.all(got <= e + 1e-5)  # saturation only ever lowers the count
    cap = np.broadcast_to((ln_n - GLINT_LN0) / GLINT_LN_STEP, e.shape)  # one per facet
    assert np.abs(got - cap)[x > 100].max() < 1e-3


def _isolated_sparkles(value: float, n: int = 400, seed: int = 5):
    """``n`` sparkles of ``value`` on a grid 6 px apart (each alone in its 3 x 3
    neighbourhood), spread by :func:`glitter.spread_disc` with the shares of glitter
    noise (the textures' law, ``-log10(1 - u) 255 / 6`` clipped to 255); returns their 3 x 3
    neighbourhoods (n, 3, 3)."""
    side = int(math.ceil(math.sqrt(n)))
    g = np.zeros((6 * side, 6 * side), np.float32)
    g[3::6, 3::6] = value
    u = np.random.default_rng(seed).random(g.shape)
    noise = np.clip(-np.log10(1.0 - u) * 255.0 / 6.0, 0.0, 255.0).astype(np.float32)
    glitter.spread_disc(g, glitter.shares_of(noise))
    blocks = g.reshape(side, 6, side, 6)[:, 2:5, :, 2:5].transpose(0, 2, 1, 3)
    return blocks.reshape(-1, 3, 3)[:n]


def test_a_sparkle_spreads_over_a_disc_with_the_shares_drawn():
    """The core keeps its value; an edge neighbour gets an exponential share of it (mean
    EDGE_SHARE, at most MAX_SHARE), a corner one CORNER_SHARE of that: the mean light of a
    sparkle is 1 + 4 (1 + CORNER_SHARE) E[min(s, MAX_SHARE)] of its value."""
    b = _isolated_sparkles(1.0, n=2500)
    assert np.all(b[:, 1, 1] == 1.0)
    edges = np.concatenate([b[:, 0, 1], b[:, 1, 0], b[:, 1, 2], b[:, 2, 1]])
    corners = np.concatenate([b[:, 0, 0], b[:, 0, 2], b[:, 2, 0], b[:, 2, 2]])
    assert edges.max() <= glitter.MAX_SHARE and corners.max() <= glitter.MAX_SHARE
    m, cap = glitter.EDGE_SHARE, glitter.MAX_SHARE
    capped = m * (1.0 - math.exp(-cap / m))  # E[min(s, cap)], s exponential of mean m
    assert abs(edges.mean() - capped) < 0.03
    assert abs(corners.mean() / edges.mean() - glitter.CORNER_SHARE) < 0.05
    # exponential: the median share is ln 2 of the mean
    assert abs(np.median(edges) - math.log(2) * m) < 0.03


def test_saturated_sparkles_are_blobs_of_many_shapes_not_one_cross():
    """A sparkle three times white saturates its own pixel and the neighbours whose share
    reaches a third: blobs of 1 to 9 pixels in many shapes, few of them the plus that one
    fixed share of 0.45 made of every such sparkle."""
    b = _isolated_sparkles(3.0)
    sat = b >= 1.0
    shapes = {s.tobytes() for s in sat}
    plus = np.array([[0, 1, 0], [1, 1, 1], [0, 1, 0]], bool)
    share_plus = float(np.mean([np.array_equal(s, plus) for s in sat]))
    sizes = sat.reshape(len(sat), -1).sum(1)
    assert len(shapes) >= 40, len(shapes)
    assert share_plus < 0.2, share_plus
    assert sizes.min() == 1 and sizes.max() >= 7


def test_masking_is_smiths_for_gaussian_slopes():
    """Lambda = (exp(-a^2) / (sqrt(pi) a) - erfc(a)) / 2 with a = cot(theta) / sqrt(2 var):
    0 from above, 0.0251 at a = 1, ~1 / (2 sqrt(pi) a) - 1/2 towards the horizon; the
    variance is the slope variance along the direction's azimuth."""
    e_u, e_c = np.array([1.0, 0.0]), np.array([0.0, 1.0])
    var_u, var_c = 0.04, 0.01

    def along(axis, a, var):  # a unit direction along ``axis`` whose a is ``a``
        t = a * math.sqrt(2 * var)  # cot(theta)
        h = 1 / math.sqrt(1 + t * t)
        return np.array([*(h * axis), t * h])

    lam = masking(np.stack([along(e_u, 1.0, var_u), along(e_c, 1.0, var_c),
                            along(e_u, 0.01, var_u), np.array([0.0, 0.0, 1.0])]),
                  e_u, e_c, var_u, var_c)
    expected = (math.exp(-1) / math.sqrt(math.pi) - math.erfc(1.0)) / 2
    assert lam[0] == pytest.approx(expected, abs=2e-6)
    assert lam[1] == pytest.approx(expected, abs=2e-6)  # the crosswind variance crosswind
    assert lam[2] == pytest.approx((math.exp(-1e-4) / (math.sqrt(math.pi) * 0.01)
                                    - math.erfc(0.01)) / 2, rel=1e-5)
    assert lam[3] == 0.0


def test_glint_stays_finite_towards_the_horizon():
    """Cox-Munk's glint grows as 1 / cos(theta_v) towards the horizon; the waves hide the
    faces that would mirror the sun there (Smith's masking), so the expected glint of the
    rows just under the horizon levels off: within 1.5x between 0.1 and 1 degree under it
    (without the masking, 9x: the white band that crowned flat views into the sun)."""
    from types import SimpleNamespace

    from sdcomp.render.water.coarse import _glint_terms

    sun = np.array([0.0, math.cos(math.radians(30)), math.sin(math.radians(30))])
    sky = SimpleNamespace(sun=sun, e_sun=1.0)
    elev = np.radians([0.1, 1.0])
    d = np.stack([np.zeros(2), np.cos(elev), -np.sin(elev)], axis=1)  # towards the sun
    e_u, e_c = np.array([0.0, 1.0]), np.array([1.0, 0.0])
    unres = np.full((2, 2), 0.02)
    res_sd = np.zeros((2, 2))
    mean = _glint_terms(d, sky, np.zeros((2, 2)), e_u, e_c, unres, res_sd, np.ones(2))["mean"]
    assert 0 < mean[0] < 1.5 * mean[1], mean
