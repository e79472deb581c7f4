"""The scale rule: the camera's artefacts are made at the recording's native scale, then
shrunk with the frame. Sizes given in native pixels are converted to output pixels with the
scale factors ``(sx, sy) = native / output`` (:attr:`sdcomp.scene.look.CameraLook.scale`):
blurs shrink by ``s``, noise averages down by ``sqrt(sx sy)``, sharpening's halos narrow and
fade (see docs/water.md)."""

from __future__ import annotations

import math

import numpy as np


def scaled_blur(sigma_native: float, sx: float, sy: float) -> tuple[float, float]:
    """A Gaussian blur of ``sigma_native`` native pixels seen in an image ``sx`` x ``sy``
    times smaller: sigma / s per axis (output px). Gaussians scale exactly."""
    return sigma_native / sx, sigma_native / sy


def scaled_noise(sigma_native, sx: float, sy: float):
    """Noise standard deviation after averaging ``sx`` x ``sy`` independent native pixels
    into one output pixel: sigma / sqrt(sx sy) (any shape)."""
    return np.asarray(sigma_native) / math.sqrt(sx * sy)


SHARPEN_SIGMA_MIN = 0.6  # output px: the narrowest unsharp mask used (see scaled_sharpen)


def scaled_sharpen(amount: float, sigma_native: float, sx: float, sy: float
                   ) -> tuple[float, float]:
    """The unsharp mask (amount, sigma in output px) that the native one (``amount``,
    ``sigma_native``) becomes after a reduction by ``sx`` x ``sy``.

    An unsharp mask boosts frequency w by ``amount (1 - exp(-sigma^2 w^2 / 2))``. After the
    reduction, sigma is ``sigma_native / s`` (s the geometric mean of sx, sy); where that is
    narrower than :data:`SHARPEN_SIGMA_MIN` output pixels the mask is applied at that width
    with the amount that gives the same boost at the output Nyquist frequency (w = pi):
    ``amount x (1 - exp(-pi^2 sigma^2 / 2)) / (1 - exp(-pi^2 SHARPEN_SIGMA_MIN^2 / 2))``.
    So the halo shrinks with the image and its strength goes to zero (sigma -> 0).
    """
    sigma = sigma_native / math.sqrt(sx * sy)
    if sigma >= SHARPEN_SIGMA_MIN:
        return amount, sigma

    def boost(s):
        return 1.0 - math.exp(-(math.pi * s) ** 2 / 2)

    return amount * boost(sigma) / boost(SHARPEN_SIGMA_MIN), SHARPEN_SIGMA_MIN
