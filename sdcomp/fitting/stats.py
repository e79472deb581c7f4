"""The scene statistics ``sdcomp fit`` matches: per image, over its empty-water patches.

Water (the realism report's, :mod:`sdcomp.report.realism.patches`): ``luminance`` (median
patch mean of Rec. 601 luma, 0-255), ``saturation`` (median patch mean HSV saturation, 0-1),
``highpass_std`` (median patch std of luma minus its 9 x 9 box blur, 8-bit levels),
``glint_fraction`` (mean share of pixels with luma >= 230, 0-1) and the water's colour as
chromaticity ``chroma_r`` = R / (R + G + B), ``chroma_b`` = B / (R + G + B) (medians of the
patches' mean sRGB levels); ``highlight_r``, ``highlight_b``: the same chromaticity of the
brightest :data:`HIGHLIGHT_SHARE` of the patches' pixels (by luma: the waves' mirrored sky,
glitter, foam). The surface's reflection is nearly neutral whatever the water, so the
highlights carry the sky's and the camera's colour and not the water's: a colour cast of
the camera tints them, green water does not (the two explain a green frame's mean colour
equally well).

Camera: ``noise`` (8-bit levels: Immerkaer's estimate, sqrt(pi / 2) / 6 mean |Laplacian
residual|, the 25th percentile over patches, where texture adds least), ``noise_slope``
(report only: levels^2 of noise variance per level of luma, the least-squares slope of the
patches' variance on their luminance), ``sharpness`` (median over patches of std(Y - blur3)
/ std(Y - blur9): lower is blurrier), ``blockiness`` (the excess |step| of luma across
8-pixel block edges over that inside blocks, relative: 0 without JPEG blocks) and ``vignetting``
(1 - mean luma at radius > 0.8 of the half-diagonal / mean luma within 0.4).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import cv2
import numpy as np

from ..report.realism.patches import image_maps, maps_patch_stats, to_patches
from ..util.noise import patch_noise

#: the statistics matched, in report order
STATS = ("luminance", "saturation", "highpass_std", "glint_fraction", "chroma_r", "chroma_b",
         "highlight_r", "highlight_b", "noise", "sharpness", "blockiness", "vignetting")
#: report-only statistics (measured, not matched)
EXTRA = ("noise_slope",)
#: a difference of this much in a statistic counts as one unit of the fit's loss
SCALES = {"luminance": 12.0, "saturation": 0.05, "highpass_std": 1.0, "glint_fraction": 0.01,
          "chroma_r": 0.012, "chroma_b": 0.012, "highlight_r": 0.015, "highlight_b": 0.015,
          "noise": 0.4, "sharpness": 0.03,
          "blockiness": 0.05, "vignetting": 0.05}
UNITS = {"luminance": "0-255", "saturation": "0-1", "highpass_std": "levels",
         "glint_fraction": "0-1", "chroma_r": "R/(R+G+B)", "chroma_b": "B/(R+G+B)",
         "highlight_r": "R/(R+G+B)", "highlight_b": "B/(R+G+B)",
         "noise": "levels", "sharpness": "ratio", "blockiness": "ratio",
         "vignetting": "0-1", "noise_slope": "levels^2/level"}
BLOCK_FLOOR = 1.0  #: levels added to the inside step of :func:`blockiness`
HIGHLIGHT_SHARE = 0.01  #: ``highlight_*`` is the colour of this brightest share of pixels


def image_stats(rgb: np.ndarray, keep: np.ndarray | None = None,
                scene: np.ndarray | None = None) -> dict[str, float] | None:
    """The statistics (:data:`STATS` and :data:`EXTRA`) of one (H, W, 3) uint8 RGB image
    over its grid patches where ``keep`` ((n,) bool, None = all) is True; ``blockiness``
    and ``vignetting``, measured over the whole image, over its pixels where ``scene``
    ((H, W) bool, None = all) is True (False: painted out). None when no patch is kept."""
    maps = image_maps(rgb)
    ps = maps_patch_stats(maps, keep)
    if ps["luminance"].size == 0:
        return None
    sel = slice(None) if keep is None else np.asarray(keep, bool)
    pixels = to_patches(rgb)[sel].reshape(ps["luminance"].size, -1, 3)
    rgb_mean = pixels.mean(axis=1)
    chroma = rgb_mean / np.maximum(rgb_mean.sum(axis=1, keepdims=True), 1e-6)
    high = highlight_chroma(pixels.reshape(-1, 3), to_patches(maps.y)[sel].reshape(-1))
    noise = patch_noise(maps.y)[sel]
    fine = to_patches(maps.y - cv2.blur(maps.y, (3, 3), borderType=cv2.BORDER_REFLECT_101)
                      )[sel].reshape(noise.size, -1).std(axis=1)
    sharp = fine / np.maximum(ps["highpass_std"], 1e-3)
    return {
        "luminance": float(np.median(ps["luminance"])),
        "saturation": float(np.median(ps["saturation"])),
        "highpass_std": float(np.median(ps["highpass_std"])),
        "glint_fraction": float(np.mean(ps["glint_fraction"])),
        "chroma_r": float(np.median(chroma[:, 0])),
        "chroma_b": float(np.median(chroma[:, 2])),
        "highlight_r": high[0],
        "highlight_b": high[1],
        "noise": float(np.percentile(noise, 25)),
        "sharpness": float(np.median(sharp)),
        "blockiness": blockiness(maps.y, scene),
        "vignetting": vignetting(maps.y, scene),
        "noise_slope": _noise_slope(ps["luminance"], noise),
    }


def highlight_chroma(rgb: np.ndarray, y: np.ndarray) -> tuple[float, float]:
    """(R, B) / (R + G + B) of the summed colour of the brightest :data:`HIGHLIGHT_SHARE`
    of the pixels ``rgb`` (n, 3) uint8 by their luma ``y`` (n,) float (at least one pixel);
    NaN for no pixels or a black selection."""
    if y.size == 0:
        return math.nan, math.nan
    k = max(1, int(round(y.size * HIGHLIGHT_SHARE)))
    top = np.argpartition(y, y.size - k)[y.size - k:]
    total = rgb[top].sum(axis=0, dtype=np.float64)
    s = float(total.sum())
    return (float(total[0] / s), float(total[2] / s)) if s > 0 else (math.nan, math.nan)


def _noise_slope(lum: np.ndarray, noise: np.ndarray) -> float:
    """Least-squares slope of noise variance (levels^2) on patch luminance (levels); NaN
    with fewer than 3 patches or no spread of luminance."""
    if lum.size < 3 or np.ptp(lum) < 1.0:
        return float("nan")
    return float(np.polyfit(lum, noise ** 2, 1)[0])


def blockiness(y: np.ndarray, scene: np.ndarray | None = None, block: int = 8) -> float:
    """(Mean |step| of the (H, W) float32 luma across ``block``-pixel edges, columns and
    rows, minus the mean |step| inside blocks) / (the inside mean + :data:`BLOCK_FLOOR`
    levels): 0 without blocking (the floor keeps smooth water from dividing by ~0); only
    the steps between two pixels of ``scene`` ((H, W) bool; None: all); NaN for images
    smaller than 2 blocks or without steps of both kinds."""
    h, w = y.shape
    if h < 2 * block or w < 2 * block:
        return float("nan")
    dx = np.abs(np.diff(y, axis=1))
    dy = np.abs(np.diff(y, axis=0))
    on_x = (np.arange(w - 1) % block) == block - 1
    on_y = (np.arange(h - 1) % block) == block - 1
    if scene is None:
        edge = dx[:, on_x].sum() + dy[on_y].sum()
        n_edge = dx[:, on_x].size + dy[on_y].size
        inner = dx[:, ~on_x].sum() + dy[~on_y].sum()
        n_inner = dx[:, ~on_x].size + dy[~on_y].size
    else:
        sx = scene[:, 1:] & scene[:, :-1]  # steps between two pixels of the scene
        sy = scene[1:] & scene[:-1]
        edge = dx[:, on_x][sx[:, on_x]].sum() + dy[on_y][sy[on_y]].sum()
        n_edge = np.count_nonzero(sx[:, on_x]) + np.count_nonzero(sy[on_y])
        inner = dx[:, ~on_x][sx[:, ~on_x]].sum() + dy[~on_y][sy[~on_y]].sum()
        n_inner = np.count_nonzero(sx[:, ~on_x]) + np.count_nonzero(sy[~on_y])
        if n_edge == 0 or n_inner == 0:
            return float("nan")
    inner_mean = inner / n_inner
    return float((edge / n_edge - inner_mean) / (inner_mean + BLOCK_FLOOR))


def vignetting(y: np.ndarray, scene: np.ndarray | None = None) -> float:
    """1 - (mean luma beyond 0.8 of the half-diagonal) / (mean luma within 0.4 of it) of
    the (H, W) float32 luma ``y`` over its pixels of ``scene`` ((H, W) bool; None: all)
    (0: flat; positive: darker corners; NaN where either ring has none)."""
    h, w = y.shape
    yy, xx = np.ogrid[:h, :w]
    r = np.hypot((xx - (w - 1) / 2) / (w / 2), (yy - (h - 1) / 2) / (h / 2)) / math.sqrt(2)
    inside, outside = r < 0.4, r > 0.8
    if scene is not None:
        inside, outside = inside & scene, outside & scene
    centre = y[inside].mean() if np.any(inside) else np.nan
    corner = y[outside].mean() if np.any(outside) else np.nan
    return float(1.0 - corner / max(centre, 1e-6))


def stack(rows: Sequence[dict[str, float] | None]) -> dict[str, np.ndarray]:
    """{statistic: (n,) float64} of per-image statistics dicts (None rows left out)."""
    kept = [r for r in rows if r is not None]
    return {k: np.array([r[k] for r in kept], np.float64) for k in (*STATS, *EXTRA)}


def summary(per_image: dict[str, np.ndarray]) -> dict[str, tuple[float, float, float]]:
    """{statistic: (p10, p50, p90)} over images (NaNs left out; NaN where none is left)."""
    out = {}
    for k, v in per_image.items():
        v = v[np.isfinite(v)]
        p10, p50, p90 = np.percentile(v, (10, 50, 90)) if v.size else (math.nan,) * 3
        out[k] = (float(p10), float(p50), float(p90))
    return out


def distance(a: dict[str, tuple[float, float, float]], b: dict[str, tuple[float, float, float]],
             stats: tuple[str, ...] = STATS) -> dict[str, float]:
    """{statistic: |median difference| + (|p10 diff| + |p90 diff|) / 4, in units of
    :data:`SCALES`} between two summaries; NaN where either is unknown."""
    out = {}
    for k in stats:
        d = np.abs(np.subtract(a[k], b[k])) / SCALES[k]
        out[k] = float(d[1] + (d[0] + d[2]) / 4)
    return out


def loss(a: dict, b: dict, stats: tuple[str, ...] = STATS) -> float:
    """Sum of squared :func:`distance` over the statistics both summaries know."""
    d = np.array(list(distance(a, b, stats).values()))
    return float(np.sum(d[np.isfinite(d)] ** 2))
