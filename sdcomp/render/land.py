"""What is not water: land beyond a coastline, and the sky (with hills) above the horizon."""

from __future__ import annotations

import math

import cv2
import numpy as np

from ..scene.camera import (
    CameraModel,
    CameraPose,
    horizon_row,
    pixel_centres,
    project,
    row_directions,
)
from ..scene.scene import Shore
from ..util.colour import linear_to_srgb
from .ground import offsets
from .optics import sky_linear
from .textures import Texture


def add_land(image: np.ndarray, model: CameraModel, pose: CameraPose, shore: Shore,
             land: Texture, gain: np.ndarray, seed: tuple[int, ...]) -> None:
    """Land beyond the coastline of ``shore`` drawn in place on the uint8 (H, W, 3)
    ``image``: a textured polygon with a foam line at the shore; ``gain`` is the camera
    gain on the background grid, ``seed`` the land texture's offset seed."""
    w, h = model.width, model.height
    a = math.radians(shore.angle)
    normal = np.array([math.cos(a), math.sin(a)])
    along_dir = np.array([-math.sin(a), math.cos(a)])
    reach = pose.altitude * 8  # beyond the frame of any view that sees the coast
    along = np.linspace(-reach, reach, 800)
    across = shore.distance + shore.wiggle(along)
    coast = along[:, None] * along_dir + across[:, None] * normal
    far = coast + normal * reach
    poly_world = np.concatenate([coast, far[::-1]])
    pts = np.concatenate([poly_world, np.zeros((len(poly_world), 1))], axis=1)
    uv, depth = project(model, pose, pts)
    ok = (depth > 1e-3) & np.isfinite(uv).all(axis=1)
    if ok.sum() < 3:
        return
    mask = np.zeros((h, w), np.uint8)
    poly = np.round(uv[ok] * 16).astype(np.int32)
    cv2.fillPoly(mask, [poly], 255, lineType=cv2.LINE_AA, shift=4)
    if not mask.any():
        return
    line = np.round(uv[: len(coast)][ok[: len(coast)]] * 16).astype(np.int32)
    foam = np.zeros((h, w), np.uint8)
    thick = max(1, int(round(0.6 / max(pose.altitude / model.fx, 1e-6))))
    cv2.polylines(foam, [line], False, 255, thickness=thick, lineType=cv2.LINE_AA,
                  shift=4)
    gx, gy = model.nadir_gsd(pose.altitude)
    tex = land.view(*offsets(np.random.default_rng(list(seed))), gx * w, gy * h, w, h)
    g = float(np.mean(gain))
    bx, by, bw, bh = cv2.boundingRect(cv2.bitwise_or(mask, foam))
    win = (slice(by, by + bh), slice(bx, bx + bw))  # only where land or foam is
    m = mask[win].astype(np.float32) * np.float32(1.0 / 255.0)
    land_px = cv2.blendLinear(image[win], cv2.convertScaleAbs(tex[win], alpha=g), 1.0 - m, m)
    f = foam[win].astype(np.float32) * np.float32(0.7 / 255.0)
    white = np.full_like(land_px, min(255, round(230.0 * g)))
    image[win] = cv2.blendLinear(land_px, white, 1.0 - f, f)


def add_sky(image: np.ndarray, model: CameraModel, pose: CameraPose, hills: int | None,
            gain: np.ndarray) -> None:
    """The sky above the horizon (a sharp line) drawn in place on the uint8 (H, W, 3)
    ``image``, with hills on it when ``hills`` (the ridge's seed) is given; ``gain`` is the
    camera gain on the background grid."""
    h = model.height
    v_h = horizon_row(model, pose.pitch)
    rows = int(math.ceil(max(0.0, min(h, v_h))))
    if rows <= 0:
        return
    vv = pixel_centres(model, 1, rows)
    # elevation sine of each row's ray through the image centre column
    fwd, up = row_directions(pose.pitch, vv)
    sin_el = up / np.sqrt(up ** 2 + fwd ** 2)
    col = sky_linear(np.clip(sin_el, 0, 1)) * float(np.mean(gain[0]))
    col = linear_to_srgb(col) * 255.0
    image[:rows] = np.clip(col + 0.5, 0, 255).astype(np.uint8)[:, None, :]
    if hills is not None:
        _add_hills(image, model, v_h, hills, float(np.mean(gain[0])))


def _add_hills(image: np.ndarray, model: CameraModel, v_h: float, seed: int,
               gain: float) -> None:
    """A ridge of hills standing on the horizon row ``v_h``, drawn in place."""
    w, h = model.width, model.height
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
    yy = np.arange(h, dtype=np.float64)[:, None]
    cover = np.clip(np.minimum(yy + 0.5 - top[None, :], v_h + 1.0 - yy), 0, 1)
    cover = cover.astype(np.float32)[..., None]
    hill = linear_to_srgb(np.array([0.10, 0.13, 0.09]) * 0.6 + 0.4 * np.array(
        sky_linear(0.0))) * 255.0 * gain
    img = image.astype(np.float32) * (1 - cover) + cover * hill.astype(np.float32)
    image[:] = np.clip(img + 0.5, 0, 255).astype(np.uint8)
