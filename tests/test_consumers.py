"""The real consumers read our output as we mean it: Ultralytics trains and validates one
epoch from a yaml model on the YOLO labels (offline, no weights) and its ``save_json``
predictions are accepted by pycocotools against our COCO file; Ultralytics' and supervision's
own rasterisers draw our polygons back to our masks; supervision loads each split.

Ultralytics runs in a child process: importing it changes process-wide settings (numpy's
print options, OpenCV's thread count) that other tests must not inherit.
"""

from __future__ import annotations

import contextlib
import io
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from pycocotools.coco import COCO
from pycocotools.cocoeval import COCOeval

from sdcomp.io.png import decode_png16

from .datasets import REPO, cli

BASE = ["--size", "128", "--clutter", "0", "--count", "1-3", "--seed", "5", "--no-progress",
        "--workers", "1"]

ULTRALYTICS = r"""
import json, sys, time
from pathlib import Path
import numpy as np
from ultralytics import YOLO
from ultralytics.data.utils import polygon2mask
from sdcomp.io.png import decode_png16

folder, runs, train = Path(sys.argv[1]), sys.argv[2], sys.argv[3] == "train"
out = {}
if train:
    start = time.perf_counter()
    model = YOLO("yolov8n-seg.yaml")
    model.train(data=str(folder / "data.yaml"), epochs=1, imgsz=128, batch=8, workers=0,
                device="cpu", pretrained=False, plots=False, amp=False, project=runs,
                name="train", exist_ok=True, verbose=False)
    res = model.val(data=str(folder / "data.yaml"), imgsz=128, batch=8, workers=0,
                    device="cpu", save_json=True, plots=False, conf=0.001, project=runs,
                    name="val", exist_ok=True)
    out["seconds"] = time.perf_counter() - start
    out["predictions"] = str(Path(res.save_dir) / "predictions.json")
    # what Ultralytics found wrong with the labels (corrupt, out of bounds, duplicates)
    out["label_warnings"] = [m for s in ("train", "val") for m in np.load(
        folder / "labels" / f"{s}.cache", allow_pickle=True).item().get("msgs", [])]
# Ultralytics' own rasteriser on every polygon of the val labels
ious, areas = [], []
for label in sorted((folder / "labels" / "val").glob("*.txt")):
    inst = decode_png16((folder / "masks" / "val" / (label.stem + ".png")).read_bytes())
    h, w = inst.shape
    for k, line in enumerate(label.read_text().splitlines()):
        xy = np.array(line.split()[1:], np.float32).reshape(-1, 2) * np.array([w, h], np.float32)
        drawn = polygon2mask((h, w), [xy.reshape(-1)], downsample_ratio=1).astype(bool)
        mask = inst == k + 1
        ious.append(float((drawn & mask).sum() / (drawn | mask).sum()))
        areas.append(int(mask.sum()))
out["ious"], out["areas"] = ious, areas
print("RESULT " + json.dumps(out))
"""


def run_ultralytics(folder: Path, tmp: Path, train: bool) -> dict:
    """Run :data:`ULTRALYTICS` on ``folder`` in a child process, offline, its settings and
    runs under ``tmp``; returns its result."""
    env = {**os.environ, "YOLO_OFFLINE": "1", "YOLO_CONFIG_DIR": str(tmp / "config"),
           "PYTHONPATH": os.pathsep.join([str(REPO), *filter(None, [
               os.environ.get("PYTHONPATH")])])}
    proc = subprocess.run([sys.executable, "-c", ULTRALYTICS, str(folder), str(tmp / "runs"),
                           "train" if train else "raster"], env=env, cwd=tmp,
                          capture_output=True, text=True, timeout=900)
    assert proc.returncode == 0, proc.stderr[-4000:]
    line = [x for x in proc.stdout.splitlines() if x.startswith("RESULT ")]
    assert line, proc.stdout[-2000:]
    return json.loads(line[-1][len("RESULT "):])


@pytest.fixture(scope="module")
def seg(tmp_path_factory, sprites_dir) -> Path:
    """A small dataset at the default altitudes with COCO and YOLO polygon labels."""
    out = tmp_path_factory.mktemp("consumers") / "seg"
    rc, _, err = cli([*BASE, "--n", "24", "--format", "coco,yolo", "--yolo-seg", "--out", out,
                      "--sprites", sprites_dir])
    assert rc == 0, err
    return out


def quiet_coco(path: Path) -> COCO:
    with contextlib.redirect_stdout(io.StringIO()):
        return COCO(str(path))


def test_ultralytics_trains_and_its_predictions_match_our_coco_ids(seg, tmp_path):
    result = run_ultralytics(seg, tmp_path, train=True)
    # each split has its own label cache: neither run rewrites the other's
    assert (seg / "labels" / "train.cache").is_file()
    assert (seg / "labels" / "val.cache").is_file()
    assert not (seg / "labels.cache").exists()
    assert result["label_warnings"] == []  # every label line as Ultralytics wants it
    gt = quiet_coco(seg / "annotations" / "instances_val.json")
    preds = json.loads(Path(result["predictions"]).read_text())
    assert preds, "a random-weight model still predicts something at conf 0.001"
    assert {p["image_id"] for p in preds} <= set(gt.getImgIds())
    with contextlib.redirect_stdout(io.StringIO()):
        dt = gt.loadRes(result["predictions"])  # "Results do not correspond" if ids differ
        ev = COCOeval(gt, dt, "segm")
        ev.evaluate()
        ev.accumulate()
        ev.summarize()
    assert len(ev.stats) == 12
    # its own rasteriser draws our polygons back to our masks
    assert np.mean(result["ious"]) > 0.999 and min(result["ious"]) > 0.95
    print(f"ultralytics one epoch + val: {result['seconds']:.1f} s; polygon IoU mean "
          f"{np.mean(result['ious']):.4f} min {min(result['ious']):.4f}")


def test_polygons_through_ultralytics_close_up(tmp_path, sprites_dir):
    """At 4-8 m objects are 20-60 px with holes and several pieces: still drawn back."""
    out = tmp_path / "close"
    rc, _, err = cli([*BASE, "--n", "20", "--altitude", "4-8", "--format", "yolo",
                      "--yolo-seg", "--val-fraction", "0.5", "--out", out,
                      "--sprites", sprites_dir])
    assert rc == 0, err
    result = run_ultralytics(out, tmp_path, train=False)
    ious, areas = np.array(result["ious"]), np.array(result["areas"])
    assert len(ious) > 10
    # a mask in pieces is joined by bridges a pixel wide: on a mask of a dozen pixels one
    # bridge pixel costs 0.08 IoU, on one of 50 px or more under 0.05
    assert ious.mean() > 0.995 and ious[areas >= 50].min() > 0.95, (ious, areas)
    assert (ious * (areas + 2) >= areas).all(), (ious, areas)  # at most 2 px extra


def test_supervision_reads_each_split(seg):
    import supervision as sv

    gt = quiet_coco(seg / "annotations" / "instances_val.json")
    ds = sv.DetectionDataset.from_yolo(
        images_directory_path=str(seg / "images" / "val"),
        annotations_directory_path=str(seg / "labels" / "val"),
        data_yaml_path=str(seg / "data.yaml"), force_masks=True)
    assert len(ds) == len(gt.getImgIds())
    ious = []
    for path, _, det in ds:
        image_id = int(Path(path).stem)
        inst = decode_png16((seg / "masks" / gt.imgs[image_id]["mask_file"]).read_bytes())
        anns = sorted(gt.loadAnns(gt.getAnnIds(imgIds=[image_id], iscrowd=False)),
                      key=lambda a: a["instance_id"])
        assert len(det) == len(anns)
        if not anns:
            continue  # an empty label file: no masks at all
        assert det.class_id.tolist() == [a["category_id"] - 1 for a in anns]
        for drawn, ann in zip(det.mask, anns, strict=True):
            mask = inst == ann["instance_id"]
            ious.append((drawn & mask).sum() / (drawn | mask).sum())
    assert np.mean(ious) > 0.999 and min(ious) > 0.95
    # and the COCO file with the split folder in file_name, from the images/ root
    coco = sv.DetectionDataset.from_coco(images_directory_path=str(seg / "images"),
                                         annotations_path=str(seg / "annotations" /
                                                              "instances_val.json"),
                                         force_masks=True)
    assert len(coco) == len(gt.getImgIds())
    for path, _, det in coco:
        if len(det) == 0:
            continue
        image_id = int(Path(path).stem)
        inst = decode_png16((seg / "masks" / gt.imgs[image_id]["mask_file"]).read_bytes())
        # supervision reads the ignore regions (iscrowd entries) as masks too
        crowd = [int(a["area"]) for a in gt.loadAnns(gt.getAnnIds(imgIds=[image_id],
                                                                   iscrowd=True))]
        assert sorted(int(m.sum()) for m in det.mask) == sorted(
            [int((inst == k).sum()) for k in np.unique(inst) if k] + crowd)
