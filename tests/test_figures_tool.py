"""tools/figures.py: the figures page's rows read from the benchmarks and the per-stage
profile."""

from __future__ import annotations

import ast
import json
from pathlib import Path

from .tools import load_tool

ROOT = Path(__file__).resolve().parent.parent


def _benchmark_names() -> set[str]:
    """Every benchmark's pytest name, parameter ids included, from benchmarks/*.py (the
    ``ids=`` of each ``parametrize``; a test without one is its bare name)."""
    names = set()
    for path in (ROOT / "benchmarks").glob("test_*.py"):
        for node in ast.parse(path.read_text()).body:
            if not isinstance(node, ast.FunctionDef) or not node.name.startswith("test_"):
                continue
            ids = [kw.value for d in node.decorator_list if isinstance(d, ast.Call)
                   for kw in d.keywords if kw.arg == "ids"]
            names |= ({f"{node.name}[{i.value}]" for i in ids[0].elts}  # type: ignore
                      if ids else {node.name})
    return names


def test_every_benchmark_row_names_a_benchmark():
    tool = load_tool("figures")
    names = _benchmark_names()
    assert "test_bench_disk_1080_two_workers[default]" in names
    for row in tool.BENCH_ROWS:
        assert row.test in names, row.test


def test_rows_are_read_from_a_benchmark_json(tmp_path):
    tool = load_tool("figures")
    path = tmp_path / "bench.json"
    path.write_text(json.dumps({"datetime": "2026-11-28T14:00:00", "benchmarks": [
        {"name": "test_bench_disk_1080_two_workers[default]",
         "extra_info": {"images": 40, "images_per_s": 7.4}},
        {"name": "test_bench_video_to_disk[416]",
         "extra_info": {"video_frames_per_s": 60.5, "video_over_still": 0.71}},
        {"name": "test_bench_disk_416_two_workers", "extra_info": {}},
    ]}))
    found = {f.key: f for f in tool.from_benchmarks(path)}
    assert sorted(found) == ["disk-1080-ips", "video-416-fps", "video-416-still-ratio"]
    assert found["disk-1080-ips"].value == 7.4 and found["video-416-still-ratio"].value == 0.71
    assert "2026-11-28" in found["video-416-fps"].source
    # a row written and read back is the same figure
    row = found["disk-1080-ips"]
    assert tool.read_table_text(row.row())["disk-1080-ips"] == row


def test_stage_rows_sum_the_profiles_steps(sprites_dir):
    tool = load_tool("figures")
    found = {f.key: f.value for f in tool.stage_figures(((96, 64),), 2, sprites_dir)}
    parts = ("water", "glitter", "objects", "camera", "lens", "compression")
    assert set(found) == {f"stage-96-{p}-ms" for p in ("whole", *parts)}
    whole = found["stage-96-whole-ms"]
    assert whole > found["stage-96-water-ms"] > 0 and found["stage-96-camera-ms"] > 0
    assert found["stage-96-water-ms"] + found["stage-96-objects-ms"] + found[
        "stage-96-camera-ms"] < whole
    assert found["stage-96-glitter-ms"] <= found["stage-96-water-ms"]
    assert found["stage-96-lens-ms"] + found["stage-96-compression-ms"] <= found[
        "stage-96-camera-ms"]
    assert tool.profile.__module__ == "profile_stages"  # the tool's own profile, not a copy
