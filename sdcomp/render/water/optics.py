"""Optics of the air-water interface and of the water body, and sRGB encoding.

Colours are relative linear RGB (camera R, G, B after white balance to daylight: a white
Lambertian surface under the full daylight of a clear sky has radiance (1, 1, 1) / pi per
unit of downwelling irradiance).

- :func:`fresnel` is the exact Fresnel reflectance of unpolarised light (the mean of the s
  and p reflectances), :func:`schlick` its usual approximation.
- The water body: inherent optical properties (absorption ``a`` and backscattering ``b_b``
  per channel, 1/m) from pure water plus three constituents: chlorophyll (mg/m^3),
  coloured dissolved organic matter (CDOM, absorption at 440 nm, 1/m) and total suspended
  mineral solids (TSM, g/m^3); remote-sensing reflectance from Gordon et al. (1988),
  ``r_rs = 0.0949 u + 0.0794 u^2`` with ``u = b_b / (a + b_b)`` just below the surface, and
  ``R_rs = 0.52 r_rs / (1 - 1.7 r_rs)`` above it (Lee et al. 2002). Optically shallow water
  adds the bottom (Lee et al. 1998, simplified: one attenuation ``K = a + b_b`` each way).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ...util.colour import linear_to_srgb, luminance, srgb_to_linear

N_WATER = 1.333

# Band-averaged IOPs of the camera's R, G, B channels (effective ~600, ~540, ~465 nm).
A_WATER = np.array([0.30, 0.050, 0.012])  # pure water absorption, 1/m (Pope & Fry 1997)
BB_WATER = np.array([0.0006, 0.0010, 0.0020])  # pure water backscattering, 1/m (Morel 1974)
A_PHY = np.array([0.010, 0.008, 0.033])  # chlorophyll-specific absorption at 1 mg/m^3
A_CDOM = np.array([0.07, 0.22, 0.64])  # CDOM absorption relative to 440 nm (slope 0.015/nm)
A_NAP = 0.03 * np.array([0.14, 0.33, 0.72])  # mineral absorption per g/m^3 (slope 0.011/nm)
BB_NAP = 0.012 * np.array([0.92, 1.0, 1.12])  # mineral backscattering per g/m^3
BB_PHY = 0.0030 * np.array([0.9, 1.0, 1.1])  # particulate backscattering at 1 mg/m^3 chl
GORDON = (0.0949, 0.0794)


def fresnel(cos_i, n: float = N_WATER):
    """Exact reflectance of unpolarised light at an interface from air into a medium of
    index ``n``, for the cosine of the incidence angle ``cos_i`` (any shape; clipped to
    [0, 1]): ``(R_s + R_p) / 2``. Returns float64 or float32 like the input."""
    c = np.clip(np.asarray(cos_i), 0.0, 1.0)
    s2t = (1.0 - c * c) / (n * n)
    ct = np.sqrt(np.maximum(1.0 - s2t, 0.0))
    rs = ((c - n * ct) / (c + n * ct + 1e-30)) ** 2
    rp = ((ct - n * c) / (ct + n * c + 1e-30)) ** 2
    r = 0.5 * (rs + rp)
    return np.where(c <= 0.0, 1.0, r).astype(np.result_type(c, np.float32))


def schlick(cos_i, n: float = N_WATER):
    """Schlick's approximation of :func:`fresnel`."""
    r0 = ((n - 1.0) / (n + 1.0)) ** 2
    c = np.clip(np.asarray(cos_i), 0.0, 1.0)
    return r0 + (1.0 - r0) * (1.0 - c) ** 5


def refracted_cos(cos_i, n: float = N_WATER):
    """Cosine of the refraction angle in water for light incident at ``cos_i`` from air."""
    c = np.clip(np.asarray(cos_i), 0.0, 1.0)
    return np.sqrt(1.0 - (1.0 - c * c) / (n * n))


# --------------------------------------------------------------------------- water body

@dataclass(frozen=True)
class Constituents:
    """Water constituents: chlorophyll ``chl`` (mg/m^3), CDOM absorption at 440 nm ``cdom``
    (1/m), total suspended mineral solids ``tsm`` (g/m^3)."""

    chl: float
    cdom: float
    tsm: float


def iops(chl, cdom, tsm) -> tuple[np.ndarray, np.ndarray]:
    """Absorption ``a`` and backscattering ``b_b`` (1/m) per channel R, G, B.

    Arguments may be scalars or arrays (broadcast); results have shape ``(..., 3)``.
    ``a = a_w + a_phy* chl**0.65 + a_cdom(440) * spectral shape + a_nap* tsm`` and
    ``b_b = b_bw + b_bphy* chl**0.62 + b_bnap* tsm``.
    """
    chl = np.asarray(chl, np.float64)[..., None]
    cdom = np.asarray(cdom, np.float64)[..., None]
    tsm = np.asarray(tsm, np.float64)[..., None]
    a = A_WATER + A_PHY * np.power(chl, 0.65) + A_CDOM * cdom + A_NAP * tsm
    bb = BB_WATER + BB_PHY * np.power(chl, 0.62) + BB_NAP * tsm
    return a, bb


def subsurface_rrs(a, bb):
    """Gordon et al. (1988) remote-sensing reflectance just below the surface (1/sr):
    ``0.0949 u + 0.0794 u^2``, ``u = b_b / (a + b_b)``."""
    u = np.asarray(bb) / (np.asarray(a) + np.asarray(bb))
    return GORDON[0] * u + GORDON[1] * u * u


def above_rrs(rrs_below):
    """Remote-sensing reflectance above the surface (1/sr) from the one below (Lee 2002)."""
    r = np.asarray(rrs_below)
    return 0.52 * r / (1.0 - 1.7 * r)


def shallow_rrs(a, bb, depth, bottom_albedo):
    """Below-surface reflectance of optically shallow water of ``depth`` metres over a
    Lambertian bottom of ``bottom_albedo`` (per channel): the deep-water reflectance seen
    through a water column of two-way attenuation ``exp(-2 K H)``, ``K = a + b_b``, plus the
    bottom's ``albedo / pi`` attenuated the same way."""
    deep = subsurface_rrs(a, bb)
    t = np.exp(-2.0 * (np.asarray(a) + np.asarray(bb)) * np.asarray(depth)[..., None])
    return deep * (1.0 - t) + np.asarray(bottom_albedo) / math.pi * t


def diffuse_attenuation(a, bb, cos_sun_w: float = 1.0):
    """Diffuse attenuation of downwelling light (1/m), ``(a + b_b) / mu_w`` (Gordon's
    first-order form; ``mu_w``: cosine of the refracted sun angle)."""
    return (np.asarray(a) + np.asarray(bb)) / max(cos_sun_w, 0.2)


def beam_attenuation(a, bb):
    """Beam attenuation ``c = a + b`` (1/m), with the scattering ``b`` taken as
    ``b_b / 0.02`` for particles (mean backscattering ratio) and ``2 b_bw`` for water."""
    a, bb = np.asarray(a), np.asarray(bb)
    return a + 2.0 * BB_WATER + (bb - BB_WATER) / 0.02


# --------------------------------------------------------------------------- sRGB

def srgb_encode(lin) -> np.ndarray:
    """Linear [0, 1] to sRGB [0, 1] (clipped), float32
    (:func:`sdcomp.util.colour.linear_to_srgb`)."""
    return linear_to_srgb(np.asarray(lin, np.float32))


def srgb_decode(s) -> np.ndarray:
    """sRGB [0, 1] to linear [0, 1], float32 (:func:`sdcomp.util.colour.srgb_to_linear`)."""
    return srgb_to_linear(np.asarray(s, np.float32))


def swatch(a, bb, grey: float = 0.18) -> tuple[int, int, int]:
    """The colour of deep water of IOPs ``a``, ``b_b`` (3,) as an sRGB swatch: its
    above-surface reflectance scaled to the luminance ``grey`` (a camera's exposure of a
    frame full of it), sRGB 0..255."""
    rrs = np.asarray(above_rrs(subsurface_rrs(a, bb)), np.float64)
    lin = rrs * (grey / max(float(luminance(rrs)), 1e-12))
    return tuple(int(round(float(v) * 255.0)) for v in srgb_encode(lin))  # type: ignore[return-value]
