"""Water optics (sdcomp.render.water.optics): Fresnel, IOPs and Gordon's reflectance,
Beer-Lambert for the shallow bottom, sRGB."""

from __future__ import annotations

import math

import numpy as np

from sdcomp.render.water import optics
from sdcomp.scene.water import WATER_TYPES

N = 1.333


def _fresnel_exact(theta: float, n: float = N) -> float:
    """Unpolarised Fresnel reflectance from the Fresnel equations written with angles
    (Born & Wolf): ``(sin^2(i - t) / sin^2(i + t) + tan^2(i - t) / tan^2(i + t)) / 2``."""
    if theta == 0:
        return ((n - 1) / (n + 1)) ** 2
    tt = math.asin(math.sin(theta) / n)
    rs = (math.sin(theta - tt) / math.sin(theta + tt)) ** 2
    rp = (math.tan(theta - tt) / math.tan(theta + tt)) ** 2
    return 0.5 * (rs + rp)


def test_fresnel_normal_incidence():
    assert abs(float(optics.fresnel(1.0)) - ((N - 1) / (N + 1)) ** 2) < 1e-9
    assert abs(float(optics.fresnel(1.0)) - 0.0204) < 1e-4


def test_fresnel_grazing_goes_to_one():
    assert float(optics.fresnel(0.0)) == 1.0
    assert float(optics.fresnel(math.cos(math.radians(89.99)))) > 0.998
    assert float(optics.fresnel(math.cos(math.radians(89.0)))) > 0.89
    assert float(optics.fresnel(math.cos(math.radians(80.0)))) > 0.34


def test_fresnel_matches_exact_formula():
    th = np.radians(np.linspace(0.0, 89.5, 200))
    ours = optics.fresnel(np.cos(th))
    ref = np.array([_fresnel_exact(t) for t in th])
    assert np.max(np.abs(ours - ref)) < 1e-6
    assert np.all(np.diff(ours) >= -1e-12)  # monotonic in the angle
    # Brewster's angle: the p-polarised part vanishes, R = R_s / 2 there
    b = math.atan(N)
    tt = math.asin(math.sin(b) / N)
    assert abs(float(optics.fresnel(math.cos(b))) - 0.5 * (
        math.sin(b - tt) / math.sin(b + tt)) ** 2) < 1e-9


def test_schlick_is_an_approximation():
    th = np.radians(np.linspace(0, 85, 50))
    assert np.max(np.abs(optics.schlick(np.cos(th)) - optics.fresnel(np.cos(th)))) < 0.06


def test_refraction_follows_snell():
    th = np.radians(np.linspace(0.0, 89.0, 50))
    cos_t = optics.refracted_cos(np.cos(th))
    np.testing.assert_allclose(np.sin(th), N * np.sqrt(1 - cos_t ** 2), atol=1e-12)


def test_gordon_formula():
    a = np.array([0.5, 0.05, 0.02])
    bb = np.array([0.01, 0.01, 0.01])
    u = bb / (a + bb)
    np.testing.assert_allclose(optics.subsurface_rrs(a, bb), 0.0949 * u + 0.0794 * u * u)
    r = optics.subsurface_rrs(a, bb)
    np.testing.assert_allclose(optics.above_rrs(r), 0.52 * r / (1 - 1.7 * r))


def test_iops_add_constituents():
    a0, bb0 = optics.iops(0.0, 0.0, 0.0)
    np.testing.assert_allclose(a0, optics.A_WATER)
    np.testing.assert_allclose(bb0, optics.BB_WATER)
    a1, bb1 = optics.iops(0.0, 0.0, 10.0)
    np.testing.assert_allclose(a1 - a0, 10 * optics.A_NAP)
    np.testing.assert_allclose(bb1 - bb0, 10 * optics.BB_NAP)
    a2, _ = optics.iops(0.0, 0.5, 0.0)
    np.testing.assert_allclose(a2 - a0, 0.5 * optics.A_CDOM)
    # arrays broadcast to (..., 3)
    a3, bb3 = optics.iops(np.array([0.0, 1.0]), 0.0, np.array([0.0, 10.0]))
    assert a3.shape == bb3.shape == (2, 3)
    np.testing.assert_allclose(a3[0], a0)


def _rrs_of(wtype: str) -> np.ndarray:
    (c0, c1), (g0, g1), (t0, t1) = WATER_TYPES[wtype]
    a, bb = optics.iops(math.sqrt(c0 * c1), math.sqrt(g0 * g1), math.sqrt(t0 * t1))
    return optics.above_rrs(optics.subsurface_rrs(a, bb))


def test_water_type_colours():
    ocean, turbid, algae, lake = (_rrs_of(t) for t in ("ocean", "turbid", "algae", "lake"))
    assert ocean[2] > ocean[1] > ocean[0]  # blue ocean
    assert turbid[0] > turbid[2] and turbid[1] > turbid[2]  # brown: red, green > blue
    assert algae[1] > algae[0] and algae[1] > algae[2]  # green
    assert turbid.max() > lake.max()  # sediment is bright
    assert 1e-4 < ocean.max() < 0.03 and turbid.max() < 0.08


def test_shallow_bottom_beer_lambert():
    a = np.array([0.3, 0.05, 0.02])
    bb = np.array([0.002, 0.002, 0.002])
    albedo = np.array([0.3, 0.3, 0.3])
    deep = optics.subsurface_rrs(a, bb)
    for h in (0.5, 2.0, 8.0):
        t = np.exp(-2 * (a + bb) * h)
        np.testing.assert_allclose(optics.shallow_rrs(a, bb, h, albedo),
                                   deep * (1 - t) + albedo / math.pi * t)
    # very deep: the deep-water value; depth 0: the bottom
    np.testing.assert_allclose(optics.shallow_rrs(a, bb, 1e4, albedo), deep)
    np.testing.assert_allclose(optics.shallow_rrs(a, bb, 0.0, albedo), albedo / math.pi)


def test_attenuations():
    a = np.array([0.3, 0.05, 0.02])
    bb = optics.BB_WATER + np.array([0.01, 0.01, 0.01])
    # beam: absorption plus all scattering (particles' b = b_b / 0.02, water's b = 2 b_bw)
    np.testing.assert_allclose(optics.beam_attenuation(a, bb),
                               a + 2 * optics.BB_WATER + 0.01 / 0.02)
    # diffuse: (a + b_b) / mu_w, stronger for slanted refracted sunlight
    np.testing.assert_allclose(optics.diffuse_attenuation(a, bb), a + bb)
    assert np.all(optics.diffuse_attenuation(a, bb, 0.8) > optics.diffuse_attenuation(a, bb))


def test_srgb_round_trip():
    x = np.linspace(0, 1, 101, dtype=np.float32)
    np.testing.assert_allclose(optics.srgb_decode(optics.srgb_encode(x)), x, atol=1e-5)
    assert abs(float(optics.srgb_encode(0.18)) * 255 - 117.9) < 0.5
    # the standard's two pieces meet at 0.0031308 (linear) = 0.04045 (encoded)
    assert abs(float(optics.srgb_encode(0.0031308)) - 0.04045) < 1e-5
