"""Helpers for the fault, shard and fuzz tests: run the generator, check a dataset folder.

:func:`check_intact` is the "nothing corrupt" check after any fault: every file under a final
name is whole (images and masks decode completely, JSON parses, the COCO files load in
pycocotools and name only files that exist, the journal reads), masks, boxes and areas agree.
"""

from __future__ import annotations

import contextlib
import io
import json
import os
import signal
import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np
from pycocotools import mask as mask_utils
from pycocotools.coco import COCO

from sdcomp.coco import read_journal
from sdcomp.errors import run_cli
from sdcomp.generate import main

REPO = Path(__file__).resolve().parents[1]
CLI = ("import sys; from sdcomp.errors import run_cli; from sdcomp.generate import main; "
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
    for p in sorted((root / "images").glob("[!.]*")) if (root / "images").exists() else ():
        data = p.read_bytes()
        if p.suffix == ".jpg":
            assert data[:3] == b"\xff\xd8\xff" and data.rstrip(b"\0")[-2:] == b"\xff\xd9", p
        else:
            assert data[:8] == b"\x89PNG\r\n\x1a\n" and data.endswith(PNG_END), p
        if decode:
            assert cv2.imread(str(p), cv2.IMREAD_UNCHANGED) is not None, p
    for p in sorted((root / "masks").glob("[!.]*")) if (root / "masks").exists() else ():
        data = p.read_bytes()
        assert data[:8] == b"\x89PNG\r\n\x1a\n" and data.endswith(PNG_END), p
        if decode:
            m = cv2.imread(str(p), cv2.IMREAD_UNCHANGED)
            assert m is not None and m.dtype == np.uint16, p
    if (root / "records.jsonl").exists():
        read_journal(root / "records.jsonl")  # raises on a damaged line
    listed = 0
    for split in ("train", "val"):
        path = root / "annotations" / f"instances_{split}.json"
        if not path.exists():
            continue
        coco = _load_coco(path)
        for iid, im in coco.imgs.items():
            listed += 1
            assert (root / "images" / im["file_name"]).is_file(), im["file_name"]
            mask_path = root / "masks" / im["mask_file"]
            assert mask_path.is_file(), im["mask_file"]
            if not decode:
                continue
            mask = cv2.imread(str(mask_path), cv2.IMREAD_UNCHANGED)
            assert mask.shape == (im["height"], im["width"])
            anns = coco.loadAnns(coco.getAnnIds(imgIds=[iid]))
            ids = sorted(int(v) for v in np.unique(mask) if v)
            assert ids == sorted(a["instance_id"] for a in anns), im["file_name"]
            for a in anns:
                m = mask == a["instance_id"]
                assert a["area"] == int(m.sum()) == int(mask_utils.area(a["segmentation"]))
                ys, xs = np.nonzero(m)
                assert a["bbox"] == [int(xs.min()), int(ys.min()), int(xs.max() - xs.min() + 1),
                                     int(ys.max() - ys.min() + 1)]
    if meta is not None and meta["status"] == "complete":
        assert listed == meta["counts"]["images"]
    return listed


def one_line_error(err: str) -> None:
    """``err`` is exactly one ``error: ...`` line, no traceback."""
    assert err.startswith("error: ") and err.endswith("\n") and err.count("\n") == 1, err
    assert "Traceback" not in err
