"""Ultralytics YOLO labels: box or polygon label files, split lists and ``data.yaml``.

With ``--format yolo`` (or ``coco,yolo``) the dataset folder also holds::

    labels/train/000000.txt  one line per annotated object, coordinates normalised to 0-1:
    labels/val/000003.txt    "class cx cy w h" (boxes), or "class x1 y1 x2 y2 ..." with
                             --yolo-seg (a polygon of the instance mask); an empty file for
                             an image without objects
    train.txt, val.txt       the split's images, one "./images/train/000000.jpg" per line
    data.yaml                the split lists and the class names, for Ultralytics

``labels/train/`` lies beside ``images/train/`` with the same file stems, which is where
Ultralytics looks for an image's labels (it swaps the last ``/images/`` of the path for
``/labels/`` and the suffix for ``.txt``) and where supervision's ``from_yolo`` takes a
split's labels from; each split gets its own Ultralytics cache (``labels/train.cache``,
``labels/val.cache``). List files with ``./`` paths are read relative to the list's folder.
``data.yaml`` has no ``path:`` key, so Ultralytics takes the yaml's own folder as the root and
the dataset folder can be moved. Class ``k`` is COCO ``category_id`` ``k + 1``.

Box coordinates are pixel-edge coordinates (the left edge of the image is x = 0, the right
edge x = width), divided by the width or height and written with 6 decimals, so a label box
equals the COCO ``bbox`` ``[x, y, w, h]`` to within 0.5e-6 of the image size. Polygons are
made for the way consumers draw them (:func:`mask_polygon`): Ultralytics' ``polygon2mask``
and supervision's ``polygon_to_mask`` give back exactly the mask, holes included, except
where a bridge joins separate pieces of one object.
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


#: where a vertex sits inside its pixel, pixels: this far from the pixel's left (top) edge
#: on a left (top) side of the outline, this far before its centre on a right (bottom) side
VERTEX_INSET = 1.0 / 32.0


def mask_polygon(crop: np.ndarray, x0: int = 0, y0: int = 0) -> np.ndarray:
    """One polygon around the True pixels of ``crop`` ((h, w) bool, its top-left pixel at
    (x0, y0) in the image) that Ultralytics and supervision draw back to exactly the mask:
    (K, 2) float64 pixel coordinates (x, y; the image's left edge is x = 0), K >= 4.

    Both consumers draw a polygon with ``cv2.fillPoly`` after making its vertices integers
    (Ultralytics truncates, supervision rounds), which fills every pixel whose index is on
    or inside the integer polygon: a vertex names a pixel, not a corner. So the outline runs
    through the mask's boundary pixels (traced with ``cv2.findContours`` on the mask
    upsampled 2x, whose sub-pixels say which side of its pixel a vertex is on), each vertex
    at ``pixel + VERTEX_INSET`` on a left or top side and ``pixel + 0.5 - VERTEX_INSET`` on a
    right or bottom side: inside [pixel, pixel + 0.5), where truncating and rounding agree.
    The polygon's extent is the mask's box less about half a pixel on the right and bottom.

    Holes and separate pieces are joined into the one polygon by zero-width bridges, each
    contour spliced in at its vertex nearest to the outline so far; an even-odd fill leaves
    the holes empty. A bridge between separate pieces crosses pixels outside the mask, which
    a fill draws (YOLO has one polygon per object). Raises ValueError for a mask without any
    True pixel.
    """
    crop = np.asarray(crop, dtype=bool)
    if crop.ndim != 2 or not crop.any():
        raise ValueError("mask_polygon needs a 2-D mask with at least one True pixel")
    path = _straight_runs_dropped(_spliced(_contours_2x(crop)))
    inset = np.where(path % 2 == 0, VERTEX_INSET, 0.5 - VERTEX_INSET)
    return (path // 2) + inset + np.array([x0, y0], np.float64)


def _contours_2x(crop: np.ndarray) -> list[np.ndarray]:
    """The outer contours and holes of ``crop`` upsampled 2x: (K, 2) int sub-pixel (x, y)
    paths of boundary sub-pixels, each outer contour followed by its holes. Sub-pixel 2c
    (2c + 1) is the left (right) half of pixel c."""
    h, w = crop.shape
    up = np.zeros((2 * h + 2, 2 * w + 2), np.uint8)  # a blank border for findContours
    up[1:-1, 1:-1] = np.repeat(np.repeat(crop.view(np.uint8), 2, axis=0), 2, axis=1)
    contours, hier = cv2.findContours(up, cv2.RETR_CCOMP, cv2.CHAIN_APPROX_NONE)
    links = hier.reshape(-1, 4)  # next, previous, first child, parent
    out = []
    for i, c in enumerate(contours):
        if links[i, 3] != -1:
            continue
        out.append(c.reshape(-1, 2) - 1)
        j = links[i, 2]
        while j != -1:
            out.append(contours[j].reshape(-1, 2) - 1)
            j = links[j, 0]
    return out


def _spliced(pieces: list[np.ndarray]) -> np.ndarray:
    """One closed path through all ``pieces`` ((K, 2) closed paths): each spliced into the
    path so far at the nearest pair of vertices, along a bridge walked there and back."""
    path = pieces[0]
    for piece in pieces[1:]:
        d = ((path[:, None, :] - piece[None, :, :]) ** 2).sum(axis=2)
        i, j = np.unravel_index(int(np.argmin(d)), d.shape)
        walk = np.roll(piece, -int(j), axis=0)
        path = np.vstack([path[:i + 1], walk, walk[:1], path[i:]])
    return path


def _straight_runs_dropped(path: np.ndarray) -> np.ndarray:
    """``path`` (K, 2) without the vertices in the middle of a straight run (where the
    direction in equals the direction out)."""
    if len(path) < 3:
        return path
    d_in = path - np.roll(path, 1, axis=0)
    d_out = np.roll(path, -1, axis=0) - path
    cross = d_in[:, 0] * d_out[:, 1] - d_in[:, 1] * d_out[:, 0]
    straight = (cross == 0) & ((d_in * d_out).sum(axis=1) > 0)
    return path[~straight]


def polygon_line(class_id: int, polygon: np.ndarray, width: int, height: int) -> str:
    """``"class x1 y1 x2 y2 ..."`` of a (K, 2) pixel polygon, normalised to 0-1."""
    xy = np.asarray(polygon, np.float64) / np.array([width, height], np.float64)
    xy = np.clip(xy, 0.0, 1.0)  # (vertices lie inside their pixels: a no-op)
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
        return (layout.labels, *layout.split_folders(layout.labels))

    def image_files(self, layout: DatasetLayout, index: int, split: str) -> tuple[Path, ...]:
        return (layout.label_file(index, split),)

    def write_image(self, layout: DatasetLayout, index: int, split: str,
                    instances: np.ndarray, annotations: list[dict]) -> None:
        files.write_file(layout.label_file(index, split),
                         label_text(instances, annotations, self.seg).encode())

    def finish(self, layout: DatasetLayout, offsets: dict[int, int], categories: list[dict],
               info: dict) -> dict[str, int]:
        write_lists(layout, iter_records(layout.journal, offsets), categories, __version__,
                    self.seg)
        return {}

    def layout_entries(self) -> dict[str, str]:
        return dict(LAYOUT)


__all__ = ["YoloWriter", "box_line", "mask_polygon", "polygon_line", "label_text",
           "write_lists", "data_yaml", "VERTEX_INSET"]
