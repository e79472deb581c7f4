"""Ground textures seen through the camera: straight down (one resampled crop) and oblique
(one ground line per image row), faded to the texture's mean where a row would alias."""

from __future__ import annotations

import cv2
import numpy as np

from ..scene.camera import CameraModel, pixel_centres, row_directions
from .textures import Texture


def ground_view(model: CameraModel, altitude: float, pitch: float, tile: Texture, x0: float,
                y0: float) -> np.ndarray:
    """(H, W, C) uint8: ``tile`` on a ground plane ``altitude`` metres below a camera
    pitched ``pitch`` degrees (in its heading frame), its origin offset by (x0, y0) metres.
    (The sea floor is such a plane, at its apparent depth.)"""
    if pitch >= 89.999:
        gx, gy = model.nadir_gsd(altitude)
        return tile.view(x0, y0, gx * model.width, gy * model.height, model.width,
                         model.height)
    return perspective_sample(model, altitude, pitch, tile, x0, y0)


def perspective_sample(model: CameraModel, altitude: float, pitch: float, tile: Texture,
                       x0: float, y0: float) -> np.ndarray:
    """Sample a ground texture through an oblique camera: image rows map to ground
    distance, columns to the lateral offset, in the camera's heading frame. (H, W, C) uint8.

    Rows whose pixels span many texels would alias: they fade to the tile's mean (and
    rows that are all mean, beyond the fade or above the horizon, are not sampled)."""
    w, h = model.width, model.height
    u = pixel_centres(model, 0, dtype=np.float32)
    v = pixel_centres(model, 1, dtype=np.float32)
    # camera frame ray (u, v, 1) in (forward-horizontal, right, up) components
    fwd, up = row_directions(pitch, v)
    valid_row = up < -1e-4
    t = np.where(valid_row, altitude / np.maximum(-up, 1e-4), np.inf)  # distance
    centre = min(int(h * 0.75), h - 1)
    pitch_m = float(t[centre]) / model.fx if valid_row[centre] else 1.0
    row_pitch = t / model.fx  # metres per pixel per row
    over = np.log2(np.maximum(row_pitch / max(pitch_m, 1e-9), 1e-9))
    keep = np.clip(1.5 - over, 0.0, 1.0).astype(np.float32)  # (h,) 1: texture, 0: mean
    mean = tile.mean
    # one row of the mean colour (whole rows are copied fast; a (C,) broadcast is not)
    mean_row = np.tile(np.clip(mean + 0.5, 0, 255).astype(np.uint8), w)
    out = np.empty((h, w, mean.size), np.uint8)
    rows = np.flatnonzero(keep > 0)
    r0, r1 = (int(rows[0]), int(rows[-1]) + 1) if rows.size else (h, h)
    out.reshape(h, -1)[:r0] = mean_row
    out.reshape(h, -1)[r1:] = mean_row
    if r0 == r1:
        return out
    tex = tile.sample_rows(x0, y0, t[r0:r1], u, -fwd[r0:r1] * t[r0:r1], pitch_m)
    out[r0:r1] = tex
    fade = np.flatnonzero(keep[r0:r1] < 1) + r0  # rows of tex x keep + mean x (1 - keep)
    if fade.size:
        f0, f1 = int(fade[0]), int(fade[-1]) + 1
        band = out[f0:f1]
        k = np.repeat(keep[f0:f1, None], w, axis=1)
        means = np.repeat(mean_row[None], f1 - f0, axis=0).reshape(band.shape)
        cv2.blendLinear(band, means, k, 1.0 - k, dst=band)
    return out


def offsets(rng: np.random.Generator) -> tuple[float, float]:
    """A random texture offset (x0, y0) in metres, as numpy float64 scalars (which keep the
    arithmetic of :meth:`Texture.sample_rows` in float64)."""
    x0, y0 = rng.uniform(0, 1000, 2)
    return x0, y0

