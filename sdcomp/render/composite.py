"""Compositing layers onto the background: shadows first, then each layer ``over`` the
image, far to near, premultiplied; a layer reduces the weights of the layers it covers."""

from __future__ import annotations

import math

import cv2
import numpy as np

from .layers import Layer

SHADOW_BLUR_WORK = 8.0  # pixels: wider shadow blurs are made on a reduced copy


def cast_shadow(image: np.ndarray, layer: Layer) -> None:
    """Darken the background under ``layer``'s shadow (in place): the shadow takes
    ``shadow_strength`` of the linear light, so sRGB levels keep ``(1 - s a)**(1 / 2.2)``
    (``a`` the shadow's blurred coverage, quantised to 256 steps: one table look-up and one
    multiply per pixel). Wide blurs are made on a reduced copy (sigma at most
    :data:`SHADOW_BLUR_WORK` pixels there) and magnified back."""
    if layer.shadow_strength <= 0.01:
        return
    x0, y0, x1, y1 = layer.roi
    h, w = image.shape[:2]
    sigma = layer.shadow_blur
    pad = int(math.ceil(2 * sigma)) + 1
    a8 = cv2.copyMakeBorder(cv2.convertScaleAbs(layer.alpha, alpha=255.0), pad, pad, pad,
                            pad, cv2.BORDER_CONSTANT, value=0)
    if sigma > 0.3:
        a8 = _blur_u8(a8, sigma)
    ox, oy = layer.shadow_offset
    sx, sy = int(round(x0 - pad + ox)), int(round(y0 - pad + oy))
    ax0, ay0 = max(sx, 0), max(sy, 0)
    ax1, ay1 = min(sx + a8.shape[1], w), min(sy + a8.shape[0], h)
    if ax1 <= ax0 or ay1 <= ay0:
        return
    sub = np.ascontiguousarray(a8[ay0 - sy:ay1 - sy, ax0 - sx:ax1 - sx])
    table = np.clip(np.rint(255.0 * (1.0 - layer.shadow_strength * np.arange(256) / 255.0)
                            ** (1 / 2.2)), 0, 255).astype(np.uint8)
    keep = cv2.LUT(sub, table)
    region = image[ay0:ay1, ax0:ax1]
    cv2.multiply(region, cv2.merge([keep, keep, keep]), dst=region, scale=1.0 / 255.0)


def _blur_u8(a8: np.ndarray, sigma: float) -> np.ndarray:
    """Gaussian blur of a uint8 (h, w) map by ``sigma`` pixels, on a copy reduced by an
    integer factor when ``sigma`` exceeds :data:`SHADOW_BLUR_WORK` (smooth: nothing is
    lost)."""
    f = max(1, int(sigma // SHADOW_BLUR_WORK))
    if f == 1:
        return cv2.GaussianBlur(a8, (0, 0), sigma)
    h, w = a8.shape
    small = cv2.resize(a8, (max(1, w // f), max(1, h // f)), interpolation=cv2.INTER_AREA)
    small = cv2.GaussianBlur(small, (0, 0), sigma / f)
    return cv2.resize(small, (w, h), interpolation=cv2.INTER_LINEAR)


def over(image: np.ndarray, layer: Layer, below: list[Layer]) -> None:
    """Composite ``layer`` over ``image`` and reduce the weights of the layers it covers."""
    x0, y0, x1, y1 = layer.roi
    region = image[y0:y1, x0:x1]
    out = region.astype(np.float32) * (1.0 - layer.alpha)[..., None] + layer.colour
    region[:] = np.clip(out + 0.5, 0, 255).astype(np.uint8)
    for other in below:
        ox0, oy0, ox1, oy1 = other.roi
        ix0, iy0, ix1, iy1 = max(x0, ox0), max(y0, oy0), min(x1, ox1), min(y1, oy1)
        if ix1 <= ix0 or iy1 <= iy0:
            continue
        other.weight[iy0 - oy0:iy1 - oy0, ix0 - ox0:ix1 - ox0] *= (
            1.0 - layer.alpha[iy0 - y0:iy1 - y0, ix0 - x0:ix1 - x0])


def composite(image: np.ndarray, layers: list[Layer], shadows: bool) -> None:
    """Draw ``layers`` (far to near) onto the uint8 (H, W, 3) ``image`` in place, their
    shadows first when ``shadows``."""
    if shadows:
        for layer in layers:
            cast_shadow(image, layer)
    for k, layer in enumerate(layers):
        over(image, layer, layers[:k])
