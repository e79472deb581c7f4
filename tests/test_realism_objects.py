"""Per-object appearance statistics (``sdcomp realism --objects``): the statistics on
synthetic images with known answers, the GSD at a box, and the command on a small
``--preset seadronessee`` dataset, whose frames read back as "real" frames (COCO and YOLO
labels) give the generated side's numbers."""

from __future__ import annotations

import json
import math
import shutil
from pathlib import Path

import cv2
import numpy as np
import pytest

from sdcomp.cli.realism import main
from sdcomp.errors import UserError, run_cli
from sdcomp.report.realism import object_statistics
from sdcomp.report.realism.object_report import objects_report
from sdcomp.report.realism.object_sets import measure_objects
from sdcomp.report.realism.objects import STATS, box_statistics, record_gsd, sea_gsd, summarise
from sdcomp.report.realism.sources import load_generated, load_real, pinhole_record
from sdcomp.scene.camera import CameraModel, CameraPose, centre_gsd

COL = {s: i for i, s in enumerate(STATS)}


def grey_noise(h: int = 240, w: int = 240, level: float = 128.0, sd: float = 6.0,
               seed: int = 0) -> np.ndarray:
    """(h, w, 3) uint8 grey Gaussian noise."""
    g = np.random.default_rng(seed).normal(level, sd, (h, w, 1))
    return np.clip(np.round(g), 0, 255).astype(np.uint8).repeat(3, axis=2)


def stats_of(img, boxes, gsd=None, min_size=15.0) -> dict:
    v = box_statistics(img, boxes, gsd, min_size)
    return {s: v[0, i] for s, i in COL.items()}


def test_dark_square_in_a_box_on_grey_noise():
    img = grey_noise()
    img[110:130, 110:130] = 60  # a quarter of the 40 x 40 box around it
    s = stats_of(img, [[100, 100, 40, 40]])
    assert s["dark_share"] == pytest.approx(0.25, abs=0.01)
    assert s["bright_share"] == 0
    # box mean 0.25 * 60 + 0.75 * 128 = 111, surrounding mean 128, std 6
    assert s["contrast"] == pytest.approx((111 - 128) / 6, rel=0.05)
    assert s["aspect"] == 1 and s["saturation"] == 0
    assert s["size_image_px"] == 40 and s["size_px"] == pytest.approx(40 * 1920 / 240)
    assert math.isnan(s["size_m"])


def test_bright_and_coloured_boxes():
    img = grey_noise(seed=1)
    img[100:112, 60:100] = 250  # 40 x 12 of a 40 x 30 box: 0.4 of it bright
    s = stats_of(img, [[60, 100, 40, 30]], gsd=0.02)
    assert s["bright_share"] == pytest.approx(0.4, abs=0.01) and s["dark_share"] == 0
    assert s["contrast"] > 5 and s["aspect"] == pytest.approx(0.75)
    assert s["size_m"] == pytest.approx(0.02 * math.sqrt(1200))
    img[20:50, 20:40] = (255, 0, 0)  # pure red: saturation 1, grey 76, 52 levels darker
    s = stats_of(img, [[20, 20, 20, 30]])
    assert s["saturation"] == pytest.approx(1.0) and s["dark_share"] == 1
    assert s["aspect"] == pytest.approx(1.5)


def test_levels_just_at_the_thresholds():
    """Dark means >= 25 levels below the surrounding mean, bright >= 40 above (uniform
    water of 100: a pixel of 75 is dark, 76 not; 140 bright, 139 not)."""
    img = np.full((120, 120, 3), 100, np.uint8)
    img[50:60, 40:80] = 75
    img[60:70, 40:80] = 76
    img[70:80, 40:80] = 140
    img[80:90, 40:80] = 139
    s = stats_of(img, [[40, 50, 40, 40]])
    assert s["dark_share"] == pytest.approx(0.25) and s["bright_share"] == pytest.approx(0.25)
    assert math.isnan(s["contrast"])  # the water's std is 0


def test_other_boxes_are_not_surrounding_water():
    img = grey_noise(seed=2)
    img[100:120, 100:120] = 60
    boxes = [[100, 100, 20, 20], [125, 100, 20, 20]]
    before = box_statistics(img, boxes)
    img[100:120, 125:145] = 255  # the neighbour inside the window turns bright
    after = box_statistics(img, boxes)
    assert after[0, COL["contrast"]] == before[0, COL["contrast"]] < -5
    assert after[0, COL["dark_share"]] == 1
    unlabelled = stats_of(img, boxes[:1])  # the neighbour counts as water
    assert unlabelled["contrast"] > 0.5 * before[0, COL["contrast"]]
    kept = box_statistics(img, boxes, exclude_others=False)  # ... as it does here
    assert kept[0, COL["contrast"]] == unlabelled["contrast"]


def test_window_is_grown_by_the_longer_side_and_clipped():
    """Water beyond max(w, h) of the box does not count; a box at the corner is measured
    on what is left of its window."""
    img = grey_noise(seed=3)
    img[:, :] = 128
    img[100:110, 100:130] = 0  # box 30 x 10
    img[70:140, 70:160] = np.where(img[70:140, 70:160] == 0, 0, 140)  # its window: 140
    s = stats_of(img, [[100, 100, 30, 10]])
    assert s["dark_share"] == 1 and math.isnan(s["contrast"])  # all water 140, std 0
    img2 = grey_noise(seed=4)
    img2[0:20, 0:20] = 40
    s = stats_of(img2, [[0, 0, 20, 20]])
    assert s["dark_share"] == 1 and s["contrast"] < -10


def test_small_and_empty_boxes_are_not_measured():
    img = grey_noise()
    v = box_statistics(img, [[10, 10, 10, 10], [10, 10, 20, 10], [300, 300, 20, 20],
                             [50, 50, 0, 30], [50, 50, 15, 15]])
    assert np.isnan(v[:4]).all() and not np.isnan(v[4, :6]).any()
    assert not np.isnan(box_statistics(img, [[10, 10, 10, 10]], min_size=10)).all()
    assert box_statistics(img, np.zeros((0, 4))).shape == (0, len(STATS))


def test_summary_per_category():
    v = np.full((5, len(STATS)), np.nan)
    v[:4] = np.arange(4)[:, None] * np.ones(len(STATS))
    v[3, COL["size_m"]] = np.nan
    s = summarise(v, ["a", "a", "a", "b", "b"])
    assert list(s) == ["a", "b"] and s["a"]["count"] == 3 and s["b"]["count"] == 1
    assert s["a"]["contrast"] == {"median": 1.0, "p10": 0.2, "p90": 1.8, "n": 3}
    assert s["b"]["size_m"]["n"] == 0 and math.isnan(s["b"]["size_m"]["median"])


@pytest.mark.parametrize("pitch", [90.0, 45.0])
def test_gsd_at_a_box_is_the_camera_depth_over_the_focal_length(pitch):
    model = CameraModel(416, 416, 22.9, 416, 416)
    rec = pinhole_record(model, 30.0, pitch)
    g = record_gsd(rec, np.array([[203.0, 203.0, 10.0, 10.0], [0, 0, 10, 10],
                                  [0, 400, 10, 10]]))
    assert g is not None
    assert g[0] == pytest.approx(centre_gsd(model, CameraPose(30.0, pitch)), rel=1e-9)
    if pitch == 90:
        assert g == pytest.approx(g[0])  # straight down: one depth
    else:
        assert g[1] > g[0] > g[2]  # the top of the frame is farther
        # a ray above the horizon meets no sea
        up = sea_gsd(rec["K"], rec["R_w2c"], rec["t_w2c"], np.array([208.0]),
                     np.array([-1e4]))
        assert np.isnan(up).all()
    assert record_gsd({"K": [[1, 0, 0]]}, np.zeros((1, 4))) is None


# --------------------------------------------------------------------------- a dataset

@pytest.fixture(scope="module")
def sds(small_datasets) -> Path:
    """10 images of ``--preset seadronessee`` at the real frames' focal length, COCO and
    YOLO labels; two categories, of the atlases tests/test_sar_generate.py builds (the
    session's sprite folder then holds no other: that test checks that it does not)."""
    return small_datasets("objects", "--preset", "seadronessee", "--camera", "custom",
                          "--fov", "22.9", "--sensor-px", "320,320", "--size", "320",
                          "--n", "10", "--seed", "4", "--format", "coco,yolo",
                          "--count-view", "0",  # the preset's counts in this narrow view
                          "--object", "swimmer-03", "--category", "swimmer",
                          "--object", "life_saving_appliances", "--clutter-kinds", "buoy",
                          "log")


def as_real(dataset: Path, folder: Path) -> tuple[Path, Path, Path]:
    """The dataset's images in one folder, as real frames: (images, a COCO file of both
    splits, a YOLO labels folder with its data.yaml)."""
    images, labels = folder / "images", folder / "yolo" / "labels"
    images.mkdir(parents=True)
    labels.mkdir(parents=True)
    coco: dict = {"images": [], "annotations": []}
    for split in ("train", "val"):
        part = json.loads((dataset / "annotations" / f"instances_{split}.json").read_text())
        coco["images"] += part["images"]
        coco["annotations"] += part["annotations"]
        coco["categories"] = part["categories"]
        for f in (dataset / "images" / split).iterdir():
            shutil.copy(f, images / f.name)
        for f in (dataset / "labels" / split).glob("*.txt"):
            shutil.copy(f, labels / f.name)
    shutil.copy(dataset / "data.yaml", labels.parent / "data.yaml")
    (folder / "coco.json").write_text(json.dumps(coco))
    return images, folder / "coco.json", labels


def test_command_writes_the_object_report(sds, tmp_path):
    out = tmp_path / "out"
    assert main([str(sds), "--objects", "--out", str(out), "-q"]) == 0
    assert sorted(p.name for p in out.iterdir()) == ["object_crops.png", "objects.json",
                                                      "objects.md"]
    r = json.loads((out / "objects.json").read_text())
    cats = {c["id"]: c["name"] for c in json.loads(
        (sds / "annotations" / "instances_train.json").read_text())["categories"]}
    big = set()
    for split in ("train", "val"):
        for a in json.loads((sds / "annotations" / f"instances_{split}.json").read_text())[
                "annotations"]:
            if a["bbox"][2] * a["bbox"][3] >= 15 ** 2:
                big.add(cats[a["category_id"]])
    gen = r["categories"]["generated"]
    assert set(gen) == big == {"swimmer", "life_saving_appliances"} and r["real"] is None
    assert set(r["crops"]["scales"]) == big
    for row in gen.values():
        assert set(row) == {"count", *STATS} and row["size_m"]["n"] == row["count"]
    md = (out / "objects.md").read_text()
    assert all(f"## {c}" in md for c in big)
    img = cv2.imread(str(out / "object_crops.png"))
    assert img is not None and img.shape[0] > 100 * len(big)
    # the Python function gives the same summary (JSON writes NaN as null)
    assert json.loads(json.dumps(object_statistics(sds)).replace("NaN", "null")) == gen


def rows(frames) -> tuple[list, np.ndarray]:
    """(key (image, category, x, y) per measured box, (n, len(STATS)) values) of a set, in
    the keys' order."""
    t = measure_objects(frames)
    keys = [(frames.frames[f].path.stem, c, round(b[0]), round(b[1]))
            for f, c, b in zip(t.frames, t.categories, t.boxes, strict=True)]
    order = sorted(range(len(keys)), key=keys.__getitem__)
    return [keys[i] for i in order], t.values[order]


def test_real_frames_with_coco_or_yolo_labels_measure_as_generated(sds, tmp_path):
    images, coco, yolo = as_real(sds, tmp_path)
    gk, gv = rows(load_generated(sds))
    ck, cv = rows(load_real(images, coco, fov=22.9))
    assert ck == gk and len(gk) > 5
    np.testing.assert_allclose(cv[:, :6], gv[:, :6], rtol=1e-12)
    np.testing.assert_allclose(cv[:, 7], gv[:, 7], rtol=1e-12)
    # real: a pinhole of --real-fov from the meta; generated: its lens's zoom (< 0.2 %)
    np.testing.assert_allclose(cv[:, COL["size_m"]], gv[:, COL["size_m"]], rtol=0.01)
    yk, yv = rows(load_real(images, yolo, gsd=0.05))
    assert yk == gk  # YOLO's rounded fractions cover the same pixels
    np.testing.assert_allclose(yv[:, :6], gv[:, :6], rtol=1e-6, atol=1e-9)
    np.testing.assert_allclose(yv[:, 7], gv[:, 7], rtol=1e-6)
    np.testing.assert_allclose(yv[:, COL["size_m"]], 0.05 * gv[:, 7], rtol=1e-6)

    out = tmp_path / "out"
    r = objects_report(sds, images, out, real_labels=coco, real_fov=22.9)
    g, rr = r["categories"]["generated"], r["categories"]["real"]
    assert set(g) == set(rr)
    for cat in g:
        assert g[cat]["count"] == rr[cat]["count"]
        for s in ("contrast", "dark_share", "aspect", "size_px"):
            assert rr[cat][s]["median"] == pytest.approx(g[cat][s]["median"])
    assert "| per box | unit | generated" in (out / "objects.md").read_text()
    assert "real (" in (out / "objects.md").read_text()


def test_user_mistakes_are_one_line_errors(sds, tmp_path, capsys):
    with pytest.raises(UserError, match="--real-labels"):
        objects_report(sds, tmp_path)
    with pytest.raises(UserError, match="need --real"):
        objects_report(sds, None, real_labels=tmp_path / "x.json")
    with pytest.raises(UserError, match="--min-size"):
        objects_report(sds, min_size=0)
    with pytest.raises(UserError):
        objects_report(tmp_path / "missing", out_dir=tmp_path / "o")
    with pytest.raises(UserError, match="no such file"):
        objects_report(sds, sds / "images", tmp_path / "o", real_labels=tmp_path / "no.json")
    # the command: one line on stderr, exit status 2
    assert run_cli(main, [str(tmp_path / "missing"), "--objects"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: ") and err.count("\n") == 1 and "Traceback" not in err
