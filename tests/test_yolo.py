"""YOLO export: label files against the COCO annotations of the same dataset, the layout
Ultralytics reads (labels/ beside images/, ./-relative split lists, data.yaml), polygons
traced from the masks, images unchanged by the format options, resume, yolo-only runs."""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st

from sdcomp.io.png import decode_png16
from sdcomp.io.yolo import box_line, data_yaml, mask_polygon
from sdcomp.report.stats import dataset_stats

from .datasets import cli

BASE = ["--n", "40", "--size", "96", "--clutter", "0", "--altitude", "3-6", "--count", "0-3",
        "--seed", "11", "--no-progress"]


@pytest.fixture(scope="module")
def datasets(tmp_path_factory, sprites_dir) -> dict[str, Path]:
    """The same dataset as coco only, coco+yolo boxes (2 workers) and yolo polygons."""
    root = tmp_path_factory.mktemp("yolo")
    runs = {"coco": [], "boxes": ["--format", "coco,yolo", "--workers", "2"],
            "seg": ["--format", "coco", "yolo", "--yolo-seg"]}
    for name, extra in runs.items():
        rc, _, err = cli([*BASE, "--out", root / name, "--sprites", sprites_dir,
                          "--workers", "1", *extra])
        assert rc == 0, err
    return {name: root / name for name in runs}


def coco(folder: Path) -> tuple[dict, dict, dict]:
    """images by id, annotations by image id, and each image's split."""
    images, anns, split = {}, {}, {}
    for s in ("train", "val"):
        d = json.loads((folder / "annotations" / f"instances_{s}.json").read_text())
        for im in d["images"]:
            images[im["id"]] = im
            anns.setdefault(im["id"], [])
            split[im["file_name"]] = s
        for a in d["annotations"]:
            anns[a["image_id"]].append(a)
    return images, anns, split


def labels(folder: Path, file_name: str) -> list[list[float]]:
    text = (folder / "labels" / (Path(file_name).stem + ".txt")).read_text()
    assert text == "" or text.endswith("\n")
    return [[float(v) for v in line.split()] for line in text.splitlines()]


def filled_area(mask: np.ndarray) -> int:
    """Pixels of the mask with its holes (background not 4-connected to the outside) filled."""
    h, w = mask.shape
    pad = np.zeros((h + 2, w + 2), np.uint8)
    pad[1:-1, 1:-1] = mask
    outside = pad.copy()
    cv2.floodFill(outside, np.zeros((h + 4, w + 4), np.uint8), (0, 0), 2, flags=4)
    return int((outside[1:-1, 1:-1] != 2).sum())


def shoelace(poly: np.ndarray) -> float:
    x, y = poly[:, 0], poly[:, 1]
    return 0.5 * abs(float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1))))


def test_format_options_do_not_change_images_or_coco(datasets):
    for name in ("boxes", "seg"):
        for sub in ("images", "masks"):
            a = sorted((datasets["coco"] / sub).iterdir())
            b = sorted((datasets[name] / sub).iterdir())
            assert [p.name for p in a] == [p.name for p in b]
            assert all(p.read_bytes() == q.read_bytes() for p, q in zip(a, b, strict=True))
        for s in ("train", "val"):
            f = f"annotations/instances_{s}.json"
            assert (datasets["coco"] / f).read_bytes() == (datasets[name] / f).read_bytes()
    assert not (datasets["coco"] / "labels").exists()
    assert not (datasets["coco"] / "data.yaml").exists()
    meta = json.loads((datasets["seg"] / "dataset.json").read_text())
    assert meta["config"]["format"] == ["coco", "yolo"] and meta["config"]["yolo_seg"] is True
    assert meta["layout"]["yolo_data"] == "data.yaml"


def test_ultralytics_layout(datasets):
    folder = datasets["boxes"]
    images, anns, split = coco(folder)
    data = yaml.safe_load((folder / "data.yaml").read_text())
    assert "path" not in data  # the root is the yaml's folder: the dataset can move
    assert data["train"] == "train.txt" and data["val"] == "val.txt"
    assert data["nc"] == 1 and data["names"] == {0: "bluerov2"}
    listed = {}
    for s in ("train", "val"):
        lines = (folder / f"{s}.txt").read_text().splitlines()
        assert lines == sorted(lines) and lines
        for line in lines:
            # Ultralytics reads "./x" relative to the list file's folder
            assert line.startswith("./images/")
            assert (folder / line[2:]).is_file()
            listed[Path(line).name] = s
    assert listed == split  # every image once, in its COCO split
    # one label file per image, where Ultralytics looks: /images/ -> /labels/, .txt
    stems = sorted(p.stem for p in (folder / "images").iterdir())
    assert sorted(p.stem for p in (folder / "labels").iterdir()) == stems
    empty = [im for im in images.values() if not anns[im["id"]]]
    assert empty, "the dataset should contain empty images (--count 0-3)"
    for im in empty:
        assert (folder / "labels" / (Path(im["file_name"]).stem + ".txt")).read_bytes() == b""


def matched_rows(folder: Path):
    """Per image of ``folder``: its COCO entry and (label row, annotation) pairs in instance
    order, checking that the label file has one row per annotation."""
    images, anns, _ = coco(folder)
    for image_id, im in images.items():
        rows = labels(folder, im["file_name"])
        assert len(rows) == len(anns[image_id])
        yield im, list(zip(rows, sorted(anns[image_id], key=lambda a: a["instance_id"]),
                           strict=True))


def test_boxes_agree_with_coco(datasets):
    folder = datasets["boxes"]
    n = 0
    for im, pairs in matched_rows(folder):
        W, H = im["width"], im["height"]
        for row, ann in pairs:
            cls, cx, cy, w, h = row
            assert cls == ann["category_id"] - 1
            x, y, bw, bh = ann["bbox"]
            got = [(cx - w / 2) * W, (cy - h / 2) * H, w * W, h * H]
            assert got == pytest.approx([x, y, bw, bh], abs=1e-6 * max(W, H) * 2)
            assert -1e-6 <= cx - w / 2 and cx + w / 2 <= 1 + 1e-6
            n += 1
    assert n > 20


def test_polygons_agree_with_coco_and_masks(datasets):
    folder = datasets["seg"]
    n = 0
    for im, pairs in matched_rows(folder):
        W, H = im["width"], im["height"]
        inst = decode_png16((folder / "masks" / im["mask_file"]).read_bytes())
        for row, ann in pairs:
            assert row[0] == ann["category_id"] - 1
            assert len(row) % 2 == 1 and len(row) >= 1 + 2 * 4
            poly = np.array(row[1:]).reshape(-1, 2) * [W, H]
            x, y, bw, bh = ann["bbox"]
            lo, hi = poly.min(axis=0), poly.max(axis=0)
            # the polygon's extent is the COCO box (pixel edges) to within the 6 decimals
            assert [*lo, *(hi - lo)] == pytest.approx([x, y, bw, bh], abs=2e-6 * max(W, H))
            mask = inst == ann["instance_id"]
            assert int(mask.sum()) == ann["area"]
            # area along the pixel edges: the mask's, with any holes filled
            assert shoelace(poly) == pytest.approx(filled_area(mask), abs=0.01 * ann["area"])
            n += 1
    assert n > 20


def test_mask_polygon_shapes():
    m = np.zeros((9, 11), bool)
    m[2:5, 3:7] = True  # a 4 x 3 rectangle: its four corners exactly
    p = mask_polygon(m)
    assert sorted(map(tuple, p.tolist())) == [(3, 2), (3, 5), (7, 2), (7, 5)]
    one = mask_polygon(np.ones((1, 1), bool), 5, 8)  # one pixel at (5, 8)
    assert sorted(map(tuple, one.tolist())) == [(5, 8), (5, 9), (6, 8), (6, 9)]
    two = np.zeros((6, 10), bool)
    two[1:3, 1:3] = True
    two[3:5, 6:9] = True  # two pieces: joined by a zero-width bridge, areas add
    p = mask_polygon(two)
    assert shoelace(p) == pytest.approx(4 + 6)
    assert p.min(axis=0).tolist() == [1, 1] and p.max(axis=0).tolist() == [9, 5]
    with pytest.raises(ValueError):
        mask_polygon(np.zeros((3, 3), bool))


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**32 - 1), st.floats(0.2, 0.8))
def test_mask_polygon_random_masks(seed, density):
    rng = np.random.default_rng(seed)
    m = cv2.dilate((rng.random((14, 17)) < density * 0.3).astype(np.uint8),
                   np.ones((2, 2), np.uint8)).astype(bool)
    if not m.any():
        m[3, 4] = True
    p = mask_polygon(m)
    ys, xs = np.nonzero(m)
    assert p.min(axis=0).tolist() == [xs.min(), ys.min()]
    assert p.max(axis=0).tolist() == [xs.max() + 1, ys.max() + 1]
    assert shoelace(p) == pytest.approx(filled_area(m))


def test_box_line_and_yaml():
    assert box_line(0, [10, 20, 30, 40], 100, 200) == "0 0.250000 0.200000 0.300000 0.200000"
    text = data_yaml([{"id": 1, "name": "rov"}, {"id": 2, "name": 'odd "name": x'}],
                     has_val=False)
    d = yaml.safe_load(text)
    assert d["names"] == {0: "rov", 1: 'odd "name": x'} and d["nc"] == 2
    assert d["val"] == "train.txt"


def test_resume_redraws_a_missing_label_and_yolo_only(datasets, tmp_path, sprites_dir):
    folder = tmp_path / "only"
    argv = [*BASE, "--n", "12", "--format", "yolo", "--out", folder, "--sprites", sprites_dir,
            "--workers", "1"]
    rc, out, err = cli(argv)
    assert rc == 0, err
    assert "wrote 12 images" in out
    assert not list((folder / "annotations").glob("*.json"))  # no COCO with --format yolo
    s = dataset_stats(folder)  # read from the journal instead
    assert sum(v["images"] for v in s["splits"].values()) == 12
    assert s["categories"] == {1: "bluerov2"}
    ref = {p.name: p.read_bytes() for p in (datasets["boxes"] / "labels").iterdir()}
    got = {p.name: p.read_bytes() for p in (folder / "labels").iterdir()}
    assert got == {k: ref[k] for k in got} and len(got) == 12
    (folder / "labels" / "000003.txt").unlink()
    rc, _, err = cli([*argv, "--resume"])
    assert rc == 0, err
    assert (folder / "labels" / "000003.txt").read_bytes() == ref["000003.txt"]
    # resuming with other label options is refused, naming the option
    rc, _, err = cli([*argv, "--resume", "--yolo-seg"])
    assert rc == 2 and "yolo_seg" in err


@pytest.mark.parametrize("value", ["voc", "coco,json", ""])
def test_bad_format(tmp_path, value):
    rc, _, err = cli(["--n", "2", "--format", value, "--out", tmp_path / "x"])
    assert rc == 2 and "--format" in err and "coco" in err and "Traceback" not in err
    assert not (tmp_path / "x").exists()
