"""``bench sim2real``: generated categories mapped to real ones, real frames read from COCO
or YOLO labels, scoring by size band at the frames' own resolution, BatchNorm re-estimation,
the verdict, and the command end to end."""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pytest

from sdcomp.bench import sim2real
from sdcomp.bench.adapt import native_resolution, reestimate_batchnorm
from sdcomp.bench.cli import main
from sdcomp.bench.detector import build_detector
from sdcomp.bench.evaluate import banded_metrics
from sdcomp.bench.realdata import RealSet, TrainData, category_map, real_frames, training_data
from sdcomp.errors import UserError

from .datasets import cli

pytestmark = pytest.mark.usefixtures("one_torch_thread")
W, H = 256, 144  # the stand-in real frames: another size and aspect than the training


def test_categories_map_by_name_or_by_flag():
    real = {3: "Buoy", 5: "boat", 9: "person"}
    assert category_map(["buoy", "kayak"], real, []) == {1: 3}
    assert category_map(["buoy", "kayak"], real, ["kayak=BOAT"]) == {1: 3, 2: 5}
    assert category_map(["rov"], real, ["rov=person"]) == {1: 9}
    for names, maps, words in ((["rov"], [], "--map GEN=REAL"),
                               (["buoy"], ["buoy=ship"], "--map 'buoy=ship'"),
                               (["buoy"], ["buoy"], "GEN=REAL"),
                               (["buoy", "kayak"], ["kayak=buoy"], "both map to real")):
        with pytest.raises(UserError, match=words):
            category_map(names, real, maps)


def test_size_bands_split_ap_by_object_area():
    gt = {"images": [{"id": 1, "width": 200, "height": 200}],
          "categories": [{"id": 4, "name": "a"}],
          "annotations": [{"id": k + 1, "image_id": 1, "category_id": 4, "bbox": b,
                           "area": b[2] * b[3], "iscrowd": 0}
                          for k, b in enumerate([[0, 0, 10, 10], [50, 50, 20, 20],
                                                 [100, 100, 50, 50]])]}
    found = [{"image_id": 1, "category_id": 4, "bbox": [0, 0, 10, 10], "score": 0.9},
             {"image_id": 1, "category_id": 4, "bbox": [100, 100, 50, 50], "score": 0.8}]
    m = banded_metrics(gt, found)["bands"]
    assert [m[b]["boxes"] for b in ("all", "tiny", "small", "medium", "large")] == [3, 1, 1,
                                                                                   1, 0]
    assert m["tiny"]["AP50"] == 1.0 and m["small"]["AP50"] == 0.0
    assert m["medium"]["AP"] == 1.0 and m["large"]["AP"] == -1.0
    assert m["all"]["AR100"] == pytest.approx(2 / 3, abs=1e-4)


def test_real_frames_from_coco_and_yolo(tmp_path):
    frames = tmp_path / "frames"
    frames.mkdir()
    for name in ("a", "b", "c"):
        cv2.imwrite(str(frames / f"{name}.png"), np.zeros((50, 100, 3), np.uint8))
    coco = {"images": [{"id": 7, "file_name": "x/a.jpg", "width": 200, "height": 100}],
            "annotations": [{"id": 1, "image_id": 7, "category_id": 2,
                             "bbox": [190, 10, 20, 20]}],
            "categories": [{"id": 2, "name": "buoy"}]}
    (tmp_path / "c.json").write_text(json.dumps(coco))
    rs = real_frames(frames, tmp_path / "c.json")
    assert [s.key for s in rs.sources] == ["a"]  # b and c are not listed
    # labelled at twice the size, clipped at the frame's right edge
    assert rs.coco["annotations"][0]["bbox"] == [95.0, 5.0, 5.0, 10.0]
    labels = tmp_path / "labels"
    labels.mkdir()
    (labels / "b.txt").write_text("0 0.5 0.5 0.2 0.2\n")
    (labels / "classes.txt").write_text("kayak\n")
    rs = real_frames(frames, labels)
    assert [s.key for s in rs.sources] == ["a", "b", "c"]  # YOLO: no file, no objects
    assert rs.categories == {1: "kayak"} and len(rs.coco["annotations"]) == 1
    with pytest.raises(UserError, match="none of its 1 labelled frames"):
        real_frames(tmp_path / "frames", _coco_named(tmp_path, "zzz"))


def _coco_named(tmp_path: Path, name: str) -> Path:
    p = tmp_path / f"{name}.json"
    p.write_text(json.dumps({"images": [{"id": 1, "file_name": f"{name}.png"}],
                             "annotations": [], "categories": []}))
    return p


def test_sizes_note_flags_boxes_of_another_shape():
    """A square frame of a 3:2 sensor draws boxes 1.5x as tall for their width as the
    sensor's own aspect: the note names the category and the flags; boxes of the real shape
    and size pass without a note, and so does a category with too few boxes to tell."""
    def train(aspect: float, n: int = 5) -> TrainData:
        boxes = np.array([[10, 10, 10 + 20 / aspect ** 0.5, 10 + 20 * aspect ** 0.5]] * n,
                         np.float32)
        return TrainData([], ["buoy"], [(Path("x.jpg"), boxes, np.ones(n, np.int64))])

    w, h = 20 / 0.8 ** 0.5, 20 * 0.8 ** 0.5  # 0.8 as tall as wide, 20 px
    real = RealSet("r", [], {"annotations": [{"category_id": 4, "bbox": [0, 0, w, h],
                                              "area": w * h}] * 5}, {4: "buoy"})
    same = sim2real._sizes(train(0.8), real, {1: 4})
    assert same["note"] == ""
    assert same["aspects"]["buoy"]["generated"] == pytest.approx(0.8, rel=1e-4)
    tall = sim2real._sizes(train(0.8 * 1.5), real, {1: 4})
    assert "buoy 0.80 real, 1.20 generated" in tall["note"]
    assert "--width and --height" in tall["note"] and "px (median)" not in tall["note"]
    few = sim2real._sizes(train(0.8 * 1.5, n=4), real, {1: 4})
    assert few["note"] == "" and few["aspects"] == {}


def test_native_resolution_never_resizes():
    model = build_detector("mobilenet_v3-fpn", "none", 1, 64, 20, 10, 8).eval()
    import torch
    image = torch.rand(3, H, W)
    assert model.transform([image])[0].image_sizes == [(36, 64)]  # shrunk to fit 64 px
    native_resolution(model)
    batch = model.transform([image])[0]
    assert batch.image_sizes == [(H, W)] and batch.tensors.shape[-2:] == (160, 256)
    with torch.no_grad():
        out = model([image])[0]
    assert out["boxes"].shape[1] == 4
    assert (out["boxes"][:, 2] <= W + 1e-3).all() and (out["boxes"][:, 3] <= H + 1e-3).all()


def test_batchnorm_statistics_are_those_of_the_frames():
    """The first BatchNorm layer's new running mean is the mean of its input over the
    frames; the model itself is unchanged; frozen (pretrained-style) layers are thawed."""
    import torch
    from torchvision.ops.misc import FrozenBatchNorm2d

    model = native_resolution(build_detector("mobilenet_v3-fpn", "none", 1, 64, 20, 10, 8))
    model.eval()
    first = next(m for m in model.modules() if isinstance(m, torch.nn.BatchNorm2d))
    old = first.running_mean.clone()
    rng = np.random.default_rng(0)
    frames = [rng.integers(0, 120, (H, W, 3), dtype=np.uint8) + np.uint8(k * 60)
              for k in range(3)]
    seen: list = []
    hook = first.register_forward_pre_hook(lambda m, x: seen.append(x[0].mean((0, 2, 3))))
    new, n = reestimate_batchnorm(model, frames)
    hook.remove()
    assert n == 3 and torch.equal(first.running_mean, old)
    new_first = next(m for m in new.modules() if isinstance(m, torch.nn.BatchNorm2d))
    assert torch.allclose(new_first.running_mean, torch.stack(seen).mean(0), atol=1e-4)
    assert not new_first.training and not torch.allclose(new_first.running_mean, old)
    frozen = FrozenBatchNorm2d(4)
    frozen.running_mean += 3.0
    holder = torch.nn.Sequential(frozen)
    holder.transform, holder.backbone = model.transform, lambda t: None  # type: ignore
    thawed, _ = reestimate_batchnorm(holder, frames[:1])
    assert isinstance(thawed[0], torch.nn.BatchNorm2d)


def test_verdicts():
    def m(ap50):
        return {"bands": {"all": {"AP50": ap50}}}

    assert sim2real.diagnose(m(0.1), m(0.0), m(0.0))["gap"] == "training"
    assert sim2real.diagnose(m(0.8), m(0.75), m(0.76))["gap"] == "none"
    assert sim2real.diagnose(m(0.8), m(0.1), m(0.6))["gap"] == "scene"
    assert sim2real.diagnose(m(0.8), m(0.1), m(0.2))["gap"] == "object"
    assert sim2real.diagnose(None, m(-1.0), m(-1.0))["gap"] == "unknown"


@pytest.fixture(scope="module")
def real_stand_in(gen_grey, tmp_path_factory) -> tuple[Path, Path]:
    """6 of gen_grey's frames resized to 256 x 144, as COCO "real" frames with one labelled box
    of a category named "rov" (not the generated "bluerov2")."""
    d = tmp_path_factory.mktemp("real")
    data = training_data([gen_grey])
    images, anns = [], []
    for k, im in enumerate((data.val["images"] + [{"path": p} for p, _, _ in data.items])[:6]):
        rgb = cv2.imread(str(im["path"]))
        cv2.imwrite(str(d / f"f{k}.png"), cv2.resize(rgb, (W, H)))
        images.append({"id": k + 1, "file_name": f"f{k}.png", "width": W, "height": H})
    anns.append({"id": 1, "image_id": 1, "category_id": 1, "bbox": [20, 20, 12, 10]})
    coco = {"images": images, "annotations": anns, "categories": [{"id": 1, "name": "rov"}]}
    (d / "real.json").write_text(json.dumps(coco))
    return d, d / "real.json"


TINY = ["--backbone", "mobilenet_v3-fpn", "--max-iter", "2", "--batch-size", "2",
        "--lr", "0.01", "--warmup-iters", "1", "--proposals-train", "40",
        "--proposals-test", "20", "--roi-batch", "16", "--no-progress"]


def test_command_end_to_end(gen_default, real_stand_in, tmp_path, monkeypatch):
    frames, labels = real_stand_in
    out = tmp_path / "s2r"
    base = ["sim2real", "--train", gen_default, "--real", frames, "--real-labels", labels,
            "--out", out, *TINY]
    rc, _, err = cli(base, main)  # "bluerov2" is not "rov": one line, nothing written
    assert rc == 2 and len(err.strip().splitlines()) == 1 and "--map" in err, err
    assert not out.exists()
    shapes: list = []
    real_predict = sim2real.predict
    monkeypatch.setattr(sim2real, "predict", lambda model, images, *a: (
        shapes.extend(i.shape for i in images), real_predict(model, images, *a))[1])
    rc, text, err = cli([*base, "--map", "bluerov2=rov"], main)
    assert rc == 0, err
    assert "verdict:" in text and "BatchNorm re-estimated" in text
    r = json.loads((out / "sim2real.json").read_text())
    assert r["mapping"] == {"bluerov2": "rov"} and r["real"]["frames"] == 6
    assert r["batchnorm"]["frames"] == 6 and r["batchnorm"]["layers"] > 10
    assert r["real_before"]["bands"]["all"]["boxes"] == 1
    assert r["real_before"]["bands"]["tiny"]["boxes"] == 1  # 12 x 10 px
    assert r["synthetic_val"] is not None and len(r["train"]["losses"]) == 2
    assert (H, W, 3) in shapes and (192, 192, 3) in shapes  # real frames at their own size
    assert cv2.imread(str(out / "detections.jpg")).shape[1] == 2 * 640 + 6
    assert "| real, as trained | all | 1 |" in (out / "report.md").read_text()
    # the same command again: the training is done, only the scoring runs
    rc, _, err = cli([*base, "--map", "bluerov2=rov"], main)
    assert rc == 0, err
    assert json.loads((out / "sim2real.json").read_text())["train"]["resumed_from"] == 2
