"""Compositing layers onto the background: shadows first, then each layer ``over`` the
image, far to near, premultiplied; a layer reduces the weights of the layers it covers."""

from __future__ import annotations

import math

import cv2
import numpy as np

from .layers import Layer

SHADOW_BLUR_WORK = 8.0  # pixels: shadow blurs twice as wide are made on a reduced copy
BAND_PIXELS = 1 << 18  # layers are blended in bands of rows of about this many pixels
NO_COLOUR = np.zeros((0, 0, 3), np.float32)  # a drawn layer's colour, released


MAX_SLICES = 16  #: height slices of an extruded shadow (one per pixel of its length, at most)


def extruded(alpha: np.ndarray, height: np.ndarray | None, step: tuple[float, float]
             ) -> tuple[np.ndarray, int, int]:
    """(coverage (h', w') float32, dx, dy) of the shadow a layer casts on the water: its
    coverage ``alpha`` (h, w) with every pixel's column of ``height`` / alpha metres above
    the water (``height`` (h, w) float32, premultiplied; None: flat) laid along ``step``
    (frame pixels per metre up): the union of the slices at or above each height, each moved
    by its height (at most :data:`MAX_SLICES`), on a canvas whose pixel (0, 0) is the
    layer's pixel (dx, dy) (dx, dy <= 0)."""
    if height is None or not (step[0] or step[1]):
        return alpha, 0, 0
    h = np.divide(height, alpha, out=np.zeros_like(height), where=alpha > 1e-3)
    top = float(h.max()) if h.size else 0.0
    sx, sy = top * step[0], top * step[1]
    length = math.hypot(sx, sy)
    if length < 0.5:
        return alpha, 0, 0
    k = min(int(math.ceil(length)), MAX_SLICES)
    px, py = int(math.ceil(abs(sx))), int(math.ceil(abs(sy)))
    rows, cols = alpha.shape
    out = np.zeros((rows + 2 * py, cols + 2 * px), np.float32)
    part, above = np.empty_like(alpha), np.empty(alpha.shape, bool)  # reused per slice
    for j in range(k + 1):
        z = top * j / k
        if j == 0:
            part[:] = alpha
        else:
            np.greater_equal(h, z - 1e-6, out=above)
            np.multiply(alpha, above, out=part)
        ox, oy = px + int(round(z * step[0])), py + int(round(z * step[1]))
        view = out[oy:oy + rows, ox:ox + cols]
        np.maximum(view, part, out=view)
    return out, -px, -py


def cast_shadow(image: np.ndarray, layer: Layer) -> None:
    """Darken the background under ``layer``'s shadow (in place; its coverage
    :func:`extruded` by the heights above the water): the shadow takes
    ``shadow_strength`` of the linear light (per channel), so sRGB levels keep
    ``(1 - s a)**(1 / 2.2)`` (``a`` the shadow's blurred coverage, quantised to 256 steps:
    a table look-up per channel and one multiply per pixel). Wide blurs are made on a copy
    reduced by an integer factor (sigma under twice :data:`SHADOW_BLUR_WORK` pixels there)
    and magnified back band by band of :data:`BAND_PIXELS` over the frame's part only (no
    full-size copy of a shadow wider than the frame)."""
    strength = np.asarray(layer.shadow_strength, np.float64).reshape(-1)
    if float(strength.max()) <= 0.01:
        return
    x0, y0, x1, y1 = layer.roi
    h, w = image.shape[:2]
    sigma = layer.shadow_blur
    f = max(1, int(sigma // SHADOW_BLUR_WORK))
    pad = -(-(int(math.ceil(2 * sigma)) + 1) // f) * f  # a multiple of f
    alpha, height, step = layer.alpha, layer.shadow_height, layer.shadow_step
    if f > 1:  # extruded on the reduced copy: (1 / f)**2 of the memory and the work
        small = (-(-alpha.shape[1] // f), -(-alpha.shape[0] // f))
        alpha = cv2.resize(alpha, small, interpolation=cv2.INTER_AREA)
        height = None if height is None else cv2.resize(height, small,
                                                        interpolation=cv2.INTER_AREA)
        step = (step[0] / f, step[1] / f)
    cover, dx, dy = extruded(alpha, height, step)
    x0, y0 = x0 + dx * f, y0 + dy * f
    a8 = cv2.convertScaleAbs(cover, alpha=255.0)
    del alpha, height, cover
    a8 = cv2.copyMakeBorder(a8, pad // f, pad // f, pad // f, pad // f,
                            cv2.BORDER_CONSTANT, value=0)
    if sigma > 0.3:
        a8 = cv2.GaussianBlur(a8, (0, 0), sigma / f)
    ox, oy = layer.shadow_offset
    sx, sy = int(round(x0 - pad + ox)), int(round(y0 - pad + oy))  # the map's corner
    ax0, ay0 = max(sx, 0), max(sy, 0)
    ax1, ay1 = min(sx + a8.shape[1] * f, w), min(sy + a8.shape[0] * f, h)
    if ax1 <= ax0 or ay1 <= ay0:
        return
    # one 256-entry table per channel (a shadow takes more of the red: the sun is warmer)
    table = np.clip(np.rint(255.0 * (1.0 - np.arange(256)[:, None] / 255.0 * strength)
                            ** (1 / 2.2)), 0, 255).astype(np.uint8)
    tables = [np.ascontiguousarray(table[:, c % len(strength)]) for c in range(3)]
    rows = max(1, BAND_PIXELS // (ax1 - ax0))
    for a in range(ay0, ay1, rows):
        b = min(a + rows, ay1)
        if f == 1:
            sub = a8[a - sy:b - sy, ax0 - sx:ax1 - sx]
        else:  # frame pixel p samples the reduced map at (p - corner + 0.5) / f - 0.5
            m = np.array([[1.0 / f, 0.0, (ax0 - sx + 0.5) / f - 0.5],
                          [0.0, 1.0 / f, (a - sy + 0.5) / f - 0.5]])
            sub = cv2.warpAffine(a8, m, (ax1 - ax0, b - a),
                                 flags=cv2.INTER_LINEAR | cv2.WARP_INVERSE_MAP,
                                 borderMode=cv2.BORDER_REPLICATE)
        sub = np.ascontiguousarray(sub)
        region = image[a:b, ax0:ax1]
        cv2.multiply(region, cv2.merge([cv2.LUT(sub, t) for t in tables]), dst=region,
                     scale=1.0 / 255.0)


def over(image: np.ndarray, layer: Layer, below: list[Layer]) -> None:
    """Composite ``layer`` over ``image`` (band by band of rows of :data:`BAND_PIXELS`: no
    float copy of a large region) and reduce the weights of the layers it covers.

    ``image (1 - alpha) + colour``, and where the layer lies under the water (its weight
    below its coverage) the water in front of it is the image's own: ``+ (alpha - weight)
    (image - water)``, ``water`` the layer's modelled water (:attr:`Layer.water_srgb`). A
    limb deep in the water so takes on the waves, glints and colour of the water drawn
    around it (the user's footage too) instead of the model's flat water colour."""
    x0, y0, x1, y1 = layer.roi
    rows = max(1, BAND_PIXELS // max(x1 - x0, 1))
    water = (None if layer.water_srgb is None
             else np.asarray(layer.water_srgb, np.float32))
    for a in range(0, y1 - y0, rows):
        b = min(a + rows, y1 - y0)
        region = image[y0 + a:y0 + b, x0:x1]
        bg = region.astype(np.float32)
        out = bg * (1.0 - layer.alpha[a:b])[..., None]
        out += layer.colour[a:b]
        if water is not None:
            wet = layer.alpha[a:b] - layer.weight[a:b]
            if float(wet.max()) > 1e-3:
                out += np.maximum(wet, 0.0)[..., None] * (bg - water)
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
    shadows first when ``shadows``. Each layer's shadow caster is released once the shadows
    are cast (set to None) and its ``colour`` once drawn (set to :data:`NO_COLOUR`): the
    masks need only coverage and weights."""
    if shadows:
        for layer in layers:
            cast_shadow(image, layer)
    for layer in layers:
        layer.shadow_height = None  # cast (or not wanted): released
    for k, layer in enumerate(layers):
        over(image, layer, layers[:k])
        layer.colour = NO_COLOUR  # drawn: only its coverage and weight are used from here
