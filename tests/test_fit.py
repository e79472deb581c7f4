"""``sdcomp fit``: recovery of hidden settings from footage sdcomp made, a stand-in for footage
it did not make, the statistics, the written config and the command line.

The recovery runs are small (16 frames of 192 px, 8 rendered frames per candidate, one
search pass) so the whole module takes about two minutes on 2 cores. What they check, per
hidden setting (docs/fit.md states the same):

- the fitted config's statistics are within the noise of the hidden run's: the fit's loss to
  the footage (:func:`sdcomp.fitting.stats.loss`) is at most ``3 x`` that of the hidden
  settings rendered again with other seeds, plus 20, and below the defaults';
- the identifiable settings: the hidden water type's colour family (blue: ocean, coastal;
  green: lake, algae; brown: turbid) is among the fitted types, the hidden
  turbidity range's middle lies inside the fitted range, the fitted water colour is within 3
  units (0.036 of R or B share) of the footage's, and the wind ranges overlap.
"""

from __future__ import annotations

import json
import math
import tomllib
from pathlib import Path

import cv2
import numpy as np
import pytest

from sdcomp import GeneratorConfig
from sdcomp.errors import UserError, run_cli
from sdcomp.fitting import fit_footage
from sdcomp.fitting.config_file import config_text, write_config
from sdcomp.fitting.footage import working_size
from sdcomp.fitting.report import markdown
from sdcomp.fitting.search import CANDIDATES, Renderer, cast_start, invert_water
from sdcomp.fitting.stats import STATS, blockiness, distance, image_stats, loss, vignetting
from sdcomp.pipeline import Generator
from sdcomp.run.record import encode_image
from sdcomp.scene.water import WATER_PRESETS

SIZE = 192
FRAMES = 16
RENDERS = 8
#: hidden settings of the recovery runs (E: a non-default camera look; C: no camera at all)
HIDDEN = {
    "turbid-overcast": {"water": ["turbid"], "turbidity": "0.6-0.9", "sky": ["overcast"],
                        "wind": "2-4"},
    "ocean-windy": {"water": ["ocean"], "turbidity": "0.1-0.4", "wind": "6-10",
                    "sun_elevation": "50-80"},
    "coastal-clean": {"water": ["coastal"], "turbidity": "0.3-0.6", "look": "clean"},
    "algae-photo": {"water": ["algae"], "turbidity": "0.4-0.8", "recording": "photo",
                    "jpeg_quality": "60-70", "sky": ["clear"]},
    "lake-zenmuse": {"water": ["lake"], "turbidity": "0.2-0.5", "look": "zenmuse-x5",
                     "wind": "1-3", "sun_elevation": "20-40"},
}


def make_footage(folder: Path, settings: dict, sprites_dir: Path, seed: int = 99,
                 post=None) -> GeneratorConfig:
    """Write FRAMES water-only frames of ``settings`` as JPEG files at their drawn quality
    (or, with ``post``, ``post(rgb)`` as PNG: footage from another camera); the config."""
    config = GeneratorConfig.from_mapping({**settings, "width": SIZE, "height": SIZE,
                                           "count": 0, "clutter": 0, "seed": seed})
    gen = Generator(config, sprites_dir, progress=False)
    folder.mkdir(parents=True, exist_ok=True)
    for i in range(FRAMES):
        scene = gen.scene(i)
        image = gen.render_scene(scene).image.copy()
        if post is None:
            data = encode_image(image, "jpg", scene.jpeg_quality)
            (folder / f"f{i:03d}.jpg").write_bytes(data)
        else:
            (folder / f"f{i:03d}.png").write_bytes(encode_image(post(image), "png", 0))
    return config


def _low(param) -> float:
    return float(param.values[0])


def _high(param) -> float:
    return float(param.values[-1])


@pytest.mark.parametrize("name", list(HIDDEN))
def test_recovers_hidden_settings(name, tmp_path, sprites_dir):
    hidden = make_footage(tmp_path / name, HIDDEN[name], sprites_dir)
    r = fit_footage(tmp_path / name, sprites_dir=sprites_dir, n_render=RENDERS, passes=1)
    foot = r.footage.summary
    # the hidden settings again, other seeds: the noise of a run of this size
    again = Renderer(r.config, sprites_dir, RENDERS).measure(
        GeneratorConfig.from_mapping({"seed": 3}, base=hidden))[0]
    fitted, noise = loss(r.search.summary, foot), loss(again, foot)
    assert fitted <= 3 * noise + 20, (fitted, noise, r.config.to_dict())
    assert fitted < loss(r.search.default_summary, foot)
    c = r.config
    family = next(t for t in WATER_PRESETS.values() if hidden.water[0] in t)
    assert set(family) & set(c.water), (c.water, r.search.water_votes)
    mid = (_low(hidden.turbidity) + _high(hidden.turbidity)) / 2
    assert _low(c.turbidity) <= mid <= _high(c.turbidity), c.turbidity
    d = distance(r.search.summary, foot)
    assert d["chroma_r"] < 3 and d["chroma_b"] < 3, d
    assert _low(c.wind) <= _high(hidden.wind) and _low(hidden.wind) <= _high(c.wind), c.wind
    assert (c.width, c.height) == (SIZE, SIZE)
    assert "not fitted" in r.geometry


def other_camera(rgb: np.ndarray) -> np.ndarray:
    """A camera sdcomp does not model: a warm colour matrix with a gamma lift, a Gaussian
    blur (sigma 1.2 px) and WebP compression at quality 30 (a codec the generator lacks)."""
    m = np.array([[1.05, 0.10, -0.05], [0.02, 0.95, 0.03], [-0.05, 0.05, 0.80]], np.float32)
    x = np.clip((rgb.astype(np.float32) / 255.0) @ m.T, 0, 1) ** 0.85
    x = cv2.GaussianBlur(x * 255.0, (0, 0), 1.2)
    bgr = cv2.cvtColor(np.clip(x, 0, 255).astype(np.uint8), cv2.COLOR_RGB2BGR)
    ok, data = cv2.imencode(".webp", bgr, [cv2.IMWRITE_WEBP_QUALITY, 30])
    assert ok
    return cv2.cvtColor(cv2.imdecode(data, cv2.IMREAD_COLOR), cv2.COLOR_BGR2RGB)


def test_standin_from_another_camera_is_closer_than_defaults(tmp_path, sprites_dir):
    make_footage(tmp_path / "other", {"water": ["coastal", "lake"], "wind": "2-6"},
                 sprites_dir, post=other_camera)
    r = fit_footage(tmp_path / "other", sprites_dir=sprites_dir, n_render=RENDERS, passes=1)
    foot = r.footage.summary
    d_fit, d_dflt = distance(r.search.summary, foot), distance(r.search.default_summary, foot)
    assert loss(r.search.summary, foot) < 0.5 * loss(r.search.default_summary, foot)
    missed = [k for k in STATS if d_fit[k] > d_dflt[k]]
    assert len(missed) <= len(STATS) // 2, {k: (d_fit[k], d_dflt[k]) for k in STATS}
    text = markdown(r, "fitted.toml", None)  # the report names what was not reached
    assert all(k in text.split("Not reached")[1].split("\n")[0] for k in missed) if missed \
        else "at least as close" in text


def green_cast(rgb: np.ndarray) -> np.ndarray:
    """docs/fit.md's tinted stand-in: a green cast with lifted blacks (R x 0.55 + 10, G x
    0.75 + 35, B x 0.6 + 20), a white balance no water colour makes."""
    x = rgb.astype(np.float32) * np.float32([0.55, 0.75, 0.6]) + np.float32([10, 35, 20])
    return np.clip(x, 0, 255).astype(np.uint8)


def test_white_balance_and_exposure_fit_a_colour_cast(tmp_path, sprites_dir):
    """A cast no water explains is fitted by the camera's white balance (red and blue gains
    under 1 for a green cast) and exposure bias: the loss falls to under half what the
    search reaches without those settings, and the saturation is reached."""
    make_footage(tmp_path / "cast", {"water": ["coastal", "lake"], "wind": "2-6"},
                 sprites_dir, post=green_cast)
    without = tuple(g for g in CANDIDATES if g not in ("exposure", "wb_red", "wb_blue"))
    runs = {name: fit_footage(tmp_path / "cast", sprites_dir=sprites_dir, n_render=RENDERS,
                              passes=1, groups=groups)
            for name, groups in (("with", None), ("without", without))}
    foot = runs["with"].footage.summary
    losses = {k: loss(r.search.summary, foot) for k, r in runs.items()}
    assert losses["with"] < 0.5 * losses["without"], losses
    c = runs["with"].config
    assert c.wb_red is not None and _high(c.wb_red) < 1.0, c.to_dict()
    assert c.wb_blue is not None and _high(c.wb_blue) < 1.0, c.to_dict()
    # the green highlights started a second search from their cast; the report says so
    cast = runs["with"].search.cast
    assert cast is not None and cast["wb_red"] < 1.0 and cast["wb_blue"] < 1.0, cast
    assert runs["without"].search.cast is None  # (white balance not searched)
    assert "highlights carry a colour cast" in markdown(runs["with"], "f.toml", None)
    d = distance(runs["with"].search.summary, foot)
    d_dflt = distance(runs["with"].search.default_summary, foot)
    assert d["saturation"] < d_dflt["saturation"] and d["chroma_r"] < 3, d
    text = config_text(c, ["test"], False)
    assert "wb_red = " in text and write_config(tmp_path / "cast.toml", text) == c


def test_contrast_is_fitted_to_a_vivid_camera(tmp_path, sprites_dir):
    """Footage of a camera with a vivid profile (a steep tone curve, contrast 1.8, and
    saturation 1.4, above every look's draws) is fitted with a fixed contrast above the
    looks' usual 1.15, and the loss falls below what the look alone reaches (measured: 86.2
    against 102.3 searching the look, then the contrast; with every setting searched, 35.5
    against 72.8: docs/fit.md)."""
    make_footage(tmp_path / "vivid", {"water": ["coastal", "lake"], "wind": "2-6",
                                      "contrast": 1.8, "saturation": 1.4}, sprites_dir)
    runs = {name: fit_footage(tmp_path / "vivid", sprites_dir=sprites_dir, n_render=RENDERS,
                              passes=1, groups=groups)
            for name, groups in (("with", ("look", "contrast")), ("without", ("look",)))}
    foot = runs["with"].footage.summary
    losses = {k: loss(r.search.summary, foot) for k, r in runs.items()}
    assert losses["with"] < 0.9 * losses["without"], losses
    c = runs["with"].config
    assert c.contrast is not None and _low(c.contrast) > 1.15, c.to_dict()
    text = config_text(c, ["test"], False)
    assert "contrast = " in text and write_config(tmp_path / "vivid.toml", text) == c


def test_shot_noise_is_fitted_to_a_noisy_camera(tmp_path, sprites_dir):
    """Footage of a far noisier sensor than any look draws (a dim scene's shot noise, 0.08,
    where the looks draw at most 6e-4), under an overcast sky, is fitted with a fixed shot
    noise of at least 0.02: the frames' median noise is reached (measured: 0.577 levels
    against the footage's 0.572; the look alone 0.257) and the loss falls (14.6 against
    79.0). The sky is searched too and the footage has no glitter: the noise statistic
    counts sparkles as noise (a frame full of glitter measures 17-20 levels), so under a
    sunny sky the shot noise chosen turned on how the sparkles are drawn (a near tie of
    the losses, 35.6 for 0.02 against 35.8 for 0.06, once each sparkle drew its own
    spread)."""
    make_footage(tmp_path / "noisy", {"water": ["coastal", "lake"], "wind": "2-6",
                                      "shot_noise": 0.08, "sky": ["overcast"]}, sprites_dir)
    runs = {name: fit_footage(tmp_path / "noisy", sprites_dir=sprites_dir, n_render=RENDERS,
                              passes=1, groups=groups)
            for name, groups in (("with", ("sky", "look", "noise")),
                                 ("without", ("sky", "look")))}
    foot = runs["with"].footage.summary
    miss = {k: abs(r.search.summary["noise"][1] - foot["noise"][1]) for k, r in runs.items()}
    assert miss["with"] < 0.5 * miss["without"], miss
    losses = {k: loss(r.search.summary, foot) for k, r in runs.items()}
    assert losses["with"] < 0.8 * losses["without"], losses
    c = runs["with"].config
    assert c.shot_noise is not None and _low(c.shot_noise) >= 0.02, c.to_dict()
    text = config_text(c, ["test"], False)
    assert "shot_noise = " in text and write_config(tmp_path / "noisy.toml", text) == c


# --------------------------------------------------------------------------- the statistics

def test_statistics_respond_to_blur_noise_and_blocks():
    rng = np.random.default_rng(0)
    base = np.clip(rng.normal(100, 10, (192, 192, 3)), 0, 255).astype(np.uint8)
    sharp = image_stats(base)
    blurred = image_stats(cv2.GaussianBlur(base, (0, 0), 1.5))
    assert sharp is not None and blurred is not None
    assert blurred["sharpness"] < sharp["sharpness"]
    assert blurred["noise"] < sharp["noise"]
    yy, xx = np.mgrid[:192, :192]
    ramp = (60 + 0.4 * xx + 0.3 * yy + 8 * np.sin(xx / 5.0) * np.cos(yy / 7.0))
    smooth = np.repeat(ramp[..., None], 3, axis=2).astype(np.uint8)
    ok, data = cv2.imencode(".jpg", smooth, [cv2.IMWRITE_JPEG_QUALITY, 15])
    blocky = cv2.imdecode(data, cv2.IMREAD_COLOR).astype(np.float32).mean(axis=2)
    assert blockiness(blocky) > blockiness(smooth.astype(np.float32).mean(axis=2)) + 0.1
    vig = 150.0 * (1 - 0.4 * ((xx - 96) ** 2 + (yy - 96) ** 2) / (2 * 96 ** 2))
    assert 0.2 < vignetting(vig.astype(np.float32)) < 0.5
    assert image_stats(base, np.zeros(9, bool)) is None


def test_highlights_carry_a_camera_cast_but_not_the_waters_colour():
    """The brightest 1 % of the water's pixels are the surface's neutral reflection: green
    water leaves their colour as it is, a green camera cast (gains and lifted blacks, as
    the sim2real stand-in's) tints them, while both make the frame's mean colour green."""
    rng = np.random.default_rng(1)
    water = np.clip(rng.normal(0, 6, (192, 192, 3)) + (60, 90, 110), 0, 255)
    sparkle = rng.random((192, 192)) < 0.012  # a little over the 1 % measured
    blue = water.copy()
    blue[sparkle] = 235
    green = np.clip(rng.normal(0, 6, (192, 192, 3)) + (50, 110, 70), 0, 255)
    green[sparkle] = 235
    cast = np.clip(blue * (0.55, 0.75, 0.6) + (10, 35, 20), 0, 255)
    s_blue, s_green, s_cast = (image_stats(a.astype(np.uint8)) for a in (blue, green, cast))
    assert s_blue and s_green and s_cast
    assert s_green["chroma_b"] < s_blue["chroma_b"] - 0.04  # green water ...
    assert s_cast["chroma_b"] < s_blue["chroma_b"] - 0.04  # ... and a green cast
    assert abs(s_green["highlight_r"] - 1 / 3) < 0.005  # the sparkles stay white
    assert abs(s_green["highlight_b"] - 1 / 3) < 0.005
    assert s_cast["highlight_r"] < 1 / 3 - 0.05  # the cast tints them
    assert {"highlight_r", "highlight_b"} <= set(STATS)


def _highlights(r: float, b: float) -> dict:
    """A summary dict holding only highlight shares (p10, p50, p90 alike)."""
    return {"highlight_r": (r, r, r), "highlight_b": (b, b, b)}


def test_a_cast_in_the_highlights_starts_a_second_search_from_it():
    """The footage's highlights over the defaults' give the white balance the second search
    starts from: the stand-in's green cast (its white at R 150, G 226, B 173) gives red and
    blue gains well under 1 (linear: the encoded ratios to the power 2.2), snapped to the
    candidates; white highlights, unknown ones or white balance left out of the search
    give none."""
    base = GeneratorConfig()
    white = _highlights(1 / 3, 1 / 3)
    total = 150 + 226 + 173
    cast = cast_start(base, _highlights(150 / total, 173 / total), white, None)
    assert cast is not None
    # R/G 150/226 -> 0.41 linear, B/G 173/226 -> 0.56: the nearest candidates
    assert (_low(cast.wb_red), _low(cast.wb_blue)) == (0.4, 0.6), cast.to_dict()
    warm = cast_start(base, _highlights(0.38, 0.29), white, None)
    assert warm is not None and _low(warm.wb_red) > 1.0 > _low(warm.wb_blue)
    assert cast_start(base, _highlights(0.335, 0.33), white, None) is None  # no cast
    assert cast_start(base, _highlights(math.nan, 0.3), white, None) is None
    assert cast_start(base, _highlights(0.27, 0.31), white, ("wind", "wb_red")) is None
    both = cast_start(base, _highlights(0.27, 0.31), white, ("wb_red", "wb_blue"))
    assert both is not None


def test_water_inversion_picks_the_nearest_colour():
    fine = np.linspace(0, 1, 21)
    table = {"ocean": np.stack([0.30 + 0 * fine, 0.37 - 0.02 * fine], 1),
             "turbid": np.stack([0.33 + 0.03 * fine, 0.32 - 0.02 * fine], 1)}
    per = {"chroma_r": np.array([0.345, 0.345, 0.35, 0.30]),
           "chroma_b": np.array([0.31, 0.31, 0.307, 0.37])}
    water, (lo, hi), votes, _ = invert_water(table, per)
    assert water == ("ocean", "turbid") and votes == {"ocean": 1, "turbid": 3}
    assert lo <= 0.5 <= hi


def test_working_size_keeps_aspect_and_caps():
    assert working_size(192, 192, None) == (192, 192)
    assert working_size(3840, 2160, None) == (512, 288)
    assert working_size(3840, 2160, 416) == (416, 234)


def test_written_config_loads_and_is_commented(tmp_path):
    config = GeneratorConfig.from_mapping({"water": ["ocean"], "turbidity": "0.1-0.3",
                                           "wind": "3-7", "width": 320, "height": 240})
    text = config_text(config, ["fitted to nothing"], geometry_fitted=False)
    assert "altitude" not in text and text.count("#") >= 10
    back = write_config(tmp_path / "c.toml", text)
    assert back.water == ("ocean",) and str(back.wind) == "3-7" and back.width == 320
    assert tomllib.loads((tmp_path / "c.toml").read_text())["turbidity"] == "0.1-0.3"


# --------------------------------------------------------------------------- command line

def _cli(argv, capsys) -> tuple[int, str, str]:
    from sdcomp.cli import main

    rc = run_cli(main, ["fit", *map(str, argv)])
    out = capsys.readouterr()
    return rc, out.out, out.err


def test_cli_help_is_listed_and_clear(capsys):
    from sdcomp.cli import usage

    assert "fit" in usage()
    with pytest.raises(SystemExit) as exc:
        _cli(["--help"], capsys)
    assert exc.value.code == 0
    text = capsys.readouterr().out
    assert text.startswith("usage: sdcomp fit")
    for word in ("FRAMES", "--out", "--labels", "--altitude", "--pitch", "--size",
                 "generate --config", "docs/fit.md"):
        assert word in text, word
    from sdcomp.cli.fit import build_parser

    from .test_cli import option_entries

    missing = [e for e in option_entries(build_parser()) if "default" not in e]
    assert not missing, missing


@pytest.mark.parametrize("argv,needle", [
    (["/nonexistent/frames"], "no such file"),
    (["{empty}"], "no photos or videos"),
    (["{bad}"], "bad.jpg"),
    (["{empty}", "--search", "colour"], "--search"),
    (["{empty}", "--out", "x.json"], ".toml"),
    (["{empty}", "--altitude"], "--altitude"),
    (["{empty}", "--fov", "200"], "--fov 200"),
    (["{good}", "--labels", "{labels}"], "--labels"),
])
def test_cli_bad_input_is_one_line(argv, needle, tmp_path, capsys):
    """One line naming fit's own options (not `realism`'s --real, --real-labels)."""
    (tmp_path / "empty").mkdir()
    (tmp_path / "bad").mkdir()
    (tmp_path / "bad" / "bad.jpg").write_bytes(b"not a jpeg")
    (tmp_path / "good").mkdir()
    cv2.imwrite(str(tmp_path / "good" / "f0.png"), np.full((32, 48, 3), 90, np.uint8))
    labels = tmp_path / "labels.json"  # lists none of the frames
    labels.write_text(json.dumps({"images": [{"id": 1, "file_name": "other.jpg", "width": 48,
                                              "height": 32}], "annotations": [],
                                  "categories": [{"id": 1, "name": "boat"}]}))
    argv = [a.format(empty=tmp_path / "empty", bad=tmp_path / "bad", good=tmp_path / "good",
                     labels=labels) for a in argv]
    rc, _, err = _cli(argv, capsys)
    assert rc == 2
    assert err.count("\n") == 1 and err.startswith("error:") and needle in err, err
    assert "Traceback" not in err and "--real" not in err, err


def test_cli_writes_a_config_generate_reads(tmp_path, sprites_dir, capsys):
    frames = tmp_path / "frames"
    make_footage(frames, {"water": ["turbid"], "wind": "2-4"}, sprites_dir)
    out = tmp_path / "fit" / "fitted.toml"
    rc, _, err = _cli([frames, "--out", out, "--sprites", sprites_dir, "--renders", 4,
                       "--passes", 1, "--search", "sky,wind", "--altitude", 30, "--fov", 70,
                       "-q"], capsys)
    assert rc == 0, err
    config = GeneratorConfig.from_mapping(tomllib.loads(out.read_text()))
    assert config.width == SIZE and "turbid" in config.water
    assert str(config.altitude) == "30"
    # --fov: the footage's frames are the camera's sensor
    assert (config.camera, config.fov, config.sensor_px) == ("custom", 70.0, (SIZE, SIZE))
    from sdcomp.cli import main

    rc = run_cli(main, ["generate", "--config", str(out), "--dump-config"])
    dumped = capsys.readouterr().out
    assert rc == 0 and 'water = ["turbid"' in dumped and 'altitude = 30' in dumped, dumped
    # at another size and aspect than fitted: one line says what changes (issue 48, item 4)
    rc = run_cli(main, ["generate", "--config", str(out), "--width", "1920", "--height",
                        "1080", "--dump-config"])
    err = capsys.readouterr().err
    assert rc == 0 and f"fitted at {SIZE}x{SIZE}" in err and "aspect differs" in err, err
    assert err.count("\n") == 1 and "sdcomp fit --size 1920" in err
    rc = run_cli(main, ["generate", "--config", str(out), "--size", str(2 * SIZE),
                        "--dump-config"])
    err = capsys.readouterr().err
    assert rc == 0 and "fitted at" in err and "aspect" not in err, err
    report = (out.parent / "fit_report.md").read_text()
    assert "| luminance |" in report and "geometry from the footage" in report
    data = json.loads((out.parent / "fit_report.json").read_text())
    assert {r["statistic"] for r in data["statistics"]} >= set(STATS)
    assert (out.parent / "fit_crops.png").stat().st_size > 1000


# --------------------------------------------------------------------------- reading footage

def _plain_frames(folder: Path, n: int = 4, size: int = 192) -> list[np.ndarray]:
    """``n`` noisy blue-green frames written as PNG files f000.png...; the frames."""
    from .conftest import water_like

    folder.mkdir(parents=True, exist_ok=True)
    frames = [water_like(size, size, k) for k in range(n)]
    for k, f in enumerate(frames):
        cv2.imwrite(str(folder / f"f{k:03d}.png"), cv2.cvtColor(f, cv2.COLOR_RGB2BGR))
    return frames


def _coco(path: Path, boxes: dict[str, list], meta: dict) -> Path:
    images = [{"id": k + 1, "file_name": f"{name}.png", "width": 192, "height": 192,
               "meta": meta} for k, name in enumerate(boxes)]
    anns = [{"id": 100 * (k + 1) + j, "image_id": k + 1, "category_id": 1, "bbox": b,
             "area": b[2] * b[3], "iscrowd": 0}
            for k, name in enumerate(boxes) for j, b in enumerate(boxes[name])]
    path.write_text(json.dumps({"images": images, "annotations": anns,
                                "categories": [{"id": 1, "name": "boat"}]}))
    return path


def test_labels_mask_objects_and_give_geometry(tmp_path):
    from sdcomp.fitting.footage import read_footage

    _plain_frames(tmp_path / "f", 2)
    meta = {"height_above_takeoff(meter)": 42.0, "gimbal_pitch(degrees)": 80.0}
    labels = _coco(tmp_path / "l.json", {"f000": [[0, 0, 100, 192]], "f001": []}, meta)
    foot = read_footage(tmp_path / "f", labels)
    assert foot.frames == 2 and foot.altitude == [42.0, 42.0] and foot.pitch == [80.0, 80.0]
    assert read_footage(tmp_path / "f", labels, altitude=15.0).altitude == [15.0]
    everything = _coco(tmp_path / "all.json", {"f000": [[0, 0, 192, 192]],
                                               "f001": [[0, 0, 192, 192]]}, {})
    with pytest.raises(UserError, match="free of labelled objects"):
        read_footage(tmp_path / "f", everything)


def test_dji_xmp_gives_geometry(tmp_path):
    from sdcomp.fitting.footage import read_footage

    frame = _plain_frames(tmp_path / "png", 1)[0]
    ok, data = cv2.imencode(".jpg", cv2.cvtColor(frame, cv2.COLOR_RGB2BGR))
    xmp = (b'http://ns.adobe.com/xap/1.0/\x00<x:xmpmeta><rdf:Description '
           b'drone-dji:RelativeAltitude="+35.20" drone-dji:GimbalPitchDegree="-60.50">'
           b'</rdf:Description></x:xmpmeta>')
    app1 = b"\xff\xe1" + (len(xmp) + 2).to_bytes(2, "big") + xmp
    (tmp_path / "dji").mkdir()
    (tmp_path / "dji" / "DJI_0001.JPG").write_bytes(data[:2].tobytes() + app1 +
                                                    data[2:].tobytes())
    foot = read_footage(tmp_path / "dji")
    assert foot.altitude == [35.2] and foot.pitch == [60.5]
    assert read_footage(tmp_path / "png").altitude == []


def _video(tmp_path, name: str) -> Path:
    """A 6-frame 128 x 128 MJPG video at 10 frames/s of plain water frames."""
    path = tmp_path / name
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 10, (128, 128))
    for f in _plain_frames(tmp_path / "png", 6, 128):
        writer.write(cv2.cvtColor(f, cv2.COLOR_RGB2BGR))
    writer.release()
    return path


def test_video_frames_are_read(tmp_path):
    from sdcomp.fitting.footage import read_footage

    path = _video(tmp_path, "clip.avi")
    foot = read_footage(path, max_frames=4)
    assert foot.frames == 4 and (foot.width, foot.height) == (128, 128)


def _srt(entries: list[tuple[float, float, str]], crlf: bool = False) -> str:
    """A subtitle file of (start s, end s, text) entries, as DJI drones write them."""
    def stamp(t: float) -> str:
        ms = round(t * 1000)
        return f"{ms // 3600000:02d}:{ms // 60000 % 60:02d}:{ms // 1000 % 60:02d},{ms % 1000:03d}"
    blocks = [f"{i + 1}\n{stamp(a)} --> {stamp(b)}\n{text}\n" for i, (a, b, text) in
              enumerate(entries)]
    out = "\n".join(blocks)
    return out.replace("\n", "\r\n") if crlf else out


def test_video_srt_log_gives_geometry_per_frame(tmp_path):
    """A DJI video's SRT beside it gives each frame its height above take-off and gimbal
    pitch (newer models: ``rel_alt``, ``gb_pitch``, one entry per frame); without one the
    geometry is unknown; the absolute (GPS) altitude is never taken."""
    from sdcomp.fitting.footage import read_footage

    path = _video(tmp_path, "DJI_0042.avi")
    assert read_footage(path).altitude == []
    text = [f'<font size="28">FrameCnt: {k + 1}, DiffTime: 100ms\n2024-06-01 12:00:00.{k}\n'
            f"[iso: 100] [shutter: 1/1000.0] [latitude: 47.67] [longitude: 9.26] "
            f"[rel_alt: {30 + k}.500 abs_alt: {420 + k}.100] [gb_yaw: 12.0 gb_pitch: "
            f"-{40 + k}.0 gb_roll: 0.0] </font>" for k in range(6)]
    (tmp_path / "DJI_0042.SRT").write_text(_srt([(0.1 * k, 0.1 * (k + 1), t)
                                                 for k, t in enumerate(text)], crlf=True))
    foot = read_footage(path, max_frames=6)
    assert sorted(foot.altitude) == [30.5 + k for k in range(6)]
    assert sorted(foot.pitch) == [40.0 + k for k in range(6)]
    assert any("flight logs" in n for n in foot.notes)


def test_srt_entries_of_older_models_and_broken_lines():
    """Older DJI SRTs (one entry a second, ``H 36.2m`` without gimbal pitch) are read; an
    entry without a time span or with a broken number gives nothing, without an error."""
    from sdcomp.fitting.flightlog import ALTITUDE_KEY, PITCH_KEY, parse_srt

    old = ("F/2.8, SS 1000, ISO 100, EV 0, GPS (9.2679, 47.6721, 19), D 12.34m, H 36.20m, "
           "H.S 0.00m/s, V.S 0.00m/s")
    text = _srt([(0.0, 1.0, old), (1.0, 2.0, "[rel_alt: x.y] [gb_pitch: -1e]"),
                 (2.0, 3.0, "HOME(9.26,47.67) 2019.06.01 [altitude: 431.2]")])
    text += "\n\n7\nno time here\n[rel_alt: 99.0]\n"
    starts, ends, metas = parse_srt(text)
    assert starts.tolist() == [0.0, 1.0, 2.0] and ends.tolist() == [1.0, 2.0, 3.0]
    assert metas[0] == {ALTITUDE_KEY: 36.2} and PITCH_KEY not in metas[0]
    assert metas[1] == {} and metas[2] == {}


def test_sky_of_oblique_footage_is_kept_out_with_its_field_of_view(tmp_path, sprites_dir):
    """Frames looking 20 degrees below the horizon: with --fov (and the pitch) the rows
    above the horizon and its margin are kept out of the water statistics (the sky is
    brighter than this water: the median luminance falls), and the rendered frames of the
    search keep theirs out too, so the same scene measures the same both ways."""
    import math

    from sdcomp.fitting.footage import read_footage
    from sdcomp.fitting.search import Renderer

    hidden = make_footage(tmp_path / "low", {"water": ["coastal"], "pitch": 20, "hills": 0.0,
                                             "shore": 0.0}, sprites_dir)
    m = hidden.camera_model()
    fov = math.degrees(2 * math.atan(math.hypot(m.width, m.height) / 2 / m.fx))
    plain = read_footage(tmp_path / "low", pitch=20)
    masked = read_footage(tmp_path / "low", pitch=20, fov=fov)
    assert masked.sky_masked and not plain.sky_masked
    assert any("sky kept out of 16 frames" in n for n in masked.notes)
    lum = {k: f.summary["luminance"][1] for k, f in (("plain", plain), ("masked", masked))}
    assert lum["masked"] < lum["plain"] - 4, lum
    rendered = Renderer(hidden, sprites_dir, 8, mask_sky=True).measure(hidden)[0]
    assert abs(rendered["luminance"][1] - lum["masked"]) < 4, (rendered["luminance"], lum)
    with pytest.raises(UserError, match="--fov 200"):
        read_footage(tmp_path / "low", fov=200)


def test_photos_exif_focal_length_gives_the_field_of_view(tmp_path, sprites_dir):
    """Without --fov a photo's EXIF 35 mm equivalent focal length gives its field of view
    (24 mm: 2 atan(43.27 / 48) = 84.06 degrees diagonally), so the sky of oblique photos
    is kept out and the fitted camera takes it; photos without one leave it unknown."""
    from PIL import Image

    from sdcomp.fitting.api import base_config
    from sdcomp.fitting.flightlog import photo_fov
    from sdcomp.fitting.footage import read_footage

    make_footage(tmp_path / "png", {"water": ["coastal"], "pitch": 20, "hills": 0.0,
                                    "shore": 0.0}, sprites_dir)
    (tmp_path / "exif").mkdir()
    for src in sorted((tmp_path / "png").glob("*.jpg"))[:4]:
        with Image.open(src) as im:
            exif = Image.Exif()
            exif.get_ifd(0x8769)[0xA405] = 24  # FocalLengthIn35mmFilm
            im.save(tmp_path / "exif" / src.name, "JPEG", exif=exif, quality=95)
    one = next((tmp_path / "exif").glob("*.jpg"))
    assert abs(photo_fov(one) - 84.06) < 0.01
    assert photo_fov(next((tmp_path / "png").glob("*.jpg"))) is None
    foot = read_footage(tmp_path / "exif", pitch=20)
    assert foot.fov == 84.1 and foot.sky_masked
    assert any("from their EXIF" in n for n in foot.notes)
    assert read_footage(tmp_path / "png", pitch=20, max_frames=4).fov is None
    # fit_footage passes the footage's field of view to the base config
    base, how = base_config(foot, 0, foot.fov)
    assert (base.camera, base.fov) == ("custom", 84.1) and "EXIF" in how


def test_geometry_line_says_when_the_camera_stretches_the_footages_objects():
    """Without a field of view the fit keeps the default camera (a 3:2 photo sensor) at the
    footage's frame size: 16:9 frames draw its objects 0.84 times as tall for their width,
    which the geometry line says (naming --fov); 3:2 frames and a known field of view (the
    footage's frames are the sensor) draw them as they are."""
    from sdcomp.fitting.api import base_config
    from sdcomp.fitting.footage import Footage

    def how(w: int, h: int, fov: float | None = None) -> str:
        return base_config(Footage({}, {}, w, h), 0, fov)[1]

    wide = how(512, 288)
    assert "0.84 times as tall" in wide and "--fov" in wide, wide
    assert "times as tall" not in how(480, 320)
    assert "times as tall" not in how(512, 288, 74.4)


def test_water_line_says_why_the_config_keeps_another_water():
    """The report's Water line and the config's water never contradict each other silently
    (it read "turbid 57, algae 3" beside water = ["algae"])."""
    from sdcomp.fitting.report import water_line

    votes = {"turbid": 57, "algae": 3, "ocean": 0}
    kept = water_line(votes, ("algae",))
    assert "chose turbid" in kept and "keeps algae" in kept and "no closer" in kept
    assert "chose" not in water_line(votes, ("turbid",))
    both = {"turbid": 30, "algae": 30}
    assert "chose" not in water_line(both, ("algae", "turbid"))
    assert "chose algae, turbid" in water_line(both, ("turbid",))
