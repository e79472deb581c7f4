"""What a video run makes: :class:`VideoConfig`, the generator's config plus the settings of
sequences (how many, how long, at what frame rate, how the drone flies, how the water
carries things). Declared once with their kind, bounds and help (:func:`setting`), as the
generator's fields are; the command line (:mod:`sdcomp.cli.video`) makes a flag of each.

Units: seconds, frames per second, metres per second.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from typing import Any

from ..errors import SettingError
from .config import GeneratorConfig
from .flight import FLIGHTS
from .params import Param
from .settings import names, setting, setting_of


def sequence_split(s: int, val_fraction: float) -> str:
    """``"val"`` or ``"train"`` for sequence ``s``: whole sequences, never frames of one
    across splits. Sequence ``s`` is val when ``floor((s + 1) f) > floor(s f)``, so the first
    ``n`` sequences hold exactly ``floor(n f)`` val ones, spread evenly (f = 0.2: sequences
    4, 9, 14, ...), whatever ``--sequences`` a run or its ``--resume`` asks for."""
    f = float(val_fraction)
    before, upto = math.floor(round(s * f, 9)), math.floor(round((s + 1) * f, 9))
    return "val" if upto > before else "train"


@dataclass(frozen=True)
class VideoConfig:
    """A video run: ``generator`` (every image option, drawn once per sequence unless it is
    naturally per frame) and the fields below."""

    generator: GeneratorConfig = GeneratorConfig()
    sequences: int = setting(4, "int", "number of sequences (clips)", "N", 1, 1_000_000)
    frames: int = setting(150, "int", "frames per sequence", "N", 1, 1_000_000)
    fps: float = setting(30.0, "float", "frames per second", "FPS", 0.1, 240.0)
    flight: tuple[str, ...] = setting(FLIGHTS, "custom", "how the drone flies, one drawn per "
                                      "sequence: " + ", ".join(FLIGHTS), "KIND")
    speed: Param = setting("3-8", "param", "flight speed along the path, m/s (per sequence)",
                           "M/S", 0.0, 25.0, "m/s")
    current: Param = setting("0-0.4", "param", "surface current carrying everything afloat, "
                             "m/s (per sequence, in a random direction)", "M/S", 0.0, 3.0,
                             "m/s")
    leeway: float = setting(0.03, "float", "wind drift of floating things as a fraction of "
                            "the wind speed", "F", 0.0, 0.2)
    mp4: bool = setting(False, "bool", "also write an MP4 per sequence (OpenCV's writer)")
    latitude: float = setting(47.6715, "float", "latitude of where the flights start, "
                              "degrees (the metadata's GPS positions)", "DEG", -85.0, 85.0)
    longitude: float = setting(9.2706, "float", "longitude of where the flights start, "
                               "degrees", "DEG", -180.0, 180.0)

    def __post_init__(self) -> None:
        if not isinstance(self.generator, GeneratorConfig):
            raise TypeError("generator must be a GeneratorConfig")
        for f in fields(self):
            if f.name == "generator":
                continue
            object.__setattr__(self, f.name, setting_of(f).check(f.name, getattr(self, f.name)))
        kinds = tuple(str(k).strip().lower() for k in names(self.flight, "flight"))
        bad = [k for k in kinds if k not in FLIGHTS]
        if bad or not kinds:
            raise SettingError("flight", f"{{name}} {bad[0] if bad else ''!r} is not a flight: "
                                         f"use {', '.join(FLIGHTS)}")
        object.__setattr__(self, "flight", kinds)
        if self.generator.backgrounds:
            raise SettingError("backgrounds", "{name} (photos) cannot be flown over: a video "
                                              "needs a sea that moves with the camera; drop "
                                              "{name} for sdcomp video")

    @property
    def duration(self) -> float:
        """Seconds per sequence."""
        return self.frames / self.fps

    def to_dict(self) -> dict[str, Any]:
        """JSON-able: the video fields and ``generator`` (its own dict)."""
        out: dict[str, Any] = {}
        for f in fields(self):
            v = getattr(self, f.name)
            if f.name == "generator":
                v = v.to_dict()
            elif isinstance(v, Param):
                v = v.to_json()
            elif isinstance(v, tuple):
                v = list(v)
            out[f.name] = v
        return out

    @classmethod
    def video_fields(cls) -> list:
        """The dataclass fields of the video settings (not ``generator``)."""
        return [f for f in fields(cls) if f.name != "generator"]
