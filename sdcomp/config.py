"""The generator's configuration: one frozen, validated dataclass, its presets and file form.

Every field of :class:`GeneratorConfig` is a command-line flag (``--field-name``) and a key of
a TOML config file (``field_name`` or ``field-name``). Randomised fields are :class:`Param`
values (``30``, ``10-50`` or ``10,20,30``) drawn once per image. Values are checked in one
place, :meth:`GeneratorConfig.__post_init__`, which also accepts the text and TOML forms, so
``GeneratorConfig(altitude="10-50")`` and ``GeneratorConfig(altitude=30)`` both work.

Precedence: defaults < ``--preset`` < ``--config FILE`` < flags on the command line.
"""

from __future__ import annotations

import difflib
import json
import math
from dataclasses import dataclass, fields, replace
from pathlib import Path

import tomllib

from .camera import PRESETS as CAMERA_PRESETS
from .camera import CameraModel
from .errors import UserError
from .params import Param, parse_param
from .water import WATER_COLORS, parse_water

#: clutter kinds (procedural meshes in :mod:`sdcomp.clutter`)
CLUTTER_KINDS = ("buoy", "log", "boat", "foam")
IMAGE_FORMATS = ("jpg", "png")
#: annotation formats of --format (COCO JSON, Ultralytics YOLO label files)
LABEL_FORMATS = ("coco", "yolo")
MAX_INSTANCES = 999  # objects of interest per image (annotation ids reserve 3 digits)


@dataclass(frozen=True)
class ObjectSpec:
    """An object of interest: a built-in mesh name or a mesh file, and its COCO category."""

    mesh: str = "bluerov2"
    category: str = ""

    def __post_init__(self) -> None:
        if not isinstance(self.mesh, str) or not self.mesh.strip() or "\0" in self.mesh:
            raise UserError("--object needs a built-in mesh name (bluerov2, bluerov2-heavy) "
                            "or a mesh file path")
        if not self.category:
            object.__setattr__(self, "category", Path(self.mesh).stem if Path(
                self.mesh).suffix else self.mesh)
        if not isinstance(self.category, str) or not self.category.strip():
            raise UserError(f"--category {self.category!r} must be a non-empty name")


# name: (flag bounds lo, hi, unit, integer) for every Param field
PARAM_BOUNDS: dict[str, tuple[float, float, str, bool]] = {
    "altitude": (1.0, 1000.0, "m", False),
    "pitch": (15.0, 90.0, "degrees", False),
    "heading": (-360.0, 720.0, "degrees", False),
    "turbidity": (0.0, 1.0, "", False),
    "wind": (0.0, 25.0, "m/s", False),
    "floor_depth": (0.5, 200.0, "m", False),
    "sun_elevation": (5.0, 90.0, "degrees", False),
    "sun_azimuth": (-360.0, 720.0, "degrees", False),
    "ambient": (0.0, 2.0, "", False),
    "count": (0.0, float(MAX_INSTANCES), "objects", True),
    "draft": (-1.0, 100.0, "m", False),
    "exposure": (-3.0, 3.0, "stops", False),
    "white_balance": (0.0, 0.5, "", False),
    "noise": (0.0, 50.0, "", False),
    "vignetting": (0.0, 1.0, "", False),
    "jpeg_quality": (1.0, 100.0, "", True),
}

# name: (lo, hi, unit) for plain float fields
FLOAT_BOUNDS: dict[str, tuple[float, float, str]] = {
    "val_fraction": (0.0, 1.0, ""),
    "tilt": (0.0, 30.0, "degrees"),
    "whitecaps": (0.0, 5.0, ""),
    "clutter": (0.0, 50.0, "objects per image"),
    "rocks": (0.0, 1.0, ""),
    "shore": (0.0, 1.0, ""),
    "hills": (0.0, 1.0, ""),
    "motion_blur": (0.0, 1.0, ""),
    "defocus_blur": (0.0, 1.0, ""),
}

# name: (lo, hi) for plain int fields
INT_BOUNDS: dict[str, tuple[int, int]] = {
    "n": (1, 100_000_000),
    "seed": (0, 2**63 - 1),
    "width": (1, 32_000),
    "height": (1, 32_000),
    "min_visible_px": (1, 100_000_000),
}


@dataclass(frozen=True)
class GeneratorConfig:
    """Everything that decides a generated dataset (with the seed, it fixes every byte).

    Units: metres, degrees (pitch: below the horizon, 90 = straight down), m/s, pixels.
    See ``python -m sdcomp.generate --help`` for each field's meaning.
    """

    # run
    n: int = 2500
    seed: int = 0
    val_fraction: float = 0.2
    image_format: str = "jpg"
    jpeg_quality: Param = "90-95"  # type: ignore[assignment]
    min_visible_px: int = 4
    amodal: bool = False
    format: tuple[str, ...] = ("coco",)  # annotation formats (do not change the images)
    yolo_seg: bool = False  # YOLO polygon labels instead of boxes
    # camera
    camera: str = "mavic2pro"
    fov: float | None = None
    sensor_px: tuple[int, int] | None = None
    width: int = 416
    height: int = 416
    altitude: Param = "10-50"  # type: ignore[assignment]
    pitch: Param = 90  # type: ignore[assignment]
    heading: Param = "0-360"  # type: ignore[assignment]
    # water
    water: tuple[str, ...] = ("brown", "blue", "green")
    turbidity: Param = "0.1-0.9"  # type: ignore[assignment]
    wind: Param = "1-8"  # type: ignore[assignment]
    floor_depth: Param = "2-12"  # type: ignore[assignment]
    whitecaps: float = 1.0
    backgrounds: str | None = None
    # light
    sun_elevation: Param = "25-80"  # type: ignore[assignment]
    sun_azimuth: Param = "0-360"  # type: ignore[assignment]
    ambient: Param = "0.3-0.5"  # type: ignore[assignment]
    shadows: bool = True
    # objects of interest
    objects: tuple[ObjectSpec, ...] = (ObjectSpec("bluerov2", "bluerov2"),)
    count: Param = "1-3"  # type: ignore[assignment]
    draft: Param = "0-0.05"  # type: ignore[assignment]
    tilt: float = 5.0
    # objects of non-interest
    clutter: float = 0.6
    clutter_kinds: tuple[str, ...] = CLUTTER_KINDS
    rocks: float = 0.35
    shore: float = 0.15
    hills: float = 0.7
    # camera effects
    exposure: Param = "-0.3-0.3"  # type: ignore[assignment]
    white_balance: Param = "0-0.06"  # type: ignore[assignment]
    noise: Param = "0-3"  # type: ignore[assignment]
    motion_blur: float = 0.1
    defocus_blur: float = 0.05
    vignetting: Param = "0-0.3"  # type: ignore[assignment]

    def __post_init__(self) -> None:
        def put(name, value):
            object.__setattr__(self, name, value)

        for name, (lo, hi, unit, integer) in PARAM_BOUNDS.items():
            v = getattr(self, name)
            put(name, parse_param(v.to_json() if isinstance(v, Param) else v,
                                  _flag(name), lo, hi, unit, integer))
        for name, (lo, hi, unit) in FLOAT_BOUNDS.items():
            put(name, _check_float(getattr(self, name), name, lo, hi, unit))
        for name, (lo, hi) in INT_BOUNDS.items():
            put(name, _check_int(getattr(self, name), name, lo, hi))
        for name in ("amodal", "shadows", "yolo_seg"):
            if not isinstance(getattr(self, name), bool):
                raise UserError(f"{_flag(name)} must be true or false")
        put("format", _label_formats(self.format))
        if self.image_format not in IMAGE_FORMATS:
            raise UserError(f"--image-format {self.image_format!r} is unknown; use "
                            f"{' or '.join(IMAGE_FORMATS)}")
        # camera
        if self.camera not in (*CAMERA_PRESETS, "custom"):
            raise UserError(f"--camera {self.camera!r} is unknown; use one of "
                            f"{', '.join(CAMERA_PRESETS)} or custom (with --fov, --sensor-px)")
        if self.camera == "custom":
            if self.fov is None or self.sensor_px is None:
                raise UserError("--camera custom needs --fov DEGREES (diagonal) and "
                                "--sensor-px WIDTH,HEIGHT")
        if self.fov is not None:
            put("fov", _check_float(self.fov, "fov", 1.0, 170.0, "degrees"))
        if self.sensor_px is not None:
            sp = _int_pair(self.sensor_px, "sensor_px")
            put("sensor_px", sp)
        self.camera_model()  # validates the combination
        # water
        water = _seq(self.water, "water")
        if not water:
            raise UserError("--water needs at least one colour: "
                            f"{', '.join(WATER_COLORS)} or R,G,B")
        put("water", tuple(_water_text(w) for w in water))
        if self.backgrounds is not None:
            if not isinstance(self.backgrounds, (str, Path)) or "\0" in str(self.backgrounds):
                raise UserError(f"--backgrounds {self.backgrounds!r} must be a folder path")
            put("backgrounds", str(self.backgrounds))
        # objects
        objs = self.objects
        objs = (objs,) if isinstance(objs, (ObjectSpec, dict)) else _seq(objs, "objects",
                                                                          "--object")
        specs = []
        for o in objs:
            if isinstance(o, str):
                o = ObjectSpec(o)
            elif isinstance(o, dict):
                unknown = set(o) - {"mesh", "category"}
                if unknown:
                    raise UserError(f"objects: unknown key {sorted(map(str, unknown))[0]!r}; "
                                    f"use mesh and category")
                o = ObjectSpec(**o)
            elif not isinstance(o, ObjectSpec):
                raise UserError(f"--object {o!r} is not a mesh name or path")
            specs.append(o)
        if not specs:
            raise UserError("--object: give at least one object of interest")
        names = [s.category for s in specs]
        if len(set(names)) != len(names):
            raise UserError(f"--category names must differ between objects: {names}")
        put("objects", tuple(specs))
        kinds = _seq(self.clutter_kinds, "clutter_kinds")
        for k in kinds:
            if k not in CLUTTER_KINDS:
                raise UserError(f"--clutter-kinds {k!r} is unknown; use some of "
                                f"{', '.join(CLUTTER_KINDS)}")
        put("clutter_kinds", tuple(dict.fromkeys(kinds)))

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
        """COCO categories, ids from 1 in the order of ``objects``."""
        return [{"id": i + 1, "name": o.category, "supercategory": "object"}
                for i, o in enumerate(self.objects)]

    # ----------------------------------------------------------------- (de)serialise
    def to_dict(self) -> dict:
        """JSON-able dict that :meth:`from_mapping` reads back to an equal config."""
        out = {}
        for f in fields(self):
            v = getattr(self, f.name)
            if isinstance(v, Param):
                v = v.to_json()
            elif f.name == "objects":
                v = [{"mesh": o.mesh, "category": o.category} for o in v]
            elif isinstance(v, tuple):
                v = list(v)
            out[f.name] = v
        return out

    def to_toml(self) -> str:
        """The whole config as TOML text; ``load_toml`` + :meth:`from_mapping` of it give an
        equal config (``--dump-config`` prints it, ``--config FILE`` reads it back).

        Unset optional fields (None) are left out: their default is None.
        """
        lines = [f"# sdcomp generator config: every field, resolved (sdcomp {_version()})",
                 "# reproduce the run with: sdcomp generate --config THIS_FILE --out DIR"]
        for key, value in self.to_dict().items():
            if value is not None:
                lines.append(f"{key} = {_toml_value(value)}")
        return "\n".join(lines) + "\n"

    @classmethod
    def from_mapping(cls, mapping: dict, base: GeneratorConfig | None = None,
                     source: str = "config") -> GeneratorConfig:
        """A config from a dict of field names (``-`` or ``_``) to values, over ``base``."""
        names = {f.name for f in fields(cls)}
        clean = {}
        for key, value in mapping.items():
            name = str(key).replace("-", "_")
            if name not in names:
                near = difflib.get_close_matches(name, sorted(names), n=1, cutoff=0.6)
                hint = f"did you mean {near[0]!r}? " if near else ""
                raise UserError(f"{source}: unknown key {key!r}; {hint}see "
                                f"`python -m sdcomp.generate --help` for the names")
            clean[name] = value
        return replace(base or cls(), **clean)


def _flag(name: str) -> str:
    return "--" + name.replace("_", "-")


def _check_float(v, name: str, lo: float, hi: float, unit: str) -> float:
    unit_s = f" {unit}" if unit else ""
    try:
        if isinstance(v, bool):
            raise TypeError
        x = float(v)
    except (TypeError, ValueError, OverflowError):
        raise UserError(f"{_flag(name)} {v!r} is not a number: use {lo:g} to {hi:g}"
                        f"{unit_s}") from None
    if not (math.isfinite(x) and lo <= x <= hi):
        raise UserError(f"{_flag(name)} {v!r} is out of range: use {lo:g} to {hi:g}{unit_s}")
    return x


def _check_int(v, name: str, lo: int, hi: int) -> int:
    if isinstance(v, bool) or not isinstance(v, (int, float)) or (
            isinstance(v, float) and not v.is_integer()):
        try:
            v = int(str(v).strip())
        except ValueError:
            raise UserError(f"{_flag(name)} {v!r} is not a whole number: use {lo} to "
                            f"{hi}") from None
    v = int(v)
    if not lo <= v <= hi:
        raise UserError(f"{_flag(name)} {v} is out of range: use {lo} to {hi}")
    return v


def _int_pair(v, name: str) -> tuple[int, int]:
    if isinstance(v, str):
        v = v.replace("x", ",").split(",")
    try:
        a, b = (int(x) for x in v)
    except (TypeError, ValueError, OverflowError):
        raise UserError(f"{_flag(name)} {v!r} must be WIDTH,HEIGHT in pixels") from None
    if not (1 <= a <= 100_000 and 1 <= b <= 100_000):
        raise UserError(f"{_flag(name)} {a},{b} is out of range: use 1 to 100000 pixels")
    return a, b


def _version() -> str:
    from . import __version__
    return __version__


def _toml_value(v) -> str:
    """TOML text of a JSON-like value: bool, int, float, str, list, dict (inline table)."""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        return repr(v)  # shortest round-trip form; finite (checked), valid TOML
    if isinstance(v, str):
        return json.dumps(v)  # a TOML basic string
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{" + ", ".join(f"{json.dumps(str(k))} = {_toml_value(x)}"
                               for k, x in v.items()) + "}"
    raise TypeError(f"no TOML form for {type(v).__name__}")


def _label_formats(v) -> tuple[str, ...]:
    items = [v] if isinstance(v, str) else list(v) if isinstance(v, (list, tuple)) else None
    if items is None or not all(isinstance(x, str) for x in items):
        raise UserError(f"--format {v!r} must be coco, yolo or coco,yolo")
    names = [x.strip().lower() for item in items for x in item.split(",") if x.strip()]
    for name in names:
        if name not in LABEL_FORMATS:
            raise UserError(f"--format {name!r} is unknown; use coco, yolo or coco,yolo")
    if not names:
        raise UserError("--format needs at least one of coco, yolo")
    return tuple(f for f in LABEL_FORMATS if f in names)  # canonical order


def _seq(v, name: str, flag: str = "") -> tuple:
    """A list-valued field as a tuple: one text is a list of one; UserError for the rest."""
    if isinstance(v, str):
        return (v,)
    if isinstance(v, (list, tuple)):
        return tuple(v)
    raise UserError(f"{flag or _flag(name)} {v!r} must be a name or a list of names")


def _water_text(w) -> str:
    if isinstance(w, (list, tuple)) and len(w) == 3:
        try:
            w = ",".join(str(int(c)) for c in w)
        except (TypeError, ValueError, OverflowError):
            raise UserError(f"--water {w!r} is not a colour: use a name "
                            f"({', '.join(WATER_COLORS)}) or R,G,B of 0-255") from None
    parse_water(str(w))  # raises UserError for an unknown name or bad RGB
    return str(w)


# --------------------------------------------------------------------------- presets

def _paper(**kw) -> dict:
    # the paper's datasets: one BlueROV2 per image, 416 x 416
    return {"objects": [{"mesh": "bluerov2", "category": "bluerov2"}], "count": 1,
            "width": 416, "height": 416, **kw}


#: named presets: field values applied over the defaults
PRESETS: dict[str, dict] = {
    **{f"paper-alt{a}": _paper(water=["brown"], altitude=a) for a in (10, 20, 30, 40, 50)},
    "paper-brown": _paper(water=["brown"], altitude=10),
    "paper-blue": _paper(water=["blue"], altitude=10),
    "paper-green": _paper(water=["green"], altitude=10),
}


def preset(name: str) -> dict:
    if name not in PRESETS:
        raise UserError(f"--preset {name!r} is unknown; use one of {', '.join(PRESETS)}")
    return dict(PRESETS[name])


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
