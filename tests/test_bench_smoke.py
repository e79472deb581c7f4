"""The detector benchmark's ``smoke`` preset end to end (every row of Tables 1-5, tiny), as
CI runs it: ``python -m sdcomp.bench grid --preset smoke`` in a fresh folder produces every
table, every metric in [0, 1] or -1, the training loss falling in every cell and the plots;
a second run skips every cell. Its wall time against the issue's 15-minute bound is the
``-m slow`` benchmark ``benchmarks/test_bench_detector.py::test_smoke_grid_time``."""

from __future__ import annotations

import json

import pytest

pytest.importorskip("torchvision")

from sdcomp.bench.cli import main  # noqa: E402
from sdcomp.bench.evaluate import METRICS  # noqa: E402
from sdcomp.bench.grid import PRESETS  # noqa: E402
from sdcomp.bench.report import PLOTS  # noqa: E402
from sdcomp.errors import run_cli  # noqa: E402


def test_smoke_grid_makes_every_table_and_a_second_run_skips_every_cell(
        sprites_dir, tmp_path, one_torch_thread):
    out = tmp_path / "r"
    argv = ["grid", "--preset", "smoke", "--out", str(out), "--sprites", str(sprites_dir),
            "--threads", "1"]
    assert run_cli(main, argv) == 0
    spec = PRESETS["smoke"]
    report = (out / "report.md").read_text()
    for t in (1, 2, 3, 4, 5):
        assert f"## Table {t}:" in report
    assert "(not run)" not in report and "synthetic-field" in report
    assert sorted(p.name for p in (out / "plots").iterdir()) == sorted(PLOTS)
    cells = [json.loads(p.read_text()) for p in sorted((out / "cells").glob("*.json"))]
    assert sorted(c["cell"] for c in cells) == sorted(c.id for c in spec.cells())
    for c in cells:
        for part in ("test", "val"):
            for k in METRICS:
                v = c[part]["metrics"][k]
                assert isinstance(v, float) and (v == -1.0 or 0.0 <= v <= 1.0), (c["cell"], k)
        assert c["test"]["test_set"].startswith("synthetic-field")
        losses = [row[0] for row in c["training"]["losses"]]
        assert len(losses) == spec.train.max_iter
        k = len(losses) // 3
        assert sum(losses[-k:]) / k < 0.8 * sum(losses[:k]) / k, (c["cell"], losses)
    # a second run finds every cell done and rewrites none
    before = {p.name: p.read_bytes() for p in (out / "cells").glob("*.json")}
    assert run_cli(main, argv) == 0
    assert {p.name: p.read_bytes() for p in (out / "cells").glob("*.json")} == before
