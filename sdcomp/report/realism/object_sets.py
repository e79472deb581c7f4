"""Per-object statistics (:mod:`.objects`) of a whole set: a generated dataset or real frames
with labels, read by :mod:`.sources`.

    from sdcomp.report.realism import object_statistics
    stats = object_statistics("dataset/")   # {category: {"count", "contrast": {...}, ...}}
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .objects import MIN_SIZE, STATS, box_statistics, record_gsd, summarise
from .sources import Frame, FrameSet, frame_painted, frame_rgb, load_generated


@dataclass
class ObjectTable:
    """The measured boxes of a set, one row each (boxes not measured are left out).

    Attributes:
        values: (n, len(STATS)) float64 (:func:`.objects.box_statistics`).
        categories: (n,) category names.
        frames: (n,) int64 index of each row's frame in the set's ``frames``.
        boxes: (n, 4) float64 x, y, w, h pixels.
        gsd: (n,) float64 metres per pixel at the box centre (NaN: unknown).
        images_read, unreadable: images measured and those that could not be read.
        boxes_total: boxes listed in the images read; seconds: time taken.
    """

    values: np.ndarray
    categories: list
    frames: np.ndarray
    boxes: np.ndarray
    gsd: np.ndarray
    images_read: int = 0
    unreadable: int = 0
    boxes_total: int = 0
    seconds: float = 0.0
    gsd_how: dict = field(default_factory=dict)

    def summary(self) -> dict[str, dict]:
        """Per category: :func:`.objects.summarise`."""
        return summarise(self.values, self.categories)

    def info(self, frames: FrameSet) -> dict:
        """How the set was measured (JSON-ready)."""
        return {"folder": str(frames.folder), "kind": frames.kind, "images": len(frames.frames),
                "images_read": self.images_read, "unreadable": self.unreadable,
                "boxes": self.boxes_total, "measured": int(len(self.values)),
                "size_m_known": int(np.isfinite(self.gsd).sum()), "gsd": dict(self.gsd_how),
                "notes": list(frames.notes), "seconds": round(self.seconds, 2)}


def frame_box_gsd(frame: Frame, boxes: np.ndarray) -> tuple[np.ndarray, str]:
    """((k,) float64 metres per pixel at each box centre, NaN where unknown; how it is known):
    ``--real-gsd`` for every box, else the frame's camera record (generated images; real
    ones whose meta and ``--real-fov`` give the pose), else the frame's centre GSD, else
    unknown."""
    k = len(boxes)
    if frame.gsd is not None and frame.gsd_source == "user":
        return np.full(k, float(frame.gsd)), "--real-gsd"
    g = record_gsd(frame.camera, boxes) if frame.camera else None
    if g is not None:
        return g, "camera at the box centre"
    if frame.gsd:
        return np.full(k, float(frame.gsd)), "image centre"
    return np.full(k, np.nan), "unknown"


def measure_objects(frames: FrameSet, min_size: float = MIN_SIZE, log=None,
                    exclude_others: bool = True) -> ObjectTable:
    """Measure every labelled box of a set (:func:`.objects.box_statistics`, with
    ``exclude_others``; a real frame's painted-out regions, :func:`.sources.frame_painted`,
    are no box's water); frames without boxes contribute nothing but are counted as read."""
    t0 = time.perf_counter()
    say = log or (lambda msg: None)
    vals, cats, idx, bxs, gsds = [], [], [], [], []
    read = bad = total = 0
    how: dict[str, int] = {}
    for i, frame in enumerate(frames.frames):
        boxes = np.asarray(frame.boxes or [], np.float64).reshape(-1, 4)
        if not len(boxes):
            read += 1
            continue
        rgb = frame_rgb(frame)
        if rgb is None:
            bad += 1
            continue
        read += 1
        total += len(boxes)
        names = list(frame.categories or [])
        names += ["?"] * (len(boxes) - len(names))
        g, why = frame_box_gsd(frame, boxes)
        how[why] = how.get(why, 0) + 1
        painted = frame_painted(frame, rgb)
        v = box_statistics(rgb, boxes, g, min_size, exclude_others,
                           None if painted is None else ~painted)
        keep = np.flatnonzero(~np.isnan(v).all(axis=1))
        vals.append(v[keep])
        cats += [str(names[j]) for j in keep]
        idx.append(np.full(len(keep), i, np.int64))
        bxs.append(boxes[keep])
        gsds.append(g[keep])
        if (i + 1) % 100 == 0:
            say(f"{frames.kind}: {i + 1}/{len(frames.frames)} images measured")
    return ObjectTable(_stack(vals, (0, len(STATS))), cats, _stack(idx, 0).astype(np.int64),
                       _stack(bxs, (0, 4)), _stack(gsds, 0), read, bad, total,
                       time.perf_counter() - t0, how)


def _stack(parts: list, empty) -> np.ndarray:
    return np.concatenate(parts) if parts else np.zeros(empty)


def object_statistics(folder: str | Path, max_images: int | None = None,
                      min_size: float = MIN_SIZE, seed: int = 0,
                      exclude_others: bool = True) -> dict[str, dict]:
    """Per-category object statistics of a generated dataset folder.

    Args:
        folder: a finished ``sdcomp generate --out`` folder (every split).
        max_images: at most this many images, a seeded random choice (None: all).
        min_size: boxes with sqrt(w h) below this many pixels are left out.
        seed: seed of the image choice.
        exclude_others: True (the definition): the other labelled boxes in a box's window
            are not its surrounding water; False: they are (only the box itself is not).
    Returns:
        {category: {"count": boxes measured, stat: {"median", "p10", "p90", "n"}}} for each
        stat of :data:`.objects.STATS` (contrast, dark_share, bright_share, aspect,
        saturation, size_px, size_m, size_image_px); see :func:`.objects.summarise`.
    UserError for a folder that is not a dataset."""
    return measure_objects(load_generated(folder, max_images, seed), min_size,
                           exclude_others=exclude_others).summary()
