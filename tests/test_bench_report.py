"""Report of a results folder: markdown tables beside the paper's figures, PNG plots."""

from __future__ import annotations

import json

import cv2
import pytest

from sdcomp.bench.evaluate import METRICS
from sdcomp.bench.grid import PRESETS
from sdcomp.bench.report import PLOTS, load_results, markdown, write_report
from sdcomp.bench.runner import FORMAT, write_json
from sdcomp.errors import UserError


def _cell(cell_id, rows, ap50, apm=-1.0):
    metrics = {m: 0.25 for m in METRICS} | {"AP50": ap50, "APm": apm, "APl": -1.0}
    return {"format": FORMAT, "cell": cell_id, "rows": rows, "train_images": 10,
            "wall_time_s": {"total": 2.0},
            "test": {"test_set": "synthetic-field (x)", "metrics": metrics},
            "val": {"test_set": "synthetic-val", "metrics": metrics | {"AP50": 0.96}}}


@pytest.fixture()
def results(tmp_path):
    grid = PRESETS["paper-table1"].to_dict()
    write_json(tmp_path / "grid.json", {"format": "sdcomp-bench-grid", "grid": grid,
                                        "test_set": "synthetic-field (x)", "device": "cpu"})
    write_json(tmp_path / "cells" / "a.json", _cell("a", [[1, "10 m"]], 0.875, 0.5))
    write_json(tmp_path / "cells" / "b.json", _cell("b", [[1, "30 m"]], 0.125))
    (tmp_path / "cells" / "junk.json").write_text("{")  # ignored
    return tmp_path


def test_markdown_puts_ours_beside_the_paper(results):
    meta, rows = load_results(results)
    assert set(rows) == {(1, "10 m"), (1, "30 m")}
    text = markdown(meta, rows)
    assert "## Table 1: altitude, 626 images, brown water" in text
    assert "## Table 2" not in text  # not in this grid
    assert "test set: synthetic-field (x)" in text
    lines = {ln.split("|")[1].strip(): ln for ln in text.splitlines() if ln.startswith("| ")}
    cells10 = [c.strip() for c in lines["10 m"].split("|")[1:-1]]
    # row, images, AP AP50 AP75 APs APm APl AR100, val AP50, gap, paper x5
    assert cells10[:11] == ["10 m", "10", "25.00", "87.50", "25.00", "25.00", "50.00", "-",
                            "25.00", "96.00", ""]
    assert cells10[11:] == ["58.41", "90.90", "72.62", "57.82", "84.72"]
    cells20 = [c.strip() for c in lines["20 m"].split("|")[1:-1]]
    # a row not run keeps the columns: the paper's figures under the paper's headers
    assert cells20 == ["20 m", "(not run)", *[""] * 9, "47.46", "95.03", "31.28", "47.27",
                       "57.41"]
    assert "12.50" in lines["30 m"] and "32.70" in lines["30 m"]
    assert "## Table 6" in text and "| 500 | 77.09 | 98.97 |" in text  # the paper's only


def test_write_report_writes_markdown_and_three_plots(results):
    written = write_report(results)
    assert (results / "report.md").read_text().startswith("# Detector benchmark")
    assert sorted(p.name for p in (results / "plots").iterdir()) == sorted(PLOTS)
    for name in PLOTS:
        image = cv2.imread(str(results / "plots" / name))
        assert image is not None and image.shape[0] > 200 and image.shape[1] > 200
    assert written["report"] == results / "report.md"
    assert not list(results.rglob(".*.tmp"))


def test_report_of_a_folder_without_results(tmp_path):
    with pytest.raises(UserError, match="no grid.json"):
        load_results(tmp_path)
    (tmp_path / "grid.json").write_text(json.dumps({"grid": {"tables": [3]}}))
    meta, rows = load_results(tmp_path)
    assert rows == {}
    text = markdown(meta, rows)
    assert text.count("(not run)") == 5


def test_table6_rows_are_ours_when_the_grid_ran_it(tmp_path):
    grid = PRESETS["paper-table6"].to_dict()
    write_json(tmp_path / "grid.json", {"format": "sdcomp-bench-grid", "grid": grid,
                                        "test_set": "real (t.json, 9 images)", "device": "cpu"})
    write_json(tmp_path / "cells" / "real-n500.json",
               {**_cell("real-n500", [[6, "500"]], 0.5), "val": None})
    meta, rows = load_results(tmp_path)
    text = markdown(meta, rows)
    assert "## Table 6: real frames only" in text and "the paper's only" not in text
    row = [c.strip() for c in next(ln for ln in text.splitlines()
                                   if ln.startswith("| 500 |")).split("|")[1:-1]]
    # row, images, 7 metrics, val AP50 ("-": real frames have no synthetic val), gap, paper
    assert row[:4] == ["500", "10", "25.00", "50.00"] and row[9] == "-"
    assert row[11:13] == ["77.09", "98.97"]
    assert "| 1000 | (not run) |" in text
    write_report(tmp_path)
    assert cv2.imread(str(tmp_path / "plots" / "ap_vs_size.png")) is not None
