"""Named presets of the generator: field values applied over the defaults (``--preset``).

- ``paper-alt10`` ... ``paper-alt50``, ``paper-brown``, ``paper-blue``, ``paper-green``:
  SeaDroneSim's datasets, one BlueROV2 per 416 x 416 image.
- ``seadronessee``: SeaDronesSee's five classes (:mod:`sdcomp.assets.sar`) with its category
  ids and names, class proportions, altitudes and gimbal pitches (as pairs), objects per
  frame (fewer in a narrower view) and frame size, over open water (see
  :data:`SEADRONESSEE`).
"""

from __future__ import annotations

import math
from typing import Any

from ..errors import UserError
from .camera import PITCH_RANGE


def _paper(**kw: Any) -> dict:
    # the paper's datasets: one BlueROV2 per image, 416 x 416
    return {"objects": [{"mesh": "bluerov2", "category": "bluerov2"}], "count": 1,
            "width": 416, "height": 416, **kw}


# SeaDronesSee object detection v2, validation split (1547 frames, 9630 boxes): annotations
# per class; the (height above take-off m, gimbal pitch degrees below the horizon) of 100 of
# its 1030 frames with flight metadata (all 3840 x 2160), every 10.3th in order of altitude
# then pitch: the pairs keep the joint distribution (higher flights look more steeply
# down, correlation 0.38), which sets how far away the objects are; drawn paired
# (pair_pitch). Its one pitch under sdcomp's floor of 2 degrees (a level view) is drawn at 2;
# the flat views (12 % of the frames at 0-14 degrees) are where its smallest boats and buoys
# are, far off. And the boxes per frame, as 40 quantiles
# (at (i + 0.5) / 40). A list is drawn uniformly, so the lists reproduce the distributions.
SDS_CLASSES = (("swimmer", 6206), ("boat", 2214), ("jetski", 320),
               ("life_saving_appliances", 330), ("buoy", 560))
SDS_ALTITUDE = (6, 9, 9, 9, 9, 9, 10, 10, 10, 10, 10, 10, 15, 17, 17, 17, 17, 17, 17, 17, 18,
                18, 18, 19, 20, 25, 28, 28, 29, 30, 30, 30, 30, 30, 31, 31, 32, 32, 32, 32, 32,
                32, 32, 34, 34, 36, 36, 36, 36, 36, 36, 37, 37, 37, 37, 37, 37, 37, 37, 37, 38,
                38, 38, 38, 38, 40, 41, 43, 44, 48, 48, 48, 48, 48, 48, 48, 48, 48, 50, 50, 52,
                52, 52, 52, 52, 52, 56, 60, 60, 60, 60, 61, 61, 96, 96, 96, 96, 96, 96, 124)
SDS_PITCH = (75, 45, 45, 52, 66, 59, 15, 14, 11, 18, 11, 16, 34, 34, 2, 2, 2, 2, 34, 28, 28, 28,
             34, 34, 34, 55, 55, 61, 52, 55, 83, 37, 56, 37, 37, 37, 27, 27, 61, 27, 27, 27, 55,
             55, 55, 25, 25, 25, 25, 25, 46, 36, 35, 35, 36, 36, 36, 35, 35, 36, 35, 39, 38, 38,
             58, 34, 0, 78, 90, 36, 36, 36, 36, 36, 36, 36, 36, 36, 29, 29, 40, 40, 44, 46, 40,
             46, 90, 8, 8, 8, 8, 40, 36, 71, 71, 71, 71, 71, 71, 77)
# The same 100 frames' view of the sun (tools/sds_sun_geometry.py: the sun's position from
# each frame's UTC time, latitude and longitude): the camera's heading relative to the sun
# (sdcomp's azimuths, the sun at 0; drawn paired, so a frame's pitch keeps its heading: 7 %
# of the 1030 frames (9 of these 100) look within 30 degrees of the sun, where a uniform
# heading has 17 %, and so into its glitter) and the sun's elevation (midday in August at
# 47-54 degrees north: 43-51 degrees, where sdcomp's default draws 25-80).
SDS_HEADING = (313, 60, 299, 302, 311, 310, 163, 159, 124, 206, 118, 219, 341, 342, 298, 298, 298,
               298, 341, 87, 87, 87, 341, 341, 341, 167, 167, 346, 304, 151, 358, 304, 304, 325,
               324, 327, 195, 231, 346, 206, 231, 185, 118, 166, 97, 247, 247, 248, 247, 231, 226,
               102, 163, 165, 193, 134, 156, 178, 178, 186, 202, 124, 124, 124, 166, 122, 235, 241,
               216, 98, 98, 98, 98, 98, 98, 98, 98, 98, 268, 266, 33, 33, 38, 40, 33, 44, 217, 301,
               301, 291, 291, 33, 33, 47, 47, 209, 209, 176, 209, 268)
SDS_SUN_ELEVATION = (48, 51, 48, 48, 48, 48, 51, 51, 51, 51, 51, 51, 49, 49, 46, 46, 46, 46, 49,
                     49, 49, 49, 49, 49, 49, 48, 48, 49, 45, 48, 45, 45, 45, 45, 45, 45, 44, 44,
                     49, 44, 44, 44, 48, 48, 48, 45, 45, 45, 45, 45, 45, 48, 49, 49, 48, 48, 48,
                     49, 49, 48, 49, 48, 48, 48, 48, 49, 49, 49, 49, 43, 43, 43, 43, 43, 43, 43,
                     43, 43, 51, 51, 43, 43, 43, 43, 43, 43, 49, 44, 44, 44, 44, 50, 50, 49, 49,
                     49, 49, 49, 49, 50)
SDS_COUNT = (1, 1, 1, 1, 2, 2, 2, 3, 3, 3, 4, 4, 4, 5, 5, 5, 5, 5, 6, 7, 7, 7, 7, 7, 7, 7, 8, 9,
             9, 9, 9, 10, 10, 11, 11, 12, 13, 13, 13, 14)
# the DJI Mavic 2 Pro's 4K video (most of SeaDronesSee's metadata frames): 28 mm equivalent
# lens, full sensor width in 16:9, i.e. 65.5 degrees across, 72.8 diagonally (fx = 2987 px)
SDS_FOV = round(2 * math.degrees(math.atan(math.hypot(18.0, 18.0 * 9 / 16) / 28.0)), 1)
# the view its counts are for: the 4K frame's area in squared focal lengths, (3840 / fx)
# (2160 / fy) (a 416 px window at the same focal length holds a twelfth of the objects)
_SDS_F = math.hypot(3840, 2160) / 2 / math.tan(math.radians(SDS_FOV / 2))
SDS_VIEW = round(3840 / _SDS_F * 2160 / _SDS_F, 4)

# Where in the frame SeaDronesSee's boxes lie, per class (its 3840 x 2160 metadata frames):
# the uniform ranges whose 10th and 90th percentiles are the boxes' centres'. The operator
# frames the swimmers and appliances (near the centre and below it); boats, jet skis and
# buoys are mostly farther, high in oblique frames. (u0, v0, u1, v1), fractions of the frame.
SDS_FRAMES = {"swimmer": (0.38, 0.27, 0.80, 0.86), "boat": (0.15, 0.04, 0.85, 0.64),
              "jetski": (0.05, 0.11, 0.85, 0.57),
              "life_saving_appliances": (0.31, 0.43, 0.79, 0.82),
              "buoy": (0.15, 0.0, 0.83, 0.71)}

#: per class, the box sizes ``sqrt(w h)`` of SeaDronesSee's val boxes in its 3840 x 2160
#: frames over the focal length (2988 px): quantiles at 2, 5, 10, 15, ..., 95 and 98 % (the
#: ends for 0 and 100 %: the extremes left out), measured from its annotations. Buoys come
#: in two sizes, 59 % of the boxes under 0.008 and the rest over 0.016: theirs at 2, 2.5,
#: 5, 7.5, ..., 97.5 and 98 %, so that few are drawn between
SDS_SIZES = {
    "swimmer": (0.0053, 0.0067, 0.0078, 0.0086, 0.0092, 0.0098, 0.0103, 0.0108, 0.0113,
                0.0118, 0.0124, 0.0132, 0.0141, 0.015, 0.016, 0.0171, 0.0184, 0.0205,
                0.0256, 0.0333, 0.0688),
    "boat": (0.0091, 0.0098, 0.0116, 0.013, 0.0165, 0.0242, 0.0328, 0.035, 0.0365, 0.0377,
             0.0393, 0.0401, 0.041, 0.0422, 0.046, 0.0494, 0.0537, 0.058, 0.0639, 0.0832,
             0.1063),
    "jetski": (0.0101, 0.0114, 0.0127, 0.0174, 0.0181, 0.0187, 0.0199, 0.0216, 0.0254,
               0.0261, 0.0276, 0.029, 0.0297, 0.0313, 0.0345, 0.0361, 0.04, 0.0442, 0.0579,
               0.0675, 0.0724),
    "life_saving_appliances": (0.0059, 0.0063, 0.0067, 0.0072, 0.0079, 0.0082, 0.0085,
                               0.0087, 0.0089, 0.0091, 0.0093, 0.0096, 0.0099, 0.01, 0.0103,
                               0.0107, 0.0109, 0.0115, 0.0119, 0.0124, 0.0133),
    "buoy": (0.0043, 0.0043, 0.0046, 0.0048, 0.0053, 0.0055, 0.0056, 0.0057, 0.0059, 0.0059,
             0.006, 0.0061, 0.0061, 0.0061, 0.0062, 0.0062, 0.0063, 0.0063, 0.0064, 0.0065,
             0.0066, 0.0068, 0.0074, 0.008, 0.0161, 0.0168, 0.0186, 0.0189, 0.02, 0.0235,
             0.0237, 0.024, 0.0252, 0.026, 0.0278, 0.0296, 0.0301, 0.0309, 0.0331, 0.0383,
             0.0391),
}

#: per class, how often each interval between neighbouring :data:`SDS_SIZES` is drawn
#: (the objects' ``size_weight``), one weight per :data:`SDS_WEIGHT_GROUP` neighbouring
#: intervals (the fit's resolution): a size that few of the preset's views can show (a
#: small boat needs a high or flat view) is drawn again in the others, so without them the
#: sizes shown lean to those that most views can (placed at 1.17 of SeaDronesSee's at p10
#: for boats, 1.39 for jet skis, 2.5 at p50 for buoys); fitted by
#: ``tools/fit_size_weights.py`` (6 rounds of 6000 scenes: placed at 0.97-1.18 of
#: SeaDronesSee's at p10 ... p90, another seed; fitted again when people and biminis came
#: aboard the boats, whose larger footprints left small jet skis less room: p10 1.21).
#: Swimmers and life-saving appliances are drawn evenly: their boxes come out at 1.05 and
#: 0.92 of the size placed for (the mask keeps a swimmer's arms where they show under the
#: water; an appliance's box is a pixel narrower each way at 1080p's 8-15 px), which the
#: lean makes up for (boxes at 0.8-1.05 of SeaDronesSee's); with fitted weights swimmers
#: came out at 1.14-1.28 at p90
SDS_WEIGHT_GROUP = 2
SDS_SIZE_WEIGHTS = {
    "boat": (2.05, 1.68, 1.1, 0.96, 0.9, 0.85, 0.78, 0.67, 0.57, 0.44),
    "jetski": (2.91, 0.97, 0.69, 0.61, 0.63, 0.76, 0.94, 0.84, 0.71, 0.95),
    "buoy": (1.44, 1.25, 1.55, 1.85, 1.46, 2.88, 0.32, 1.38, 1.06, 1.1, 1.11, 0.54, 0.38,
             0.38, 0.42, 0.43, 0.58, 0.61, 0.6, 0.66),
}

#: the ``seadronessee`` preset: categories in SeaDronesSee's id order (swimmer 1, boat 2,
#: jetski 3, life_saving_appliances 4, buoy 5), weighted by its annotation counts and placed
#: where its boxes lie in the frame (:data:`SDS_FRAMES`) at the distance where they show
#: its box sizes (:data:`SDS_SIZES`); green coastal water as its frames show it (of its
#: 1030 4K frames with flight metadata, 695 are over the North Sea's coast, August 2021,
#: and 335 over Lake Constance near the shore, August 2020: turbid summer water, Secchi
#: depths of a few metres; a swimmer's body below the shoulders is lost in it), the
#: ``coastal`` water type at turbidity 0.5-1.0 (chlorophyll 1.4-4 mg/m^3, CDOM 0.14-0.4
#: /m, sediment 1.4-4 g/m^3: an object keeps half its image 0.2-0.5 m down, see
#: :data:`~sdcomp.scene.objects.VISIBLE_DEPTH`); mostly open, deep water (a sandy
#: bottom in 10 % of the frames, a shore in 5 %); clutter only of what SeaDronesSee does
#: not annotate (logs, foam); ignore regions as its category 0 ``ignored``. Its objects
#: per frame are a 4K frame's (``count_view``): a narrower view holds fewer, at least one
SEADRONESSEE: dict[str, Any] = {
    "objects": [{"mesh": k, "category": k, "weight": n, "frame": list(SDS_FRAMES[k]),
                 "size": list(SDS_SIZES[k])}
                | ({"size_weight": [w for w in SDS_SIZE_WEIGHTS[k]
                                   for _ in range(SDS_WEIGHT_GROUP)]}
                   if k in SDS_SIZE_WEIGHTS else {}) for k, n in SDS_CLASSES],
    "count": list(SDS_COUNT), "count_view": SDS_VIEW,
    "altitude": list(SDS_ALTITUDE),
    "pitch": [max(p, PITCH_RANGE[0]) for p in SDS_PITCH], "pair_pitch": True,
    "heading": list(SDS_HEADING), "sun_elevation": list(SDS_SUN_ELEVATION), "sun_azimuth": 0,
    "camera": "custom", "fov": SDS_FOV, "sensor_px": [3840, 2160],
    "width": 3840, "height": 2160,
    "water": ["coastal"], "turbidity": "0.5-1.0", "shallow": 0.1,
    "clutter": 0.3, "clutter_kinds": ["log", "foam"], "shore": 0.05,
    "ignored_category": True,
}

#: named presets: field values applied over the defaults
PRESETS: dict[str, dict] = {
    **{f"paper-alt{a}": _paper(water=["brown"], altitude=a) for a in (10, 20, 30, 40, 50)},
    "paper-brown": _paper(water=["brown"], altitude=10),
    "paper-blue": _paper(water=["blue"], altitude=10),
    "paper-green": _paper(water=["green"], altitude=10),
    "seadronessee": SEADRONESSEE,
}


def preset(name: str) -> dict:
    """The field values of preset ``name``; UserError naming the presets otherwise."""
    if name not in PRESETS:
        raise UserError(f"--preset {name!r} is unknown; use one of {', '.join(PRESETS)}")
    return dict(PRESETS[name])
