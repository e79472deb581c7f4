"""Lambertian relighting of unlit sprites (albedo + camera-frame normals) by a sun.

Colours are sRGB uint8 on input and output; the light is applied in linear RGB.
"""

from __future__ import annotations

import math

import numpy as np


def srgb_to_linear(c: np.ndarray) -> np.ndarray:
    """sRGB values in [0, 1] (any shape, float) to linear RGB in [0, 1]."""
    c = np.asarray(c, dtype=np.float32)
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def linear_to_srgb(c: np.ndarray) -> np.ndarray:
    """Linear RGB in [0, 1] (any shape, float) to sRGB in [0, 1] (clipped)."""
    c = np.minimum(np.maximum(np.asarray(c, dtype=np.float32), 0.0), 1.0)
    return np.where(c <= 0.0031308, c * 12.92, 1.055 * c ** (1 / 2.4) - 0.055)


def sun_direction(elevation_deg: float, azimuth_deg: float) -> np.ndarray:
    """(3,) unit vector towards the sun in the world frame (x forward, y port, z up).

    ``azimuth_deg`` is measured from +x towards +y, ``elevation_deg`` above the horizon.
    """
    e, a = math.radians(elevation_deg), math.radians(azimuth_deg)
    return np.array([math.cos(e) * math.cos(a), math.cos(e) * math.sin(a), math.sin(e)])


def shade(albedo: np.ndarray, normal: np.ndarray, sun_cam: np.ndarray,
          ambient: float = 0.35, sun: float = 0.9) -> np.ndarray:
    """Relight a sprite: ``albedo * (ambient + sun * max(0, n . s))``.

    Args:
        albedo: (H, W, 3) uint8 sRGB.
        normal: (H, W, 3) float unit normals in the camera frame.
        sun_cam: (3,) unit vector towards the sun in the same camera frame.
        ambient, sun: light intensities (linear, unitless).

    Returns:
        (H, W, 3) uint8 sRGB.
    """
    lin = srgb_to_linear(albedo.astype(np.float32) / 255.0)
    lambert = np.clip(normal @ np.asarray(sun_cam, np.float32), 0.0, None)[..., None]
    out = linear_to_srgb(lin * (ambient + sun * lambert))
    return np.rint(out * 255.0).astype(np.uint8)
