"""Optics of the sea surface and the sky: refraction, Fresnel reflectance, the sky's
radiance, the surface's slope statistics. Pure functions; colours in linear RGB."""

from __future__ import annotations

import numpy as np

REFRACTIVE_INDEX = 1.333
SLOPE_SCALE = 40.0  # uint8 units per standard deviation of a slope channel
SKY_ZENITH = (0.16, 0.30, 0.62)  # linear RGB of the clear sky overhead
SKY_HORIZON = (0.62, 0.70, 0.80)  # linear RGB of the sky at the horizon
SKY_ZENITH_RGB = np.asarray(SKY_ZENITH, np.float32)  # the same as (3,) float32 arrays
SKY_HORIZON_RGB = np.asarray(SKY_HORIZON, np.float32)


def refracted_cos(cos_incidence):
    """Cosine of the refracted angle under water for light arriving at ``cos_incidence``."""
    sin2_i = np.maximum(1.0 - np.square(cos_incidence), 0.0)
    return np.sqrt(1.0 - sin2_i / REFRACTIVE_INDEX ** 2)


def fresnel(cos_incidence):
    """Schlick's reflectance of the air-water surface for light at ``cos_incidence``."""
    r0 = ((REFRACTIVE_INDEX - 1) / (REFRACTIVE_INDEX + 1)) ** 2
    return r0 + (1 - r0) * np.power(1.0 - np.minimum(np.maximum(cos_incidence, 0.0), 1.0), 5)


def sky_linear(elevation_sin) -> np.ndarray:
    """Linear sky radiance (..., 3) for directions with sine of elevation ``elevation_sin``."""
    t = np.sqrt(np.minimum(np.maximum(np.asarray(elevation_sin, np.float32), 0.0), 1.0))
    t = t[..., None]
    return SKY_HORIZON_RGB + (SKY_ZENITH_RGB - SKY_HORIZON_RGB) * t


def slope_variance(wind: float) -> float:
    """Cox-Munk mean-square slope of the sea surface at ``wind`` m/s."""
    return 0.003 + 0.00512 * max(float(wind), 0.0)
