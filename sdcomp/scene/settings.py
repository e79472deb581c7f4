"""How a config field is declared once: its kind, bounds, unit, and how it is shown.

A field of :class:`~sdcomp.scene.config.GeneratorConfig` is declared with :func:`setting`,
which stores a :class:`Setting` in the field's metadata: the check applied to its value
(:meth:`Setting.check`), and the metavar and help text the command line shows. A bad value
raises :class:`SettingError`, which names the setting as Python and config files spell it
(``altitude``); the command line reports it as the flag (``--altitude``,
:func:`sdcomp.errors.run_cli`).
"""

from __future__ import annotations

import dataclasses
import json
import math
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..errors import SettingError, UserError
from .params import Param, parse_param

#: fields of earlier versions and what took their place: a config naming one still loads
#: (with a warning), the value is not used
RETIRED = {
    "ambient": "the sky model sets the light from the sky",
    "white_balance": "--wb-red and --wb-blue set it (--look draws it by default)",
    "noise": "--look draws the sensor noise per image (--shot-noise fixes its shot noise)",
    "vignetting": "--look draws the vignetting per image",
    "exposure": "the camera exposes automatically; --exposure-bias sets its bias",
    "rocks": "the sea floor is sand (--shallow, --floor-depth)",
}
#: kinds of :class:`Setting` whose check is :meth:`Setting.check`; "custom" fields are
#: checked by the config itself
KINDS = ("param", "float", "int", "bool", "path", "custom")


@dataclass(frozen=True)
class Setting:
    """A config field's declaration (see the module docstring).

    ``kind``: "param" (a :class:`Param`: a value, range or list drawn per image), "float",
    "int", "bool", "path" (a file or folder path, or None) or "custom"; ``lo``/``hi``:
    inclusive bounds; ``unit``: shown after numbers; ``integer``: whole-number params;
    ``optional``: None is a value (unset); ``metavar``, ``help``: the command line's."""

    kind: str
    help: str
    metavar: str = ""
    lo: float = -math.inf
    hi: float = math.inf
    unit: str = ""
    integer: bool = False
    optional: bool = False

    def check(self, name: str, value: Any) -> Any:
        """``value`` checked and normalised for the field ``name``; SettingError when bad.
        Custom settings are returned as they are."""
        if value is None and self.optional:
            return None
        if self.kind == "param":
            v = value.to_json() if isinstance(value, Param) else value
            return parse_param(v, name, self.lo, self.hi, self.unit, self.integer)
        if self.kind == "float":
            return check_float(value, name, self.lo, self.hi, self.unit)
        if self.kind == "int":
            return check_int(value, name, int(self.lo), int(self.hi))
        if self.kind == "bool":
            if not isinstance(value, bool):
                raise SettingError(name, "{name} must be true or false")
            return value
        if self.kind == "path" and value is not None:
            if self.optional and str(value).lower() == "none":
                return None  # --grade none: unset what a config file set
            return path_text(value, name)
        return value


def setting(default: Any, kind: str, help: str, metavar: str = "", lo: float = -math.inf,
            hi: float = math.inf, unit: str = "", integer: bool = False) -> Any:
    """A dataclass field with ``default`` and its :class:`Setting` in the metadata (a
    default of None makes the setting optional: None stays None)."""
    assert kind in KINDS, kind
    return dataclasses.field(default=default, metadata={
        "setting": Setting(kind, help, metavar, lo, hi, unit, integer, default is None)})


def setting_of(field: dataclasses.Field) -> Setting:
    """The :class:`Setting` of a field declared with :func:`setting`."""
    return field.metadata["setting"]


def check_float(v: Any, name: str, lo: float, hi: float, unit: str = "") -> float:
    """``v`` as a finite float in [lo, hi]; SettingError naming ``name`` otherwise."""
    unit_s = f" {unit}" if unit else ""
    try:
        if isinstance(v, bool):
            raise TypeError
        x = float(v)
    except (TypeError, ValueError, OverflowError):
        raise SettingError(name, f"{{name}} {v!r} is not a number: use {lo:g} to {hi:g}"
                                 f"{unit_s}") from None
    if not (math.isfinite(x) and lo <= x <= hi):
        raise SettingError(name, f"{{name}} {v!r} is out of range: use {lo:g} to {hi:g}"
                                 f"{unit_s}")
    return x


def check_int(v: Any, name: str, lo: int, hi: int) -> int:
    """``v`` as an int in [lo, hi] (whole floats and numeric text accepted)."""
    if isinstance(v, bool) or not isinstance(v, (int, float)) or (
            isinstance(v, float) and not v.is_integer()):
        try:
            v = int(str(v).strip())
        except ValueError:
            raise SettingError(name, f"{{name}} {v!r} is not a whole number: use {lo} to "
                                     f"{hi}") from None
    v = int(v)
    if not lo <= v <= hi:
        raise SettingError(name, f"{{name}} {v} is out of range: use {lo} to {hi}")
    return v


def int_pair(v: Any, name: str) -> tuple[int, int]:
    """``v`` ("W,H", "WxH" or a pair) as two ints in 1..100000."""
    if isinstance(v, str):
        v = v.replace("x", ",").split(",")
    try:
        a, b = (int(x) for x in v)
    except (TypeError, ValueError, OverflowError):
        raise SettingError(name, f"{{name}} {v!r} must be WIDTH,HEIGHT in pixels") from None
    if not (1 <= a <= 100_000 and 1 <= b <= 100_000):
        raise SettingError(name, f"{{name}} {a},{b} is out of range: use 1 to 100000 pixels")
    return a, b


def path_text(v: Any, name: str) -> str:
    """``v`` (text or a :class:`~pathlib.Path`) as path text; SettingError otherwise."""
    if not isinstance(v, (str, Path)) or "\0" in str(v):
        raise SettingError(name, f"{{name}} {v!r} must be a file or folder path")
    return str(v)


def names(v: Any, name: str) -> tuple:
    """A list-valued field as a tuple: one text is a list of one; SettingError for the
    rest."""
    if isinstance(v, str):
        return (v,)
    if isinstance(v, (list, tuple)):
        return tuple(v)
    raise SettingError(name, f"{{name}} {v!r} must be a name or a list of names")


def choice_list(v: Any, name: str, known: tuple[str, ...], *, empty: bool = False
                ) -> tuple[str, ...]:
    """A list-valued field of names from ``known`` (``a,b`` text, a list, or a list of such
    texts; case-insensitive) in the order of ``known`` (the canonical one), each once.
    SettingError names the bad value; an empty list only when ``empty``."""
    items = [v] if isinstance(v, str) else list(v) if isinstance(v, (list, tuple)) else None
    every = ", ".join(known)
    if items is None or not all(isinstance(x, str) for x in items):
        raise SettingError(name, f"{{name}} {v!r} must be one or more of {every}")
    found = [x.strip().lower() for item in items for x in item.split(",") if x.strip()]
    for item in found:
        if item not in known:
            raise SettingError(name, f"{{name}} {item!r} is unknown; use {every} (comma-"
                                     f"separated for several)")
    if not found and not empty:
        raise SettingError(name, f"{{name}} needs at least one of {every}")
    return tuple(f for f in known if f in found)


def toml_value(v: Any) -> str:
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
        return "[" + ", ".join(toml_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{" + ", ".join(f"{json.dumps(str(k))} = {toml_value(x)}"
                               for k, x in v.items()) + "}"
    raise TypeError(f"no TOML form for {type(v).__name__}")


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
    grade = data.get("grade")
    if isinstance(grade, str) and grade and not Path(grade).is_absolute():
        data = {**data, "grade": str(p.parent / grade)}  # beside the config file
    return data
