"""The two sides of ``bench sim2real``: generated training data of any categories, the
user's labelled real frames, and which generated category is which real one.

- :func:`training_data`: one or more generated dataset folders (read by
  :func:`sdcomp.io.layout.load_dataset`), their categories merged by name into detector
  classes 1..K; the train split to train on, the val split as the synthetic reference.
- :func:`real_frames`: the user's frames (photos and videos, :mod:`sdcomp.render.footage`)
  and their labels (a COCO json file or a YOLO labels folder) as a COCO ground truth at the
  frames' own size. The frames scored are those the labels name; a YOLO folder's photos
  without a label file are scored as frames with no objects (Ultralytics' convention).
- :func:`category_map`: generated category -> real category, by name (case-insensitive),
  with ``--map GEN=REAL`` overrides.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import UserError
from ..io.layout import load_dataset
from ..render.footage import Source, list_sources
from ..render.footage_labels import read_labels


@dataclass
class TrainData:
    """Generated training data: ``names`` (K,) class names (class k + 1 = ``names[k]``),
    ``items`` (path, boxes (n, 4) float32 x0, y0, x1, y1 px, labels (n,) int64 classes) per
    training image, ``val`` a COCO dict of the val split (class ids as category ids, each
    image with its ``path``, ``area`` the box's, as for the real frames, which have no
    masks), ``key`` 12 hex digits identifying the data, and the folders."""

    folders: list[Path]
    names: list[str]
    items: list = field(default_factory=list)
    val: dict = field(default_factory=dict)
    key: str = ""

    def boxes(self, classes: set[int]) -> np.ndarray:
        """(n, 4) x0, y0, x1, y1 pixels of the training boxes of ``classes``."""
        out = [b[np.isin(lab, list(classes))] for _, b, lab in self.items]
        return np.concatenate(out) if out else np.zeros((0, 4))

    def box_sides(self, classes: set[int]) -> np.ndarray:
        """(n,) sqrt(w h) of the training boxes of ``classes``, pixels."""
        b = self.boxes(classes)
        return np.sqrt((b[:, 2] - b[:, 0]) * (b[:, 3] - b[:, 1]))

    def box_aspects(self, classes: set[int]) -> np.ndarray:
        """(n,) height / width of the training boxes of ``classes``."""
        b = self.boxes(classes)
        return (b[:, 3] - b[:, 1]) / np.maximum(b[:, 2] - b[:, 0], 1e-6)

    @property
    def image_size(self) -> int:
        """The largest side of the generated images, pixels."""
        sides = [max(im["width"], im["height"]) for im in self.val.get("images", [])]
        return max(sides, default=416)


def training_data(folders: list[str | Path]) -> TrainData:
    """The train and val splits of generated dataset folders (UserError when a folder is not
    a dataset or the train split has no images)."""
    names: list[str] = []
    items: list = []
    val: dict = {"images": [], "annotations": [], "categories": []}
    digest = hashlib.sha256()
    for folder in map(Path, folders):
        data = load_dataset(folder)
        digest.update(json.dumps(data.layout.run_config(), sort_keys=True).encode())
        digest.update(f"{len(data.entries)}".encode())
        cls = {}
        for cid, name in sorted(data.categories.items()):
            if name not in names:
                names.append(name)
            cls[cid] = names.index(name) + 1
        for e in data.entries:
            path = str((folder / "images" / e.image["file_name"]).resolve())
            anns = [a for a in e.annotations if a.get("category_id") in cls
                    and a["bbox"][2] > 0 and a["bbox"][3] > 0]
            if e.split == "val":
                image_id = len(val["images"]) + 1
                val["images"].append({**e.image, "id": image_id, "path": path})
                for a in anns:
                    x, y, w, h = a["bbox"]
                    val["annotations"].append({
                        "id": len(val["annotations"]) + 1, "image_id": image_id,
                        "category_id": cls[a["category_id"]], "bbox": [x, y, w, h],
                        "area": float(w * h), "iscrowd": 0})  # box area, as the real
                continue
            boxes = np.asarray([[a["bbox"][0], a["bbox"][1], a["bbox"][0] + a["bbox"][2],
                                 a["bbox"][1] + a["bbox"][3]] for a in anns],
                               np.float32).reshape(-1, 4)
            labels = np.asarray([cls[a["category_id"]] for a in anns], np.int64)
            items.append((path, boxes, labels))
    if not items:
        raise UserError(f"--train {', '.join(map(str, folders))}: no images in the train "
                        f"split; generate more images (or a lower --val-fraction)")
    val["categories"] = [{"id": k + 1, "name": n} for k, n in enumerate(names)]
    return TrainData([Path(f) for f in folders], names, items, val,
                     digest.hexdigest()[:12])


@dataclass
class RealSet:
    """The user's labelled frames: ``sources[k]`` is COCO image ``k + 1`` of ``coco``
    (boxes in the frame's own pixels, ``area`` = w h), ``categories`` {id: name}."""

    label: str
    sources: list[Source]
    coco: dict
    categories: dict[int, str]

    def box_sides(self, category_ids: set[int]) -> np.ndarray:
        """(n,) float64 sqrt(w h) of the labelled boxes of ``category_ids``, pixels."""
        return np.asarray([np.sqrt(a["area"]) for a in self.coco["annotations"]
                           if a["category_id"] in category_ids], np.float64)

    def box_aspects(self, category_ids: set[int]) -> np.ndarray:
        """(n,) float64 height / width of the labelled boxes of ``category_ids``."""
        return np.asarray([a["bbox"][3] / max(a["bbox"][2], 1e-6)
                           for a in self.coco["annotations"]
                           if a["category_id"] in category_ids], np.float64)


def real_frames(path: str | Path, labels: str | Path) -> RealSet:
    """The labelled real frames at ``path`` with ``labels`` (UserError naming the flag
    when none of them match or a file is bad)."""
    sources = list_sources(path, "--real")
    lab = read_labels(labels, "--real-labels")
    images: list[dict] = []
    anns: list[dict] = []
    chosen: list[Source] = []
    for s in sources:
        fl = lab.of(s.key)
        if fl is None and not (lab.kind == "yolo" and s.frame is None):
            continue
        chosen.append(s)
        image_id = len(chosen)
        images.append({"id": image_id, "file_name": s.key, "width": s.width,
                       "height": s.height})
        if fl is None:
            continue
        for (x, y, w, h), c in zip(fl.pixels(s.width, s.height), fl.categories, strict=True):
            x0, y0 = max(float(x), 0.0), max(float(y), 0.0)
            x1, y1 = min(float(x + w), s.width), min(float(y + h), s.height)
            if x1 - x0 > 0 and y1 - y0 > 0:
                anns.append({"id": len(anns) + 1, "image_id": image_id,
                             "category_id": int(c), "bbox": [x0, y0, x1 - x0, y1 - y0],
                             "area": (x1 - x0) * (y1 - y0), "iscrowd": 0})
    if not chosen:
        raise UserError(f"--real-labels {labels}: none of its {len(lab.frames)} labelled "
                        f"frames is in --real {path}; frames are matched by file name "
                        f"without extension (video frames: <video name>_<frame:06d>)")
    cats = [{"id": i, "name": n} for i, n in sorted(lab.categories.items())]
    label = f"real ({Path(labels).name}, {len(chosen)} frames, {len(anns)} boxes)"
    return RealSet(label, chosen, {"images": images, "annotations": anns,
                                   "categories": cats}, dict(lab.categories))


def category_map(generated: list[str], real: dict[int, str], overrides: list[str]
                 ) -> dict[int, int]:
    """{detector class (1..K of ``generated``): real category id} by name, case-insensitive;
    ``overrides`` ``GEN=REAL`` pairs of names win. UserError for an unknown name, two
    classes mapped to one real category, or no pair at all."""
    real_by_name: dict[str, int] = {}
    for cid, name in real.items():
        real_by_name.setdefault(name.strip().lower(), cid)
    gen_by_name = {n.strip().lower(): k + 1 for k, n in enumerate(generated)}
    pairs = {gen_by_name[n]: real_by_name[n] for n in gen_by_name if n in real_by_name}
    for text in overrides:
        g, sep, r = text.partition("=")
        g, r = g.strip().lower(), r.strip().lower()
        if not sep or g not in gen_by_name or r not in real_by_name:
            raise UserError(
                f"--map {text!r}: use GEN=REAL with a generated category "
                f"({', '.join(generated)}) and a real one "
                f"({', '.join(sorted(real.values())) or 'none'})")
        pairs[gen_by_name[g]] = real_by_name[r]
    if not pairs:
        raise UserError(
            f"no generated category ({', '.join(generated)}) has the name of a real one "
            f"({', '.join(sorted(real.values())) or 'none'}); say which is which with "
            f"--map GEN=REAL")
    seen: dict[int, int] = {}
    for k, cid in sorted(pairs.items()):
        if cid in seen:
            raise UserError(f"--map: generated {generated[seen[cid] - 1]!r} and "
                            f"{generated[k - 1]!r} both map to real {real[cid]!r}; map one "
                            f"generated category to each real one")
        seen[cid] = k
    return pairs
