"""Scene description: everything random about one image, drawn from (seed, index, config).

A :class:`Scene` is plain data (kubric-style: the description is kept apart from the
renderer in :mod:`sdcomp.compositor`). :func:`sample_scene` draws it with a generator seeded
by ``(seed, index)`` only, so image ``i`` never depends on which worker made it or on the
images before it.

World frame: metres, z up, sea surface z = 0, camera above the origin. Angles in degrees;
headings and azimuths counter-clockwise from world +x.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .camera import CameraModel, CameraPose
from .config import GeneratorConfig
from .water import attenuation, parse_water

MAX_DISTANCE_ALTITUDES = 12.0  # objects are placed at most this many altitudes away
EDGE_MARGIN = 0.02  # object centres may lie this fraction of the frame size outside it


@dataclass(frozen=True)
class Placement:
    """One floating object. ``kind`` is ``"object"`` (annotated; ``model`` indexes
    ``config.objects``) or ``"clutter"`` (never annotated; ``model`` indexes
    ``config.clutter_kinds``). (x, y): where its waterline centre meets the sea, metres.
    ``draft``: metres below its natural waterline (negative: higher). ``tint``: albedo gain."""

    kind: str
    model: int
    x: float
    y: float
    heading: float
    roll: float
    pitch: float
    draft: float
    tint: tuple[float, float, float] = (1.0, 1.0, 1.0)


@dataclass(frozen=True)
class Shore:
    """Land beyond a wavy coastline: points p with p . (cos a, sin a) > distance + wiggle."""

    angle: float
    distance: float
    seed: int


@dataclass(frozen=True)
class Effects:
    """Camera effects: exposure (stops), white-balance gains (R, G, B), noise standard
    deviation (8-bit levels), motion blur (length px, angle deg) or None, defocus blur sigma
    (px) or None, vignetting (fractional fall-off at the corners), JPEG quality."""

    exposure: float
    white_balance: tuple[float, float, float]
    noise: float
    motion_blur: tuple[float, float] | None
    defocus_blur: float | None
    vignetting: float
    jpeg_quality: int


@dataclass(frozen=True)
class Scene:
    """Everything that varies per image (see the module docstring for frames and units)."""

    index: int
    camera: CameraPose
    water_name: str
    water_rgb: tuple[int, int, int]
    turbidity: float
    attenuation: float  # 1/m
    wind: float  # m/s
    swell_direction: float  # degrees
    floor_depth: float  # m
    sun_elevation: float
    sun_azimuth: float
    ambient: float
    placements: tuple[Placement, ...]
    shore: Shore | None
    hills: int | None  # seed of the ridge line when hills are drawn, else None
    effects: Effects
    texture_seed: int  # offsets into the texture tiles, background and noise choice


def scene_rng(seed: int, index: int) -> np.random.Generator:
    """The random generator of image ``index`` (independent streams per image)."""
    return np.random.default_rng([int(seed), int(index), 0x5DC0])


def sample_scene(config: GeneratorConfig, index: int, model: CameraModel | None = None
                 ) -> Scene:
    """Draw the scene of image ``index``; a pure function of (config, index)."""
    rng = scene_rng(config.seed, index)
    model = model or config.camera_model()
    pose = CameraPose(config.altitude.sample(rng), config.pitch.sample(rng),
                      config.heading.sample(rng) % 360.0)
    water = config.water[min(int(rng.random() * len(config.water)), len(config.water) - 1)]
    name, rgb = parse_water(water)
    jitter = rng.uniform(0.92, 1.08, 3)
    rgb = tuple(min(max(round(c * j), 0), 255) for c, j in zip(rgb, jitter.tolist(),
                                                                strict=True))
    turbidity = config.turbidity.sample(rng)
    wind = config.wind.sample(rng)
    swell = rng.uniform(0, 360)
    floor_depth = config.floor_depth.sample(rng)
    sun_el = config.sun_elevation.sample(rng)
    sun_az = config.sun_azimuth.sample(rng) % 360.0
    ambient = config.ambient.sample(rng)

    shore = None
    if rng.random() < config.shore:
        footprint = pose.altitude * model.width / model.fx
        shore = Shore(rng.uniform(0, 360), footprint * rng.uniform(0.2, 0.45),
                      int(rng.integers(2**31)))
    hills = int(rng.integers(2**31)) if rng.random() < config.hills else None

    placements = []
    n_obj = int(config.count.sample(rng))
    for _ in range(n_obj):
        p = _place(rng, config, model, pose, shore, "object",
                   int(rng.integers(len(config.objects))))
        if p is not None:
            placements.append(p)
    n_clutter = int(rng.poisson(config.clutter)) if config.clutter > 0 else 0
    for _ in range(n_clutter):
        p = _place(rng, config, model, pose, shore, "clutter",
                   int(rng.integers(len(config.clutter_kinds))))
        if p is not None:
            placements.append(p)

    exposure = config.exposure.sample(rng)
    wb_amp = config.white_balance.sample(rng)
    wb = (1.0 + rng.uniform(-wb_amp, wb_amp), 1.0, 1.0 + rng.uniform(-wb_amp, wb_amp))
    noise = config.noise.sample(rng)
    scale = max(model.width, model.height) / 416.0
    motion = ((rng.uniform(2, 6) * scale, rng.uniform(0, 180))
              if rng.random() < config.motion_blur else None)
    defocus = rng.uniform(0.6, 1.4) * scale if rng.random() < config.defocus_blur else None
    effects = Effects(exposure, wb, noise, motion, defocus, config.vignetting.sample(rng),
                      int(config.jpeg_quality.sample(rng)))
    return Scene(index, pose, name, rgb, turbidity, attenuation(turbidity), wind, swell,
                 floor_depth, sun_el, sun_az, ambient, tuple(placements), shore, hills,
                 effects, int(rng.integers(2**31)))


def on_land(shore: Shore | None, x, y):
    """Whether ground points (x, y) metres lie on the land of ``shore`` (array or bool)."""
    if shore is None:
        return np.zeros(np.shape(x), bool)
    a = math.radians(shore.angle)
    along = -np.asarray(x) * math.sin(a) + np.asarray(y) * math.cos(a)
    across = np.asarray(x) * math.cos(a) + np.asarray(y) * math.sin(a)
    return across > shore.distance + coast_wiggle(shore, along)


def coast_wiggle(shore: Shore, along):
    """Offset (metres) of the coastline from its straight line at ``along`` metres."""
    r = np.random.default_rng(shore.seed)
    out = np.zeros(np.shape(along), np.float64)
    for wavelength in (60.0, 23.0, 9.0, 3.5):
        phase = r.uniform(0, 2 * math.pi)
        out = out + wavelength * 0.08 * np.sin(2 * math.pi * np.asarray(along) / wavelength
                                               + phase)
    return out


def _place(rng, config, model, pose, shore, kind, index) -> Placement | None:
    """A random placement seen in the frame (possibly cut by its edge), on water."""
    u0, v0 = rng.random(), rng.random()
    heading = rng.uniform(0, 360)
    roll, pitch = rng.uniform(-1, 1, 2) * config.tilt
    draft = config.draft.sample(rng) if kind == "object" else rng.uniform(-0.02, 0.04)
    tint = _clutter_tint(rng, config.clutter_kinds[index]) if kind == "clutter" else (1.0,) * 3
    for attempt in range(8):
        if attempt:
            u0, v0 = rng.random(), rng.random()
        m = EDGE_MARGIN
        u = (-m + (1 + 2 * m) * u0) * model.width
        v = (-m + (1 + 2 * m) * v0) * model.height
        hit = _ground_point(model, pose, u, v)
        if hit is None:
            continue
        x, y = hit
        if math.hypot(x, y) > MAX_DISTANCE_ALTITUDES * pose.altitude:
            continue
        if on_land(shore, x, y):
            continue
        return Placement(kind, index, x, y, heading, float(roll), float(pitch), float(draft),
                         tint)
    return None


def _ground_point(model: CameraModel, pose: CameraPose, u: float, v: float
                  ) -> tuple[float, float] | None:
    """Where the ray through pixel (u, v) meets the sea, metres; None above the horizon.
    (Scalar form of :func:`sdcomp.camera.ground_points`, which it must agree with.)"""
    x = (u - model.width / 2) / model.fx
    y = (v - model.height / 2) / model.fy
    p, h = math.radians(pose.pitch), math.radians(pose.heading)
    cp, sp, ch, sh = math.cos(p), math.sin(p), math.cos(h), math.sin(h)
    # rows of camera_basis: right (sh, -ch, 0), down (-sp*ch, -sp*sh, -cp), fwd (cp*ch, cp*sh, -sp)
    dx = x * sh - y * sp * ch + cp * ch
    dy = -x * ch - y * sp * sh + cp * sh
    dz = -y * cp - sp
    if dz > -1e-9:
        return None
    t = pose.altitude / -dz
    return dx * t, dy * t


def _clutter_tint(rng, kind: str) -> tuple[float, float, float]:
    if kind == "buoy":  # orange-red, yellow, white or green buoys
        options = ((1.0, 1.0, 1.0), (1.05, 2.6, 0.5), (1.05, 2.9, 7.0), (0.35, 1.8, 1.4))
        return options[int(rng.integers(len(options)))]
    if kind == "boat":  # white, blue or red hulls (the hull is white: gains darken it)
        options = ((1.0, 1.0, 1.0), (0.35, 0.55, 0.95), (0.9, 0.3, 0.3), (0.8, 0.8, 0.8))
        return options[int(rng.integers(len(options)))]
    g = rng.uniform(0.8, 1.15)
    return (g, g, g)
