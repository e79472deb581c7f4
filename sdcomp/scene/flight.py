"""How a drone flies through a sequence: a :class:`Flight` is the camera's path as a smooth,
analytic function of time, drawn once per sequence (:func:`draw_flight`).

Kinds (:data:`FLIGHTS`): ``hover`` (station keeping with a small drift), ``pass`` (a
straight pass at constant speed), ``orbit`` (a circle around the point the camera looks
at), ``lawnmower`` (a search pattern: parallel legs joined by half-circle turns) and
``random`` (a smooth wander). Every kind adds a slow altitude change and a slow gimbal
change within the configured ranges, hover drift and gimbal jitter. Accelerations stay
below :data:`MAX_ACCEL` (a DJI-like multirotor's), so the camera never jumps.

The state at time ``t`` depends only on the flight's parameters and ``t`` (not on the
number of frames, nor on earlier frames): frame ``k`` of a sequence is ``state(k / fps)``.
World frame of :mod:`sdcomp.scene.camera` (metres, x east, y north; headings degrees
counter-clockwise from +x); the flight starts above the world origin.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .camera import ALTITUDE_RANGE, PITCH_RANGE

FLIGHTS = ("hover", "pass", "orbit", "lawnmower", "random")
MAX_ACCEL = 2.0  # m/s^2: the largest horizontal acceleration a path asks for
HOVER_DRIFT = 0.4  # m: amplitude of a hovering drone's position drift
JITTER = 0.25  # degrees: gimbal jitter amplitude (pitch and yaw)
ALT_WANDER = 2.0  # m: the largest slow altitude change around the start
PITCH_WANDER = 4.0  # degrees: the largest slow gimbal change around the start


@dataclass(frozen=True)
class Wander:
    """A smooth bounded signal: a sum of sines ``sum a_i sin(w_i t + p_i)`` (arrays (3,))."""

    amp: tuple[float, ...]
    omega: tuple[float, ...]
    phase: tuple[float, ...]

    @classmethod
    def draw(cls, rng: np.random.Generator, amplitude: float, period: float) -> Wander:
        """Three sines of periods ``period`` x [0.6, 1.6] with amplitudes summing to
        ``amplitude`` (so the signal stays within +-amplitude)."""
        w = rng.uniform(0.5, 1.0, 3)
        periods = period * rng.uniform(0.6, 1.6, 3)
        return cls(tuple(float(a) for a in amplitude * w / w.sum()),
                   tuple(float(2 * math.pi / p) for p in periods),
                   tuple(float(p) for p in rng.uniform(0, 2 * math.pi, 3)))

    def at(self, t: np.ndarray | float) -> np.ndarray:
        """The signal at times ``t`` (seconds, any shape)."""
        t = np.asarray(t, np.float64)
        terms = zip(self.amp, self.omega, self.phase, strict=True)
        return sum((a * np.sin(w * t + p) for a, w, p in terms), np.zeros_like(t))

    def rate(self, t: np.ndarray | float) -> np.ndarray:
        """Its time derivative at ``t`` (units per second)."""
        t = np.asarray(t, np.float64)
        terms = zip(self.amp, self.omega, self.phase, strict=True)
        return sum((a * w * np.cos(w * t + p) for a, w, p in terms), np.zeros_like(t))


def _safe_period(amplitude: float, period: float) -> float:
    """The shortest period at least ``period`` whose sines of ``amplitude`` (metres)
    accelerate by at most MAX_ACCEL / 4 (the slowest of the three sines has 0.6 x it)."""
    return max(period, 2 * math.pi * math.sqrt(max(amplitude, 1e-9) / (MAX_ACCEL / 4)) / 0.6)


@dataclass(frozen=True)
class FlightState:
    """The camera at times ``t`` (arrays of one shape): world position ``x``, ``y`` (m),
    ``altitude`` (m), ``heading`` and ``pitch`` (degrees) and velocity ``vx``, ``vy``,
    ``vz`` (m/s)."""

    t: np.ndarray
    x: np.ndarray
    y: np.ndarray
    altitude: np.ndarray
    heading: np.ndarray
    pitch: np.ndarray
    vx: np.ndarray
    vy: np.ndarray
    vz: np.ndarray

    @property
    def speed(self) -> np.ndarray:
        """Horizontal speed, m/s."""
        return np.hypot(self.vx, self.vy)


@dataclass(frozen=True)
class Flight:
    """One sequence's flight (see the module docstring): ``kind``, start ``altitude`` (m),
    ``pitch`` and ``heading`` (degrees), ``speed`` (m/s along the path), ``direction``
    (degrees: the path's direction at the start), ``follow`` (the camera's heading follows
    the path; False: held at ``heading``), the pattern's size ``radius`` (orbit radius,
    half the lawnmower's leg spacing, m) and ``leg`` (lawnmower leg length, m), ``turn``
    (+1 counter-clockwise, -1 clockwise), the altitude and pitch bounds, and the
    wanders (altitude, pitch, position drift x/y, jitter pitch/yaw, random-path x/y)."""

    kind: str
    altitude: float
    pitch: float
    heading: float
    speed: float
    direction: float
    follow: bool
    radius: float
    leg: float
    turn: float
    alt_bounds: tuple[float, float]
    pitch_bounds: tuple[float, float]
    alt_wander: Wander
    pitch_wander: Wander
    drift_x: Wander
    drift_y: Wander
    jitter_pitch: Wander
    jitter_yaw: Wander
    path_x: Wander
    path_y: Wander

    def state(self, t) -> FlightState:
        """The camera at times ``t`` seconds (scalar or array)."""
        t = np.asarray(t, np.float64)
        px, py, vx, vy, yaw = self._path(t)
        px = px + self.drift_x.at(t)
        py = py + self.drift_y.at(t)
        vx = vx + self.drift_x.rate(t)
        vy = vy + self.drift_y.rate(t)
        lo, hi = self.alt_bounds
        alt = np.clip(self.altitude + self.alt_wander.at(t), lo, hi)
        vz = np.where((alt > lo) & (alt < hi), self.alt_wander.rate(t), 0.0)
        plo, phi = self.pitch_bounds
        pitch = np.clip(self.pitch + self.pitch_wander.at(t) + self.jitter_pitch.at(t),
                        plo, phi)
        heading = (yaw + self.jitter_yaw.at(t)) % 360.0
        return FlightState(t, px, py, alt, heading, pitch, vx, vy, vz)

    def _path(self, t: np.ndarray):
        """(x, y, vx, vy, camera heading) of the path without drift or jitter."""
        d = math.radians(self.direction)
        ux, uy = math.cos(d), math.sin(d)
        zero = np.zeros_like(t)
        if self.kind == "hover":
            return zero, zero, zero, zero, zero + self.heading
        if self.kind == "pass":
            s = self.speed * t
            return s * ux, s * uy, zero + self.speed * ux, zero + self.speed * uy, \
                self._yaw(zero + self.direction)
        if self.kind == "orbit":
            r, w = self.radius, self.turn * self.speed / self.radius
            # the centre lies ahead of the camera, where it looks
            cx, cy = r * math.cos(math.radians(self.heading)), r * math.sin(
                math.radians(self.heading))
            a = math.radians(self.heading + 180.0) + w * t
            x, y = cx + r * np.cos(a), cy + r * np.sin(a)
            vx, vy = -r * w * np.sin(a), r * w * np.cos(a)
            look = (np.degrees(a) + 180.0) % 360.0  # towards the centre
            return x, y, vx, vy, (look if self.follow else zero + self.heading)
        if self.kind == "lawnmower":
            return self._lawnmower(t, ux, uy)
        # random: a drift of the whole path at speed x direction plus a smooth wander
        x = self.speed * t * ux + self.path_x.at(t)
        y = self.speed * t * uy + self.path_y.at(t)
        vx = self.speed * ux + self.path_x.rate(t)
        vy = self.speed * uy + self.path_y.rate(t)
        return x, y, vx, vy, self._yaw(np.degrees(np.arctan2(vy, vx)))

    def _yaw(self, course: np.ndarray) -> np.ndarray:
        """The camera heading for a path heading ``course`` (degrees)."""
        return course if self.follow else np.zeros_like(course) + self.heading

    def _lawnmower(self, t: np.ndarray, ux: float, uy: float):
        """Legs of ``leg`` metres along the direction, joined by half circles of
        ``radius`` turning ``turn``-wise; constant speed."""
        r, leg, v = self.radius, self.leg, self.speed
        cycle = 2 * leg + 2 * math.pi * r  # two legs and two turns
        s = np.mod(v * t, cycle)
        n_cycles = np.floor(v * t / cycle)
        nx, ny = -uy * self.turn, ux * self.turn  # across the legs, towards the next leg
        along = np.zeros_like(t)
        across = np.zeros_like(t)
        course = np.zeros_like(t)  # degrees relative to the direction
        # leg 1: forward
        m1 = s < leg
        along[m1], across[m1], course[m1] = s[m1], 0.0, 0.0
        # turn 1: half circle to across = 2r
        m2 = (s >= leg) & (s < leg + math.pi * r)
        a = (s[m2] - leg) / r
        along[m2], across[m2] = leg + r * np.sin(a), r - r * np.cos(a)
        course[m2] = np.degrees(a) * self.turn
        # leg 2: back
        m3 = (s >= leg + math.pi * r) & (s < 2 * leg + math.pi * r)
        along[m3] = leg - (s[m3] - leg - math.pi * r)
        across[m3], course[m3] = 2 * r, 180.0
        # turn 2: half circle to the next leg (across = 4r), turning the same way
        m4 = s >= 2 * leg + math.pi * r
        a = (s[m4] - 2 * leg - math.pi * r) / r
        along[m4], across[m4] = -r * np.sin(a), 3 * r - r * np.cos(a)
        course[m4] = 180.0 - np.degrees(a) * self.turn
        across = across + 4 * r * n_cycles
        x = along * ux + across * nx
        y = along * uy + across * ny
        c = np.radians(self.direction + course)
        return x, y, v * np.cos(c), v * np.sin(c), self._yaw((self.direction + course) % 360)


def draw_flight(rng: np.random.Generator, kind: str, altitude: float, pitch: float,
                heading: float, speed: float, alt_range: tuple[float, float],
                pitch_range: tuple[float, float], footprint: float) -> Flight:
    """A flight of ``kind`` starting at ``altitude`` (m), ``pitch`` and ``heading``
    (degrees), flying at ``speed`` m/s (capped where a turn would need more than
    MAX_ACCEL), its altitude and pitch wandering within ``alt_range`` and ``pitch_range``;
    ``footprint``: the width of ground the camera sees at the start (m), which sizes the
    orbit and the lawnmower's legs. A fixed number of draws from ``rng`` whatever the
    kind."""
    follow = bool(rng.random() < 0.75)
    direction = float(heading if follow else rng.uniform(0, 360))
    turn = 1.0 if rng.random() < 0.5 else -1.0
    lo = max(alt_range[0], ALTITUDE_RANGE[0])
    hi = min(alt_range[1], ALTITUDE_RANGE[1])
    plo = max(pitch_range[0], PITCH_RANGE[0])
    phi = min(pitch_range[1], PITCH_RANGE[1])
    alt_amp = min(ALT_WANDER, 0.5 * (hi - lo))
    pitch_amp = min(PITCH_WANDER, 0.5 * (phi - plo))
    alt_w = Wander.draw(rng, alt_amp, 25.0)
    pitch_w = Wander.draw(rng, pitch_amp, 30.0)
    drift = HOVER_DRIFT if kind == "hover" else 0.15
    period = _safe_period(drift, 8.0)
    drift_x, drift_y = Wander.draw(rng, drift, period), Wander.draw(rng, drift, period)
    jit_p, jit_y = Wander.draw(rng, JITTER, 0.8), Wander.draw(rng, JITTER, 1.1)
    wander = 0.6 * max(speed, 1.0) * 6.0  # m: the random path's excursions
    path_x = Wander.draw(rng, wander, _safe_period(wander, 12.0))
    path_y = Wander.draw(rng, wander, _safe_period(wander, 12.0))
    tilt = math.radians(max(pitch, 15.0))
    radius = altitude / math.tan(tilt) if pitch < 80.0 else 0.35 * footprint
    radius = max(radius, 5.0)
    if kind == "lawnmower":
        radius = max(0.4 * footprint, 5.0)  # legs 0.8 footprints apart
    leg = max(2.0 * footprint, 30.0)
    if kind in ("orbit", "lawnmower"):
        speed = min(speed, math.sqrt(MAX_ACCEL * 0.8 * radius))
    speed = 0.0 if kind == "hover" else float(speed)
    return Flight(kind, float(altitude), float(pitch), float(heading) % 360.0, speed,
                  direction, follow, float(radius), float(leg), turn, (lo, hi), (plo, phi),
                  alt_w, pitch_w, drift_x, drift_y, jit_p, jit_y, path_x, path_y)
