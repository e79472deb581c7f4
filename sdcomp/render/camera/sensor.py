"""The sensor: shot and read noise in linear light (through the tone curve's slope: stronger in
the shadows), a Bayer mosaic and demosaicing, optical softness."""

from __future__ import annotations

import cv2
import numpy as np

from ...util.tiles import wrap_window
from .photometric import Photometric, tone_curve
from .scale import scaled_noise

NOISE_SCALE = 32.0  # tile levels per standard deviation (as sdcomp's compositor)
BAND_PIXELS = 1 << 17  # the noise is applied in bands of rows of about this many pixels


DEMOSAIC_SIGMA = 0.5  # native px: Gaussian equivalent of bilinear demosaicing softness


def sigma_present(sigma: np.ndarray, thumb: np.ndarray) -> float:
    """The largest noise sigma (a (256, 3) table) over the levels between each channel's
    darkest and brightest value in ``thumb`` (uint8 (h, w, 3)): what the frame can show."""
    out = 0.0
    for c, plane in enumerate(cv2.split(thumb)):
        lo, hi = cv2.minMaxLoc(plane)[:2]
        out = max(out, float(sigma[int(lo):int(hi) + 1, c].max()))
    return out


def make_noise_tile(seed: tuple[int, ...], h: int, w: int) -> np.ndarray:
    """A sensor-noise tile for frames of up to about (h, w): (nh, nw, 3) uint8
    ``128 + 32 N(0, 1)`` (rounded, clipped at +-4 sigma), channels independent, a function
    of the seed sequence ``seed``; 1021 / 1031 px larger than the frame (up to 1024) in
    each direction (each image reads a window of it: :func:`noise_window`)."""
    rng = np.random.default_rng([*seed, 0xCA3E7A])
    nh, nw = min(h, 1024) + 1021, min(w, 1024) + 1031
    n = 128.0 + NOISE_SCALE * rng.standard_normal((nh, nw, 3), dtype=np.float32)
    return np.clip(np.rint(n), 0, 255).astype(np.uint8)


def noise_window(tile: np.ndarray, h: int, w: int, oy: int, ox: int) -> np.ndarray:
    """(h, w, 3) uint8 window of the noise tile at offsets (``oy``, ``ox``) taken modulo the
    free room (a view when the frame fits in the tile, else the tile repeated: a copy)."""
    nh, nw = tile.shape[:2]
    if h <= nh and w <= nw:
        y, x = oy % (nh - h + 1), ox % (nw - w + 1)
        return tile[y:y + h, x:x + w]
    return wrap_window(tile, oy, ox, h, w)


def noise_sigma(table: Photometric, a: float, b: float, sx: float = 1.0, sy: float = 1.0,
                curve: dict | None = None) -> np.ndarray:
    """(256, 3) float64 noise standard deviation in output levels per input level: the
    linear standard deviation ``sqrt(a x + b)`` at the linear signal x of that level, times
    the tone curve's slope (first-order propagation: noise is stronger in the shadows, where
    the curve is steep, and gone in clipped highlights), reduced by :func:`scaled_noise`.

    With ``curve`` (the :func:`tone_curve` keyword arguments) the slope is the secant over
    x +- sigma (clipped at 0) instead of the tangent: the same for small noise, finite and
    closer to the true spread near black where the curve bends within one sigma."""
    sigma_lin = np.sqrt(a * table.linear + b)
    slope = table.slope
    if curve is not None:
        x = table.linear
        lo, hi = np.maximum(x - sigma_lin, 0.0), x + sigma_lin
        v = 255.0 * tone_curve(np.stack([hi, lo]), **curve)
        slope = (v[0] - v[1]) / np.maximum(hi - lo, 1e-12)
    return scaled_noise(sigma_lin * slope, sx, sy)


def apply_lut_noise(image: np.ndarray, table: Photometric, sigma: np.ndarray,
                    window: np.ndarray) -> np.ndarray:
    """Tone table plus signal-dependent noise: ``round(levels[p] + sigma[p] n)`` per channel,
    with n = (window - 128) / 32 the tile's N(0, 1) (uint8 (H, W, 3) window). Two float
    ``cv2.LUT`` lookups, one multiply, one saturating add, in bands of rows of about
    :data:`BAND_PIXELS` pixels (their float intermediates stay in the processor's cache:
    7x faster on a 20 MP frame than whole-frame passes); (H, W, 3) uint8."""
    s = sigma / NOISE_SCALE
    base = (table.levels - 128.0 * s).astype(np.float32).reshape(256, 1, 3)
    scale = s.astype(np.float32).reshape(256, 1, 3)
    out = np.empty_like(image)
    h, w = image.shape[:2]
    rows = max(1, BAND_PIXELS // max(w, 1))
    for a in range(0, h, rows):
        band = image[a:a + rows]
        noise = cv2.multiply(cv2.LUT(band, scale), window[a:a + rows], dtype=cv2.CV_32F)
        cv2.add(cv2.LUT(band, base), noise, dst=out[a:a + rows], dtype=cv2.CV_8U)
    return out


DEMOSAIC_CODES = {
    "bilinear": cv2.COLOR_BayerBG2RGB,
    "ea": cv2.COLOR_BayerBG2RGB_EA,
    "vng": cv2.COLOR_BayerBG2RGB_VNG,
}


def bayer_mosaic(image: np.ndarray) -> np.ndarray:
    """(H, W) uint8 RGGB Bayer mosaic of an (H, W, 3) uint8 RGB image: R at even rows and
    columns, B at odd rows and columns, G elsewhere."""
    m = np.empty(image.shape[:2], np.uint8)
    m[0::2, 0::2] = image[0::2, 0::2, 0]
    m[0::2, 1::2] = image[0::2, 1::2, 1]
    m[1::2, 0::2] = image[1::2, 0::2, 1]
    m[1::2, 1::2] = image[1::2, 1::2, 2]
    return m


def demosaic(image: np.ndarray, method: str = "bilinear") -> np.ndarray:
    """Re-sample an (H, W, 3) uint8 RGB image through an RGGB Bayer mosaic and OpenCV's
    demosaicing (``bilinear``, ``ea`` edge-aware or ``vng``): the softness, zipper and
    false-colour artefacts of a real sensor at the native scale. (OpenCV names Bayer
    patterns by the second row's second and third pixels: RGGB is its ``BayerBG``.)"""
    return cv2.demosaicing(bayer_mosaic(image), DEMOSAIC_CODES[method])


def soften(image: np.ndarray, sigma_x: float, sigma_y: float) -> np.ndarray:
    """Gaussian blur of an (H, W, 3) uint8 image, sigmas in output px (reflected border)."""
    return cv2.GaussianBlur(image, (0, 0), sigmaX=sigma_x, sigmaY=sigma_y)
