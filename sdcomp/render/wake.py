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
RASTER_MAX = 1024  # pixels: the wake raster's longer side at most


def wake_strength(speed: float) -> tuple[float, float]:
    """(peak coverage of the turbulent wake, of the Kelvin arms) at ``speed`` m/s: a faint
    streak just above :data:`SPEED_MIN`, white water near :data:`FOAM_SPEED`."""
    if speed < SPEED_MIN:
        return 0.0, 0.0
    core = min(0.15 + 0.6 * (speed - SPEED_MIN) / (FOAM_SPEED - SPEED_MIN), 0.75)
    arms = 0.0 if speed < ARM_SPEED else min(0.1 + 0.05 * (speed - ARM_SPEED), 0.45)
    return core, arms


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
    most :data:`RASTER_MAX`); broken into patches by a smooth random field of ``seed``.
    None when there is no visible wake."""
    core, arms = wake_strength(speed)
    if core <= 0.0:
        return None
    back, side = wake_extent(length, beam, speed)
    front = length / 2 + beam
    res = max(res, (back + front) / RASTER_MAX, 2 * side / RASTER_MAX)
    w, h = int(math.ceil((back + front) / res)) + 1, int(math.ceil(2 * side / res)) + 1
    u = (np.arange(w, dtype=np.float32) * res - front)[None, :]
    v = (np.arange(h, dtype=np.float32) * res - side)[:, None]
    # turbulent wake: from the stern, half-width growing from half the beam, fading with age
    behind = u - length / 2
    half = beam / 2 + 0.03 * np.maximum(behind, 0.0)
    age = np.maximum(behind, 0.0) / max(WAKE_SECONDS * speed, 1e-6)
    cover = np.where(behind > 0, np.exp(-(v / half) ** 2) * np.exp(-3.0 * age), 0.0) * core
    if arms > 0:
        # the Kelvin arms: from the bow, at the cusp angle either side of the track
        along = u + length / 2
        reach = min(ARM_SECONDS * speed, WAKE_MAX)
        off = np.abs(v) - along * math.tan(math.radians(KELVIN_HALF_ANGLE))
        width = 0.15 * beam + 0.02 * np.maximum(along, 0.0)
        line = np.exp(-(off / width) ** 2) * np.exp(-2.0 * np.maximum(along, 0) / reach)
        cover = np.maximum(cover, np.where(along > 0, line, 0.0) * arms)
    cover = cover.astype(np.float32)
    rng = np.random.default_rng([*seed, 0x3A4E])
    cell = max(1, int(round(0.3 / res)))  # foam patches about 0.3 m across
    coarse = rng.standard_normal((h // cell + 2, w // cell + 2)).astype(np.float32)
    field = np.asarray(cv2.resize(coarse, (coarse.shape[1] * cell, coarse.shape[0] * cell),
                                  interpolation=cv2.INTER_LINEAR)[:h, :w], np.float32)
    field /= np.float32(max(float(field.std()), 1e-6))
    cover = (cover * np.clip(0.55 + 0.45 * field, 0.0, 1.0)).astype(np.float32)
    return np.minimum(cover, 1.0), front, side, res


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
