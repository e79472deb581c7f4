"""Sun glitter per pixel: a compound Poisson number of sparkles from the Cox-Munk PDF of the facet
slope that mirrors the sun, given the pixel's drawn slope."""

from __future__ import annotations

import math
import weakref

import cv2
import numpy as np

from ...util.tiles import wrap_window
from . import optics
from .base import (
    GLINT_LN0,
    GLINT_LN_STEP,
    GLINT_MIN,
    LAYERS,
    SLOPE_NU,
    SPARKLE_BLUR,
    SUN_DISC,
    scratch,
    tick,
    to_u8,
)
from .coarse import facets, quantum
from .detile import mosaic
from .layers import level_runs, resize_box
from .optics import luminance
from .sky import Sky
from .textures import SLOPE_SCALE, WaterTextures
from .waves import WaveState, layer_weights_at


def add_mean_glint(img: np.ndarray, sea: dict, gain: float, plan) -> None:
    """The glitter's expected brightness, smooth (no sparkles), added in place to the sea
    rows ``img`` (H - sea_row0, W, 3) uint8: per coarse grid point, the mean over the glint
    table's distribution of a pixel's clipped value ``E[min(b + q S, 1)]`` (``b`` the water's
    luminance, ``q`` a sparkle's quantum, ``S`` the compound Poisson glint of the point's
    expected count), added as :func:`add_glitter` adds its sparkles: the sRGB difference,
    the same in every channel."""
    lam = np.asarray(sea["lam"], np.float64)
    if float(np.max(sea["glint_white"])) < GLINT_MIN:
        return
    gh, gw = sea["shape"]
    base = np.clip(luminance(sea["L0"]) * gain, 0.0, 1.0)
    mean = expected_clipped(lam, base, np.asarray(sea["quantum"], np.float64))
    diff = (optics.srgb_encode(mean) - optics.srgb_encode(base)) * 255.0
    up = plan.sea.upsample(to_u8(diff.reshape(gh, gw)))
    cv2.add(img, cv2.cvtColor(up, cv2.COLOR_GRAY2RGB), dst=img)


def expected_clipped(lam: np.ndarray, base: np.ndarray, q: np.ndarray) -> np.ndarray:
    """``E[min(base + q S, 1)]`` per point (N,) for the compound Poisson glint ``S`` of
    ``lam`` expected sparkles (:func:`_glint_table`: its quantiles at exceedance
    probabilities ``10**(-6 c / 255)``, rows interpolated in ``ln lam``; the tail beyond
    1e-6 is left out)."""
    table = _glint_table().astype(np.float64)  # (rows, 256)
    f = np.clip((np.log(np.maximum(lam, 1e-300)) - GLINT_LN0) / GLINT_LN_STEP, 0,
                table.shape[0] - 1)
    r0 = np.minimum(np.floor(f).astype(np.int64), table.shape[0] - 2)
    w = f - r0
    # beyond the last row, lam sparkles sum to lam / lam_top times lam_top's (see
    # _beyond_table)
    ln_top = GLINT_LN0 + (table.shape[0] - 1) * GLINT_LN_STEP
    q = q * np.exp(np.maximum(np.log(np.maximum(lam, 1e-300)) - ln_top, 0.0))
    p = 10.0 ** (-6.0 * np.arange(table.shape[1]) / (table.shape[1] - 1))
    dp = np.append(-np.diff(p), p[-1])  # probability of each quantile's interval

    def mean_of(rows: np.ndarray) -> np.ndarray:
        x = table[rows]  # (N, 256) the value exceeded with probability p (rising)
        mid = 0.5 * (x + np.concatenate([x[:, 1:], x[:, -1:]], axis=1))
        return (np.minimum(base[:, None] + q[:, None] * mid, 1.0) * dp[None]).sum(1)

    return mean_of(r0) * (1 - w) + mean_of(r0 + 1) * w


def add_glitter(img, layers, sea, gain, plan, textures: WaterTextures, noise_off, sky: Sky,
             waves: WaveState, fp_rows):
    """Sun glitter (Cox & Munk 1954) per pixel, added to the image in the region where it
    can matter (its box is returned as (x0, y0, x1, y1), or None).

    A pixel's expected glint is ``E_sun R p(s) / (4 cos theta_v cos^4 beta)`` with ``p`` the
    Gaussian PDF of the UNRESOLVED slopes around the pixel's drawn slope (long waves plus
    its two texture layers): facets tilted towards the sun's mirror direction glow, so the
    glitter follows the waves. It is made of sparkles: a compound Poisson sum of
    ``lam`` sparkles (see SPARKLE_DENSITY) of Pareto intensities, drawn from the glint
    table with the pixel's noise (``textures.noise``): isolated sparkles (some saturated)
    where ``lam`` is small, a grainy sheen where it is large, blown-out white at the centre.

    Per pixel, with the drawn slope ``t = sum_k w_k (code_k - 128) / 32`` over the texture
    layers, ``ln lam = lc - (nu + 2) / 2 ln(1 + q_u^2 + q_c^2)`` with ``q = k - b t``: the
    coarse terms are folded into ``q = K - P (A + M)``, ``M = r_b (B - 128) + r_c (C -
    128)``, ``r_k = w_k / w_a``."""
    if sky.e_sun <= 0:
        return None
    gl = sea["glint_log"]
    gh, gw = sea["shape"]
    unres = sea["unres"]
    sdr = sea["res_sd"]
    nu = SLOPE_NU
    kt = (nu - 2.0) / nu
    su = np.sqrt(unres[:, 0] * kt)  # Student-t scales
    sc = np.sqrt(unres[:, 1] * kt)
    lam0 = gl["geo"] * sea["haze"] * sea["density"]  # sparkles per pixel per unit PDF
    logc = np.log(np.maximum(lam0, 1e-30) / (2 * math.pi * su * sc))
    ku = gl["du"] / (math.sqrt(nu) * su)
    kc = gl["dc"] / (math.sqrt(nu) * sc)
    bu = sdr[:, 0] / (math.sqrt(nu) * su)  # per unit of drawn slope (t)
    bc = sdr[:, 1] / (math.sqrt(nu) * sc)
    reach_u = np.maximum(np.abs(ku) - 3.5 * bu, 0)  # best case over |t| <= 3.5
    reach_c = np.maximum(np.abs(kc) - 3.5 * bc, 0)
    best = (logc - (nu + 2) / 2 * np.log1p(reach_u ** 2 + reach_c ** 2)).reshape(gh, gw)
    # a sparkle is visible where its count beats the floor of ITS row: near the camera
    # (small footprints, few facets) one sparkle is brighter, so fewer suffice
    floor_rows = np.log(GLINT_MIN / quantum(facets(fp_rows)))
    ch = len(floor_rows) / gh
    starts = np.minimum((np.arange(gh) * ch).astype(np.int64), len(floor_rows) - 1)
    floors = np.minimum.reduceat(floor_rows, starts)  # per grid row: its rows' lowest
    box = _glint_box(best, floors, plan.sea, gh, gw)
    if box is None:
        return None
    x0, y0, x1, y1 = box
    tick("g.coarse")
    grid = plan.sea
    # per grid point: the layers' weights at its level; coarse maps folded so that per
    # pixel q = K - P (A + r M) with A the full layer's codes and M the low layers' mix
    lev = sea["lev"]
    wts = np.zeros((len(LAYERS), len(lev), 2))
    for lv in np.unique(lev):
        sel = lev == lv
        for k, wk in enumerate(layer_weights_at(waves, int(lv))):
            wts[k, sel] = wk
    inv = 1.0 / SLOPE_SCALE
    # exposed linear luminance of the water under the glint (for the compositing)
    base = np.clip(luminance(sea["L0"]) * gain, 1e-4, 1.0)
    maps = [np.ascontiguousarray(m.reshape(gh, gw), np.float32) for m in (
        ku + bu * 128 * inv * wts[0, :, 0], kc + bc * 128 * inv * wts[0, :, 1],
        (logc - GLINT_LN0) / GLINT_LN_STEP, base)]
    pu = (bu * wts[0, :, 0] * inv).astype(np.float32)
    pc = (bc * wts[0, :, 1] * inv).astype(np.float32)
    m4 = [resize_box(m, grid.r1 - grid.r0, grid.width, x0, y0, x1, y1) for m in maps]
    pu_b: np.ndarray | float
    pc_b: np.ndarray | float
    if np.ptp(pu) > 0.02 * abs(pu).max() or np.ptp(pc) > 0.02 * abs(pc).max():
        p2 = resize_box(np.stack([pu, pc], -1).reshape(gh, gw, 2), grid.r1 - grid.r0,
                         grid.width, x0, y0, x1, y1)
        pu_b, pc_b = p2[..., 0], p2[..., 1]
    else:
        pu_b, pc_b = float(pu.mean()), float(pc.mean())
    tick("g.maps")
    # the low layers mixed at quarter resolution (relative to the full layer's weight,
    # averaged over the box's levels) and magnified over the box
    a4, b4 = layers["a4"], layers["b4"]
    rows, w = a4.shape[:2]
    hq, wq = b4.shape[:2]
    rs = [(b - a, layer_weights_at(waves, lv))
          for lv, a, b in level_runs(layers["levels_a"][y0:y1])]
    n_rows = max(sum(n for n, _ in rs), 1)
    r_b = sum(n * float(ws[1].mean() / max(ws[0].mean(), 1e-9)) for n, ws in rs) / n_rows
    r_c = sum(n * float(ws[2].mean() / max(ws[0].mean(), 1e-9)) for n, ws in rs) / n_rows
    c_up = cv2.resize(layers["c4"], (wq, hq), interpolation=cv2.INTER_LINEAR)
    mixes = []
    for ch in (0, 1):
        mix = cv2.addWeighted(cv2.extractChannel(b4, ch), r_b, cv2.extractChannel(c_up, ch),
                              r_c, -128.0 * (r_b + r_c), dtype=cv2.CV_32F)
        mixes.append(resize_box(mix, rows, w, x0, y0, x1, y1))  # (box,) float32
    tick("g.warp_b")
    hh, ww = y1 - y0, x1 - x0
    e = scratch("g_e", (hh, ww), np.float32)  # becomes the glint table's row coordinate
    qu = scratch("g_qu", (hh, ww), np.float32)
    qc = scratch("g_qc", (hh, ww), np.float32)
    ca = scratch("g_ca", (hh, ww))
    for ch, q, pmap in ((0, qu, pu_b), (1, qc, pc_b)):
        cv2.extractChannel(a4[y0:y1, x0:x1], ch, dst=ca)
        cv2.add(mixes[ch], ca, dst=q, dtype=cv2.CV_32F)  # A + M: M the low layers' share
        if isinstance(pmap, float):
            cv2.scaleAdd(q, -pmap, m4[ch], dst=q)  # K - P (A + r B)
        else:
            cv2.multiply(q, pmap, dst=q)
            cv2.subtract(m4[ch], q, dst=q)
    cv2.multiply(qu, qu, dst=e)
    cv2.multiply(qc, qc, dst=qc)
    cv2.add(e, qc, dst=e)
    e += np.float32(1.0)
    cv2.log(e, dst=e)  # ln(1 + q^2): the Student-t's exponent
    cv2.scaleAdd(e, -(nu + 2) / 2 / GLINT_LN_STEP, m4[2], dst=e)
    # at most one sparkle per facet: saturate the count, row by row (footprints per row)
    n_fac = facets(fp_rows[y0:y1]).astype(np.float32)[:, None]
    if float(n_fac.min()) < 1e4:
        saturate_rows(e, np.log(n_fac))
    tick("g.q")
    # draw each pixel's glint (in quanta) from the table at its noise column
    nt = textures.noise
    n0, n1 = int(noise_off[0]) + y0, int(noise_off[1]) + x0
    g = qu  # (reused)
    draw_glint(_noise_window(nt, n0, n1, hh, ww, "gnoise"), e, g)
    # a sparkle is the sun's disc mirrored in a facet, clipped on the sensor: ~3 px across
    # at 416 px and smaller frames (larger frames' facets are smaller than the disc)
    if SPARKLE_BLUR and SUN_DISC * math.sqrt(plan.fx * plan.fy) > 1.5:
        spread_disc(g, _noise_window(_shares(nt), n0, n1, hh, ww, "gshare"))
    tick("g.draw")
    # composite in linear light: sRGB(base + glint) - sRGB(base), added to every channel;
    # sRGB through a LUT of sqrt(linear) (steps of ~1 level even in dark water)
    g *= quantum(n_fac).astype(np.float32)
    cv2.add(g, m4[3], dst=g)
    cv2.sqrt(g, dst=g)
    g8 = cv2.convertScaleAbs(g, alpha=255.0)
    cv2.LUT(g8, _sqrt_srgb_lut(), dst=g8)
    b8 = cv2.convertScaleAbs(cv2.sqrt(m4[3]), alpha=255.0)
    cv2.LUT(b8, _sqrt_srgb_lut(), dst=b8)
    d8 = cv2.subtract(g8, b8)
    # a saturated sparkle saturates every channel (white light added to the water's colour
    # past the sensor's full scale), not only the luminance
    cv2.max(d8, cv2.threshold(g8, 254, 255, cv2.THRESH_BINARY)[1], dst=d8)
    d3 = cv2.cvtColor(d8, cv2.COLOR_GRAY2RGB)
    region = img[y0:y1, x0:x1]
    cv2.add(region, d3, dst=region)
    tick("g.apply")
    return (x0, y0 + grid.r0, x1, y1 + grid.r0)


SATURATE_SERIES = 0.1  # below this many sparkles per facet, saturate_rows uses a series
#: a sparkle's disc over its neighbours (a 3 px disc at a random place within its pixel):
#: the mean of the exponential share of its value that an edge neighbour draws, a corner
#: neighbour's share over an edge one's, and the most a neighbour gets. Set so that the
#: default 416 px images keep their glitter: over 80 images, mean grey level 112.1 ->
#: 112.6, pixels >= 235 4.58 -> 4.54 %, >= 200 9.62 -> 9.66 % (the fixed cross of 0.45
#: before; ``--preset seadronessee`` at 22.9 degrees: 1.33 -> 1.42 % and 3.52 -> 3.59 %)
EDGE_SHARE, CORNER_SHARE, MAX_SHARE = 0.52, 0.45, 1.0


def _noise_window(nt: np.ndarray, n0: int, n1: int, hh: int, ww: int,
                  name: str) -> np.ndarray:
    """The (hh, ww) window of the periodic glitter noise ``nt`` from texel (n0, n1): a
    view when it fits, else wrapped into the scratch array ``name``; a window larger than
    the tile is a :func:`~sdcomp.render.water.detile.mosaic` of it (no repeats)."""
    if hh > nt.shape[0] or ww > nt.shape[1]:
        return mosaic(nt, n0, n1, hh, ww, scratch(name, (hh, ww), np.float32))
    n0, n1 = n0 % nt.shape[0], n1 % nt.shape[1]
    if n0 + hh <= nt.shape[0] and n1 + ww <= nt.shape[1]:
        return nt[n0:n0 + hh, n1:n1 + ww]
    return wrap_window(nt, n0, n1, hh, ww, scratch(name, (hh, ww), np.float32))


def shares_of(noise: np.ndarray) -> np.ndarray:
    """The spread's shares (see :func:`spread_disc`) from glitter noise ``noise`` (h, w)
    float32 ``-log10(1 - u) 255 / 6``, whose mean is ``255 / (6 ln 10)``: exponential
    shares of mean :data:`EDGE_SHARE`, at most :data:`MAX_SHARE`; (h, w) float32."""
    share = noise * np.float32(EDGE_SHARE * 6.0 * math.log(10.0) / 255.0)
    return np.minimum(share, np.float32(MAX_SHARE), out=share)


def _shares(nt: np.ndarray) -> np.ndarray:
    """:func:`shares_of` the glitter noise tile ``nt`` rolled by half its size (draws
    apart from the glint's own at each pixel), made once per tile (the last two kept)."""
    hit = _SHARES.get(id(nt))
    if hit is not None and hit[0]() is nt:
        return hit[1]
    half = nt.shape[0] // 2
    tile = shares_of(np.roll(nt, (half, half), axis=(0, 1)))
    while len(_SHARES) >= 2:
        _SHARES.pop(next(iter(_SHARES)))
    _SHARES[id(nt)] = (weakref.ref(nt), tile)
    return tile


_SHARES: dict = {}


def spread_disc(g: np.ndarray, share: np.ndarray) -> None:
    """In place: each sparkle of ``g`` (h, w) float32 spread over its 3 x 3 neighbours, as
    the sun's disc of about 3 px at a random place within its pixel covers them: a
    neighbour gets the largest of its neighbours' values times its own random ``share``
    ((h, w) float32, :func:`shares_of`: exponential of mean :data:`EDGE_SHARE`, at most
    :data:`MAX_SHARE`), times :data:`CORNER_SHARE` at the corners, and keeps its own
    value if larger. A saturated sparkle becomes a blob of 1 to 9 pixels, each of its own
    shape, where one fixed share made every one the same cross."""
    edges = cv2.dilate(g, _CROSS)
    corners = cv2.dilate(g, _CORNERS)
    np.multiply(corners, np.float32(CORNER_SHARE), out=corners)
    cv2.max(edges, corners, dst=edges)
    cv2.multiply(edges, share, dst=edges)
    cv2.max(g, edges, dst=g)


def draw_glint(noise: np.ndarray, e: np.ndarray, out: np.ndarray) -> None:
    """Each pixel's glint in quanta into ``out`` (h, w) float32: the glint table's entry at
    its noise column ``noise`` and its row ``e`` (both (h, w) float32; ``e`` is clamped to
    the table in place), times :func:`_beyond_table`'s gain past the last row."""
    beyond = _beyond_table(e)
    cv2.remap(_glint_table(), noise, e, cv2.INTER_NEAREST, dst=out,
              borderMode=cv2.BORDER_REPLICATE)
    if beyond is not None:
        cv2.multiply(out, beyond, dst=out)


def _beyond_table(e: np.ndarray) -> np.ndarray | None:
    """(h, w) float32 gains for the pixels of ``e`` (glint-table row coordinates, (h, w)
    float32, clamped to the last row in place) whose expected sparkle count lies beyond
    the table's last row (``ln lam`` 7: about 1100 sparkles; a far pixel at a low view
    near the sun's mirror point holds up to 1e5): the sum of ``lam`` sparkles is, within
    its noise, ``lam / lam_top`` times that of ``lam_top`` (their mean scales so; their
    relative spread shrinks, which the table's last row keeps); None where none is."""
    top = np.float32(_glint_table().shape[0] - 1)
    if float(e.max()) <= top:
        return None
    over = e - top
    np.maximum(over, np.float32(0.0), out=over)
    over *= np.float32(GLINT_LN_STEP)
    np.minimum(e, top, out=e)
    return cv2.exp(over)


def saturate_rows(e: np.ndarray, ln_n: np.ndarray) -> None:
    """In place: at most one sparkle per facet. ``e`` (h, w) float32 holds glint-table row
    coordinates ``(ln lam - GLINT_LN0) / GLINT_LN_STEP``; ``ln_n`` (h, 1) float32 the log
    facet count of each row. The expected count becomes ``N (1 - exp(-lam / N))``, i.e.
    ``ln lam`` grows by ``ln((1 - exp(-x)) / x)`` with ``x = lam / N``: from its series
    ``-x/2 + x^2/24 - x^4/2880`` below :data:`SATURATE_SERIES` (relative error < 1e-9),
    exactly on the pixels above, by OpenCV's exp and log (NumPy's float32 ``expm1`` has no
    vector path: 20x the cost of ``exp``)."""
    u = e * np.float32(GLINT_LN_STEP)
    u += np.float32(GLINT_LN0) - ln_n  # ln x
    x = cv2.exp(u)
    c = x * np.float32(-1.0 / 2880)
    c *= x
    c += np.float32(1.0 / 24)
    c *= x
    c -= np.float32(0.5)
    c *= x  # ln((1 - exp(-x)) / x), x small
    big = np.flatnonzero(x >= np.float32(SATURATE_SERIES))
    if big.size:  # 1 - exp(-x) loses nothing in float32 here (x >= 0.1)
        one = cv2.exp(x.ravel()[big] * np.float32(-1.0)).reshape(-1)
        np.subtract(np.float32(1.0), one, out=one)
        c.ravel()[big] = cv2.log(one).reshape(-1) - u.ravel()[big]
    c *= np.float32(1.0 / GLINT_LN_STEP)
    e += c


_TABLES: dict = {}


_CROSS = cv2.getStructuringElement(cv2.MORPH_CROSS, (3, 3))
_CORNERS = np.array([[1, 0, 1], [0, 0, 0], [1, 0, 1]], np.uint8)


def _glint_table() -> np.ndarray:
    """(65, 256) float32 quantiles of one pixel's glint in quanta (tools/make_glint_table.py):
    row ``(ln lam - GLINT_LN0) / GLINT_LN_STEP``, column the pixel's noise coordinate."""
    t = _TABLES.get("glint")
    if t is None:
        import os
        path = os.path.join(os.path.dirname(__file__), "data", "glint_table.npy")
        t = _TABLES["glint"] = np.ascontiguousarray(np.load(path).astype(np.float32))
    return t


def _glint_box(best: np.ndarray, floors: np.ndarray, grid, gh: int, gw: int):
    """Pixel box (x0, y0, x1, y1; rows relative to the sea's first row) of the grid cells
    (dilated by one) where the best-case log sparkle count exceeds its grid row's entry of
    ``floors`` (gh,), or None."""
    on = best > floors[:, None]
    if not on.any():
        return None
    ys, xs = np.nonzero(cv2.dilate(on.astype(np.uint8), np.ones((3, 3), np.uint8)))
    ch = (grid.r1 - grid.r0) / gh
    cw = grid.width / gw
    y0, y1 = int(ys.min() * ch), min(int(math.ceil((ys.max() + 1) * ch)), grid.r1 - grid.r0)
    x0, x1 = int(xs.min() * cw), min(int(math.ceil((xs.max() + 1) * cw)), grid.width)
    if y1 <= y0 or x1 <= x0:
        return None
    return x0, y0, x1, y1


def _sqrt_srgb_lut() -> np.ndarray:
    """uint8 (256,): 255 sRGB(x) for linear x = (i / 255)**2."""
    t = _TABLES.get("sqrt_srgb")
    if t is None:
        x = (np.arange(256) / 255.0) ** 2
        t = _TABLES["sqrt_srgb"] = to_u8(optics.srgb_encode(x) * 255.0)
    return t

