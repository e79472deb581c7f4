"""``bench sim2real``: how good is generated data for YOUR object on YOUR frames?

Train a detector on generated datasets (any categories), then score it on the user's
labelled real frames at their own resolution (:func:`.adapt.native_resolution`: nothing is
resized), by size band (:func:`.evaluate.banded_metrics`); then score the same weights again
after re-estimating their BatchNorm statistics on unlabelled real frames
(:func:`.adapt.reestimate_batchnorm`). The synthetic val split is scored too, as the
reference the real score is compared with. :func:`diagnose` turns the three AP50s into the
verdict the report prints:

- synthetic val AP50 under :data:`MIN_LEARNT`: the detector has not learnt the generated
  data yet (nothing can be concluded);
- real AP50 within :data:`TRANSFER_GAP` of the synthetic one: the data transfers;
- BatchNorm re-estimation recovers at least half of the gap: **the scene does not look
  real** (the water, light and camera: the frames' global statistics), not the object;
- otherwise: **the object does not look real** (or differs in size, pose or context), since
  even with the real frames' statistics the detector misses it.

Results in OUT/: ``sim2real.json`` (everything), ``report.md``, ``detections.jpg`` (real
frames with their labels and the detections before and after re-estimation) and
``checkpoint.pt`` (the training's resume point: an interrupted run continues).
"""

from __future__ import annotations

import json
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .. import __version__
from ..errors import UserError
from ..render.footage import VideoReader, list_sources, read_source
from ..util.files import atomic_write_bytes
from .adapt import batchnorm_layers, reestimate_batchnorm
from .detector import predict
from .evaluate import banded_metrics
from .realdata import RealSet, TrainData, category_map, real_frames, training_data
from .sim2real_report import detections_figure, render_markdown
from .train import TrainConfig, read_image, train, train_key

TRANSFER_GAP = 0.1  #: real AP50 this close to the synthetic one counts as transferring
MIN_LEARNT = 0.3  #: below this synthetic val AP50 the detector is not trained enough to judge
SIZE_RATIO = 1.5  #: median object sizes further apart than this are flagged
#: median box aspects (height / width) further apart than this are flagged: a frame of
#: another aspect than the sensor's is the sensor image resized, which stretches every
#: object (a 3:2 sensor in a square frame draws boxes 1.5x as tall for their width as its
#: photos show them)
ASPECT_RATIO = 1.25
ASPECT_MIN_BOXES = 5  #: boxes a category needs on each side for its aspects to be compared
UNLABELLED_MAX = 200  #: unlabelled frames used for BatchNorm re-estimation, at most


@dataclass(frozen=True)
class Sim2RealSpec:
    """What ``bench sim2real`` runs: ``train`` generated dataset folders, ``real`` frames
    with ``real_labels``, ``maps`` GEN=REAL overrides, ``unlabelled`` frames for BatchNorm
    re-estimation (None: the real frames, their labels unused), results in ``out``."""

    train: tuple[Path, ...]
    real: Path
    real_labels: Path
    out: Path
    maps: tuple[str, ...] = ()
    unlabelled: Path | None = None
    unlabelled_max: int = UNLABELLED_MAX
    config: TrainConfig = field(default_factory=TrainConfig)
    device: str = "cpu"
    progress: bool | None = None
    overwrite: bool = False
    score_threshold: float = 0.5


def run_sim2real(spec: Sim2RealSpec, log=print) -> dict:
    """Train, score before and after BatchNorm re-estimation, write OUT's files; returns
    the contents of ``sim2real.json``. Every input is checked before training starts."""
    t0 = time.perf_counter()
    if not 1 <= spec.unlabelled_max <= 100_000:
        raise UserError(f"--unlabelled-max {spec.unlabelled_max} is out of range: use 1 to "
                        f"100000 frames")
    data = training_data(list(spec.train))
    real = real_frames(spec.real, spec.real_labels)
    mapping = category_map(data.names, real.categories, list(spec.maps))
    unlabelled = _unlabelled(spec, real)
    sizes = _sizes(data, real, mapping)
    if spec.out.exists() and not spec.out.is_dir():
        raise UserError(f"--out {spec.out} is a file; give a folder")
    log(f"sim2real: {len(data.items)} generated training images ({', '.join(data.names)}), "
        f"{real.label}; scored: " + ", ".join(f"{data.names[k - 1]}={real.categories[c]}"
                                             for k, c in sorted(mapping.items())))
    if sizes["note"]:
        log(f"warning: {sizes['note']}")
    ckpt = spec.out / "checkpoint.pt"
    if spec.overwrite and ckpt.exists():
        ckpt.unlink()
    key = train_key(spec.config, [data.key, "sim2real-native", *data.names], data.image_size)
    model, history = train(spec.config, data.items, data.image_size, ckpt, key, spec.device,
                           spec.progress, num_classes=len(data.names), native=True)
    t_train = time.perf_counter()
    before, dets_before = score_real(model, real, mapping, spec.device)
    adapted, n_frames = reestimate_batchnorm(
        model, (read_source(s, _VIDEOS, "--unlabelled") for s in unlabelled), spec.device)
    after, dets_after = score_real(adapted, real, mapping, spec.device)
    val = score_val(model, data, spec.device)
    result: dict = {
        "format": "sdcomp-sim2real", "sdcomp": __version__, "device": spec.device,
        "train": {"folders": [str(f) for f in data.folders], "images": len(data.items),
                  "classes": data.names, "key": key, "config": spec.config.to_dict(),
                  "losses": history["losses"], "resumed_from": history["resumed_from"]},
        "real": {"label": real.label, "frames": len(real.sources),
                 "boxes": len(real.coco["annotations"]), "path": str(spec.real),
                 "labels": str(spec.real_labels)},
        "mapping": {data.names[k - 1]: real.categories[c] for k, c in sorted(mapping.items())},
        "sizes": sizes, "batchnorm": {"layers": batchnorm_layers(model),
                                      "frames": n_frames, "source": str(
                                          spec.unlabelled or spec.real)},
        "synthetic_val": val, "real_before": before, "real_after": after,
        "categories": {data.names[k - 1]: c for k, c in sorted(mapping.items())},
        "wall_s": {"training": round(history["wall_s"], 1),
                   "scoring": round(time.perf_counter() - t_train, 1)},
    }
    result["verdict"] = diagnose(val, before, after)
    spec.out.mkdir(parents=True, exist_ok=True)
    detections_figure(spec.out / "detections.jpg", real, _VIDEOS, dets_before, dets_after,
                      spec.score_threshold)
    result["wall_s"]["total"] = round(time.perf_counter() - t0, 1)
    atomic_write_bytes(spec.out / "sim2real.json",
                       (json.dumps(result, indent=1) + "\n").encode())
    atomic_write_bytes(spec.out / "report.md", render_markdown(result).encode())
    return result


_VIDEOS = VideoReader("--real")


def _unlabelled(spec: Sim2RealSpec, real: RealSet) -> list:
    """The frames BatchNorm statistics are re-estimated on: at most ``unlabelled_max`` of
    ``spec.unlabelled`` (evenly spaced through them) or else the real frames."""
    if spec.unlabelled is None:
        return real.sources[:spec.unlabelled_max]
    sources = list_sources(spec.unlabelled, "--unlabelled")
    if len(sources) > spec.unlabelled_max:
        pick = np.linspace(0, len(sources) - 1, spec.unlabelled_max).round().astype(int)
        sources = [sources[i] for i in pick]
    return sources


def _sizes(data: TrainData, real: RealSet, mapping: dict[int, int]) -> dict:
    """Object sizes (sqrt of the box area, pixels) and box aspects (height / width) of the
    scored categories: the medians, the generated 2nd-98th percentile size range and the
    fraction of real objects inside it, and a note when the median sizes differ by more than
    :data:`SIZE_RATIO`, a quarter of the real objects lie outside that range or a
    category's median aspects (each side with at least :data:`ASPECT_MIN_BOXES` boxes)
    differ by more than :data:`ASPECT_RATIO`."""
    gen = data.box_sides(set(mapping))
    rl = real.box_sides(set(mapping.values()))
    if not gen.size or not rl.size:
        return {"generated_median_px": None, "real_median_px": None, "note": ""}
    g, r = float(np.median(gen)), float(np.median(rl))
    lo, hi = (float(v) for v in np.percentile(gen, [2, 98]))
    inside = float(np.mean((rl >= lo) & (rl <= hi)))
    notes = []
    if max(g / r, r / g) > SIZE_RATIO:
        notes.append(f"the objects are {r:.0f} px (median) in the real frames but {g:.0f} px "
                     f"in the generated ones")
    if inside < 0.75:
        notes.append(f"{100 * (1 - inside):.0f} % of the real objects are outside the "
                     f"generated sizes ({lo:.0f}-{hi:.0f} px)")
    aspects = {}
    for k, c in sorted(mapping.items()):
        gen_a, real_a = data.box_aspects({k}), real.box_aspects({c})
        if min(gen_a.size, real_a.size) >= ASPECT_MIN_BOXES:
            aspects[data.names[k - 1]] = {"generated": float(np.median(gen_a)),
                                          "real": float(np.median(real_a))}
    off = [f"{name} {a['real']:.2f} real, {a['generated']:.2f} generated"
           for name, a in aspects.items()
           if max(a["generated"] / a["real"], a["real"] / a["generated"]) > ASPECT_RATIO]
    if off:
        notes.append(f"the boxes' median height / width differs ({'; '.join(off)}): a frame "
                     f"of another aspect than the camera's sensor stretches the objects; "
                     f"give --width and --height the real frames' aspect")
    note = "; ".join(notes)
    if note:
        note += (": the detector is scored on sizes and shapes it was not trained on; "
                 "generate at the real frames' altitude, camera and image size")
    return {"generated_median_px": g, "real_median_px": r, "generated_range_px": [lo, hi],
            "real_inside_range": inside, "aspects": aspects, "note": note}


def _detections(model, arrays: list[np.ndarray], device: str) -> list:
    """Per image, predict one at a time (the images may differ in size)."""
    return [predict(model, [a], device, 1)[0] for a in arrays]


def score_real(model, real: RealSet, mapping: dict[int, int], device: str
               ) -> tuple[dict, list]:
    """Banded metrics of ``model`` on the real frames (classes mapped to real categories;
    unmapped classes' detections dropped) and the detections per frame (boxes (K, 4) x0, y0,
    x1, y1 px, scores (K,), real category ids (K,))."""
    per_frame = []
    dets: list[dict] = []
    for k, s in enumerate(real.sources):
        boxes, scores, labels = _detections(model, [read_source(s, _VIDEOS, "--real")],
                                            device)[0]
        keep = np.isin(labels, list(mapping))
        cats = np.asarray([mapping[int(c)] for c in labels[keep]], np.int64)
        per_frame.append((boxes[keep], scores[keep], cats))
        for (x0, y0, x1, y1), sc, c in zip(boxes[keep], scores[keep], cats, strict=True):
            dets.append({"image_id": k + 1, "category_id": int(c), "score": float(sc),
                         "bbox": [float(x0), float(y0), float(x1 - x0), float(y1 - y0)]})
    return banded_metrics(real.coco, dets, sorted(mapping.values())), per_frame


def score_val(model, data: TrainData, device: str) -> dict | None:
    """Banded metrics on the generated val split (None when it has no images)."""
    images = data.val["images"]
    if not images:
        return None
    dets: list[dict] = []
    for im in images:
        boxes, scores, labels = _detections(model, [read_image(im["path"])], device)[0]
        dets += [{"image_id": im["id"], "category_id": int(c), "score": float(s),
                  "bbox": [float(b[0]), float(b[1]), float(b[2] - b[0]), float(b[3] - b[1])]}
                 for b, s, c in zip(boxes, scores, labels, strict=True)]
    return banded_metrics(data.val, dets)


def diagnose(val: dict | None, before: dict, after: dict) -> dict:
    """Which gap the scores point at (see the module docstring): {"gap": "training",
    "none", "scene", "object" or "unknown", "text": one sentence}."""
    b, a = before["bands"]["all"]["AP50"], after["bands"]["all"]["AP50"]
    v = val["bands"]["all"]["AP50"] if val else None
    if min(a, b) < 0:
        return {"gap": "unknown", "text": "the real frames have no labelled object of a "
                                          "scored category"}
    ref = v if v is not None and v >= 0 else None
    if ref is not None and ref < MIN_LEARNT:
        return {"gap": "training", "text": f"the detector has not learnt the generated data "
                f"(AP50 {ref:.3f} on its val split): train longer (--max-iter) or on more "
                f"images before judging the transfer"}
    if ref is not None and ref - b <= TRANSFER_GAP:
        return {"gap": "none", "text": f"transfers: real AP50 {b:.3f} is within "
                                       f"{TRANSFER_GAP} of the synthetic {ref:.3f}"}
    gap = (ref if ref is not None else 1.0) - b
    if a - b >= 0.5 * gap and a - b > 0.02:
        return {"gap": "scene", "text": f"the scene does not look real: re-estimating "
                f"BatchNorm on unlabelled real frames lifts real AP50 from {b:.3f} to {a:.3f}"
                f" (no labels, no training); the frames' global look (water, light, camera) "
                f"is the gap, not the object"}
    return {"gap": "object", "text": f"the object does not look real (or differs in size, "
            f"pose or context): real AP50 {b:.3f}, {a:.3f} with BatchNorm re-estimated on "
            f"real frames" + (f", against {ref:.3f} on generated images" if ref is not None
                             else "")}
