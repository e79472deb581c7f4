"""Grid presets, cells and configuration checks of the detector benchmark (no torch)."""

from __future__ import annotations

import subprocess
import sys

import pytest

from sdcomp.bench.datasets import FieldSpec
from sdcomp.bench.grid import GREEN_EXTRA, PAPER, PRESETS, TABLES, Cell, GridSpec, preset
from sdcomp.bench.train import TrainConfig, batch_indices
from sdcomp.errors import UserError

EXPECTED_ROWS = {
    1: ["10 m", "20 m", "30 m", "40 m", "50 m"],
    2: ["brown", "blue", "green"],
    3: ["308", "626", "2500", "308+G", "626+G"],
    4: ["10 m", "20 m", "30 m", "40 m", "50 m"],
    5: ["brown", "blue", "green"],
}


def test_paper_preset_lists_every_row_of_tables_1_to_5_with_the_paper_figures():
    rows = PRESETS["paper"].rows()
    got: dict[int, list[str]] = {}
    for table, label, _ in rows:
        got.setdefault(table.number, []).append(label)
    assert got == EXPECTED_ROWS
    for t, labels in EXPECTED_ROWS.items():
        assert list(PAPER[t]) == labels
        assert all(len(v) == 5 for v in PAPER[t].values())
    assert PAPER[1]["10 m"] == (58.41, 90.90, 72.62, 57.82, 84.72)
    assert PAPER[3]["626+G"][1] == 98.27


@pytest.mark.parametrize("t", [1, 2, 3, 4, 5])
def test_table_presets_hold_exactly_their_table(t):
    spec = preset(f"paper-table{t}")
    assert [label for _, label, _ in spec.rows()] == EXPECTED_ROWS[t]
    assert {table.number for table, _, _ in spec.rows()} == {t}


def test_cells_of_the_paper_grid():
    spec = PRESETS["paper"]
    cells = spec.cells()
    # 21 rows, but 10 m brown 626 (Tables 1-3) and 10 m brown 2500 (Tables 3-5) are shared
    assert len(spec.rows()) == 21 and len(cells) == 17
    assert len({c.id for c in cells}) == 17
    t1 = [c for label, c in TABLES[1].rows]
    assert [c.altitude for c in t1] == [10, 20, 30, 40, 50]
    assert {(c.water, c.n) for c in t1} == {("brown", 626)}
    assert [c.n for _, c in TABLES[4].rows] == [2500] * 5
    assert [(c.water, c.altitude) for _, c in TABLES[5].rows] == [
        ("brown", 10), ("blue", 10), ("green", 10)]
    g308 = dict(TABLES[3].rows)["308+G"]
    parts = spec.parts(g308)
    assert [(p.water, p.n) for p in parts] == [("brown", 308), ("green", GREEN_EXTRA)]
    assert GREEN_EXTRA == 137 and parts[0].seed != parts[1].seed
    assert parts[0].size == 416


def test_paper_defaults_are_the_paper_schedule():
    spec = PRESETS["paper"]
    tc = spec.train
    assert (tc.optimizer, tc.lr, tc.max_iter, spec.image_size) == ("sgd", 0.001, 1500, 416)
    assert tc.backbone == "resnext101_32x8d-fpn" and tc.weights == "none"
    assert spec.size_scale == 1.0
    config = spec.parts(Cell(30, "brown", 626))[0].generator_config()
    assert (config.n, config.width, config.height) == (626, 416, 416)
    assert config.water == ("brown",) and config.altitude.to_json() == 30
    assert config.val_fraction == 0.2 and config.count.to_json() == 1


def test_smoke_preset_covers_every_row_small():
    spec = PRESETS["smoke"]
    assert {t.number for t, _, _ in spec.rows()} == {1, 2, 3, 4, 5}
    assert len(spec.rows()) == 21
    assert spec.train.backbone == "mobilenet_v3-fpn"
    assert spec.train.max_iter <= 20 and spec.image_size <= 192
    counts = {c.id: sum(p.n for p in spec.parts(c)) for c in spec.cells()}
    assert max(counts.values()) <= 64
    # sizes keep their order: 308 < 626 < 2500, and +G adds images
    assert counts["alt10-brown-n308"] < counts["alt10-brown-n626"] < counts[
        "alt10-brown-n2500"]
    assert counts["alt10-brown-n308+g137"] > counts["alt10-brown-n308"]


def test_field_set_is_held_out_and_mixed():
    spec = PRESETS["paper"]
    config = spec.field.generator_config(416)
    assert config.seed not in {p.seed for c in spec.cells() for p in spec.parts(c)}
    assert len(config.water) == 3
    assert config.altitude.to_json() == "10-20" and config.pitch.to_json() == "60-90"
    assert config.val_fraction == 0.0
    with pytest.raises(UserError, match="--field-seed"):
        GridSpec("x", field=FieldSpec(seed=0))
    with pytest.raises(UserError, match="--water"):
        FieldSpec(water=("purple",))


@pytest.mark.parametrize("kw, flag", [
    ({"lr": -1.0}, "--lr"), ({"lr": float("nan")}, "--lr"), ({"max_iter": 0}, "--max-iter"),
    ({"batch_size": 2.5}, "--batch-size"), ({"backbone": "vgg16"}, "--backbone"),
    ({"optimizer": "lbfgs"}, "--optimizer"), ({"weights": "no/such.pt"}, "--weights"),
    ({"hflip": "yes"}, "--hflip"),
])
def test_train_config_rejects_bad_values(kw, flag):
    with pytest.raises(UserError, match=flag):
        TrainConfig(**kw)


@pytest.mark.parametrize("kw, flag", [
    ({"tables": (7,)}, "tables"), ({"size_scale": 0}, "--size-scale"),
    ({"image_size": 8}, "--image-size"), ({"seed": -3}, "--seed"),
])
def test_grid_spec_rejects_bad_values(kw, flag):
    with pytest.raises(UserError, match=flag):
        GridSpec("x", **kw)


def test_unknown_preset_names_the_choices():
    with pytest.raises(UserError, match="paper-table1"):
        preset("paper-table9")


def test_mixed_water_draws_all_three_colours():
    config = GridSpec("x").parts(Cell(10, "mixed", 626))[0].generator_config()
    assert config.water == ("brown", "blue", "green") and config.n == 626


def test_multi_scale_training_sizes():
    from sdcomp.bench.detector import train_sizes

    assert train_sizes(416) == (416,)
    assert train_sizes(416, 0.5) == (208, 260, 312, 364, 416)
    with pytest.raises(UserError, match="--min-scale"):
        TrainConfig(min_scale=0.01)


def test_lr_warm_up_then_constant():
    tc = TrainConfig(lr=0.01, warmup_iters=10)
    assert tc.lr_at(0) == pytest.approx(0.01 * (0.001 + 0.999 * 0.1))
    assert tc.lr_at(9) == pytest.approx(0.01)
    assert tc.lr_at(10) == tc.lr_at(1000) == 0.01
    assert TrainConfig(warmup_iters=0).lr_at(0) == 0.001


def test_batches_visit_every_image_once_per_epoch_and_repeat_for_a_seed():
    n, b = 10, 2
    epoch0 = [i for it in range(5) for i in batch_indices(n, b, seed=3, iteration=it)]
    assert sorted(epoch0) == list(range(n))
    assert epoch0 != list(range(n))  # shuffled
    assert batch_indices(n, b, 3, 7) == batch_indices(n, b, 3, 7)
    assert batch_indices(n, b, 3, 7) != batch_indices(n, b, 4, 7) or \
        batch_indices(n, b, 3, 8) != batch_indices(n, b, 4, 8)


def test_the_package_and_grid_import_without_torch():
    code = ("import sys, sdcomp, sdcomp.generate, sdcomp.bench.cli, sdcomp.bench.grid, "
            "sdcomp.bench.report; print('torch' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True)
    assert out.stdout.strip() == "False"


def test_table6_trains_on_real_frames_and_joins_a_grid_given_them():
    from sdcomp.bench.cli import build_parser, grid_from_args
    spec = preset("paper-table6")
    assert [label for _, label, _ in spec.rows()] == list(PAPER[6]) == ["500", "1000", "1500"]
    assert [c.id for c in spec.cells()] == ["real-n500", "real-n1000", "real-n1500"]
    assert spec.real and TABLES[6].real and not PRESETS["paper"].real
    assert [spec.images(c.n) for c in spec.cells()] == [500, 1000, 1500]
    argv = ["grid", "--preset", "smoke", "--out", "o"]
    assert grid_from_args(build_parser().parse_args(argv)).tables == (1, 2, 3, 4, 5)
    given = argv + ["--real-train", "x.json", "--real-train-images", "frames"]
    assert grid_from_args(build_parser().parse_args(given)).tables == (1, 2, 3, 4, 5, 6)
