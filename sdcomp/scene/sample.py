"""Drawing the scene of image ``i``: a pure function of (config, i).

:func:`sample_scene` draws everything random about one image with a generator seeded by
``(seed, index)`` only, so image ``i`` never depends on which worker made it or on the images
before it. The order of the draws is part of the output's definition: changing it changes
every dataset.
"""

from __future__ import annotations

import math

import numpy as np

from .camera import CameraModel, CameraPose, ground_point
from .config import GeneratorConfig
from .objects import clutter_assets, low_enough, object_assets
from .scene import Effects, FeatureSeeds, Placement, Role, Scene, Shore, on_land
from .water import attenuation, parse_water

MAX_DISTANCE_ALTITUDES = 12.0  # objects are placed at most this many altitudes away
EDGE_MARGIN = 0.02  # object centres may lie this fraction of the frame size outside it
VARIANT_TINT = (0.85, 1.15, 0.05)  # a variant object's albedo gain range, channel jitter


def scene_rng(seed: int, index: int) -> np.random.Generator:
    """The random generator of image ``index`` (independent streams per image)."""
    return np.random.default_rng([int(seed), int(index), 0x5DC0])


def object_asset(config: GeneratorConfig, k: int) -> str:
    """Asset key of ``config.objects[k]``: its mesh (a built-in name or a file path), or
    its first variant's."""
    return object_assets(config.objects[k].mesh)[0]


def clutter_asset(kind: str) -> str:
    """Asset key of the clutter kind ``kind`` (its first variant's)."""
    return clutter_assets(kind)[0]


def sample_scene(config: GeneratorConfig, index: int, model: CameraModel | None = None
                 ) -> Scene:
    """Draw the scene of image ``index``; a pure function of (config, index)."""
    rng = scene_rng(config.seed, index)
    model = model or config.camera_model()
    pose = CameraPose(*_altitude_pitch(rng, config), config.heading.sample(rng) % 360.0)
    water = config.water[min(int(rng.random() * len(config.water)), len(config.water) - 1)]
    name, rgb = parse_water(water)
    jitter = rng.uniform(0.92, 1.08, 3)
    r, g, b = (min(max(round(c * j), 0), 255) for c, j in zip(rgb, jitter.tolist(),
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
    placements = _placements(rng, config, model, pose, shore)
    effects = _effects(rng, config, model)
    seeds = FeatureSeeds.of(int(rng.integers(2**31)), config.seed)
    return Scene(index, model, pose, name, (r, g, b), turbidity, attenuation(turbidity), wind,
                 swell, floor_depth, sun_el, sun_az, ambient, placements, shore, hills,
                 effects, seeds, config.shadows, config.whitecaps)


def _altitude_pitch(rng: np.random.Generator, config: GeneratorConfig) -> tuple[float, float]:
    """The camera's altitude (m) and pitch (degrees): drawn apart, or, with ``pair_pitch``,
    the pitch at the altitude's place in its list (one draw picks the place as
    :meth:`Param.sample` would; the pitch's draw is made and unused, so that the draws after
    it stay where they are)."""
    if not config.pair_pitch:
        return config.altitude.sample(rng), config.pitch.sample(rng)
    n = len(config.altitude.choices)
    k = min(int(rng.random() * n), n - 1)
    rng.random()
    return config.altitude.choices[k], config.pitch.choices[k]


def _placements(rng: np.random.Generator, config: GeneratorConfig, model: CameraModel,
                pose: CameraPose, shore: Shore | None) -> tuple[Placement, ...]:
    """The objects of interest, then the clutter, each seen in the frame and on water."""
    placements = []
    n_obj = int(config.count.sample(rng))
    weights = [o.weight for o in config.objects]
    cumulative = np.cumsum(weights) if len(set(weights)) > 1 else None
    for _ in range(n_obj):
        k, asset, tint = _pick_object(rng, config, cumulative, pose.altitude)
        p = _place(rng, config, model, pose, shore, Role.OBJECT, (asset,), k + 1, tint)
        if p is not None:
            placements.append(p)
    n_clutter = int(rng.poisson(config.clutter)) if config.clutter > 0 else 0
    for _ in range(n_clutter):
        kind = config.clutter_kinds[int(rng.integers(len(config.clutter_kinds)))]
        p = _place(rng, config, model, pose, shore, Role.CLUTTER, clutter_assets(kind), 0)
        if p is not None:
            placements.append(p)
    return tuple(placements)


def _pick_object(rng: np.random.Generator, config: GeneratorConfig,
                 cumulative: np.ndarray | None, altitude: float
                 ) -> tuple[int, str, tuple[float, float, float]]:
    """(index in ``config.objects``, asset key, albedo gains) of one object of interest:
    chosen by weight (``cumulative``: the running sums of the weights, None when they are
    all equal: then drawn as before weights existed), then, for a kind of variants, one
    variant low enough for the camera's ``altitude`` (:func:`low_enough`) in a shade of
    its own (draws that objects of one mesh never make)."""
    if cumulative is None:
        k = int(rng.integers(len(config.objects)))
    else:
        k = min(int(np.searchsorted(cumulative, rng.random() * cumulative[-1], "right")),
                len(cumulative) - 1)
    assets = object_assets(config.objects[k].mesh)
    if len(assets) == 1:
        return k, assets[0], (1.0, 1.0, 1.0)
    assets = low_enough(assets, altitude)
    asset = assets[int(rng.integers(len(assets)))]
    lo, hi, jitter = VARIANT_TINT
    gains = rng.uniform(lo, hi) * (1.0 + rng.uniform(-jitter, jitter, 3))
    return k, asset, (float(gains[0]), float(gains[1]), float(gains[2]))


def _effects(rng: np.random.Generator, config: GeneratorConfig, model: CameraModel
             ) -> Effects:
    """The camera effects of one image."""
    exposure = config.exposure.sample(rng)
    wb_amp = config.white_balance.sample(rng)
    wb = (1.0 + rng.uniform(-wb_amp, wb_amp), 1.0, 1.0 + rng.uniform(-wb_amp, wb_amp))
    noise = config.noise.sample(rng)
    scale = max(model.width, model.height) / 416.0
    motion = ((rng.uniform(2, 6) * scale, rng.uniform(0, 180))
              if rng.random() < config.motion_blur else None)
    defocus = rng.uniform(0.6, 1.4) * scale if rng.random() < config.defocus_blur else None
    return Effects(exposure, wb, noise, motion, defocus, config.vignetting.sample(rng),
                   int(config.jpeg_quality.sample(rng)))


def _place(rng: np.random.Generator, config: GeneratorConfig, model: CameraModel,
           pose: CameraPose, shore: Shore | None, role: Role, assets: tuple[str, ...],
           category_id: int, tint: tuple[float, float, float] = (1.0, 1.0, 1.0)
           ) -> Placement | None:
    """A random placement seen in the frame (possibly cut by its edge), on water; None
    when 8 tries find no such place. An object is ``assets[0]`` in ``tint``; clutter is
    one of its kind's ``assets`` (variants), or its one mesh in a random shade."""
    u0, v0 = rng.random(), rng.random()
    heading = rng.uniform(0, 360)
    roll, pitch = rng.uniform(-1, 1, 2) * config.tilt
    draft = config.draft.sample(rng) if role is Role.OBJECT else rng.uniform(-0.02, 0.04)
    asset = assets[0]
    if role is Role.CLUTTER:  # one draw either way: which variant, or the tint of the one
        if len(assets) > 1:
            assets = low_enough(assets, pose.altitude)
            asset = assets[int(rng.integers(len(assets)))]
        else:
            tint = _clutter_tint(rng)
    for attempt in range(8):
        if attempt:
            u0, v0 = rng.random(), rng.random()
        m = EDGE_MARGIN
        u = (-m + (1 + 2 * m) * u0) * model.width
        v = (-m + (1 + 2 * m) * v0) * model.height
        hit = ground_point(model, pose, u, v)
        if hit is None:
            continue
        x, y = hit
        if math.hypot(x, y) > MAX_DISTANCE_ALTITUDES * pose.altitude:
            continue
        if on_land(shore, x, y):
            continue
        return Placement(role, asset, category_id, x, y, heading, float(roll), float(pitch),
                         float(draft), tint)
    return None


def _clutter_tint(rng: np.random.Generator) -> tuple[float, float, float]:
    """Albedo gains of one clutter object of a kind with one mesh (logs, foam): lighter or
    darker."""
    g = rng.uniform(0.8, 1.15)
    return (g, g, g)
