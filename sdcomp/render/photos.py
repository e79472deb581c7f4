"""The user's own footage as backgrounds (``--backgrounds PATH [--background-labels L]``).

``PATH`` is a folder (or one file) of still photos and video files
(:mod:`sdcomp.render.footage`). Every frame of every file is a candidate: image ``i`` draws
its frame, crop and flip from its own photo seed (:attr:`FeatureSeeds.photo`, made from
``(seed, i)``), so any worker draws the same background. The crop has the output's aspect
ratio and covers 60-100 % of the frame's shorter side, but never fewer frame pixels than the
output has where the frame holds that many (footage is not enlarged: magnified, it is blurrier
than any real frame); it is resized to the output size.
Frames are read on demand and kept, downscaled to the largest size a crop of them can need,
in a cache of :data:`CACHE_BYTES` per process.

**Real objects in the footage.** Frames of real flights show real objects (boats, buoys,
swimmers) that the dataset must not contain unlabelled: a detector trained on such images
is taught that a real object is background, the opposite of what sdcomp data is for. With
labels (a COCO file or a YOLO folder naming the objects in some frames, any category), the
labelled boxes, widened by :data:`BOX_MARGIN` of their size and :data:`BOX_MARGIN_PX` pixels
for wakes, reflections and loose labels, are kept out of the image: each image tries up to
:data:`TRIES` (frame, crop) draws and takes the first whose crop holds no labelled box; when
all of them do (frames crowded with objects), the draw with the least labelled area is taken
and the boxes in it are painted over with the surrounding water (``cv2.inpaint``, Telea;
a crop that is all labelled boxes becomes its median colour).
Either way no labelled object is in the output, so no synthetic object is ever placed over
one and none is left unannotated. Frames without labels are taken to hold no objects.
"""

from __future__ import annotations

from collections import OrderedDict
from pathlib import Path

import cv2
import numpy as np

from ..errors import UserError
from .footage import (
    IMAGE_EXTENSIONS,
    MAX_PIXELS,
    Source,
    VideoReader,
    check_photo,
    list_sources,
    read_photo,
    read_source,
)
from .footage_labels import Labels, read_labels

EXTENSIONS = IMAGE_EXTENSIONS  # kept for code that imported it from here
__all__ = ["EXTENSIONS", "MAX_PIXELS", "Backgrounds", "check_photo"]
CACHE_BYTES = 256 * 2**20  #: decoded, downscaled frames kept per process
MIN_CROP = 0.6  #: the crop covers at least this fraction of the frame's shorter side
#: (and at least the output's width in frame pixels, where the frame is that wide)
TRIES = 16  #: (frame, crop) draws per image looking for one clear of labelled objects
BOX_MARGIN = 0.25  #: labelled boxes are widened by this fraction of their size on each side
BOX_MARGIN_PX = 4.0  #: and by this many frame pixels


class Backgrounds:
    """The frames of the user's footage; :meth:`pick` gives one image's background as an
    (H, W, 3) uint8 RGB array. ``labels``: a COCO json file or YOLO labels folder whose
    boxes are kept out of every background (see the module docstring)."""

    def __init__(self, path: str | Path, labels: str | Path | None = None):
        self.path = Path(path)
        if not self.path.exists():
            raise UserError(f"--backgrounds {path}: no such folder or file; give a folder of "
                            f"empty-water photos or drone videos (or one such file)")
        self.sources: list[Source] = list_sources(self.path, "--backgrounds")
        self.labels: Labels | None = None
        self._boxes: dict[int, np.ndarray] = {}  # source index -> (k, 4) x0, y0, x1, y1 frac
        if labels is not None:
            self.labels = read_labels(labels, "--background-labels")
            for i, s in enumerate(self.sources):
                fl = self.labels.of(s.key)
                if fl is not None and len(fl.boxes):
                    self._boxes[i] = _widened(fl.pixels(s.width, s.height), s.width, s.height)
            matched = sum(self.labels.of(s.key) is not None for s in self.sources)
            if not matched:
                raise UserError(
                    f"--background-labels {labels}: none of its {len(self.labels.frames)} "
                    f"labelled frames is in --backgrounds {path}; frames are matched by file "
                    f"name without extension (video frames: <video name>_<frame:06d>)")
        self._videos = VideoReader("--backgrounds")
        self._cache: OrderedDict[tuple, np.ndarray] = OrderedDict()
        self._cached_bytes = 0
        if self.sources[0].frame is None:  # a broken first photo fails before any writing
            read_photo(self.sources[0].path)  # (videos decoded their first frame already)

    @property
    def files(self) -> list[Path]:
        """The photo and video files, sorted."""
        return list(dict.fromkeys(s.path for s in self.sources))

    def __len__(self) -> int:
        """The number of frames (a photo is one, a video as many as it has)."""
        return len(self.sources)

    def __getstate__(self) -> dict:
        state = dict(self.__dict__)
        state["_cache"], state["_cached_bytes"] = OrderedDict(), 0
        return state

    def labelled_boxes(self, index: int) -> np.ndarray:
        """(k, 4) float64 widened labelled boxes of frame ``index``: x0, y0, x1, y1 as
        fractions of its width and height (empty without labels)."""
        return self._boxes.get(index, np.zeros((0, 4)))

    def _frame(self, i: int, scale: float) -> np.ndarray:
        """Frame ``i`` resized by ``scale`` (<= 1), from the cache when it is there."""
        key = (i, scale)
        img = self._cache.get(key)
        if img is not None:
            self._cache.move_to_end(key)
            return img
        img = read_source(self.sources[i], self._videos)
        if scale < 1:
            h, w = img.shape[:2]
            img = cv2.resize(img, (max(1, round(w * scale)), max(1, round(h * scale))),
                             interpolation=cv2.INTER_AREA)
        self._cache[key] = img
        self._cached_bytes += img.nbytes
        while self._cached_bytes > CACHE_BYTES and len(self._cache) > 1:
            self._cached_bytes -= self._cache.popitem(last=False)[1].nbytes
        return img

    def pick(self, seed: tuple[int, ...], width: int, height: int) -> np.ndarray:
        """The background for an image whose photo seed sequence is ``seed``
        (:attr:`sdcomp.scene.scene.FeatureSeeds.photo`): (height, width, 3) uint8."""
        return self.pick_scaled(seed, width, height)[0]

    def pick_scaled(self, seed: tuple[int, ...], width: int, height: int
                    ) -> tuple[np.ndarray, float]:
        """(:meth:`pick`'s background, its magnification: output pixels per pixel of the
        frame it was cut from; above 1 where the crop was enlarged)."""
        rng = np.random.default_rng(list(seed))
        aspect = width / height
        best: tuple[float, int, np.ndarray, bool] | None = None
        for _ in range(TRIES):
            i = int(rng.integers(len(self.sources)))
            s = self.sources[i]
            max_w = min(s.width, s.height * aspect)
            # 60-100 % of the frame, but never enlarged where the frame is big enough:
            # magnified footage is blurrier than any real frame (and than the objects)
            cw = max_w * rng.uniform(max(MIN_CROP, min(width / max_w, 1.0)), 1.0)
            ch = cw / aspect
            # max(0, ...): where the crop spans the frame, cw / aspect can exceed the
            # frame's height by a rounding error (a 5 x 125 frame cut from a wide photo)
            x0 = rng.uniform(0, max(0.0, s.width - cw))
            y0 = rng.uniform(0, max(0.0, s.height - ch))
            flip = bool(rng.random() < 0.5)
            crop = np.array([x0 / s.width, y0 / s.height, (x0 + cw) / s.width,
                             (y0 + ch) / s.height])
            covered = _covered(self.labelled_boxes(i), crop)
            if best is None or covered < best[0]:
                best = (covered, i, crop, flip)
            if covered == 0:
                break
        assert best is not None
        covered, i, crop, flip = best
        out = self._cut(i, crop, flip, width, height)
        if covered > 0:
            out = _paint(out, self.labelled_boxes(i), crop, flip)
        return out, width / max((crop[2] - crop[0]) * self.sources[i].width, 1e-9)

    def _cut(self, i: int, crop: np.ndarray, flip: bool, width: int, height: int
             ) -> np.ndarray:
        """The crop (x0, y0, x1, y1 fractions) of frame ``i``, flipped left-right when
        ``flip``, resized to ``width`` x ``height``."""
        s = self.sources[i]
        # downscaled as far as the smallest crop of this frame still needs
        need = width / (MIN_CROP * min(s.width, s.height * width / height))
        scale = min(1.0, 2.0 ** np.ceil(np.log2(max(need, 1e-9))))
        img = self._frame(i, float(scale))
        ph, pw = img.shape[:2]
        x0, y0, x1, y1 = crop * np.array([pw, ph, pw, ph])
        # at least one pixel each way (a crop under a pixel high, e.g. a 9 x 1 output, would
        # otherwise be empty)
        cut = img[int(y0):max(int(y1), int(y0) + 1), int(x0):max(int(x1), int(x0) + 1)]
        if flip:
            cut = cut[:, ::-1]
        interp = cv2.INTER_AREA if cut.shape[1] > width else cv2.INTER_LINEAR
        return cv2.resize(np.ascontiguousarray(cut), (width, height), interpolation=interp)


def _widened(boxes: np.ndarray, width: int, height: int) -> np.ndarray:
    """(k, 4) x0, y0, x1, y1 frame fractions of (k, 4) x, y, w, h pixel boxes widened by
    :data:`BOX_MARGIN` of their size and :data:`BOX_MARGIN_PX` on each side."""
    x, y, w, h = boxes.T
    mx, my = BOX_MARGIN * w + BOX_MARGIN_PX, BOX_MARGIN * h + BOX_MARGIN_PX
    return np.stack([(x - mx) / width, (y - my) / height, (x + w + mx) / width,
                     (y + h + my) / height], axis=1)


def _covered(boxes: np.ndarray, crop: np.ndarray) -> float:
    """The area (frame fractions squared) of ``boxes`` (k, 4) inside ``crop`` (4,), both
    x0, y0, x1, y1."""
    if not len(boxes):
        return 0.0
    w = np.clip(np.minimum(boxes[:, 2], crop[2]) - np.maximum(boxes[:, 0], crop[0]), 0, None)
    h = np.clip(np.minimum(boxes[:, 3], crop[3]) - np.maximum(boxes[:, 1], crop[1]), 0, None)
    return float((w * h).sum())


def _paint(image: np.ndarray, boxes: np.ndarray, crop: np.ndarray, flip: bool) -> np.ndarray:
    """``image`` (the crop ``crop`` of a frame, flipped when ``flip``) with the labelled
    ``boxes`` (frame fractions) in it painted over from the surrounding water."""
    h, w = image.shape[:2]
    cx0, cy0, cx1, cy1 = crop
    mask = np.zeros((h, w), np.uint8)
    for x0, y0, x1, y1 in boxes:
        u0, u1 = (x0 - cx0) / (cx1 - cx0) * w, (x1 - cx0) / (cx1 - cx0) * w
        v0, v1 = (y0 - cy0) / (cy1 - cy0) * h, (y1 - cy0) / (cy1 - cy0) * h
        if flip:
            u0, u1 = w - u1, w - u0
        mask[max(0, int(np.floor(v0))):max(0, int(np.ceil(v1))),
             max(0, int(np.floor(u0))):max(0, int(np.ceil(u1)))] = 255
    if not mask.any():
        return image
    if mask.all():  # nothing but labelled objects: no water to paint from
        fill = np.median(image.reshape(-1, 3), axis=0).astype(np.uint8)
        return np.broadcast_to(fill, image.shape).copy()
    return cv2.inpaint(image, mask, 5, cv2.INPAINT_TELEA)
