"""A ``--preset seadronessee`` dataset against SeaDronesSee's own validation annotations
(``../shared/reference/seadronessee/instances_val.json``; skipped where it is absent): class
shares, altitudes, gimbal pitches, boxes per frame and per-class box sizes as quantiles, and
a COCO file that loads with SeaDronesSee's category ids.

The dataset is rendered at 1920 x 1080 with the preset's camera (the same field of view:
every pixel size is half that of the 3840 x 2160 frames, and is doubled before comparing)
to keep the test short; the reference is its 3840 x 2160 frames, the ones with flight
metadata. How close (400 frames: with 200, the 30-60 jet skis, appliances and buoys made
quantiles that moved by up to 0.3 from one draw of the scenes to the next): altitudes and
pitches within a few percent (pitches down to the floor of 2 degrees); box sizes per class
within 1.25 times SeaDronesSee's at p10, p50 and p90 where they are (each class is placed
where SeaDronesSee's boxes lie in the frame: swimmers near the centre, boats and buoys high
in oblique frames, on the row where it shows a box size drawn from its class's, each size
drawn as often as the views that can show it require: ``size_weight``).
"""

from __future__ import annotations

import numpy as np
import pytest
from pycocotools.coco import COCO

from .datasets import generate
from .seadronessee import CLASSES, load_val, merged_coco, quantiles, stats, table

pytestmark = pytest.mark.reference


@pytest.fixture(scope="module")
def pair(tmp_path_factory, sprites_dir):
    """(the reference's statistics, the preset dataset's folder and statistics)."""
    real = stats(load_val())
    out = tmp_path_factory.mktemp("sds") / "preset"
    rc, _, err = generate(["--preset", "seadronessee", "--width", "1920", "--height", "1080",
                           "--n", "400"], out, sprites_dir,
                          workers=2)
    assert rc == 0, err
    return real, out, stats(merged_coco(out), width=None, scale=2.0)


def test_coco_file_loads_with_seadronessees_categories(pair):
    _, out, _ = pair
    real = {c["id"]: c["name"] for c in load_val()["categories"]}  # with 0: "ignored"
    coco = COCO(str(out / "annotations" / "instances_train.json"))
    assert {c["id"]: c["name"] for c in coco.loadCats(coco.getCatIds())} == real
    assert set(coco.getCatIds()) == set(real) and len(coco.getAnnIds()) > 500
    # the ignore regions are SeaDronesSee's: category 0, iscrowd
    assert all(a["iscrowd"] == (a["category_id"] == 0) for a in coco.dataset["annotations"])


def test_class_shares_and_boxes_per_frame(pair):
    real, _, synth = pair
    every = stats(load_val(), width=None)  # the preset's proportions: the whole val file's
    shares = [np.array([len(s["size"][c]) for c in CLASSES], float) for s in (every, synth)]
    share_r, share_s = (v / v.sum() for v in shares)
    assert np.abs(share_s - share_r).max() < 0.06, (share_r, share_s)
    # fewer than drawn: objects that find no water in 8 tries, or show under 4 pixels
    assert 0.8 < synth["count"].mean() / real["count"].mean() < 1.1, table(real, synth)


def ks_distance(a: np.ndarray, b: np.ndarray) -> float:
    """The Kolmogorov-Smirnov distance of two samples: the largest gap of their CDFs (for
    these lumpy distributions, steadier than quantiles that sit on a step)."""
    x = np.union1d(a, b)
    return float(np.abs(np.searchsorted(np.sort(a), x, "right") / len(a)
                        - np.searchsorted(np.sort(b), x, "right") / len(b)).max())


def test_altitudes_and_pitches(pair):
    real, _, synth = pair
    # the preset holds whole metres and degrees, and frames under the pitch floor (2) at it;
    # 200 draws from the reference itself stay under a KS distance of 0.115 99 times in 100
    altitude, pitch = np.round(real["altitude"]), np.maximum(np.round(real["pitch"]), 2)
    assert ks_distance(synth["altitude"], altitude) < 0.12, table(real, synth)
    assert synth["pitch"].min() == 2  # 5 of its 100 pairs are at 0-2 degrees
    assert ks_distance(synth["pitch"], pitch) < 0.15, table(real, synth)
    pairs = [np.corrcoef(s["altitude"], s["pitch"])[0, 1] for s in (real, synth)]
    assert abs(pairs[1] - pairs[0]) < 0.2, pairs  # drawn as pairs


def _size_ratios(pair) -> tuple[dict, str]:
    """Per class: the preset's box-size quantiles (0.1 ... 0.9) over SeaDronesSee's."""
    real, _, synth = pair
    return ({c: quantiles(synth["size"][c]) / quantiles(real["size"][c]) for c in CLASSES},
            table(real, synth))


@pytest.mark.parametrize("cls", CLASSES)
def test_box_sizes_per_class(pair, cls):
    """Every class's boxes follow SeaDronesSee's within 1.25 times at p10, p50 and p90.
    Measured here (seed 0, 400 frames): swimmer 0.88/1.07/1.09, boat 1.00/1.02/0.98, jetski
    1.20/0.97/0.99 (71 boxes), life-saving appliances 0.82/0.82/1.04 (64), buoy
    0.88/1.01/0.92 (109). These are samples whose quantiles move where the real sizes step
    (jet skis from 38 to 52 px between p10 and p15, buoys from 24 to 48 px at p57), while
    the sizes placed over 6000 scenes are within 1.18 of SeaDronesSee's
    (tools/fit_size_weights.py). The appliances' boxes come out a pixel narrower each way
    than the size they are placed for (0.92 of it at these 8-15 px)."""
    ratio, why = _size_ratios(pair)
    r = ratio[cls][[0, 2, 4]]
    assert np.all((r > 1 / 1.25) & (r < 1.25)), (cls, why)
