"""Per-object appearance statistics: how a labelled box looks against the water around it
(``sdcomp realism --objects``). Pure functions on NumPy arrays; definitions (docs/realism.md):

For an (H, W, 3) uint8 sRGB image, the grey level is the report's luminance
``Y = 0.299 R + 0.587 G + 0.114 B`` (float, 0..255: OpenCV's ``BGR2GRAY`` weights without its
rounding to integers; :func:`.patches.luminance`) and the saturation HSV's
``(max - min) / max`` (0..1; :func:`.patches.saturation`). A box (x, y, w, h) (pixels, COCO)
covers columns floor(x) .. ceil(x + w) - 1 and likewise rows (as :func:`.patches.boxes_mask`,
edges within :data:`EDGE_EPS` of a whole pixel taken as whole: YOLO's rounded fractions).
Only boxes with ``sqrt(w h) >= min_size`` image pixels are measured. Its **surrounding
water** is the box grown by its longer side ``max(w, h)`` on every side (clipped to the
frame), minus every labelled box of the image (the box itself and its neighbours). Per box:

- ``contrast``: (box mean Y - surrounding mean Y) / surrounding std of Y (population std);
- ``dark_share``: share of box pixels with Y <= surrounding mean - 25;
- ``bright_share``: share of box pixels with Y >= surrounding mean + 40;
- ``aspect``: h / w;
- ``saturation``: mean saturation of the box pixels;
- ``size_px``: sqrt(w h) * 1920 / W (the size on a frame 1920 px wide);
- ``size_m``: sqrt(w h) * the GSD at the box centre (metres), NaN where unknown;
- ``size_image_px``: sqrt(w h) in the image's own pixels (not rescaled: the size to compare
  where the frames are crops at one focal length, e.g. 416 px renders at the focal length of
  1920 px real frames, for which ``size_px`` would be 1920 / 416 times too large);
- ``skin_share``: share of box pixels that are skin-like (:func:`skin_mask`: faces, hands,
  bare arms and legs);
- ``vivid_share``: share of box pixels of a saturated orange, red or pink (:func:`vivid_mask`:
  life jackets, tubes, boards, canopies).

The first three are NaN when fewer than :data:`MIN_SURROUND` surrounding pixels remain, and
the contrast also when their std is 0. The GSD at a pixel (:func:`sea_gsd`) is the depth,
along the optical axis, of the sea point the pixel sees, over the focal length in pixels:
the metres per pixel of an object facing the camera there (at the image centre: the slant
distance over fx, the frame's ``gsd(m/px)``).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import cv2
import numpy as np

from ...render.camera.lens import undistort
from .patches import luminance, saturation

#: the per-box statistics, in the column order of :func:`box_statistics`
STATS = ("contrast", "dark_share", "bright_share", "aspect", "saturation", "size_px",
         "size_m", "size_image_px", "skin_share", "vivid_share")
UNITS = {"contrast": "surrounding std", "dark_share": "0..1", "bright_share": "0..1",
         "aspect": "h / w", "saturation": "0..1", "size_px": "px at 1920 wide",
         "size_m": "m", "size_image_px": "image px", "skin_share": "0..1",
         "vivid_share": "0..1"}
#: the statistics that are shares of a box's pixels: their summaries also say in how many
#: boxes the share is above zero (e.g. "skin-like pixels in 67 % of the boxes")
SHARES = ("dark_share", "bright_share", "skin_share", "vivid_share")
MIN_SIZE = 15.0  #: smallest sqrt(w h) measured, image pixels
DARK_LEVELS = 25.0  #: a box pixel this many grey levels below the surrounding mean is dark
BRIGHT_LEVELS = 40.0  #: ... this many above it is bright
REFERENCE_WIDTH = 1920  #: size_px is sqrt(w h) on a frame this many pixels wide
MIN_SURROUND = 16  #: fewest surrounding-water pixels for contrast and the shares
PERCENTILES = (10, 50, 90)
EDGE_EPS = 1e-3  #: a box edge this close to a whole pixel is on it (pixels)


def skin_mask(rgb: np.ndarray) -> np.ndarray:
    """(...,) bool: skin-like pixels of (..., 3) uint8 RGB: YCrCb Cr in [135, 175], Cb in
    [85, 130] and Y >= 60 (faces, hands and necks in daylight, lit or shaded; dry sand and
    some orange fabric pass too)."""
    ycc = cv2.cvtColor(np.ascontiguousarray(rgb.reshape(-1, 1, 3)), cv2.COLOR_RGB2YCrCb)
    ycc = ycc.reshape(rgb.shape)
    yy, cr, cb = ycc[..., 0], ycc[..., 1], ycc[..., 2]
    return (cr >= 135) & (cr <= 175) & (cb >= 85) & (cb <= 130) & (yy >= 60)


def vivid_mask(rgb: np.ndarray) -> np.ndarray:
    """(...,) bool: vivid orange, red and pink pixels of (..., 3) uint8 RGB (life jackets,
    tubes, canopies): HSV hue at most 34 degrees (red to orange) or at least 320 (pink to
    red; OpenCV's hue <= 17 or >= 160), saturation >= 0.5, value >= 0.35."""
    hsv = cv2.cvtColor(np.ascontiguousarray(rgb.reshape(-1, 1, 3)), cv2.COLOR_RGB2HSV)
    hsv = hsv.reshape(rgb.shape)
    hue, s, v = hsv[..., 0], hsv[..., 1], hsv[..., 2]
    return ((hue <= 17) | (hue >= 160)) & (s >= 128) & (v >= 90)


def box_slices(box: Sequence[float], shape: tuple[int, int], grow: float = 0.0
               ) -> tuple[slice, slice] | None:
    """(rows, cols) slices of the pixels box (x, y, w, h) covers (floor(x) .. ceil(x + w) - 1,
    at least one pixel, edges within :data:`EDGE_EPS` of a whole pixel rounded to it) after
    growing it by ``grow`` pixels on every side, clipped to an image of ``shape`` (H, W);
    None when nothing is left."""
    bx, by, bw, bh = (float(v) for v in box[:4])
    if not all(math.isfinite(v) for v in (bx, by, bw, bh, grow)):
        return None
    x0, y0 = math.floor(bx - grow + EDGE_EPS), math.floor(by - grow + EDGE_EPS)
    x1 = max(math.ceil(bx + bw + grow - EDGE_EPS), x0 + 1)
    y1 = max(math.ceil(by + bh + grow - EDGE_EPS), y0 + 1)
    h, w = shape
    x0, y0, x1, y1 = max(x0, 0), max(y0, 0), min(x1, w), min(y1, h)
    if x1 <= x0 or y1 <= y0:
        return None
    return slice(y0, y1), slice(x0, x1)


def labelled_mask(shape: tuple[int, int], boxes: np.ndarray) -> np.ndarray:
    """(H, W) bool: the pixels any of the (k, 4) boxes covers (:func:`box_slices`)."""
    out = np.zeros(shape, bool)
    for box in boxes:
        sl = box_slices(box, shape)
        if sl is not None:
            out[sl] = True
    return out


def box_statistics(rgb: np.ndarray, boxes: np.ndarray | Sequence[Sequence[float]],
                   gsd: np.ndarray | float | None = None, min_size: float = MIN_SIZE,
                   exclude_others: bool = True, valid: np.ndarray | None = None
                   ) -> np.ndarray:
    """The statistics of :data:`STATS` of each box of one image.

    Args:
        rgb: (H, W, 3) uint8 sRGB image.
        boxes: (k, 4) x, y, w, h pixels (COCO); every one counts as labelled (kept out of
            every box's surrounding water).
        gsd: metres per pixel at each box centre, (k,) float or one float for all; None or
            NaN: unknown (``size_m`` NaN).
        min_size: boxes with sqrt(w h) below this many pixels are not measured.
        exclude_others: False: the other boxes in a box's window count as its water (only
            the box itself is left out); True (the definition): they do not.
        valid: (H, W) bool, False on pixels that are not the scene (a real frame's
            painted-out regions): never surrounding water. None: all are.
    Returns:
        (k, len(STATS)) float64, a row per box in the order of ``boxes``; a box not measured
        (too small, not finite or outside the image) has a row of NaN.
    """
    b = np.asarray(boxes, np.float64).reshape(-1, 4)
    k = len(b)
    out = np.full((k, len(STATS)), np.nan)
    if k == 0:
        return out
    h, w = rgb.shape[:2]
    g = np.broadcast_to(np.asarray(np.nan if gsd is None else gsd, np.float64), (k,))
    y = luminance(rgb)
    s = saturation(rgb)
    skin, vivid = skin_mask(rgb), vivid_mask(rgb)
    labelled = labelled_mask((h, w), b)
    invalid = None if valid is None else ~np.asarray(valid, bool)
    for i, (bw, bh) in enumerate(b[:, 2:]):
        size = math.sqrt(bw * bh) if bw > 0 and bh > 0 else float("nan")
        inner = box_slices(b[i], (h, w)) if math.isfinite(size) and size >= min_size else None
        if inner is None:
            continue
        yb = y[inner].astype(np.float64)
        out[i, 3] = bh / bw
        out[i, 4] = float(s[inner].mean(dtype=np.float64))
        out[i, 5] = size * REFERENCE_WIDTH / w
        out[i, 6] = size * g[i] if math.isfinite(g[i]) and g[i] > 0 else np.nan
        out[i, 7] = size
        out[i, 8] = float(skin[inner].mean())
        out[i, 9] = float(vivid[inner].mean())
        window = box_slices(b[i], (h, w), grow=max(bw, bh))
        assert window is not None  # it holds the box
        if exclude_others:
            out_of_water = labelled[window]
        else:
            own = np.zeros(labelled.shape, bool)
            own[inner] = True
            out_of_water = own[window]
        if invalid is not None:
            out_of_water = out_of_water | invalid[window]
        water = y[window][~out_of_water].astype(np.float64)
        if water.size < MIN_SURROUND:
            continue
        mean, std = float(water.mean()), float(water.std())
        out[i, 0] = (float(yb.mean()) - mean) / std if std > 0 else np.nan
        out[i, 1] = float(np.mean(yb <= mean - DARK_LEVELS))
        out[i, 2] = float(np.mean(yb >= mean + BRIGHT_LEVELS))
    return out


def sea_gsd(k: np.ndarray, r_w2c: np.ndarray, t_w2c: np.ndarray, u: np.ndarray,
            v: np.ndarray, dist: Sequence[float] = (0.0, 0.0)) -> np.ndarray:
    """Metres per pixel at pixels (u, v) of a camera over the sea z = 0.

    Args:
        k: (3, 3) intrinsics, OpenCV's convention (pixel (0, 0)'s centre at (0, 0)).
        r_w2c: (3, 3) rotation, rows the camera's right, down, forward in world axes (z up).
        t_w2c: (3,) metres, x_cam = r_w2c @ x_world + t_w2c.
        u, v: pixel coordinates (same shape), COCO's (pixel (0, 0)'s centre at (0.5, 0.5)).
        dist: radial distortion (k1, k2) of the recorded image (undone before the ray).
    Returns:
        float64 of ``u``'s shape: depth of the sea point along the optical axis over fx; NaN
        where the ray does not meet the sea in front of the camera.
    """
    k = np.asarray(k, np.float64)
    r = np.asarray(r_w2c, np.float64)
    t = np.asarray(t_w2c, np.float64)
    u, v = np.asarray(u, np.float64), np.asarray(v, np.float64)
    xd = np.stack([(u - 0.5 - k[0, 2]) / k[0, 0], (v - 0.5 - k[1, 2]) / k[1, 1]], axis=-1)
    k1, k2 = (float(c) for c in (list(dist) + [0.0, 0.0])[:2])
    xu = undistort(xd, k1, k2) if (k1 or k2) else xd
    centre = -r.T @ t  # the camera in world coordinates
    # world z of the ray x_cam = (xu, yu, 1): the depth along the axis is its parameter
    dz = xu[..., 0] * r[0, 2] + xu[..., 1] * r[1, 2] + r[2, 2]
    depth = np.where(dz < -1e-12, centre[2] / np.where(dz < -1e-12, -dz, 1.0), np.nan)
    return np.where(depth > 0, depth / k[0, 0], np.nan)


def record_gsd(camera: Mapping, boxes: np.ndarray) -> np.ndarray | None:
    """(k,) float64 metres per pixel at the centres of (k, 4) boxes (x, y, w, h) from a
    COCO ``camera`` record (``K``, ``R_w2c``, ``t_w2c``, optional ``dist_coeffs``; see
    :func:`sea_gsd`); None when the record lacks them or they are not finite."""
    try:
        kk = np.asarray(camera["K"], np.float64)
        r = np.asarray(camera["R_w2c"], np.float64)
        t = np.asarray(camera["t_w2c"], np.float64)
        dist = [float(c) for c in (camera.get("dist_coeffs") or [0.0, 0.0])[:2]]
    except (KeyError, TypeError, ValueError):
        return None
    if kk.shape != (3, 3) or r.shape != (3, 3) or t.shape != (3,) or not (
            np.isfinite(kk).all() and np.isfinite(r).all() and np.isfinite(t).all()) or (
            kk[0, 0] <= 0 or kk[1, 1] <= 0):
        return None
    b = np.asarray(boxes, np.float64).reshape(-1, 4)
    return sea_gsd(kk, r, t, b[:, 0] + b[:, 2] / 2, b[:, 1] + b[:, 3] / 2, dist)


def summarise(values: np.ndarray, categories: Sequence[str]) -> dict[str, dict]:
    """Per-category summary of measured boxes.

    Args:
        values: (n, len(STATS)) float64 rows of :func:`box_statistics` (NaN rows, boxes not
            measured, are left out).
        categories: (n,) the category name of each row.
    Returns:
        {category: {"count": boxes measured, stat: {"median", "p10", "p90", "n"}}} per
        statistic of :data:`STATS`, over its finite values (n of them; NaN when none),
        categories sorted by name; the :data:`SHARES` also ``"nonzero"``, the fraction of
        those boxes whose share is above zero. Percentiles: NumPy's linear interpolation.
    """
    v = np.asarray(values, np.float64).reshape(-1, len(STATS))
    cats = np.asarray(list(categories), dtype=object)
    if len(cats) != len(v):
        raise ValueError(f"{len(cats)} categories for {len(v)} rows")
    measured = ~np.isnan(v).all(axis=1)
    out: dict[str, dict] = {}
    for name in sorted({str(c) for c in cats[measured]}):
        rows = v[measured & (cats == name)]
        entry: dict = {"count": int(len(rows))}
        for j, stat in enumerate(STATS):
            col = rows[:, j][np.isfinite(rows[:, j])]
            if col.size:
                p10, p50, p90 = (float(x) for x in np.percentile(col, PERCENTILES))
            else:
                p10 = p50 = p90 = float("nan")
            entry[stat] = {"median": p50, "p10": p10, "p90": p90, "n": int(col.size)}
            if stat in SHARES:
                entry[stat]["nonzero"] = float(np.mean(col > 0)) if col.size else float("nan")
        out[name] = entry
    return out
