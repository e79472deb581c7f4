"""The ``sdcomp`` command: dispatch, help texts, --dump-config round trip, unknown config
keys, --quiet/--verbose, and ``sdcomp stats`` on a generated folder."""

from __future__ import annotations

import argparse
import configparser
import contextlib
import importlib
import io
import json
import re
import subprocess
import sys
import tomllib
from pathlib import Path

import cv2
import pytest

from sdcomp import cli
from sdcomp.cli import atlas, generate, merge, show, stats, video
from sdcomp.report.stats import dataset_stats, size_class
from sdcomp.scene.config import GeneratorConfig

from .datasets import cli as run_in_process

REPO = Path(__file__).resolve().parents[1]
SMALL = ["--n", "24", "--size", "96", "--clutter", "0", "--altitude", "3-6", "--count", "0-2",
         "--seed", "4", "--no-progress", "--workers", "1"]


def sdcomp(argv) -> tuple[int, str, str]:
    """``sdcomp ARGV`` in this process: (exit status, stdout, stderr)."""
    return run_in_process(argv, cli.main)


def option_entries(parser) -> list[str]:
    """Each option's help entry (flags and text, whitespace collapsed), --help excluded."""
    text = parser.format_help()
    return [" ".join(e.split()) for e in re.split(r"\n(?=  -)", text)
            if e.startswith("  -") and not e.startswith("  -h, --help")]


def test_console_script_entry_point():
    cfg = configparser.ConfigParser()
    cfg.read(REPO / "setup.cfg")
    scripts = cfg["options.entry_points"]["console_scripts"].strip().splitlines()
    name, target = (x.strip() for x in scripts[0].split("="))
    module, func = target.split(":")
    assert name == "sdcomp" and getattr(importlib.import_module(module), func) is cli.run


def test_top_level_help_and_errors():
    rc, out, _ = sdcomp(["--help"])
    assert rc == 0
    for name in ("atlas", "generate", "show", "stats", "merge", "bench"):
        assert re.search(rf"^  {name} ", out, re.M)
    rc, _, err = sdcomp(["genrate", "--n", "3"])
    assert rc == 2 and "'genrate'" in err and "'generate'" in err
    assert err.count("\n") == 1 and "Traceback" not in err
    rc, out, _ = sdcomp([])
    assert rc == 2 and "usage: sdcomp COMMAND" in out


def test_missing_optional_command_is_one_clear_line(monkeypatch):
    monkeypatch.setitem(sys.modules, "sdcomp.bench.cli", None)  # as if not installed
    rc, _, err = sdcomp(["bench", "--help"])
    assert rc == 2 and "sdcomp bench" in err and "sdcomp.bench" in err
    assert err.count("\n") == 1 and "Traceback" not in err


@pytest.mark.parametrize("name", ["generate", "video", "show", "stats", "merge",
                                  "atlas build"])
def test_every_option_shows_its_default(name):
    if name == "atlas build":
        parser = argparse.ArgumentParser(formatter_class=argparse.ArgumentDefaultsHelpFormatter)
        atlas.add_build_arguments(parser)
    else:
        parser = {"generate": generate, "video": video, "show": show, "stats": stats,
                  "merge": merge}[name].build_parser()
    entries = option_entries(parser)
    assert len(entries) >= 3
    missing = [e for e in entries if "default" not in e]
    assert not missing, f"{name}: options without a default: {missing}"


@pytest.mark.parametrize("module", ["generate", "video", "show", "stats", "merge", "atlas"])
def test_python_m_forms_still_work(module):
    res = subprocess.run([sys.executable, "-m", f"sdcomp.{module}", "--help"], cwd=REPO,
                         capture_output=True, text=True, timeout=120)
    assert res.returncode == 0 and "usage:" in res.stdout


def test_dump_config_round_trip(tmp_path):
    # defaults < preset < config file < flags, all in play
    (tmp_path / "base.toml").write_text('altitude = "12-18"\nwater = ["green", "10,20,30"]\n'
                                        "shallow = 0.1\n")
    argv = ["generate", "--preset", "paper-alt30", "--config", tmp_path / "base.toml",
            "--pitch", "40-90", "--format", "coco,yolo", "--yolo-seg", "--fov", "80.5",
            "--wb-red", "0.9-1.1", "--out", tmp_path / "never"]
    rc, dumped, err = sdcomp([*argv, "--dump-config"])
    assert rc == 0, err
    assert not (tmp_path / "never").exists()  # nothing written
    data = tomllib.loads(dumped)
    # every setting but the unset optional ones (None: TOML has no null), fov and wb_red set
    unset = {k for k, v in GeneratorConfig().to_dict().items() if v is None}
    assert unset >= {"sensor_px", "backgrounds", "background_labels", "exposure_bias"}
    assert set(data) == set(GeneratorConfig().to_dict()) - unset | {"fov", "wb_red"}
    assert data["altitude"] == "12-18" and data["pitch"] == "40-90"
    assert data["wb_red"] == "0.9-1.1" and "wb_blue" not in data
    assert data["format"] == ["coco", "yolo"] and data["yolo_seg"] is True
    (tmp_path / "dump.toml").write_text(dumped)
    parser = generate.build_parser()
    direct = generate.config_from_args(parser.parse_args([str(a) for a in argv[1:]]))
    fed = generate.config_from_args(parser.parse_args(["--config", str(tmp_path / "dump.toml")]))
    assert fed == direct and fed.to_dict() == direct.to_dict()
    assert fed != GeneratorConfig()
    # and the dump of the fed-back config is the same text
    rc, again, _ = sdcomp(["generate", "--config", tmp_path / "dump.toml", "--dump-config"])
    assert rc == 0 and again == dumped


def test_unknown_config_key_names_the_nearest(tmp_path):
    (tmp_path / "bad.toml").write_text("altitud = 30\n")
    rc, out, err = sdcomp(["generate", "--config", tmp_path / "bad.toml", "--out",
                           tmp_path / "o"])
    assert rc == 2 and "'altitud'" in err and "did you mean 'altitude'" in err
    assert err.count("\n") == 1 and not (tmp_path / "o").exists()
    (tmp_path / "far.toml").write_text("zzzz = 1\n")
    rc, _, err = sdcomp(["generate", "--config", tmp_path / "far.toml", "--dump-config"])
    assert rc == 2 and "'zzzz'" in err and "did you mean" not in err


@pytest.fixture(scope="module")
def small_dataset(tmp_path_factory, sprites_dir) -> Path:
    out = tmp_path_factory.mktemp("cli") / "ds"
    rc, stdout, err = sdcomp(["generate", *SMALL, "--out", out, "--sprites", sprites_dir])
    assert rc == 0, err
    assert "wrote 24 images" in stdout
    return out


def test_quiet_and_verbose(small_dataset, tmp_path, sprites_dir):
    rc, out, err = sdcomp(["generate", *SMALL, "--n", "3", "--out", tmp_path / "q",
                           "--sprites", sprites_dir, "--quiet"])
    assert rc == 0 and out == "" and err == ""
    rc, out, err = sdcomp(["generate", *SMALL, "--n", "3", "--out", tmp_path / "v",
                           "--sprites", sprites_dir, "--verbose"])
    assert rc == 0 and "wrote 3 images" in out and "altitude = " in out  # the config
    rc, out, _ = sdcomp(["stats", small_dataset, "--out", "-", "-q"])
    assert rc == 0 and out == ""


def test_stats_table_and_figure(small_dataset, tmp_path):
    coco = {}
    for split in ("train", "val"):
        coco[split] = json.loads(
            (small_dataset / "annotations" / f"instances_{split}.json").read_text())
    png = tmp_path / "s.png"
    rc, out, err = sdcomp(["stats", small_dataset, "--out", png])
    assert rc == 0, err
    rows = {line[:24].strip(): line.split()[-3:] for line in out.splitlines()
            if line.startswith(("images", "objects:", "ignore regions"))}
    n = {s: len(coco[s]["images"]) for s in coco}
    assert rows["images"] == [str(n["train"]), str(n["val"]), str(n["train"] + n["val"])]
    empty = {s: sum(1 for im in coco[s]["images"]
                    if not any(a["image_id"] == im["id"] and not a["iscrowd"]
                               for a in coco[s]["annotations"]))
             for s in coco}
    assert rows["images with no objects"][-1] == str(empty["train"] + empty["val"])
    labelled = [a for c in coco.values() for a in c["annotations"] if not a["iscrowd"]]
    assert rows["objects: bluerov2"][-1] == str(len(labelled))
    assert rows["ignore regions"][-1] == str(sum(len(c["annotations"])
                                                 for c in coco.values()) - len(labelled))
    s = dataset_stats(small_dataset, bins=5)
    areas = [a["area"] for a in labelled]
    assert sum(s["sizes"]["bluerov2"].values()) == len(areas)
    assert s["sizes"]["bluerov2"]["small"] == sum(a < 32 ** 2 for a in areas)
    alts = [im["meta"]["height_above_takeoff(meter)"] for c in coco.values()
            for im in c["images"]]
    assert sum(s["meta"]["altitude"]["counts"]) == len(alts)
    assert s["meta"]["altitude"]["min"] == min(alts) and 3 <= min(alts) <= max(alts) <= 6
    assert sum(s["water"].values()) == len(alts)
    img = cv2.imread(str(png))
    assert img is not None and img.shape[0] > 300 and img.shape[1] > 600
    assert [size_class(a) for a in (1023, 1024, 9215, 9216)] == [
        "small", "medium", "medium", "large"]


def test_stats_errors(tmp_path, small_dataset):
    rc, _, err = sdcomp(["stats", tmp_path / "nothing"])
    assert rc == 2 and "not a generated dataset" in err
    rc, _, err = sdcomp(["stats", small_dataset, "--out", tmp_path / "x.jpg"])
    assert rc == 2 and ".png" in err
    rc, _, err = sdcomp(["stats", small_dataset, "--bins", "0"])
    assert rc == 2 and "--bins" in err


@pytest.mark.parametrize("name", ["atlas", "generate", "show", "stats", "merge", "bench"])
def test_usage_line_names_the_way_the_command_was_run(name):
    """``sdcomp NAME --help`` says ``usage: sdcomp NAME``; the module run directly (``python
    -m sdcomp.NAME``) names itself so."""
    for run, want in ((lambda: cli.main([name, "--help"]), f"sdcomp {name}"),
                      (lambda: cli.command(name)(["--help"]), f"python -m sdcomp.{name}")):
        buf = io.StringIO()
        with contextlib.redirect_stdout(buf), pytest.raises(SystemExit) as exc:
            run()
        assert exc.value.code == 0 and buf.getvalue().startswith(f"usage: {want} ")
    assert cli._RUNNING == []  # nothing left behind by either run


def test_retired_options_load_with_a_warning(tmp_path, caplog):
    """Flags and config keys of earlier versions (the old renderer's noise, exposure,
    rocks...) are accepted with a warning naming what replaced them, and change nothing."""
    from sdcomp.scene.config import RETIRED

    parser = generate.build_parser()
    with caplog.at_level("WARNING"):
        old = generate.config_from_args(parser.parse_args(
            ["--noise", "3", "--exposure", "0.5", "--out", str(tmp_path / "x")]))
    assert old == generate.config_from_args(parser.parse_args(["--out", str(tmp_path)]))
    text = caplog.text
    assert "'noise' is no longer used" in text and RETIRED["noise"] in text
    assert "'exposure' is no longer used" in text
    (tmp_path / "old.toml").write_text("rocks = 0.3\nambient = 0.4\naltitude = 25\n")
    cfg = GeneratorConfig.from_mapping(generate.load_toml(tmp_path / "old.toml"))
    assert cfg.altitude == GeneratorConfig(altitude=25).altitude
    assert "--noise" not in parser.format_help()  # not listed
