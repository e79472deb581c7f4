"""Compositing layers onto the background: shadows first, then each layer ``over`` the
image, far to near, premultiplied; a layer reduces the weights of the layers it covers."""

from __future__ import annotations

import math

import cv2
import numpy as np

from .layers import Layer


def cast_shadow(image: np.ndarray, layer: Layer) -> None:
    """Darken the background under ``layer``'s shadow (in place): the shadow takes
    ``shadow_strength`` of the linear light, so sRGB levels keep ``(1 - s)**(1 / 2.2)``."""
    if layer.shadow_strength <= 0.01:
        return
    x0, y0, x1, y1 = layer.roi
    h, w = image.shape[:2]
    pad = int(math.ceil(2 * layer.shadow_blur)) + 1
    a = cv2.copyMakeBorder(layer.alpha, pad, pad, pad, pad, cv2.BORDER_CONSTANT, value=0)
    if layer.shadow_blur > 0.3:
        a = cv2.GaussianBlur(a, (0, 0), layer.shadow_blur)
    ox, oy = layer.shadow_offset
    sx, sy = int(round(x0 - pad + ox)), int(round(y0 - pad + oy))
    ax0, ay0 = max(sx, 0), max(sy, 0)
    ax1, ay1 = min(sx + a.shape[1], w), min(sy + a.shape[0], h)
    if ax1 <= ax0 or ay1 <= ay0:
        return
    sub = a[ay0 - sy:ay1 - sy, ax0 - sx:ax1 - sx]
    region = image[ay0:ay1, ax0:ax1]
    shade = np.power(1.0 - np.float32(layer.shadow_strength) * sub,
                     np.float32(1 / 2.2))[..., None]
    region[:] = (region.astype(np.float32) * shade + 0.5).astype(np.uint8)


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
