"""Side-by-side crops of objects and empty water, generated vs real, at one ground sampling
distance.

Every crop is a window of ``out_px`` x ``out_px`` pixels at the target GSD (metres per pixel):
the source window is ``out_px * gsd_target / gsd_src`` source pixels wide, centred on the object
(or on an empty-water patch), and resampled by ``gsd_src / gsd_target`` (INTER_AREA when
shrinking, bicubic when enlarging). A frame whose GSD is unknown is cropped at its own
resolution (no rescaling), and the montage says so. GSD is per image (at the image centre), so
crops far from the centre of oblique frames are only roughly matched.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from .patches import PATCH, boxes_mask, empty_water, patch_origins
from .sources import FrameSet, load_frame

PAD_RGB = (40, 40, 40)
OUT_PX = 128


@dataclass
class Crop:
    """One crop: ``rgb`` (out_px, out_px, 3) uint8, ``caption`` (short text), ``scaled``
    (whether it was resampled to the target GSD)."""

    rgb: np.ndarray
    caption: str
    scaled: bool


def crop_at_gsd(rgb: np.ndarray, centre: tuple[float, float], gsd_src: float | None,
                gsd_target: float | None, out_px: int = OUT_PX) -> tuple[np.ndarray, bool]:
    """((out_px, out_px, 3) uint8 crop of (H, W, 3) uint8 ``rgb`` centred on ``centre`` (x, y
    pixels) resampled by gsd_src / gsd_target, whether it was rescaled). Outside the image is
    :data:`PAD_RGB`. With either GSD unknown (None or <= 0) the crop is at native resolution."""
    x0, y0, side, scaled = crop_window(centre, gsd_src, gsd_target, out_px)
    h, w = rgb.shape[:2]
    win = np.empty((side, side, 3), np.uint8)
    win[:] = PAD_RGB
    sx0, sy0, sx1, sy1 = max(x0, 0), max(y0, 0), min(x0 + side, w), min(y0 + side, h)
    if sx1 > sx0 and sy1 > sy0:
        win[sy0 - y0:sy1 - y0, sx0 - x0:sx1 - x0] = rgb[sy0:sy1, sx0:sx1]
    if side == out_px:
        return win, scaled
    interp = cv2.INTER_AREA if side > out_px else cv2.INTER_CUBIC
    return cv2.resize(win, (out_px, out_px), interpolation=interp), scaled


def crop_window(centre: tuple[float, float], gsd_src: float | None, gsd_target: float | None,
                out_px: int = OUT_PX) -> tuple[int, int, int, bool]:
    """(x0, y0, side, scaled): the source window of :func:`crop_at_gsd`, its top-left pixel
    and side (source pixels; the crop maps it onto ``out_px``), and whether it is rescaled."""
    scaled = bool(gsd_src and gsd_target and gsd_src > 0 and gsd_target > 0)
    # output pixels per source pixel
    scale = gsd_src / gsd_target if gsd_src and gsd_target and scaled else 1.0
    side = max(1, int(round(out_px / scale)))
    cx, cy = centre
    return int(round(cx - side / 2)), int(round(cy - side / 2)), side, scaled


def median_gsd(frames: FrameSet) -> float | None:
    """Median of the known per-image GSDs of a set (m/px), None if none is known."""
    g = [f.gsd for f in frames.frames if f.gsd]
    return float(np.median(g)) if g else None


def pick_crops(frames: FrameSet, gsd_target: float | None, n: int = 8, seed: int = 0,
               out_px: int = OUT_PX, max_reads: int = 40) -> tuple[list[Crop], list[Crop]]:
    """(object crops, empty-water crops) of up to ``n`` each from a set, images chosen at
    random (seeded; at most ``max_reads`` images read). Objects: the largest box of each image
    with boxes; water: a crop centred on an empty-water patch
    (:func:`.patches.empty_water`) whose whole window is inside the image and clear
    of objects, boxes and invalid pixels."""
    rng = np.random.default_rng(seed)
    order = rng.permutation(len(frames.frames))[:max_reads]
    objects: list[Crop] = []
    water: list[Crop] = []
    for i in order:
        if len(objects) >= n and len(water) >= n:
            break
        frame = frames.frames[int(i)]
        loaded = load_frame(frame)
        if loaded is None:
            continue
        cap = _caption(frame)
        boxes = [b for b in (frame.boxes or []) if b[2] > 0 and b[3] > 0]
        if boxes and len(objects) < n:
            b = max(boxes, key=lambda b: b[2] * b[3])
            img, scaled = crop_at_gsd(loaded.rgb, (b[0] + b[2] / 2, b[1] + b[3] / 2),
                                      frame.gsd, gsd_target, out_px)
            objects.append(Crop(img, cap, scaled))
        if len(water) < n:
            centre = _clear_centre(loaded, frame, gsd_target, out_px, rng)
            if centre is not None:
                img, scaled = crop_at_gsd(loaded.rgb, centre, frame.gsd, gsd_target, out_px)
                water.append(Crop(img, cap, scaled))
    return objects, water


def _clear_centre(loaded, frame, gsd_target, out_px, rng) -> tuple[float, float] | None:
    """Centre (x, y) of an empty-water patch whose whole crop window lies inside the image
    and holds no object, box or invalid pixel; a random one of those, None if none."""
    shape = loaded.rgb.shape[:2]
    keep = empty_water(shape, loaded.instances, frame.boxes, loaded.valid)
    if not keep.any():
        return None
    bad = ~loaded.valid if loaded.valid is not None else np.zeros(shape, bool)
    if loaded.instances is not None:
        bad = bad | (loaded.instances != 0)
    if frame.boxes:
        bad = bad | boxes_mask(shape, frame.boxes)
    integral = cv2.integral(bad.astype(np.uint8))  # (H + 1, W + 1) counts
    scaled = bool(frame.gsd and gsd_target)
    side = max(PATCH, round(out_px * (gsd_target / frame.gsd if scaled else 1.0)))
    h, w = shape
    ok = []
    for i in np.flatnonzero(keep):
        x, y = patch_origins(h, w)[i]
        cx, cy = x + PATCH / 2, y + PATCH / 2
        x0, y0 = round(cx - side / 2), round(cy - side / 2)
        x1, y1 = x0 + side, y0 + side
        if x0 < 0 or y0 < 0 or x1 > w or y1 > h:
            continue
        if integral[y1, x1] - integral[y0, x1] - integral[y1, x0] + integral[y0, x0] == 0:
            ok.append((cx, cy))
    return ok[int(rng.integers(len(ok)))] if ok else None


def _caption(frame) -> str:
    return f"{frame.gsd * 100:.1f}cm" if frame.gsd else "gsd ?"


def _label(img: np.ndarray, text: str, org: tuple[int, int], scale: float = 0.45,
           colour=(235, 235, 235)) -> None:
    """Draw ``text`` at ``org`` (baseline left, pixels) on a dark box, in place."""
    (tw, th), base = cv2.getTextSize(text, cv2.FONT_HERSHEY_SIMPLEX, scale, 1)
    x, y = org
    roi = img[max(y - th - 2, 0):y + base, max(x - 2, 0):x + tw + 2]
    roi[:] = (roi.astype(np.float32) * 0.35).astype(np.uint8)
    cv2.putText(img, text, org, cv2.FONT_HERSHEY_SIMPLEX, scale, colour, 1, cv2.LINE_AA)


def montage(rows: list[tuple[str, list[Crop]]], title: str, n: int, out_px: int = OUT_PX
            ) -> np.ndarray:
    """(H, W, 3) uint8 RGB montage: one row of up to ``n`` crops per (label, crops), the label
    above the row, each crop's caption (its source GSD) in its corner, ``title`` on top."""
    gap, band, head = 4, 22, 30
    width = n * (out_px + gap) + gap
    height = head + len(rows) * (band + out_px + gap)
    img = np.full((height, width, 3), 25, np.uint8)
    for line, text in enumerate(_wrap(title, width)):
        _label(img, text, (gap, 13 + 13 * line), 0.42)
    y = head
    for label, crops in rows:
        _label(img, label if crops else f"{label}: none", (gap, y + 16), 0.5, (255, 220, 120))
        y += band
        for j, c in enumerate(crops[:n]):
            x = gap + j * (out_px + gap)
            img[y:y + out_px, x:x + out_px] = c.rgb
            text = c.caption + ("" if c.scaled else " (native)")
            if text:
                _label(img, text, (x + 3, y + out_px - 5), 0.35)
        y += out_px + gap
    return img


def _wrap(text: str, width_px: int, char_px: int = 8) -> list[str]:
    per = max(20, width_px // char_px)
    words, lines, cur = text.split(), [], ""
    for w in words:
        if len(cur) + len(w) + 1 > per:
            lines.append(cur)
            cur = w
        else:
            cur = f"{cur} {w}".strip()
    return [*lines, cur][:2]


def crops_figure(path, generated: FrameSet, real: FrameSet | None = None, n: int = 8,
                 seed: int = 0, out_px: int = OUT_PX) -> dict:
    """Write the montage PNG to ``path``; returns {"target_gsd", "note"}.

    Target GSD: the median real GSD when known, else the median generated GSD."""
    g_gsd = median_gsd(generated)
    r_gsd = median_gsd(real) if real is not None else None
    target = r_gsd or g_gsd
    g_obj, g_water = pick_crops(generated, target, n, seed, out_px)
    rows = [("generated objects", g_obj)]
    if real is not None:
        r_obj, r_water = pick_crops(real, target, n, seed + 1, out_px)
        rows += [("real objects", r_obj), ("generated empty water", g_water),
                 ("real empty water", r_water)]
    else:
        rows.append(("generated empty water", g_water))
    if target is None:
        note = "GSD unknown: crops at native resolution (NOT matched)"
    else:
        side_m = out_px * target
        note = (f"all crops resampled to {target * 100:.1f} cm/px ({side_m:.1f} m across)")
        if real is not None and r_gsd is None:
            note += "; real GSD unknown: real crops at native resolution (NOT rescaled)"
    img = montage(rows, note, n, out_px)
    cv2.imwrite(str(path), cv2.cvtColor(img, cv2.COLOR_RGB2BGR))
    return {"target_gsd": target, "note": note}

