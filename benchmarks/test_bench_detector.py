"""The detector benchmark end to end on CPU (pytest-benchmark; figures in ``extra_info``).

- ``test_smoke_grid_time`` (``-m slow``, 2-4 min): the wall time of ``python -m sdcomp.bench
  grid --preset smoke`` (every row of Tables 1-5, tiny) in a fresh folder, within the issue's
  15 minutes; what it makes is checked in CI by tests/test_bench_smoke.py, which runs in
  parallel with the other tests.
- ``test_cpu_mobilenet_learns`` (``-m slow``, about 15 min on 2 cores): MobileNetV3-FPN from
  scratch on 626 images at 10 m reaches AP50 >= 0.5 on the held-out synthetic field set.
"""

from __future__ import annotations

import json
import time

import pytest

from sdcomp.bench.cli import main
from sdcomp.bench.datasets import CacheOptions, FieldSpec, field_test
from sdcomp.bench.grid import Cell, GridSpec
from sdcomp.bench.runner import RunContext, run_cell
from sdcomp.bench.train import TrainConfig
from sdcomp.errors import run_cli

SMOKE_LIMIT_S = 15 * 60  # the bound for the smoke grid on this machine

#: the opt-in CPU run: SGD at lr 0.01 (the paper's 0.001 barely moves a detector trained from
#: scratch in a CPU budget; AdamW 1e-3 peaked at AP50 0.21 and fell to 0.10 by 600
#: iterations), fewer proposals to keep an iteration near 2 s, multi-scale training
#: (0.5-1x, as Detectron2's resize) for the field set's 10-20 m
CPU_TRAIN = TrainConfig(backbone="mobilenet_v3-fpn", optimizer="sgd", lr=0.01,
                        weight_decay=1e-4, max_iter=400, batch_size=4, warmup_iters=50,
                        checkpoint_every=50, proposals_train=500, proposals_test=300,
                        roi_batch=128, min_scale=0.5)
#: 626 images at 10 m, water brown, blue or green per image (a brown-only model scores ~0 on
#: the field set's blue and green water)
CPU_CELL = Cell(10, "mixed", 626)


@pytest.mark.slow
def test_smoke_grid_time(benchmark, machine, sprites_dir, tmp_path, one_torch_thread):
    """Wall time of the smoke grid in a fresh folder (what it makes is checked in CI by
    tests/test_bench_smoke.py) and of a second run that skips every cell."""
    out = tmp_path / "r"
    argv = ["grid", "--preset", "smoke", "--out", str(out), "--sprites", str(sprites_dir),
            "--threads", "1"]
    timing = {}

    def once():
        t0 = time.perf_counter()
        assert run_cli(main, argv) == 0
        timing["first"] = time.perf_counter() - t0

    benchmark.pedantic(once, rounds=1, iterations=1)
    cells = [json.loads(p.read_text()) for p in sorted((out / "cells").glob("*.json"))]
    per_cell = [c["wall_time_s"]["total"] for c in cells]
    t0 = time.perf_counter()
    assert run_cli(main, argv) == 0
    rerun = time.perf_counter() - t0
    benchmark.extra_info.update(
        wall_s=round(timing["first"], 1), rerun_s=round(rerun, 1), cells=len(cells),
        cell_s_mean=round(sum(per_cell) / len(per_cell), 2), cell_s_max=round(max(per_cell), 2))
    print(f"\nsmoke grid: {timing['first']:.1f} s for {len(cells)} cells "
          f"({benchmark.extra_info['cell_s_mean']} s per cell, max "
          f"{benchmark.extra_info['cell_s_max']} s); re-run {rerun:.1f} s")
    machine.measure_after()
    assert timing["first"] < machine.limit(SMOKE_LIMIT_S)
    assert rerun < timing["first"]


@pytest.mark.slow
def test_cpu_mobilenet_learns(benchmark, sprites_dir, tmp_path, one_torch_thread):
    grid = GridSpec("cpu", tables=(1,), train=CPU_TRAIN, field=FieldSpec(n=100))
    cache = CacheOptions(tmp_path / "datasets", sprites_dir, 2, False)
    ctx = RunContext(tmp_path / "r", cache, "cpu", False, 8)
    test = field_test(grid.field, grid.image_size, cache)
    result = {}

    def once():
        result.update(run_cell(CPU_CELL, grid, test, ctx))

    benchmark.pedantic(once, rounds=1, iterations=1)
    m, val = result["test"]["metrics"], result["val"]["metrics"]
    benchmark.extra_info.update(test_AP50=m["AP50"], test_AP=m["AP"], val_AP50=val["AP50"],
                                wall_s=result["wall_time_s"])
    print(f"\ncpu benchmark: field AP50 {m['AP50']:.3f} AP {m['AP']:.3f}, val AP50 "
          f"{val['AP50']:.3f}, {result['wall_time_s']}")
    assert m["AP50"] >= 0.5
