"""The generator's command line and output folder: layout, COCO validity, splits,
determinism across workers, resume, refusals, bad values, config files, presets, backgrounds.

Every run is small (96 px, tens of images, no clutter) and goes through
``run_cli(main, argv)`` so exit statuses and messages are those a user sees.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import os
import re
import shutil
import signal
import subprocess
import sys
from dataclasses import fields
from pathlib import Path

import cv2
import numpy as np
import pytest
from pycocotools import mask as mask_utils
from pycocotools.coco import COCO
from pycocotools.cocoeval import COCOeval

import sdcomp
from sdcomp.cli.generate import build_parser, main
from sdcomp.run import local as writer
from sdcomp.run.record import split_of
from sdcomp.scene.config import RETIRED, GeneratorConfig

from .datasets import by_name, cli, generate, image_path

# pycocotools' own decode under numpy 2 warns about __array__(copy=...); not ours
pytestmark = pytest.mark.filterwarnings("ignore:__array__ implementation:DeprecationWarning")

# dataset A: low altitude so that the BlueROV2 is a few dozen pixels at 96 px; 40 images
# (more than one chunk of 32, so --workers 2 really uses a pool and an interruption can
# come after a checkpointed chunk)
BASE = ["--n", "40", "--size", "96", "--clutter", "0", "--altitude", "3-6", "--count", "0-2",
        "--seed", "7"]
META_KEYS = ("height_above_takeoff(meter)", "gimbal_pitch(degrees)", "gimbal_heading(degrees)",
             "gsd(m/px)", "water_color", "water_rgb", "turbidity", "sun_elevation(degrees)",
             "sun_azimuth(degrees)")
POSE_KEYS = ("heading_deg", "roll_deg", "pitch_deg", "draft_m")
REPO = Path(__file__).resolve().parents[1]


# --------------------------------------------------------------------------- helpers

def gen(out: Path, sprites: Path, *extra, base=BASE, workers: int = 1) -> tuple[int, str, str]:
    """One generator run into ``out`` (flags later in the list win over earlier ones)."""
    return generate(base, out, sprites, *extra, workers=workers)


def python(code: str, argv: list, timeout: float) -> tuple[int, str, str]:
    """Run ``code`` in a fresh Python process (its own session, so that a hang of it or of
    its worker processes is killed as a whole after ``timeout`` seconds and fails the test)."""
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(
        [str(REPO), *filter(None, [os.environ.get("PYTHONPATH")])])}
    proc = subprocess.Popen([sys.executable, "-c", code, *map(str, argv)], cwd=REPO, env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            start_new_session=True)
    try:
        out, err = proc.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.communicate()
        pytest.fail(f"the run did not finish in {timeout} s (hung)")
    return proc.returncode, out, err


CLI = ("import sys; from sdcomp.errors import run_cli; from sdcomp.generate import main; "
       "sys.exit(run_cli(main, sys.argv[1:]))")


def files(root: Path) -> dict[str, bytes]:
    """Every file under ``root`` by relative path."""
    return {p.relative_to(root).as_posix(): p.read_bytes()
            for p in sorted(root.rglob("*")) if p.is_file()}


def snapshot(root: Path) -> dict[str, tuple]:
    """Listing of ``root`` with each entry's kind, size, mtime and bytes."""
    snap = {}
    for p in sorted(root.rglob("*")):
        st = p.stat()
        snap[p.relative_to(root).as_posix()] = (
            p.is_dir(), st.st_size, st.st_mtime_ns, None if p.is_dir() else p.read_bytes())
    return snap


def load_coco(path: Path) -> COCO:
    with contextlib.redirect_stdout(io.StringIO()):
        return COCO(str(path))


def coco_json(root: Path, split: str) -> dict:
    return json.loads((root / "annotations" / f"instances_{split}.json").read_text())


def both(root: Path) -> tuple[list[dict], list[dict]]:
    """Images and annotations of both splits together."""
    images, anns = [], []
    for split in ("train", "val"):
        d = coco_json(root, split)
        images += d["images"]
        anns += d["annotations"]
    return images, anns


def journal_lines(root: Path) -> list[bytes]:
    return [ln for ln in (root / "records.jsonl").read_bytes().splitlines() if ln.strip()]


def assert_same_dataset(a: Path, b: Path) -> None:
    """Every file byte-identical; records.jsonl may differ in line order (and repeat a
    regenerated image's record)."""
    fa, fb = files(a), files(b)
    assert sorted(fa) == sorted(fb)
    differ = [k for k in fa if k != "records.jsonl" and fa[k] != fb[k]]
    assert not differ, f"files differ: {differ[:10]}"
    la, lb = journal_lines(a), journal_lines(b)
    assert set(la) == set(lb)
    last = lambda lines: {json.loads(ln)["index"]: ln for ln in lines}  # noqa: E731
    assert last(la) == last(lb)


@pytest.fixture(scope="module")
def dataset_a(tmp_path_factory, sprites_dir) -> Path:
    """The reference run: BASE, one worker, uninterrupted."""
    out = tmp_path_factory.mktemp("gen") / "a"
    rc, stdout, err = gen(out, sprites_dir)
    assert rc == 0, err
    assert "wrote 40 images" in stdout
    return out


# --------------------------------------------------------------------------- 1. layout

def test_layout_images_masks_annotations_dataset_json(dataset_a):
    root = dataset_a
    assert sorted(p.name for p in root.iterdir()) == sorted(
        ["images", "masks", "annotations", "dataset.json", "records.jsonl"])
    # no leftover temporary files anywhere
    assert not [p for p in root.rglob(".*")]

    image_files = by_name(root / "images")
    mask_files = by_name(root / "masks")
    assert [p.name for p in image_files] == [f"{i:06d}.jpg" for i in range(40)]
    assert [p.name for p in mask_files] == [f"{i:06d}.png" for i in range(40)]
    for p in image_files:
        assert p.read_bytes()[:3] == b"\xff\xd8\xff"  # really a JPEG
        img = cv2.imread(str(p), cv2.IMREAD_UNCHANGED)
        assert img is not None and img.dtype == np.uint8 and img.shape == (96, 96, 3)

    images, anns = both(root)
    by_image: dict[int, list[dict]] = {}
    for a in anns:
        by_image.setdefault(a["image_id"], []).append(a)
    assert len(images) == 40
    for im in images:
        assert (im["width"], im["height"]) == (96, 96)
        assert (root / "images" / im["file_name"]).is_file()
        mask = cv2.imread(str(root / "masks" / im["mask_file"]), cv2.IMREAD_UNCHANGED)
        assert mask is not None and mask.dtype == np.uint16 and mask.shape == (96, 96)
        mine = by_image.get(im["id"], [])
        ids = sorted(int(v) for v in np.unique(mask) if v != 0)
        assert ids == sorted(a["instance_id"] for a in mine), im["file_name"]
        for a in mine:
            assert int((mask == a["instance_id"]).sum()) == a["area"]

    meta = json.loads((root / "dataset.json").read_text())
    assert meta["sdcomp_version"] == sdcomp.__version__
    assert meta["seed"] == 7 and meta["status"] == "complete"
    cfg = meta["config"]
    assert (cfg["n"], cfg["seed"], cfg["width"], cfg["height"]) == (40, 7, 96, 96)
    assert (cfg["altitude"], cfg["count"], cfg["clutter"]) == ("3-6", "0-2", 0)
    c = meta["counts"]
    train, val = coco_json(root, "train"), coco_json(root, "val")
    assert c["images"] == len(image_files) == len(mask_files) == 40
    assert c["train"] == len(train["images"]) and c["val"] == len(val["images"])
    assert c["train"] + c["val"] == 40
    assert c["annotations"] == len(anns) > 0
    assert c["empty_images"] == sum(1 for im in images if im["id"] not in by_image)
    assert c["objects_dropped"] == sum(im["meta"]["objects_dropped"] for im in images)

    lines = journal_lines(root)
    assert sorted(json.loads(ln)["index"] for ln in lines) == list(range(40))


def test_png_image_format(tmp_path, sprites_dir):
    out = tmp_path / "png"
    rc, _, err = gen(out, sprites_dir, "--n", "5", "--image-format", "png")
    assert rc == 0, err
    paths = by_name(out / "images")
    assert [p.name for p in paths] == [f"{i:06d}.png" for i in range(5)]
    for path in paths:
        assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
        img = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
        assert img.dtype == np.uint8 and img.shape == (96, 96, 3)
    images, _ = both(out)
    assert sorted(im["file_name"] for im in images) == sorted(
        p.relative_to(out / "images").as_posix() for p in paths)
    assert json.loads((out / "dataset.json").read_text())["config"]["image_format"] == "png"


# --------------------------------------------------------------------------- 2. COCO

def test_coco_files_valid_for_pycocotools(dataset_a):
    root = dataset_a
    cocos = {s: load_coco(root / "annotations" / f"instances_{s}.json") for s in ("train", "val")}
    image_ids, ann_ids = [], []
    empty_listed = 0
    for split, coco in cocos.items():
        cats = coco.loadCats(coco.getCatIds())
        assert [c["id"] for c in cats] == [1] and cats[0]["name"] == "bluerov2"
        for iid in coco.getImgIds():
            im = coco.imgs[iid]
            image_ids.append(iid)
            assert im["file_name"] == f"{split}/{iid:06d}.jpg"  # id = the file's number
            assert im["mask_file"] == f"{split}/{iid:06d}.png"
            assert split_of(7, iid, 0.2) == split
            for k in META_KEYS:
                assert k in im["meta"], k
            assert isinstance(im["meta"]["water_color"], str)
            assert len(im["meta"]["water_rgb"]) == 3
            assert 3 <= im["meta"]["height_above_takeoff(meter)"] <= 6
            assert im["meta"]["gimbal_pitch(degrees)"] == 90
            assert im["meta"]["gsd(m/px)"] > 0
            mine = coco.loadAnns(coco.getAnnIds(imgIds=[iid]))
            if not mine:
                empty_listed += 1
            mask = cv2.imread(str(root / "masks" / im["mask_file"]), cv2.IMREAD_UNCHANGED)
            if not mine:
                assert not mask.any()
            for a in mine:
                ann_ids.append(a["id"])
                assert a["category_id"] == 1 and a["iscrowd"] == 0
                seg = a["segmentation"]
                assert isinstance(seg["counts"], str) and seg["size"] == [96, 96]
                assert a["area"] == int(mask_utils.area(seg)) == int(
                    (mask == a["instance_id"]).sum()) > 0
                rle_mask = coco.annToMask(a).astype(bool)
                np.testing.assert_array_equal(rle_mask, mask == a["instance_id"])
                x, y, w, h = a["bbox"]
                ys, xs = np.nonzero(rle_mask)
                assert [x, y, w, h] == [xs.min(), ys.min(), xs.max() - xs.min() + 1,
                                        ys.max() - ys.min() + 1]
                for k in POSE_KEYS:
                    assert k in a["pose"], k
    assert len(image_ids) == len(set(image_ids)) == 40
    assert len(ann_ids) == len(set(ann_ids)) > 0
    assert empty_listed >= 1  # images without objects are kept, listed with no annotation


@pytest.mark.parametrize("iou_type", ["bbox", "segm"])
def test_cocoeval_of_ground_truth_against_itself_is_perfect(dataset_a, iou_type):
    for split in ("train", "val"):
        gt = load_coco(dataset_a / "annotations" / f"instances_{split}.json")
        if not gt.getAnnIds():
            continue
        key = "bbox" if iou_type == "bbox" else "segmentation"
        dets = [{"image_id": a["image_id"], "category_id": a["category_id"], key: a[key],
                 "score": 1.0} for a in gt.loadAnns(gt.getAnnIds())]
        with contextlib.redirect_stdout(io.StringIO()):
            dt = gt.loadRes(dets)
            ev = COCOeval(gt, dt, iou_type)
            ev.evaluate()
            ev.accumulate()
            ev.summarize()
        assert ev.stats[0] == pytest.approx(1.0), (split, ev.stats)


# --------------------------------------------------------------------------- 3. split

def test_val_fraction_is_exact_and_deterministic(tmp_path, sprites_dir):
    args = ("--n", "100", "--size", "32", "--count", "0-1", "--seed", "3", "--val-fraction", "0.2")
    roots = [tmp_path / "s1", tmp_path / "s2"]
    for r in roots:
        rc, _, err = gen(r, sprites_dir, *args)
        assert rc == 0, err
    val, train = coco_json(roots[0], "val"), coco_json(roots[0], "train")
    assert len(val["images"]) == 20 and len(train["images"]) == 80
    counts = json.loads((roots[0] / "dataset.json").read_text())["counts"]
    assert (counts["val"], counts["train"]) == (20, 80)
    assert sorted(im["id"] for im in val["images"]) == [
        i for i in range(100) if split_of(3, i, 0.2) == "val"]
    for split in ("train", "val"):
        p = f"annotations/instances_{split}.json"
        assert (roots[0] / p).read_bytes() == (roots[1] / p).read_bytes()
    # another seed chooses other val images (still exactly 20)
    other = [i for i in range(100) if split_of(4, i, 0.2) == "val"]
    assert len(other) == 20 and other != sorted(im["id"] for im in val["images"])


def test_val_fraction_zero_gives_empty_loadable_val(tmp_path, sprites_dir):
    out = tmp_path / "v0"
    rc, _, err = gen(out, sprites_dir, "--n", "10", "--val-fraction", "0")
    assert rc == 0, err
    coco = load_coco(out / "annotations" / "instances_val.json")
    assert coco.getImgIds() == [] and coco.getAnnIds() == [] and coco.getCatIds() == [1]
    assert len(load_coco(out / "annotations" / "instances_train.json").getImgIds()) == 10
    counts = json.loads((out / "dataset.json").read_text())["counts"]
    assert (counts["train"], counts["val"]) == (10, 0)


# --------------------------------------------------------------------------- 4. determinism

def test_two_workers_give_identical_files(dataset_a, tmp_path, sprites_dir):
    # as a user runs it: a fresh process (see the next test for a long-lived one)
    b = tmp_path / "w2"
    rc, _, err = python(CLI, [*BASE, "--out", b, "--sprites", sprites_dir, "--workers", 2,
                              "--no-progress"], timeout=60)
    assert rc == 0, err
    assert_same_dataset(dataset_a, b)


def test_workers_after_opencv_use_in_the_same_process(tmp_path, sprites_dir):
    """A process that used OpenCV's thread pool earlier (a notebook, a previous run through
    the Python API) and then generates with workers must not hang: the forked workers
    inherit the pool's state."""
    code = ("import sys, time, numpy as np, cv2\n"
            "cv2.GaussianBlur(np.zeros((2000, 2000), np.float32), (31, 31), 5)\n"
            "time.sleep(1.0)  # the pool's threads go to sleep on their condition variable\n"
            + CLI)
    out = tmp_path / "after_cv2"
    rc, _, err = python(code, [*BASE, "--out", out, "--sprites", sprites_dir, "--workers", 2,
                               "--no-progress"], timeout=40)
    assert rc == 0, err
    assert len(by_name(out / "images")) == 40


def test_other_seed_gives_other_images(dataset_a, tmp_path, sprites_dir):
    b = tmp_path / "seed8"
    rc, _, err = gen(b, sprites_dir, "--seed", "8")
    assert rc == 0, err
    # (another seed puts other images in val: compare by file name)
    fa = {Path(k).name: v for k, v in files(dataset_a / "images").items()}
    fb = {Path(k).name: v for k, v in files(b / "images").items()}
    assert sorted(fa) == sorted(fb)
    assert all(fa[k] != fb[k] for k in fa)
    assert json.loads((b / "dataset.json").read_text())["seed"] == 8


# --------------------------------------------------------------------------- 5. resume

def test_interrupted_run_resumes_to_identical_dataset(dataset_a, tmp_path, sprites_dir,
                                                      monkeypatch):
    b = tmp_path / "b"
    real = writer.make_record
    calls = []

    def flaky(gen_, index, *rest):
        if len(calls) == 35:  # Ctrl-C while rendering image 35 (the second chunk)
            raise KeyboardInterrupt
        calls.append(index)
        return real(gen_, index, *rest)

    monkeypatch.setattr(writer, "make_record", flaky)
    rc, _, err = gen(b, sprites_dir)
    assert rc == 130
    assert calls == list(range(35))
    assert "--resume" in err

    meta = json.loads((b / "dataset.json").read_text())
    assert meta["status"] == "interrupted"
    images, anns = both(b)
    done = sorted(im["id"] for im in images)
    journaled = sorted(json.loads(ln)["index"] for ln in journal_lines(b))
    # the COCO files cover exactly the images whose records were written (whole chunks)
    assert done == journaled == list(range(35 // writer.CHUNK * writer.CHUNK))
    assert meta["counts"]["images"] == len(done)
    for split in ("train", "val"):  # valid COCO, and the same entries as the full run
        load_coco(b / "annotations" / f"instances_{split}.json")
        full = coco_json(dataset_a, split)
        part = coco_json(b, split)
        assert part["images"] == [im for im in full["images"] if im["id"] in done]
        assert part["annotations"] == [a for a in full["annotations"]
                                       if a["image_id"] in done]
    for im in images:
        assert (b / "images" / im["file_name"]).is_file()
        assert (b / "masks" / im["mask_file"]).is_file()

    monkeypatch.setattr(writer, "make_record", real)
    # a leftover temporary file, and an image of the journal that went missing
    lost = image_path(b, 5)
    tmp = lost.parent / ".000003.jpg.123.tmp"
    tmp.write_bytes(b"half a jpeg")
    lost.unlink()
    rc, _, err = gen(b, sprites_dir, "--resume")
    assert rc == 0, err
    assert not tmp.exists()
    assert lost.is_file()
    assert json.loads((b / "dataset.json").read_text())["status"] == "complete"
    assert_same_dataset(dataset_a, b)

    # resuming a complete dataset (other worker count: not an output option) changes nothing
    before = files(b)
    rc, _, err = gen(b, sprites_dir, "--resume", workers=2)
    assert rc == 0, err
    assert files(b) == before


# --------------------------------------------------------------------------- 6. refusals

def test_non_empty_out_is_refused_without_resume_or_overwrite(dataset_a, tmp_path,
                                                             sprites_dir):
    c = tmp_path / "c"
    shutil.copytree(dataset_a, c)
    before = snapshot(c)
    rc, _, err = gen(c, sprites_dir)
    assert rc == 2
    assert err.startswith("error: ") and err.count("\n") == 1
    assert "--resume" in err and "--overwrite" in err
    assert snapshot(c) == before

    # --resume with other output options: refused, naming the option, nothing changed
    for flag, value, name in [("--altitude", "4-7", "altitude"), ("--seed", "9", "seed"),
                              ("--size", "64", "width")]:
        rc, _, err = gen(c, sprites_dir, "--resume", flag, value)
        assert rc == 2, flag
        assert err.startswith("error: ") and err.count("\n") == 1
        assert name in err, err
        assert snapshot(c) == before

    # --overwrite replaces the dataset (another seed and size: nothing of the old is left)
    (c / "notes.txt").write_text("mine")
    rc, _, err = gen(c, sprites_dir, "--overwrite", "--n", "5", "--seed", "9")
    assert rc == 0, err
    assert [p.name for p in by_name(c / "images")] == [f"{i:06d}.jpg" for i in range(5)]
    assert len(by_name(c / "masks")) == 5
    assert len(journal_lines(c)) == 5
    meta = json.loads((c / "dataset.json").read_text())
    assert (meta["seed"], meta["config"]["n"], meta["counts"]["images"]) == (9, 5, 5)
    images, _ = both(c)
    assert len(images) == 5
    assert (c / "notes.txt").read_text() == "mine"  # only the dataset's own files go


# --------------------------------------------------------------------------- 7. bad values

def _bad_cases(tmp: Path) -> dict[str, tuple[list[str], str, str | None]]:
    """name: (argv, flag the message must name, other text it must contain)."""
    empty = tmp / "empty_bg"
    empty.mkdir()
    (empty / "readme.txt").write_text("no photos here")
    corrupt = tmp / "corrupt_bg"
    corrupt.mkdir()
    (corrupt / "broken.jpg").write_bytes(b"this is not a jpeg")
    bad_toml = tmp / "bad.toml"
    bad_toml.write_text("altitude = [\n")
    unknown = tmp / "unknown.toml"
    unknown.write_text("altitude = 20\nbogus_key = 3\n")
    return {
        "n0": (["--n", "0"], "--n", None),
        "n-5": (["--n", "-5"], "--n", None),
        "alt0": (["--altitude", "0"], "--altitude", None),
        "alt-3": (["--altitude", "-3"], "--altitude", None),
        "alt50-10": (["--altitude", "50-10"], "--altitude", None),
        "water-purple": (["--water", "purple"], "--water", None),
        "water-300": (["--water", "300,0,0"], "--water", None),
        "preset": (["--preset", "nope"], "--preset", None),
        "size0": (["--size", "0"], "--size", None),
        "width0": (["--width", "0"], "--width", None),
        "pitch1": (["--pitch", "1"], "--pitch", None),
        "pitch95": (["--pitch", "95"], "--pitch", None),
        "turbidity": (["--turbidity", "1.5"], "--turbidity", None),
        "val2": (["--val-fraction", "2"], "--val-fraction", None),
        "bg-missing": (["--backgrounds", tmp / "no_such_dir"], "--backgrounds", None),
        "bg-empty": (["--backgrounds", empty], "--backgrounds", None),
        "bg-corrupt": (["--backgrounds", corrupt], "--backgrounds", "broken.jpg"),
        "object-missing": (["--object", tmp / "no_such_mesh.obj"], "--object",
                           "no_such_mesh.obj"),
        "config-missing": (["--config", tmp / "no_such.toml"], "--config", None),
        "config-invalid": (["--config", bad_toml], "--config", None),
        "config-unknown": (["--config", unknown], "--config", "bogus_key"),
        "format-gif": (["--image-format", "gif"], "--image-format", None),
        "camera": (["--camera", "nope"], "--camera", None),
        "count3-1": (["--count", "3-1"], "--count", None),
        "workers0": (["--workers", "0"], "--workers", None),
        "camera-off": (["--camera-off", "lens", "blocks"], "--camera-off", "blocks"),
    }


BAD_NAMES = ["n0", "n-5", "alt0", "alt-3", "alt50-10", "water-purple", "water-300", "preset",
             "size0", "width0", "pitch1", "pitch95", "turbidity", "val2", "bg-missing",
             "bg-empty", "bg-corrupt", "object-missing", "config-missing", "config-invalid",
             "config-unknown", "format-gif", "camera", "count3-1", "workers0", "camera-off"]


@pytest.mark.parametrize("case", BAD_NAMES)
def test_bad_value_exits_2_naming_the_flag_and_writes_nothing(case, tmp_path, sprites_dir):
    argv, flag, extra = _bad_cases(tmp_path)[case]
    out = tmp_path / "out"
    rc, stdout, err = cli(["--n", "3", "--size", "96", "--clutter", "0", *argv,
                           "--out", out, "--sprites", sprites_dir, "--no-progress"])
    assert rc == 2, (rc, err)
    assert err.startswith("error: ") and err.endswith("\n") and err.count("\n") == 1, err
    assert re.search(re.escape(flag) + r"(?![\w-])", err), f"{flag} not named in: {err}"
    if extra:
        assert extra in err, err
    assert not out.exists()
    assert "Traceback" not in err and "wrote" not in stdout


def test_bad_case_names_cover_all_cases(tmp_path):
    assert sorted(_bad_cases(tmp_path)) == sorted(BAD_NAMES)


# --------------------------------------------------------------------------- 8. config, presets

def metas(root: Path) -> list[dict]:
    images, _ = both(root)
    return [im["meta"] for im in images]


def test_config_file_is_applied_and_flags_override_it(tmp_path, sprites_dir):
    conf = tmp_path / "gen.toml"
    conf.write_text('altitude = "20-30"\nwater = ["blue"]\ncount = 1\n')
    small = ["--n", "10", "--size", "96", "--clutter", "0"]
    a = tmp_path / "conf"
    rc, _, err = cli([*small, "--config", conf, "--out", a, "--sprites", sprites_dir,
                      "--workers", 1, "--no-progress"])
    assert rc == 0, err
    ms = metas(a)
    assert len(ms) == 10
    assert all(20 <= m["height_above_takeoff(meter)"] <= 30 for m in ms)
    assert len({m["height_above_takeoff(meter)"] for m in ms}) > 1  # a range, not a value
    assert all(m["water_color"] == "blue" for m in ms)
    assert all(m["objects_placed"] == 1 for m in ms)
    cfg = json.loads((a / "dataset.json").read_text())["config"]
    assert (cfg["altitude"], cfg["water"], cfg["count"]) == ("20-30", ["blue"], 1)

    b = tmp_path / "conf_flags"
    rc, _, err = cli([*small, "--config", conf, "--altitude", "12", "--water", "green",
                      "--out", b, "--sprites", sprites_dir, "--workers", 1, "--no-progress"])
    assert rc == 0, err
    ms = metas(b)
    assert all(m["height_above_takeoff(meter)"] == 12 for m in ms)
    assert all(m["water_color"] == "green" for m in ms)
    assert all(m["objects_placed"] == 1 for m in ms)  # the file's count still applies


def test_preset_paper_alt30(tmp_path, sprites_dir):
    out = tmp_path / "preset"
    rc, _, err = cli(["--preset", "paper-alt30", "--n", "10", "--size", "96", "--clutter", "0",
                      "--out", out, "--sprites", sprites_dir, "--workers", 1, "--no-progress"])
    assert rc == 0, err
    ms = metas(out)
    assert len(ms) == 10
    assert all(m["height_above_takeoff(meter)"] == 30 for m in ms)
    assert all(m["water_color"] == "brown" for m in ms)
    assert all(m["objects_placed"] == 1 for m in ms)
    images, _ = both(out)
    assert all((im["width"], im["height"]) == (96, 96) for im in images)  # flag over preset


def test_help_lists_every_flag_with_a_default(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["--help"])
    assert exc.value.code == 0
    text = " ".join(capsys.readouterr().out.split())
    parser = build_parser()
    # earlier versions' flags (RETIRED) are accepted but not listed
    shown = [a for a in parser._actions if a.help != argparse.SUPPRESS]
    flags = [s for a in shown for s in a.option_strings if s.startswith("--")]
    for f in fields(GeneratorConfig):
        flag = "--object" if f.name == "objects" else "--" + f.name.replace("_", "-")
        assert flag in flags, flag
    for flag in flags:
        assert flag in text, flag
    hidden = {s for a in parser._actions if a.help == argparse.SUPPRESS for s in a.option_strings}
    assert {"--" + name.replace("_", "-") for name in RETIRED} <= hidden
    # each option's help line states its default (switches and name-pickers excepted)
    no_default = {"--help", "--resume", "--overwrite", "--preset", "--config"}
    for action in shown:
        opts = [s for s in action.option_strings if s.startswith("--")]
        if not opts or set(opts) & no_default:
            continue
        helptext = " ".join((action.help or "").split())
        assert "(default:" in helptext, opts


# --------------------------------------------------------------------------- 9. backgrounds

def test_backgrounds_folder_of_photos(tmp_path, sprites_dir):
    bg = tmp_path / "photos"
    bg.mkdir()
    rng = np.random.default_rng(0)
    for k in range(2):
        # magenta-ish photos: nothing the procedural water ever looks like
        yy, xx = np.mgrid[0:150, 0:200]
        img = np.zeros((150, 200, 3), np.float32)
        img[..., 0] = 150 + 60 * xx / 200 + k * 20  # B
        img[..., 2] = 150 + 60 * yy / 150  # R
        img[..., 1] = 30
        img += rng.normal(0, 8, img.shape)
        cv2.imwrite(str(bg / f"water{k}.jpg"), np.clip(img, 0, 255).astype(np.uint8))
    small = ["--n", "6", "--size", "96", "--clutter", "0", "--altitude", "4-6", "--seed", "2"]
    a, b = tmp_path / "with_bg", tmp_path / "procedural"
    rc, _, err = gen(a, sprites_dir, "--backgrounds", bg, base=small)
    assert rc == 0, err
    rc, _, err = gen(b, sprites_dir, base=small)
    assert rc == 0, err
    fa, fb = files(a / "images"), files(b / "images")
    assert sorted(fa) == sorted(fb) and len(fa) == 6
    assert all(fa[k] != fb[k] for k in fa)
    for name in fa:
        rgb = cv2.imread(str(a / "images" / name))[..., ::-1].reshape(-1, 3).mean(0)
        assert rgb[0] > rgb[1] + 60 and rgb[2] > rgb[1] + 60, (name, rgb)
        proc = cv2.imread(str(b / "images" / name))[..., ::-1].reshape(-1, 3).mean(0)
        assert not (proc[0] > proc[1] + 60 and proc[2] > proc[1] + 60), (name, proc)
    cfg = json.loads((a / "dataset.json").read_text())["config"]
    assert cfg["backgrounds"] == str(bg)


def test_chunk_size_follows_frame_size_and_run_length():
    """Tasks handed to workers: up to CHUNK small images, one full-resolution frame per
    task, and short runs cut so that every worker gets several tasks."""
    assert writer.chunk_size(416, 416, 2500, 2) == writer.CHUNK
    assert writer.chunk_size(416, 416, 2500, 1) == writer.CHUNK
    assert writer.chunk_size(5472, 3648, 2500, 2) == 1
    assert writer.chunk_size(30000, 30000, 1, 1) == 1
    assert writer.chunk_size(416, 416, 40, 2) == 5  # 8 tasks for 2 workers
    assert writer.chunk_size(416, 416, 40, 1) == writer.CHUNK  # no pool: fewer journal writes
    assert writer.chunk_size(2000, 2000, 2500, 2) == writer.CHUNK_PIXELS // 4_000_000
