"""Drawing the scene of image ``i``: a pure function of (config, i).

:func:`sample_scene` draws everything random about one image with a generator seeded by
``(seed, index)`` only, so image ``i`` never depends on which worker made it or on the images
before it. The order of the draws is part of the output's definition: changing it changes
every dataset.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from .camera import CameraModel, CameraPose, camera_basis, ground_point, ground_points
from .config import MAX_INSTANCES, GeneratorConfig
from .look import CameraLook
from .look_table import sample_look
from .moorings import moor
from .objects import (
    CLUTTER_PREFIX,
    clutter_assets,
    draw_size,
    footprint_radius,
    low_enough,
    object_assets,
    under_way,
    visible_hull,
)
from .scene import FeatureSeeds, Placement, Role, Scene, Shore, on_land
from .water import SKY_WEIGHTS, WaterParams, constituents, parse_water

MAX_DISTANCE_ALTITUDES = 12.0  # objects are placed at most this many altitudes away
EDGE_MARGIN = 0.02  # object centres may lie this fraction of the frame size outside it
VARIANT_TINT = (0.85, 1.15, 0.05)  # a variant object's albedo gain range, channel jitter
MAX_CLUTTER = 50.0  # the most clutter an image draws on average (--clutter's bound)


def scene_rng(seed: int, index: int) -> np.random.Generator:
    """The random generator of image ``index`` (independent streams per image)."""
    return np.random.default_rng([int(seed), int(index), 0x5DC0])


def object_asset(config: GeneratorConfig, k: int) -> str:
    """Asset key of ``config.objects[k]``: its mesh (a built-in name or a file path), or
    its first variant's."""
    return object_assets(config.objects[k].mesh)[0]


def sample_scene(config: GeneratorConfig, index: int, model: CameraModel | None = None
                 ) -> Scene:
    """Draw the scene of image ``index``; a pure function of (config, index)."""
    rng = scene_rng(config.seed, index)
    model = model or config.camera_model()
    altitude, pitch, at = _altitude_pitch(rng, config)
    pose = CameraPose(altitude, pitch, config.heading.sample_at(rng, at) % 360.0)
    water = sample_water(rng, config, at)
    shore = None
    if rng.random() < config.shore:
        footprint = pose.altitude * model.width / model.fx
        shore = Shore(rng.uniform(0, 360), footprint * rng.uniform(0.2, 0.45),
                      int(rng.integers(2**31)))
    hills = int(rng.integers(2**31)) if rng.random() < config.hills else None
    placements = _travel(np.random.default_rng([int(config.seed), int(index), 0x3A4E]),
                         config, _placements(rng, config, model, pose, shore))
    placements = moor(np.random.default_rng([int(config.seed), int(index), 0x400D]),
                      config.moored, placements, shore, (model, pose))
    look = sample_look(config.look_preset, rng, model.width, model.height,
                       recording=config.recording, fx=model.fx, fy=model.fy,
                       motion=config.motion_blur, overrides=config.look_overrides())
    water, look = expose(water, look)
    look = replace(look, off=config.camera_off, grade=config.grade)  # draws stay the same
    scale = max(model.width, model.height) / 416.0
    defocus = rng.uniform(0.6, 1.4) * scale if rng.random() < config.defocus_blur else None
    quality = int(config.jpeg_quality.sample(rng))
    seeds = FeatureSeeds.of(int(rng.integers(2**31)), config.seed)
    footage = config.footage_blur if config.backgrounds and config.footage_look else None
    return Scene(index, model, pose, water, placements, shore, hills, look, defocus, quality,
                 seeds, config.shadows, config.glitter, footage_blur=footage)


def _travel(rng: np.random.Generator, config: GeneratorConfig,
            placements: tuple[Placement, ...]) -> tuple[Placement, ...]:
    """``placements`` with their speeds through the water: each travels with its kind's
    chance (:func:`~sdcomp.scene.objects.under_way`, scaled by ``config.under_way``) at a
    speed uniform in its kind's range. Two draws per placement from ``rng``, a stream of
    its own: the scene's other draws are those of a run without speeds."""
    out = []
    for p in placements:
        chance, slow, fast = under_way(p.asset)
        moving, pace = rng.random(), rng.random()
        if moving < chance * config.under_way:
            p = replace(p, speed=slow + (fast - slow) * pace)
        out.append(p)
    return tuple(out)


def expose(water: WaterParams, look: CameraLook) -> tuple[WaterParams, CameraLook]:
    """One exposure per image, made where the light is: the camera's auto exposure (its
    target luminance and bias) becomes the renderer's exposure target, and the camera
    stage applies no gain of its own (``ae_strength`` and ``exposure_ev`` 0). Sun sparkles
    then clip against the exposure the image really has, as on a sensor, instead of being
    clipped at the renderer's and scaled after. A clean look keeps the water's own target."""
    if look.preset == "clean":
        return water, look
    target = min(max(look.ae_target * 2.0 ** look.exposure_ev, 0.02), 0.6)
    return (replace(water, exposure_target=target),
            replace(look, ae_strength=0.0, exposure_ev=0.0))


def _pick(rng: np.random.Generator, kinds: tuple[str, ...], weights: dict[str, float]) -> str:
    """One of ``kinds``, drawn with ``weights`` (renormalised over them)."""
    w = np.array([weights[k] for k in kinds], np.float64)
    return kinds[min(int(np.searchsorted(np.cumsum(w / w.sum()), rng.random(), "right")),
                     len(kinds) - 1)]


def _log_uniform(rng: np.random.Generator, lo: float, hi: float) -> float:
    return float(math.exp(rng.uniform(math.log(lo), math.log(hi))))


def sample_water(rng: np.random.Generator, config: GeneratorConfig,
                 at: tuple[int, int] | None = None) -> WaterParams:
    """The water and sky of one image (see :class:`WaterParams`): the water named by
    ``config.water`` (a preset draws one of its types), its constituents placed by the
    turbidity in the type's ranges (log scale, each +-0.15 at random), patchiness, a shallow
    bottom with probability ``config.shallow``, waves (slicks on calm water, swell on the
    sea), the sky, the sun (at the flight log's entry ``at``: :meth:`Param.sample_at`) and the
    exposure target. Every value is drawn whether it is used or not: later draws stay put."""
    name, types, rgb = parse_water(config.water[int(rng.integers(len(config.water)))])
    wtype = types[int(rng.integers(len(types)))]
    turbidity = config.turbidity.sample(rng)
    # each constituent at its own place within +-0.15 of the turbidity
    chl, cdom, tsm = (constituents(wtype, turbidity + rng.uniform(-0.15, 0.15))[k]
                      for k in range(3))
    patchiness, patch_scale = float(rng.uniform(0.05, 0.45)), _log_uniform(rng, 25.0, 400.0)
    depth = config.floor_depth.sample(rng)
    shallow = rng.random() < config.shallow
    wind, wind_dir, wave_age = config.wind.sample(rng), rng.uniform(0, 360), _log_uniform(
        rng, 0.84, 4.0)
    slicks = float(rng.uniform(0.05, 0.5)) if rng.random() < 0.4 and wind < 6.0 else 0.0
    swell = float(rng.uniform(0.3, 2.0)) if rng.random() < 0.6 else 0.0
    swell_length, swell_dir = _log_uniform(rng, 40.0, 200.0), rng.uniform(0, 360)
    sky = _pick(rng, config.sky, SKY_WEIGHTS)
    cover = {"clear": 0.0, "overcast": 1.0}.get(sky, config.cloud_cover.sample(rng))
    return WaterParams(
        name=name, water_type=wtype, chl=chl, cdom=cdom, tsm=tsm, rgb=rgb,
        turbidity=turbidity, patchiness=patchiness, patch_scale=patch_scale,
        depth=depth if shallow else None, wind=wind, wind_dir=wind_dir, wave_age=wave_age,
        slicks=slicks, swell_height=swell if wtype in ("ocean", "coastal") else 0.0,
        swell_length=swell_length, swell_dir=swell_dir, foam_scale=config.whitecaps,
        sky=sky, cloud_cover=cover, cloud_height=rng.uniform(800.0, 2500.0),
        cloud_scale=_log_uniform(rng, 6.0, 25.0), cloud_bright=rng.uniform(0.7, 1.1),
        visibility=_log_uniform(rng, 6000.0, 40000.0),
        sun_elevation=config.sun_elevation.sample_at(rng, at),
        sun_azimuth=config.sun_azimuth.sample_at(rng, at) % 360.0,
        exposure_target=rng.uniform(0.16, 0.21), seed=int(rng.integers(2**31)))


def _altitude_pitch(rng: np.random.Generator, config: GeneratorConfig
                    ) -> tuple[float, float, tuple[int, int] | None]:
    """The camera's altitude (m) and pitch (degrees), and the place (k, n) in the flight log
    of n entries they were drawn at: drawn apart (None), or, with ``pair_pitch``, the pitch
    at the altitude's place in its list (one draw picks the place as :meth:`Param.sample`
    would; the pitch's :meth:`Param.sample_at` makes its draw too, so later draws stay put)."""
    if not config.pair_pitch:
        return config.altitude.sample(rng), config.pitch.sample(rng), None
    n = len(config.altitude.choices)
    k = min(int(rng.random() * n), n - 1)
    return config.altitude.choices[k], config.pitch.sample_at(rng, (k, n)), (k, n)


def _placements(rng: np.random.Generator, config: GeneratorConfig, model: CameraModel,
                pose: CameraPose, shore: Shore | None) -> tuple[Placement, ...]:
    """The objects of interest, then the clutter, each seen in the frame and on water, none
    on another (:func:`~sdcomp.scene.objects.footprint_radius`; foam patches excepted)."""
    placements: list[Placement] = []
    taken: list[tuple[float, float, float]] = []  # (x, y, radius) metres of those placed
    n_obj = _count(rng, config, model)
    weights = [o.weight for o in config.objects]
    cumulative = np.cumsum(weights) if len(set(weights)) > 1 else None
    for _ in range(n_obj):
        for _draw in range(SIZE_PICKS):
            k, asset, tint = _pick_object(rng, config, cumulative, pose.altitude)
            spec = config.objects[k]
            p = _place(rng, config, model, pose, shore, Role.OBJECT, (asset,), k + 1, tint,
                       spec.frame, (spec.size, spec.size_weight), taken)
            if p is not None or spec.size is None:
                break
            # an object that cannot show its sizes in this view (a boat under a low drone
            # looking straight down): another object drawn in its place
        if p is not None:
            placements.append(p)
    n_clutter = int(rng.poisson(clutter_mean(config, model))) if config.clutter > 0 else 0
    for _ in range(n_clutter):
        kind = config.clutter_kinds[int(rng.integers(len(config.clutter_kinds)))]
        p = _place(rng, config, model, pose, shore, Role.CLUTTER, clutter_assets(kind), 0,
                   taken=taken)
        if p is not None:
            placements.append(p)
    return tuple(placements)


def view_share(config: GeneratorConfig, model: CameraModel) -> float:
    """How many of the views that ``config.count`` is for (``count_view``, squared focal
    lengths) the camera ``model``'s image covers, ``(width / fx) (height / fy)`` over it;
    1 when the count is per image (``count_view`` 0)."""
    if config.count_view <= 0:
        return 1.0
    return model.width / model.fx * model.height / model.fy / config.count_view


def clutter_mean(config: GeneratorConfig, model: CameraModel) -> float:
    """Mean clutter per image of ``model``: scaled by :func:`view_share`, capped."""
    return min(config.clutter * view_share(config, model), MAX_CLUTTER)


def _count(rng: np.random.Generator, config: GeneratorConfig, model: CameraModel) -> int:
    """The number of objects of interest in one image: ``config.count`` drawn, scaled to
    the camera's view (:func:`view_share`) and rounded at random (one more draw, only when
    scaled), at least one when the count drawn is (a narrower view is still aimed at
    something), at most :data:`~sdcomp.scene.config.MAX_INSTANCES`."""
    n = int(config.count.sample(rng))
    if config.count_view <= 0:
        return n
    scaled = int(math.floor(n * view_share(config, model) + rng.random()))
    return min(max(scaled, min(n, 1)), MAX_INSTANCES)


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


def _place(rng: np.random.Generator, config: GeneratorConfig, model: CameraModel,
           pose: CameraPose, shore: Shore | None, role: Role, assets: tuple[str, ...],
           category_id: int, tint: tuple[float, float, float] = (1.0, 1.0, 1.0),
           frame: tuple[float, float, float, float] | None = None,
           size: tuple[tuple[float, ...] | None, tuple[float, ...] | None] = (None, None),
           taken: list[tuple[float, float, float]] | None = None) -> Placement | None:
    """A random placement seen in the frame (possibly cut by its edge), on water, its
    footprint's disc clear of those in ``taken`` ((x, y, radius) metres; the new one's
    is appended); None when 8 tries find no such place. An object is ``assets[0]`` in
    ``tint``; clutter is one of its kind's ``assets`` (variants), or its one mesh in a
    random shade. Its centre lies in the image part ``frame`` (fractions (u0, v0, u1, v1)),
    or anywhere in the frame up to :data:`EDGE_MARGIN` outside it; with box-size quantiles
    ``size[0]`` (over the focal length) and their intervals' weights ``size[1]``, on the row
    of that part where it shows a size drawn from them (:func:`_row_for_size`)."""
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
    # foam patches lie flat on the water: objects float in them, they keep no disc
    radius = None if asset.removeprefix(CLUTTER_PREFIX) == "foam" else footprint_radius(asset)
    target = None
    quantiles, size_weight = size
    if quantiles is not None and frame is None:
        frame = (0.0, 0.0, 1.0, 1.0)  # a size needs rows to choose from: the whole frame
    for attempt in range(8):
        if attempt:
            u0, v0 = rng.random(), rng.random()
        if quantiles is not None:  # the box size to show, pixels
            target = draw_size(quantiles, size_weight, rng.random()) * model.fx
        uv = _image_point(model, pose, frame, u0, v0, target, asset, heading)
        if uv is None:  # not at that size in this view: another draw
            continue
        hit = ground_point(model, pose, *uv)
        if hit is None:
            continue
        x, y = hit
        if not _free(x, y, MAX_DISTANCE_ALTITUDES * pose.altitude, shore, taken, radius):
            continue
        if radius is not None and taken is not None:
            taken.append((x, y, radius))
        return Placement(role, asset, category_id, x, y, heading, float(roll), float(pitch),
                         float(draft), tint)
    return None


def _free(x: float, y: float, reach: float, shore: Shore | None,
          taken: list[tuple[float, float, float]] | None, radius: float | None) -> bool:
    """Whether (``x``, ``y``) (metres, on the sea) can take an object: within ``reach``
    metres of the point under the camera, on water, and its disc of ``radius`` metres
    (None: it keeps none) overlapping none of ``taken`` ((x, y, radius) each)."""
    if math.hypot(x, y) > reach or on_land(shore, x, y):
        return False
    if radius is None or not taken:
        return True
    return all((x - tx) ** 2 + (y - ty) ** 2 >= (radius + tr) ** 2 for tx, ty, tr in taken)


def _image_point(model: CameraModel, pose: CameraPose,
                 frame: tuple[float, float, float, float] | None, u0: float, v0: float,
                 target: float | None, asset: str, heading: float
                 ) -> tuple[float, float] | None:
    """The pixel (u, v) an object's centre is placed at, from uniform draws ``u0``, ``v0``:
    anywhere in the frame up to :data:`EDGE_MARGIN` outside it (``frame`` None), or in the
    part ``frame``, on the row where ``asset`` shows a box of ``target`` pixels when given
    (None where no row does)."""
    if frame is None:
        m = EDGE_MARGIN
        return (-m + (1 + 2 * m) * u0) * model.width, (-m + (1 + 2 * m) * v0) * model.height
    u = (frame[0] + (frame[2] - frame[0]) * u0) * model.width
    v = (frame[1] + (frame[3] - frame[1]) * v0) * model.height
    if target is not None:
        row, fits = _row_for_size(model, pose, u, frame[1] * model.height,
                                  frame[3] * model.height, target, visible_hull(asset),
                                  heading, v0)
        if not fits:
            return None
        v = row
    return u, v


#: objects drawn for one place when those drawn cannot show their box sizes in the view
SIZE_PICKS = 4
#: rows tried per placement when an object's box size is drawn (:func:`_row_for_size`)
SIZE_ROWS = 32
#: how far (ratio) a row's expected box size may miss the drawn one and still be chosen
SIZE_SLACK = 1.15


def _row_for_size(model: CameraModel, pose: CameraPose, u: float, v_lo: float, v_hi: float,
                  target_px: float, hull: np.ndarray, heading: float, pick: float
                  ) -> tuple[float, bool]:
    """(the image row, pixels in [v_lo, v_hi], in column ``u`` at which an object whose
    visible part has the hull corners ``hull`` (K, 3) (:func:`~sdcomp.scene.objects.
    visible_hull`: metres, body frame, z up from the waterline), turned to ``heading``
    degrees, shows a box of about ``target_px`` pixels; whether it does). Its box at a
    row is the extent of the corners projected by the camera's local projection there
    (the renderer's, linearised at the object): ``sqrt(w h)``. Of the :data:`SIZE_ROWS`
    rows tried, those within :data:`SIZE_SLACK` of it are kept and ``pick`` (in [0, 1))
    chooses among them; where none is (a steep view has nearly one scale: the size cannot
    be shown there), the nearest, and False (the caller draws again)."""
    rows = np.linspace(v_lo, v_hi, SIZE_ROWS)
    pts, hit = ground_points(model, pose, np.full(SIZE_ROWS, u), rows)
    shown = _box_sides(model, pose, np.where(hit[:, None], pts, 0.0), hull, heading)
    miss = np.where(hit, np.abs(np.log(np.maximum(shown, 1e-9) / target_px)), np.inf)
    near = np.flatnonzero(miss <= math.log(SIZE_SLACK))
    if len(near) == 0:
        return float(rows[int(np.argmin(miss))]), False
    return float(rows[near[min(int(pick * len(near)), len(near) - 1)]]), True


def _box_sides(model: CameraModel, pose: CameraPose, at: np.ndarray, hull: np.ndarray,
               heading: float) -> np.ndarray:
    """(R,) pixels: ``sqrt(w h)`` of the box of the points ``hull`` (K, 3) (metres, body
    frame) of an object at heading ``heading`` degrees standing at each of the sea points
    ``at`` (R, 3) (metres, the point under the camera at the origin), each projected by
    the camera's Jacobian at its place."""
    h = math.radians(heading)
    rot = np.array([[math.cos(h), -math.sin(h), 0.0], [math.sin(h), math.cos(h), 0.0],
                    [0.0, 0.0, 1.0]])
    world = hull @ rot.T  # (K, 3) offsets from the object's place
    basis = camera_basis(pose.pitch, pose.heading)
    xc = (at - np.array([0.0, 0.0, pose.altitude])) @ basis.T  # (R, 3) camera frame
    z = np.maximum(xc[:, 2], 1e-6)
    # d(u, v) / d(camera frame) per row, times the basis: (R, 2, 3) pixels per metre
    d_cam = np.zeros((len(at), 2, 3))
    d_cam[:, 0, 0] = model.fx / z
    d_cam[:, 0, 2] = -model.fx * xc[:, 0] / z ** 2
    d_cam[:, 1, 1] = model.fy / z
    d_cam[:, 1, 2] = -model.fy * xc[:, 1] / z ** 2
    uv = d_cam @ (basis @ world.T)  # (R, 2, K)
    extent = uv.max(axis=2) - uv.min(axis=2)
    return np.sqrt(np.maximum(extent[:, 0] * extent[:, 1], 0.0))


def _clutter_tint(rng: np.random.Generator) -> tuple[float, float, float]:
    """Albedo gains of a clutter object of a one-mesh kind (logs, foam): lighter or darker."""
    g = rng.uniform(0.8, 1.15)
    return (g, g, g)
