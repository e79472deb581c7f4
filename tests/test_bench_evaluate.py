"""COCO metrics of the benchmark against hand-checked cases (pycocotools COCOeval)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from sdcomp.bench.datasets import EvalSet
from sdcomp.bench.evaluate import METRICS, coco_metrics, detections_to_coco


def _gt(boxes_per_image: list[list[list[float]]]) -> dict:
    images, anns = [], []
    for i, boxes in enumerate(boxes_per_image):
        images.append({"id": i + 1, "file_name": f"{i}.jpg", "width": 416, "height": 416})
        for x, y, w, h in boxes:
            anns.append({"id": len(anns) + 1, "image_id": i + 1, "category_id": 1,
                         "bbox": [x, y, w, h], "area": w * h, "iscrowd": 0})
    return {"images": images, "annotations": anns,
            "categories": [{"id": 1, "name": "bluerov2"}]}


def _dets(gt: dict, dx: float = 0.0, score: float = 0.9) -> list[dict]:
    return [{"image_id": a["image_id"], "category_id": 1, "score": score,
             "bbox": [a["bbox"][0] + dx, *a["bbox"][1:]]} for a in gt["annotations"]]


def test_perfect_detections_score_one_in_every_area_range():
    # small (10x12 = 120 px), medium (40x50 = 2000 px), large (120x100 = 12000 px)
    gt = _gt([[[5, 5, 10, 12]], [[50, 60, 40, 50], [200, 200, 120, 100]], []])
    m = coco_metrics(gt, _dets(gt))
    assert set(m) == set(METRICS)
    assert m == {k: 1.0 for k in METRICS}


def test_shifted_box_scores_by_its_iou():
    # 10x10 box shifted 2 px right: IoU = 80 / (100 + 100 - 80) = 2/3, a hit at the IoU
    # thresholds 0.50, 0.55, 0.60, 0.65 only: AP = 4/10, AP50 = 1, AP75 = 0; a small object
    gt = _gt([[[20, 20, 10, 10]]])
    m = coco_metrics(gt, _dets(gt, dx=2.0))
    iou = 80 / 120
    hits = int(np.sum(np.linspace(0.5, 0.95, 10) <= iou + 1e-12))
    assert hits == 4
    assert m["AP"] == pytest.approx(0.4, abs=1e-6)
    assert m["AP50"] == 1.0 and m["AP75"] == 0.0
    assert m["APs"] == pytest.approx(0.4, abs=1e-6)
    assert m["APm"] == -1.0 and m["APl"] == -1.0  # no ground truth of those sizes
    assert m["AR100"] == pytest.approx(0.4, abs=1e-6)


def test_no_detections_score_zero_where_ground_truth_exists():
    gt = _gt([[[20, 20, 10, 10]], [[100, 100, 50, 50]]])
    m = coco_metrics(gt, [])
    assert m["AP"] == m["AP50"] == m["AP75"] == m["APs"] == m["APm"] == m["AR100"] == 0.0
    assert m["APl"] == -1.0


def test_false_positive_ranked_first_halves_precision():
    # one object; a miss (0.9) ranked above the hit (0.8): precision 1/2 at full recall
    gt = _gt([[[20, 20, 30, 30]]])
    dets = [{"image_id": 1, "category_id": 1, "bbox": [300, 300, 30, 30], "score": 0.9},
            {"image_id": 1, "category_id": 1, "bbox": [20, 20, 30, 30], "score": 0.8}]
    m = coco_metrics(gt, dets)
    assert m["AP50"] == pytest.approx(0.5, abs=1e-6)
    assert m["AR100"] == 1.0
    # the same hit ranked first is perfect
    dets[0]["score"] = 0.1
    assert coco_metrics(gt, dets)["AP50"] == 1.0


def test_detections_to_coco_converts_corners_and_keeps_one_class():
    boxes = np.array([[10, 20, 40, 60], [0, 0, 5, 5]], np.float32)
    scores = np.array([0.9, 0.8], np.float32)
    labels = np.array([1, 2])
    out = detections_to_coco([7], [(boxes, scores, labels)], category_id=3)
    assert out == [{"image_id": 7, "category_id": 3, "bbox": [10.0, 20.0, 30.0, 40.0],
                    "score": pytest.approx(0.9, abs=1e-5)}]


def test_eval_set_scores_only_its_category_and_fills_coco_fields():
    coco = {"images": [{"id": 1, "file_name": "a.jpg"}],
            "categories": [{"id": 4, "name": "boat"}, {"id": 9, "name": "bluerov2"}],
            "annotations": [{"image_id": 1, "category_id": 4, "bbox": [0, 0, 5, 5]},
                            {"image_id": 1, "category_id": 9, "bbox": [1, 2, 3, 4]}]}
    gt = EvalSet("real", "real", coco, None, 9).coco_for_category()
    assert [c["id"] for c in gt["categories"]] == [9]
    assert gt["annotations"] == [{"image_id": 1, "category_id": 9, "bbox": [1, 2, 3, 4],
                                  "id": 1, "area": 12, "iscrowd": 0}]
    dets = [{"image_id": 1, "category_id": 9, "bbox": [1, 2, 3, 4], "score": 1.0}]
    assert coco_metrics(gt, dets)["AP"] == 1.0


@pytest.mark.parametrize("crowd_category", [1, 0])
def test_detections_on_ignore_regions_are_neither_true_nor_false(crowd_category):
    """An ignore region (iscrowd 1, of the scored category or SeaDronesSee's category 0
    'ignored') makes a detection on it count for nothing; the same detection elsewhere is a
    false positive; the trainer takes no ignore region as a positive box."""
    from sdcomp.bench.train import training_items

    gt = _gt([[[20, 20, 30, 30]]])
    gt["images"][0]["path"] = "0.jpg"
    gt["annotations"].append({"id": 2, "image_id": 1, "category_id": crowd_category,
                              "bbox": [200.0, 200.0, 3.0, 1.0], "area": 3, "iscrowd": 1})
    scored = EvalSet("t", "synthetic-val", gt, Path("."), 1).coco_for_category()
    assert [a["iscrowd"] for a in scored["annotations"]] == [0, 1]
    on = {"image_id": 1, "category_id": 1, "score": 0.99, "bbox": [200.0, 200.0, 3.0, 1.0]}
    off = dict(on, bbox=[300.0, 300.0, 3.0, 1.0])
    assert coco_metrics(scored, [*_dets(gt)[:1], on])["AP"] == 1.0
    assert coco_metrics(scored, [*_dets(gt)[:1], off])["AP"] < 1.0
    (_, boxes), = training_items(gt)
    assert boxes.tolist() == [[20.0, 20.0, 50.0, 50.0]]
