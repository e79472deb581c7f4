"""A tiny grid end to end: cells skipped when done, resumed when interrupted, reported."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from sdcomp.bench.cli import main
from sdcomp.bench.datasets import CacheOptions, FieldSpec, field_test
from sdcomp.bench.evaluate import METRICS
from sdcomp.bench.grid import GridSpec
from sdcomp.bench.report import write_report
from sdcomp.bench.runner import RunContext, cell_path, checkpoint_path, run_cell, run_grid
from sdcomp.bench.train import TrainConfig, load_checkpoint
from sdcomp.errors import UserError, run_cli

TRAIN = TrainConfig(backbone="mobilenet_v3-fpn", lr=0.01, max_iter=2, batch_size=2,
                    warmup_iters=1, checkpoint_every=1, proposals_train=40,
                    proposals_test=20, roi_batch=16)
GRID = GridSpec("tiny", tables=(2,), size_scale=0.001, min_images=4, image_size=64,
                train=TRAIN, field=FieldSpec(n=3))


pytestmark = pytest.mark.usefixtures("one_torch_thread")


def test_half_done_grid_resumes_and_reports(tmp_path, sprites_dir):
    out = tmp_path / "results"
    ctx = RunContext(out, CacheOptions(tmp_path / "cache", sprites_dir, 1, False), "cpu")
    test = field_test(GRID.field, GRID.image_size, ctx.cache)
    assert test.kind == "synthetic-field" and len(test.coco["images"]) == 3
    brown, blue, green = GRID.cells()

    def stop(iteration, loss):
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):  # green interrupted after its first iteration
        run_cell(green, GRID, test, ctx, [(2, "green")], on_iteration=stop)
    assert load_checkpoint(checkpoint_path(out, green.id))["iteration"] == 1
    assert not cell_path(out, green.id).exists()

    log: list[str] = []
    results = run_grid(GRID, test, ctx, log=log.append)
    assert [r["cell"] for r in results] == [brown.id, blue.id, green.id]
    assert [r["training"]["resumed_from"] for r in results] == [0, 0, 1]
    for r in results:
        assert len(r["training"]["losses"]) == TRAIN.max_iter
        assert r["test"]["test_set"] == test.label and r["val"]["test_set"] == "synthetic-val"
        for part in ("test", "val"):
            for k in METRICS:
                v = r[part]["metrics"][k]
                assert v == -1.0 or 0.0 <= v <= 1.0
        assert r["device"] == "cpu" and r["wall_time_s"]["total"] > 0
        assert r["config"]["train"] == TRAIN.to_dict()
    assert len(log) == 3 and all("done earlier" not in line for line in log)

    # a finished grid with one cell's result lost: only that cell is scored again
    stamps = {c.id: cell_path(out, c.id).stat().st_mtime_ns for c in (blue, green)}
    cell_path(out, brown.id).unlink()
    log.clear()
    again = run_grid(GRID, test, ctx, log=log.append)
    assert "done earlier" not in log[0] and all("done earlier" in ln for ln in log[1:])
    assert again[0]["training"]["resumed_from"] == TRAIN.max_iter  # not retrained
    assert again[0]["training"]["losses"] == results[0]["training"]["losses"]
    assert {c.id: cell_path(out, c.id).stat().st_mtime_ns for c in (blue, green)} == stamps
    assert again[1:] == results[1:]
    # datasets were cached: the second run generated nothing
    assert all(d["reused"] for d in again[0]["config"]["datasets"])

    written = write_report(out)
    text = written["report"].read_text()
    assert "## Table 2: water colour" in text and test.label in text
    assert "(not run)" not in text and "54.72" in text  # paper's blue AP beside ours
    grid_meta = json.loads((out / "grid.json").read_text())
    assert grid_meta["test_set"] == test.label and grid_meta["grid"]["name"] == "tiny"

    # eval: the field set's own COCO file given as "real" frames scores the same
    field = Path(test.files[0])
    argv = ["eval", str(out), "--cell", blue.id, "--threads", "1", "--test-coco",
            str(field / "annotations" / "instances_train.json"), "--test-images",
            str(field / "images")]
    assert run_cli(main, argv) == 0
    (scored,) = (out / "eval").glob(f"{blue.id}--real*.json")
    scored = json.loads(scored.read_text())
    assert scored["test_set"].startswith("real (instances_train.json, 3 images")
    assert scored["metrics"] == results[1]["test"]["metrics"]

    # other training settings into the same folder are refused
    other = GRID.with_overrides({"max_iter": 3})
    with pytest.raises(UserError, match="other settings"):
        run_grid(other, test, ctx, log=log.append)


def test_datasets_only_generates_what_train_then_reuses(tmp_path, sprites_dir, capsys):
    """`grid --datasets-only` trains nothing; a `train --cell` after it generates nothing."""
    common = ["--preset", "paper-table2", "--size-scale", "0.006", "--image-size", "64",
              "--field-n", "3", "--out", str(tmp_path / "r"), "--sprites", str(sprites_dir),
              "--workers", "1", "--threads", "1", "--no-progress", "--device", "cpu"]
    # the GPU job's flags work on a machine without one: nothing is trained here
    assert run_cli(main, ["grid", "--datasets-only", *common, "--device", "cuda"]) == 0
    assert "the datasets of 3 cells and the test set" in capsys.readouterr().out
    made = sorted(p.name for p in (tmp_path / "r" / "datasets").iterdir())
    assert [n.rsplit("-", 1)[0] for n in made] == [
        "alt10-blue", "alt10-brown", "alt10-green", "field64"]
    assert not (tmp_path / "r" / "cells").exists()
    train = ["--backbone", "mobilenet_v3-fpn", "--max-iter", "1", "--batch-size", "2",
             "--warmup-iters", "0", "--proposals-train", "40", "--proposals-test", "20",
             "--roi-batch", "16", "--lr", "0.01"]
    assert run_cli(main, ["train", "--cell", "alt10-blue-n626", *common, *train]) == 0
    cell = json.loads(cell_path(tmp_path / "r", "alt10-blue-n626").read_text())
    assert [d["reused"] for d in cell["config"]["datasets"]] == [True]
    assert sorted(p.name for p in (tmp_path / "r" / "datasets").iterdir()) == made
