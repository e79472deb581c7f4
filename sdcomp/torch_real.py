"""PyTorch datasets of the user's real frames, alone or mixed with sdcomp's images, in the
torchvision detection format of :mod:`sdcomp.torch_datasets` (import them from there).

- :class:`RealDetection`: labelled real frames (photos and videos of
  :mod:`sdcomp.render.footage`, a COCO file or YOLO folder of
  :mod:`sdcomp.render.footage_labels`), each ``(image, target)``. Real labels are boxes:
  ``masks`` are the boxes filled (the only shape the labels give), ``area`` the box's,
  ``ignore`` all 0 (COCO crowd boxes are not read).
- :class:`MixedDetection`: one stream of real and synthetic samples in a fixed ratio
  (item ``i`` is real where ``floor((i + 1) r) > floor(i r)``: exactly the share ``r`` of
  every prefix), each kind cycled in order; what "mixed batches of synthetic and K real
  frames" trains on. The ignore regions of the synthetic images pass through.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from pathlib import Path

import numpy as np
import torch
from torchvision import tv_tensors

from .errors import UserError
from .render.footage import Source, VideoReader, list_sources, read_source
from .render.footage_labels import read_labels
from .torch_datasets import Target, Transforms, check_image_dtype


class RealDetection(torch.utils.data.Dataset):
    """The labelled frames at ``frames`` (photos and videos) with ``labels``, as
    ``(image, target)`` (see :mod:`sdcomp.torch_datasets`); the frames are those the labels
    name (a YOLO folder's photos without a label file: frames with no objects). Boxes are
    clipped to the frame; those left without area are dropped.

    Args:
        category_ids: category name -> id of the targets' ``labels`` (e.g. a synthetic
            dataset's, so both kinds share ids; names match case-insensitively); None: the
            labels' own ids. UserError for a labelled name it lacks.
        transforms, image_dtype: as :class:`~sdcomp.torch_datasets.SyntheticDetection`.
    """

    def __init__(self, frames: str | Path, labels: str | Path,
                 category_ids: Mapping[str, int] | None = None,
                 transforms: Transforms | None = None,
                 image_dtype: torch.dtype = torch.float32):
        lab = read_labels(labels, "labels")
        self.image_dtype = check_image_dtype(image_dtype)
        self.transforms = transforms
        self.sources: list[Source] = []
        self.boxes: list[np.ndarray] = []  # (n, 4) float32 x1, y1, x2, y2 per frame
        self.labels: list[np.ndarray] = []  # (n,) int64
        ids = _id_map(lab.categories, category_ids, labels)
        for s in list_sources(frames, "frames"):
            fl = lab.of(s.key)
            if fl is None and not (lab.kind == "yolo" and s.frame is None):
                continue
            xywh = fl.pixels(s.width, s.height) if fl is not None else np.zeros((0, 4))
            cats = fl.categories if fl is not None else np.zeros(0, np.int64)
            xyxy = np.concatenate([xywh[:, :2], xywh[:, :2] + xywh[:, 2:]], 1)
            xyxy = np.clip(xyxy, 0, [s.width, s.height, s.width, s.height])
            keep = (xyxy[:, 2] > xyxy[:, 0]) & (xyxy[:, 3] > xyxy[:, 1])
            self.sources.append(s)
            self.boxes.append(xyxy[keep].astype(np.float32))
            self.labels.append(np.asarray([ids[int(c)] for c in cats[keep]], np.int64))
        if not self.sources:
            raise UserError(f"labels {labels}: none of its {len(lab.frames)} frames is in "
                            f"{frames} (matched by file name without extension)")
        self._videos = VideoReader("frames")

    def __len__(self) -> int:
        return len(self.sources)

    def __getitem__(self, i: int) -> tuple[torch.Tensor, Target]:
        if not -len(self) <= i < len(self):
            raise IndexError(f"index {i} out of range for {len(self)} frames")
        k = i % len(self)
        rgb = read_source(self.sources[k], self._videos, "frames")
        image, target = box_sample(rgb, self.boxes[k], self.labels[k], k, self.image_dtype)
        if self.transforms is not None:
            image, target = self.transforms(image, target)
        return image, target


def _id_map(categories: dict[int, str], category_ids: Mapping[str, int] | None,
            labels: str | Path) -> dict[int, int]:
    """Label file category id -> target id (:class:`RealDetection`'s ``category_ids``)."""
    if category_ids is None:
        return _Identity()
    by_name = {n.lower(): v for n, v in category_ids.items()}
    out = {}
    for c, name in categories.items():
        if name.lower() not in by_name:
            raise UserError(f"labels {labels}: category {name!r} is not among "
                            f"{sorted(category_ids)}; add it to category_ids")
        out[c] = by_name[name.lower()]
    return out


class _Identity(dict):
    """A mapping of every id to itself (labels' own ids, categories listed or not)."""

    def __missing__(self, key: int) -> int:
        return key


def box_sample(rgb: np.ndarray, boxes: np.ndarray, labels: np.ndarray, image_id: int,
               image_dtype: torch.dtype = torch.float32) -> tuple[torch.Tensor, Target]:
    """The torchvision form of a frame labelled with boxes: ``rgb`` (H, W, 3) uint8,
    ``boxes`` (N, 4) float32 x1, y1, x2, y2 pixels, ``labels`` (N,) int64; masks are the
    boxes filled (pixels whose centres lie inside), ``area`` the boxes' areas."""
    h, w = rgb.shape[:2]
    n = len(boxes)
    chw = torch.from_numpy(np.ascontiguousarray(rgb.transpose(2, 0, 1)))
    image = chw.float().div_(255.0) if check_image_dtype(image_dtype) is torch.float32 \
        else chw
    ys, xs = np.arange(h) + 0.5, np.arange(w) + 0.5
    b = boxes.reshape(n, 4)
    inside_x = (xs[None] >= b[:, 0:1]) & (xs[None] <= b[:, 2:3])  # (N, W)
    inside_y = (ys[None] >= b[:, 1:2]) & (ys[None] <= b[:, 3:4])  # (N, H)
    masks = (inside_y[:, :, None] & inside_x[:, None, :]).astype(np.uint8)
    target = {"boxes": tv_tensors.BoundingBoxes(torch.from_numpy(b.astype(np.float32)),
                                                format="XYXY", canvas_size=(h, w)),
              "labels": torch.from_numpy(np.asarray(labels, np.int64).reshape(n)),
              "masks": tv_tensors.Mask(torch.from_numpy(masks)),
              "image_id": int(image_id),
              "area": torch.from_numpy(((b[:, 2] - b[:, 0]) * (b[:, 3] - b[:, 1]))
                                       .astype(np.float32)),
              "iscrowd": torch.zeros(n, dtype=torch.int64),
              "ignore": tv_tensors.Mask(torch.zeros((h, w), dtype=torch.uint8))}
    return tv_tensors.Image(image), target


class MixedDetection(torch.utils.data.Dataset):
    """``real`` and ``synthetic`` samples in one stream, the share ``ratio`` of it real
    (see the module docstring), each kind cycled in order; ``length`` items (default:
    enough that every synthetic sample comes once, ``ceil(len(synthetic) / (1 - ratio))``;
    ``len(real)`` at ratio 1). ``kind(i)`` says which an item is."""

    def __init__(self, real: torch.utils.data.Dataset, synthetic: torch.utils.data.Dataset,
                 ratio: float, length: int | None = None):
        if not (isinstance(ratio, (int, float)) and 0 <= ratio <= 1):
            raise UserError(f"ratio {ratio!r} is out of range: use the share of real samples, "
                            f"0 to 1")
        n_real, n_syn = len(real), len(synthetic)  # type: ignore[arg-type]
        if (ratio > 0 and n_real == 0) or (ratio < 1 and n_syn == 0):
            raise UserError(f"a ratio of {ratio} needs both kinds: {n_real} real and "
                            f"{n_syn} synthetic samples given")
        self.real, self.synthetic, self.ratio = real, synthetic, float(ratio)
        self.length = (length if length is not None else
                       n_real if ratio == 1 else math.ceil(n_syn / (1 - ratio)))

    def __len__(self) -> int:
        return self.length

    def _reals_before(self, i: int) -> int:
        return math.floor(i * self.ratio + 1e-9)

    def kind(self, i: int) -> str:
        """"real" or "synthetic": the kind of item ``i``."""
        return "real" if self._reals_before(i + 1) > self._reals_before(i) else "synthetic"

    def __getitem__(self, i: int) -> tuple[torch.Tensor, Target]:
        if not 0 <= i < self.length:
            raise IndexError(f"index {i} out of range for {self.length} items")
        before = self._reals_before(i)
        if self.kind(i) == "real":
            return self.real[before % len(self.real)]  # type: ignore[arg-type]
        return self.synthetic[(i - before) % len(self.synthetic)]  # type: ignore[arg-type]
