"""A tiny grid end to end: cells skipped when done, resumed when interrupted, reported."""

from __future__ import annotations

import json
import re
from dataclasses import replace
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


def test_table6_trains_on_real_frames_alone(tmp_path, sprites_dir, capsys):
    """--real-train: Table 6's cells train on nested subsets of the user's frames (here a
    generated set standing in for them), are scored on the test set and reported beside
    the paper's figures; a pool too small, frames of the test set among them and a missing
    folder are refused before anything is written."""
    cache = CacheOptions(tmp_path / "cache", sprites_dir, 1, False)
    pool = field_test(FieldSpec(n=6, seed=2000), 64, cache)  # the "real" training frames
    frames = Path(pool.files[0])
    coco, images = frames / "annotations" / "instances_train.json", frames / "images"
    test = field_test(FieldSpec(n=3, seed=2001), 64, cache)
    common = ["--size-scale", "0.004", "--image-size", "64", "--sprites", str(sprites_dir),
              "--workers", "1", "--threads", "1", "--no-progress", "--device", "cpu",
              "--cache", str(tmp_path / "cache"), "--backbone", "mobilenet_v3-fpn",
              "--max-iter", "2", "--batch-size", "2", "--warmup-iters", "1",
              "--proposals-train", "40", "--proposals-test", "20", "--roi-batch", "16"]
    out = tmp_path / "r"
    real = ["--real-train", str(coco), "--real-train-images", str(images)]
    assert run_cli(main, ["grid", "--preset", "paper-table6", "--list", *common]) == 0
    assert "table 6  500      real-n500  (4 real images)" in capsys.readouterr().out

    for argv, match in [
            ([], "Table 6 trains on your real frames; give --real-train"),
            (real[:2], "--real-train and --real-train-images go together"),
            (["--real-train", str(coco), "--real-train-images", str(tmp_path / "no")],
             "--real-train-images .*no: no such folder"),
            (["--size-scale", "0.01", *real], "Table 6 asks 15 frames, it has 6; lower "
                                              "--size-scale"),
            ([*real, "--test-coco", str(coco), "--test-images", str(images)],
             "--real-train holds 6 of the --test-coco frames")]:
        assert run_cli(main, ["grid", "--preset", "paper-table6", "--out", str(out),
                              *common, *argv]) == 2
        assert re.search(match, capsys.readouterr().err)
        assert not out.exists()

    spec = GridSpec("t6", tables=(6,), size_scale=0.004, min_images=2, image_size=64,
                    train=TRAIN, field=FieldSpec(n=3, seed=2001))
    from sdcomp.bench.datasets import real_train
    frames6 = real_train(coco, images)
    small, mid, big = (frames6.pick(n, 0) for n in (2, 4, 6))
    assert [p for p, _ in small] == [p for p, _ in mid][:2]  # nested, the paper's sets grow
    assert [p for p, _ in mid] == [p for p, _ in big][:4]
    assert sorted(p for p, _ in big) == sorted(str(p.resolve()) for p in images.rglob("*.jpg"))

    ctx = RunContext(out, cache, "cpu")
    log: list[str] = []
    results = run_grid(spec, test, ctx, log=log.append, real=frames6)
    assert [r["cell"] for r in results] == ["real-n500", "real-n1000", "real-n1500"]
    assert [r["train_images"] for r in results] == [2, 4, 6]
    assert all(r["val"] is None and r["config"]["datasets"] == [] for r in results)
    assert {r["config"]["real_train"]["key"] for r in results} == {frames6.key}
    assert all("real frames, no val split" in line for line in log)
    assert len({r["train_key"] for r in results}) == 3
    text = write_report(out)["report"].read_text()
    assert "## Table 6: real frames only" in text and "(not run)" not in text
    row = next(ln for ln in text.splitlines() if ln.startswith("| 1500 |"))
    assert row.split("|")[2].strip() == "6" and "77.44" in row  # ours beside the paper's
    assert "Table 6 (the paper's only)" not in text
    log.clear()
    assert run_grid(spec, test, ctx, log=log.append, real=frames6) == results  # done cells
    assert all("done earlier" in line for line in log)


def test_table6_cells_train_again_on_another_dataset_seed(tmp_path, sprites_dir):
    """The frames a Table 6 cell draws depend on the grid's --seed: another seed is
    another training key (its cell is not taken for the old one's)."""
    from sdcomp.bench.datasets import real_train
    from sdcomp.bench.grid import RealCell
    cache = CacheOptions(tmp_path / "cache", sprites_dir, 1, False)
    frames = Path(field_test(FieldSpec(n=4, seed=2002), 64, cache).files[0])
    real = real_train(frames / "annotations" / "instances_train.json", frames / "images")
    test = field_test(FieldSpec(n=2, seed=2003), 64, cache)
    spec = GridSpec("t6", tables=(6,), size_scale=0.004, min_images=2, image_size=64,
                    train=replace(TRAIN, max_iter=1), field=FieldSpec(n=2, seed=2003))
    keys = [run_cell(RealCell(500), g, test, RunContext(tmp_path / f"r{g.seed}", cache),
                     real=real)["train_key"]
            for g in (spec, spec.with_overrides(seed=5))]
    assert keys[0] != keys[1]
