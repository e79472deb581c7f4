"""The water and sky of a scene: :class:`WaterParams`, plain data, and the water names.

Water is described by what it holds, not by a colour: the inherent optical properties come
from its constituents (chlorophyll, coloured dissolved organic matter, suspended sediment),
and the renderer (:mod:`sdcomp.render.water`) derives the colour a drone sees from them, the
sky and the sun. Five types span what drones fly over; the paper's colours are presets of
them:

- ``ocean`` (clear open sea: deep blue), ``coastal`` (teal to green-blue), ``turbid``
  (sediment-laden river or estuary: brown), ``algae`` (green bloom), ``lake`` (humic olive);
- ``brown`` = turbid, ``blue`` = ocean or coastal, ``green`` = lake or algae;
- ``R,G,B``: a custom colour (sRGB of the water body seen straight down under a bright
  sky), with the attenuation of its turbidity.

Units: metres, m/s, degrees (world frame of :mod:`sdcomp.scene.camera`: azimuths and
directions counter-clockwise from +x); chlorophyll mg/m^3, CDOM absorption at 440 nm 1/m,
suspended matter g/m^3.
"""

from __future__ import annotations

from dataclasses import dataclass

from ..errors import SettingError, UserError

#: water types: (chl mg/m^3, CDOM a(440) 1/m, TSM g/m^3) ranges; turbidity picks the place
#: in each range (log scale)
WATER_TYPES: dict[str, tuple[tuple[float, float], tuple[float, float], tuple[float, float]]] = {
    "ocean": ((0.05, 0.5), (0.003, 0.03), (0.05, 1.0)),  # clear open sea: deep blue
    "coastal": ((0.5, 4.0), (0.05, 0.4), (0.5, 4.0)),  # teal to green-blue
    "turbid": ((1.0, 15.0), (0.3, 3.0), (15.0, 150.0)),  # sediment-laden river, estuary
    "algae": ((12.0, 80.0), (0.2, 1.5), (1.0, 6.0)),  # green phytoplankton bloom
    "lake": ((2.0, 15.0), (0.5, 3.0), (0.5, 5.0)),  # humic olive lake
}
#: the paper's colour names -> the water types they stand for
WATER_PRESETS: dict[str, tuple[str, ...]] = {
    "brown": ("turbid",),
    "blue": ("ocean", "coastal"),
    "green": ("lake", "algae"),
}
WATER_NAMES = (*WATER_TYPES, *WATER_PRESETS)
SKY_KINDS = ("clear", "broken", "overcast")
#: how often each sky is drawn: drones fly mostly in fair weather (SeaDronesSee's footage is
#: sunny or partly cloudy)
SKY_WEIGHTS = {"clear": 0.4, "broken": 0.45, "overcast": 0.15}
SAND = (0.32, 0.28, 0.20)  # bottom albedo of pale sand
GRAVITY = 9.81  # m/s^2: the waves' restoring acceleration (and the things that ride them)


@dataclass(frozen=True)
class WaterParams:
    """The water and sky of one image (everything random about them). Plain data.

    Water body: ``name`` (as the config named it: a type, a preset or ``R,G,B``),
    ``water_type`` (a key of :data:`WATER_TYPES`), mean constituents ``chl``, ``cdom``,
    ``tsm``; ``rgb``: a custom colour's sRGB (None: the constituents' own colour);
    ``turbidity`` (0..1): where the constituents lie in the type's ranges;
    ``patchiness``: standard deviation of their log across the scene (0: uniform);
    ``patch_scale``: metres, size of plumes and patches; ``depth``: metres of optically
    shallow water over a sandy bottom, or None (deep).
    Waves: ``wind`` m/s at 10 m, ``wind_dir`` degrees (direction the wind blows towards),
    ``wave_age``: inverse wave age (0.84 fully developed sea .. 4 short-fetch lake waves);
    ``slicks``: fraction of the surface under slicks (calm, no capillaries); swell of
    significant height ``swell_height`` m (0: none), ``swell_length`` m, ``swell_dir`` deg;
    ``foam_scale``: whitecap coverage relative to the open-sea fit.
    Sky: ``sky`` (clear/broken/overcast), ``cloud_cover`` (0..1), ``cloud_height`` m,
    ``cloud_scale`` m per texel of the cloud field, ``cloud_bright`` (brightness of sunlit
    cloud relative to a white surface), ``visibility`` m; sun ``sun_elevation``,
    ``sun_azimuth`` degrees.
    Exposure: ``exposure_target`` linear metered luminance (0.18 = mid grey),
    ``metering`` ("average" or "centre").
    ``seed``: per-image offsets into the tiles and noise.
    Video (defaults: a still image, as before): ``origin`` (2,) world metres (x east, y
    north) of the point under the camera (scene coordinates stay camera-relative): the sea,
    its patches and the clouds are sampled at world positions; ``frame_heading`` degrees
    (counter-clockwise from +x) of the wave tiles' x axis fixed in the world (None: the
    tiles follow the camera's right axis); ``time`` seconds of the waves' motion (None:
    frozen tiles; else each wave mode travels at its deep-water gravity-capillary speed).
    """

    name: str = "lake"
    water_type: str = "lake"
    chl: float = 5.0
    cdom: float = 1.0
    tsm: float = 5.0
    rgb: tuple[int, int, int] | None = None
    turbidity: float = 0.5
    patchiness: float = 0.2
    patch_scale: float = 120.0
    depth: float | None = None
    wind: float = 3.0
    wind_dir: float = 0.0
    wave_age: float = 2.0
    slicks: float = 0.0
    swell_height: float = 0.0
    swell_length: float = 80.0
    swell_dir: float = 0.0
    foam_scale: float = 1.0
    sky: str = "clear"
    cloud_cover: float = 0.0
    cloud_height: float = 1500.0
    cloud_scale: float = 12.0
    cloud_bright: float = 0.9
    visibility: float = 15000.0
    sun_elevation: float = 50.0
    sun_azimuth: float = 0.0
    exposure_target: float = 0.18
    metering: str = "average"
    seed: int = 0
    origin: tuple[float, float] = (0.0, 0.0)
    frame_heading: float | None = None
    time: float | None = None


def constituents(water_type: str, turbidity: float) -> tuple[float, float, float]:
    """(chl mg/m^3, CDOM 1/m, TSM g/m^3) of ``water_type`` at ``turbidity`` (0..1, clipped):
    the place in each of the type's ranges (:data:`WATER_TYPES`), on a log scale."""
    t = min(max(float(turbidity), 0.0), 1.0)
    chl, cdom, tsm = (lo * (hi / lo) ** t for lo, hi in WATER_TYPES[water_type])
    return chl, cdom, tsm


def parse_water(text: str) -> tuple[str, tuple[str, ...], tuple[int, int, int] | None]:
    """A water name: a type, a preset or ``R,G,B`` 0-255.

    Returns (name, the water types it draws from, the custom sRGB colour or None); the
    name of an RGB colour is the text ``"R,G,B"`` (a custom colour draws the ``coastal``
    type's light with its own colour)."""
    t = str(text).strip().lower()
    if t in WATER_TYPES:
        return t, (t,), None
    if t in WATER_PRESETS:
        return t, WATER_PRESETS[t], None
    try:
        values = [int(p) for p in t.split(",")]
    except ValueError:
        values = []
    if len(values) != 3 or not all(0 <= c <= 255 for c in values):
        raise UserError(f"--water {text!r} is not a water: use {', '.join(WATER_NAMES)} or "
                        f"R,G,B with 0-255 each")
    r, g, b = values
    return f"{r},{g},{b}", ("coastal",), (r, g, b)


def water_text(w: object) -> str:
    """A ``--water`` colour as text (a name of :data:`WATER_NAMES` or ``R,G,B``, from text or
    a list of three numbers), checked (SettingError or UserError naming the bad value)."""
    if isinstance(w, (list, tuple)) and len(w) == 3:
        try:
            w = ",".join(str(int(c)) for c in w)
        except (TypeError, ValueError, OverflowError):
            raise SettingError("water", f"{{name}} {w!r} is not a water: use a name "
                                        f"({', '.join(WATER_NAMES)}) or R,G,B of 0-255"
                               ) from None
    parse_water(str(w))  # raises UserError for an unknown name or bad RGB
    return str(w)
