"""A contact sheet of a generated dataset: images with mask outlines, boxes and captions.

Reads the folder that the generator wrote::

    DIR/images/000000.jpg            photos (file_name in the COCO files)
    DIR/masks/000000.png             16-bit instance ids (mask_file in the COCO files)
    DIR/annotations/instances_train.json, instances_val.json
    DIR/records.jsonl                the run's journal: read instead of the COCO files in a
                                     folder written with --format yolo (which has none)

and draws, per chosen image, the photo letterboxed into a square cell, the outline of each
instance (traced in the full-resolution mask, then scaled), its COCO box, both in one bright
colour per category, and a one-line caption (file stem, altitude, gimbal pitch, water colour,
turbidity, number of annotations) on a dark band at the bottom of the cell.

The command line is ``python -m sdcomp.show`` (:mod:`sdcomp.cli.show`). Python::

    from sdcomp.report.sheet import contact_sheet
    rgb = contact_sheet("dataset/", n=12, split="val")     # (H, W, 3) uint8 RGB
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from ..errors import UserError
from ..io.layout import SPLIT_CHOICES, Dataset, DatasetLayout, Entry, load_dataset
from ..io.png import decode_png16
from ..util.files import write_png

SELECT_CHOICES = ("spread", "first", "random")
MIN_CELL = 32
BACKGROUND = (40, 40, 40)  # sRGB around the letterboxed images
PAD = 1  # pixels kept free on each side of a cell's image, so neighbours do not touch
TEXT_RGB = (235, 235, 235)
BAND_DARKEN = 0.3  # caption band = pixels x this
FONT = cv2.FONT_HERSHEY_SIMPLEX
# bright, mutually distinct colours (sRGB) for category ids 1, 2, ... (then repeating)
PALETTE = (
    ("red", (255, 60, 60)), ("green", (60, 255, 60)), ("blue", (70, 150, 255)),
    ("yellow", (255, 230, 0)), ("magenta", (255, 60, 255)), ("cyan", (0, 255, 255)),
    ("orange", (255, 150, 0)), ("violet", (170, 110, 255)),
)


def category_colour(category_id: int) -> tuple[int, int, int]:
    """The RGB colour outlines and boxes of ``category_id`` are drawn in."""
    return PALETTE[(int(category_id) - 1) % len(PALETTE)][1]


def category_colour_name(category_id: int) -> str:
    return PALETTE[(int(category_id) - 1) % len(PALETTE)][0]



def select_indices(count: int, n: int, select: str = "spread", seed: int = 0) -> list[int]:
    """Which of ``count`` images (indices, ascending) to show, at most ``n``.

    ``first``: the first n; ``spread``: n evenly over the range, first and last included;
    ``random``: n distinct ones drawn with ``seed``.
    """
    if select not in SELECT_CHOICES:
        raise UserError(f"--select {select!r} is unknown: use {', '.join(SELECT_CHOICES)}")
    if n < 1:
        raise UserError(f"--n {n} must be at least 1")
    if n >= count:
        return list(range(count))
    if select == "first":
        return list(range(n))
    if select == "random":
        return sorted(int(i) for i in np.random.default_rng(seed).choice(count, n, replace=False))
    if n == 1:
        return [0]
    # step (count-1)/(n-1) >= 1, so flooring x + 0.5 keeps the picks distinct
    return [int(math.floor(i * (count - 1) / (n - 1) + 0.5)) for i in range(n)]


# --------------------------------------------------------------------------- drawing

def band_height(cell: int) -> int:
    """Rows at the bottom of a cell that the caption band covers."""
    (_, th), base = cv2.getTextSize("Ag0", FONT, _font_scale(cell), 1)
    return min(cell, th + base + 4)


def _font_scale(cell: int) -> float:
    return max(0.3, cell / 640)


def _fit_text(text: str, cell: int) -> tuple[str, float]:
    """The caption (cut if need be) and a font scale at which it fits the cell's width."""
    scale, room = _font_scale(cell), cell - 4
    (w, _), _ = cv2.getTextSize(text, FONT, scale, 1)
    if w > room:
        scale = max(0.25, scale * room / w)
    while text and cv2.getTextSize(text, FONT, scale, 1)[0][0] > room:
        text = text[:-1]
    return text.rstrip(), scale


def _num(meta: dict, key: str) -> float | None:
    try:
        v = float(meta[key])
    except (KeyError, TypeError, ValueError):
        return None
    return v if math.isfinite(v) else None


def caption(entry: Entry) -> str:
    """E.g. ``000123 alt 23m pitch 90 brown t0.40 n=2``; metadata that is absent is left out."""
    meta = entry.image.get("meta")
    meta = meta if isinstance(meta, dict) else {}
    parts = [Path(entry.image["file_name"]).stem]
    if (alt := _num(meta, "height_above_takeoff(meter)")) is not None:
        parts.append(f"alt {alt:.0f}m")
    if (pitch := _num(meta, "gimbal_pitch(degrees)")) is not None:
        parts.append(f"pitch {pitch:.0f}")
    if meta.get("water_color"):
        parts.append(str(meta["water_color"]))
    if (turb := _num(meta, "turbidity")) is not None:
        parts.append(f"t{turb:.2f}")
    parts.append(f"n={len(entry.annotations)}")
    return " ".join(parts)


def _read_image(path: Path, target_scale: float, listed: tuple[int, int] | None,
                how: str) -> tuple[np.ndarray, tuple[int, int]]:
    """The RGB image and its full size (w, h).

    Decoded at 1/2, 1/4 or 1/8 size where that is still at least ``target_scale`` of the
    ``listed`` size and the file agrees with that size; otherwise decoded whole.
    """
    if not path.is_file():
        raise UserError(f"image {str(path)!r} is listed in the COCO file but missing: "
                        f"{how}")
    factor = 1
    while listed is not None and factor < 8 and target_scale * factor * 2 <= 1.0:
        factor *= 2
    flags = {1: cv2.IMREAD_COLOR, 2: cv2.IMREAD_REDUCED_COLOR_2,
             4: cv2.IMREAD_REDUCED_COLOR_4, 8: cv2.IMREAD_REDUCED_COLOR_8}
    img = cv2.imread(str(path), flags[factor])
    if img is not None and factor > 1:
        assert listed is not None
        if (abs(img.shape[1] * factor - listed[0]) < factor
                and abs(img.shape[0] * factor - listed[1]) < factor):
            return cv2.cvtColor(img, cv2.COLOR_BGR2RGB), listed
        img = cv2.imread(str(path), cv2.IMREAD_COLOR)  # the listed size is wrong: use the file's
    if img is None:
        raise UserError(f"image {str(path)!r} cannot be decoded (corrupt or truncated): "
                        f"{how}")
    return cv2.cvtColor(img, cv2.COLOR_BGR2RGB), (img.shape[1], img.shape[0])


def _read_mask(path: Path, shape: tuple[int, int], how: str) -> np.ndarray:
    if not path.is_file():
        raise UserError(f"mask {str(path)!r} is listed in the COCO file but missing: "
                        f"{how}")
    try:
        mask = decode_png16(path.read_bytes())
    except (OSError, ValueError) as exc:
        raise UserError(f"mask {str(path)!r} is unreadable ({exc}): {how}") from None
    if mask.shape != shape:
        raise UserError(f"mask {str(path)!r} is {mask.shape[1]}x{mask.shape[0]} but its image "
                        f"is {shape[1]}x{shape[0]}: {how}")
    return mask


def _contours(mask: np.ndarray, instance_ids: set[int]) -> dict[int, list[np.ndarray]]:
    """Outer contours (full-resolution pixel coordinates) of each instance id in ``mask``."""
    ys, xs = np.nonzero(mask)
    vals = mask[ys, xs]
    out: dict[int, list[np.ndarray]] = {}
    for iid in instance_ids:
        sel = vals == iid
        if not sel.any():
            continue
        y0, y1, x0, x1 = ys[sel].min(), ys[sel].max(), xs[sel].min(), xs[sel].max()
        crop = (mask[y0:y1 + 1, x0:x1 + 1] == iid).astype(np.uint8)
        found, _ = cv2.findContours(crop, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE,
                                    offset=(int(x0), int(y0)))
        out[iid] = list(found)
    return out


def render_cell(folder: str | Path, entry: Entry, cell: int = 256,
                labels: bool = True) -> np.ndarray:
    """(cell, cell, 3) uint8 RGB: the image letterboxed, outlines, boxes and caption."""
    folder = Path(folder)
    tile = np.empty((cell, cell, 3), np.uint8)
    tile[:] = BACKGROUND
    rec = entry.image
    w, h = rec.get("width"), rec.get("height")
    listed = (w, h) if isinstance(w, int) and isinstance(h, int) and w > 0 and h > 0 else None
    room = cell - 2 * PAD
    scale_hint = min(room / listed[0], room / listed[1]) if listed else 1.0
    img, (w, h) = _read_image(folder / "images" / rec["file_name"], scale_hint, listed,
                              DatasetLayout(folder).resume_hint())
    origin, scale = _letterbox(tile, img, (w, h))
    anns = entry.annotations
    contours: dict[int, list[np.ndarray]] = {}
    iids = {a["instance_id"] for a in anns if isinstance(a.get("instance_id"), int)}
    if iids and isinstance(rec.get("mask_file"), str):
        mask = _read_mask(folder / "masks" / rec["mask_file"], (h, w),
                          DatasetLayout(folder).resume_hint())
        contours = _contours(mask, iids)
    for ann in anns:
        _draw_annotation(tile, ann, contours, origin, scale)
    if labels:
        _draw_caption(tile, caption(entry))
    return tile


def _letterbox(tile: np.ndarray, img: np.ndarray, size: tuple[int, int]
               ) -> tuple[tuple[int, int], tuple[float, float]]:
    """Draw ``img`` ((h', w', 3) uint8 RGB, possibly decoded reduced) into the square
    ``tile`` ((cell, cell, 3), in place), scaled to fit with :data:`PAD` pixels free on each
    side and centred. ``size``: the image's full size (w, h) in pixels.

    Returns ((ox, oy), (sx, sy)): where the image's top left corner lies in the tile, and
    tile pixels per full-size image pixel in x and in y.
    """
    cell = tile.shape[0]
    w, h = size
    room = cell - 2 * PAD
    s = min(room / w, room / h)
    dw, dh = max(1, round(w * s)), max(1, round(h * s))
    ox, oy = (cell - dw) // 2, (cell - dh) // 2
    interp = cv2.INTER_AREA if dw < img.shape[1] else cv2.INTER_LINEAR
    tile[oy:oy + dh, ox:ox + dw] = cv2.resize(img, (dw, dh), interpolation=interp)
    return (ox, oy), (dw / w, dh / h)


def _draw_annotation(tile: np.ndarray, ann: dict, contours: dict[Any, list[np.ndarray]],
                     origin: tuple[int, int], scale: tuple[float, float]) -> None:
    """Draw one COCO annotation's box (if it has a valid one) and the outlines of its
    instance (``contours``: full-resolution pixel coordinates per instance id) into
    ``tile`` (in place), in its category's colour. ``origin``, ``scale``: as
    :func:`_letterbox` returns them."""
    (ox, oy), (sx, sy) = origin, scale
    cid = ann.get("category_id")
    colour = category_colour(cid if isinstance(cid, int) else 1)
    bbox = ann.get("bbox")
    if (isinstance(bbox, list) and len(bbox) == 4
            and all(isinstance(v, (int, float)) and math.isfinite(v) for v in bbox)):
        x, y, bw, bh = (float(v) for v in bbox)
        p0 = (ox + round(x * sx), oy + round(y * sy))
        p1 = (ox + max(round(x * sx), round((x + bw) * sx) - 1),
              oy + max(round(y * sy), round((y + bh) * sy) - 1))
        cv2.rectangle(tile, p0, p1, colour, 1, cv2.LINE_8)
    for c in contours.get(ann.get("instance_id"), []):
        # pixel centres to cell coordinates, 4 fractional bits for sub-pixel placement
        pts = (c[:, 0, :] + 0.5) * (sx, sy) - 0.5 + (ox, oy)
        cv2.polylines(tile, [np.round(pts * 16).astype(np.int32)], True, colour, 1,
                      cv2.LINE_8, shift=4)


def _draw_caption(tile: np.ndarray, text: str) -> None:
    """Darken the caption band at the bottom of the square ``tile`` ((cell, cell, 3) uint8,
    in place) and write ``text`` on it, cut and scaled to fit the width."""
    cell = tile.shape[0]
    bh_ = band_height(cell)
    band = tile[cell - bh_:]
    band[:] = (band * BAND_DARKEN).astype(np.uint8)
    text, fs = _fit_text(text, cell)
    (_, th), base = cv2.getTextSize("Ag0", FONT, fs, 1)
    cv2.putText(tile, text, (2, cell - 2 - base), FONT, fs, TEXT_RGB, 1, cv2.LINE_AA)


def check_params(n: int, columns: int, cell: int) -> None:
    if n < 1:
        raise UserError(f"--n {n} must be at least 1")
    if columns < 1:
        raise UserError(f"--columns {columns} must be at least 1")
    if cell < MIN_CELL:
        raise UserError(f"--cell {cell} is too small: use at least {MIN_CELL} pixels")


def check_choices(split: str, select: str) -> None:
    if split not in SPLIT_CHOICES:
        raise UserError(f"--split {split!r} is unknown: use {', '.join(SPLIT_CHOICES)}")
    if select not in SELECT_CHOICES:
        raise UserError(f"--select {select!r} is unknown: use {', '.join(SELECT_CHOICES)}")


def sheet_of(ds: Dataset, split: str, n: int, columns: int, cell: int, select: str, seed: int,
           labels: bool) -> tuple[np.ndarray, list[Entry]]:
    if not ds.entries:
        raise UserError(f"{str(ds.folder)!r} has no images in split {split!r}: choose another "
                        f"--split, or {ds.layout.resume_hint()}")
    shown = [ds.entries[i] for i in select_indices(len(ds.entries), n, select, seed)]
    cols = min(columns, len(shown))
    rows = math.ceil(len(shown) / cols)
    sheet = np.empty((rows * cell, cols * cell, 3), np.uint8)
    sheet[:] = BACKGROUND
    for k, entry in enumerate(shown):
        r, c = divmod(k, cols)
        sheet[r * cell:(r + 1) * cell, c * cell:(c + 1) * cell] = render_cell(
            ds.folder, entry, cell, labels)
    return sheet, shown


def contact_sheet(folder: str | Path, n: int = 24, split: str = "all", columns: int = 6,
                  cell: int = 256, select: str = "spread", seed: int = 0,
                  labels: bool = True) -> np.ndarray:
    """(H, W, 3) uint8 RGB contact sheet of up to ``n`` images of the dataset in ``folder``.

    The images of ``split`` are sorted by id and ``select``-ed (see :func:`select_indices`);
    they fill ``min(columns, shown)`` columns of ``cell`` x ``cell`` cells, row by row, so
    the sheet is ``ceil(shown / min(columns, shown)) * cell`` high. Raises UserError for bad
    arguments or a missing or broken dataset.
    """
    check_params(n, columns, cell)
    check_choices(split, select)
    return sheet_of(load_dataset(folder, split), split, n, columns, cell, select, seed,
                  labels)[0]


# --------------------------------------------------------------------------- command line


write_sheet = write_png  # the sheet's name for it (sdcomp.show exports it)
