"""Randomised scene parameters: a fixed value, a uniform range or a list of choices.

A :class:`Param` is what the generator draws one value of per image. Written as text (command
line) it is ``30`` (always 30), ``10-50`` (uniform in [10, 50]) or ``10,20,30`` (one of the
three, equally likely); in a config file it may also be a number or a list of numbers.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

import numpy as np

from ..errors import SettingError

_NUM = r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?"
_RANGE = re.compile(rf"^\s*({_NUM})\s*(?:-|\.\.|:)\s*({_NUM})\s*$")


@dataclass(frozen=True)
class Param:
    """A per-image random value: uniform in [lo, hi], or one of ``choices`` when given.

    ``integer`` ranges draw whole numbers from lo to hi inclusive.
    """

    lo: float
    hi: float
    choices: tuple[float, ...] = ()
    integer: bool = False

    @property
    def fixed(self) -> bool:
        return not self.choices and self.lo == self.hi

    @property
    def values(self) -> tuple[float, ...]:
        """Every value it can take (choices) or its (lo, hi) bounds."""
        return self.choices or (self.lo, self.hi)

    def sample(self, rng: np.random.Generator) -> float:
        """One value (always consumes exactly one draw from ``rng``, for reproducibility)."""
        u = rng.random()
        if self.choices:
            return self.choices[min(int(u * len(self.choices)), len(self.choices) - 1)]
        if self.integer:
            return float(min(int(self.lo + u * (self.hi - self.lo + 1)), int(self.hi)))
        return self.lo + u * (self.hi - self.lo)

    def sample_at(self, rng: np.random.Generator, at: tuple[int, int] | None) -> float:
        """The value at place ``k`` of its list where it is a list of ``n``, ``at`` = (k, n)
        (a flight log's entry: ``pair_pitch``), else :meth:`sample`'s; one draw from
        ``rng`` either way."""
        u = self.sample(rng)
        return self.choices[at[0]] if at is not None and len(self.choices) == at[1] else u

    def to_json(self):
        """A number, a "lo-hi" string or a list: the form :func:`parse_param` reads back."""
        if self.choices:
            return [_num(c) for c in self.choices]
        if self.lo == self.hi:
            return _num(self.lo)
        return f"{_num(self.lo)}-{_num(self.hi)}"

    def __str__(self) -> str:
        v = self.to_json()
        return ",".join(str(c) for c in v) if isinstance(v, list) else str(v)


def _num(x: float):
    return int(x) if float(x).is_integer() and abs(x) < 1e15 else float(x)


def parse_param(value, name: str, lo: float, hi: float, unit: str = "",
                integer: bool = False) -> Param:
    """Read a :class:`Param` from text or a config-file value, checking it lies in [lo, hi].

    Raises:
        SettingError: naming the setting ``name``, the allowed range and the accepted forms.
    """
    unit_s = f" {unit}" if unit else ""
    form = (f"{{name}} must be a number, a range like {_num(lo)}-{_num(hi)} or a list like "
            f"a,b,c, within {_num(lo)} to {_num(hi)}{unit_s}")
    try:
        p = _read_param(value)
    except (TypeError, ValueError, OverflowError):
        raise SettingError(name, f"{{name}} {value!r} is not valid: {form}") from None
    values = p.values
    if not all(math.isfinite(v) for v in values):
        raise SettingError(name, f"{{name}} {value!r} is not valid: {form}")
    if integer and not all(float(v).is_integer() for v in values):
        raise SettingError(name, f"{{name}} {value!r} must be whole numbers: {form}")
    if not p.choices and p.lo > p.hi:
        raise SettingError(name, f"{{name}} {value!r}: the minimum {_num(p.lo)} is above the "
                                 f"maximum {_num(p.hi)}; write it as {_num(p.hi)}-"
                                 f"{_num(p.lo)}")
    bad = [v for v in values if not lo <= v <= hi]
    if bad:
        raise SettingError(name, f"{{name}} {_num(bad[0])}{unit_s} is out of range: use "
                                 f"{_num(lo)} to {_num(hi)}{unit_s}")
    if p.choices:
        return Param(min(values), max(values), tuple(values), integer)
    return Param(p.lo, p.hi, (), integer)


def _read_param(value) -> Param:
    """The :class:`Param` that ``value`` writes, unchecked: a number (fixed), a list or tuple
    of numbers (choices) or text (``30``, ``10-50``, ``10,20,30``).

    Raises:
        ValueError, TypeError, OverflowError: ``value`` is none of these (a bool, an empty
            list, text that is not a number...); :func:`parse_param` words the error.
    """
    if isinstance(value, bool):
        raise ValueError
    if isinstance(value, (int, float)):
        return Param(float(value), float(value))
    if isinstance(value, (list, tuple)):
        if not value:
            raise ValueError
        return Param(0.0, 0.0, tuple(float(v) for v in value))
    if isinstance(value, str):
        m = _RANGE.match(value)
        if m:
            return Param(float(m.group(1)), float(m.group(2)))
        if "," in value:
            return Param(0.0, 0.0, tuple(float(v) for v in value.split(",")))
        return Param(float(value), float(value))
    raise ValueError
