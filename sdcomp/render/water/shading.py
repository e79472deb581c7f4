"""Shading the wave layers: ``img = A + B z`` (smooth colour, smooth response per unit slope, the
unit texture variable), and whitecaps."""

from __future__ import annotations

import math

import cv2
import numpy as np

from . import optics
from .base import FACET, FOAM_ALBEDO, LAYERS, Z_SCALE, scratch, tick, to_u8
from .layers import level_runs, resize_box
from .optics import luminance
from .textures import N_LEVELS, SLOPE_SCALE, foam_exceedance, pitch
from .waves import WaveState, layer_weights_at


def _direction(resp: dict) -> np.ndarray:
    """The image's slope direction (2,): the principal axis of the luminance response, signed
    so that the mean response along it is positive (the drawn amplitude ``B`` is a
    magnitude: with the axis's other sign the waves would be drawn inverted)."""
    ju = luminance(resp["u"]).ravel()
    jc = luminance(resp["c"]).ravel()
    m = np.array([[ju @ ju, ju @ jc], [ju @ jc, jc @ jc]])
    if not np.isfinite(m).all() or m.trace() <= 1e-12:
        return np.array([1.0, 0.0])
    _, vecs = np.linalg.eigh(m)
    g = vecs[:, -1]
    if float(np.mean(ju * g[0] + jc * g[1])) < 0:
        g = -g
    return g / np.linalg.norm(g)


def _transform_runs(src, dst, levels, waves, g, k, which: int, shift: int,
                    offset: float = 128.0, grain=None) -> None:
    """``dst = offset + k g . (w t) + k grain n`` per run of rows of one level (``w``: the
    layer weights of level ``lev + shift``, layer ``which``; ``n``: the tile's per-texel
    noise channel, ``grain(lev)`` its weight)."""
    m = np.zeros((3, 4), np.float32)
    runs = level_runs(levels)
    for lev, a, b in runs:
        wt = layer_weights_at(waves, lev + shift)[which]
        m[:, 0] = k * g[0] * wt[0]
        m[:, 1] = k * g[1] * wt[1]
        m[:, 2] = k * (grain(lev) if grain is not None else 0.0)
        m[:, 3] = offset - 128.0 * (m[0, 0] + m[0, 1] + m[0, 2])
        one = len(runs) == 1
        cv2.transform(src if one else src[a:b], m, dst=dst if one else dst[a:b])


def _z_layer(layers, name: str, which: int, waves, g) -> np.ndarray:
    """(rows, cols) float32 ``g . (w t)`` of texture layer ``name`` (index ``which`` in
    LAYERS) in units of the total drawn sd."""
    c4 = layers[name + "4"]
    z = np.empty(c4.shape[:2], np.float32)
    inv = 1.0 / SLOPE_SCALE
    off = LAYERS[which][2]
    for lev, a, b in level_runs(layers["levels_" + name]):
        wt = layer_weights_at(waves, lev - off)[which]
        cu, cc = g[0] * wt[0] * inv, g[1] * wt[1] * inv
        blk = c4[a:b]
        z[a:b] = blk[..., 0] * np.float32(cu) + blk[..., 1] * np.float32(cc) - np.float32(
            128.0 * (cu + cc))
    return z


def shade_fast(img, layers, a_srgb, resp, plan, waves) -> None:
    """``img = A + B (z_a + z_b + z_c)`` (A: smooth colour, B: smooth per-channel amplitude,
    z: unit texture variable along the image's slope direction; z_a of the full-resolution
    layer, z_b, z_c of the 1/4 and 1/16 ones). Full-resolution passes: z_a =
    transform(codes); img = z_a * B + D with ``D = A - B * 128 / Z_SCALE + B (z_b + z_c)``
    made at quarter resolution."""
    g = _direction(resp)
    rows, w = img.shape[:2]
    k = Z_SCALE / SLOPE_SCALE
    a4 = layers["a4"]
    a3 = scratch("a3", (rows, w, 3))
    cv2.cvtColor(a4, cv2.COLOR_RGBA2RGB, dst=a3)
    z = scratch("za", (rows, w, 3))

    def grain(lev: int) -> float:
        """Sub-pixel facets: their reflections average over ~(footprint / FACET)**2 of
        them; the grain they leave, relative to the drawn waves' response."""
        if lev >= N_LEVELS:
            return 0.0
        un = float(np.sqrt(waves.unres[lev].sum()))
        res = float(np.sqrt((waves.resolved_sd(lev) ** 2).sum()))
        fp = pitch(lev) / 0.75 if not plan.nadir else pitch(lev)
        return min(0.6, un / max(res, 1e-6) * FACET / max(fp, FACET))

    _transform_runs(a3, z, layers["levels_a"], waves, g, k, 0, 0, grain=grain)
    tick("sh.z")
    b = np.sqrt(resp["u"] ** 2 + resp["c"] ** 2).astype(np.float32)  # levels per unit z
    b8 = np.clip(b * np.float32(128.0 / Z_SCALE), 0, 255)
    hq, wq = layers["b4"].shape[:2]
    zb = _z_layer(layers, "b", 1, waves, g)
    zb += cv2.resize(_z_layer(layers, "c", 2, waves, g), (wq, hq),
                     interpolation=cv2.INTER_LINEAR)
    a_q = cv2.resize(a_srgb.astype(np.float32), (wq, hq), interpolation=cv2.INTER_LINEAR)
    b_q = cv2.resize(b, (wq, hq), interpolation=cv2.INTER_LINEAR)
    b8_q = cv2.resize(b8, (wq, hq), interpolation=cv2.INTER_LINEAR)
    d_q = a_q - b8_q + b_q * zb[..., None]
    tick("sh.quarter")
    grid = plan.sea
    bfull = grid.upsample(to_u8(b8), out=scratch("shade_b", img.shape))
    cv2.multiply(z, bfull, dst=img, scale=1.0 / 128.0)
    tick("sh.mul")
    dfull = scratch("shade_d", img.shape)
    cv2.resize(to_u8(d_q), (w, rows), dst=dfull, interpolation=cv2.INTER_LINEAR)
    cv2.add(img, dfull, dst=img)
    if float(d_q.min()) <= -0.5:
        cv2.resize(to_u8(-d_q), (w, rows), dst=dfull, interpolation=cv2.INTER_LINEAR)
        cv2.subtract(img, dfull, dst=img)
    tick("sh.add")


def _slopes_box(layers, waves, x0, y0, x1, y1) -> tuple[np.ndarray, np.ndarray]:
    """Drawn slopes per pixel over a box (rows y0..y1 relative to the sea's first row), in
    units of the total drawn sd: (t_u, t_c) float32 from the three layers (the low ones
    magnified, cell-centred, as in :func:`shade_fast`)."""
    a4 = layers["a4"]
    rows, w = a4.shape[:2]
    tu = np.zeros((y1 - y0, x1 - x0), np.float32)
    tc = np.zeros_like(tu)
    for k, (name, _, off) in enumerate(LAYERS):
        c = resize_box(layers[name + "4"], rows, w, x0, y0, x1, y1) if k else \
            a4[y0:y1, x0:x1]
        wts = np.zeros((y1 - y0, 2), np.float32)
        for lev, a, b in level_runs(layers["levels_a"][y0:y1]):
            wts[a:b] = layer_weights_at(waves, lev)[k]
        tu += (c[..., 0].astype(np.float32) - 128.0) * wts[:, :1] / SLOPE_SCALE
        tc += (c[..., 1].astype(np.float32) - 128.0) * wts[:, 1:] / SLOPE_SCALE
        del off
    return tu, tc


def shade_exact(img, layers, a_srgb, resp, plan, waves) -> None:
    """``img = A + J_u t_u + J_c t_c`` per pixel in float32 (reference shading)."""
    rows, w = img.shape[:2]
    tu, tc = _slopes_box(layers, waves, 0, 0, w, rows)
    grid = plan.sea
    a = grid.upsample(a_srgb.astype(np.float32))
    ju = grid.upsample(resp["u"].astype(np.float32))
    jc = grid.upsample(resp["c"].astype(np.float32))
    img[:] = to_u8(a + ju * tu[..., None] + jc * tc[..., None])


def add_foam(img, a4, sea, waves: WaveState, gain, a_srgb) -> None:
    """Whitecaps: where the tile's foam code exceeds the quantile of the coverage (see
    :mod:`sdcomp.render.water.textures`), the water brightens towards foam (diffuse white under the
    mean downwelling light), with soft edges (over 0.19 decades of the exceedance
    probability: from 1.16 W to 0.75 W)."""
    cover = waves.foam * sea["foam_scale"] * float(1.0 - 0.8 * sea["slick"].mean())
    if cover < 1e-4:
        return
    decades = -np.log10(np.maximum(foam_exceedance(), 1e-6)) + math.log10(cover)
    lut = to_u8(np.clip((decades * (255.0 / 4.0) + 4.0) / 12.0, 0.0, 1.0) * 255.0)
    e_d = sea["e_d"].mean(0)
    foam_lin = FOAM_ALBEDO / math.pi * e_d * gain * float(sea["haze"].mean())
    foam = optics.srgb_encode(foam_lin) * 255.0
    add = np.clip(foam - a_srgb.reshape(-1, 3).mean(0), 0, 255)  # (3,) sRGB levels
    rows, w = img.shape[:2]
    f1 = scratch("foam1", (rows, w))
    cv2.extractChannel(a4, 3, dst=f1)
    cv2.LUT(f1, lut, dst=f1)
    f3 = scratch("foam3", img.shape)
    cv2.cvtColor(f1, cv2.COLOR_GRAY2RGB, dst=f3)
    m = np.zeros((3, 3), np.float32)
    m[0, 0], m[1, 1], m[2, 2] = add / 255.0
    cv2.transform(f3, m, dst=f3)
    cv2.add(img, f3, dst=img)
