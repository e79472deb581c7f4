"""Slope statistics of the sea per image (:class:`WaveState`), the long waves and swell on the
coarse grid, and the unresolved slopes' PDF."""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property, lru_cache

import numpy as np

from ...scene.water import GRAVITY, WaterParams
from .base import LAYERS, SLOPE_NU, uniforms
from .geometry import RESOLVE
from .sky import norm_ppf
from .spectrum import FULLY_DEVELOPED, band_slope_variance, cox_munk, whitecap_fraction
from .textures import N_LEVELS, N_TILE, SLOPE_SCALE, WaterTextures, erfc_nonneg, pitch


@dataclass(frozen=True, eq=False)
class WaveState:
    """Per-image slope statistics of the sea (see :func:`wave_state`).

    ``band_u``, ``band_c``: (N_BANDS,) slope variances of each band, scaled so that all bands
    plus the sub-centimetre rest sum to Cox-Munk's totals ``cm_u``, ``cm_c``.
    ``group_sd``: (N_LEVELS + 3, 2) slope standard deviation (upwind, crosswind) of level
    tile ``L`` (bands L, L + 1) for this spectrum (rows past the last level: 0).
    ``unres``: (N_LEVELS + 1, 2) slope variance finer than level ``l``'s tile (at least 10 %
    of Cox-Munk's); row N_LEVELS: all of it. ``foam``: whitecap coverage."""

    band_u: np.ndarray
    band_c: np.ndarray
    cm_u: float
    cm_c: float
    group_sd: np.ndarray
    unres: np.ndarray
    foam: float

    def group_at(self, level) -> np.ndarray:
        """(..., 2) slope sd of a level tile at a continuous ``level`` (variance
        interpolated between the integer levels)."""
        f = np.clip(np.asarray(level, np.float64), 0.0, N_LEVELS + 3.999)
        i = np.floor(f).astype(np.int64)
        w = (f - i)[..., None]
        v = self.group_sd[i] ** 2 * (1 - w) + self.group_sd[i + 1] ** 2 * w
        return np.sqrt(v)

    @cached_property
    def layer_weights(self) -> np.ndarray:
        """(N_LEVELS + 1, len(LAYERS), 2) each texture layer's share of the drawn slope sd
        (upwind, crosswind) per level (row N_LEVELS: zeros)."""
        out = np.zeros((N_LEVELS + 1, len(LAYERS), 2))
        for lev in range(N_LEVELS):
            gs = np.stack([self.group_sd[lev + 2 * k] for k in range(len(LAYERS))])
            out[lev] = gs / np.maximum(np.sqrt((gs ** 2).sum(0)), 1e-12)
        return out

    def unres_at(self, level) -> np.ndarray:
        """(..., 2) unresolved variance at a continuous ``level`` (interpolated)."""
        f = np.clip(np.asarray(level, np.float64), 0.0, float(N_LEVELS))
        i = np.minimum(np.floor(f).astype(np.int64), N_LEVELS - 1)
        w = (f - i)[..., None]
        return self.unres[i] * (1 - w) + self.unres[i + 1] * w

    def resolved_sd(self, level) -> np.ndarray:
        """(..., 2) slope sd drawn per pixel at ``level`` (continuous; the three texture
        layers together: levels l, l + 2, l + 4)."""
        lev = np.asarray(level, np.float64)
        return np.sqrt(sum(self.group_at(lev + 2 * k) ** 2 for k in range(len(LAYERS))))


def wave_state(wind: float, wave_age: float) -> WaveState:
    """See :func:`_wave_state` (cached on wind and wave age rounded to 0.01)."""
    return _wave_state(round(float(wind), 2), round(float(wave_age), 2))


@lru_cache(maxsize=4096)
def _wave_state(wind: float, wave_age: float) -> WaveState:
    """Slope statistics for a wind of ``wind`` m/s and inverse wave age ``wave_age``: the
    Elfouhaily et al. (1997) spectrum shared into octave bands, scaled to the Cox-Munk
    (1954) clean-sea total; per level tile the slope sd it stands for, and per drawn level
    the variance left unresolved: what is left of Cox-Munk's upwind/crosswind totals after
    the bands from that level up, at least 10 % of them."""
    u, c = band_slope_variance(wind, wave_age)
    cm_u, cm_c = cox_munk(wind)
    f = (cm_u + cm_c) / max(float(u.sum() + c.sum()), 1e-12)
    u, c = u * f, c * f
    bu, bc = u[1:], c[1:]
    nb = len(bu)
    group = np.zeros((N_LEVELS + 6, 2))
    for lev in range(N_LEVELS):
        group[lev] = (math.sqrt(bu[lev:lev + 2].sum()), math.sqrt(bc[lev:lev + 2].sum()))
    unres = np.zeros((N_LEVELS + 1, 2))
    for lev in range(N_LEVELS + 1):
        res_u, res_c = bu[min(lev, nb):].sum(), bc[min(lev, nb):].sum()
        unres[lev] = (max(cm_u - res_u, 0.1 * cm_u, 2e-4), max(cm_c - res_c, 0.1 * cm_c, 2e-4))
    # Monahan's coverage is for the open sea; younger, fetch-limited seas (lakes) whiten
    # less at the same wind
    foam = whitecap_fraction(wind) * min(1.0, FULLY_DEVELOPED / max(wave_age, 1e-3)) ** 0.8
    return WaveState(bu, bc, cm_u, cm_c, group, unres, foam)


def long_waves(textures: WaterTextures, waves: WaveState, pu: np.ndarray, pc: np.ndarray,
                lev: np.ndarray) -> np.ndarray:
    """Slopes (N, 2) (upwind, crosswind) of the waves too long for the per-pixel layers at
    ground coordinates ``pu``, ``pc`` (metres along the tile axes): level tiles ``l + 6, l +
    8, ...`` of set 0 (``l``: each point's level), weighted by the spectrum."""
    out = np.zeros(pu.shape + (2,), np.float64)
    first = lev + 2 * len(LAYERS)
    lo = int(first.min())
    if lo >= N_LEVELS:
        return out
    levels = np.arange(lo, N_LEVELS)
    sd = waves.group_sd[levels]  # (nl, 2)
    keep = sd.sum(1) > 1e-4
    levels, sd = levels[keep], sd[keep]
    if len(levels) == 0:
        return out
    n = N_TILE
    p = pitch(0) * 2.0 ** levels[:, None]  # (nl, 1)
    tx = pu[None, :] / p + n // 2  # (tile columns are shifted by n/2)
    ty = pc[None, :] / p
    x0 = np.floor(tx)
    y0 = np.floor(ty)
    fx = (tx - x0)[..., None]
    fy = (ty - y0)[..., None]
    ix = x0.astype(np.int64) % n
    iy = y0.astype(np.int64) % n
    v = np.empty(ix.shape + (2,), np.float64)
    for i, lv in enumerate(levels):  # (each level's tile: evolved ones are made lazily)
        st = textures.coarse_level(int(lv))
        jx, jy, gx, gy = ix[i], iy[i], fx[i], fy[i]
        v[i] = ((st[jy, jx] * (1 - gx) + st[jy, jx + 1] * gx) * (1 - gy)
                + (st[jy + 1, jx] * (1 - gx) + st[jy + 1, jx + 1] * gx) * gy)
    t = (v - 128.0) / SLOPE_SCALE  # unit-variance codes, (nl, N, 2)
    use = (levels[:, None] >= first[None, :]) & ((levels[:, None] - first[None, :]) % 2 == 0)
    return (t * sd[:, None, :] * use[..., None]).sum(0)


def level_continuous(footprint) -> np.ndarray:
    """Continuous level for pixel footprints ``footprint`` (m): level ``ceil(result)`` is the
    finest whose shortest wave spans RESOLVE footprints (see
    :func:`sdcomp.render.water.geometry.level_for`)."""
    need = RESOLVE * np.asarray(footprint, np.float64) / 4.0
    return np.clip(np.log2(np.maximum(need, 1e-12) / pitch(0)), -1.0, float(N_LEVELS))


def slope_pdf(du, dc, var_u, var_c, nu: float = SLOPE_NU):
    """PDF of surface slopes (upwind ``du``, crosswind ``dc`` from the mean) with variances
    ``var_u``, ``var_c``: a bivariate Student-t with ``nu`` degrees of freedom (scaled to
    those variances; Gaussian as nu -> inf). Its tails are heavier than a Gaussian's, as the
    peakedness of Cox & Munk's (1954) measured distributions."""
    k = (nu - 2.0) / nu  # scale^2 / variance of a Student-t
    su2, sc2 = var_u * k, var_c * k
    q = (du ** 2 / su2 + dc ** 2 / sc2) / nu
    return (1.0 + q) ** (-(nu + 2.0) / 2.0) / (2 * math.pi * np.sqrt(su2 * sc2))


def masking(w, e_u, e_c, var_u, var_c):
    """Smith's masking of a rough surface seen from (or lit from) unit directions ``w``
    (..., 3), z up: ``Lambda`` (...) of a Gaussian slope distribution with variances
    ``var_u`` upwind and ``var_c`` crosswind (axes ``e_u``, ``e_c``: horizontal unit
    (2,) vectors), ``(exp(-a^2) / (sqrt(pi) a) - erfc(a)) / 2`` with ``a = cot(theta) /
    sqrt(2 var)``, ``var`` the slope variance along ``w``'s azimuth. The share of facets
    seen (or lit) is ``1 / (1 + Lambda)``: 1 from above, falling to nothing towards the
    horizon, where the waves hide each other's faces (the Student-t tails of
    :func:`slope_pdf` are left out of it)."""
    w = np.asarray(w, np.float64)
    hx = w[..., :2] @ np.asarray(e_u, np.float64)
    hy = w[..., :2] @ np.asarray(e_c, np.float64)
    horiz2 = np.maximum(hx * hx + hy * hy, 1e-12)
    var = (var_u * hx * hx + var_c * hy * hy) / horiz2
    a = np.maximum(w[..., 2], 1e-6) / np.sqrt(2.0 * horiz2 * np.maximum(var, 1e-12))
    return np.maximum((np.exp(-a * a) / (math.sqrt(math.pi) * a) - erfc_nonneg(a)) / 2.0, 0.0)


CAPILLARITY = 7.28e-5  # m^3/s^2: surface tension over density of sea water


def omega(k):
    """Angular frequency (rad/s) of deep-water waves of wavenumber ``k`` (rad/m): the
    dispersion relation with capillarity, ``omega**2 = g k + (sigma / rho) k**3``."""
    k = np.asarray(k, np.float64)
    return np.sqrt(GRAVITY * k + CAPILLARITY * k ** 3)


def swell_slopes(params: WaterParams, gx, gy) -> np.ndarray:
    """World slopes (N, 2) of a narrow-band swell at world points ``gx``, ``gy`` (N,)
    metres: three long-crested components travelling along ``swell_dir`` (at
    ``params.time`` seconds, when set)."""
    uu = uniforms(params.seed, 0x5E11, 9)
    sigma_h = params.swell_height / 4.0
    amp = sigma_h * math.sqrt(2.0 / 3.0)
    out = np.zeros((len(gx), 2))
    for i in range(3):
        k = 2 * math.pi / (params.swell_length * (0.9 + 0.2 * uu[3 * i]))
        a = math.radians(params.swell_dir - 12 + 24 * uu[3 * i + 1])
        kx, ky = k * math.cos(a), k * math.sin(a)
        ph = 2 * math.pi * uu[3 * i + 2]
        if params.time is not None:
            ph -= float(omega(k)) * float(params.time)
        c = np.cos(kx * gx + ky * gy + ph) * amp
        out[:, 0] += -kx * c
        out[:, 1] += -ky * c
    return out


def norm_quantile(p: float) -> float:
    return norm_ppf(p)


def layer_weights_at(waves: WaveState, lev: int) -> np.ndarray:
    """(len(LAYERS), 2) upwind/crosswind weight of each texture layer at level ``lev``: its
    slope sd over the total drawn sd (zeros outside the levels)."""
    if lev >= N_LEVELS or lev < 0:
        return waves.layer_weights[N_LEVELS]
    return waves.layer_weights[lev]
