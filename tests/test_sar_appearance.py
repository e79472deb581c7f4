"""Search-and-rescue objects as a drone camera records them, per labelled box, against the
statistics measured on real SeaDronesSee frames (124 frames at 1920 x 1080 of green coastal
sea, 1004 boxes: 999 swimmers and 5 boats; the frames are not in this repository: the figures
are the measurement's, :mod:`sdcomp.report.realism.objects` defines each statistic), and,
where ``../shared/reference`` is present, against the boxes marked by eye in its real frames
(``tests/data/realframes_objects.json``: 17 SeaDronesSee tracking frames of Lake Constance and
16 AFO frames).

Two real sets of people in the water disagree: the North Sea frames' swimmers are dark
(median contrast -1.88 against their water, dark share 0.23, bright share 0.06; yet skin-like
pixels in 67 % of their boxes and saturated orange or red in 40 %, as the user measured them),
Lake Constance's are bright (+1.32, 0.115, 0.165; skin in all, orange or red in 86 %:
volunteers in life jackets). The swimmers' mix now follows the crop classifier on the frames
at hand (docs/sar.md): contrast +0.15, dark share 0.115, bright share 0.075 over these 1040
images, skin-like pixels in 70 % of the boxes and orange or red in 36 %; the dark bounds of
the North Sea figures fail (expected failures below, with the measured figures).

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
                           "--n", "1040"], out, sprites_dir, workers=2)
    assert rc == 0, err
    return object_statistics(out, exclude_others=False)


def test_swimmers_keep_their_shape_and_saturation(stats):
    """Their boxes are as wide as real ones and their saturation stays near the real one
    (measured 0.84 and 0.25)."""
    s = stats["swimmer"]
    assert s["count"] >= 150
    assert 0.7 <= s["aspect"]["median"] <= 1.0, s
    assert abs(s["saturation"]["median"] - REAL_SWIMMER["saturation"]) <= 0.1, s


@pytest.mark.xfail(reason="the North Sea frames' swimmers are darker than their water on "
                          "the median; with jackets on 8 of 20 variants sdcomp's measure "
                          "+0.15 (before: -1.07), Lake Constance's real ones +1.32",
                   strict=False)
def test_swimmers_are_not_bright_bodies(stats):
    """The swimmers are no longer brighter than their water on the median (whole bodies in
    bright clothes were +0.14 std above it)."""
    s = stats["swimmer"]
    assert s["contrast"]["median"] < 0.0, s


@pytest.mark.xfail(reason="dark share 0.115 (North Sea real 0.23, Lake Constance real "
                          "0.115): the jackets and bare skin of the new mix", strict=False)
def test_swimmers_hold_as_many_dark_pixels_as_real_ones(stats):
    """Dark heads and suits, the body below the shoulders lost in green water: the share
    of box pixels 25 levels under the water's mean is at least 0.15 (real 0.23; the bright
    bodies measured 0.04, whole bodies in dark suits in clearer water 0.11)."""
    s = stats["swimmer"]
    assert s["dark_share"]["median"] >= 0.15, s


@pytest.mark.xfail(reason="median contrast +0.15 against the North Sea's -1.88 (Lake "
                          "Constance's +1.32): see the module docstring", strict=False)
def test_swimmers_are_as_dark_against_their_water_as_real_ones(stats):
    """Heads and shoulders in dark suits out of the water, the body under them lifted
    towards the surface by refraction and faded, few neighbours in a window as narrow as
    this one (the preset's counts are a 4K frame's), most of them upright and in dark suits
    as search-and-rescue footage shows them: the box's mean lies at least one standard
    deviation of its water below that water (real -1.88). Measured -1.07 over these 1040
    images (seeds 1-3: -1.06, -1.06, -1.00; with the earlier mix of poses and outfits,
    treading 12 of 20, bright jackets, tubes and swimwear on 8, -0.80 over 520 images and
    -0.60 to -0.82 at seeds 1-3: an expected failure then). In calm water (surrounding std
    under 8 levels) -1.5 to -2.5; in the sun's glitter (over 25 levels, a fifth of the boxes)
    -0.3 to -0.6."""
    s = stats["swimmer"]
    assert s["contrast"]["median"] <= -1.0, s


def test_swimmers_hold_as_many_bright_pixels_as_real_ones(stats):
    """Splash, glints, jackets and bare skin: the bright share within 0.04 of the real 0.06.
    Measured 0.075 over these 1040 images (0.030 with the darker mix before, 0.024 with
    the one before that)."""
    s = stats["swimmer"]
    assert abs(s["bright_share"]["median"] - REAL_SWIMMER["bright_share"]) <= 0.04, s


@pytest.mark.xfail(reason="the reference rests on the 5 boats of the 124 frames; measured "
                          "0.363 here, the 61 boats marked in the Lake Constance frames 0.32",
                   strict=False)
def test_boats_are_as_bright_as_real_ones(stats):
    """White hulls in the sun: the boats' bright share within 0.1 of the real one (0.48).
    Measured 0.411 here (155 boats in 1040 images; seeds 1-3: 0.426, 0.411, 0.425); over
    520 images 0.379 (74 boats), 0.383 before the swimmers' mix changed the draws. Since
    the preset draws its frames' view of the sun (before, over 520 images: 0.371, 0.452,
    0.333, 0.435): fewer views into the glitter and towards the bright sky behind it."""
    s = stats["boat"]
    assert abs(s["bright_share"]["median"] - REAL_BOAT_BRIGHT) <= 0.1, s
