"""Hostile and extreme input, property-based (hypothesis): any config either makes a valid
dataset whose masks, boxes and areas agree, or is refused with a one-line
:class:`~sdcomp.errors.UserError`; never a traceback.

- config values: every field given numbers in and out of range, ranges, lists, text,
  booleans, nested tables, NaN, huge numbers; unknown keys; TOML files of random bytes;
- whole runs over the config space with the extremes pinned as examples: an object that
  overflows the frame (1 m altitude), sub-pixel objects (1000 m), pitch at the 2 degree
  floor (the horizon just above the frame's centre), 1 x 1 output, zero objects, hundreds
  of overlapping objects;
- the files users hand over (tests/user_inputs.py): photos of every kind damaged every way,
  COCO files with any field changed, YOLO lines of any text, read as ``realism``, ``fit``,
  ``bench sim2real`` and ``--backgrounds`` read them and through those whole commands: they
  work or stop with one line naming the file, nothing written.

The CI runs a modest number of examples; ``pytest -m slow tests/test_fuzz.py`` runs the long
campaign (and an 8000 x 8000 frame) and prints its figures.
"""

from __future__ import annotations

import contextlib
import string
import tempfile
from dataclasses import fields
from pathlib import Path

import cv2
import numpy as np
import pytest
from hypothesis import HealthCheck, event, example, given, settings
from hypothesis import strategies as st
from hypothesis.errors import InvalidArgument

from sdcomp.errors import UserError
from sdcomp.io.layout import IGNORE_SUFFIX
from sdcomp.run import RunOptions, run
from sdcomp.scene.config import GeneratorConfig, load_toml
from sdcomp.scene.settings import setting_of

from .datasets import check_intact
from .user_inputs import (
    check_command,
    check_user_files,
    coco_edits,
    command,
    generated,
    photo_files,
    yolo_lines,
)

__all__ = ["command", "generated"]  # fixtures

pytestmark = pytest.mark.filterwarnings("ignore:__array__ implementation:DeprecationWarning")

FIELDS = [f.name for f in fields(GeneratorConfig)]
#: name: (lo, hi) of every field with numeric bounds (params, floats, ints)
BOUNDS = {f.name: (setting_of(f).lo, setting_of(f).hi) for f in fields(GeneratorConfig)
          if setting_of(f).kind in ("param", "float", "int")}
CI = settings(max_examples=60, deadline=None, derandomize=True,
              suppress_health_check=[HealthCheck.too_slow])
CI_RUNS = settings(max_examples=8, deadline=None, derandomize=True,
                   suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
SLOW = settings(max_examples=1500, deadline=None,
                suppress_health_check=[HealthCheck.too_slow])
SLOW_RUNS = settings(max_examples=120, deadline=None,
                     suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])

# --------------------------------------------------------------------------- values

numbers = st.one_of(
    st.integers(-10**6, 10**6), st.integers(), st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from([0, 1, -1, 0.5, 1e-9, 1e308, 2**63, 2**64, -2**63, 10**30]))
texts = st.one_of(
    st.text(max_size=12),
    st.text(alphabet="0123456789.-,:eE+ xnaif", max_size=12),
    st.builds(lambda a, b: f"{a}-{b}", numbers, numbers),
    st.builds(lambda xs: ",".join(map(str, xs)), st.lists(numbers, max_size=4)),
    st.sampled_from(["", " ", "nan", "inf", "-inf", "1e999", "10-", "-", ",", "1,,2",
                     "brown", "blue", "green", "255,0,0", "300,0,0", "jpg", "png", "gif",
                     "custom", "mavic2pro", "bluerov2", "../../etc/passwd", "a\nb", "\0"]))
scalars = st.one_of(numbers, texts, st.booleans(), st.none(), st.dates(), st.datetimes())
values = st.recursive(scalars, lambda inner: st.one_of(
    st.lists(inner, max_size=4), st.dictionaries(st.text(max_size=6), inner, max_size=3)),
    max_leaves=8)


def field_value(name: str):
    """Values for ``name``: mostly near its valid range, some anything."""
    special = {
        "objects": st.one_of(
            st.sampled_from(["bluerov2", "bluerov2-heavy", "no_such_mesh", "x.obj", ""]),
            st.lists(st.one_of(
                st.sampled_from(["bluerov2", "bluerov2-heavy", ""]),
                st.fixed_dictionaries({"mesh": st.sampled_from(["bluerov2", "nope", 3])},
                                      optional={"category": texts, "colour": texts})),
                max_size=3)),
        "water": st.one_of(texts, st.lists(texts, max_size=3),
                           st.lists(st.lists(numbers, min_size=3, max_size=3), max_size=2)),
        "clutter_kinds": st.one_of(texts, st.lists(st.sampled_from(
            ["buoy", "log", "boat", "foam", "rock", ""]), max_size=5)),
        "camera": st.sampled_from(["mavic2pro", "phantom4pro", "custom", "nope", ""]),
        "image_format": st.sampled_from(["jpg", "png", "gif", "JPG", ""]),
        "sensor_px": st.one_of(texts, st.lists(numbers, max_size=3)),
    }
    if name in special:
        return st.one_of(special[name], values)
    if name in BOUNDS:
        lo, hi = BOUNDS[name]
        near = st.floats(lo - abs(hi - lo) * 0.2 - 1, hi + abs(hi - lo) * 0.2 + 1)
        return st.one_of(near, near.map(round), st.builds(lambda a, b: f"{a}-{b}", near, near),
                         st.lists(near, max_size=3), values)
    return values


mappings = st.dictionaries(
    st.one_of(st.sampled_from(FIELDS), st.sampled_from([f.replace("_", "-") for f in FIELDS]),
              st.text(string.ascii_lowercase + "_-", min_size=1, max_size=10)),
    st.none(), max_size=6).flatmap(lambda keys: st.fixed_dictionaries(
        {k: field_value(k.replace("-", "_")) for k in keys}))


def _one_line(e: UserError) -> None:
    msg = str(e)
    assert msg and "\n" not in msg and "Traceback" not in msg, msg


def _named(e: UserError, mapping: dict) -> None:
    """The message names one of the given keys (as a flag, a key, or the file's field)."""
    msg = str(e)
    names = set()
    for k in mapping:
        n = str(k).replace("-", "_")
        names |= {str(k), n, "--" + n.replace("_", "-")}
        if n == "objects":  # its setting errors name the flag's setting, "object"
            names |= {"--object", "--category", "object", "category"}
    names |= {"--camera", "--fov", "--sensor-px"} if set(mapping) & {
        "camera", "fov", "sensor_px", "sensor-px", "width", "height"} else set()
    assert any(n in msg for n in names), (msg, sorted(mapping))


# --------------------------------------------------------------------------- config only

def check_mapping(mapping: dict) -> GeneratorConfig | None:
    try:
        config = GeneratorConfig.from_mapping(mapping, None, "--config test.toml")
    except UserError as e:
        _one_line(e)
        _named(e, mapping)
        return None
    # a valid config survives its own round trip (dataset.json and --resume rely on it)
    again = GeneratorConfig.from_mapping(config.to_dict())
    assert again == config
    return config


@CI
@given(mappings)
@example({"altitude": 10**400})
@example({"fov": 10**400})
@example({"n": 1e300})
@example({"seed": -1})
@example({"width": 2.5})
@example({"count": "1e999"})
@example({"objects": [{"mesh": "bluerov2", "colour": "red"}]})
@example({"water": [[1e300, 0, 0]]})
@example({"sensor_px": [1e300, 2]})
@example({"bogus": 1})
def test_any_config_mapping_is_valid_or_a_one_line_error(mapping):
    check_mapping(mapping)


@pytest.mark.slow
@SLOW
@given(mappings)
def test_config_mapping_campaign(mapping):
    check_mapping(mapping)


@CI
@given(st.one_of(st.binary(max_size=200),
                 st.text(max_size=200).map(str.encode),
                 st.builds(lambda k, v: f"{k} = {v}\n".encode(),
                           st.sampled_from(FIELDS + ["bogus"]),
                           st.sampled_from(["1", "-1", "1e999", "nan", "inf", '"x"', "[1,", "[]",
                                            "{}", "1979-05-27", "true", '"10-5"', "[[1]]"]))))
def test_config_file_of_random_bytes(data):
    with tempfile.TemporaryDirectory() as d:
        path = Path(d) / "c.toml"
        path.write_bytes(data)
        try:
            mapping = load_toml(path)
        except UserError as e:
            _one_line(e)
            assert str(path) in str(e)
            return
        try:
            GeneratorConfig.from_mapping(mapping, None, f"--config {path}")
        except UserError as e:
            _one_line(e)


# --------------------------------------------------------------------------- whole runs

def _run_strategy(max_side: int):
    """Configs of a run: small n, extremes of geometry, counts and effects."""
    side = st.one_of(st.integers(1, 8), st.integers(9, max_side))
    param = lambda name: st.one_of(  # noqa: E731
        st.floats(*BOUNDS[name]),
        st.sampled_from(BOUNDS[name]),
        st.builds(lambda a, b: f"{min(a, b)}-{max(a, b)}", st.floats(*BOUNDS[name]),
                  st.floats(*BOUNDS[name])))
    return st.fixed_dictionaries({
        "n": st.integers(1, 3), "seed": st.integers(0, 2**63 - 1), "width": side,
        "height": side,
        "altitude": param("altitude"), "pitch": param("pitch"), "heading": param("heading"),
        "count": st.one_of(st.integers(0, 3), st.integers(0, 40)),
        "clutter": st.one_of(st.just(0.0), st.floats(0, 8)),
    }, optional={
        "val_fraction": st.floats(0, 1), "image_format": st.sampled_from(["jpg", "png"]),
        "jpeg_quality": st.integers(1, 100), "min_visible_px": st.integers(1, 50),
        "amodal": st.booleans(), "camera": st.sampled_from(["mavic2pro", "phantom4pro"]),
        "fov": st.floats(1, 170),
        "turbidity": param("turbidity"), "wind": param("wind"),
        "floor_depth": param("floor_depth"), "whitecaps": st.floats(0, 5),
        "sun_elevation": param("sun_elevation"), "cloud_cover": param("cloud_cover"),
        "sky": st.lists(st.sampled_from(["clear", "broken", "overcast"]), min_size=1,
                        max_size=3),
        "shadows": st.booleans(), "draft": param("draft"), "tilt": st.floats(0, 30),
        "shallow": st.floats(0, 1), "shore": st.floats(0, 1), "hills": st.floats(0, 1),
        "look": st.sampled_from(["auto", "clean", "mavic2pro", "phantom4pro", "zenmuse-x5"]),
        "recording": st.sampled_from(["video", "photo"]), "motion_blur": st.floats(0, 1),
        "defocus_blur": st.floats(0, 1), "min_in_frame": st.floats(0, 1),
        "sensor_px": st.tuples(st.integers(1, 9000), st.integers(1, 9000)),
        "water": st.one_of(st.sampled_from(["brown", "0,0,0", "255,255,255", "ocean"]),
                           st.lists(st.sampled_from(["brown", "blue", "green", "10,200,30",
                                                     "lake", "algae"]),
                                    min_size=1, max_size=3)),
        "clutter_kinds": st.lists(st.sampled_from(["buoy", "log", "boat", "foam"]),
                                  min_size=1, max_size=4),
        "objects": st.sampled_from([["bluerov2"], [{"mesh": "bluerov2", "category": "a"},
                                                   {"mesh": "bluerov2", "category": "b"}]]),
        "backgrounds": st.just(BG),
    })


BG = "<photos>"  # replaced by a folder of background photos


@pytest.fixture(scope="module")
def photos(tmp_path_factory) -> Path:
    d = tmp_path_factory.mktemp("photos")
    rng = np.random.default_rng(0)
    for k, shape in enumerate([(90, 160, 3), (300, 200, 3), (7, 9, 3)]):
        cv2.imwrite(str(d / f"water{k}.png"), rng.integers(0, 255, shape, dtype=np.uint8))
    return d


def _event(text: str) -> None:
    """Count ``text`` in hypothesis's statistics (outside a @given test: nothing)."""
    with contextlib.suppress(InvalidArgument):
        event(text)


def check_run(mapping: dict, sprites: Path, photos: Path | None = None) -> None:
    if mapping.get("backgrounds") == BG:
        mapping = {**mapping, "backgrounds": str(photos)}
    try:
        config = GeneratorConfig.from_mapping(mapping, None, "config")
    except UserError as e:
        _one_line(e)
        _event("refused by the config")
        return
    with tempfile.TemporaryDirectory() as d:
        out = Path(d) / "out"
        try:
            counts = run(config, RunOptions(out, workers=1, progress=False, sprites_dir=sprites))
        except UserError as e:
            _one_line(e)
            _event("refused by the run")
            return
        _event("valid dataset")
        assert counts["images"] == config.n
        assert check_intact(out) == config.n  # masks, boxes and areas agree
        for p in (out / "images").glob("*/*"):
            img = cv2.imread(str(p), cv2.IMREAD_UNCHANGED)
            assert img.shape == (config.height, config.width, 3)
        assert counts["objects_dropped"] >= 0 and counts["annotations"] >= 0
        mask_ids = ignore_masks = 0
        for p in (out / "masks").glob("*/*"):
            m = cv2.imread(str(p), cv2.IMREAD_UNCHANGED)
            if p.name.endswith(IGNORE_SUFFIX):  # 255 on the ignore regions, 0 elsewhere
                # written only where there is one; it may cover the whole frame (a 1 x 1
                # frame at 1 m over an object too small to label, found by the campaign)
                values = set(np.unique(m).tolist())
                assert m.dtype == np.uint8 and values <= {0, 255} and 255 in values, values
                ignore_masks += 1
            else:
                mask_ids += len(np.unique(m[m > 0]))
        assert mask_ids == counts["annotations"]
        assert (ignore_masks > 0) == (counts["objects_ignored"] > 0)


EXTREMES = [
    # the object overflows the frame: 1 m above a 1.5 m long vehicle, looking straight down
    {"n": 2, "seed": 1, "width": 64, "height": 48, "altitude": 1, "pitch": 90, "heading": 0,
     "count": 3, "clutter": 0.0},
    # sub-pixel: 1000 m up, 16 px frame
    {"n": 2, "seed": 2, "width": 16, "height": 16, "altitude": 1000, "pitch": 90,
     "heading": 0, "count": 3, "clutter": 2.0},
    # pitch at the horizon limit, high and low
    {"n": 2, "seed": 3, "width": 80, "height": 45, "altitude": 1000, "pitch": 2,
     "heading": "0-360", "count": 3, "clutter": 3.0},
    {"n": 2, "seed": 4, "width": 64, "height": 64, "altitude": 1, "pitch": 2, "heading": 90,
     "count": 3, "clutter": 0.0},
    # 1 x 1 output
    {"n": 3, "seed": 5, "width": 1, "height": 1, "altitude": "1-1000", "pitch": "2-90",
     "heading": 0, "count": 3, "clutter": 5.0},
    # zero objects
    {"n": 2, "seed": 6, "width": 32, "height": 32, "altitude": 10, "pitch": 60,
     "heading": 0, "count": 0, "clutter": 0.0},
    # many objects overlapping
    {"n": 1, "seed": 7, "width": 64, "height": 64, "altitude": 3, "pitch": 90,
     "heading": 0, "count": 150, "clutter": 8.0, "amodal": True},
    # a 9 x 1 frame cut from a 7 x 9 photo (found by the campaign: an empty crop crashed)
    {"n": 1, "seed": 1406, "width": 9, "height": 1, "altitude": 1.0, "pitch": 15.0,
     "heading": 0.0, "count": 0, "clutter": 0.0, "backgrounds": BG, "sensor_px": (1, 1)},
    # a 5 x 125 frame whose crop spans a photo's height (found by the campaign: rounding)
    {"n": 1, "seed": 0, "width": 5, "height": 125, "altitude": 1.0, "pitch": 2.0,
     "heading": 0.0, "count": 0, "clutter": 0.0, "val_fraction": 0.0, "backgrounds": BG},
    # a 1 x 1 frame that is wholly an ignore region (found by the campaign)
    {"n": 1, "seed": 0, "width": 1, "height": 1, "altitude": 1.0, "pitch": 77.0, "count": 1,
     "draft": -1.0},
]


@pytest.mark.parametrize("mapping", EXTREMES, ids=["overflow", "subpixel", "horizon-high",
                                                   "horizon-low", "1x1", "zero", "crowd",
                                                   "thin-photo", "tall-crop", "1x1-ignored"])
def test_extreme_runs(mapping, sprites_dir, photos):
    check_run(mapping, sprites_dir, photos)


@CI_RUNS
@given(mapping=_run_strategy(96))
def test_random_runs_make_valid_datasets(mapping, sprites_dir, photos):
    check_run(mapping, sprites_dir, photos)


@pytest.mark.slow
@SLOW_RUNS
@given(mapping=_run_strategy(640))
def test_random_runs_campaign(mapping, sprites_dir, photos):
    check_run(mapping, sprites_dir, photos)


@pytest.mark.slow
def test_8000_square_frame(sprites_dir):
    check_run({"n": 1, "seed": 8, "width": 8000, "height": 8000, "altitude": "5-50",
               "pitch": 90, "heading": 0, "count": 20, "clutter": 5.0}, sprites_dir)



# --------------------------------------------------------------------------- user files
# photos of any kind damaged any way, COCO files with any field changed, YOLO lines of any
# text, read as every command reads them and through whole commands (tests/user_inputs.py)

QUIET = list(HealthCheck)
INPUTS = settings(max_examples=40, deadline=None, derandomize=True, suppress_health_check=QUIET)
INPUTS_SLOW = settings(max_examples=500, deadline=None, suppress_health_check=QUIET)
COMMANDS = settings(max_examples=6, deadline=None, derandomize=True, suppress_health_check=QUIET)
COMMANDS_SLOW = settings(max_examples=20, deadline=None, suppress_health_check=QUIET)


@INPUTS
@given(file=photo_files(), edit=coco_edits(), lines=st.lists(yolo_lines(), max_size=3))
def test_user_files_work_or_are_refused_naming_them(file, edit, lines):
    check_user_files(file, edit, lines)


@pytest.mark.slow
@INPUTS_SLOW
@given(file=photo_files(), edit=coco_edits(), lines=st.lists(yolo_lines(), max_size=3))
def test_user_files_campaign(file, edit, lines):
    check_user_files(file, edit, lines)


@COMMANDS
@given(cmd=st.sampled_from(["realism", "backgrounds"]), file=photo_files(), edit=coco_edits())
def test_commands_on_user_files(command, cmd, file, edit):
    check_command(command, cmd, file, edit)


@pytest.mark.slow
@COMMANDS_SLOW
@given(cmd=st.sampled_from(["realism", "backgrounds", "fit", "sim2real"]), file=photo_files(),
       edit=coco_edits())
def test_commands_on_user_files_campaign(command, cmd, file, edit):
    check_command(command, cmd, file, edit)
