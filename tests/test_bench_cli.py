"""Command line of the detector benchmark: bad input is one line on stderr, exit 2."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from sdcomp.bench.cli import main
from sdcomp.errors import run_cli


def _fails(capsys, argv, match: str) -> None:
    assert run_cli(main, argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("error: ")
    assert match in err, err


@pytest.fixture()
def coco_without_category(tmp_path):
    (tmp_path / "frames").mkdir()
    (tmp_path / "frames" / "a.jpg").write_bytes(b"x")
    path = tmp_path / "real.json"
    path.write_text(json.dumps({"images": [{"id": 1, "file_name": "a.jpg"}],
                                "annotations": [],
                                "categories": [{"id": 1, "name": "kayak"}]}))
    return path


def test_bad_input_is_one_line_and_writes_nothing(capsys, tmp_path, coco_without_category):
    out = tmp_path / "out"
    frames = str(tmp_path / "frames")
    cases = [
        (["grid", "--preset", "paper-table9", "--out", str(out)], "--preset 'paper-table9'"),
        (["grid", "--out", str(out), "--test-coco", str(tmp_path / "none.json"),
          "--test-images", frames], "none.json: no such file"),
        (["grid", "--out", str(out), "--test-coco", str(coco_without_category),
          "--test-images", frames], "no category named 'bluerov2' (found: kayak)"),
        (["grid", "--out", str(out), "--test-coco", str(coco_without_category)],
         "--test-coco and --test-images go together"),
        (["grid", "--out", str(out), "--lr", "0"], "--lr 0.0 is out of range"),
        (["grid", "--out", str(out), "--max-iter", "-5"], "--max-iter -5 is out of range"),
        (["grid", "--out", str(out), "--backbone", "vgg"], "--backbone 'vgg' is unknown"),
        (["grid", "--out", str(out), "--weights", str(tmp_path / "w.pt")], "--weights"),
        (["grid", "--out", str(out), "--image-size", "8"], "--image-size 8"),
        (["grid", "--out", str(out), "--device", "tpu"], "--device 'tpu' is unknown"),
        (["grid", "--out", str(out), "--threads", "0"], "--threads 0"),
        (["grid"], "grid needs --out"),
        (["train", "--out", str(out), "--cell", "alt99-red-n1"], "--cell 'alt99-red-n1'"),
        (["report", str(tmp_path / "nothing")], "no grid.json"),
        (["eval", str(tmp_path / "nothing"), "--cell", "alt10-brown-n626"],
         "no finished cell"),
    ]
    for argv, match in cases:
        _fails(capsys, argv, match)
    assert not out.exists()


def test_no_cuda_is_a_user_error(capsys, tmp_path):
    torch = pytest.importorskip("torch")
    if torch.cuda.is_available():
        pytest.skip("this machine has CUDA")
    _fails(capsys, ["grid", "--out", str(tmp_path / "o"), "--device", "cuda"],
           "no CUDA device here")


def test_list_shows_every_row_of_the_preset(capsys):
    assert run_cli(main, ["grid", "--preset", "paper", "--list"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert len(lines) == 21
    assert lines[0].split()[:4] == ["table", "1", "10", "m"]
    assert "alt10-brown-n626+g137  (763 images)" in lines[12]


def test_module_entry_point():
    r = subprocess.run([sys.executable, "-m", "sdcomp.bench", "grid", "--preset", "nope",
                        "--out", "x"], capture_output=True, text=True)
    assert r.returncode == 2 and r.stdout == ""
    assert r.stderr.strip().splitlines() == [
        "error: --preset 'nope' is unknown; use one of paper, paper-table1, paper-table2, "
        "paper-table3, paper-table4, paper-table5, paper-table6, smoke"]
