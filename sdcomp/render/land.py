"""What is not water: land beyond a coastline (rip-rap along it), and hills standing on the
horizon, lit by the sun and sky of the image's :class:`~sdcomp.render.water.WaterLight` and
exposed like the water."""

from __future__ import annotations

import math

import cv2
import numpy as np

from ..scene.camera import CameraModel, CameraPose, horizon_row, project
from ..scene.scene import Shore
from ..util.colour import linear_to_srgb, srgb_to_linear
from .ground import ground_view, offsets
from .textures import Texture
from .water import WaterLight

HILL_ALBEDO = (0.06, 0.08, 0.05)  # linear RGB: wooded hills
HILL_DISTANCE = 3000.0  # metres: how far the hills are (their haze)
#: the land polygon's near plane, in altitudes along the optical axis: the ground in view
#: lies at least cos(85 degrees) = 0.087 altitudes deep (views up to 170 degrees across)
NEAR = 0.02


def diffuse_scale(light: WaterLight) -> np.ndarray:
    """(3,) float32: exposed linear radiance per unit albedo of a horizontal Lambertian
    surface under the image's sun and sky, ``(E_sun sin(elevation) + E_sky) / pi x gain``."""
    e = light.sun_irradiance * max(float(light.sun[2]), 0.0) + light.sky_irradiance
    return (np.asarray(e, np.float32) * np.float32(light.gain / np.pi)).astype(np.float32)


def albedo_table(scale: np.ndarray) -> np.ndarray:
    """(256, 1, 3) uint8 ``cv2.LUT`` table: sRGB albedo level -> sRGB exposed level of a
    surface with radiance ``albedo x scale`` (3,) (see :func:`diffuse_scale`)."""
    lin = srgb_to_linear(np.arange(256, dtype=np.float32)[:, None] / 255.0) * scale[None]
    out = np.clip(linear_to_srgb(np.clip(lin, 0, 1)) * 255.0 + 0.5, 0, 255)
    return out.astype(np.uint8).reshape(256, 1, 3)


def add_land(image: np.ndarray, model: CameraModel, pose: CameraPose, shore: Shore,
             land: Texture, stones: Texture, light: WaterLight, seed: tuple[int, ...]
             ) -> None:
    """Land beyond the coastline of ``shore`` drawn in place on the uint8 (H, W, 3)
    ``image``: a textured polygon (``land``) with a band of rip-rap (``stones``) along the
    shore, :func:`shore_band` metres wide, lit by ``light``; ``seed`` is the textures'
    offset seed."""
    masks = land_masks(model, pose, shore)
    if masks is None:
        return
    mask, band = masks
    rng = np.random.default_rng(list(seed))
    tex = ground_view(model, pose.altitude, pose.pitch, land, *offsets(rng))
    table = albedo_table(diffuse_scale(light))
    bx, by, bw, bh = cv2.boundingRect(cv2.bitwise_or(mask, band))
    win = (slice(by, by + bh), slice(bx, bx + bw))  # only where land or stones are
    m = mask[win].astype(np.float32) * np.float32(1.0 / 255.0)
    lit = cv2.LUT(np.ascontiguousarray(tex[win]), table)
    land_px = cv2.blendLinear(image[win], lit, 1.0 - m, m)
    stone = ground_view(model, pose.altitude, pose.pitch, stones, *offsets(rng))
    f = band[win].astype(np.float32) * np.float32(1.0 / 255.0)
    lit_stone = cv2.LUT(np.ascontiguousarray(stone[win]), table)
    image[win] = cv2.blendLinear(land_px, lit_stone, 1.0 - f, f)


def shore_band(shore: Shore) -> float:
    """Width (metres) of the rip-rap along the coast of ``shore``: 0.8 to 3 m, drawn from
    its seed (its own stream: no other draw moves)."""
    return float(np.random.default_rng([shore.seed, 0xBA9D]).uniform(0.8, 3.0))


def land_masks(model: CameraModel, pose: CameraPose, shore: Shore
               ) -> tuple[np.ndarray, np.ndarray] | None:
    """(land, band) uint8 (H, W) anti-aliased masks (255 = covered) of the land beyond the
    coastline of ``shore`` and of the rip-rap band along it (:func:`shore_band` wide,
    centred on the coast), or None where no land is in view.

    The land is a ground polygon (the coast and a far edge, ``8 x altitude`` metres out),
    clipped at :data:`NEAR` before it is projected (:func:`clip_near`): its vertices
    behind or beside the camera would project to no pixel, or past int32's range."""
    w, h = model.width, model.height
    a = math.radians(shore.angle)
    normal = np.array([math.cos(a), math.sin(a)])
    reach = pose.altitude * 8  # beyond the frame of any view that sees the coast
    # vertices at most 8 px apart straight down (the wiggle's finest wave is 3.5 m)
    along = np.linspace(-reach, reach, max(800, int(math.ceil(2 * model.fx))))
    coast = np.stack(shore.sea(along, shore.coast(along)), axis=1)
    far = coast + normal * reach
    poly_world = np.concatenate([coast, far[::-1]])
    pts = np.concatenate([poly_world, np.zeros((len(poly_world), 1))], axis=1)
    near = NEAR * pose.altitude
    depth = project(model, pose, pts)[1]
    clipped = clip_near(pts, depth, near, closed=True)
    if not clipped:
        return None
    mask = np.zeros((h, w), np.uint8)
    cv2.fillPoly(mask, [_fixed(model, pose, clipped[0])], 255, lineType=cv2.LINE_AA, shift=4)
    if not mask.any():
        return None
    band = np.zeros((h, w), np.uint8)
    thick = max(1, int(round(shore_band(shore) / max(pose.altitude / model.fx, 1e-6))))
    lines = [_fixed(model, pose, piece) for piece in
             clip_near(pts[: len(coast)], depth[: len(coast)], near, closed=False)]
    cv2.polylines(band, lines, False, 255, thickness=thick, lineType=cv2.LINE_AA, shift=4)
    return mask, band


def clip_near(points: np.ndarray, depth: np.ndarray, near: float, closed: bool
              ) -> list[np.ndarray]:
    """The parts of a polygon (``closed``) or polyline through ``points`` (N, 3) world
    metres in front of the plane ``depth == near`` (``depth`` (N,) metres along the optical
    axis, affine in the points, so edges are cut exactly): [polygon] or [] for a closed one
    (Sutherland-Hodgman against one plane), the runs of a polyline (each (M >= 2, 3)).
    Points all in front come back unchanged."""
    inside = depth >= near
    if inside.all():
        return [points]
    n = len(points)
    nxt = np.roll(np.arange(n), -1)
    t = (near - depth) / np.where(depth[nxt] != depth, depth[nxt] - depth, 1.0)
    cross = points + t[:, None] * (points[nxt] - points)  # where edge i -> i+1 meets it
    cuts = inside != inside[nxt]
    if closed:
        both = np.stack([points, cross], axis=1).reshape(-1, 3)
        keep = np.stack([inside, cuts], axis=1).reshape(-1)
        kept = both[keep]
        return [kept] if len(kept) >= 3 else []
    pieces = []
    idx = np.flatnonzero(inside)
    breaks = np.flatnonzero(np.diff(idx) > 1)
    for s, e in zip(np.r_[idx[:1], idx[breaks + 1]], np.r_[idx[breaks], idx[-1:]],
                    strict=True):
        run = [cross[s - 1:s]] if s > 0 else []
        run += [points[s:e + 1]] + ([cross[e:e + 1]] if e < n - 1 else [])
        piece = np.concatenate(run)
        if len(piece) >= 2:
            pieces.append(piece)
    return pieces


def _fixed(model: CameraModel, pose: CameraPose, points: np.ndarray) -> np.ndarray:
    """(N, 2) int32 pixel coordinates x 16 (OpenCV's ``shift=4``) of world ``points`` (N, 3)
    in front of the camera; held inside int32 (a bound far outside any frame)."""
    uv = project(model, pose, points)[0]
    return np.clip(np.round(uv * 16), -2 ** 30, 2 ** 30).astype(np.int32)


def add_hills(image: np.ndarray, model: CameraModel, pose: CameraPose, seed: int,
              light: WaterLight, visibility: float) -> None:
    """A ridge of hills (the ridge line's seed ``seed``) standing on the horizon, drawn in
    place on the uint8 (H, W, 3) ``image`` when the horizon is in view: wooded slopes lit
    by ``light``, veiled by the haze of :data:`HILL_DISTANCE` metres of air of
    ``visibility`` metres."""
    w, h = model.width, model.height
    v_h = horizon_row(model, pose.pitch)
    if v_h <= 0:
        return
    rng = np.random.default_rng(seed)
    x = np.arange(w, dtype=np.float64)
    ridge = np.zeros(w)
    for wl in (w * 1.3, w * 0.45, w * 0.13, w * 0.04):
        ridge += rng.uniform(0.3, 1.0) * wl * np.sin(2 * np.pi * x / wl
                                                     + rng.uniform(0, 6.3))
    height = np.clip(model.fy * math.radians(rng.uniform(0.4, 2.2))
                     * (0.6 + 0.4 * ridge / (np.abs(ridge).max() + 1e-9)), 0, None)
    if rng.random() < 0.5:  # hills on one side only
        side = np.clip((x / w - rng.uniform(0.2, 0.8)) * rng.choice([-1, 1]) * 6, 0, 1)
        height = height * side
    top = v_h - height
    rows = min(h, int(math.ceil(v_h)) + 1)  # the hills end on the horizon
    yy = np.arange(rows, dtype=np.float64)[:, None]
    cover = np.clip(np.minimum(yy + 0.5 - top[None, :], v_h + 1.0 - yy), 0, 1)
    cover = cover.astype(np.float32)[..., None]
    haze = float(np.exp(-HILL_DISTANCE / visibility))
    lin = (np.asarray(HILL_ALBEDO) * diffuse_scale(light) * haze
           + light.sky.horizon_rgb * light.gain * (1.0 - haze))
    hill = linear_to_srgb(np.clip(lin, 0, 1)) * 255.0
    img = image[:rows].astype(np.float32) * (1 - cover) + cover * hill.astype(np.float32)
    image[:rows] = np.clip(img + 0.5, 0, 255).astype(np.uint8)
