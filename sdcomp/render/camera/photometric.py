"""The camera's photometric stage: exposure (auto and bias), white balance, tone curve, gamma,
contrast, black lift folded into one per-channel 256-entry table, and the saturation matrix."""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from ...util.colour import LUMA, linear_to_srgb
from .lens import LEVEL_LINEAR
from .scale import scaled_noise

LOG_BLACK, LOG_K, LOG_MAX = 0.08, 35.0, 4.0



TOE_EPS = 0.01  # soft_pow: power curves get a finite slope at black


def white_balance_gains(red: float, blue: float, tint: float) -> np.ndarray:
    """(3,) float64 linear gains (R, G, B) = (red, tint, blue) / their Rec.709 luma, so a
    colour cast does not change the luminance of grey."""
    g = np.array([red, tint, blue], np.float64)
    return g / float(LUMA @ g)


def soft_pow(v, e: float, eps: float = TOE_EPS):
    """``v^e`` on [0, 1] with a finite slope at 0: ``((v + eps)^e - eps^e) / ((1 + eps)^e -
    eps^e)`` (0 -> 0, 1 -> 1; e = 1: identity). Power curves with e < 1 are infinitely steep
    at black, which would amplify black-level noise without bound."""
    if e == 1.0:
        return v
    lo = eps**e
    return ((v + eps) ** e - lo) / ((1 + eps) ** e - lo)


def tone_curve(x, knee: float = 1.0, flat: float = 0.0, contrast: float = 1.0,
               gamma: float = 1.0, black: float = 0.0):
    """Encoded value V in [0, 1] (float64, same shape) of linear signal ``x`` >= 0.

    1. shoulder: x above ``knee`` is compressed ``knee + (1 - knee)(1 - exp(-(x - knee) /
       (1 - knee)))`` (C1, towards 1); knee = 1: hard clip at 1;
    2. encoding: ``(1 - flat) srgb(x_shoulder) + flat log_profile(x)`` with the log
       profile ``0.08 + 0.92 log(1 + 35 x) / log(1 + 35 x 4)`` (D-Log/D-Cinelike-like: lifted
       black, grey 0.18 at 0.45, white 1 at 0.75, clipping 2 stops above white);
    3. contrast S-curve about 0.5: ``p(V) / (p(V) + p(1 - V))`` with p = :func:`soft_pow`
       of exponent ``contrast``;
    4. ``soft_pow(V, gamma)``; 5. black lift ``b + (1 - b) V``.

    With the identity parameters (1, 0, 1, 1, 0) this is the sRGB curve, so the renderer's
    levels map to themselves."""
    x = np.maximum(np.asarray(x, np.float64), 0.0)
    if knee < 1.0:
        k = knee
        over = np.maximum(x - k, 0.0)
        xs = np.minimum(x, k) + (1 - k) * (1 - np.exp(-over / (1 - k)))
    else:
        xs = np.minimum(x, 1.0)
    v = linear_to_srgb(xs)
    if flat > 0:
        log = LOG_BLACK + (1 - LOG_BLACK) * np.log1p(LOG_K * np.minimum(x, LOG_MAX)) / (
            math.log1p(LOG_K * LOG_MAX))
        v = (1 - flat) * v + flat * log
    if contrast != 1.0:
        a, b = soft_pow(v, contrast), soft_pow(1 - v, contrast)
        v = a / (a + b)
    if gamma != 1.0:
        v = soft_pow(v, gamma)
    if black:
        v = black + (1 - black) * v
    return v


@dataclass(frozen=True)
class Photometric:
    """Per-channel tables of one look (index: input sRGB level 0..255, column: R, G, B).

    ``linear``: (256, 3) float64 linear signal after exposure and white balance;
    ``levels``: (256, 3) float64 output level (0..255, unrounded) = 255 x tone curve;
    ``slope``: (256, 3) float64 d(output level) / d(linear signal), or None;
    ``lut``: (256, 1, 3) uint8 rounded ``levels`` for ``cv2.LUT``;
    ``sigma``: (256, 3) float64 noise sigma in output levels, when asked for
    (:func:`photometric_tables` with ``noise``), else None."""

    linear: np.ndarray
    levels: np.ndarray
    slope: np.ndarray | None
    lut: np.ndarray
    sigma: np.ndarray | None = None

    @property
    def identity(self) -> bool:
        return bool(np.array_equal(self.lut[:, 0, :], np.repeat(
            np.arange(256, dtype=np.uint8)[:, None], 3, axis=1)))


def photometric_tables(gain: float, wb: np.ndarray, knee: float, flat: float,
                       contrast: float, gamma: float, black: float,
                       noise: tuple[float, float, float, float] | None = None,
                       with_slope: bool = True) -> Photometric:
    """The tables of :class:`Photometric`: level -> linear (sRGB decoding) -> x ``gain``
    (exposure, linear) x ``wb`` (3,) -> :func:`tone_curve` -> level. The slope is a central
    difference (relative step 1e-4; one-sided at 0); ``with_slope=False`` leaves it None
    (the pipeline does not need it). With ``noise`` = (a, b, sx, sy) the table also carries
    ``sigma``: :func:`noise_sigma` with the secant slope over x +- sigma, the curve there
    interpolated from the 256 levels (dense enough: its x spacing at black, 3e-4, is below
    the read noise; this runs per image, so one evaluation of the curve serves all).

    Level 255 is the renderer's clip: a radiance at least its full scale, mostly far above
    it (the sun's sparkles); like a sensor's saturated pixel it stays white (255, no noise)
    whatever the exposure and white balance."""
    x = LEVEL_LINEAR[:, None] * (gain * np.asarray(wb, np.float64))[None, :]
    pts = [x]
    if with_slope:
        h = np.maximum(1e-7, 1e-4 * x)
        pts += [x + h, np.maximum(x - h, 0.0)]
    v = 255.0 * tone_curve(np.stack(pts), knee, flat, contrast, gamma, black)
    levels = v[0]
    levels[255] = 255.0
    slope = (v[1] - v[2]) / (pts[1] - pts[2]) if with_slope else None
    lut = np.clip(np.rint(levels), 0, 255).astype(np.uint8).reshape(256, 1, 3)
    sigma = None
    if noise is not None:
        a, b, sx, sy = noise
        sigma_lin = np.sqrt(a * x + b)
        sigma = np.empty_like(x)
        for c in range(3):
            xc, s = x[:, c], sigma_lin[:, c]
            hi, lo = xc + s, np.maximum(xc - s, 0.0)
            sigma[:, c] = s * (np.interp(hi, xc, levels[:, c]) - np.interp(lo, xc, levels[:, c])
                               ) / np.maximum(hi - lo, 1e-12)
        sigma = scaled_noise(sigma, sx, sy)
        sigma[255] = 0.0
    return Photometric(x, levels, slope, lut, sigma)


_LINEAR_LUT = LEVEL_LINEAR.astype(np.float32).reshape(256, 1)


def thumbnail(image: np.ndarray, samples: int = 64) -> np.ndarray:
    """About ``samples`` x ``samples`` pixels of an (H, W, 3) image on a regular stride (a
    contiguous copy): what the metering sees."""
    h, w = image.shape[:2]
    return np.ascontiguousarray(image[::max(1, h // samples), ::max(1, w // samples)])


def mean_luminance(thumb: np.ndarray, wb: np.ndarray) -> float:
    """Mean linear Rec.709 luminance (after white balance ``wb``) of a uint8 sRGB
    (h, w, 3) image, usually a :func:`thumbnail`."""
    means = cv2.mean(cv2.LUT(thumb, _LINEAR_LUT))[:3]
    return float(np.dot(means, LUMA * np.asarray(wb)))


def exposure_gain(mean: float, target: float, strength: float, ev: float,
                  limit: float = 32.0) -> float:
    """Linear exposure gain: auto exposure ``(target / mean)^strength`` times ``2^ev``,
    clamped to [1/limit, limit]."""
    g = (target / max(mean, 1e-4)) ** strength * 2.0 ** ev
    return float(min(max(g, 1.0 / limit), limit))


def apply_lut(image: np.ndarray, table: Photometric) -> np.ndarray:
    """(H, W, 3) uint8 through the per-channel 8-bit table (one ``cv2.LUT``)."""
    return cv2.LUT(image, table.lut)


def colour_matrix(saturation: float) -> np.ndarray:
    """(3, 3) float32 saturation matrix about Rec.709 luma: ``s I + (1 - s) 1 LUMA^T``
    (rows sum to 1: greys and luma kept)."""
    m = saturation * np.eye(3) + (1 - saturation) * np.ones((3, 1)) * LUMA[None, :]
    return m.astype(np.float32)


def apply_colour(image: np.ndarray, matrix: np.ndarray) -> np.ndarray:
    """(H, W, 3) uint8 times a (3, 3) matrix per pixel (``cv2.transform``, rounded and
    saturated)."""
    return cv2.transform(image, matrix)
