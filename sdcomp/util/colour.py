"""sRGB and linear RGB: the transfer functions every stage that lights colours uses.

Light is added and multiplied in linear RGB; images and albedos are stored as sRGB.
"""

from __future__ import annotations

import numpy as np


def srgb_to_linear(c: np.ndarray) -> np.ndarray:
    """sRGB values in [0, 1] (any shape, float) to linear RGB in [0, 1]."""
    c = np.asarray(c, dtype=np.float32)
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def linear_to_srgb(c: np.ndarray) -> np.ndarray:
    """Linear RGB in [0, 1] (any shape, float) to sRGB in [0, 1] (clipped)."""
    c = np.minimum(np.maximum(np.asarray(c, dtype=np.float32), 0.0), 1.0)
    return np.where(c <= 0.0031308, c * 12.92, 1.055 * c ** (1 / 2.4) - 0.055)
