"""No silent surprises: option abbreviations and misspellings, objects too small to annotate,
the progress bar, growing a dataset, an old folder's format, the camera record, the zoomed
contact sheet and a constant parameter in the statistics figure."""

from __future__ import annotations

import json
import math

import cv2
import numpy as np
import pytest

from sdcomp.cli import main as sdcomp_main
from sdcomp.cli.generate import main as generate
from sdcomp.cli.show import main as show
from sdcomp.pipeline import Generator
from sdcomp.scene.camera import project
from sdcomp.scene.config import GeneratorConfig

from .datasets import assert_identical, cli, one_line_error

SMALL = ["--size", "96", "--clutter", "0", "--altitude", "4-8", "--seed", "4", "--workers",
         "1", "--no-progress"]


@pytest.mark.parametrize("argv, near", [
    (["--altitud", "30"], "--altitude"), (["--alt", "30"], "--altitude"),
    (["--no-shadow"], "--no-shadows"), (["--yolo-sg"], "--yolo-seg")])
def test_options_are_never_abbreviated_and_misspellings_get_a_hint(tmp_path, argv, near):
    rc, _, err = cli([*argv, "--out", tmp_path / "x"])
    assert rc == 2
    one_line_error(err)
    assert f"did you mean {near}?" in err and argv[0] in err
    assert not (tmp_path / "x").exists()


def test_every_command_errors_in_one_line():
    for argv in (["show", "x", "--no-label"], ["stats"], ["merge", "--ot", "d"],
                 ["atlas", "build", "--sise", "3"], ["generate", "--workers", "many"]):
        rc, _, err = cli(argv, entry=sdcomp_main)
        assert rc == 2, argv
        one_line_error(err)


def test_help_shows_each_default_once(capsys):
    with pytest.raises(SystemExit):
        show(["--help"])
    text = capsys.readouterr().out
    assert text.count("(default:") == text.count("(default") and "(default: None)" not in text
    flat = " ".join(text.split())
    assert "no caption band (default: captions under each image)" in flat
    assert "(default: True)" not in flat
    with pytest.raises(SystemExit):
        generate(["--help"])
    flat = " ".join(capsys.readouterr().out.split())
    assert flat.count("(default: 416)") == 3  # --size, --width, --height, each once


def test_a_run_of_unannotatable_objects_warns(tmp_path, sprites_dir):
    rc, out, err = cli(["--n", "3", "--size", "64", "--altitude", "500", "--count", "2",
                        "--workers", "1", "--no-progress", "--out", tmp_path / "far",
                        "--sprites", sprites_dir])
    assert rc == 0
    assert "wrote 3 images" in out and "0 objects labelled" in out and "6 not visible" in out
    assert "none of the 6 objects placed could be labelled" in err
    assert "--altitude" in err and "--min-visible-px" in err


def test_progress_bar_has_percentage_elapsed_and_eta(tmp_path, sprites_dir):
    rc, _, err = cli(["--n", "4", *SMALL[:-1], "--progress", "--out", tmp_path / "p",
                      "--sprites", sprites_dir])
    assert rc == 0
    last = err.replace("\r", "\n").strip().splitlines()[-1]
    assert last.startswith("generate: 100%|") and "4/4 [" in last and "<00:00" in last
    assert "img/s]" in last


def test_resume_grows_a_finished_dataset_to_a_fresh_runs_bytes(tmp_path, sprites_dir):
    base = [*SMALL, "--format", "coco,yolo", "--yolo-seg", "--sprites", sprites_dir]
    rc, _, err = cli([*base, "--n", "7", "--out", tmp_path / "grown"])
    assert rc == 0, err
    before = (tmp_path / "grown" / "images").rglob("*.jpg")
    kept = {p.relative_to(tmp_path / "grown"): p.stat().st_mtime_ns for p in before}
    rc, out, err = cli([*base, "--n", "15", "--resume", "--out", tmp_path / "grown"])
    assert rc == 0, err
    assert "wrote 15 images" in out
    rc, _, err = cli([*base, "--n", "15", "--out", tmp_path / "fresh"])
    assert rc == 0, err
    assert_identical(tmp_path / "grown", tmp_path / "fresh")
    # the first images were not redrawn
    assert all((tmp_path / "grown" / p).stat().st_mtime_ns == t for p, t in kept.items())
    rc, _, err = cli([*base, "--n", "10", "--resume", "--out", tmp_path / "grown"])
    assert rc == 2 and "--n 15 or larger" in err
    one_line_error(err)


def test_resume_refuses_a_format_1_folder(tmp_path, sprites_dir):
    argv = [*SMALL, "--n", "3", "--out", tmp_path / "old", "--sprites", sprites_dir]
    assert cli(argv)[0] == 0
    meta_path = tmp_path / "old" / "dataset.json"
    meta = json.loads(meta_path.read_text())
    assert meta["format_version"] == 2
    meta["format_version"] = 1
    meta_path.write_text(json.dumps(meta))
    rc, _, err = cli([*argv, "--resume"])
    assert rc == 2
    one_line_error(err)
    assert "dataset format 1" in err and "--overwrite" in err


def test_camera_record_projects_objects_into_their_boxes(tmp_path, sprites_dir):
    """K, dist_coeffs, R_w2c and t_w2c of an image project each object's position to
    inside its box (through the lens's distortion, as OpenCV projects); without the
    distortion and the zoom they are the scene's pinhole camera; the heading is DJI's
    (clockwise from north); visibility is a fraction."""
    config = GeneratorConfig(width=160, height=120, altitude="5-9", pitch="50-90",
                             clutter=0, count="1-3", seed=9)
    gen = Generator(config, sprites_dir, progress=False)
    out = tmp_path / "cam"
    rc, _, err = cli(["--config", _toml(tmp_path, config), "--n", "8", "--workers", "1",
                      "--no-progress", "--out", out, "--sprites", sprites_dir])
    assert rc == 0, err
    checked = 0
    for line in (out / "records.jsonl").read_text().splitlines():
        rec = json.loads(line)
        cam, scene = rec["image"]["camera"], gen.scene(rec["index"])
        K, R, t = (np.array(cam[k]) for k in ("K", "R_w2c", "t_w2c"))
        dist = np.array(cam["dist_coeffs"], np.float64)
        assert np.allclose(R @ R.T, np.eye(3), atol=1e-8) and dist.shape == (5,)
        zoom = K[0, 0] / scene.model.fx  # the lens's zoom scales the focal lengths
        assert (cam["width"], cam["height"]) == (160, 120)
        assert cam["sensor"]["preset"] == "mavic2pro"
        heading = rec["image"]["meta"]["gimbal_heading(degrees)"]
        assert -180 <= heading < 180
        assert math.isclose((90 - scene.camera.heading - heading) % 360, 0, abs_tol=1e-3) or \
            math.isclose((90 - scene.camera.heading - heading) % 360, 360, abs_tol=1e-3)
        for ann in rec["annotations"]:
            assert 0 < ann["visibility"] <= 1
            assert all(isinstance(v, float) for v in ann["bbox"])
            p = ann["pose"]
            world = np.array([p["x_m"], p["y_m"], 0.0])
            cam_pt = R @ world + t
            u, v, _ = K @ (cam_pt / cam_pt[2])
            uv, _ = project(scene.model, scene.camera, world[None])
            pinhole = [K[0, 2] + (u - K[0, 2]) / zoom + 0.5,
                       K[1, 2] + (v - K[1, 2]) / zoom + 0.5]
            assert pinhole == pytest.approx(uv[0].tolist(), abs=1e-3)
            seen, _ = cv2.projectPoints(world[None], cv2.Rodrigues(R)[0], t, K, dist)
            u, v = seen[0, 0]
            x, y, w, h = ann["bbox"]
            if x == 0 or y == 0 or x + w == 160 or y + h == 120:
                continue  # cut by the frame: its centre may lie outside
            # within the box, or by a few pixels beside it: the ROV floats awash, and
            # its box is the part that supplies half a pixel's colour, which may end a
            # pixel or two short of its centre (refraction moves submerged parts by
            # fractions of a pixel)
            m = max(2.0, 0.5 * max(w, h))
            assert x - m <= u + 0.5 <= x + w + m and y - m <= v + 0.5 <= y + h + m
            checked += 1
    assert checked > 5


def _toml(tmp_path, config: GeneratorConfig):
    path = tmp_path / "c.toml"
    path.write_text(config.to_toml())
    return path


def test_zoom_sheet_has_a_cell_per_object_and_stats_say_constants(tmp_path, sprites_dir):
    from sdcomp.report.stats import dataset_stats, plot_stats

    out = tmp_path / "z"
    rc, _, err = cli(["--n", "6", "--clutter", "0", "--count", "2", "--seed", "1",
                      "--workers", "1", "--no-progress", "--out", out, "--sprites",
                      sprites_dir])
    assert rc == 0, err
    rc, printed, err = cli([out, "--zoom", "--n", "5", "--columns", "5", "--cell", "64",
                            "--out", tmp_path / "z.png"], entry=show)
    assert rc == 0, err
    assert "5 objects" in printed and "320x64 px" in printed
    import cv2

    sheet = cv2.imread(str(tmp_path / "z.png"))
    assert sheet.shape == (64, 320, 3)
    # each cell is magnified: neighbouring pixels repeat (nearest-neighbour enlargement)
    cell = sheet[8:40, 8:56].astype(int)
    assert (np.abs(np.diff(cell, axis=1)).sum(axis=2) == 0).mean() > 0.5
    stats = dataset_stats(out)
    assert stats["meta"]["pitch"]["min"] == stats["meta"]["pitch"]["max"] == 90
    assert plot_stats(stats)[:8] == b"\x89PNG\r\n\x1a\n"


def test_visibility_compares_areas_after_the_lens(sprites_dir):
    """The lens magnifies the recorded frame by its zoom (1.00-1.02): an object's visible
    area, measured after it, is compared with its silhouette magnified likewise, so a whole
    object in view is about 1, not up to 4 % over (what is left over comes from the local
    magnification of the distortion and from small objects' pixel rounding, and the record's
    visibility is capped at 1)."""
    from sdcomp.annotate.records import coco_annotations
    from sdcomp.scene.config import GeneratorConfig

    g = Generator(GeneratorConfig(n=40, seed=3, count="3", clutter=0.0, altitude="5-15"),
                  sprites_dir)
    ratios, zooms = [], []
    for i in range(40):
        f = g.render(i)
        zooms.append(f.camera["zoom"])
        ratios += [o.area / o.silhouette_area for o in f.objects if o.silhouette_area >= 300]
        assert all(0 < a["visibility"] <= 1 for a in coco_annotations(f))
    assert max(zooms) > 1.01 and len(ratios) > 20
    assert max(ratios) < 1.035
