"""The water behind a moving object: its wake, seen from the air.

A hull under way leaves two things on the water (Kelvin 1887; aerial photographs of boats):

- the **turbulent wake**: a band of churned, foamy water straight behind the stern, about the
  hull's beam wide, widening slowly and fading over tens of seconds of travel; white behind
  a fast motorboat, a faint lighter streak behind a slow one;
- the **Kelvin wave pattern**: waves confined to a wedge of half-angle 19.47 degrees behind
  the bow, whose divergent crests show from the air as two thin bright lines (breaking
  crests, foam streaks) along the wedge's arms, strong for fast planing hulls and invisible
  below about 1 m/s.

Both are drawn as foam coverage (:class:`~sdcomp.render.foam.FoamRing`, lit like the water's
surface, under every object and never annotated) from a raster in the object's track frame
on the water: ``u`` metres behind the object's centre along its track, ``v`` metres across.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

KELVIN_HALF_ANGLE = math.degrees(math.asin(1.0 / 3.0))  # 19.47 degrees
WAKE_SECONDS = 12.0  # s: how long the turbulent wake stays visible behind the object
WAKE_MAX = 60.0  # m: longest wake drawn
ARM_SECONDS = 5.0  # s: the Kelvin arms' visible length, in seconds of travel
SPEED_MIN = 0.3  # m/s: slower objects leave no visible wake
ARM_SPEED = 1.5  # m/s: the Kelvin arms show from this speed on
FOAM_SPEED = 8.0  # m/s: the turbulent wake is fully white from this speed on
PLANE_FROM = 4.0  # m/s: below this a hull displaces water (Kelvin's wedge)
PLANE_SPEED = 8.0  # m/s: a hull planes from about this speed on (its wake white water)
WING_ANGLE = 12.0  # degrees: half-angle of a planing hull's white water either side
WING_LENGTHS = 2.5  # hull lengths over which that white water fades
FOAM_SECONDS = 2.5  # s: the white water behind a hull breaks up over about this long
SCAR = 0.15  # of the peak: the smooth, lighter scar the wake leaves for WAKE_SECONDS
RASTER_MAX = 1024  # pixels: the wake raster's longer side at most


def wake_strength(speed: float) -> tuple[float, float]:
    """(peak coverage of the turbulent wake, of the Kelvin arms) at ``speed`` m/s: a faint
    streak just above :data:`SPEED_MIN`, white water near :data:`FOAM_SPEED` (a planing hull's
    prop wash is all foam)."""
    if speed < SPEED_MIN:
        return 0.0, 0.0
    core = min(0.15 + 0.8 * (speed - SPEED_MIN) / (FOAM_SPEED - SPEED_MIN), 0.95)
    arms = 0.0 if speed < ARM_SPEED else min(0.06 + 0.03 * (speed - ARM_SPEED), 0.25)
    return core, arms


def planing(speed: float) -> float:
    """0 (displacement speeds, up to :data:`PLANE_FROM`) to 1 (a hull planing at
    :data:`PLANE_SPEED` and over): how much of the near wake is the churned white water of a
    planing hull, whose visible wake is narrower than Kelvin's wedge (Rabaud & Moisy 2013:
    the angle falls as 1 / Froude number at high speed)."""
    return float(np.clip((speed - PLANE_FROM) / (PLANE_SPEED - PLANE_FROM), 0.0, 1.0))


def foam_texture(shape: tuple[int, int], res: float, seed: tuple[int, ...]) -> np.ndarray:
    """(h, w) float32 zero-mean, unit-std turbulent foam field of a raster of ``res`` metres
    per pixel (columns along the track): noise smoothed at three scales, 0.1, 0.35 and 1.2 m
    across the track and three times that along it (foam is drawn out into streaks behind a
    hull), the finer scales weighted more (a broken, bubbly surface). Each scale is drawn
    on a grid of about a third of its size and magnified (bilinear), so its cost does not
    grow with the raster."""
    h, w = shape
    rng = np.random.default_rng([*seed, 0x3A4E])
    field = np.zeros((h, w), np.float32)
    for scale_m, weight in ((0.1, 1.0), (0.35, 0.8), (1.2, 0.6)):
        cv = max(scale_m / 3.0 / res, 1.0)  # raster pixels per grid cell, across
        gh, gw = int(h / cv) + 2, int(w / (3.0 * cv)) + 2
        noise = rng.random((gh, gw), dtype=np.float32)
        up = cv2.resize(noise, (w, h), interpolation=cv2.INTER_CUBIC)
        up = up - np.float32(up.mean())
        field += np.float32(weight) * (up / np.float32(max(float(up.std()), 1e-6)))
    return field / np.float32(max(float(field.std()), 1e-6))


def wake_extent(length: float, beam: float, speed: float) -> tuple[float, float]:
    """(metres behind the object's centre, metres either side of its track) that the wake of
    a hull ``length`` x ``beam`` metres at ``speed`` m/s covers."""
    back = min(WAKE_SECONDS * speed, WAKE_MAX) + length / 2
    arms = min(ARM_SECONDS * speed, WAKE_MAX) if speed >= ARM_SPEED else 0.0
    side = max(beam, (arms + length) * math.tan(math.radians(KELVIN_HALF_ANGLE))) + beam
    return back, side


def wake_cover(length: float, beam: float, speed: float, res: float,
               seed: tuple[int, ...]) -> tuple[np.ndarray, float, float, float] | None:
    """The wake of a hull ``length`` x ``beam`` metres moving at ``speed`` m/s as a coverage
    raster: ((h, w) float32 in [0, 1], u0, v0, res) where raster pixel (row j, column i) covers
    the water at ``u = i res - u0`` metres behind the object's centre and ``v = j res - v0``
    across its track (``res`` metres per pixel, raised so the raster's longer side is at
    most :data:`RASTER_MAX`). None when there is no visible wake.

    Three parts: the turbulent wake from the stern, flat-topped across (ragged edges),
    widening and fading with age; for a planing hull (:func:`planing`) two bands of white
    water from the transom's corners diverging at :data:`WING_ANGLE` over the first
    :data:`WING_LENGTHS` hull lengths; the Kelvin arms from the bow at the cusp angle. All
    are foam broken by :func:`foam_texture`: solid near the hull, falling apart into
    streaks and patches as it ages."""
    core, arms = wake_strength(speed)
    if core <= 0.0:
        return None
    plane = planing(speed)
    back, side = wake_extent(length, beam, speed)
    front = length / 2 + beam
    res = max(res, (back + front) / RASTER_MAX, 2 * side / RASTER_MAX)
    w, h = int(math.ceil((back + front) / res)) + 1, int(math.ceil(2 * side / res)) + 1
    u = np.arange(w, dtype=np.float32) * np.float32(res) - np.float32(front)  # (w,)
    v = (np.arange(h, dtype=np.float32) * np.float32(res) - np.float32(side))[:, None]
    behind = np.maximum(u - np.float32(length / 2), 0.0)
    astern = (u > length / 2).astype(np.float32)
    seconds = behind / np.float32(max(speed, 1e-6))  # since the stern passed
    half = np.float32(beam * (0.45 + 0.25 * plane)) + np.float32(0.04) * behind
    q = (v / half) ** 2
    across = np.exp(-(q * q)) * astern  # flat-topped: ragged edges come from the texture
    # white water that breaks up in seconds, then a faint smooth scar that lasts
    white = across * (np.exp(-seconds / np.float32(FOAM_SECONDS)) * np.float32(core))
    scar = across * (np.exp(-3.0 * seconds / np.float32(WAKE_SECONDS)) * np.float32(SCAR * core))
    av = np.abs(v)
    if plane > 0:
        # the stern's white water thrown out either side at the wing angle
        off = av - (np.float32(beam / 2) + behind * np.float32(math.tan(math.radians(WING_ANGLE))))
        width = np.float32(0.2 * beam) + np.float32(0.05) * behind
        fade = np.exp(-behind / np.float32(WING_LENGTHS * length)) * astern * np.float32(
            0.9 * plane)
        np.maximum(white, np.exp(-(off / width) ** 2) * fade, out=white)
    if arms > 0:
        # the Kelvin arms: from the bow, at the cusp angle either side of the track
        along = np.maximum(u + np.float32(length / 2), 0.0)
        reach = min(ARM_SECONDS * speed, WAKE_MAX)
        off = av - along * np.float32(math.tan(math.radians(KELVIN_HALF_ANGLE)))
        width = np.float32(0.15 * beam) + np.float32(0.02) * along
        fade = np.exp(-2.0 * along / np.float32(reach)) * (u + length / 2 > 0) * np.float32(arms)
        np.maximum(white, np.exp(-(off / width) ** 2) * fade.astype(np.float32), out=white)
    field = foam_texture((h, w), res, seed)
    # young foam is solid, old foam breaks up into streaks: the threshold rises with age
    age = np.minimum(seconds / np.float32(FOAM_SECONDS), 2.0)
    broken = field * np.float32(0.5) + (np.float32(1.2) - np.float32(0.55) * age)
    np.clip(broken, 0.0, 1.0, out=broken)
    cover = np.maximum(white * broken, scar)
    np.minimum(cover, 1.0, out=cover)
    return cover.astype(np.float32, copy=False), front, side, res


def place_wake(shape: tuple[int, int], u0: float, v0: float, res: float, track: np.ndarray,
               jac: np.ndarray, centre: np.ndarray, width: int, height: int
               ) -> tuple[np.ndarray, tuple[int, int, int, int]] | None:
    """(affine (2, 3) float64 raster pixels -> roi pixels, roi (x0, y0, x1, y1) inside the
    ``width`` x ``height`` frame) of a :func:`wake_cover` raster of ``shape`` (h, w): the
    object's ``track`` (2,) unit vector on the water (world x, y), ``jac`` (2, 2) frame pixels
    per world metre (x, y) at the object, ``centre`` (2,) the frame pixel of its centre on
    the water. None when the wake misses the frame."""
    t = np.asarray(track, np.float64)
    n = np.array([-t[1], t[0]])
    m = np.empty((2, 3))
    m[:, 0] = -res * (jac @ t)
    m[:, 1] = res * (jac @ n)
    m[:, 2] = centre + jac @ (u0 * t - v0 * n)
    h, w = shape
    corners = np.array([[-0.5, -0.5, 1], [w - 0.5, -0.5, 1], [-0.5, h - 0.5, 1],
                        [w - 0.5, h - 0.5, 1]]) @ m.T
    x0, y0 = max(math.floor(corners[:, 0].min()), 0), max(math.floor(corners[:, 1].min()), 0)
    x1 = min(math.ceil(corners[:, 0].max()) + 1, width)
    y1 = min(math.ceil(corners[:, 1].max()) + 1, height)
    if x1 <= x0 or y1 <= y0:
        return None
    m[:, 2] -= (x0, y0)
    return m, (x0, y0, x1, y1)
