"""A zoomed contact sheet: one cell per object, a crop around it magnified.

At the generator's defaults (10-50 m, 416 px) every object is COCO-small (2-17 px across), so
whole-image cells (:mod:`sdcomp.report.sheet`) show specks. Here each cell is a square crop
of ``context`` times the object's larger box side (at least :data:`MIN_CROP` pixels) centred
on its box, enlarged to the cell with nearest-neighbour sampling (so pixels stay visible),
with the object's mask outline and box in its category's colour, the outlines of other
objects in the crop thinner, and a caption: file stem, instance id, box size in pixels and
the visible fraction. ``sdcomp show DIR --zoom`` draws it.
"""

from __future__ import annotations

import math
from pathlib import Path

import cv2
import numpy as np

from ..errors import UserError
from ..io.layout import Dataset, Entry
from ..io.png import decode_png16
from .sheet import BACKGROUND, FONT, PAD, TEXT_RGB, band_height, category_colour, select_indices

#: crop side = this x the larger box side, by default
CONTEXT = 3.0
#: smallest crop side, image pixels
MIN_CROP = 16


def zoom_objects(ds: Dataset) -> list[tuple[Entry, dict]]:
    """Every (image entry, annotation) of ``ds`` with a usable box, in image then instance
    order."""
    out = []
    for e in ds.entries:
        for a in sorted(e.annotations, key=lambda a: a.get("instance_id", 0)):
            box = a.get("bbox")
            if isinstance(box, list) and len(box) == 4 and box[2] > 0 and box[3] > 0:
                out.append((e, a))
    return out


#: objects smaller than this in a whole-image cell (median box side, sheet pixels) are
#: shown zoomed by default
SMALL_IN_CELL = 12.0


def median_side_in_cell(ds: Dataset, cell: int) -> float | None:
    """The objects' median box side (sqrt(w h)) as drawn in a whole-image cell of ``cell``
    pixels, or None when the dataset has no objects."""
    sides = []
    for e, a in zoom_objects(ds):
        longest = max(float(e.image.get("width", 0)), float(e.image.get("height", 0)))
        if longest > 0:
            w, h = a["bbox"][2:]
            sides.append((float(w) * float(h)) ** 0.5 * cell / longest)
    return float(np.median(sides)) if sides else None


def crop_window(bbox: list[float], context: float = CONTEXT) -> tuple[int, int, int]:
    """(x0, y0, side) of the square crop, image pixels, around a COCO box [x, y, w, h]."""
    x, y, w, h = (float(v) for v in bbox)
    side = max(MIN_CROP, int(math.ceil(max(w, h) * context)))
    return int(round(x + w / 2 - side / 2)), int(round(y + h / 2 - side / 2)), side


def _padded_crop(arr: np.ndarray, x0: int, y0: int, side: int, fill) -> np.ndarray:
    """``arr[y0:y0+side, x0:x0+side]`` with what lies outside ``arr`` set to ``fill``."""
    out = np.empty((side, side, *arr.shape[2:]), arr.dtype)
    out[...] = fill
    h, w = arr.shape[:2]
    sx0, sy0, sx1, sy1 = max(x0, 0), max(y0, 0), min(x0 + side, w), min(y0 + side, h)
    if sx1 > sx0 and sy1 > sy0:
        out[sy0 - y0:sy1 - y0, sx0 - x0:sx1 - x0] = arr[sy0:sy1, sx0:sx1]
    return out


def zoom_cell(folder: Path, entry: Entry, ann: dict, cell: int = 256,
              context: float = CONTEXT, labels: bool = True) -> np.ndarray:
    """(cell, cell, 3) uint8 RGB: the crop around ``ann`` magnified, outlines, box, caption."""
    img_path = folder / "images" / entry.image["file_name"]
    bgr = cv2.imread(str(img_path), cv2.IMREAD_COLOR)
    if bgr is None:
        raise UserError(f"image {str(img_path)!r} is missing or unreadable: re-run sdcomp "
                        f"generate with --resume to redraw it")
    x0, y0, side = crop_window(ann["bbox"], context)
    room = cell - 2 * PAD
    tile = np.empty((cell, cell, 3), np.uint8)
    tile[:] = BACKGROUND
    crop = _padded_crop(cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB), x0, y0, side, BACKGROUND)
    tile[PAD:PAD + room, PAD:PAD + room] = cv2.resize(crop, (room, room),
                                                      interpolation=cv2.INTER_NEAREST)
    scale = room / side
    mask_file = entry.image.get("mask_file")
    if isinstance(mask_file, str):
        try:
            inst = decode_png16((folder / "masks" / mask_file).read_bytes())
        except (OSError, ValueError):
            raise UserError(f"mask {str(folder / 'masks' / mask_file)!r} is missing or "
                            f"unreadable: re-run sdcomp generate with --resume") from None
        _outlines(tile, _padded_crop(inst, x0, y0, side, 0), room, ann, entry)
    x, y, w, h = (float(v) for v in ann["bbox"])
    p0 = (PAD + round((x - x0) * scale), PAD + round((y - y0) * scale))
    p1 = (PAD + round((x + w - x0) * scale) - 1, PAD + round((y + h - y0) * scale) - 1)
    cv2.rectangle(tile, p0, p1, category_colour(ann.get("category_id", 1)), 1, cv2.LINE_8)
    if labels:
        _caption(tile, zoom_caption(entry, ann))
    return tile


def _outlines(tile: np.ndarray, ids: np.ndarray, room: int, ann: dict, entry: Entry) -> None:
    """Draw every annotated instance's outline in the (side, side) uint16 id crop ``ids``,
    enlarged to ``room`` pixels: the zoomed object's 2 px wide, the others 1 px."""
    big = cv2.resize(ids, (room, room), interpolation=cv2.INTER_NEAREST)
    for other in entry.annotations:
        iid = other.get("instance_id")
        if not isinstance(iid, int) or not (big == iid).any():
            continue
        found, _ = cv2.findContours((big == iid).astype(np.uint8), cv2.RETR_CCOMP,
                                    cv2.CHAIN_APPROX_SIMPLE, offset=(PAD, PAD))
        width = 2 if iid == ann.get("instance_id") else 1
        cv2.polylines(tile, list(found), True, category_colour(other.get("category_id", 1)),
                      width, cv2.LINE_8)


def zoom_caption(entry: Entry, ann: dict) -> str:
    """E.g. ``000123 #2 7x5px vis 0.93``."""
    _, _, w, h = ann["bbox"]
    text = f"{Path(entry.image['file_name']).stem} #{ann.get('instance_id')} {w:.0f}x{h:.0f}px"
    vis = ann.get("visibility")
    return text + (f" vis {vis:.2f}" if isinstance(vis, (int, float)) else "")


def _caption(tile: np.ndarray, text: str) -> None:
    """``text`` on a darkened band at the bottom of ``tile`` (in place)."""
    cell = tile.shape[0]
    band = tile[cell - band_height(cell):]
    band[:] = (band * 0.3).astype(np.uint8)
    scale = max(0.3, cell / 640)
    width = cv2.getTextSize(text, FONT, scale, 1)[0][0]
    if width > cell - 4:
        scale = max(0.25, scale * (cell - 4) / width)
    while text and cv2.getTextSize(text, FONT, scale, 1)[0][0] > cell - 4:
        text = text[:-1]
    base = cv2.getTextSize("Ag0", FONT, scale, 1)[1]
    cv2.putText(tile, text, (2, cell - 2 - base), FONT, scale, TEXT_RGB, 1, cv2.LINE_AA)


def zoom_sheet(ds: Dataset, n: int = 24, columns: int = 6, cell: int = 256,
               select: str = "spread", seed: int = 0, labels: bool = True,
               context: float = CONTEXT) -> tuple[np.ndarray, list[tuple[Entry, dict]]]:
    """(H, W, 3) uint8 RGB sheet of up to ``n`` objects of ``ds`` (``select``-ed over all its
    objects as :func:`~sdcomp.report.sheet.select_indices`), and the objects shown."""
    objects = zoom_objects(ds)
    if not objects:
        raise UserError(f"{str(ds.folder)!r} has no annotated objects to zoom on: drop "
                        f"--zoom to see the images")
    shown = [objects[i] for i in select_indices(len(objects), n, select, seed)]
    cols = min(columns, len(shown))
    rows = math.ceil(len(shown) / cols)
    sheet = np.empty((rows * cell, cols * cell, 3), np.uint8)
    sheet[:] = BACKGROUND
    for k, (entry, ann) in enumerate(shown):
        r, c = divmod(k, cols)
        sheet[r * cell:(r + 1) * cell, c * cell:(c + 1) * cell] = zoom_cell(
            ds.folder, entry, ann, cell, context, labels)
    return sheet, shown
