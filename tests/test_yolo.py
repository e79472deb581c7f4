"""YOLO export: label files against the COCO annotations of the same dataset, the layout
Ultralytics and supervision read (per-split images/ and labels/ folders, ./-relative split
lists, data.yaml), polygons that their own rasterisers draw back to our masks, images
unchanged by the format options, resume, yolo-only runs."""

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
from sdcomp.io.yolo import VERTEX_INSET, box_line, data_yaml, mask_polygon
from sdcomp.report.stats import dataset_stats

from .datasets import cli, files

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
    """The rows of the label file of the image ``file_name`` ("train/000003.jpg")."""
    text = (folder / "labels" / Path(file_name).with_suffix(".txt")).read_text()
    assert text == "" or text.endswith("\n")
    return [[float(v) for v in line.split()] for line in text.splitlines()]


def test_format_options_do_not_change_images_or_coco(datasets):
    for name in ("boxes", "seg"):
        for sub in ("images", "masks"):
            a, b = files(datasets["coco"] / sub), files(datasets[name] / sub)
            assert a == b and len(a) == 40
        for s in ("train", "val"):
            f = f"annotations/instances_{s}.json"
            assert (datasets["coco"] / f).read_bytes() == (datasets[name] / f).read_bytes()
    assert not (datasets["coco"] / "labels").exists()
    assert not (datasets["coco"] / "data.yaml").exists()
    assert sorted(p.name for p in datasets["coco"].iterdir()) == [
        "annotations", "dataset.json", "images", "masks", "records.jsonl"]
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
            assert line.startswith(f"./images/{s}/")
            assert (folder / line[2:]).is_file()
            listed[line.removeprefix("./images/")] = s
    assert listed == split  # every image once, in its COCO split, in its split's folder
    for s in ("train", "val"):
        # one label file per image, where Ultralytics looks: /images/ -> /labels/, .txt
        stems = sorted(p.stem for p in (folder / "images" / s).iterdir())
        assert sorted(p.stem for p in (folder / "labels" / s).iterdir()) == stems
    # COCO ids are the numbers in the file names (what Ultralytics' save_json writes)
    assert all(int(Path(im["file_name"]).stem) == i for i, im in images.items())
    empty = [im for im in images.values() if not anns[im["id"]]]
    assert empty, "the dataset should contain empty images (--count 0-3)"
    for im in empty:
        assert labels(folder, im["file_name"]) == []


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


def fill_like_consumers(poly: np.ndarray, shape: tuple[int, int]) -> tuple[np.ndarray, ...]:
    """The masks Ultralytics (vertices truncated) and supervision (rounded) draw from a
    (K, 2) pixel polygon: ``cv2.fillPoly`` of the integer vertices, as both do."""
    out = []
    for ints in (poly.astype(np.int32), np.round(poly).astype(np.int32)):
        m = np.zeros(shape, np.uint8)
        cv2.fillPoly(m, [ints], 1)
        out.append(m.astype(bool))
    return tuple(out)


def holes(mask: np.ndarray) -> int:
    """Holes of a mask: background regions (4-connected) not touching its border."""
    h, w = mask.shape
    pad = np.ones((h + 2, w + 2), np.uint8)
    pad[1:-1, 1:-1] = ~mask
    n, lab = cv2.connectedComponents(pad, connectivity=4)
    return n - 2 if n > 1 else 0  # the outside, then the holes (label 0 is the mask)


def test_polygons_agree_with_coco_and_masks(datasets):
    folder = datasets["seg"]
    n = exact = 0
    for im, pairs in matched_rows(folder):
        W, H = im["width"], im["height"]
        inst = decode_png16((folder / "masks" / im["mask_file"]).read_bytes())
        for row, ann in pairs:
            assert row[0] == ann["category_id"] - 1
            assert len(row) % 2 == 1 and len(row) >= 1 + 2 * 4
            poly = np.array(row[1:]).reshape(-1, 2) * [W, H]
            x, y, bw, bh = ann["bbox"]
            lo, hi = poly.min(axis=0), poly.max(axis=0)
            # the extent: the box's left/top edge, half a pixel short on the right/bottom
            assert lo == pytest.approx([x + VERTEX_INSET, y + VERTEX_INSET], abs=1e-4)
            assert hi == pytest.approx([x + bw - 0.5 - VERTEX_INSET,
                                        y + bh - 0.5 - VERTEX_INSET], abs=1e-4)
            mask = inst == ann["instance_id"]
            # one piece without holes is drawn back exactly; a mask in pieces (a submerged
            # object's faded parts) is joined by bridges that add pixels, never lose one
            simple = (cv2.connectedComponents(mask.astype(np.uint8), connectivity=8)[0] == 2
                      and holes(mask) == 0)
            for drawn in fill_like_consumers(poly, (H, W)):
                assert (drawn >= mask).all()  # never a pixel lost
                assert not simple or (drawn == mask).all(), (im["file_name"], ann["id"])
                exact += simple
            n += 1
    assert n > 20 and exact >= 0.75 * 2 * n


def test_mask_polygon_shapes():
    m = np.zeros((9, 11), bool)
    m[2:5, 3:7] = True  # a 4 x 3 rectangle: vertices inside its corner pixels
    p = mask_polygon(m)
    lo, hi = VERTEX_INSET, 0.5 - VERTEX_INSET
    assert sorted(map(tuple, p.tolist())) == [(3 + lo, 2 + lo), (3 + lo, 4 + hi),
                                              (6 + hi, 2 + lo), (6 + hi, 4 + hi)]
    one = mask_polygon(np.ones((1, 1), bool), 5, 8)  # one pixel at (5, 8)
    assert sorted(map(tuple, one.tolist())) == [(5 + lo, 8 + lo), (5 + lo, 8 + hi),
                                                (5 + hi, 8 + lo), (5 + hi, 8 + hi)]
    ring = np.ones((7, 8), bool)
    ring[2:4, 3:5] = False  # a hole: kept
    for drawn in fill_like_consumers(mask_polygon(ring), ring.shape):
        assert (drawn == ring).all()
    two = np.zeros((6, 10), bool)
    two[1:3, 1:3] = True
    two[3:5, 6:9] = True  # two pieces: joined by a zero-width bridge, drawn as a line
    for drawn in fill_like_consumers(mask_polygon(two), two.shape):
        assert (drawn >= two).all() and (drawn & ~two).sum() <= 4
    with pytest.raises(ValueError):
        mask_polygon(np.zeros((3, 3), bool))


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**32 - 1), st.floats(0.2, 0.8))
def test_mask_polygon_random_masks(seed, density):
    """Drawn as the consumers draw it, a polygon never loses a pixel of its mask, and gives
    exactly a mask in one piece without holes; its extent is the mask's box with the
    vertices inside their pixels."""
    rng = np.random.default_rng(seed)
    m = cv2.dilate((rng.random((14, 17)) < density * 0.3).astype(np.uint8),
                   np.ones((2, 2), np.uint8)).astype(bool)
    if not m.any():
        m[3, 4] = True
    p = mask_polygon(m)
    ys, xs = np.nonzero(m)
    assert np.floor(p.min(axis=0)).tolist() == [xs.min(), ys.min()]
    assert np.floor(p.max(axis=0)).tolist() == [xs.max(), ys.max()]
    one_piece = cv2.connectedComponents(m.astype(np.uint8), connectivity=8)[0] == 2
    for drawn in fill_like_consumers(p, m.shape):
        assert (drawn >= m).all()
        if one_piece and holes(m) == 0:
            assert (drawn == m).all()


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
    assert not (folder / "annotations").exists()  # no empty COCO folder either
    ref = files(datasets["boxes"] / "labels")
    got = files(folder / "labels")
    assert got == {k: ref[k] for k in got} and len(got) == 12
    lost = next(folder.glob("labels/*/000003.txt"))
    lost.unlink()
    rc, _, err = cli([*argv, "--resume"])
    assert rc == 0, err
    assert lost.read_bytes() == ref[lost.relative_to(folder / "labels").as_posix()]
    # resuming with other label options is refused, naming the option
    rc, _, err = cli([*argv, "--resume", "--yolo-seg"])
    assert rc == 2 and "yolo_seg" in err


def test_yolo_seg_needs_yolo_output(tmp_path):
    rc, _, err = cli(["--n", "2", "--yolo-seg", "--out", tmp_path / "x"])
    assert rc == 2 and "--yolo-seg" in err and "--format yolo" in err
    assert err.count("\n") == 1 and not (tmp_path / "x").exists()


@pytest.mark.parametrize("value", ["voc", "coco,json", ""])
def test_bad_format(tmp_path, value):
    rc, _, err = cli(["--n", "2", "--format", value, "--out", tmp_path / "x"])
    assert rc == 2 and "--format" in err and "coco" in err and "Traceback" not in err
    assert not (tmp_path / "x").exists()
