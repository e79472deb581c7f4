"""Test helpers for the water renderer (:mod:`sdcomp.render.water`): a slow per-pixel
reference of its shading, and the realism metrics of empty-water patches.

:func:`render_reference` draws the same scene as :func:`sdcomp.render.water.render_water`
but evaluates the reflection of the sky and the water-leaving light exactly at every pixel,
for the pixel's own normal (long waves + the three drawn texture layers), instead of the
linearised ``A + B z`` of the fast path (no glitter, no whitecaps).

:func:`patch_stats` and :func:`summarise` are the realism metrics the water was tuned to
(copied from the prototype's ``seawater/metrics.py``; sdcomp itself has no patch metrics):

- ``Y = 0.299 R + 0.587 G + 0.114 B`` (float32, 0..255);
- ``highpass = Y - box9(Y)`` (9 x 9 box mean, borders reflected without repeating the edge
  pixel: OpenCV's BORDER_REFLECT_101) on the whole image, then cut into patches;
- ``S = (max - min) / max`` of R, G, B (0 where max = 0);
- patches: non-overlapping 64 x 64 tiles from the top-left corner; a patch counts when all
  its pixels see the sea (``valid``);
- per patch: saturation = mean(S), luminance = mean(Y), highpass_std = std(highpass),
  glint_fraction = mean(Y >= 230).
"""

from __future__ import annotations

import cv2
import numpy as np

from sdcomp.render.water import optics
from sdcomp.render.water.base import LW_ANISO, R0
from sdcomp.render.water.layers import wave_layers
from sdcomp.render.water.optics import N_WATER, fresnel
from sdcomp.render.water.shading import _slopes_box
from sdcomp.render.water.surface import draw_water, view_water
from sdcomp.scene.camera import camera_basis

PATCH = 64
METRICS = ("saturation", "luminance", "highpass_std", "glint_fraction")
#: real SeaDronesSee-like frames: (median, 10th, 90th percentile) per metric
REAL = {"saturation": (0.18, 0.04, 0.32), "luminance": (121.0, None, None),
        "highpass_std": (6.2, 2.1, 26.2), "glint_fraction": (0.003, 0.0, 0.18)}


def render_reference(model, pose, params, textures) -> tuple[np.ndarray, dict]:
    """(image (H, W, 3) uint8, info) of :func:`render_water` without glitter, the sea's
    rows shaded exactly per pixel: the pixel's normal from the interpolated long-wave slope
    plus its drawn slopes (three layers), the sky reflected about it (Fresnel of its
    incidence angle, the sky blurred by the unresolved roughness), the water-leaving light
    transmitted through it, haze towards the horizon colour; same exposure gain."""
    view = view_water(model, pose, params, textures)
    img, info = draw_water(view, textures, glint="none")
    plan, sea, waves, frame = view.plan, view.sea, view.waves, view.frame
    grid = plan.sea
    layers = wave_layers(plan, textures, view.altitude, frame, view.world_off, frame["rows"])
    rows, w = grid.r1 - grid.r0, plan.width
    e_u, e_c = frame["e_u"], frame["e_c"]
    # per-pixel view rays in the world frame
    v = (np.arange(grid.r0, grid.r1) + 0.5 - plan.height / 2) / plan.fy
    u = (np.arange(w) + 0.5 - plan.width / 2) / plan.fx
    uu, vv = np.meshgrid(u, v)
    d = np.stack([uu, vv, np.ones_like(uu)], -1) @ camera_basis(pose.pitch, pose.heading)
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    # slopes: long waves (coarse, interpolated) + drawn layers (per pixel, in units of the
    # drawn standard deviation)
    gh, gw = sea["shape"]
    res = grid.upsample(sea["res_sd"].reshape(gh, gw, 2).astype(np.float32))
    tu, tc = _slopes_box(layers, waves, 0, 0, w, rows)
    slope = (tu * res[..., 0])[..., None] * e_u + (tc * res[..., 1])[..., None] * e_c
    slope = slope + grid.upsample(sea["long_slope"].reshape(gh, gw, 2).astype(np.float32))
    n = np.concatenate([-slope, np.ones(slope.shape[:-1] + (1,))], -1)
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    cos_i = np.clip(-(n * d).sum(-1), 1e-4, 1.0)
    refl = d + 2.0 * cos_i[..., None] * n
    unres = grid.upsample(sea["unres"].reshape(gh, gw, 2).astype(np.float32))
    blur = 2.0 * np.sqrt(unres.sum(-1))
    l_sky = view.sky.radiance(refl.reshape(-1, 3), blur.reshape(-1)).reshape(refl.shape)
    r = fresnel(cos_i)[..., None]
    l_w = grid.upsample(sea["l_w"].reshape(gh, gw, 3).astype(np.float32))
    down = -d[..., 2]
    cos_w = np.sqrt(1.0 - (1.0 - cos_i ** 2) / N_WATER ** 2)
    cos_wz = np.clip(cos_w * n[..., 2] - np.sqrt(np.maximum(1 - cos_w ** 2, 0)) *
                     np.sqrt(np.maximum(1 - n[..., 2] ** 2, 0)), -1, 1)
    aniso = (1.0 + LW_ANISO * (1.0 - np.abs(cos_wz))) / (1.0 + LW_ANISO * (
        1.0 - np.sqrt(1.0 - (1.0 - down ** 2) / N_WATER ** 2)))
    view_t = ((1.0 - r[..., 0]) * aniso)[..., None] / (1.0 - R0)
    haze = np.exp(-(view.altitude / np.maximum(down, 1e-6)) / params.visibility)[..., None]
    rad = (r * l_sky + view_t * l_w) * haze + view.sky.horizon_rgb * (1.0 - haze)
    out = img.copy()
    out[grid.r0:grid.r1] = np.clip(optics.srgb_encode(rad * view.gain) * 255.0 + 0.5, 0,
                                   255).astype(np.uint8)
    return out, info


def luma(rgb: np.ndarray) -> np.ndarray:
    """(H, W) float32 ``0.299 R + 0.587 G + 0.114 B`` of an (H, W, 3) uint8 image."""
    f = rgb.astype(np.float32)
    return f[..., 0] * np.float32(0.299) + f[..., 1] * np.float32(0.587) + f[..., 2] * \
        np.float32(0.114)


def highpass(y: np.ndarray) -> np.ndarray:
    """``y`` minus its 9 x 9 box mean (borders reflected, BORDER_REFLECT_101)."""
    return y - cv2.blur(y, (9, 9), borderType=cv2.BORDER_REFLECT_101)


def patch_stats(rgb: np.ndarray, valid: np.ndarray | None = None) -> dict[str, np.ndarray]:
    """Per-patch statistics {metric: (m,) float64} of an (H, W, 3) uint8 RGB image over the
    64 x 64 patches that see only the sea (see the module docstring)."""
    a = np.ascontiguousarray(rgb)
    y = luma(a)
    hp = highpass(y)
    r, g, b = cv2.split(a)
    mx = cv2.max(cv2.max(r, g), b).astype(np.float32)
    mn = cv2.min(cv2.min(r, g), b).astype(np.float32)
    s = np.divide(mx - mn, mx, out=np.zeros_like(mx), where=mx > 0)
    h, w = y.shape
    rows, cols = h // PATCH, w // PATCH

    def tiles(m):
        t = m[:rows * PATCH, :cols * PATCH].reshape(rows, PATCH, cols, PATCH)
        return t.swapaxes(1, 2).reshape(rows * cols, PATCH * PATCH)

    keep = np.ones(rows * cols, bool)
    if valid is not None:
        keep &= tiles(np.asarray(valid, bool)).all(axis=1)
    yt, ht, st = tiles(y)[keep], tiles(hp)[keep], tiles(s)[keep]
    return {"saturation": st.mean(1, dtype=np.float64),
            "luminance": yt.mean(1, dtype=np.float64),
            "highpass_std": ht.std(1, dtype=np.float64),
            "glint_fraction": (yt >= 230.0).mean(1, dtype=np.float64)}


def summarise(stats: list[dict[str, np.ndarray]]) -> dict[str, dict[str, float]]:
    """{metric: {n, median, p10, p90}} over the concatenated per-patch statistics."""
    out = {}
    for m in METRICS:
        v = np.concatenate([np.asarray(s[m], np.float64) for s in stats])
        p10, p50, p90 = np.percentile(v, (10, 50, 90)) if v.size else (np.nan,) * 3
        out[m] = {"n": int(v.size), "median": float(p50), "p10": float(p10),
                  "p90": float(p90)}
    return out
