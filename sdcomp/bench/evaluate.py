"""COCO detection metrics with pycocotools, and scoring a detector on a test set.

Metrics (:data:`METRICS`), as COCOeval's ``stats`` for bounding boxes, each a fraction in
[0, 1] (the paper prints them x 100), or ``-1`` where COCO defines none (no ground-truth box
in that area range, e.g. APl when every object is under 96^2 px):

- ``AP``: mean over IoU 0.50:0.05:0.95, ``AP50``/``AP75``: at IoU 0.5/0.75,
- ``APs``/``APm``/``APl``: AP of objects under 32^2 px, 32^2-96^2 px, over 96^2 px (area =
  the ground truth's COCO ``area``),
- ``AR100``: recall averaged over IoU 0.50:0.95 with at most 100 detections per image.
"""

from __future__ import annotations

import contextlib
import io

import numpy as np
from pycocotools.coco import COCO
from pycocotools.cocoeval import COCOeval

METRICS = ("AP", "AP50", "AP75", "APs", "APm", "APl", "AR100")
_STAT_INDEX = {"AP": 0, "AP50": 1, "AP75": 2, "APs": 3, "APm": 4, "APl": 5, "AR100": 8}


def coco_from_dict(data: dict) -> COCO:
    """A pycocotools ``COCO`` index over an in-memory COCO dict (no file, no printing)."""
    coco = COCO()
    coco.dataset = data
    with contextlib.redirect_stdout(io.StringIO()):
        coco.createIndex()
    return coco


def coco_metrics(gt: dict, detections: list[dict]) -> dict[str, float]:
    """COCOeval bounding-box metrics of ``detections`` against the COCO dict ``gt``.

    ``detections``: dicts with ``image_id``, ``category_id`` (ids of ``gt``), ``bbox``
    [x, y, w, h] pixels and ``score``. Returns {metric: float} for :data:`METRICS`, each in
    [0, 1] or -1 (undefined). No detections at all give 0 wherever ground truth exists.
    """
    gt_coco = coco_from_dict(gt)
    anns = []
    for k, d in enumerate(detections):
        x, y, w, h = (float(v) for v in d["bbox"])
        anns.append({"id": k + 1, "image_id": int(d["image_id"]),
                     "category_id": int(d["category_id"]), "bbox": [x, y, w, h],
                     "area": w * h, "score": float(d["score"]), "iscrowd": 0})
    dt_coco = coco_from_dict({"images": gt.get("images", []),
                              "categories": gt.get("categories", []), "annotations": anns})
    ev = COCOeval(gt_coco, dt_coco, iouType="bbox")
    with contextlib.redirect_stdout(io.StringIO()):
        ev.evaluate()
        ev.accumulate()
        ev.summarize()
    return {m: _clean(ev.stats[i]) for m, i in _STAT_INDEX.items()}


def _clean(v: float) -> float:
    v = float(v)
    return -1.0 if v < 0 else round(min(max(v, 0.0), 1.0), 6)


def detections_to_coco(image_ids: list[int], results: list, category_id: int,
                       label: int = 1) -> list[dict]:
    """COCO result dicts from :func:`~.detector.predict` output.

    ``results[k]`` = (boxes (K, 4) x0, y0, x1, y1 px, scores (K,), labels (K,)) of image
    ``image_ids[k]``; detections of class ``label`` become ``category_id``.
    """
    out = []
    for image_id, (boxes, scores, labels) in zip(image_ids, results, strict=True):
        keep = np.asarray(labels) == label
        for (x0, y0, x1, y1), s in zip(np.asarray(boxes)[keep], np.asarray(scores)[keep],
                                       strict=True):
            out.append({"image_id": int(image_id), "category_id": int(category_id),
                        "bbox": [round(float(x0), 2), round(float(y0), 2),
                                 round(float(x1 - x0), 2), round(float(y1 - y0), 2)],
                        "score": round(float(s), 5)})
    return out


def evaluate_detector(model, test, device: str = "cpu", batch_size: int = 4) -> dict:
    """Score ``model`` on ``test`` (a :class:`~.datasets.EvalSet`); returns its metrics, the
    number of images and of ground-truth boxes (ignore regions not counted: COCOeval
    ignores detections on them), and the test set's label."""
    from .detector import predict
    from .train import read_image

    ids: list[int] = []
    results: list[dict] = []
    images = test.coco["images"]
    for k in range(0, len(images), batch_size):
        chunk = images[k:k + batch_size]
        arrays = [read_image(test.image_path(im)) for im in chunk]
        results.extend(predict(model, arrays, device, batch_size))
        ids.extend(int(im["id"]) for im in chunk)
    dets = detections_to_coco(ids, results, test.category_id)
    gt = test.coco_for_category()
    return {"test_set": test.label, "images": len(images),
            "boxes": sum(not a["iscrowd"] for a in gt["annotations"]),
            "detections": len(dets),
            "metrics": coco_metrics(gt, dets)}


#: size bands of :func:`banded_metrics`: name -> (lowest, highest) box area, pixels^2; COCO's
#: small / medium / large, with its small band split at 16^2 (drone objects are often tiny)
BANDS = {"all": (0.0, 1e10), "tiny": (0.0, 16.0**2), "small": (16.0**2, 32.0**2),
         "medium": (32.0**2, 96.0**2), "large": (96.0**2, 1e10)}


def banded_metrics(gt: dict, detections: list[dict], category_ids: list[int] | None = None
                   ) -> dict[str, dict]:
    """COCOeval bounding-box AP, AP50 and AR100 per size band (:data:`BANDS`, by the ground
    truth's ``area``) and per category, over ``category_ids`` (default: all of ``gt``).

    Returns {"bands": {band: {"AP", "AP50", "AR100", "boxes"}}, "categories": {id: {band:
    {...}}}}; values are fractions, -1 where a band has no ground truth (COCO's convention),
    ``boxes`` the number of ground-truth boxes in the band."""
    gt_coco = coco_from_dict(gt)
    ids = category_ids if category_ids is not None else sorted(gt_coco.getCatIds())
    anns = [{**d, "id": k + 1, "area": float(d["bbox"][2] * d["bbox"][3]), "iscrowd": 0}
            for k, d in enumerate(detections)]
    dt = coco_from_dict({"images": gt.get("images", []),
                         "categories": gt.get("categories", []), "annotations": anns})
    ev = COCOeval(gt_coco, dt, iouType="bbox")
    ev.params.catIds = list(ids)
    ev.params.areaRng = [list(r) for r in BANDS.values()]
    ev.params.areaRngLbl = list(BANDS)
    with contextlib.redirect_stdout(io.StringIO()):
        ev.evaluate()
        ev.accumulate()
    precision = ev.eval["precision"][..., -1]  # (T, R, K, A) at 100 detections per image
    recall = ev.eval["recall"][..., -1]  # (T, K, A)
    true = [a for a in gt["annotations"] if not a.get("iscrowd", 0)]  # ignore regions: no box
    areas = np.asarray([a["area"] for a in true], np.float64)
    cats = np.asarray([a["category_id"] for a in true])

    def band_values(k: slice | int) -> dict[str, dict]:
        out = {}
        for a, (name, (lo, hi)) in enumerate(BANDS.items()):
            inside = (areas >= lo) & (areas <= hi) & np.isin(cats, ids if isinstance(k, slice)
                                                            else [ids[k]])
            out[name] = {"AP": _mean_valid(precision[:, :, k, a]),
                         "AP50": _mean_valid(precision[0, :, k, a]),
                         "AR100": _mean_valid(recall[:, k, a]), "boxes": int(inside.sum())}
        return out

    return {"bands": band_values(slice(None)),
            "categories": {int(c): band_values(i) for i, c in enumerate(ids)}}


def _mean_valid(a: np.ndarray) -> float:
    """Mean of the entries > -1 (COCOeval's "undefined"), -1 when there are none."""
    v = np.asarray(a)[np.asarray(a) > -1]
    return round(float(v.mean()), 6) if v.size else -1.0
