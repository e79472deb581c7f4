"""COCO run-length encoding of masks (pycocotools' compressed RLE, string counts)."""

from __future__ import annotations

import numpy as np
from pycocotools import mask as mask_utils


def _mask2d(mask: np.ndarray) -> np.ndarray:
    mask = np.asarray(mask)
    if mask.ndim != 2:
        raise ValueError(f"mask must be 2-D (H, W), got shape {mask.shape}")
    return mask if mask.dtype == bool else mask != 0


def mask_to_rle(mask: np.ndarray) -> dict:
    """COCO compressed RLE of an (H, W) boolean mask: ``{"size": [H, W], "counts": str}``.

    ``counts`` is the pycocotools string (ASCII) so that ``json`` can write it; pycocotools
    reads it back as it is. A non-bool mask counts its non-zero pixels.
    """
    mask = _mask2d(mask)
    rle = mask_utils.encode(np.asfortranarray(mask, dtype=np.uint8))
    return {"size": [int(rle["size"][0]), int(rle["size"][1])],
            "counts": rle["counts"].decode("ascii")}


def crop_to_rle(crop: np.ndarray, x0: int, y0: int, height: int, width: int) -> dict:
    """COCO compressed RLE of a (height, width) mask that is zero outside ``crop`` (h, w)
    bool placed with its top-left pixel at (x0, y0): equal to :func:`mask_to_rle` of the
    full mask, without building it (runs are found in the crop's columns only)."""
    crop = _mask2d(crop)
    h, w = crop.shape
    if x0 < 0 or y0 < 0 or x0 + w > width or y0 + h > height:
        raise ValueError("the crop must lie inside the mask")
    # column-major: pixel (y, x) is at x * height + y; find where runs start and stop
    col = np.zeros((w, h + 2), np.int8)
    col[:, 1:-1] = crop.T
    change = np.diff(col, axis=1)  # +1 where a run starts, -1 after it ends
    xs, ys = np.nonzero(change)
    edges = (xs + x0) * height + (ys + y0)  # already in ascending order
    if h == height:  # a run through the bottom of one column into the next is one run
        edges, n = np.unique(edges, return_counts=True)
        edges = edges[n % 2 == 1]
    end = [] if len(edges) and edges[-1] == height * width else [height * width]
    bounds = np.concatenate([[0], edges, end])
    counts = np.diff(bounds).astype(np.uint32)
    rle = mask_utils.frPyObjects({"counts": counts.tolist(), "size": [height, width]},
                                 height, width)
    return {"size": [height, width], "counts": rle["counts"].decode("ascii")}


def rle_to_mask(rle: dict) -> np.ndarray:
    """(H, W) bool of a COCO compressed RLE ``{"size": [H, W], "counts": str}`` (as
    :func:`mask_to_rle` writes it)."""
    counts = rle["counts"]
    data = {"size": list(rle["size"]),
            "counts": counts.encode("ascii") if isinstance(counts, str) else counts}
    return mask_utils.decode(data).astype(bool)
