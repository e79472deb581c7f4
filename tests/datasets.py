"""Helpers for the fault, shard and fuzz tests: run the generator, check a dataset folder.

:func:`check_intact` is the "nothing corrupt" check after any fault: every file under a final
name is whole (images and masks decode completely, JSON parses, the COCO files load in
pycocotools and name only files that exist, the journal reads), masks, boxes and areas agree;
:func:`check_video_intact` is the same for a video run's folder.
"""

from __future__ import annotations

import contextlib
import io
import json
import os
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

import cv2
import numpy as np
from pycocotools import mask as mask_utils
from pycocotools.coco import COCO

from sdcomp.cli.check import main as check_main
from sdcomp.cli.generate import main
from sdcomp.errors import run_cli
from sdcomp.io.journal import read_journal
from sdcomp.io.mot import read_gt
from sdcomp.report.check import check_video

REPO = Path(__file__).resolve().parents[1]
CLI = ("import sys; from sdcomp.errors import run_cli; from sdcomp.generate import main; "
       "sys.exit(run_cli(main, sys.argv[1:]))")
VIDEO_CLI = ("import sys; from sdcomp.errors import run_cli; from sdcomp.video import main; "
             "sys.exit(run_cli(main, sys.argv[1:]))")
PNG_END = b"IEND\xaeB`\x82"


def cli(argv: list, entry=main) -> tuple[int, str, str]:
    """Run a command line in this process: (exit status, stdout, stderr)."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        rc = run_cli(entry, [str(a) for a in argv])
    return rc, out.getvalue(), err.getvalue()


def generate(base: list, out: Path, sprites: Path, *extra, workers: int = 1
             ) -> tuple[int, str, str]:
    """One generator run of flags ``base`` then ``extra`` (later flags win) into ``out``,
    without a progress bar: (exit status, stdout, stderr)."""
    return cli([*base, *extra, "--out", out, "--sprites", sprites, "--workers", workers,
                "--no-progress"])


def popen(code: str, argv: list) -> subprocess.Popen:
    """``python -c code argv...`` in its own session (so its workers can be killed with it)."""
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(
        [str(REPO), *filter(None, [os.environ.get("PYTHONPATH")])])}
    return subprocess.Popen([sys.executable, "-c", code, *map(str, argv)], cwd=REPO, env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            start_new_session=True)


def finish(proc: subprocess.Popen, timeout: float) -> tuple[int, str, str]:
    """Wait for ``proc``; a hang (of it or its workers) is killed and raises AssertionError."""
    try:
        out, err = proc.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.communicate()
        raise AssertionError(f"the run did not end within {timeout} s (hung)") from None
    return proc.returncode, out, err


def wait_until(condition: Callable[[], object], what: str | Callable[[], str],
               timeout: float = 30.0, interval: float = 0.02):
    """Poll ``condition()`` until it returns a true value, and return that value; at the
    deadline (``timeout`` s) fail with an AssertionError saying what was awaited (``what``,
    or what it returns then). Use it instead of a fixed sleep before checking a state."""
    deadline = time.monotonic() + timeout
    while True:
        value = condition()
        if value:
            return value
        if time.monotonic() > deadline:
            text = what() if callable(what) else what
            raise AssertionError(f"gave up after {timeout:g} s waiting for {text}")
        time.sleep(interval)  # the polling interval, not a wait for the condition


def live_processes(pgid: int) -> list[int]:
    """The pids of the processes of process group ``pgid`` (a :func:`popen` run and its
    workers) that have not ended. A zombie (ended, not yet reaped by whoever adopted it)
    counts as ended. Reads /proc; elsewhere ``[pgid]`` while any process of the group
    exists (zombies included)."""
    proc = Path("/proc")
    if not (proc / "self").is_dir():
        try:
            os.killpg(pgid, 0)
        except ProcessLookupError:
            return []
        return [pgid]
    alive = []
    for entry in proc.iterdir():
        if not entry.name.isdigit():
            continue
        try:
            stat = (entry / "stat").read_text()
        except OSError:
            continue  # it ended meanwhile
        # "pid (comm) state ppid pgrp ...": comm may hold spaces and parentheses
        state, _, pgrp = stat[stat.rindex(")") + 2:].split()[:3]
        if int(pgrp) == pgid and state not in ("Z", "X"):
            alive.append(int(entry.name))
    return alive


def files(root: Path) -> dict[str, bytes]:
    """Every file under ``root`` by relative path."""
    return {p.relative_to(root).as_posix(): p.read_bytes()
            for p in sorted(root.rglob("*")) if p.is_file()}


def assert_identical(a: Path, b: Path) -> None:
    """Both folders hold the same files with the same bytes (records.jsonl included)."""
    fa, fb = files(a), files(b)
    assert sorted(fa) == sorted(fb), (sorted(set(fa) ^ set(fb)))[:10]
    differ = [k for k in fa if fa[k] != fb[k]]
    assert not differ, f"files differ: {differ[:10]}"


def _load_coco(path: Path) -> COCO:
    with contextlib.redirect_stdout(io.StringIO()):
        return COCO(str(path))


def check_intact(root: Path, *, allow_tmp: bool = False, decode: bool = True) -> int:
    """Assert that nothing under ``root`` is corrupt; returns the number of images listed
    in its COCO files. ``allow_tmp``: leftover hidden ``.*.tmp`` files are allowed (after
    SIGKILL nothing can remove them; the next run does)."""
    if not root.exists():
        return 0
    tmp = [p for p in root.rglob(".*.tmp")]
    assert allow_tmp or not tmp, f"temporary files left: {tmp[:5]}"
    meta = None
    if (root / "dataset.json").exists():
        meta = json.loads((root / "dataset.json").read_text())
        assert meta["format"] == "sdcomp-dataset"
    _check_images(root / "images", decode)
    _check_masks(root / "masks", decode)
    if (root / "records.jsonl").exists():
        read_journal(root / "records.jsonl")  # raises on a damaged line
    listed = 0
    for split in ("train", "val"):
        path = root / "annotations" / f"instances_{split}.json"
        if path.exists():
            listed += _check_coco(root, path, decode)
    if meta is not None and meta["status"] == "complete":
        assert listed == meta["counts"]["images"]
    return listed


def check_video_intact(root: Path, *, allow_tmp: bool = False) -> int:
    """The :func:`check_intact` of a video run's folder (``sdcomp video --out root``):
    every frame and mask under a final name is whole, every JSON file parses, every gt.txt
    reads, and the COCO-video file (where written) passes ``sdcomp check`` (the frames it
    lists exist and agree with their masks, gt.txt and YOLO lines). Returns the number of
    frames it lists (all of them when video.json says the run is complete). ``allow_tmp``
    as for :func:`check_intact`."""
    if not root.exists():
        return 0
    tmp = [p for p in root.rglob(".*.tmp*")]  # .NAME.tmp and an MP4's .NAME.tmp.mp4
    assert allow_tmp or not tmp, f"temporary files left: {tmp[:5]}"
    meta = None
    if (root / "video.json").exists():
        meta = json.loads((root / "video.json").read_text())
        assert meta["format"] == "sdcomp-video"
    for seq in sorted(p for p in root.glob("sdcomp-*") if p.is_dir()):
        _check_images(seq / "img1", True)
        _check_masks(seq / "masks", True)
        for name in ("flight.json", "sequence.json"):
            if (seq / name).exists():
                json.loads((seq / name).read_text())
        if (seq / "gt" / "gt.txt").exists():
            read_gt(seq / "gt" / "gt.txt")
    listed = 0
    coco = root / "annotations" / "instances_video.json"
    if coco.exists():
        listed = len(json.loads(coco.read_text())["images"])
        problems = check_video(root, workers=1).problems
        assert not problems, problems[:5]
    if meta is not None and meta["status"] == "complete":
        assert listed == meta["counts"]["frames"]
    return listed


def sdcomp_check(folder: Path) -> str:
    """``sdcomp check folder`` in this process (one worker) passes; returns its summary."""
    rc, out, err = cli([folder, "--workers", 1], entry=check_main)
    assert rc == 0, out[-2000:] + err
    return out


def _visible_files(folder: Path) -> list[Path]:
    """The files under ``folder`` (and its split sub-folders) whose names do not start with
    a dot, sorted; none if it is absent."""
    return sorted(p for p in folder.rglob("[!.]*") if p.is_file()) if folder.exists() else []


def _check_images(folder: Path, decode: bool) -> None:
    """Every image under a final name in ``folder`` is whole: a JPEG from its start marker
    to its end marker (zero padding allowed) or a PNG to its IEND chunk, and decodes if
    ``decode``."""
    for p in _visible_files(folder):
        data = p.read_bytes()
        if p.suffix == ".jpg":
            assert data[:3] == b"\xff\xd8\xff" and data.rstrip(b"\0")[-2:] == b"\xff\xd9", p
        else:
            assert data[:8] == b"\x89PNG\r\n\x1a\n" and data.endswith(PNG_END), p
        if decode:
            assert cv2.imread(str(p), cv2.IMREAD_UNCHANGED) is not None, p


def _check_masks(folder: Path, decode: bool) -> None:
    """Every mask under a final name in ``folder`` is a whole PNG, and (if ``decode``)
    decodes as 16-bit (instance masks) or 8-bit (``_ignore.png``: ignore masks)."""
    for p in _visible_files(folder):
        data = p.read_bytes()
        assert data[:8] == b"\x89PNG\r\n\x1a\n" and data.endswith(PNG_END), p
        if decode:
            m = cv2.imread(str(p), cv2.IMREAD_UNCHANGED)
            want = np.uint8 if p.name.endswith("_ignore.png") else np.uint16
            assert m is not None and m.dtype == want, p


def _check_coco(root: Path, path: Path, decode: bool) -> int:
    """The COCO file ``path`` of the dataset ``root`` loads and names only images and masks
    that exist; if ``decode``, each mask has its image's size and exactly the instance ids
    of its annotations, whose areas and boxes match the mask. Returns its number of
    images."""
    coco = _load_coco(path)
    for iid, im in coco.imgs.items():
        assert (root / "images" / im["file_name"]).is_file(), im["file_name"]
        mask_path = root / "masks" / im["mask_file"]
        assert mask_path.is_file(), im["mask_file"]
        if decode:
            _check_annotations(coco, iid, im, mask_path)
            _check_ignore(coco, iid, im, root / "masks")
    return len(coco.imgs)


def _check_annotations(coco: COCO, iid: int, im: dict, mask_path: Path) -> None:
    """The mask of image ``iid`` (COCO record ``im``) has the image's size and exactly the
    instance ids of its annotations, each with the area and box of its pixels."""
    mask = cv2.imread(str(mask_path), cv2.IMREAD_UNCHANGED)
    assert mask.shape == (im["height"], im["width"])
    anns = coco.loadAnns(coco.getAnnIds(imgIds=[iid], iscrowd=False))
    ids = sorted(int(v) for v in np.unique(mask) if v)
    assert ids == sorted(a["instance_id"] for a in anns), im["file_name"]
    for a in anns:
        m = mask == a["instance_id"]
        assert a["area"] == int(m.sum()) == int(mask_utils.area(a["segmentation"]))
        ys, xs = np.nonzero(m)
        assert a["bbox"] == [int(xs.min()), int(ys.min()), int(xs.max() - xs.min() + 1),
                             int(ys.max() - ys.min() + 1)]


def _check_ignore(coco: COCO, iid: int, im: dict, masks: Path) -> None:
    """Image ``iid``'s ignore regions (its ``iscrowd`` annotations, RLE) cover exactly the
    pixels of its ignore mask (``ignore_file``), which no labelled object's mask touches;
    an image without ignore regions has no ignore file."""
    crowd = [a for a in coco.loadAnns(coco.getAnnIds(imgIds=[iid])) if a["iscrowd"]]
    if "ignore_file" not in im:
        assert not crowd, im["file_name"]
        return
    ignore = cv2.imread(str(masks / im["ignore_file"]), cv2.IMREAD_UNCHANGED) > 0
    labels = cv2.imread(str(masks / im["mask_file"]), cv2.IMREAD_UNCHANGED)
    assert ignore.any() and not (ignore & (labels > 0)).any(), im["ignore_file"]
    union = np.zeros_like(ignore)
    for a in crowd:
        union |= mask_utils.decode(a["segmentation"]).astype(bool)
    assert np.array_equal(union, ignore), im["ignore_file"]


def by_name(folder: Path) -> list[Path]:
    """The files under ``folder`` and its split sub-folders (no hidden ones), sorted by
    file name (the image index)."""
    return sorted((p for p in folder.rglob("[!.]*") if p.is_file()), key=lambda p: p.name)


def image_path(root: Path, index: int, ext: str = "jpg") -> Path:
    """The file of image ``index`` in the dataset ``root``, whichever split it is in."""
    found = [p for s in ("train", "val") if (p := root / "images" / s / f"{index:06d}.{ext}")
             .exists()]
    assert len(found) == 1, f"image {index} of {root}: {found}"
    return found[0]


def one_line_error(err: str) -> None:
    """``err`` is exactly one ``error: ...`` line, no traceback."""
    assert err.startswith("error: ") and err.endswith("\n") and err.count("\n") == 1, err
    assert "Traceback" not in err
