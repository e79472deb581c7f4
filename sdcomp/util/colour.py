"""sRGB and linear RGB: the transfer functions every stage that lights colours uses.

Light is added and multiplied in linear RGB; images and albedos are stored as sRGB.
"""

from __future__ import annotations

import numpy as np

LUMA = np.array([0.2126, 0.7152, 0.0722])  # Rec. 709 luminance weights of linear R, G, B
#: Rec. 601 luma weights of encoded (sRGB) R, G, B: the luma of stored images, as codecs and
#: OpenCV's grey conversion weigh them
LUMA_601 = np.array([0.299, 0.587, 0.114], np.float32)


def _float(c) -> np.ndarray:
    """``c`` as a float array: float64 kept, anything else float32."""
    a = np.asarray(c)
    return a if a.dtype == np.float64 else a.astype(np.float32)


def srgb_to_linear(c: np.ndarray) -> np.ndarray:
    """sRGB values in [0, 1] (any shape) to linear RGB in [0, 1]; float64 stays float64,
    anything else is float32."""
    c = _float(c)
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4).astype(c.dtype)


def linear_to_srgb(c: np.ndarray) -> np.ndarray:
    """Linear RGB (any shape) to sRGB in [0, 1], clipped to [0, 1] first; float64 stays
    float64, anything else is float32."""
    c = _float(c)
    c = np.minimum(np.maximum(c, 0.0), 1.0)
    return np.where(c <= 0.0031308, c * 12.92, 1.055 * c ** (1 / 2.4) - 0.055).astype(c.dtype)


def luminance(rgb) -> np.ndarray:
    """Rec. 709 luminance of linear RGB (..., 3)."""
    rgb = np.asarray(rgb)
    return rgb[..., 0] * LUMA[0] + rgb[..., 1] * LUMA[1] + rgb[..., 2] * LUMA[2]
