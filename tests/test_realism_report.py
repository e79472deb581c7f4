"""The realism report: reading generated sets and real footage (GSD, sky and land), the
classifier on same / different sets, the report's files and verdicts, the command."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest

from sdcomp.cli import COMMANDS
from sdcomp.cli.realism import main
from sdcomp.errors import UserError
from sdcomp.render.camera.lens import lens_maps
from sdcomp.report.realism import FILES, classifier, realism_report
from sdcomp.report.realism.analysis import analyse_set
from sdcomp.report.realism.patches import empty_water, to_patches
from sdcomp.report.realism.sea import pinhole_pixels
from sdcomp.report.realism.sources import FrameSet, load_frame, load_generated, load_real
from sdcomp.report.realism.targets import evaluate_targets
from sdcomp.scene.camera import CameraModel, CameraPose, centre_gsd

from .datasets import cli

REPO = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def gen_shore(small_datasets) -> Path:
    """4 oblique images (the horizon in view) that all have a shore."""
    return small_datasets("shore", "--n", "4", "--seed", "3", "--shore", "1", "--pitch",
                          "15-20", "--altitude", "10-20")


def test_generated_frames_are_read_with_masks_and_gsd(gen_default):
    fs = load_generated(gen_default, max_images=6, seed=3)
    assert len(fs.frames) == 6 and [f.group for f in fs.frames] == list(range(6))
    model = CameraModel(width=192, height=192)
    zooms = []
    for f in fs.frames:
        pose = CameraPose(f.meta["height_above_takeoff(meter)"], f.meta["gimbal_pitch(degrees)"])
        zooms.append(f.camera["K"][0][0] / model.fx)  # the lens's zoom magnifies the image
        assert f.gsd == pytest.approx(centre_gsd(model, pose) / zooms[-1], rel=1e-4)
        loaded = load_frame(f)
        assert loaded is not None and loaded.rgb.shape == (192, 192, 3)
        inst = loaded.instances
        assert inst is not None and inst.dtype == np.uint16
        keep = empty_water(inst.shape, inst, f.boxes)
        assert not (keep & to_patches(inst).reshape(len(keep), -1).any(axis=1)).any()
    assert max(zooms) > 1.001  # the default looks' lenses were recorded


def test_recorded_pixels_are_traced_back_through_the_lens():
    """The sea oracle's pinhole_pixels inverts the camera stage's lens (zoom and radial
    distortion) as the COCO camera record gives it; no record: the pixel centres."""
    model = CameraModel(width=160, height=120)
    u0, v0 = pinhole_pixels(model, None)
    assert u0[0, 0] == 0.5 and v0[-1, -1] == 119.5 and u0.shape == (120, 160)
    lens = lens_maps(160, 120, model.fx, model.fy, -0.05, 0.01)
    assert lens.zoom > 1.01
    record = {"K": [[model.fx * lens.zoom, 0, 79.5], [0, model.fy * lens.zoom, 59.5],
                    [0, 0, 1]], "dist_coeffs": [-0.05, 0.01, 0, 0, 0], "width": 160,
              "height": 120}
    u, v = pinhole_pixels(model, record)
    back = lens.forward(np.stack([u - 0.5, v - 0.5], axis=-1))
    np.testing.assert_allclose(back[..., 0], u0 - 0.5, atol=1e-6)
    np.testing.assert_allclose(back[..., 1], v0 - 0.5, atol=1e-6)
    assert np.abs(v - v0).max() > 1.0  # the top row's middle comes from lower down
    other = dict(record, width=80)  # a record of another size is not this image's
    assert np.array_equal(pinhole_pixels(model, other)[0], u0)


def test_sky_and_land_are_not_water(gen_shore):
    hows = []
    for f in load_generated(gen_shore).frames:
        loaded = load_frame(f)
        assert loaded is not None and loaded.valid is not None
        assert not loaded.valid[0].any() and loaded.valid[-1].any()  # sky on top at 15-20
        hows.append(loaded.valid_how)
    assert all("sky excluded" in h for h in hows)
    assert sum("land excluded" in h for h in hows) >= 3, hows


def _frames(folder: Path, n: int = 3, size=(96, 160)) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    for i in range(n):
        cv2.imwrite(str(folder / f"f{i}.png"), np.full((*size, 3), 60 + 20 * i, np.uint8))
    return folder


def test_real_frames_with_coco_meta_give_gsd_sky_and_boxes(tmp_path):
    frames = _frames(tmp_path / "frames")
    meta = [{"height_above_takeoff(meter)": 20.0, "gimbal_pitch(degrees)": 90.0},
            {"height_above_takeoff(meter)": 30.0, "gimbal_pitch(degrees)": 15.0}]
    coco = {"images": [{"id": k + 1, "file_name": f"sub/f{k}.png", "width": 160,
                        "height": 96, "meta": m} for k, m in enumerate(meta)],
            "annotations": [{"id": 1, "image_id": 1, "bbox": [10, 10, 5, 5],
                             "category_id": 1}]}
    (tmp_path / "c.json").write_text(json.dumps(coco))
    fs = load_real(frames, tmp_path / "c.json", fov=77.0)
    assert [f.path.name for f in fs.frames] == ["f0.png", "f1.png"]  # f2 unlisted: skipped
    assert fs.frames[0].boxes == [[10, 10, 5, 5]] and fs.frames[1].boxes == []
    fx = CameraModel(160, 96, 77.0, 160, 96).fx
    assert fs.frames[0].gsd == pytest.approx(20.0 / fx)
    assert fs.frames[1].gsd == pytest.approx(30.0 / math.sin(math.radians(15)) / fx)
    sky = load_frame(fs.frames[1])
    assert sky is not None and sky.valid is not None and not sky.valid[0].any()
    assert any("not listed" in n for n in fs.notes)
    assert all(f.gsd == 0.05 and f.gsd_source == "user"
               for f in load_real(frames, gsd=0.05).frames)
    assert load_real(frames).frames[0].gsd is None
    for bad, match in (({"gsd": -1.0}, "--real-gsd"), ({"fov": 200.0}, "--real-fov")):
        with pytest.raises(UserError, match=match):
            load_real(frames, **bad)


def test_real_video_frames_are_sampled(tmp_path, gen_grey):
    images = sorted((gen_grey / "images").rglob("*.jpg"))
    out = cv2.VideoWriter(str(tmp_path / "flight.mp4"), cv2.VideoWriter_fourcc(*"mp4v"), 25,
                          (192, 192))
    for p in images:
        out.write(cv2.imread(str(p)))
    out.release()
    fs = load_real(tmp_path / "flight.mp4", max_images=5, seed=1)
    assert len(fs.frames) == 5 and len({f.source.frame for f in fs.frames}) == 5
    loaded = load_frame(fs.frames[2])
    assert loaded is not None and loaded.rgb.shape == (192, 192, 3)


def _xy(a, b):
    x = np.concatenate([a.features, b.features])
    y = np.r_[np.zeros(len(a.features), int), np.ones(len(b.features), int)]
    return x, y, np.concatenate([a.groups, b.groups + 10**7])


def test_two_halves_of_one_dataset_are_indistinguishable(gen_default):
    fs = load_generated(gen_default)
    halves = [FrameSet(k, fs.folder, [f for f in fs.frames if f.group % 2 == i])
              for i, k in enumerate(("generated", "real"))]
    r = classifier.cross_validate(*_xy(analyse_set(halves[0]), analyse_set(halves[1], 1)), 4)
    assert r.ci_images[0] <= 0.5 <= r.ci_images[1] and r.accuracy < 0.7, r


@pytest.fixture(scope="module")
def report(gen_default, gen_grey, tmp_path_factory):
    out = tmp_path_factory.mktemp("realism")
    result = realism_report(gen_default, gen_grey / "images", out,
                            gen_grey / "annotations" / "instances_train.json", real_fov=77.0,
                            max_images=24, folds=4)
    return out, result


def test_report_files_and_verdicts(report):
    out, r = report
    for name in FILES:
        assert (out / name).stat().st_size > 0, name
    for name in FILES[2:]:
        assert cv2.imread(str(out / name)) is not None, name
    j = json.loads((out / "report.json").read_text())
    assert j["summary"]["real"]["saturation"]["n"] > 0 and j["generated"]["images_read"] == 24
    md = (out / "report.md").read_text()
    verdicts = [t["ok"] for t in r["targets"]]
    assert len(verdicts) == 8 and md.count("**PASS**") + md.count("**FAIL**") >= 8
    # grey water is far less saturated than the default brown/blue/green; told apart
    s = r["summary"]
    assert s["real"]["saturation"]["median"] < 0.5 * s["generated"]["saturation"]["median"]
    c = r["classifier"]
    assert c["accuracy"] > 0.9 and c["folds"] == 4
    assert c["patches_per_class"][0] == c["patches_per_class"][1]
    assert r["real"]["gsd_m_per_px"]["known"] == r["real"]["images_read"]


def test_targets_pass_and_fail_by_their_definitions():
    def row(median, p10, p90):
        return {"median": median, "p10": p10, "p90": p90}

    real_like = {"saturation": row(0.18, 0.04, 0.35), "luminance": row(121, 90, 160),
                 "highpass_std": row(6.0, 2.0, 28.0), "glint_fraction": row(0.003, 0, 0.2)}
    assert all(t["ok"] in (True, None) for t in evaluate_targets(real_like))
    today = {**real_like, "saturation": row(0.41, 0.16, 0.65), "highpass_std": row(13.7, 7.6,
                                                                                    23.2)}
    failed = {t["target"] for t in evaluate_targets(today) if t["ok"] is False}
    assert failed == {"median saturation in [0.1, 0.25]", "median highpass_std in [4, 8]",
                      "highpass_std p10-p90 spread >= reference real (24.1)"}


def test_report_without_real_frames(gen_default, tmp_path):
    r = realism_report(gen_default, None, tmp_path / "solo", max_images=6)
    assert r["classifier"] is None and r["real"] is None
    assert all((tmp_path / "solo" / name).is_file() for name in FILES)
    assert "No real frames" in (tmp_path / "solo" / "report.md").read_text()
    assert [t["ok"] for t in r["targets"]][5] is None  # no luminance spread to compare


def test_command_prints_verdicts(gen_default, gen_grey, tmp_path):
    rc, out, err = cli([gen_default, "--real", gen_grey, "--out", tmp_path / "o",
                        "--max-images", "6", "--folds", "2"], main)
    assert rc == 0, err
    assert "classifier accuracy" in out and "targets:" in out
    verdicts = [line for line in out.splitlines() if line.startswith(("PASS  ", "FAIL  "))]
    assert len(verdicts) == 8 and "median saturation in [0.1, 0.25]" in verdicts[0]
    assert (tmp_path / "o" / "report.md").is_file() and "realism" in COMMANDS


def test_command_mistakes_are_one_line_and_write_nothing(gen_default, tmp_path):
    frames = _frames(tmp_path / "frames", 1)
    (tmp_path / "bad.json").write_text("{oops")
    labels = tmp_path / "labels"
    labels.mkdir()
    (labels / "f0.txt").write_text("0 0.5 0.5\n")
    (tmp_path / "empty").mkdir()
    out = tmp_path / "out"
    cases = [([tmp_path / "missing"], "does not exist"),
             ([tmp_path / "empty"], "not a generated dataset"),
             ([gen_default, "--real", tmp_path / "nope"], "--real"),
             ([gen_default, "--real", tmp_path / "empty"], "no photos or videos"),
             ([gen_default, "--real", frames, "--real-labels", tmp_path / "bad.json"],
              "not valid JSON"),
             ([gen_default, "--real", frames, "--real-labels", labels], "f0.txt:1"),
             ([gen_default, "--real-gsd", "0.05"], "need --real"),
             ([gen_default, "--max-images", "1"], "--max-images")]
    for argv, words in cases:
        rc, _, err = cli([*argv, "--out", out, "-q"], main)
        assert rc == 2 and len(err.strip().splitlines()) == 1 and words in err, (argv, err)
        assert not out.exists(), argv


def test_module_entry_point(tmp_path):
    res = subprocess.run([sys.executable, "-m", "sdcomp.realism", str(tmp_path / "x")],
                         cwd=REPO, capture_output=True, text=True, timeout=120)
    assert res.returncode == 2 and "Traceback" not in res.stderr
    assert len(res.stderr.strip().splitlines()) == 1, res.stderr


@pytest.mark.usefixtures("one_torch_thread")
def test_cnn_tells_grey_water_from_the_default(gen_default, gen_grey):
    a = analyse_set(load_generated(gen_default, max_images=12), cnn=True)
    b = analyse_set(load_real(gen_grey, max_images=12), seed=1, cnn=True)
    assert a.patches is not None and b.patches is not None
    assert a.patch_groups is not None and b.patch_groups is not None
    y = np.r_[np.zeros(len(a.patches), int), np.ones(len(b.patches), int)]
    r = classifier.cross_validate_cnn(np.concatenate([a.patches, b.patches]), y,
                                      np.concatenate([a.patch_groups, b.patch_groups + 10**7]),
                                      k=2, epochs=1, min_steps=15)
    assert r.model == "cnn" and r.accuracy > 0.8, r.accuracy
