"""Test helpers for the water renderer (:mod:`sdcomp.render.water`): a slow per-pixel
reference of its shading, and the realism metrics of empty-water patches.

:func:`render_reference` draws the same scene as :func:`sdcomp.render.water.render_water`
but evaluates the reflection of the sky and the water-leaving light exactly at every pixel,
for the pixel's own normal (long waves + the three drawn texture layers), instead of the
linearised ``A + B z`` of the fast path (no glitter, no whitecaps).

:func:`patch_stats` and :func:`summarise` are the realism metrics the water was tuned to
(the prototype's ``seawater/metrics.py``), as the realism report computes them
(:mod:`sdcomp.report.realism.patches`, defined in docs/realism.md): Rec. 601 luma ``Y`` of
the 8-bit values, ``highpass = Y - box9(Y)`` on the whole image, HSV saturation, 64 x 64
patches from the top-left corner; a patch counts when all its pixels see the sea
(``valid``). :data:`REAL` holds the real frames' figures
(:data:`sdcomp.report.realism.targets.REAL_REFERENCE`) as (median, p10, p90).
"""

from __future__ import annotations

import numpy as np

from sdcomp.render.water import optics
from sdcomp.render.water.base import LW_ANISO, R0
from sdcomp.render.water.layers import wave_layers
from sdcomp.render.water.optics import N_WATER, fresnel
from sdcomp.render.water.shading import _slopes_box
from sdcomp.render.water.surface import draw_water, view_water
from sdcomp.report.realism import patches
from sdcomp.report.realism.patches import highpass
from sdcomp.report.realism.patches import luminance as luma
from sdcomp.report.realism.targets import REAL_REFERENCE
from sdcomp.scene.camera import camera_basis

__all__ = ["REAL", "highpass", "luma", "patch_stats", "render_reference", "summarise"]
#: real SeaDronesSee-like frames: (median, 10th, 90th percentile) per metric (None: unknown)
REAL = {m: (r["median"], r.get("p10"), r.get("p90")) for m, r in REAL_REFERENCE.items()}


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


def patch_stats(rgb: np.ndarray, valid: np.ndarray | None = None) -> dict[str, np.ndarray]:
    """Per-patch statistics {metric: (m,) float64} of an (H, W, 3) uint8 RGB image over the
    64 x 64 patches that see only the sea (``valid`` (H, W) bool; None: every patch)."""
    keep = patches.empty_water(rgb.shape[:2], valid=valid)
    return patches.patch_stats(rgb, keep)


def summarise(stats: list[dict[str, np.ndarray]]) -> dict[str, dict[str, float]]:
    """{metric: {n, median, p10, p90, ...}} over the concatenated per-patch statistics."""
    return patches.summarise(patches.concat_stats(stats))
