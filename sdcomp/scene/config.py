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
import math
import tomllib
from dataclasses import dataclass, fields, replace
from pathlib import Path
from typing import Any

from ..errors import SettingError, UserError
from .camera import ALTITUDE_RANGE, PITCH_RANGE, CameraModel
from .camera import PRESETS as CAMERA_PRESETS
from .objects import (
    CLUTTER_KINDS,
    DEFAULT_CLUTTER_KINDS,
    SUPERCATEGORIES,
    object_kind,
    resolve_clutter_kinds,
)
from .params import Param
from .presets import PRESETS, preset
from .settings import check_float, int_pair, names, setting, setting_of, toml_value
from .water import WATER_COLORS, parse_water

IMAGE_FORMATS = ("jpg", "png")
#: annotation formats of --format (COCO JSON, Ultralytics YOLO label files)
LABEL_FORMATS = ("coco", "yolo")
MAX_INSTANCES = 999  # objects of interest per image (annotation ids reserve 3 digits)


def _positive(v: Any) -> bool:
    """Whether ``v`` (a number or its text) is a finite number above 0."""
    try:
        return 0.0 < float(v) < math.inf
    except ValueError:
        return False


@dataclass(frozen=True)
class ObjectSpec:
    """An object of interest: a built-in mesh or kind name (a kind stands for all its
    variants, :mod:`sdcomp.scene.objects`) or a mesh file, its COCO category, and its
    ``weight``: how often it is drawn relative to the other objects (class proportions)."""

    mesh: str = "bluerov2"
    category: str = ""
    weight: float = 1.0

    def __post_init__(self) -> None:
        if not isinstance(self.mesh, str) or not self.mesh.strip() or "\0" in self.mesh:
            raise SettingError("object", "{name} needs a built-in mesh name (bluerov2, "
                                         "bluerov2-heavy, swimmer, boat, jetski, "
                                         "life_saving_appliances, buoy) or a mesh file path")
        w = self.weight
        if isinstance(w, bool) or not isinstance(w, (int, float, str)) or not _positive(w):
            raise SettingError("weight", f"{{name}} {w!r} must be a positive number (how "
                                         f"often this object is drawn relative to the others)")
        object.__setattr__(self, "weight", float(w))
        if not self.category:
            object.__setattr__(self, "category", Path(self.mesh).stem if Path(
                self.mesh).suffix else self.mesh)
        if not isinstance(self.category, str) or not self.category.strip():
            raise SettingError("category", f"{{name}} {self.category!r} must be a non-empty "
                                           f"name")


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
                                  "per 100 images)", "F", 0.0, 1.0)
    image_format: str = setting("jpg", "custom", "image file format", "jpg|png")
    jpeg_quality: Param = setting("90-95", "param", "JPEG quality, 1-100 (a value, range "
                                  "lo-hi or list)", "Q", 1.0, 100.0, integer=True)
    min_visible_px: int = setting(4, "int", "objects with fewer visible pixels are not "
                                  "annotated (counted as dropped)", "PX", 1, 100_000_000)
    amodal: bool = setting(False, "bool", "also store amodal masks (the whole projected "
                           "object, ignoring occlusion and water)")
    format: tuple[str, ...] = setting(("coco",), "custom", "annotation formats: coco (JSON), "
                                      "yolo (Ultralytics label files, data.yaml) or both; "
                                      "never changes the images", "coco,yolo")
    yolo_seg: bool = setting(False, "bool", "YOLO labels are polygons traced from the masks "
                             "instead of boxes")
    # camera
    camera: str = setting("mavic2pro", "custom", "drone camera: mavic2pro (77 deg diagonal "
                          "FOV), phantom4pro (84 deg), or custom with --fov and --sensor-px",
                          "NAME")
    fov: float | None = setting(None, "custom", "diagonal field of view, degrees (overrides "
                                "the camera's)", "DEG")
    sensor_px: tuple[int, int] | None = setting(None, "custom", "sensor resolution, pixels "
                                                "(sets the aspect the FOV refers to)", "W,H")
    width: int = setting(416, "int", "output image width, pixels", "PX", 1, 32_000)
    height: int = setting(416, "int", "output image height, pixels", "PX", 1, 32_000)
    altitude: Param = setting("10-50", "param", "camera altitude, metres: value, range lo-hi "
                              "or list a,b,c", "M", *ALTITUDE_RANGE, unit="m")
    pitch: Param = setting(90, "param", "gimbal pitch below the horizon, degrees: 90 straight "
                           "down, down to 15", "DEG", *PITCH_RANGE, unit="degrees")
    heading: Param = setting("0-360", "param", "camera heading, degrees", "DEG", -360.0,
                             720.0, "degrees")
    pair_pitch: bool = setting(False, "bool", "draw the k-th --pitch with the k-th --altitude "
                               "(two lists of one length: a joint distribution, e.g. from "
                               "flight logs)")
    # water
    water: tuple[str, ...] = setting(("brown", "blue", "green"), "custom", "water colours, "
                                     "one per image at random: brown, blue, green or R,G,B "
                                     "(several allowed)", "COLOR")
    turbidity: Param = setting("0.1-0.9", "param", "turbidity 0 (clear, 0.05/m) to 1 (murky, "
                               "5/m attenuation)", "T", 0.0, 1.0)
    wind: Param = setting("1-8", "param", "wind speed, m/s: wave roughness, glint spread, "
                          "whitecaps above 5", "M/S", 0.0, 25.0, "m/s")
    floor_depth: Param = setting("2-12", "param", "sea-floor depth, metres (seen through clear "
                                 "water)", "M", 0.5, 200.0, "m")
    whitecaps: float = setting(1.0, "float", "whitecap amount at a given wind (0 = none)", "X",
                               0.0, 5.0)
    backgrounds: str | None = setting(None, "custom", "composite onto your own empty-water "
                                      "photos in DIR instead of procedural water", "DIR")
    # light
    sun_elevation: Param = setting("25-80", "param", "sun elevation above the horizon, degrees",
                                   "DEG", 5.0, 90.0, "degrees")
    sun_azimuth: Param = setting("0-360", "param", "sun azimuth, degrees", "DEG", -360.0,
                                 720.0, "degrees")
    ambient: Param = setting("0.3-0.5", "param", "ambient sky light (linear, sun = 2.2)", "L",
                             0.0, 2.0)
    shadows: bool = setting(True, "bool", "draw object shadows on the water and sea floor")
    # objects of interest
    objects: tuple[ObjectSpec, ...] = setting(
        (ObjectSpec("bluerov2", "bluerov2"),), "custom", "object of interest: bluerov2, "
        "bluerov2-heavy, a search-and-rescue kind (swimmer, boat, jetski, "
        "life_saving_appliances, buoy: all its variants) or a mesh file (repeat for several; "
        "each its own COCO category)", "MESH")
    count: Param = setting("1-3", "param", "objects of interest per image (0 allowed: empty "
                           "images)", "K", 0.0, float(MAX_INSTANCES), "objects", True)
    draft: Param = setting("0-0.05", "param", "how far objects sink below their natural "
                           "waterline, metres (large = fully submerged)", "M", -1.0, 100.0,
                           "m")
    tilt: float = setting(5.0, "float", "largest wave tilt (roll and pitch) of objects, "
                          "degrees", "DEG", 0.0, 30.0, "degrees")
    # objects of non-interest
    clutter: float = setting(0.6, "float", "mean number of floating clutter objects per image "
                             "(0 = none)", "K", 0.0, 50.0, "objects per image")
    clutter_kinds: tuple[str, ...] = setting(DEFAULT_CLUTTER_KINDS, "custom", "clutter kinds "
                                             f"to use: {', '.join(CLUTTER_KINDS)} (the default "
                                             "drops kinds that are objects)", "KIND")
    rocks: float = setting(0.35, "float", "fraction of the sea floor covered by rocks and "
                           "debris (0 = none)", "F", 0.0, 1.0)
    shore: float = setting(0.15, "float", "probability of a shoreline with land at a frame "
                           "edge", "P", 0.0, 1.0)
    hills: float = setting(0.7, "float", "probability of hills on the horizon when the horizon "
                           "is in view", "P", 0.0, 1.0)
    # camera effects
    exposure: Param = setting("-0.3-0.3", "param", "exposure jitter, stops", "STOPS", -3.0, 3.0,
                              "stops")
    white_balance: Param = setting("0-0.06", "param", "white-balance jitter: red and blue "
                                   "gains within 1 +- A", "A", 0.0, 0.5)
    noise: Param = setting("0-3", "param", "sensor noise standard deviation, 8-bit levels",
                           "SIGMA", 0.0, 50.0)
    motion_blur: float = setting(0.1, "float", "probability of motion blur", "P", 0.0, 1.0)
    defocus_blur: float = setting(0.05, "float", "probability of defocus blur", "P", 0.0, 1.0)
    vignetting: Param = setting("0-0.3", "param", "brightness fall-off at the image corners "
                                "(fraction)", "V", 0.0, 1.0)

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
        self._put("format", _label_formats(self.format))
        if self.image_format not in IMAGE_FORMATS:
            raise SettingError("image_format", f"{{name}} {self.image_format!r} is unknown; "
                                               f"use {' or '.join(IMAGE_FORMATS)}")
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
            raise SettingError("pair_pitch", f"{{name}} needs --altitude and --pitch as lists "
                                             f"of one length (they have {n_alt} and {n_pitch} "
                                             f"values): give both as lists, or drop {{name}}")

    def _check_water(self) -> None:
        """Water colours and the user's photo folder."""
        water = names(self.water, "water")
        if not water:
            raise SettingError("water", "{name} needs at least one colour: "
                                        f"{', '.join(WATER_COLORS)} or R,G,B")
        self._put("water", tuple(_water_text(w) for w in water))
        if self.backgrounds is not None:
            if not isinstance(self.backgrounds, (str, Path)) or "\0" in str(self.backgrounds):
                raise SettingError("backgrounds", f"{{name}} {self.backgrounds!r} must be a "
                                                  f"folder path")
            self._put("backgrounds", str(self.backgrounds))

    def _check_objects(self) -> None:
        """Objects of interest (each its own category) and the clutter kinds."""
        objs = self.objects
        objs = (objs,) if isinstance(objs, (ObjectSpec, dict)) else names(objs, "object")
        specs = [_object_spec(o) for o in objs]
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

    @property
    def categories(self) -> list[dict]:
        """COCO categories, ids from 1 in the order of ``objects`` (supercategories as
        SeaDronesSee's for its kinds, else "object")."""
        return [{"id": i + 1, "name": o.category,
                 "supercategory": SUPERCATEGORIES.get(object_kind(o.mesh) or "", "object")}
                for i, o in enumerate(self.objects)]

    # ----------------------------------------------------------------- (de)serialise
    def to_dict(self) -> dict:
        """JSON-able dict that :meth:`from_mapping` reads back to an equal config."""
        out = {}
        for f in fields(self):
            v = getattr(self, f.name)
            if isinstance(v, Param):
                v = v.to_json()
            elif f.name == "objects":  # weight only where it is not 1 (as before weights)
                v = [{"mesh": o.mesh, "category": o.category}
                     | ({"weight": o.weight} if o.weight != 1.0 else {}) for o in v]
            elif isinstance(v, tuple):
                v = list(v)
            out[f.name] = v
        return out

    def to_toml(self) -> str:
        """The whole config as TOML text; ``load_toml`` + :meth:`from_mapping` of it give an
        equal config (``--dump-config`` prints it, ``--config FILE`` reads it back).

        Unset optional fields (None) are left out: their default is None.
        """
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
            if name not in known:
                near = difflib.get_close_matches(name, sorted(known), n=1, cutoff=0.6)
                hint = f"did you mean {near[0]!r}? " if near else ""
                raise UserError(f"{source}: unknown key {key!r}; {hint}see "
                                f"`python -m sdcomp.generate --help` for the names")
            clean[name] = value
        return replace(base or cls(), **clean)


def _object_spec(o: Any) -> ObjectSpec:
    """An :class:`ObjectSpec` from a spec, a mesh name or a {mesh, category} table."""
    if isinstance(o, str):
        return ObjectSpec(o)
    if isinstance(o, dict):
        unknown = set(o) - {"mesh", "category", "weight"}
        if unknown:
            raise UserError(f"objects: unknown key {sorted(map(str, unknown))[0]!r}; "
                            f"use mesh, category and weight")
        return ObjectSpec(**o)
    if not isinstance(o, ObjectSpec):
        raise SettingError("object", f"{{name}} {o!r} is not a mesh name or path")
    return o


def _label_formats(v: Any) -> tuple[str, ...]:
    """The formats of ``--format`` in canonical order (``coco,yolo`` text or a list)."""
    items = [v] if isinstance(v, str) else list(v) if isinstance(v, (list, tuple)) else None
    if items is None or not all(isinstance(x, str) for x in items):
        raise SettingError("format", f"{{name}} {v!r} must be coco, yolo or coco,yolo")
    found = [x.strip().lower() for item in items for x in item.split(",") if x.strip()]
    for name in found:
        if name not in LABEL_FORMATS:
            raise SettingError("format", f"{{name}} {name!r} is unknown; use coco, yolo or "
                                         f"coco,yolo")
    if not found:
        raise SettingError("format", "{name} needs at least one of coco, yolo")
    return tuple(f for f in LABEL_FORMATS if f in found)  # canonical order


def _water_text(w: Any) -> str:
    """A water colour as text (a name or R,G,B), checked."""
    if isinstance(w, (list, tuple)) and len(w) == 3:
        try:
            w = ",".join(str(int(c)) for c in w)
        except (TypeError, ValueError, OverflowError):
            raise SettingError("water", f"{{name}} {w!r} is not a colour: use a name "
                                        f"({', '.join(WATER_COLORS)}) or R,G,B of 0-255"
                               ) from None
    parse_water(str(w))  # raises UserError for an unknown name or bad RGB
    return str(w)


def load_toml(path: str | Path) -> dict:
    """The table of a TOML config file (keys = field names), or UserError."""
    p = Path(path)
    try:
        with open(p, "rb") as fh:
            data = tomllib.load(fh)
    except FileNotFoundError:
        raise UserError(f"--config {p}: no such file") from None
    except (OSError, tomllib.TOMLDecodeError, UnicodeDecodeError) as e:
        raise UserError(f"--config {p}: not a readable TOML file ({e})") from None
    if "generate" in data and isinstance(data["generate"], dict):
        data = data["generate"]
    return data


__all__ = ["GeneratorConfig", "ObjectSpec", "PRESETS", "preset", "load_toml"]
