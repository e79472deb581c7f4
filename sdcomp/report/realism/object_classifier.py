"""The object realism classifier: per category, can a classifier tell a real object's crop
from a generated one? (``sdcomp realism --objects --real ...``)

Per category present in both sets with at least ``min_crops`` whole boxes each
(:mod:`.object_crops`: the box and its water at one pixel scale), two classifiers are
cross-validated by image (:func:`.classifier.group_folds`: every crop of a frame in one fold;
the larger set first subsampled to the smaller's count):

- a small CNN on the crops (:func:`.classifier.cross_validate_cnn`, 4 stride-2 convolutions
  of 16, 32, 64, 64 channels, flips and quarter turns as augmentation), the number to drive
  down, where torch is installed;
- the logistic regression on the hand features of :func:`.object_crops.object_features`, a
  second opinion that also says which features tell the sets apart.

Each accuracy comes with its 95 % bootstrap interval over images (0.5: indistinguishable,
1.0: always told apart). :func:`classifier_picture` draws the crops as the classifiers see
them: real ones, generated ones, and the generated ones the classifier finds most synthetic
and most real.
"""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from . import classifier as clf
from .crops import Crop, montage
from .object_crops import CONTEXT, ObjectCrops, object_feature_names, object_features

MIN_CROPS = 10  #: fewest whole boxes of a category on each side for its classifier
CNN_CHANNELS = (16, 32, 64, 64)
SHOW_PX = 96  #: side of a crop in the picture
REAL_OFFSET = 10 ** 7  #: added to the real frames' indices (image groups unique across sets)


def classify_objects(gen: ObjectCrops, real: ObjectCrops, folds: int = 5, seed: int = 0,
                     cnn: bool = True, min_crops: int = MIN_CROPS, log=None) -> dict:
    """Per category of both sets: ``{"generated": crops, "real": crops, "logistic": CV
    dict, "cnn": CV dict or None}`` (:meth:`.classifier.CVResult.to_dict`, class 1 = real),
    or ``{"generated", "real", "error": why}`` for a category with too few crops (fewer than
    ``min_crops`` on a side, or fewer than 2 frames). ``cnn``: also the CNN (skipped, with
    ``"cnn": {"error": ...}``, where torch does not import). The out-of-fold scores of each
    model are kept under the private key ``"_scores"`` ({model: (rows of gen, rows of real,
    logits)}) for :func:`classifier_picture`; :func:`public` drops it."""
    say = log or (lambda msg: None)
    out: dict[str, dict] = {}
    cats = sorted(set(gen.categories) & set(real.categories))
    names = object_feature_names()
    for cat in cats:
        ig, ir = gen.of(cat), real.of(cat)
        entry: dict = {"generated": int(len(ig)), "real": int(len(ir))}
        out[cat] = entry
        if min(len(ig), len(ir)) < min_crops:
            entry["error"] = (f"too few whole boxes to classify ({len(ig)} generated, "
                              f"{len(ir)} real; needs {min_crops} each)")
            continue
        crops = np.concatenate([gen.crops[ig], real.crops[ir]])
        y = np.concatenate([np.zeros(len(ig), np.int64), np.ones(len(ir), np.int64)])
        groups = np.concatenate([gen.groups[ig], real.groups[ir] + REAL_OFFSET])
        rows = np.concatenate([ig, ir])
        say(f"objects: {cat}: classifying {len(ig)} generated and {len(ir)} real crops")
        x = object_features(crops, np.concatenate([gen.masks[ig], real.masks[ir]]),
                            np.concatenate([gen.boxes[ig], real.boxes[ir]]))
        try:
            lr = clf.cross_validate(x, y, groups, folds, seed=seed, names=names)
        except ValueError as exc:
            entry["error"] = str(exc)
            continue
        entry["logistic"] = lr.to_dict()
        scores = {"logistic": _scored(lr, rows, y)}
        entry["cnn"] = None
        if cnn and not clf.torch_available():
            entry["cnn"] = {"error": "torch is not importable"}
        elif cnn:
            res = clf.cross_validate_cnn(crops, y, groups, folds, seed=seed,
                                         channels=CNN_CHANNELS, augment=True)
            entry["cnn"] = res.to_dict()
            scores["cnn"] = _scored(res, rows, y)
        entry["_scores"] = scores
    return out


def _scored(res: clf.CVResult, rows: np.ndarray, y: np.ndarray) -> tuple:
    """(rows of gen scored, rows of real scored, their logits) of a CV result."""
    assert res.kept is not None and res.scores is not None
    k = res.kept
    g, r = y[k] == 0, y[k] == 1
    return rows[k][g], rows[k][r], res.scores[g], res.scores[r]


def public(result: dict) -> dict:
    """:func:`classify_objects`'s result without its private keys (JSON-ready)."""
    return {cat: {k: v for k, v in e.items() if not k.startswith("_")}
            for cat, e in result.items()}


def headline(entry: dict) -> tuple[str, dict] | None:
    """(model name, CV dict) of the number a category is judged by: the CNN's where it ran,
    else the logistic regression's; None when neither did."""
    for model in ("cnn", "logistic"):
        r = entry.get(model)
        if isinstance(r, dict) and "accuracy" in r:
            return model, r
    return None


def accuracy_text(r: dict | None) -> str:
    """'0.93 (0.88-0.97)': an accuracy and its image interval; '-' for none."""
    if not isinstance(r, dict) or "accuracy" not in r:
        return "-" if not isinstance(r, dict) else f"- ({r.get('error', '')})"
    lo, hi = r["ci95_images"]
    return f"{r['accuracy']:.3f} ({lo:.3f}-{hi:.3f})"


def classifier_picture(path: Path, result: dict, gen: ObjectCrops, real: ObjectCrops,
                       n: int = 10, seed: int = 0, out_px: int = SHOW_PX) -> None:
    """Write the crops as the classifiers see them: per category a row of random real
    crops, one of random generated ones, then the generated crops the headline classifier
    (:func:`headline`) scored most synthetic and most real (out of fold; the caption is
    p(real)), each enlarged to ``out_px``."""
    rng = np.random.default_rng(seed)
    rows: list[tuple[str, list[Crop]]] = []
    for cat, entry in result.items():
        ir, ig = real.of(cat), gen.of(cat)
        rows.append((f"{cat}: real ({len(ir)})", [_show(real.crops[i], "", out_px)
                                                  for i in _some(ir, n, rng)]))
        rows.append((f"{cat}: generated ({len(ig)})", [_show(gen.crops[i], "", out_px)
                                                       for i in _some(ig, n, rng)]))
        best = headline(entry)
        if best is None or best[0] not in entry.get("_scores", {}):
            continue
        sc = entry["_scores"][best[0]]
        g_rows, _, g_scores, _ = sc
        order = np.argsort(g_scores)
        p = 1.0 / (1.0 + np.exp(-np.clip(g_scores, -30, 30)))
        acc = accuracy_text(best[1])
        rows.append((f"{cat}: generated, most synthetic to the {best[0]} ({acc})",
                     [_show(gen.crops[g_rows[j]], f"p {p[j]:.2f}", out_px)
                      for j in order[:n]]))
        rows.append((f"{cat}: generated, most real to the {best[0]}",
                     [_show(gen.crops[g_rows[j]], f"p {p[j]:.2f}", out_px)
                      for j in order[::-1][:n]]))
    title = ("sdcomp realism --objects: the crop classifier's view (each box and its water, "
             f"the box's longer side {100 / CONTEXT:.0f} % of the crop); p = p(real) out of "
             "fold")
    img = montage(rows, title, n, out_px) if rows else np.full((40, 400, 3), 25, np.uint8)
    cv2.imwrite(str(path), cv2.cvtColor(img, cv2.COLOR_RGB2BGR))


def _some(rows: np.ndarray, n: int, rng: np.random.Generator) -> np.ndarray:
    return rows[rng.permutation(len(rows))[:n]] if len(rows) else rows


def _show(crop: np.ndarray, caption: str, out_px: int) -> Crop:
    interp = cv2.INTER_NEAREST if out_px % crop.shape[0] == 0 else cv2.INTER_LINEAR
    big = cv2.resize(crop, (out_px, out_px), interpolation=interp)
    return Crop(np.ascontiguousarray(big), caption, True)


def summary_lines(result: dict) -> list[str]:
    """One line per category: its headline accuracy and the logistic regression's."""
    lines = []
    for cat, e in result.items():
        if "error" in e:
            lines.append(f"{cat}: not classified: {e['error']}")
            continue
        best = headline(e)
        lr = e.get("logistic")
        text = (f"{cat} ({e['generated']} generated, {e['real']} real crops): "
                f"{best[0] if best else '-'} {accuracy_text(best[1] if best else None)}")
        if best and best[0] != "logistic":
            text += f"; logistic {accuracy_text(lr)}"
        lines.append(text)
    return lines

