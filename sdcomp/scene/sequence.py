"""Drawing a sequence: a pure function of (video config, sequence index), and the scene of
each of its frames: a pure function of (sequence, frame).

:func:`sample_sequence` draws what stays fixed through a clip: the scene of a still
(:func:`~sdcomp.scene.sample.sample_scene` of index ``s``: water, sky, sun, camera look,
the objects in the first view...) with its own generator, then, from a second stream of
its own, the flight (:mod:`sdcomp.scene.flight`), the current, and one :class:`Track` per
floating thing: the still's objects and clutter, and more placed along the flight where
the camera will see them. :func:`frame_scene` turns (sequence, frame ``k``) into the
:class:`~sdcomp.scene.scene.Scene` of that frame: the camera where the flight is at
``k / fps``, the things where they have drifted or travelled to, bobbing with the waves,
and the sea at that time and place. A frame depends only on (config, s, k).

Frames: the world frame of :mod:`sdcomp.scene.camera` (metres; the flight starts above the
origin); a frame's scene is camera-relative (its camera above its origin), as a still's is.
Track ids are 1, 2, ... for the objects of interest of a sequence, in the order drawn.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from .camera import CameraModel, CameraPose, ground_point
from .flight import Flight, FlightState, Wander, draw_flight
from .sample import (
    EDGE_MARGIN,
    MAX_DISTANCE_ALTITUDES,
    clutter_mean,
    sample_scene,
    view_share,
)
from .scene import Placement, Role, Scene, on_land
from .video import VideoConfig
from .water import GRAVITY


@dataclass(frozen=True)
class Track:
    """One floating thing through a sequence: ``track_id`` (1.. for objects of interest, 0
    for clutter), its still ``placement`` (asset, role, category, tint, draft, through-water
    ``speed``), its world position at t = 0 (``x0``, ``y0`` m), its ``course`` (degrees:
    heading of travel), its drift (``drift_x``, ``drift_y`` m/s: current + wind), a
    sideways ``sway`` (m), yaw wander (degrees) and wave-driven ``roll``/``pitch``
    (degrees) and ``heave`` (m)."""

    track_id: int
    placement: Placement
    x0: float
    y0: float
    course: float
    drift_x: float
    drift_y: float
    sway: Wander
    yaw: Wander
    roll: Wander
    pitch: Wander
    heave: Wander

    def velocity(self, t) -> tuple[np.ndarray, np.ndarray]:
        """World velocity (vx, vy) m/s at times ``t``."""
        c = math.radians(self.course)
        v = self.placement.speed
        s = self.sway.rate(t)
        return (self.drift_x + v * math.cos(c) - s * math.sin(c),
                self.drift_y + v * math.sin(c) + s * math.cos(c))

    def position(self, t) -> tuple[np.ndarray, np.ndarray]:
        """World position (x, y) m at times ``t`` (seconds)."""
        t = np.asarray(t, np.float64)
        c = math.radians(self.course)
        v = self.placement.speed
        s = self.sway.at(t) - self.sway.at(np.zeros_like(t))
        return (self.x0 + (self.drift_x + v * math.cos(c)) * t - s * math.sin(c),
                self.y0 + (self.drift_y + v * math.sin(c)) * t + s * math.cos(c))

    def heading(self, t) -> np.ndarray:
        """The thing's heading (degrees) at ``t``: along its path through the water when
        under way, else its own slow yaw."""
        t = np.asarray(t, np.float64)
        if self.placement.speed > 0:
            c = math.radians(self.course)
            s = self.sway.rate(t)
            v = self.placement.speed
            return np.degrees(np.arctan2(v * math.sin(c) + s * math.cos(c),
                                         v * math.cos(c) - s * math.sin(c))) % 360.0
        return (self.placement.heading + self.yaw.at(t)) % 360.0

    def at(self, t: float, cam_x: float, cam_y: float) -> Placement:
        """The placement at time ``t`` relative to a camera above (cam_x, cam_y)."""
        x, y = self.position(t)
        return replace(self.placement, x=float(x) - cam_x, y=float(y) - cam_y,
                       heading=float(self.heading(t)), roll=float(self.roll.at(t)),
                       pitch=float(self.pitch.at(t)),
                       draft=self.placement.draft + float(self.heave.at(t)))


@dataclass(frozen=True)
class Sequence:
    """One clip (see the module docstring): its index, the still ``scene`` it starts from
    (water, sky, look, camera model...), its ``flight``, its ``tracks``, ``fps`` and
    ``frames``, and the run's seed (the per-frame sensor noise windows are drawn from it)."""

    index: int
    scene: Scene
    flight: Flight
    tracks: tuple[Track, ...]
    fps: float
    frames: int
    run_seed: int

    def time(self, k: int) -> float:
        """Seconds at frame ``k`` (0-based)."""
        return k / self.fps

    def camera(self, k: int) -> FlightState:
        """The flight's state at frame ``k``."""
        return self.flight.state(self.time(k))


def sequence_rng(seed: int, s: int) -> np.random.Generator:
    """The random generator of sequence ``s``'s motion (apart from its still's)."""
    return np.random.default_rng([int(seed), int(s), 0x51DE0])


def sample_sequence(video: VideoConfig, s: int, model: CameraModel | None = None) -> Sequence:
    """Draw sequence ``s`` of ``video``; a pure function of (video, s)."""
    config = video.generator
    model = model or config.camera_model()
    still = sample_scene(config, s, model)
    rng = sequence_rng(config.seed, s)
    kind = video.flight[int(rng.integers(len(video.flight)))]
    pose = still.camera
    footprint = pose.altitude * model.width / model.fx
    alt_range = (min(config.altitude.values), max(config.altitude.values))
    pitch_range = (min(config.pitch.values), max(config.pitch.values))
    flight = draw_flight(rng, kind, pose.altitude, pose.pitch, pose.heading,
                         video.speed.sample(rng), alt_range, pitch_range, footprint)
    current, current_dir = video.current.sample(rng), rng.uniform(0, 360)
    w = still.water
    wind_dir = math.radians(w.wind_dir)
    cur = math.radians(current_dir)
    drift = (current * math.cos(cur) + video.leeway * w.wind * math.cos(wind_dir),
             current * math.sin(cur) + video.leeway * w.wind * math.sin(wind_dir))
    wave_period = 2 * math.pi * max(w.wind, 1.0) / (0.855 * GRAVITY)
    tracks = [_track(rng, p, 0.0, drift, wave_period, config.tilt)
              for p in still.placements]
    tracks += _extras(rng, video, model, flight, still, drift, wave_period)
    ids = iter(range(1, len(tracks) + 1))
    numbered = tuple(replace(tr, track_id=next(ids)) if tr.placement.role is Role.OBJECT
                     else tr for tr in tracks)
    return Sequence(s, still, flight, numbered, video.fps, video.frames, config.seed)


def _track(rng: np.random.Generator, p: Placement, t: float, drift: tuple[float, float],
           wave_period: float, tilt: float) -> Track:
    """The track of placement ``p`` (at world ``p.x``, ``p.y`` at time ``t`` seconds)
    drawn from ``rng``: drift (m/s), sway, yaw wander and bobbing with waves of
    ``wave_period`` seconds and tilts up to ``tilt`` degrees; a fixed number of draws."""
    sway = Wander.draw(rng, 0.15 + 0.3 * p.speed, 10.0 + 4.0 * p.speed)
    yaw = Wander.draw(rng, 12.0, 25.0)
    roll = Wander.draw(rng, tilt, wave_period)
    pitch = Wander.draw(rng, tilt, wave_period)
    heave = Wander.draw(rng, 0.02, wave_period)
    tr = Track(0, p, p.x, p.y, p.heading, drift[0], drift[1], sway, yaw, roll, pitch, heave)
    if t > 0:  # placed where it is at time t: start where it came from
        x, y = tr.position(t)
        tr = replace(tr, x0=2 * p.x - float(x), y0=2 * p.y - float(y))
    return tr


def _extras(rng: np.random.Generator, video: VideoConfig, model: CameraModel, flight: Flight,
            still: Scene, drift: tuple[float, float], wave_period: float) -> list[Track]:
    """Objects and clutter placed along a moving flight, each seen by the camera at a time
    drawn uniformly in the clip: as many more as the ground the camera sweeps holds (the
    still's mean count per view, per view swept). Their kind and look are drawn as a
    still's (one more still scene per extra thing)."""
    config = video.generator
    t = np.linspace(0.0, video.duration, 64)
    st = flight.state(t)
    swept = float(np.sum(np.hypot(np.diff(st.x), np.diff(st.y))))
    along = still.camera.altitude * model.height / model.fy
    views = swept / max(along, 1e-6)
    mean_count = float(np.mean(config.count.values)) * view_share(config, model)
    out: list[Track] = []
    n_obj = int(rng.poisson(mean_count * views))
    n_clutter = int(rng.poisson(clutter_mean(config, model) * views)) \
        if config.clutter > 0 else 0
    for k in range(n_obj + n_clutter):
        when = float(rng.uniform(0.0, video.duration))
        donor = sample_scene(config, int(rng.integers(2**31)), model)
        role = Role.OBJECT if k < n_obj else Role.CLUTTER
        kinds = [p for p in donor.placements if p.role is role]
        u, v = rng.random(2)
        if not kinds:
            continue
        p = kinds[0]
        cam = flight.state(when)
        pose = CameraPose(float(cam.altitude), float(cam.pitch), float(cam.heading))
        m = EDGE_MARGIN
        hit = ground_point(model, pose, (-m + (1 + 2 * m) * u) * model.width,
                           (-m + (1 + 2 * m) * v) * model.height)
        if hit is None or math.hypot(*hit) > MAX_DISTANCE_ALTITUDES * pose.altitude:
            continue
        x, y = hit[0] + float(cam.x), hit[1] + float(cam.y)
        if on_land(still.shore, x, y):
            continue
        out.append(_track(rng, replace(p, x=x, y=y), when, drift, wave_period, config.tilt))
    return out


def frame_scene(seq: Sequence, k: int) -> tuple[Scene, tuple[int, ...]]:
    """The scene of frame ``k`` of ``seq`` (camera-relative, see the module docstring;
    ``index``: the frame's number within its sequence) and the track id of each of its
    placements (0 for clutter). Things farther than the still's reach are left out."""
    t = seq.time(k)
    cam = seq.camera(k)
    cx, cy = float(cam.x), float(cam.y)
    pose = CameraPose(float(cam.altitude), float(cam.pitch), float(cam.heading))
    reach = MAX_DISTANCE_ALTITUDES * pose.altitude
    placements, ids = [], []
    for tr in seq.tracks:
        p = tr.at(t, cx, cy)
        if math.hypot(p.x, p.y) <= reach:
            placements.append(p)
            ids.append(tr.track_id)
    base = seq.scene
    water = replace(base.water, origin=(cx, cy), time=t, frame_heading=base.water.wind_dir)
    noise = np.random.default_rng([seq.run_seed, seq.index, k, 0x40153]).integers(
        0, 2**31 - 1, 2)
    look = replace(base.look, noise_oy=int(noise[0]), noise_ox=int(noise[1]))
    shore = base.shore
    if shore is not None:  # the coastline stays where it is in the world
        a = math.radians(shore.angle)
        shore = replace(shore, distance=shore.distance - (cx * math.cos(a) + cy * math.sin(a)),
                        along_offset=shore.along_offset - cx * math.sin(a) + cy * math.cos(a))
    scene = replace(base, index=k, camera=pose, water=water, placements=tuple(placements),
                    look=look, shore=shore)
    return scene, tuple(ids)
