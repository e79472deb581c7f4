"""``sdcomp check``: a clean dataset passes with its summary; each kind of corruption of a
real small dataset is found (one line naming the file) and exits 1."""

from __future__ import annotations

import json
import shutil
from collections.abc import Callable
from pathlib import Path

import cv2
import numpy as np
import pytest

from sdcomp.cli.check import main as check_main

from .datasets import cli, generate

# pycocotools' own decode under numpy 2 warns about __array__(copy=...); not ours
pytestmark = pytest.mark.filterwarnings("ignore:__array__ implementation:DeprecationWarning")

BASE = ["--size", "128", "--clutter", "0", "--count", "1-4", "--seed", "5", "--n", "8",
        "--format", "coco,yolo"]


@pytest.fixture(scope="module")
def clean(tmp_path_factory, sprites_dir) -> Path:
    out = tmp_path_factory.mktemp("check") / "clean"
    rc, _, err = generate(BASE, out, sprites_dir)
    assert rc == 0, err
    return out


def _check(folder: Path) -> tuple[int, list[str]]:
    rc, out, err = cli([str(folder)], check_main)
    assert not err, err
    return rc, out.splitlines()


def test_clean_dataset_passes_with_a_summary(clean):
    rc, lines = _check(clean)
    counts = json.loads((clean / "dataset.json").read_text())["counts"]
    assert rc == 0 and len(lines) == 1, lines
    assert lines[0] == (f"8 images: {counts['annotations']} objects labelled, "
                        f"{counts['objects_truncated']} truncated, "
                        f"{counts['objects_ignored']} ignored; 0 problems")


def _coco(root: Path, split: str = "train") -> tuple[Path, dict]:
    path = root / "annotations" / f"instances_{split}.json"
    return path, json.loads(path.read_text())


def _first(root: Path, crowd: bool) -> tuple[Path, dict, dict]:
    """(COCO file, its dict, its first annotation that is (not) an ignore region)."""
    for split in ("train", "val"):
        path, coco = _coco(root, split)
        for a in coco["annotations"]:
            if bool(a["iscrowd"]) == crowd:
                return path, coco, a
    raise AssertionError("no such annotation")


def _image_of(coco: dict, ann: dict) -> dict:
    return next(im for im in coco["images"] if im["id"] == ann["image_id"])


def shift_a_box(root: Path) -> str:
    path, coco, a = _first(root, crowd=False)
    a["bbox"][0] += 1.0
    path.write_text(json.dumps(coco))
    return _image_of(coco, a)["file_name"]


def renumber_an_image(root: Path) -> str:
    path, coco = _coco(root)
    im = coco["images"][0]
    old = im["id"]
    im["id"] = old + 500
    for a in coco["annotations"]:
        if a["image_id"] == old:
            a["image_id"] = old + 500
    path.write_text(json.dumps(coco))
    return im["file_name"]


def crop_a_mask(root: Path) -> str:
    _, coco = _coco(root)
    im = coco["images"][0]
    p = root / "masks" / im["mask_file"]
    cv2.imwrite(str(p), cv2.imread(str(p), cv2.IMREAD_UNCHANGED)[:-1])
    return im["file_name"]


def erase_an_object(root: Path) -> str:
    _, coco, a = _first(root, crowd=False)
    im = _image_of(coco, a)
    p = root / "masks" / im["mask_file"]
    m = cv2.imread(str(p), cv2.IMREAD_UNCHANGED)
    m[m == a["instance_id"]] = 0
    cv2.imwrite(str(p), m)
    return im["file_name"]


def clear_an_ignore_mask(root: Path) -> str:
    _, coco, a = _first(root, crowd=True)
    im = _image_of(coco, a)
    p = root / "masks" / im["ignore_file"]
    cv2.imwrite(str(p), np.zeros((im["height"], im["width"]), np.uint8))
    return im["file_name"]


def drop_an_ignore_region(root: Path) -> str:
    path, coco, a = _first(root, crowd=True)
    coco["annotations"].remove(a)
    path.write_text(json.dumps(coco))
    return _image_of(coco, a)["file_name"]


def drop_a_yolo_line(root: Path) -> str:
    _, coco, a = _first(root, crowd=False)
    im = _image_of(coco, a)
    p = (root / "labels" / im["file_name"]).with_suffix(".txt")
    p.write_text("".join(p.read_text().splitlines(keepends=True)[1:]))
    return im["file_name"]


def move_a_yolo_box(root: Path) -> str:
    _, coco, a = _first(root, crowd=False)
    im = _image_of(coco, a)
    p = (root / "labels" / im["file_name"]).with_suffix(".txt")
    first, *rest = p.read_text().splitlines(keepends=True)
    cls, cx, *wh = first.split()
    p.write_text(" ".join([cls, f"{float(cx) + 0.01:.6f}", *wh]) + "\n" + "".join(rest))
    return im["file_name"]


def hide_a_placed_object(root: Path) -> str:
    path, coco, a = _first(root, crowd=False)
    im = _image_of(coco, a)
    im["meta"]["objects_placed"] += 1
    path.write_text(json.dumps(coco))
    return im["file_name"]


def list_an_image_in_both_splits(root: Path) -> str:
    line = (root / "train.txt").read_text().splitlines()[0]
    with open(root / "val.txt", "a") as f:
        f.write(line + "\n")
    return line


CORRUPTIONS: list[Callable[[Path], str]] = [
    shift_a_box, renumber_an_image, crop_a_mask, erase_an_object, clear_an_ignore_mask,
    drop_an_ignore_region, drop_a_yolo_line, move_a_yolo_box, hide_a_placed_object,
    list_an_image_in_both_splits]


@pytest.mark.parametrize("corrupt", CORRUPTIONS, ids=lambda f: f.__name__)
def test_each_corruption_is_found(clean, tmp_path, corrupt):
    root = tmp_path / "d"
    shutil.copytree(clean, root)
    where = corrupt(root)
    rc, lines = _check(root)
    assert rc == 1
    problems, summary = lines[:-1], lines[-1]
    assert problems and summary.endswith(f"; {len(problems)} problems")
    assert any(where in line for line in problems), (where, problems)


# --------------------------------------------------------------------------- video runs

VIDEO = ["video", "--size", "128", "--frames", "6", "--sequences", "2", "--seed", "4",
         "--count", "2-5", "--altitude", "6-12", "--workers", "1", "--quiet",
         "--format", "coco,yolo"]


@pytest.fixture(scope="module")
def clips(tmp_path_factory, sprites_dir) -> Path:
    from sdcomp.cli import main as sdcomp_main

    out = tmp_path_factory.mktemp("check") / "clips"
    rc, _, err = cli([*VIDEO, "--out", str(out), "--sprites", str(sprites_dir)], sdcomp_main)
    assert rc == 0, err
    return out


def test_clean_video_run_passes(clips):
    rc, lines = _check(clips)
    coco = json.loads((clips / "annotations" / "instances_video.json").read_text())
    crowd = sum(a["iscrowd"] for a in coco["annotations"])
    assert rc == 0 and len(lines) == 1, lines
    assert lines[0] == (f"12 images: {len(coco['annotations']) - crowd} objects labelled, 0 "
                        f"truncated, {crowd} ignored; 0 problems")


def _drop_gt_row(root: Path) -> str:
    gt = root / "sdcomp-0001" / "gt" / "gt.txt"
    rows = gt.read_text().splitlines(keepends=True)
    gt.write_text("".join(rows[1:]))
    frame, track = rows[0].split(",")[:2]
    return f"frame {frame}, id {track}"


def _move_gt_box(root: Path) -> str:
    gt = root / "sdcomp-0000" / "gt" / "gt.txt"
    rows = gt.read_text().splitlines(keepends=True)
    cells = rows[-1].split(",")
    cells[2] = str(float(cells[2]) + 3)
    rows[-1] = ",".join(cells)
    gt.write_text("".join(rows))
    return "is not the COCO bbox"


def _erase_from_mask(root: Path) -> str:
    from sdcomp.io.png import decode_png16, encode_png16

    for mask in sorted((root / "sdcomp-0000" / "masks").glob("0*[0-9].png")):
        m = decode_png16(mask.read_bytes())
        if m.any():
            m[m == m.max()] = 0
            mask.write_bytes(encode_png16(m))
            return f"sdcomp-0000/img1/{mask.stem}"
    raise AssertionError("no object in sequence 0")


@pytest.mark.parametrize("corrupt", [_drop_gt_row, _move_gt_box, _erase_from_mask],
                         ids=["gt-row-missing", "gt-box-moved", "mask-erased"])
def test_each_video_corruption_is_found(clips, tmp_path, corrupt):
    root = tmp_path / "clips"
    shutil.copytree(clips, root)
    what = corrupt(root)
    rc, lines = _check(root)
    assert rc == 1 and any(what in line for line in lines[:-1]), lines
    assert lines[-1].endswith(f"{len(lines) - 1} problems")
