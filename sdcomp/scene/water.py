"""The water of a scene: its colour (a preset name or R,G,B) and turbidity's attenuation."""

from __future__ import annotations

from ..errors import UserError

#: the paper's water colours: sRGB of deep, fully turbid water seen from above
WATER_COLORS: dict[str, tuple[int, int, int]] = {
    "brown": (104, 84, 52),
    "blue": (24, 66, 104),
    "green": (42, 90, 66),
}


ATTENUATION_CLEAR = 0.05  # 1/m at turbidity 0 (clear ocean: visibility ~ 30 m)
ATTENUATION_TURBID = 5.0  # 1/m at turbidity 1 (silty river: visibility ~ 0.3 m)


def parse_water(text: str) -> tuple[str, tuple[int, int, int]]:
    """A water colour: a preset name (``brown``, ``blue``, ``green``) or ``R,G,B`` 0-255.

    Returns (name, sRGB); the name of an RGB colour is the text ``"R,G,B"``.
    """
    t = str(text).strip().lower()
    if t in WATER_COLORS:
        return t, WATER_COLORS[t]
    try:
        values = [int(p) for p in t.split(",")]
    except ValueError:
        values = []
    if len(values) != 3 or not all(0 <= c <= 255 for c in values):
        raise UserError(f"--water {text!r} is not a water colour: use "
                        f"{', '.join(WATER_COLORS)} or R,G,B with 0-255 each")
    r, g, b = values
    return f"{r},{g},{b}", (r, g, b)


def attenuation(turbidity: float) -> float:
    """Beam attenuation coefficient (1/m) of water of ``turbidity`` in [0, 1]: log-linear
    from :data:`ATTENUATION_CLEAR` to :data:`ATTENUATION_TURBID`."""
    return ATTENUATION_CLEAR * (ATTENUATION_TURBID / ATTENUATION_CLEAR) ** float(turbidity)
