"""``bench fewshot`` (issue 49): the real frames' split is disjoint by source photo and
stable, and a tiny end-to-end run (2 K values, a few iterations) writes every file and
resumes from its cells."""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import pytest

from sdcomp.bench.cli import main
from sdcomp.bench.fewshot import group_of, split
from sdcomp.render.footage import Source

from .datasets import cli, one_line_error
from .user_inputs import generated, scene

__all__ = ["generated"]  # a fixture

pytestmark = pytest.mark.filterwarnings("ignore:__array__ implementation:DeprecationWarning")


def _source(name: str, frame: int | None = None) -> Source:
    return Source(Path("/x") / name, frame, Path(name).stem, 160, 120)


def test_tiles_of_one_photo_and_frames_of_one_video_are_one_group():
    assert group_of(_source("DJI_0042_jpg.rf.3f9a0c.jpg")) == "DJI_0042"
    assert group_of(_source("DJI_0042_jpg.rf.77b1e2.jpg")) == "DJI_0042"
    assert group_of(_source("flight_000120.png")) == "flight"
    assert group_of(_source("a.mp4", 7)) == group_of(_source("a.mp4", 8)) == "a.mp4"


def test_split_is_disjoint_by_group_and_stable():
    names = [f"photo{p}_jpg.rf.{t:06x}.jpg" for p in range(40) for t in range(3)]
    sources = [_source(n) for n in names]
    pool, test = split(sources, 0.3)
    assert sorted(pool + test) == list(range(len(sources)))
    assert not {group_of(sources[i]) for i in pool} & {group_of(sources[i]) for i in test}
    assert 0.1 < len(test) / len(sources) < 0.5
    # stable: the same groups go the same way in another order and with others added
    more = [_source(f"other{k}.jpg") for k in range(10)] + sources[::-1]
    pool2, test2 = split(more, 0.3)
    assert {more[i].path for i in test2} >= {sources[i].path for i in test}
    assert {more[i].path for i in pool2} >= {sources[i].path for i in pool}


def test_too_few_groups_to_split_is_one_line(tmp_path):
    from sdcomp.errors import UserError
    with pytest.raises(UserError, match="source groups"):
        split([_source("a_jpg.rf.1.jpg"), _source("a_jpg.rf.2.jpg")], 0.3)


def _real_set(folder: Path, n: int = 12) -> tuple[Path, Path]:
    folder.mkdir()
    images, anns = [], []
    for k in range(n):
        img = scene(k)
        x, y = 30 + 7 * k % 90, 25 + 5 * k % 60
        cv2.rectangle(img, (x, y), (x + 14, y + 10), (30, 30, 200), -1)
        cv2.imwrite(str(folder / f"p{k}.png"), img)
        images.append({"id": k + 1, "file_name": f"p{k}.png", "width": 160, "height": 120})
        anns.append({"id": k + 1, "image_id": k + 1, "category_id": 1,
                     "bbox": [x, y, 15, 11]})
    labels = folder.parent / "real.json"
    labels.write_text(json.dumps({"images": images, "annotations": anns,
                                  "categories": [{"id": 1, "name": "bluerov2"}]}))
    return folder, labels


TINY = ["--backbone", "mobilenet_v3-fpn", "--max-iter", "2", "--batch-size", "1",
        "--lr", "0.01", "--warmup-iters", "1", "--proposals-train", "40",
        "--proposals-test", "20", "--roi-batch", "16", "--no-progress", "--device", "cpu"]


def test_end_to_end_writes_every_file_and_resumes(generated, tmp_path):
    frames, labels = _real_set(tmp_path / "real")
    out = tmp_path / "fewshot"
    argv = ["fewshot", "--train", generated, "--real", frames, "--real-labels", labels,
            "--out", out, "--k", "0,2", "--seeds", "0", "--finetune-iter", "1", *TINY]
    rc, text, err = cli(argv, main)
    assert rc == 0, err
    result = json.loads((out / "fewshot.json").read_text())
    cells = {(c["arm"], c["k"]) for c in result["cells"]}
    assert cells == {("synthetic", 0), ("real", 2), ("synthetic", 2), ("finetune", 2),
                     ("mixed", 2)}
    assert result["pool"] + result["test"] == 12
    for c in result["cells"]:
        assert set(c["metrics"]) >= {"AP", "AP50", "AR100"}
    mixed = next(c for c in result["cells"] if c["arm"] == "mixed")
    synthetic = next(c for c in result["cells"] if c["arm"] == "synthetic")
    assert mixed["images"] > synthetic["images"]  # the K frames repeated to the ratio
    report = (out / "report.md").read_text()
    assert "| K |" in report and "synthetic, fine-tuned on K" in report and "K = 2:" in report
    assert (out / "fewshot.png").stat().st_size > 5000
    assert cv2.imread(str(out / "fewshot.png")) is not None
    # a second run reads every cell back (nothing trained or scored again)
    kept = {p: p.stat().st_mtime_ns for p in (out / "cells").rglob("*") if p.is_file()}
    assert len([p for p in kept if p.name == "scores.json"]) == 4
    rc, _, err = cli(argv, main)
    assert rc == 0, err
    assert {p: p.stat().st_mtime_ns for p in kept} == kept
    again = json.loads((out / "fewshot.json").read_text())
    assert [c["metrics"] for c in again["cells"]] == [c["metrics"] for c in result["cells"]]


@pytest.mark.parametrize("flag,value,needle", [("--k", "1,x", "'x' is not a whole number"),
                                               ("--ratio", "1.5", "--ratio 1.5"),
                                               ("--seeds", "", "is not a whole number")])
def test_bad_options_are_one_line(flag, value, needle, generated, tmp_path):
    frames, labels = _real_set(tmp_path / "real", 4)
    rc, _, err = cli(["fewshot", "--train", generated, "--real", frames, "--real-labels",
                      labels, "--out", tmp_path / "o", flag, value, *TINY], main)
    assert rc == 2, err
    one_line_error(err)
    assert needle in err and not (tmp_path / "o").exists()
