"""Ultralytics YOLO labels: box or polygon label files, split lists and ``data.yaml``.

With ``--format yolo`` (or ``coco,yolo``) the dataset folder also holds::

    labels/000000.txt        one line per annotated object, coordinates normalised to 0-1:
                             "class cx cy w h" (boxes), or "class x1 y1 x2 y2 ..." with
                             --yolo-seg (a polygon traced from the instance mask); an empty
                             file for an image without objects
    train.txt, val.txt       the split's images, one "./images/000000.jpg" per line
    data.yaml                the split lists and the class names, for Ultralytics

``labels/`` lies beside ``images/`` with the same file stems, which is where Ultralytics looks
for an image's labels (it swaps the last ``/images/`` of the path for ``/labels/`` and the
suffix for ``.txt``); list files with ``./`` paths are read relative to the list's folder.
``data.yaml`` has no ``path:`` key, so Ultralytics takes the yaml's own folder as the root and
the dataset folder can be moved. Class ``k`` is COCO ``category_id`` ``k + 1``.

Coordinates are pixel-edge coordinates (the left edge of the image is x = 0, the right edge
x = width), divided by the width or height and written with 6 decimals, so a label box equals
the COCO ``bbox`` ``[x, y, w, h]`` to within 0.5e-6 of the image size. Polygons run along the
pixel edges of the mask (traced with ``cv2.findContours`` on a half-pixel grid), so their
extent is exactly the COCO box and their area the mask's pixel count, holes included (YOLO
polygons have no holes). An object in several pieces becomes one polygon that visits the
pieces in turn along zero-width bridges (the way Ultralytics joins multi-part COCO polygons).
"""

from __future__ import annotations

import json
from collections.abc import Iterable, Sequence
from pathlib import Path

import cv2
import numpy as np

from .. import __version__
from ..scene.config import GeneratorConfig
from ..util import files
from ..util.files import atomic_write_bytes
from .journal import iter_records
from .layout import SPLITS, DatasetLayout

#: dataset.json "layout" entries of the YOLO files
LAYOUT = {"yolo_labels": "labels/ (one .txt per image: class cx cy w h, or class x1 y1 ... "
                         "with --yolo-seg; normalised 0-1)",
          "yolo_data": "data.yaml", "yolo_train": "train.txt", "yolo_val": "val.txt"}
DECIMALS = 6


def _num(v: float) -> str:
    return f"{v:.{DECIMALS}f}"


def box_line(class_id: int, bbox: Sequence[float], width: int, height: int) -> str:
    """``"class cx cy w h"`` of a COCO ``bbox`` ``[x, y, w, h]`` (pixels) in a
    ``width`` x ``height`` image, normalised to 0-1."""
    x, y, w, h = (float(v) for v in bbox)
    return " ".join([str(int(class_id)), _num((x + w / 2) / width), _num((y + h / 2) / height),
                     _num(w / width), _num(h / height)])


def mask_polygon(crop: np.ndarray, x0: int = 0, y0: int = 0) -> np.ndarray:
    """One polygon around the True pixels of ``crop`` ((h, w) bool, its top-left pixel at
    (x0, y0) in the image): (K, 2) float64 pixel-edge coordinates (x, y), K >= 4.

    The outline follows the pixel edges (outer boundaries only); several pieces are joined
    into one polygon by zero-width bridges between their nearest vertices. Raises ValueError
    for a mask without any True pixel.
    """
    crop = np.asarray(crop, dtype=bool)
    if crop.ndim != 2 or not crop.any():
        raise ValueError("mask_polygon needs a 2-D mask with at least one True pixel")
    h, w = crop.shape
    # half-pixel grid: grid point (2r + i, 2c + j), i, j in 0..2, lies on pixel (r, c)'s
    # corners (even, even), edge midpoints or centre; a pixel sets all 9 of its grid points,
    # so pixels one pixel apart stay apart and the traced outline lies on the pixel edges
    grid = np.zeros((2 * h + 1, 2 * w + 1), np.uint8)
    for i in range(3):
        for j in range(3):
            grid[i:i + 2 * h:2, j:j + 2 * w:2] |= crop
    contours, _ = cv2.findContours(grid, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    pieces = [_axis_aligned(c.reshape(-1, 2)).astype(np.float64) / 2.0 for c in contours]
    poly = _join(pieces)
    return poly + np.array([x0, y0], np.float64)


def _axis_aligned(pts: np.ndarray) -> np.ndarray:
    """A closed half-pixel grid path (K, 2) int of single steps, with each diagonal step
    (which 8-connected tracing takes across a concave corner) replaced by its two axis steps
    through the pixel corner (the point with even coordinates), then only the vertices where
    the direction changes."""
    nxt = np.roll(pts, -1, axis=0)
    step = nxt - pts
    diag = (np.abs(step) == 1).all(axis=1)
    corner = np.where((pts[:, :1] % 2 == 0), np.column_stack([pts[:, 0], nxt[:, 1]]),
                      np.column_stack([nxt[:, 0], pts[:, 1]]))
    path = np.empty((len(pts) + int(diag.sum()), 2), pts.dtype)
    at = np.arange(len(pts)) + np.concatenate([[0], np.cumsum(diag)[:-1]])
    path[at] = pts
    path[at[diag] + 1] = corner[diag]
    if len(path) < 3:
        return path
    d_in = path - np.roll(path, 1, axis=0)
    d_out = np.roll(path, -1, axis=0) - path
    turn = (np.sign(d_in) != np.sign(d_out)).any(axis=1)
    return path[turn]


def _join(pieces: list[np.ndarray]) -> np.ndarray:
    """One closed path through all ``pieces`` (each (K, 2), closed implicitly): walk each
    piece from where the bridge from the previous one arrives to where the bridge to the next
    one leaves, around the last one entirely, then back along the other side of each."""
    if len(pieces) == 1:
        return pieces[0]
    entry = [0]
    leave = []
    for a, b in zip(pieces[:-1], pieces[1:], strict=True):
        d = ((a[:, None, :] - b[None, :, :]) ** 2).sum(axis=2)
        i, j = np.unravel_index(int(np.argmin(d)), d.shape)
        leave.append(int(i))
        entry.append(int(j))
    forward, back = [], []
    last = len(pieces) - 1
    for k, piece in enumerate(pieces):
        walk = np.roll(piece, -entry[k], axis=0)  # starts where the bridge arrives
        if k == last:
            forward.append(np.vstack([walk, walk[:1]]))
            continue
        stop = (leave[k] - entry[k]) % len(piece)
        forward.append(walk[:stop + 1])
        back.append(np.vstack([walk[stop:], walk[:1]]))
    return np.vstack(forward + back[::-1])


def polygon_line(class_id: int, polygon: np.ndarray, width: int, height: int) -> str:
    """``"class x1 y1 x2 y2 ..."`` of a (K, 2) pixel polygon, normalised to 0-1."""
    xy = np.asarray(polygon, np.float64) / np.array([width, height], np.float64)
    xy = np.clip(xy, 0.0, 1.0)
    return " ".join([str(int(class_id)), *(_num(v) for v in xy.reshape(-1))])


def label_text(instances: np.ndarray, annotations: Iterable[dict], seg: bool = False) -> str:
    """The label file of one image: ``instances`` (H, W) uint16 instance ids, the image's
    annotations (``instance_id``, ``category_id`` from 1, ``bbox`` [x, y, w, h] pixels) in
    order; one line per annotation, boxes or (``seg``) polygons; "" when there are none."""
    height, width = instances.shape
    lines = []
    for ann in annotations:
        cls = int(ann["category_id"]) - 1
        if not seg:
            lines.append(box_line(cls, ann["bbox"], width, height))
            continue
        x, y, w, h = (int(v) for v in ann["bbox"])
        crop = instances[y:y + h, x:x + w] == ann["instance_id"]
        lines.append(polygon_line(cls, mask_polygon(crop, x, y), width, height))
    return "".join(line + "\n" for line in lines)


def label_name(image_file: str) -> str:
    """``labels/`` file name of an image file name (``000017.jpg`` -> ``000017.txt``)."""
    return Path(image_file).with_suffix(".txt").name


def write_lists(layout: DatasetLayout, records: Iterable[dict], categories: list[dict],
                version: str, seg: bool) -> dict[str, int]:
    """``train.txt``, ``val.txt`` and ``data.yaml`` in ``out`` (atomically) from the run's
    records in index order; returns the number of images per split."""
    lists: dict[str, list[str]] = {s: [] for s in SPLITS}
    for rec in records:
        lists.setdefault(rec["split"], []).append(f"./images/{rec['image']['file_name']}\n")
    for split in SPLITS:
        atomic_write_bytes(layout.list_file(split), "".join(lists[split]).encode())
    atomic_write_bytes(layout.data_yaml, data_yaml(categories, version, seg,
                                                   has_val=bool(lists["val"])).encode())
    return {s: len(v) for s, v in lists.items()}


def data_yaml(categories: list[dict], version: str = "", seg: bool = False,
              has_val: bool = True) -> str:
    """The ``data.yaml`` text: split lists relative to its folder, ``nc`` and ``names``
    (class k = category id k + 1). Without val images, val points at the train list (Ultralytics
    needs a non-empty val set)."""
    kind = "polygons (segment)" if seg else "boxes (detect)"
    lines = [
        f"# Ultralytics YOLO dataset written by sdcomp {version}: labels are {kind}.",
        "# No 'path:' key: the root is this file's folder. Give Ultralytics this file's",
        "# absolute path, e.g. yolo detect train data=$PWD/dataset/data.yaml",
        "train: train.txt",
        "val: val.txt" if has_val else "val: train.txt  # no val images in this dataset",
        f"nc: {len(categories)}",
        "names:",
    ]
    for cat in sorted(categories, key=lambda c: c["id"]):
        lines.append(f"  {int(cat['id']) - 1}: {json.dumps(str(cat['name']))}")
    return "\n".join(lines) + "\n"


class YoloWriter:
    """The ``yolo`` label format: ``labels/NNNNNN.txt`` per image (boxes, or polygons with
    ``yolo_seg``), and ``train.txt``, ``val.txt``, ``data.yaml`` made from the journal. See
    :class:`sdcomp.io.writers.LabelWriter`."""

    def __init__(self, config: GeneratorConfig):
        self.seg = config.yolo_seg

    def folders(self, layout: DatasetLayout) -> tuple[Path, ...]:
        return (layout.labels,)

    def image_files(self, layout: DatasetLayout, index: int) -> tuple[Path, ...]:
        return (layout.label_file(index),)

    def write_image(self, layout: DatasetLayout, index: int, image_file: str,
                    instances: np.ndarray, annotations: list[dict]) -> None:
        files.write_file(layout.labels / label_name(image_file),
                         label_text(instances, annotations, self.seg).encode())

    def finish(self, layout: DatasetLayout, offsets: dict[int, int], categories: list[dict],
               info: dict) -> dict[str, int]:
        write_lists(layout, iter_records(layout.journal, offsets), categories, __version__,
                    self.seg)
        return {}

    def layout_entries(self) -> dict[str, str]:
        return dict(LAYOUT)


__all__ = ["YoloWriter", "box_line", "mask_polygon", "polygon_line", "label_text", "label_name",
           "write_lists", "data_yaml"]
