"""Images, instance maps and masks through the lens geometry (:mod:`~.lens`), and its
vignetting.

A lens that carries cached full-frame maps (one asked for before, :func:`~.lens.lens_maps`)
uses them; the others build their maps band by band from the lens's grid
(:meth:`~.lens.LensGrid.window`): a band of :data:`BAND_PIXELS` stays in the processor's
cache, the full maps of a 20 MP frame (280 MB) would not, and full maps made for one image
cost more memory traffic than they save. Both give the same pixels (the same fixed-point
maps, :meth:`~.lens.LensGrid.source`).
"""

from __future__ import annotations

import math
from collections.abc import Iterator

import cv2
import numpy as np

from .lens import LensMaps, falloff, falloff_index, vignette_table

LABEL_GAP = 16  # rows: label rows closer than this are remapped as one window
LABEL_RUNS_MAX = 8  # more runs of label rows than this: one full-frame label remap
BAND_PIXELS = 1 << 17  # streamed remaps work on bands of rows of about this many pixels


def _bands(h: int, w: int, y0: int = 0) -> Iterator[tuple[int, int]]:
    """Row ranges [a, b) covering rows ``y0`` .. ``h`` in bands of about
    :data:`BAND_PIXELS` pixels of width ``w``."""
    rows = max(8, BAND_PIXELS // max(w, 1))
    for a in range(y0, h, rows):
        yield a, min(a + rows, h)


def remap_image(image: np.ndarray, lens: LensMaps) -> np.ndarray:
    """(H, W, 3) uint8 image through the lens geometry (bilinear, one resampling per
    channel: a 3-channel remap, or 3 single-channel remaps with lateral CA)."""
    if lens.maps is not None:
        if len(lens.maps) == 1:
            m1, m2 = lens.maps[0]
            return cv2.remap(image, m1, m2, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
        planes = cv2.split(image)
        out = [cv2.remap(p, m1, m2, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
               for p, (m1, m2) in zip(planes, lens.maps, strict=True)]
        return cv2.merge(out)
    grid = lens.grid
    h, w = image.shape[:2]
    res = np.empty_like(image)
    planes = cv2.split(image) if len(grid.src) > 1 else [image]
    for a, b in _bands(h, w):
        done = [cv2.remap(p, *grid.source(c, 0, a, w, b), cv2.INTER_LINEAR,
                          borderMode=cv2.BORDER_REPLICATE) for c, p in enumerate(planes)]
        res[a:b] = done[0] if len(done) == 1 else cv2.merge(done)
    return res


def _nearest(labels: np.ndarray, lens: LensMaps, x0: int, y0: int, x1: int, y1: int
             ) -> np.ndarray:
    """Output window [y0:y1, x0:x1] of ``labels`` remapped by nearest neighbour with the
    green geometry."""
    if lens.nearest is not None:
        return cv2.remap(labels, lens.nearest[y0:y1, x0:x1],  # type: ignore[call-overload, unused-ignore]
                         None, cv2.INTER_NEAREST, borderMode=cv2.BORDER_REPLICATE)
    out = np.empty((y1 - y0, x1 - x0) + labels.shape[2:], labels.dtype)
    for a, b in _bands(y1, x1 - x0, y0):
        out[a - y0:b - y0] = cv2.remap(  # type: ignore[call-overload, unused-ignore]
            labels, lens.grid.nearest(x0, a, x1, b), None, cv2.INTER_NEAREST,
            borderMode=cv2.BORDER_REPLICATE).reshape((b - a, x1 - x0) + labels.shape[2:])
    return out


def remap_labels(labels: np.ndarray, lens: LensMaps, window: bool = True) -> np.ndarray:
    """(H, W) or (H, W, C) uint8/uint16 label image through the lens geometry by nearest
    neighbour (the green channel's geometry; lateral CA is sub-pixel and ignored): every
    output pixel takes the label of the rendered pixel nearest to its source point, so ids
    are never mixed.

    With ``window`` only the output rectangles that can see labels are remapped: the rows
    holding labels are grouped into runs (gaps of more than :data:`LABEL_GAP` rows split
    them), each run's bounding box is carried to the output with
    :meth:`~.lens.LensMaps.forward` on its border (2 px margin) and remapped alone. The
    result is the same (rectangles that overlap compute the same pixels); sparse labels, the
    usual case, cost a fraction."""
    h, w = labels.shape[:2]
    if not window:
        return _nearest(labels, lens, 0, 0, w, h).reshape(labels.shape)
    flat: np.ndarray = labels if labels.ndim == 2 else np.any(labels, axis=2)
    rows = np.flatnonzero(flat.any(axis=1))
    out = np.zeros_like(labels)
    if rows.size == 0:
        return out
    breaks = np.flatnonzero(np.diff(rows) > LABEL_GAP)
    starts = np.concatenate([[rows[0]], rows[breaks + 1]])
    ends = np.concatenate([rows[breaks], [rows[-1]]])
    if len(starts) > LABEL_RUNS_MAX:
        return remap_labels(labels, lens, window=False)
    cx, cy = (w - 1) / 2, (h - 1) / 2
    for r0, r1 in zip(starts.tolist(), ends.tolist(), strict=True):
        cols = np.flatnonzero(flat[r0:r1 + 1].any(axis=0))
        x0, x1, y0, y1 = cols[0] - 1.0, cols[-1] + 1.0, r0 - 1.0, r1 + 1.0
        # a radial model moves an edge's points monotonically with their distance from the
        # centre: its extremes are the corners and the edge's point nearest the centre
        nx, ny = min(max(cx, x0), x1), min(max(cy, y0), y1)
        p = lens.forward(np.array([[x0, y0], [x1, y0], [x0, y1], [x1, y1],
                                   [nx, y0], [nx, y1], [x0, ny], [x1, ny]]))
        ox0, oy0 = int(p[:, 0].min()) - 2, int(p[:, 1].min()) - 2
        ox1, oy1 = int(p[:, 0].max()) + 3, int(p[:, 1].max()) + 3
        ox0, oy0, ox1, oy1 = max(ox0, 0), max(oy0, 0), min(ox1, w), min(oy1, h)
        if ox1 <= ox0 or oy1 <= oy0:
            continue
        win = out[oy0:oy1, ox0:ox1]
        win[...] = _nearest(labels, lens, ox0, oy0, ox1, oy1).reshape(win.shape)
    return out


def remap_masks(masks: np.ndarray, lens: LensMaps) -> np.ndarray:
    """(N, H, W) bool masks through :func:`remap_labels`, 16 per uint16 bit plane and up to
    4 planes per remap call (bits survive nearest-neighbour remapping exactly)."""
    n, h, w = masks.shape
    out = np.zeros_like(masks, dtype=bool)
    for start in range(0, n, 64):
        group = masks[start:start + 64]
        planes = math.ceil(len(group) / 16)
        packed = np.zeros((h, w, planes), np.uint16)
        for k, m in enumerate(group):
            packed[..., k // 16] |= m.astype(np.uint16) << np.uint16(k % 16)
        if planes == 3:  # OpenCV remaps 1, 2, 3 or 4 channels; keep to 1, 2 or 4
            packed = np.concatenate([packed, np.zeros((h, w, 1), np.uint16)], axis=2)
        moved = remap_labels(packed, lens).reshape(h, w, -1)
        for k in range(len(group)):
            out[start + k] = (moved[..., k // 16] >> np.uint16(k % 16)) & 1
    return out


def vignette(image: np.ndarray, lens: LensMaps, strength: float) -> np.ndarray:
    """(H, W, 3) uint8 image darkened by the lens's vignetting of ``strength``: times the
    uint8 gain of :func:`~.lens.vignette_table` at each pixel's quantised fall-off, / 255
    (rounded); streamed lenses band by band. Returns a new image."""
    table = vignette_table(strength)
    if lens.field_r2 is not None:
        return cv2.multiply(image, cv2.LUT(falloff_index(lens), table), scale=1 / 255.0)
    h, w = image.shape[:2]
    res = np.empty_like(image)
    for a, b in _bands(h, w):
        gain = cv2.LUT(falloff(lens.grid.window(lens.grid.r2, 0, a, w, b)), table)
        res[a:b] = cv2.multiply(image[a:b], gain, scale=1 / 255.0)
    return res
