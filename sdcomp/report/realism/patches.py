"""Per-image luminance / high-pass / saturation maps and per-patch realism statistics.

Definitions (docs/realism.md), for an (H, W, 3) uint8 sRGB RGB image:

- ``Y = 0.299 R + 0.587 G + 0.114 B`` (float32, 0..255): Rec. 601 luma of the encoded
  8-bit values, as the reference real frames were measured (the renderer's
  :func:`sdcomp.util.colour.luminance` is Rec. 709 luminance of linear RGB, another
  quantity);
- ``highpass = Y - cv2.blur(Y, (9, 9), borderType=cv2.BORDER_REFLECT_101)`` on the WHOLE
  image, then cut into patches;
- ``S = (max(R, G, B) - min(R, G, B)) / max(R, G, B)``, 0 where the max is 0.

Patches are the non-overlapping 64 x 64 tiles of a grid anchored at the top-left corner (the
right and bottom remainders narrower than 64 px are not used), numbered row-major. Per patch:
``saturation = mean(S)`` (0..1), ``luminance = mean(Y)`` (0..255), ``highpass_std =
std(highpass)`` (population std, 8-bit levels), ``glint_fraction = mean(Y >= 230)`` (0..1).

A patch is "empty water" when no instance-mask pixel is non-zero in it, no box to keep clear
overlaps it and every pixel of it is valid (the optional valid-pixel mask: False on sky and
land).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass

import cv2
import numpy as np

from ...util.colour import LUMA_601
from ...util.tiles import grid_patches

PATCH = 64  #: patch side, pixels
BLUR = 9  #: box-blur side of the high-pass filter, pixels
GLINT_LEVEL = 230.0  #: luminance at or above which a pixel counts as glint (8-bit levels)
LUMA = LUMA_601  #: Rec. 601 luma weights of R, G, B (float32)
METRICS = ("saturation", "luminance", "highpass_std", "glint_fraction")
PERCENTILES = (10, 50, 90)


@dataclass(frozen=True)
class Maps:
    """Per-pixel maps of one image, each (H, W) float32: ``y`` luminance 0..255, ``hp``
    high-pass of ``y`` (8-bit levels, signed), ``s`` HSV saturation 0..1."""

    y: np.ndarray
    hp: np.ndarray
    s: np.ndarray


def check_rgb(rgb: np.ndarray) -> np.ndarray:
    """``rgb`` as a C-contiguous (H, W, 3) uint8 array; ValueError for anything else."""
    a = np.asarray(rgb)
    if a.ndim != 3 or a.shape[2] != 3 or a.dtype != np.uint8:
        raise ValueError(f"expected an (H, W, 3) uint8 RGB image, got {a.shape} {a.dtype}")
    return np.ascontiguousarray(a)


def luminance(rgb: np.ndarray) -> np.ndarray:
    """(H, W) float32 luminance Y = 0.299 R + 0.587 G + 0.114 B, 0..255, of (H, W, 3) uint8."""
    a = check_rgb(rgb).astype(np.float32)
    return a[..., 0] * LUMA[0] + a[..., 1] * LUMA[1] + a[..., 2] * LUMA[2]


def highpass(y: np.ndarray) -> np.ndarray:
    """(H, W) float32 ``y - box_blur_9x9(y)`` (reflect-101 borders) of a (H, W) float32 map."""
    y = np.ascontiguousarray(y, np.float32)
    return y - cv2.blur(y, (BLUR, BLUR), borderType=cv2.BORDER_REFLECT_101)


def saturation(rgb: np.ndarray) -> np.ndarray:
    """(H, W) float32 HSV saturation (max - min) / max of (H, W, 3) uint8 RGB; 0 where max = 0."""
    a = check_rgb(rgb)
    mx = a.max(axis=2).astype(np.float32)
    mn = a.min(axis=2).astype(np.float32)
    return np.divide(mx - mn, mx, out=np.zeros_like(mx), where=mx > 0)


def image_maps(rgb: np.ndarray) -> Maps:
    """The :class:`Maps` (Y, high-pass, S) of an (H, W, 3) uint8 RGB image."""
    y = luminance(rgb)
    return Maps(y, highpass(y), saturation(rgb))


# --------------------------------------------------------------------------- the patch grid

def grid_shape(height: int, width: int, size: int = PATCH) -> tuple[int, int]:
    """(rows, cols) of whole ``size`` x ``size`` patches in a height x width image."""
    return height // size, width // size


def patch_origins(height: int, width: int, size: int = PATCH) -> np.ndarray:
    """(n, 2) int64 (x, y) top-left pixel of each patch, row-major (as :func:`to_patches`)."""
    rows, cols = grid_shape(height, width, size)
    yy, xx = np.mgrid[0:rows, 0:cols]
    return np.stack([xx.ravel() * size, yy.ravel() * size], axis=1).astype(np.int64)


def to_patches(a: np.ndarray, size: int = PATCH) -> np.ndarray:
    """(n, size, size, ...) copy of the grid patches of an (H, W, ...) array, row-major.

    n = (H // size) * (W // size); trailing axes (e.g. colour) are kept
    (:func:`sdcomp.util.tiles.grid_patches`)."""
    return grid_patches(a, size)


def _patch_any(mask: np.ndarray, size: int) -> np.ndarray:
    """(n,) bool: whether any pixel of each grid patch of an (H, W) bool mask is True."""
    return np.asarray(to_patches(np.asarray(mask, bool), size).reshape(-1, size * size)
                      .any(axis=1))


def boxes_mask(shape: tuple[int, int], boxes: Iterable[Sequence[float]]) -> np.ndarray:
    """(H, W) bool: the pixels that boxes (x, y, w, h) (pixels, COCO convention) touch.

    A box covers columns floor(x) .. ceil(x + w) - 1 (at least one column) and likewise rows,
    clipped to the image; a box wholly outside the image marks nothing."""
    h, w = shape
    out = np.zeros((h, w), bool)
    for box in boxes:
        bx, by, bw, bh = (float(v) for v in box[:4])
        if not all(math.isfinite(v) for v in (bx, by, bw, bh)):
            continue
        x0, y0 = math.floor(bx), math.floor(by)
        x1, y1 = max(math.ceil(bx + bw), x0 + 1), max(math.ceil(by + bh), y0 + 1)
        x0, y0, x1, y1 = max(x0, 0), max(y0, 0), min(x1, w), min(y1, h)
        if x1 > x0 and y1 > y0:
            out[y0:y1, x0:x1] = True
    return out


def empty_water(shape: tuple[int, int], instances: np.ndarray | None = None,
                boxes: Iterable[Sequence[float]] | None = None,
                valid: np.ndarray | None = None, size: int = PATCH) -> np.ndarray:
    """(n,) bool over the grid patches (row-major): True for "empty water" patches.

    Args:
        shape: (H, W) of the image.
        instances: optional (H, W) integer instance map; a patch with any non-zero pixel is
            rejected.
        boxes: optional (x, y, w, h) pixel boxes to keep clear; a patch any box overlaps
            (see :func:`boxes_mask`) is rejected.
        valid: optional (H, W) bool, False on sky / land / unknown pixels; a patch with any
            invalid pixel is rejected. None accepts every pixel.
    """
    h, w = shape
    rows, cols = grid_shape(h, w, size)
    keep = np.ones(rows * cols, bool)
    if instances is not None:
        if np.shape(instances) != (h, w):
            raise ValueError(f"instance mask {np.shape(instances)} does not match image {shape}")
        keep &= ~_patch_any(np.asarray(instances) != 0, size)
    if boxes is not None:
        boxes = list(boxes)
        if boxes:
            keep &= ~_patch_any(boxes_mask((h, w), boxes), size)
    if valid is not None:
        if np.shape(valid) != (h, w):
            raise ValueError(f"valid mask {np.shape(valid)} does not match image {shape}")
        keep &= ~_patch_any(~np.asarray(valid, bool), size)
    return keep


# --------------------------------------------------------------------------- statistics

def maps_patch_stats(maps: Maps, keep: np.ndarray | None = None, size: int = PATCH
                     ) -> dict[str, np.ndarray]:
    """Per-patch statistics of an image's :class:`Maps`.

    Returns {metric: (m,) float64} for the metrics of :data:`METRICS`, over the patches where
    ``keep`` ((n,) bool, row-major; None = all) is True."""
    y, hp, s = (to_patches(a, size).reshape(-1, size * size) for a in (maps.y, maps.hp, maps.s))
    if keep is not None:
        keep = np.asarray(keep, bool)
        if keep.shape != (y.shape[0],):
            raise ValueError(f"keep has shape {keep.shape}, the grid has {y.shape[0]} patches")
        y, hp, s = y[keep], hp[keep], s[keep]
    return {
        "saturation": s.mean(axis=1, dtype=np.float64),
        "luminance": y.mean(axis=1, dtype=np.float64),
        "highpass_std": hp.std(axis=1, dtype=np.float64),
        "glint_fraction": (y >= GLINT_LEVEL).mean(axis=1, dtype=np.float64),
    }


def patch_stats(rgb: np.ndarray, keep: np.ndarray | None = None, size: int = PATCH
                ) -> dict[str, np.ndarray]:
    """Per-patch statistics ({metric: (m,) float64}) of an (H, W, 3) uint8 RGB image over the
    grid patches selected by ``keep`` ((n,) bool or None for all); see the module docstring."""
    return maps_patch_stats(image_maps(rgb), keep, size)


def concat_stats(parts: Iterable[Mapping[str, np.ndarray]]) -> dict[str, np.ndarray]:
    """Concatenate per-image statistics dicts into one {metric: (total,) float64}."""
    parts = list(parts)
    return {m: (np.concatenate([np.asarray(p[m], np.float64) for p in parts]) if parts
                else np.zeros(0)) for m in METRICS}


def summarise(stats: Mapping[str, np.ndarray]) -> dict[str, dict[str, float]]:
    """{metric: {"n", "median", "p10", "p50", "p90", "mean"}} of per-patch statistics.

    Percentiles are numpy's linear-interpolation ones; NaN (and n = 0) for an empty set."""
    out = {}
    for m in METRICS:
        v = np.asarray(stats.get(m, np.zeros(0)), np.float64)
        if v.size:
            p10, p50, p90 = np.percentile(v, PERCENTILES)
            row = {"n": int(v.size), "median": float(p50), "p10": float(p10),
                   "p50": float(p50), "p90": float(p90), "mean": float(v.mean())}
        else:
            nan = float("nan")
            row = {"n": 0, "median": nan, "p10": nan, "p50": nan, "p90": nan, "mean": nan}
        out[m] = row
    return out
