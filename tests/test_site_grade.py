"""The site grade (issue 48, item 2): the camera's last stage, fitted by ``sdcomp fit`` from
the generated water to the footage's, stored beside the config, off unless the config names
it, deterministic."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import cv2
import numpy as np
import pytest

from sdcomp import GeneratorConfig
from sdcomp.errors import UserError, run_cli
from sdcomp.fitting.grade import (
    chroma_detail,
    fit_grade,
    luma_spectrum,
    realism_accuracy,
    water_patches,
)
from sdcomp.pipeline import Generator
from sdcomp.render.camera import STAGES, apply_camera
from sdcomp.render.camera.grade import (
    SPECTRUM_BANDS,
    SiteGrade,
    apply_grade,
    filter_luma,
    identity_grade,
    load_grade,
    save_grade,
)
from sdcomp.render.camera.sensor import make_noise_tile
from sdcomp.report.realism.classifier import patch_features
from sdcomp.scene.look_table import sample_look
from sdcomp.scene.settings import load_toml


def water(n: int, seed: int, mean=(60, 110, 120), spread=(6, 9, 8), blur: float = 0.0,
          grain: float = 0.3) -> np.ndarray:
    """(n, 64, 64, 3) uint8 patches of a textured water stand-in: a per-channel mean and
    spread, a shared luma texture (channels correlated, as water's are), optionally
    blurred, and ``grain`` of independent noise per channel (colour grain)."""
    rng = np.random.default_rng(seed)
    t = rng.normal(0, 1, (n, 64, 64)).astype(np.float32)
    if blur:
        t = np.stack([cv2.GaussianBlur(a, (0, 0), blur) for a in t])
        t /= t.std()
    own = rng.normal(0, grain, (n, 64, 64, 3)).astype(np.float32)
    x = np.array(mean, np.float32) + np.array(spread, np.float32) * (t[..., None] + own)
    return np.clip(np.round(x), 0, 255).astype(np.uint8)


def test_spectrum_filter_reshapes_the_luma_and_keeps_its_mean():
    """Gains of 1 change nothing; a gain of 0.5 on the finest bands halves their amplitude
    (a quarter of the power) and leaves the coarse ones and the mean; the borders are not
    wrapped round (a bright left edge does not appear on the right)."""
    rng = np.random.default_rng(0)
    y = (100 + 10 * rng.normal(0, 1, (256, 320))).astype(np.float32)
    ones = (1.0,) * SPECTRUM_BANDS
    assert np.allclose(filter_luma(y, ones, 1.0), y, atol=1e-3)
    fine = (1.0,) * (SPECTRUM_BANDS - 2) + (0.5, 0.5)
    out = filter_luma(y, fine, 1.0)
    assert abs(out.mean() - y.mean()) < 0.05
    rgb = np.repeat(np.clip(np.stack([y, out]), 0, 255).astype(np.uint8)[..., None], 3, -1)
    patches = np.stack([rgb[k, 64 * r:64 * r + 64, 64 * c:64 * c + 64] for k in (0, 1)
                        for r in range(4) for c in range(5)]).reshape(2, 20, 64, 64, 3)
    before, after = luma_spectrum(patches[0]), luma_spectrum(patches[1])
    assert np.allclose(after[-1] / before[-1], 0.25, rtol=0.2)
    assert np.allclose(after[:3] / before[:3], 1.0, rtol=0.1)
    edge = np.full((64, 96), 50, np.float32)
    edge[:, :8] = 250
    sharp = filter_luma(edge, (1.0,) * (SPECTRUM_BANDS - 3) + (2.0, 2.0, 2.0), 1.0)
    assert np.abs(sharp[:, -16:] - 50).max() < 1.0


def frames_of(n_frames: int, per: int, seed: int, mean, between: float = 0.0, **kw
              ) -> tuple[np.ndarray, np.ndarray]:
    """((n_frames * per, 64, 64, 3) uint8 water patches, (n,) their frame): ``per`` patches
    of each frame, whose mean colour is ``mean`` moved by ``between`` levels (a random
    level per frame, the same for every channel: another light); ``kw`` as :func:`water`."""
    rng = np.random.default_rng(seed + 1000)
    out = [water(per, seed * 100 + f, mean=np.add(mean, rng.normal(0, between)), **kw)
           for f in range(n_frames)]
    return np.concatenate(out), np.repeat(np.arange(n_frames), per)


def within(patches: np.ndarray, frames: np.ndarray) -> np.ndarray:
    """(3,) the per-channel standard deviation of ``patches`` about their frame's mean."""
    px = patches.reshape(len(patches), -1, 3).astype(np.float64)
    return np.sqrt(np.mean([px[frames == f].reshape(-1, 3).var(0)
                            for f in np.unique(frames)], axis=0))


def test_fit_takes_the_generated_water_to_the_footages():
    """Footage of another colour and more contrast, whose frames differ more from each
    other: the search lowers the realism classifier's accuracy on these patches, moves the
    generated water's colour to the footage's and never stretches it by the spread between
    the footage's frames (a map that is the same for every frame would stretch each frame's
    contrast instead); it is deterministic."""
    gen, gf = frames_of(8, 5, 0, (60, 110, 120), between=2.0)
    real, rf = frames_of(8, 5, 1, (95, 120, 90), between=25.0, spread=(9, 13.5, 12))
    fitted = fit_grade(gen, gf, real, rf, 64)  # patches as frames: bands at the fitted scale
    assert fitted.trials[0] == ("the fitted scene", round(fitted.before, 4))
    assert fitted.after < fitted.before - 0.1, fitted.trials
    graded = np.stack([apply_grade(p, fitted.grade, 1.0) for p in gen])
    assert np.allclose(graded.reshape(-1, 3).mean(0), real.reshape(-1, 3).mean(0), atol=3.0)
    assert np.all(within(graded, gf) < 2.0 * within(real, rf))
    accuracy = realism_accuracy(patch_features(real), rf, graded, gf)
    assert accuracy == pytest.approx(fitted.after, abs=1e-9)
    again = fit_grade(gen, gf, real, rf, 64)
    assert again.grade.to_json() == fitted.grade.to_json() and again.trials == fitted.trials


def test_detail_measures_see_softness_and_grain():
    """The spectrum's finest bands and the chroma detail fall for a blurred and a less grainy
    water; a grade with only a chroma gain under 1 lowers the chroma detail, not the luma's."""
    sharp, soft = water(10, 0), water(10, 0, blur=1.0, grain=0.05)
    assert luma_spectrum(soft)[-1] < 0.1 * luma_spectrum(sharp)[-1]  # the finest band
    assert chroma_detail(soft) < 0.5 * chroma_detail(sharp)
    less = SiteGrade(np.eye(3), np.zeros(3), chroma=0.3, fitted_width=64)
    out = np.stack([apply_grade(p, less) for p in sharp])
    assert chroma_detail(out) < 0.5 * chroma_detail(sharp)
    assert np.allclose(luma_spectrum(out), luma_spectrum(sharp), rtol=0.1)


def test_identity_changes_nothing_and_patches_are_chosen_from_water():
    img = water(1, 3)[0]
    assert identity_grade().identity and np.array_equal(apply_grade(img, identity_grade()), img)
    frame = np.zeros((128, 192, 3), np.uint8)
    frame[:64, :64] = 200
    keep = np.array([True, False, False, False, False, False])
    p = water_patches(frame, keep, np.random.default_rng(0))
    assert p.shape == (1, 64, 64, 3) and p.min() == 200
    assert water_patches(frame, None, np.random.default_rng(0), n=4).shape == (4, 64, 64, 3)


def test_file_round_trip_and_bad_files_are_named(tmp_path):
    grade = SiteGrade(np.eye(3) * 1.2, np.array([-3.0, 4.0, 5.0]),
                      (1.0, 1.1, 1.2, 1.0, 0.9, 0.8, 0.7, 0.6), 0.5, 640, "test")
    path = tmp_path / "g.grade.json"
    save_grade(grade, path)
    back = load_grade(path)
    assert back.to_json() == grade.to_json() and back.fitted_width == 640
    d = json.loads(path.read_text())
    cases = {"not JSON": "{", "no \"format\"": json.dumps({**d, "format": "x"}),
             "3 x 3": json.dumps({**d, "matrix": [[1, 0], [0, 1]]}),
             "3 numbers": json.dumps({**d, "offset": [1, 2]}),
             "8 gains": json.dumps({**d, "detail": {**d["detail"], "spectrum": [1, 2]}}),
             "detail gains": json.dumps({**d, "detail": {**d["detail"], "chroma": 9}}),
             "missing": json.dumps({k: v for k, v in d.items() if k != "offset"})}
    for i, (needle, text) in enumerate(cases.items()):
        bad = tmp_path / f"bad{i}.json"
        bad.write_text(text)
        with pytest.raises(UserError, match="bad") as e:
            load_grade(bad)
        assert needle in str(e.value), (needle, str(e.value))
    with pytest.raises(UserError, match="no such file"):
        load_grade(tmp_path / "none.json")


def test_camera_runs_the_grade_last(tmp_path):
    """With a grade the camera's output is its ungraded output through the grade; the look
    without one gives the bytes it gave before (no ``grade`` in its JSON)."""
    grade = SiteGrade(np.eye(3) * 0.9, np.array([10.0, 0.0, -5.0]),
                      (1.0,) * 6 + (0.7, 0.5), 0.6, 320)
    path = tmp_path / "site.grade.json"
    save_grade(grade, path)
    img = np.ascontiguousarray(np.tile(water(1, 5)[0], (4, 5, 1))[:240, :320])
    ins = np.zeros((240, 320), np.uint16)
    look = replace(sample_look("mavic2pro", np.random.default_rng(2), 320, 240),
                   native_width=320, native_height=240)
    tile = make_noise_tile((1,), 240, 240)
    plain = apply_camera(img, ins, look, tile)
    graded = apply_camera(img, ins, replace(look, grade=str(path)), tile)
    assert graded[3]["stages"][-1] == "grade" and "grade" not in plain[3]["stages"]
    assert np.array_equal(graded[0], apply_grade(plain[0], grade))
    assert "grade" not in look.to_dict() and set(STAGES) - set(plain[3]["stages"]) >= {"grade"}
    off = apply_camera(img, ins, replace(look, grade=str(path), off=("grade",)), tile)
    assert np.array_equal(off[0], plain[0])


def test_config_names_the_grade_beside_it_and_generation_is_deterministic(
        tmp_path, sprites_dir, capsys):
    grade = SiteGrade(np.eye(3) * 1.1, np.array([-20.0, 10.0, -5.0]), fitted_width=96)
    folder = tmp_path / "site"
    folder.mkdir()
    save_grade(grade, folder / "fitted.grade.json")
    (folder / "fitted.toml").write_text('width = 96\nheight = 64\ngrade = "fitted.grade.json"\n')
    data = load_toml(folder / "fitted.toml")
    assert Path(data["grade"]) == folder / "fitted.grade.json"
    config = GeneratorConfig.from_mapping({**data, "count": 1, "clutter": 0})
    a = Generator(config, sprites_dir, progress=False).sample(0)
    b = Generator(config, sprites_dir, progress=False).sample(0)
    plain = Generator(replace(config, grade=None), sprites_dir, progress=False).sample(0)
    assert np.array_equal(a.image, b.image) and not np.array_equal(a.image, plain.image)
    assert np.array_equal(a.instances, plain.instances)  # the grade moves no pixel
    from sdcomp.cli import main

    (folder / "broken.toml").write_text('width = 96\nheight = 64\ngrade = "missing.json"\n')
    rc = run_cli(main, ["generate", "--config", str(folder / "broken.toml"), "--n", "1",
                        "--out", str(tmp_path / "out"), "--sprites", str(sprites_dir), "-q"])
    err = capsys.readouterr().err
    assert rc == 2 and "missing.json" in err and "no such file" in err, err
    assert "Traceback" not in err and not (tmp_path / "out").exists()



def test_fit_writes_a_grade_that_brings_another_cameras_footage_closer(tmp_path, sprites_dir,
                                                                        capsys):
    """``sdcomp fit`` on footage from a camera sdcomp does not model (a warm colour matrix,
    blur, WebP) fits a grade that lowers the realism classifier's accuracy at the fit,
    writes it beside the config, names it there, reports both accuracies, and ``generate
    --config`` draws with it (``--grade none`` without it); ``--preset`` fits under that
    preset's geometry."""
    from sdcomp.cli import main

    from .test_fit import RENDERS, make_footage, other_camera

    frames = tmp_path / "other"
    make_footage(frames, {"water": ["coastal", "lake"], "wind": "2-6"}, sprites_dir,
                 post=other_camera)
    out = tmp_path / "fit" / "site.toml"
    rc = run_cli(main, ["fit", str(frames), "--out", str(out), "--sprites", str(sprites_dir),
                        "--renders", str(RENDERS), "--passes", "1", "--search", "look,wind",
                        "--grade", "-q"])
    assert rc == 0, capsys.readouterr().err
    report = json.loads((out.parent / "fit_report.json").read_text())
    search = report["grade_search"]
    assert search["accuracy_graded"] < search["accuracy_fitted"] - 0.05, search
    assert search["trials"][0][0] == "the fitted scene"
    grade_file = out.parent / "site.grade.json"
    assert 'grade = "site.grade.json"' in out.read_text() and load_grade(grade_file)
    assert "graded" in (out.parent / "fit_report.md").read_text()
    config = GeneratorConfig.from_mapping({**load_toml(out), "count": 0, "clutter": 0})
    assert config.grade == str(grade_file)
    graded = Generator(config, sprites_dir, progress=False).sample(0).image
    plain = Generator(replace(config, grade=None), sprites_dir, progress=False).sample(0).image
    assert np.array_equal(graded, apply_grade(plain, load_grade(grade_file)))
    rc = run_cli(main, ["generate", "--config", str(out), "--grade", "none", "--dump-config"])
    assert rc == 0 and "grade" not in capsys.readouterr().out
    rc = run_cli(main, ["fit", str(frames), "--out", str(tmp_path / "p" / "p.toml"),
                        "--preset", "seadronessee", "--sprites", str(sprites_dir), "--renders",
                        "2", "--passes", "0", "-q"])
    assert rc == 0, capsys.readouterr().err
    text = (tmp_path / "p" / "p.toml").read_text()
    assert "--preset seadronessee's altitude and pitch are kept" in text
    assert "generate --preset seadronessee --config" in text and "\ngrade =" not in text
