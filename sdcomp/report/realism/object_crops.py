"""Object crops at one pixel scale, and what tells a real object's crop from a generated one.

A **crop** of a labelled box (x, y, w, h) is the square window of side :data:`CONTEXT` times
the box's longer side, centred on the box (the box and the water around it), resampled to
``out_px`` x ``out_px`` pixels (:data:`CROP_PX`; INTER_AREA when shrinking, bilinear when
enlarging), so that every object, real or generated, spans the same number of pixels: its
longer side ``out_px / CONTEXT``. A window that leaves the frame is shifted back inside it
where the frame is large enough, else the frame is mirrored (``BORDER_REFLECT_101``) to fill
it. Only **whole** boxes are cropped: a box within :data:`EDGE_PX` of the frame's edge (an
object cut by the frame, or by the tile a real frame was cut from) is left out, and so is a
box below ``min_size`` pixels (sqrt(w h)).

:func:`object_features` are the hand features of a crop for the logistic regression: the 45
patch features of the whole crop (:func:`.classifier.patch_features`) and 25 of the box
against the ring of water around it (colour and texture inside and outside, contrast, dark,
bright, skin-like, vivid orange-red and white shares, elongation).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import cv2
import numpy as np

from .classifier import feature_names, patch_features
from .objects import BRIGHT_LEVELS, DARK_LEVELS, MIN_SIZE, skin_mask, vivid_mask
from .patches import LUMA
from .sources import FrameSet, frame_rgb

CROP_PX = 64  #: side of a classifier crop, pixels
CONTEXT = 2.0  #: the crop window's side over the box's longer side
EDGE_PX = 1.0  #: a box this close to the frame's edge (pixels) is cut by it: not cropped

OBJECT_FEATURES = (
    "in_L_mean", "in_a_mean", "in_b_mean", "in_L_std", "in_a_std", "in_b_std",
    "ring_L_mean", "ring_a_mean", "ring_b_mean", "ring_L_std", "ring_a_std", "ring_b_std",
    "contrast", "dark_share", "bright_share", "in_sat_mean", "in_sat_p90", "skin_share",
    "vivid_share", "white_share", "in_hp_std", "ring_hp_std", "in_grad_mean",
    "ring_grad_mean", "elongation")


def object_feature_names() -> list[str]:
    """The names of the columns of :func:`object_features`, in order."""
    return [f"crop_{n}" for n in feature_names()] + list(OBJECT_FEATURES)


@dataclass
class ObjectCrops:
    """The crops of a set's boxes, one row each.

    Attributes:
        crops: (n, s, s, 3) uint8 RGB crops (:func:`box_crop`).
        masks: (n, s, s) bool, True on the box's pixels in the crop.
        categories: (n,) category names.
        groups: (n,) int64 the frame each crop comes from (its index in the set).
        boxes: (n, 4) float64 the boxes, x, y, w, h pixels of their frames.
        left_out: {why: count} of boxes not cropped ("cut by the frame's edge", "too small").
    """

    crops: np.ndarray
    masks: np.ndarray
    categories: list
    groups: np.ndarray
    boxes: np.ndarray
    left_out: dict = field(default_factory=dict)

    def of(self, category: str) -> np.ndarray:
        """(m,) int64 rows of ``category``."""
        return np.flatnonzero(np.asarray(self.categories, dtype=object) == category)


def is_whole(box, width: int, height: int, edge: float = EDGE_PX) -> bool:
    """Whether box (x, y, w, h) lies inside a ``width`` x ``height`` frame at least ``edge``
    pixels from each edge (not cut by it)."""
    x, y, w, h = (float(v) for v in box[:4])
    return (x >= edge and y >= edge and x + w <= width - edge and y + h <= height - edge)


def box_crop(rgb: np.ndarray, box, out_px: int = CROP_PX, context: float = CONTEXT
             ) -> tuple[np.ndarray, np.ndarray]:
    """((out_px, out_px, 3) uint8 crop, (out_px, out_px) bool box mask) of box (x, y, w, h)
    of an (H, W, 3) uint8 image: the window of side ``context * max(w, h)`` (at least 2
    pixels) centred on the box, shifted inside the frame where it fits, else mirrored at the
    frame's edges; resampled to ``out_px`` (INTER_AREA down, bilinear up)."""
    h_img, w_img = rgb.shape[:2]
    x, y, w, h = (float(v) for v in box[:4])
    side = max(2, int(round(context * max(w, h))))
    x0 = int(round(x + w / 2 - side / 2))
    y0 = int(round(y + h / 2 - side / 2))
    if side <= w_img:
        x0 = min(max(x0, 0), w_img - side)
    if side <= h_img:
        y0 = min(max(y0, 0), h_img - side)
    pl, pt = max(0, -x0), max(0, -y0)
    pr, pb = max(0, x0 + side - w_img), max(0, y0 + side - h_img)
    if pl or pt or pr or pb:
        src = cv2.copyMakeBorder(rgb[max(y0, 0):min(y0 + side, h_img),
                                     max(x0, 0):min(x0 + side, w_img)],
                                 pt, pb, pl, pr, cv2.BORDER_REFLECT_101)
    else:
        src = rgb[y0:y0 + side, x0:x0 + side]
    interp = cv2.INTER_AREA if side > out_px else cv2.INTER_LINEAR
    crop = cv2.resize(np.ascontiguousarray(src), (out_px, out_px), interpolation=interp)
    k = out_px / side
    mask = np.zeros((out_px, out_px), bool)
    c0, r0 = int(math.floor((x - x0) * k)), int(math.floor((y - y0) * k))
    c1, r1 = int(math.ceil((x + w - x0) * k)), int(math.ceil((y + h - y0) * k))
    mask[max(r0, 0):max(r1, r0 + 1), max(c0, 0):max(c1, c0 + 1)] = True
    return crop, mask


def collect_crops(frames: FrameSet, rows: list[tuple[int, np.ndarray, str]],
                  out_px: int = CROP_PX, context: float = CONTEXT,
                  min_size: float = MIN_SIZE, log=None) -> ObjectCrops:
    """The crops (:func:`box_crop`) of ``rows`` (frame index in ``frames``, box (4,) x, y,
    w, h, category), each frame read once; boxes cut by the frame's edge (:func:`is_whole`)
    or below ``min_size`` pixels are counted in ``left_out`` and not cropped, as are boxes of
    frames that cannot be read."""
    say = log or (lambda msg: None)
    by_frame: dict[int, list[tuple[np.ndarray, str]]] = {}
    for f, box, cat in rows:
        by_frame.setdefault(int(f), []).append((np.asarray(box, np.float64), str(cat)))
    crops, masks, cats, groups, boxes = [], [], [], [], []
    left: dict[str, int] = {}
    for n, (f, items) in enumerate(sorted(by_frame.items())):
        rgb = frame_rgb(frames.frames[f])
        if rgb is None:
            left["frame unreadable"] = left.get("frame unreadable", 0) + len(items)
            continue
        hh, ww = rgb.shape[:2]
        for box, cat in items:
            size = math.sqrt(max(box[2], 0) * max(box[3], 0))
            if not size >= min_size:
                left["too small"] = left.get("too small", 0) + 1
                continue
            if not is_whole(box, ww, hh):
                left["cut by the frame's edge"] = left.get("cut by the frame's edge", 0) + 1
                continue
            c, m = box_crop(rgb, box, out_px, context)
            crops.append(c)
            masks.append(m)
            cats.append(cat)
            groups.append(frames.frames[f].group)
            boxes.append(box)
        if (n + 1) % 100 == 0:
            say(f"{frames.kind}: crops of {n + 1}/{len(by_frame)} frames")
    if crops:
        return ObjectCrops(np.stack(crops), np.stack(masks), cats,
                           np.asarray(groups, np.int64), np.stack(boxes), left)
    return ObjectCrops(np.zeros((0, out_px, out_px, 3), np.uint8),
                       np.zeros((0, out_px, out_px), bool), [], np.zeros(0, np.int64),
                       np.zeros((0, 4)), left)


# --------------------------------------------------------------------------- features

def white_mask(rgb: np.ndarray) -> np.ndarray:
    """(...,) bool: white and pale-grey pixels (hulls, foam, splash): every channel >= 170
    and max - min <= 40 levels."""
    a = rgb.astype(np.int16)
    return (a.min(axis=-1) >= 170) & (a.max(axis=-1) - a.min(axis=-1) <= 40)


def _masked_mean_std(v: np.ndarray, m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(n,) mean and population std of (n, p) values over the True entries of (n, p) ``m``
    (0 where a row has none)."""
    cnt = np.maximum(m.sum(axis=1), 1)
    mean = (v * m).sum(axis=1) / cnt
    var = (((v - mean[:, None]) ** 2) * m).sum(axis=1) / cnt
    return mean, np.sqrt(var)


def object_features(crops: np.ndarray, masks: np.ndarray, boxes: np.ndarray) -> np.ndarray:
    """(n, 70) float64 hand features of (n, s, s, 3) uint8 crops with their (n, s, s) bool
    box masks and (n, 4) boxes (x, y, w, h; only their shape is used): the crop's 45 patch
    features, then :data:`OBJECT_FEATURES` (box = inside the mask, ring = the rest of the
    crop; CIELAB in OpenCV's 8-bit scaling; contrast as in :mod:`.objects` with the ring as
    the surrounding water; shares of the box's pixels; high-pass = luminance minus its 5 x 5
    box blur; elongation = longer side / shorter side)."""
    crops = np.ascontiguousarray(crops, np.uint8)
    n, s = crops.shape[0], crops.shape[1]
    if n == 0:
        return np.zeros((0, len(object_feature_names())))
    base = patch_features(crops)
    m = np.asarray(masks, bool).reshape(n, s * s)
    ring = ~m
    lab = cv2.cvtColor(crops.reshape(n * s, s, 3), cv2.COLOR_RGB2LAB).reshape(n, s * s, 3)
    lab = lab.astype(np.float64)
    cols: list[np.ndarray] = []
    for which in (m, ring):
        stats = [_masked_mean_std(lab[..., c], which) for c in range(3)]
        cols += [st[0] for st in stats] + [st[1] for st in stats]
    flat = crops.reshape(n, s * s, 3)
    y = (flat.astype(np.float32) @ LUMA).astype(np.float64)
    yin_mean, _ = _masked_mean_std(y, m)
    yr_mean, yr_std = _masked_mean_std(y, ring)
    cnt = np.maximum(m.sum(axis=1), 1)
    cols.append((yin_mean - yr_mean) / np.maximum(yr_std, 1.0))
    cols.append(((y <= yr_mean[:, None] - DARK_LEVELS) & m).sum(axis=1) / cnt)
    cols.append(((y >= yr_mean[:, None] + BRIGHT_LEVELS) & m).sum(axis=1) / cnt)
    mx = flat.max(axis=2).astype(np.float64)
    mn = flat.min(axis=2).astype(np.float64)
    sat = np.divide(mx - mn, mx, out=np.zeros_like(mx), where=mx > 0)
    sat_mean, _ = _masked_mean_std(sat, m)
    sat_in = np.where(m, sat, np.nan)
    with np.errstate(all="ignore"):
        p90 = np.nan_to_num(np.nanpercentile(sat_in, 90, axis=1))
    cols += [sat_mean, p90]
    for share in (skin_mask(flat), vivid_mask(flat), white_mask(flat)):
        cols.append((share & m).sum(axis=1) / cnt)
    yy = y.reshape(n, s, s).astype(np.float32)
    blur = np.stack([cv2.blur(p, (5, 5), borderType=cv2.BORDER_REFLECT_101) for p in yy])
    hp = (yy - blur).reshape(n, s * s).astype(np.float64)
    cols += [_masked_mean_std(hp, m)[1], _masked_mean_std(hp, ring)[1]]
    gx = np.zeros_like(yy)
    gy = np.zeros_like(yy)
    gx[:, :, 1:-1] = (yy[:, :, 2:] - yy[:, :, :-2]) / 2
    gy[:, 1:-1, :] = (yy[:, 2:, :] - yy[:, :-2, :]) / 2
    g = np.hypot(gx, gy).reshape(n, s * s).astype(np.float64)
    cols += [_masked_mean_std(g, m)[0], _masked_mean_std(g, ring)[0]]
    b = np.asarray(boxes, np.float64).reshape(n, 4)
    lo = np.maximum(np.minimum(b[:, 2], b[:, 3]), 1e-6)
    cols.append(np.maximum(b[:, 2], b[:, 3]) / lo)
    return np.hstack([base, np.stack(cols, axis=1)])
