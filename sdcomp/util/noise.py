"""Sensor noise measured in an image: Immerkaer's (1996) estimator, per patch.

The residual of the Laplacian-like kernel ``[[1, -2, 1], [-2, 4, -2], [1, -2, 1]]`` cancels
smooth image structure up to second order; over white Gaussian noise of std ``s`` its mean
absolute value is ``6 s sqrt(2 / pi)``. Texture adds to it, so the noise is read where an
image holds least: a low percentile over patches.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

from .tiles import grid_patches

LAPLACE = np.array([[1, -2, 1], [-2, 4, -2], [1, -2, 1]], np.float32)
PATCH = 64  #: patch side, pixels


def residual(y: np.ndarray) -> np.ndarray:
    """(H, W) float32 |Laplacian residual| of the (H, W) float32 luma ``y`` (reflected
    borders); its mean times :data:`SCALE` estimates a white noise's std (levels)."""
    return np.abs(cv2.filter2D(np.asarray(y, np.float32), -1, LAPLACE,
                               borderType=cv2.BORDER_REFLECT_101))


SCALE = math.sqrt(math.pi / 2) / 6.0  #: mean |residual| of unit white noise, inverted


def patch_noise(y: np.ndarray, patch: int = PATCH) -> np.ndarray:
    """(n,) float64 noise estimate (levels) of each non-overlapping ``patch`` x ``patch``
    tile of the (H, W) luma ``y`` (a grid from the top-left corner, row-major; remainders
    left out); empty when the image is smaller than a patch."""
    tiles = grid_patches(residual(y), patch)
    if len(tiles) == 0:
        return np.zeros(0)
    return tiles.reshape(len(tiles), -1).mean(axis=1, dtype=np.float64) * SCALE


def noise_level(y: np.ndarray, percentile: float = 25.0, patch: int = PATCH) -> float:
    """The noise (levels) of luma ``y``: the ``percentile`` of its patches' estimates, where
    texture adds least (the whole image's estimate when it is smaller than a patch)."""
    p = patch_noise(y, patch)
    if p.size == 0:
        return float(residual(y).mean(dtype=np.float64) * SCALE) if np.size(y) else 0.0
    return float(np.percentile(p, percentile))
