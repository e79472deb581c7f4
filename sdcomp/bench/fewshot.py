"""``bench fewshot``: how many real frames does sdcomp save you?

The user's labelled real frames are split into a training pool and a held-out test set
(:func:`split`: by source photo or video, so near-copies never straddle the split; stable:
a group's side depends on its name only). For each K and seed, four arms train the same
detector (``bench sim2real``'s, at the frames' own size) and are scored on the test set:

- ``real``: K real frames alone (none at K = 0);
- ``synthetic``: the generated data alone (one training per seed, the same for every K);
- ``finetune``: the synthetic detector fine-tuned on the same K frames;
- ``mixed``: generated data and the same K frames in one training, the real frames
  repeated so that a share ``ratio`` of the training images are real.

Each finished cell is kept in ``OUT/cells/`` (its checkpoint and its scores): a run stopped
part-way resumes there. ``OUT/fewshot.json`` holds every score, ``report.md`` the table of
AP50 by K and arm (mean and spread over the seeds), ``fewshot.png`` the plot.
"""

from __future__ import annotations

import hashlib
import json
import math
import re
import time
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from .. import __version__
from ..errors import UserError
from ..render.footage import Source
from ..util.files import atomic_write_bytes
from .fewshot_report import plot, render_markdown
from .realdata import RealSet, category_map, real_frames, training_data
from .sim2real import score_real
from .train import TrainConfig, train, train_key

ARMS = ("real", "synthetic", "finetune", "mixed")
#: a Roboflow tile's name (``<photo>_jpg.rf.<hash>``), a frame or tile number (``_0042``)
_TILE = re.compile(r"(_(jpg|jpeg|png)\.rf\.[0-9a-f]+|[_-]\d+)$", re.IGNORECASE)


@dataclass(frozen=True)
class FewshotSpec:
    """What ``bench fewshot`` runs (see the module docstring): ``ks`` the K values (None:
    the whole pool), ``seeds`` at least one, ``test_share`` of the source groups held out,
    ``ratio`` the real share of the mixed arm's images, ``finetune_iter`` the fine-tuning's
    iterations (None: half of ``config.max_iter``)."""

    train: tuple[Path, ...]
    real: Path
    real_labels: Path
    out: Path
    ks: tuple[int | None, ...] = (0, 10, 25, 50, None)
    seeds: tuple[int, ...] = (0, 1)
    test_share: float = 0.3
    ratio: float = 0.25
    finetune_iter: int | None = None
    maps: tuple[str, ...] = ()
    config: TrainConfig = field(default_factory=TrainConfig)
    device: str = "cpu"
    progress: bool | None = None

    def __post_init__(self) -> None:
        if not self.ks or any(k is not None and not 0 <= k <= 100_000 for k in self.ks):
            raise UserError(f"--k {self.ks}: give K values 0 to 100000 (or 'all')")
        if not self.seeds:
            raise UserError("--seeds: give at least one seed")
        if not 0 < self.test_share < 1:
            raise UserError(f"--test-share {self.test_share} is out of range: use 0 to 1")
        if not 0 < self.ratio < 1:
            raise UserError(f"--ratio {self.ratio} is out of range: use the real share of "
                            f"the mixed arm, 0 to 1")


def group_of(source: Source) -> str:
    """The source group of a frame: its video, or its photo's name without a tile or frame
    suffix (tiles of one photo, frames extracted from one video are one group)."""
    if source.frame is not None:
        return source.path.name
    return _TILE.sub("", source.path.stem)


def split(sources: list[Source], test_share: float) -> tuple[list[int], list[int]]:
    """(pool, test) indices into ``sources``: each group (:func:`group_of`) goes to the test
    set when its name hashes below ``test_share``; stable (the name alone decides) and
    disjoint by group. UserError when either side would be empty."""
    def fraction(g: str) -> float:
        return int(hashlib.sha256(g.encode()).hexdigest()[:12], 16) / 16 ** 12
    groups = [group_of(s) for s in sources]
    test = [i for i, g in enumerate(groups) if fraction(g) < test_share]
    pool = [i for i, g in enumerate(groups) if fraction(g) >= test_share]
    if not test or not pool:
        raise UserError(f"--real: its {len(sources)} frames form {len(set(groups))} source "
                        f"groups (photos or videos), too few to hold some out for testing "
                        f"at --test-share {test_share}; give frames of more photos or videos")
    return pool, test


def subset(real: RealSet, indices: list[int]) -> RealSet:
    """The frames ``indices`` of ``real`` as a RealSet of their own (images renumbered)."""
    images: list[dict] = []
    anns: list[dict] = []
    sources: list[Source] = []
    for new, i in enumerate(indices, 1):
        im = real.coco["images"][i]
        images.append({**im, "id": new})
        anns += [{**a, "id": len(anns) + 1, "image_id": new} for a in real.coco["annotations"]
                 if a["image_id"] == im["id"]]
        sources.append(real.sources[i])
    return RealSet(f"{len(indices)} of {real.label}", sources,
                   {"images": images, "annotations": anns,
                    "categories": real.coco["categories"]}, real.categories)


def real_items(real: RealSet, classes: dict[int, int]) -> list:
    """Training items (path, boxes (n, 4) float32 x0, y0, x1, y1, labels (n,) int64) of the
    frames of ``real``, categories mapped to detector classes by ``classes`` (real category
    -> class; boxes of other categories dropped). UserError for a video frame (train on
    photos: extract the frames)."""
    out = []
    for k, s in enumerate(real.sources):
        if s.frame is not None:
            raise UserError(f"--real {s.path}: bench fewshot trains on photos; extract the "
                            f"video's frames first (ffmpeg -i {s.path.name} f_%06d.png)")
        anns = [a for a in real.coco["annotations"]
                if a["image_id"] == k + 1 and a["category_id"] in classes]
        boxes = np.asarray([[x, y, x + w, y + h] for x, y, w, h in (a["bbox"] for a in anns)],
                           np.float32).reshape(-1, 4)
        out.append((str(s.path), boxes,
                    np.asarray([classes[a["category_id"]] for a in anns], np.int64)))
    return out


def run_fewshot(spec: FewshotSpec, log=print) -> dict:
    """Every cell (arm, K, seed), resumed where ``OUT/cells`` holds it; writes OUT's files
    and returns the contents of ``fewshot.json``. Every input is checked first."""
    t0 = time.perf_counter()
    data = training_data(list(spec.train))
    real = real_frames(spec.real, spec.real_labels)
    mapping = category_map(data.names, real.categories, list(spec.maps))
    pool_idx, test_idx = split(real.sources, spec.test_share)
    test = subset(real, test_idx)
    classes = {c: k for k, c in mapping.items()}
    ks = sorted({len(pool_idx) if k is None else min(k, len(pool_idx)) for k in spec.ks})
    if spec.out.exists() and not spec.out.is_dir():
        raise UserError(f"--out {spec.out} is a file; give a folder")
    cells = [(arm, k, s) for s in spec.seeds for k in ks for arm in ARMS
             if not (k == 0 and arm != "synthetic")]
    log(f"fewshot: {len(pool_idx)} pool and {len(test_idx)} test frames (by source), "
        f"K = {', '.join(map(str, ks))}, seeds {', '.join(map(str, spec.seeds))}: "
        f"{len(cells)} trainings")
    rows = []
    for n, (arm, k, seed) in enumerate(cells, 1):
        pick = [pool_idx[i] for i in np.random.default_rng([seed, 0xF5]).permutation(
            len(pool_idx))[:k]]
        row = _cell(spec, data, subset(real, sorted(pick)), test, mapping, classes, arm, k,
                    seed)
        rows.append(row)
        m = row["metrics"]
        log(f"[{n}/{len(cells)}] {arm} K={k} seed {seed}: AP50 {m['AP50']:.4f} "
            f"AP {m['AP']:.4f} AR100 {m['AR100']:.4f}")
    result = {"format": "sdcomp-fewshot", "sdcomp": __version__, "device": spec.device,
              "train": [str(f) for f in data.folders], "real": str(spec.real),
              "labels": str(spec.real_labels), "pool": len(pool_idx), "test": len(test_idx),
              "test_boxes": len(test.coco["annotations"]), "ks": ks,
              "seeds": list(spec.seeds), "ratio": spec.ratio,
              "config": spec.config.to_dict(), "cells": rows,
              "wall_s": round(time.perf_counter() - t0, 1)}
    spec.out.mkdir(parents=True, exist_ok=True)
    plot(result, spec.out / "fewshot.png")
    atomic_write_bytes(spec.out / "fewshot.json", (json.dumps(result, indent=1) + "\n").encode())
    atomic_write_bytes(spec.out / "report.md", render_markdown(result).encode())
    return result


def _cell(spec: FewshotSpec, data, chosen: RealSet, test: RealSet, mapping: dict,
          classes: dict, arm: str, k: int, seed: int) -> dict:
    """Train (or resume, or read back) one cell and score it on ``test``."""
    folder = spec.out / "cells" / (f"synthetic_s{seed}" if arm == "synthetic"
                                   else f"{arm}_k{k}_s{seed}")
    config = replace(spec.config, seed=seed)
    items = real_items(chosen, classes)
    if arm == "synthetic":
        items = list(data.items)
    elif arm == "mixed":
        reps = max(1, math.ceil(spec.ratio / (1 - spec.ratio) * len(data.items) / len(items)))
        items = list(data.items) + items * reps
    elif arm == "finetune":
        base = spec.out / "cells" / f"synthetic_s{seed}" / "checkpoint.pt"
        config = replace(config, weights=str(base),
                         max_iter=spec.finetune_iter or max(1, config.max_iter // 2),
                         warmup_iters=0)
    names = [str(s.path.name) for s in chosen.sources]
    key = train_key(config, [data.key, arm, *(names if arm != "synthetic" else [])],
                    data.image_size)
    done = folder / "scores.json"
    if done.exists():
        kept = json.loads(done.read_text())
        if kept.get("key") == key:
            return {**kept, "k": k}  # the synthetic cell stands at every K
    model, history = train(config, items, data.image_size, folder / "checkpoint.pt", key,
                           spec.device, spec.progress, num_classes=len(data.names),
                           native=True)
    metrics, _ = score_real(model, test, mapping, spec.device)
    row = {"arm": arm, "k": k, "seed": seed, "key": key, "images": len(items),
           "metrics": metrics["bands"]["all"], "categories": metrics.get("categories", {}),
           "train_s": history["wall_s"]}
    atomic_write_bytes(done, (json.dumps(row, indent=1) + "\n").encode())
    return row
