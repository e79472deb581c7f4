"""Search-and-rescue objects as a drone camera records them, per labelled box, against the
statistics measured on real SeaDronesSee frames (124 frames at 1920 x 1080 of green coastal
sea, 999 swimmers and 108 boats; the frames are not in this repository: the figures are the
measurement's, :mod:`sdcomp.report.realism.objects` defines each statistic).

The dataset is ``--preset seadronessee`` at the real frames' focal length (a 416 x 416
window of a 1920 px wide mavic2pro-video frame: 22.9 degrees diagonal), as measured, with
the objects such a window sees (about one in twelve of a 4K frame's, at least one); the
surrounding water of a box is the box grown by its longer side, minus the box
(``exclude_others=False``, as the real figures were taken). SeaDronesSee's own 1920 x 1080
frames (258 in its val split) are from a Zenmuse Z30 zoom camera on a Matrice 210 over the
North Sea, without flight metadata: their focal length is not the Mavic's, so box sizes are
not compared here (their swimmers are 37 px at the median, twice the Mavic 4K frames' at the
same focal length); tests/test_sar_reference.py compares sizes with the 4K frames.
"""

from __future__ import annotations

import pytest

from sdcomp.report.realism import object_statistics

from .datasets import generate

#: per box, medians over the real frames' swimmers (sqrt(w h) >= 15 px) and boats
REAL_SWIMMER = {"contrast": -1.88, "dark_share": 0.23, "bright_share": 0.06, "aspect": 0.85,
                "saturation": 0.20}
REAL_BOAT_BRIGHT = 0.48


@pytest.fixture(scope="module")
def stats(tmp_path_factory, sprites_dir):
    out = tmp_path_factory.mktemp("look") / "sds416"
    rc, _, err = generate(["--preset", "seadronessee", "--camera", "custom", "--fov", "22.9",
                           "--sensor-px", "416,416", "--width", "416", "--height", "416",
                           "--n", "520"], out, sprites_dir, workers=2)
    assert rc == 0, err
    return object_statistics(out, exclude_others=False)


def test_swimmers_are_not_bright_bodies_and_keep_their_shape(stats):
    """What changed: swimmers are no longer brighter than their water on the median (whole
    bodies in bright clothes were +0.14 std above it), their boxes are as wide as real ones
    and their saturation stays near the real one."""
    s = stats["swimmer"]
    assert s["count"] >= 150
    assert s["contrast"]["median"] < 0.0, s
    assert 0.7 <= s["aspect"]["median"] <= 1.0, s
    assert abs(s["saturation"]["median"] - REAL_SWIMMER["saturation"]) <= 0.1, s


def test_swimmers_hold_as_many_dark_pixels_as_real_ones(stats):
    """Dark heads and suits, the body below the shoulders lost in green water: the share
    of box pixels 25 levels under the water's mean is at least 0.15 (real 0.23; the bright
    bodies measured 0.04, whole bodies in dark suits in clearer water 0.11)."""
    s = stats["swimmer"]
    assert s["dark_share"]["median"] >= 0.15, s


@pytest.mark.xfail(reason="measured here: swimmer contrast -0.80 over these 520 images "
                          "(seeds 1-3: -0.82, -0.64, -0.60; 17 % of the boxes in the sun's "
                          "glitter, water std over 25 levels, at -0.46; seen from 60-90 "
                          "degrees -0.81 to -0.99); before the preset drew its frames' view "
                          "of the sun, -1.18 at seed 0 and -0.94, -0.59, -0.69 at seeds 1-3 "
                          "(real -1.88, bound -1.0): the boxes hold 64 % water at the "
                          "median (arms spread under it), the swimmers in life jackets, "
                          "swimwear or a cap are brighter than the water",
                   strict=False)
def test_swimmers_are_as_dark_against_their_water_as_real_ones(stats):
    """Heads and shoulders in dark suits out of the water, the body under them lifted
    towards the surface by refraction and faded, few neighbours in a window as narrow as
    this one (the preset's counts are a 4K frame's): the box's mean lies at least one
    standard deviation of its water below that water (real -1.88)."""
    s = stats["swimmer"]
    assert s["contrast"]["median"] <= -1.0, s


@pytest.mark.xfail(reason="measured here: swimmer bright share 0.024 over these 520 "
                          "images (passes), 0.019, 0.028, 0.026 with seeds 1-3 (seed 1 "
                          "fails; real 0.06, bound 0.04 from it); real boxes hold sun "
                          "glints and splash the water around a swimmer does not draw yet "
                          "(sdcomp's water glints less than real footage), and one swimmer "
                          "in five wears a bright life jacket",
                   strict=False)
def test_swimmers_hold_as_many_bright_pixels_as_real_ones(stats):
    s = stats["swimmer"]
    assert abs(s["bright_share"]["median"] - REAL_SWIMMER["bright_share"]) <= 0.04, s


def test_boats_are_as_bright_as_real_ones(stats):
    """White hulls in the sun: the boats' bright share within 0.1 of the real one (0.48).
    Measured 0.383 here (73 boats; seeds 1-3: 0.439, 0.417, 0.425) since the preset draws
    its frames' view of the sun (before: 0.371, 0.452, 0.333, 0.435): fewer views into the
    glitter and towards the bright sky behind it."""
    s = stats["boat"]
    assert abs(s["bright_share"]["median"] - REAL_BOAT_BRIGHT) <= 0.1, s
