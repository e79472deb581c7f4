"""The search-and-rescue kinds through the whole pipeline and the command lines: a dataset of
a kind's variants and a single variant (one atlas per variant, in the kind's parameters;
clutter variants in their own small atlases), the same bytes with any number of workers;
``sdcomp mesh info|export`` of a kind; ``sdcomp atlas build --mesh KIND``."""

from __future__ import annotations

import json
import shlex
from pathlib import Path

import cv2
import pytest
import trimesh

from sdcomp.assets import sar
from sdcomp.atlas.builtin import CLUTTER_ATLAS, KIND_ATLAS, sprite_size
from sdcomp.atlas.poses import PoseGrid
from sdcomp.atlas.store import read_index
from sdcomp.cli.atlas import main as atlas_main
from sdcomp.cli.generate import build_parser, config_from_args
from sdcomp.cli.mesh import main as mesh_main
from sdcomp.pipeline import Generator

from .datasets import cli, files, generate

BASE = ["--n", "12", "--size", "160", "--altitude", "3-5", "--pitch", "50-90", "--count",
        "2-4", "--object", "life_saving_appliances", "--object", "swimmer-03",
        "--category", "person", "--clutter", "2", "--clutter-kinds", "buoy", "log",
        "--seed", "7"]


@pytest.fixture(scope="module")
def dataset(tmp_path_factory, sprites_dir):
    out = tmp_path_factory.mktemp("sar") / "one"
    rc, _, err = generate(BASE, out, sprites_dir)
    assert rc == 0, err
    return out


def test_dataset_of_a_kind_and_a_variant(dataset, sprites_dir):
    coco = json.loads((dataset / "annotations" / "instances_train.json").read_text())
    assert [(c["id"], c["name"]) for c in coco["categories"]] == [
        (1, "life_saving_appliances"), (2, "person")]
    val = json.loads((dataset / "annotations" / "instances_val.json").read_text())
    cats = {a["category_id"] for a in coco["annotations"] + val["annotations"]}
    assert cats == {1, 2}
    # an atlas per variant, in the kind's parameters; clutter variants in their own
    for name in sar.variant_names("life_saving_appliances"):
        assert read_index(sprites_dir / f"{name}.json")["size_px"] == 96
    assert read_index(sprites_dir / "swimmer-03.json")["size_px"] == sprite_size(
        sar.build("swimmer", 3), KIND_ATLAS["swimmer"].size)  # a treading swimmer: 192
    # only what the run uses is loaded (the shared atlas folder holds other tests' too)
    config = config_from_args(build_parser().parse_args(BASE))  # the dataset's own config
    loaded = set(Generator(config, sprites_dir).compositor.assets.sprites)
    assert {k for k in loaded if k.startswith("swimmer")} == {"swimmer-03"}
    assert {k for k in loaded if not k.startswith("clutter")} == {
        "swimmer-03", *sar.variant_names("life_saving_appliances")}
    for v in range(sar.VARIANTS["buoy"]):
        index = read_index(sprites_dir / f"clutter-buoy-{v:02d}.json")
        assert index["size_px"] == CLUTTER_ATLAS.size
        assert index["mesh"]["hash"] == sar.build("buoy", v).content_hash()


def test_same_bytes_with_two_workers(dataset, tmp_path, sprites_dir):
    rc, _, err = generate(BASE, tmp_path / "two", sprites_dir, workers=2)
    assert rc == 0, err
    for sub in ("images", "masks", "annotations"):  # images/train/000000.jpg ...
        one, two = files(dataset / sub), files(tmp_path / "two" / sub)
        assert len(one) >= (2 if sub == "annotations" else 12) and sorted(one) == sorted(two)
        assert [k for k in one if one[k] != two[k]] == []


def test_an_object_kind_in_the_clutter_list_is_one_error_line(tmp_path, sprites_dir):
    rc, _, err = generate([*BASE, "--clutter-kinds", "life_saving_appliances"],
                          tmp_path / "x", sprites_dir)
    assert rc == 2 and err.count("\n") == 1
    assert err.startswith("error: --clutter-kinds life_saving_appliances is also an --object")
    assert not (tmp_path / "x").exists()


def test_mesh_info_and_export_of_a_kind(tmp_path, capsys):
    assert mesh_main(["info", "buoy"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert len(lines) == 1 + sar.VARIANTS["buoy"]
    assert lines[3].split()[:2] == ["buoy-02", "spar"]
    out = tmp_path / "buoys.ply"
    assert mesh_main(["export", "buoy", str(out)]) == 0
    lineup = trimesh.load(out, process=False)
    assert len(lineup.faces) == sum(len(sar.build("buoy", v).faces) for v in range(10))
    assert mesh_main(["export", "buoy-07", str(tmp_path / "b.glb")]) == 0
    rc, _, err = cli(["export", "buoy-10", str(tmp_path / "c.ply")], mesh_main)
    assert rc == 2 and "'buoy-10' is neither a built-in mesh" in err


def test_atlas_build_of_a_kind_writes_every_variant_and_the_kind_sheet(tmp_path, capsys):
    flags = ["--size", "16", "--supersample", "1", "--max-off-nadir", "45",
             "--off-nadir-step", "45", "--max-error", "40"]
    assert atlas_main(["build", "--mesh", "jetski", "--out", str(tmp_path), *flags]) == 0
    assert "jetski: 8 atlases" in capsys.readouterr().out
    for v in range(8):
        index = read_index(tmp_path / f"jetski-{v:02d}.json")
        assert index["size_px"] == 16 and index["supersample"] == 1
        assert index["rebuild_command"].startswith(
            f"python -m sdcomp.atlas build --mesh jetski-{v:02d} --out ")
        assert "--size 16" in index["rebuild_command"]
    sheet = cv2.imread(str(tmp_path / "jetski_sheet.png"))
    assert sheet.shape[0] == 8 * 128 and sheet.shape[1] % 128 == 0
    # a variant alone takes its kind's parameters unless the flags say otherwise
    assert atlas_main(["build", "--mesh", "jetski-05", "--out", str(tmp_path / "one"),
                       "--off-nadir-step", "45", "--max-error", "40"]) == 0
    index = read_index(tmp_path / "one" / "jetski-05.json")
    assert (index["size_px"], index["supersample"]) == (128, 3)
    assert index["grid"] == {"max_off_nadir": 80.0, "off_nadir_step": 45.0, "max_error": 40.0}
    assert len(index["poses"]) == len(PoseGrid(80.0, 45.0, 40.0).poses())


def test_readme_command_lines_of_the_section_parse(tmp_path, monkeypatch):
    """Every ``sdcomp generate`` line of docs/sar.md makes a
    valid config (flags, preset, weights, clutter kinds), without running it; a line that
    reads the config a fit line wrote (``--config fitted.toml``) reads an empty one."""
    section = (Path(__file__).resolve().parents[1] / "docs" / "sar.md").read_text()
    monkeypatch.chdir(tmp_path)
    (tmp_path / "fitted.toml").write_text("# what sdcomp fit wrote: here nothing\n")
    section = section.replace("\\\n", " ")  # a command continued on the next line
    lines = [ln.split("#")[0] for ln in section.splitlines()
             if ln.startswith("sdcomp generate ")]
    assert len(lines) >= 4
    for line in lines:
        args = build_parser().parse_args(shlex.split(line)[2:])
        config = config_from_args(args)
        assert config.objects and config.n >= 1, line
