"""The generator's configuration: one frozen, validated dataclass, its presets and file form.

Every field of :class:`GeneratorConfig` is declared once, next to its default, with its kind,
bounds, unit and help (:func:`sdcomp.scene.settings.setting`); the command line makes a flag
of it (``--field-name``) and a TOML config file a key (``field_name`` or ``field-name``).
Randomised fields are :class:`Param` values (``30``, ``10-50`` or ``10,20,30``) drawn once per
image. Values are checked in one place, :meth:`GeneratorConfig.__post_init__`, which also
accepts the text and TOML forms, so ``GeneratorConfig(altitude="10-50")`` and
``GeneratorConfig(altitude=30)`` both work.

Precedence: defaults < ``--preset`` < ``--config FILE`` < flags on the command line.
"""

from __future__ import annotations

import difflib
from dataclasses import dataclass, fields, replace
from typing import Any

from ..errors import SettingError, UserError
from ..util.log import get_logger
from .camera import ALTITUDE_RANGE, PITCH_RANGE, CameraModel
from .camera import PRESETS as CAMERA_PRESETS
from .look import PRESETS as LOOK_PRESETS
from .look import RECORDINGS, STAGES
from .objects import (
    CLUTTER_KINDS,
    DEFAULT_CLUTTER_KINDS,
    ObjectSpec,
    coco_categories,
    object_spec,
    resolve_clutter_kinds,
)
from .params import Param
from .presets import PRESETS, preset
from .settings import (
    RETIRED,
    check_float,
    choice_list,
    int_pair,
    load_toml,
    names,
    setting,
    setting_of,
    toml_value,
)
from .water import SKY_KINDS, WATER_NAMES, water_text

IMAGE_FORMATS = ("jpg", "png")
#: what --unlabelled does with objects of interest that cannot be labelled
UNLABELLED = ("draw", "skip")
#: annotation formats of --format (COCO JSON, Ultralytics YOLO label files)
LABEL_FORMATS = ("coco", "yolo")
MAX_INSTANCES = 999  # objects of interest per image (annotation ids reserve 3 digits)
#: settings that replace one parameter of the camera look's per-image draw, when set
#: (config field -> :data:`sdcomp.scene.look_table.PARAMS` name)
LOOK_SETTINGS = {"exposure_bias": "exposure_ev", "wb_red": "wb_red", "wb_blue": "wb_blue",
                 "contrast": "contrast", "saturation": "saturation", "shot_noise": "noise_a",
                 "sharpening": "sharpen_amount"}


@dataclass(frozen=True)
class GeneratorConfig:
    """Everything that decides a generated dataset (with the seed, it fixes every byte).

    Units: metres, degrees (pitch: below the horizon, 90 = straight down), m/s, pixels.
    See ``python -m sdcomp.generate --help`` for each field's meaning.
    """

    # run
    n: int = setting(2500, "int", "number of images", "N", 1, 100_000_000)
    seed: int = setting(0, "int", "random seed: image i depends only on (seed, i, options)",
                        "S", 0, 2**63 - 1)
    val_fraction: float = setting(0.2, "float", "fraction of images in the val split (exact "
                                  "per 100 images; video: of whole sequences)", "F", 0.0,
                                  1.0)
    image_format: str = setting("jpg", "custom", "image file format", "jpg|png")
    jpeg_quality: Param = setting("90-95", "param", "JPEG quality, 1-100 (a value, range "
                                  "lo-hi or list)", "Q", 1.0, 100.0, integer=True)
    min_visible_px: int = setting(4, "int", "objects of interest with fewer visible pixels "
                                  "are not labelled: their pixels become an ignore region",
                                  "PX", 1, 100_000_000)
    min_in_frame: float = setting(0.0, "float", "objects cut by the frame's edge are labelled "
                                  "only when at least this fraction of their projected "
                                  "silhouette is inside the frame, else their pixels become "
                                  "an ignore region (0: every cut object is labelled by what "
                                  "is visible, as SeaDronesSee, COCO and MOTChallenge do)",
                                  "F", 0.0, 1.0)
    unlabelled: str = setting("draw", "custom", "objects of interest that cannot be labelled "
                              "(too few pixels, too thin): draw them and mark an ignore "
                              "region, or skip drawing them (for formats without ignore "
                              "regions: YOLO)", "draw|skip")
    ignored_category: bool = setting(False, "bool", "COCO ignore regions are annotations of "
                                     "category 0 'ignored', as SeaDronesSee's, instead of "
                                     "iscrowd entries of the object's own category")
    amodal: bool = setting(False, "bool", "also store amodal masks (the whole projected "
                           "object, ignoring occlusion and water)")
    format: tuple[str, ...] = setting(("coco",), "custom", "annotation formats: coco (JSON), "
                                      "yolo (Ultralytics label files, data.yaml) or both; "
                                      "never changes the images", "coco,yolo")
    yolo_seg: bool = setting(False, "bool", "YOLO labels are polygons traced from the masks "
                             "instead of boxes")
    # camera
    camera: str = setting("mavic2pro", "custom", "drone camera: mavic2pro (77 deg diagonal "
                          "FOV), phantom4pro (84), zenmuse-x5 (72), their 16:9 4K video "
                          "(NAME-video), zenmuse-z30 (a zoom's 1920x1080 video at 40.5 deg: "
                          "SeaDronesSee's 1080p frames), or custom (--fov, --sensor-px)", "NAME")
    fov: float | None = setting(None, "custom", "diagonal field of view, degrees (overrides "
                                "the camera's)", "DEG")
    sensor_px: tuple[int, int] | None = setting(None, "custom", "sensor resolution, pixels "
                                                "(sets the aspect the FOV refers to)", "W,H")
    width: int = setting(416, "int", "output image width, pixels", "PX", 1, 32_000)
    height: int = setting(416, "int", "output image height, pixels", "PX", 1, 32_000)
    altitude: Param = setting("10-50", "param", "camera altitude, metres: value, range lo-hi "
                              "or list a,b,c", "M", *ALTITUDE_RANGE, unit="m")
    pitch: Param = setting(90, "param", "gimbal pitch below the horizon, degrees: 90 straight "
                           "down, down to 2 (nearly level)", "DEG", *PITCH_RANGE, unit="degrees")
    heading: Param = setting("0-360", "param", "camera heading, degrees anticlockwise from "
                             "east", "DEG", -360.0, 720.0, "degrees")
    pair_pitch: bool = setting(False, "bool", "draw the k-th --pitch (and --heading, --sun-"
                               "elevation, --sun-azimuth lists of that length; others apart) "
                               "with the k-th --altitude: a joint distribution, e.g. flight logs")
    # water
    water: tuple[str, ...] = setting(("brown", "blue", "green"), "custom", "waters, one per "
                                     "image at random: ocean, coastal, turbid, algae, lake, "
                                     "the paper's brown (turbid), blue (ocean or coastal), "
                                     "green (lake or algae), or R,G,B", "WATER")
    turbidity: Param = setting("0.1-0.9", "param", "how much the water holds, 0 (the clearest "
                               "of its type) to 1 (the murkiest): colour and attenuation",
                               "T", 0.0, 1.0)
    wind: Param = setting("1-8", "param", "wind speed, m/s: waves, sun glitter, whitecaps "
                          "above ~5", "M/S", 0.0, 25.0, "m/s")
    shallow: float = setting(0.3, "float", "probability that a sandy bottom lies within "
                             "--floor-depth (visible through clear water)", "P", 0.0, 1.0)
    floor_depth: Param = setting("1.5-15", "param", "depth of a shallow bottom, metres", "M",
                                 0.5, 200.0, "m")
    whitecaps: float = setting(1.0, "float", "whitecap coverage relative to the open sea's "
                               "at the same wind (0 = none)", "X", 0.0, 5.0)
    glitter: bool = setting(True, "bool", "draw the sun's glitter as sparkles (off: the "
                            "glint's mean brightness only; 0.5-2 ms less per 416 px image)")
    backgrounds: str | None = setting(None, "path", "composite onto your own footage "
                                      "instead of procedural water: a folder (or file) of "
                                      "photos and drone videos", "PATH")
    background_labels: str | None = setting(None, "path", "COCO json or YOLO labels folder "
                                            "of real objects in the --backgrounds frames: "
                                            "kept out of every image", "LABELS")
    footage_look: bool = setting(True, "bool", "over --backgrounds: the objects get the "
                                 "footage's blur (--footage-blur) and noise (measured)")
    footage_blur: float = setting(0.8, "float", "over --backgrounds: the footage camera's blur "
                                  "at its own resolution (sigma)", "PX", 0.0, 5.0, "pixels")
    # light
    sun_elevation: Param = setting("25-80", "param", "sun elevation above the horizon, degrees",
                                   "DEG", 5.0, 90.0, "degrees")
    sun_azimuth: Param = setting("0-360", "param", "sun azimuth, degrees anticlockwise from "
                                 "east", "DEG", -360.0, 720.0, "degrees")
    sky: tuple[str, ...] = setting(SKY_KINDS, "custom", "skies, one per image at random: "
                                   "clear, broken (clouds), overcast, drawn as drones fly "
                                   "(0.4, 0.45, 0.15 of the time)", "SKY")
    cloud_cover: Param = setting("0.15-0.75", "param", "cloud cover of broken skies (0-1)",
                                 "C", 0.0, 1.0)
    shadows: bool = setting(True, "bool", "draw object shadows on the water and sea floor")
    # objects of interest
    objects: tuple[ObjectSpec, ...] = setting(
        (ObjectSpec("bluerov2", "bluerov2"),), "custom", "object of interest: bluerov2, "
        "bluerov2-heavy, a search-and-rescue kind (swimmer, boat, jetski, "
        "life_saving_appliances, buoy: all its variants) or a mesh file (repeat for several; "
        "each its own COCO category)", "MESH")
    count: Param = setting("1-3", "param", "objects of interest per image (0 allowed: empty "
                           "images)", "K", 0.0, float(MAX_INSTANCES), "objects", True)
    count_view: float = setting(0.0, "float", "the view --count and --clutter are for, as "
                                "an image's area in squared focal lengths, (width / fx) "
                                "(height / fy): a camera that sees more or less of the water "
                                "draws proportionally more or fewer objects, at least one "
                                "(0: per image, whatever the camera)", "A", 0.0, 100.0)
    draft: Param = setting("0-0.05", "param", "how far objects sink below their natural "
                           "waterline, metres (large = fully submerged)", "M", -1.0, 100.0,
                           "m")
    tilt: float = setting(5.0, "float", "largest wave tilt (roll and pitch) of objects, "
                          "degrees", "DEG", 0.0, 30.0, "degrees")
    under_way: float = setting(1.0, "float", "how often floating things travel, leaving a "
                               "wake: a factor on each kind's chance (boats 0.5, jet skis "
                               "0.6, swimmers 0.4, BlueROV2 0.3; 0: all at rest)", "X", 0.0,
                               2.5)
    moored: float = setting(0.0, "float", "chance that a boat or jet ski lies at rest at a "
                            "dock (lakes, marinas): often a canopied boat lift beside it, a "
                            "jet ski on a drive-on port on half", "P", 0.0, 1.0)
    # objects of non-interest
    clutter: float = setting(0.6, "float", "mean number of floating clutter objects per image "
                             "(0 = none)", "K", 0.0, 50.0, "objects per image")
    clutter_kinds: tuple[str, ...] = setting(DEFAULT_CLUTTER_KINDS, "custom", "clutter kinds "
                                             f"to use: {', '.join(CLUTTER_KINDS)} (the default "
                                             "drops kinds that are objects)", "KIND")
    shore: float = setting(0.0, "float", "probability of a shoreline with land (a meadow behind "
                           "rip-rap) at a frame edge", "P", 0.0, 1.0)
    hills: float = setting(0.7, "float", "probability of hills on the horizon when the horizon "
                           "is in view", "P", 0.0, 1.0)
    # the drone camera's look
    look: str = setting("auto", "custom", "camera look (lens, exposure, colour, noise, "
                        "sharpening, compression, each drawn per image): mavic2pro, "
                        "phantom4pro, zenmuse-x5, clean (none), or auto (that of --camera; "
                        "clean over --backgrounds)", "NAME")
    exposure_bias: Param | None = setting(None, "param", "exposure bias over the auto "
                                          "exposure, stops, per image (e.g. =-1:0.5); unset: "
                                          "--look's draw", "EV", -4.0, 4.0, "stops")
    wb_red: Param | None = setting(None, "param", "white balance gain of red (linear, 1 "
                                   "neutral) per image; unset: --look's draw", "GAIN", 0.2, 5.0)
    wb_blue: Param | None = setting(None, "param", "white balance gain of blue, as --wb-red",
                                    "GAIN", 0.2, 5.0)
    contrast: Param | None = setting(None, "param", "tone curve contrast (an S-curve about mid "
                                     "grey; 1 none) per image; unset: --look's draw", "C",
                                     0.5, 2.5)
    saturation: Param | None = setting(None, "param", "colour saturation (1 as recorded, 0 "
                                       "grey) per image; unset: --look's draw", "S", 0.0, 2.5)
    shot_noise: Param | None = setting(None, "param", "sensor shot noise: variance A x of a "
                                       "linear signal x in 0-1 at the sensor's scale (the "
                                       "looks draw 2.5e-5 to 6e-4) per image; unset: --look's "
                                       "draw", "A", 0.0, 0.1)
    sharpening: Param | None = setting(None, "param", "in-camera sharpening: the unsharp "
                                       "mask's amount (the looks draw 0.3-1.2; 0 none) per "
                                       "image; unset: --look's draw", "S", 0.0, 3.0)
    recording: str = setting("video", "custom", "what the camera records: video (4K H.264/"
                             "H.265 frames) or photo (full-resolution JPEG)", "video|photo")
    motion_blur: float = setting(0.5, "float", "probability of motion blur along the flight",
                                 "P", 0.0, 1.0)
    defocus_blur: float = setting(0.05, "float", "probability of defocus blur", "P", 0.0, 1.0)
    camera_off: tuple[str, ...] = setting((), "custom", "camera stages to leave out, for "
                                          f"speed: {', '.join(STAGES)} (compression, "
                                          "the 4K recording's blocks, is half of a 1920x1080 "
                                          "image's time; see docs/performance.md)", "STAGE")
    grade: str | None = setting(None, "path", "site grade file of sdcomp fit, the camera's "
                                "last stage (in a config: beside it)", "FILE")

    def __post_init__(self) -> None:
        for f in fields(self):
            object.__setattr__(self, f.name, setting_of(f).check(f.name, getattr(self, f.name)))
        self._check_camera()
        self._check_water()
        self._check_objects()

    def _put(self, name: str, value: Any) -> None:
        object.__setattr__(self, name, value)

    def _check_camera(self) -> None:
        """Output formats and the camera: presets, custom FOV and sensor."""
        self._put("format", choice_list(self.format, "format", LABEL_FORMATS))
        self._put("camera_off", choice_list(self.camera_off, "camera_off", STAGES,
                                            empty=True))
        if self.yolo_seg and "yolo" not in self.format:
            raise SettingError("yolo_seg", "{name} writes YOLO polygon labels: add --format "
                                           "yolo (or coco,yolo), or drop {name}")
        if self.image_format not in IMAGE_FORMATS:
            raise SettingError("image_format", f"{{name}} {self.image_format!r} is unknown; "
                                               f"use {' or '.join(IMAGE_FORMATS)}")
        if self.unlabelled not in UNLABELLED:
            raise SettingError("unlabelled", f"{{name}} {self.unlabelled!r} is unknown; "
                                             f"use {' or '.join(UNLABELLED)}")
        if self.camera not in (*CAMERA_PRESETS, "custom"):
            raise SettingError("camera", f"{{name}} {self.camera!r} is unknown; use one of "
                                         f"{', '.join(CAMERA_PRESETS)} or custom (with --fov, "
                                         f"--sensor-px)")
        if self.camera == "custom" and (self.fov is None or self.sensor_px is None):
            raise SettingError("camera", "{name} custom needs --fov DEGREES (diagonal) and "
                                         "--sensor-px WIDTH,HEIGHT")
        if self.fov is not None:
            self._put("fov", check_float(self.fov, "fov", 1.0, 170.0, "degrees"))
        if self.sensor_px is not None:
            self._put("sensor_px", int_pair(self.sensor_px, "sensor_px"))
        self.camera_model()  # validates the combination
        n_alt, n_pitch = len(self.altitude.choices), len(self.pitch.choices)
        if self.pair_pitch and not n_alt == n_pitch > 0:
            def kind(n: int) -> str:
                return f"a list of {n}" if n else "not a list"
            raise SettingError("pair_pitch", f"{{name}} needs --altitude and --pitch as lists "
                                             f"of one length (--altitude is {kind(n_alt)}, "
                                             f"--pitch {kind(n_pitch)}): give both as lists, "
                                             f"or add --no-pair-pitch")

    def _check_water(self) -> None:
        """Waters, skies, the camera look and the user's footage (and its labels)."""
        water = names(self.water, "water")
        if not water:
            raise SettingError("water", "{name} needs at least one water: "
                                        f"{', '.join(WATER_NAMES)} or R,G,B")
        self._put("water", tuple(water_text(w) for w in water))
        sky = names(self.sky, "sky")
        bad = [k for k in sky if k not in SKY_KINDS]
        if bad or not sky:
            raise SettingError("sky", f"{{name}} {(bad or [''])[0]!r} is unknown; use some of "
                                      f"{', '.join(SKY_KINDS)}")
        self._put("sky", tuple(sky))
        if self.look not in (*LOOK_PRESETS, "auto"):
            raise SettingError("look", f"{{name}} {self.look!r} is unknown; use one of "
                                       f"{', '.join(LOOK_PRESETS)} or auto")
        if self.recording not in RECORDINGS:
            raise SettingError("recording", f"{{name}} {self.recording!r} is unknown; use "
                                            f"{' or '.join(RECORDINGS)}")
        if self.background_labels is not None and self.backgrounds is None:
            raise SettingError("background_labels", "{name} labels objects in the "
                                                    "--backgrounds footage: give that too")

    def _check_objects(self) -> None:
        """Objects of interest (each its own category) and the clutter kinds."""
        objs = self.objects
        objs = (objs,) if isinstance(objs, (ObjectSpec, dict)) else names(objs, "object")
        specs = [object_spec(o) for o in objs]
        if not specs:
            raise SettingError("object", "{name}: give at least one object of interest")
        cats = [s.category for s in specs]
        if len(set(cats)) != len(cats):
            raise SettingError("category", f"{{name}} names must differ between objects: "
                                           f"{cats}")
        self._put("objects", tuple(specs))
        kinds = names(self.clutter_kinds, "clutter_kinds")
        self._put("clutter_kinds", resolve_clutter_kinds(kinds, [s.mesh for s in specs]))

    # ----------------------------------------------------------------- derived
    def camera_model(self) -> CameraModel:
        """The :class:`CameraModel` producing ``width`` x ``height`` images."""
        if self.camera == "custom" or self.fov is not None or self.sensor_px is not None:
            base = CAMERA_PRESETS.get(self.camera, (5472, 3648, 77.0))
            sw, sh = self.sensor_px or base[:2]
            return CameraModel(sw, sh, self.fov if self.fov is not None else base[2],
                               self.width, self.height)
        return CameraModel.preset(self.camera, self.width, self.height)

    def look_overrides(self) -> dict[str, Param | None]:
        """The look's parameters set by :data:`LOOK_SETTINGS` (None: the look draws it)."""
        return {look: getattr(self, name) for name, look in LOOK_SETTINGS.items()}

    @property
    def look_preset(self) -> str:
        """The camera look's preset: ``look``, or for ``auto`` the camera's (mavic2pro for a
        custom camera), ``clean`` over your own footage (``backgrounds``: it has been filmed)."""
        if self.look != "auto":
            return self.look
        if self.backgrounds:
            return "clean"
        body = self.camera.removesuffix("-video")
        return body if body in LOOK_PRESETS else "mavic2pro"

    @property
    def categories(self) -> list[dict]:
        """COCO categories of ``objects`` (:func:`.objects.coco_categories`)."""
        return coco_categories(self.objects)

    # ----------------------------------------------------------------- (de)serialise
    def to_dict(self) -> dict:
        """JSON-able dict that :meth:`from_mapping` reads back to an equal config."""
        out = {}
        for f in fields(self):
            v = getattr(self, f.name)
            if isinstance(v, Param):
                v = v.to_json()
            elif f.name == "objects":  # weight, frame, size(_weight) where set
                v = [{"mesh": o.mesh, "category": o.category}
                     | ({"weight": o.weight} if o.weight != 1.0 else {})
                     | ({"frame": list(o.frame)} if o.frame is not None else {})
                     | ({"size": list(o.size)} if o.size is not None else {})
                     | ({"size_weight": list(o.size_weight)} if o.size_weight else {})
                     for o in v]
            elif isinstance(v, tuple):
                v = list(v)
            out[f.name] = v
        return out

    def to_toml(self) -> str:
        """The whole config as TOML text; ``load_toml`` + :meth:`from_mapping` of it give an
        equal config (``--dump-config`` prints it, ``--config FILE`` reads it back); unset
        optional fields (None, their default) are left out."""
        from .. import __version__

        lines = [f"# sdcomp generator config: every field, resolved (sdcomp {__version__})",
                 "# reproduce the run with: sdcomp generate --config THIS_FILE --out DIR"]
        for key, value in self.to_dict().items():
            if value is not None:
                lines.append(f"{key} = {toml_value(value)}")
        return "\n".join(lines) + "\n"

    @classmethod
    def from_mapping(cls, mapping: dict, base: GeneratorConfig | None = None,
                     source: str = "config") -> GeneratorConfig:
        """A config from a dict of field names (``-`` or ``_``) to values, over ``base``."""
        known = {f.name for f in fields(cls)}
        clean = {}
        for key, value in mapping.items():
            name = str(key).replace("-", "_")
            if name in RETIRED:
                get_logger(__name__).warning("%s: %r is no longer used: %s", source, key,
                                             RETIRED[name])
                continue
            if name not in known:
                near = difflib.get_close_matches(name, sorted(known), n=1, cutoff=0.6)
                hint = f"did you mean {near[0]!r}? " if near else ""
                raise UserError(f"{source}: unknown key {key!r}; {hint}see "
                                f"`python -m sdcomp.generate --help` for the names")
            clean[name] = value
        return replace(base or cls(), **clean)

__all__ = ["GeneratorConfig", "ObjectSpec", "PRESETS", "preset", "load_toml"]
