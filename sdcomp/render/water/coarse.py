"""The water's smooth terms on the coarse grid: sky reflection (exact Fresnel), water-leaving
light from the IOPs, haze, the glint's expectation, auto-exposure, and the light a floating
object sees (:class:`WaterLight`)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ...scene.water import SAND, WaterParams
from ...util.colour import srgb_to_linear
from . import optics
from .base import (
    FACET,
    LW_ANISO,
    METER_CLIP,
    R0,
    REF_F416,
    SPARKLE_DENSITY,
    SPARKLE_QUANTUM,
    tick,
    to_u8,
    uniforms,
)
from .geometry import Grid
from .optics import N_WATER, fresnel
from .sky import Sky, make_sky
from .textures import N_LEVELS, WaterTextures
from .waves import WaveState, long_waves, masking, norm_quantile, slope_pdf, swell_slopes


@dataclass(frozen=True, eq=False)
class WaterLight:
    """What an object compositor needs to light floating objects like the water around
    them (all radiances relative linear RGB BEFORE exposure; multiply by ``gain``).

    Attributes:
        sky: the :class:`~sdcomp.render.water.sky.Sky` (``sky.radiance(directions)`` per direction).
        sun: (3,) unit vector towards the sun (world frame).
        sun_irradiance: (3,) direct irradiance on a surface facing the sun at the image
            centre (zero in cloud shadow or under overcast).
        sky_irradiance: (3,) diffuse irradiance on a horizontal surface.
        water_radiance: (3,) mean water-leaving radiance of the body (just above the
            surface, looking down).
        absorption, backscatter: (3,) mean IOPs ``a``, ``b_b`` (1/m).
        beam_attenuation: (3,) ``c`` (1/m): transmittance of a path ``l`` is ``exp(-c l)``.
        diffuse_attenuation: (3,) ``K_d`` (1/m) of downwelling sunlight.
        gain: exposure gain (exposed = gain * radiance, then sRGB).
        grid: the coarse :class:`~sdcomp.render.water.geometry.Grid` of the sea (or None).
        direct: (gh, gw) float32 fraction of the direct sun reaching the sea (cloud shadows).
        l_w: (gh, gw, 3) float32 water-leaving radiance on the grid.
        refractive_index: of the water.
    """

    sky: Sky
    sun: np.ndarray
    sun_irradiance: np.ndarray
    sky_irradiance: np.ndarray
    water_radiance: np.ndarray
    absorption: np.ndarray
    backscatter: np.ndarray
    beam_attenuation: np.ndarray
    diffuse_attenuation: np.ndarray
    gain: float
    grid: Grid | None = None
    direct: np.ndarray | None = None
    l_w: np.ndarray | None = None
    refractive_index: float = N_WATER

    def at(self, u: float, v: float) -> tuple[np.ndarray, np.ndarray]:
        """(direct sun irradiance (3,), water-leaving radiance (3,)) float32 at image pixel
        (``u``, ``v``): bilinear in the coarse grids (cloud shadows, patches, shallows);
        the image-centre values without grids."""
        if self.grid is None or self.direct is None or self.l_w is None:
            return self.sun_irradiance, self.water_radiance
        g = self.grid
        fu = min(max(u * g.gw / g.width - 0.5, 0.0), g.gw - 1.0)
        fv = min(max((v - g.r0) * g.gh / max(g.r1 - g.r0, 1) - 0.5, 0.0), g.gh - 1.0)
        j0, i0 = min(int(fu), g.gw - 2) if g.gw > 1 else 0, min(int(fv), g.gh - 2) \
            if g.gh > 1 else 0
        tu, tv = fu - j0, fv - i0
        wts = np.array([(1 - tv) * (1 - tu), (1 - tv) * tu, tv * (1 - tu), tv * tu],
                       np.float32)
        j1, i1 = min(j0 + 1, g.gw - 1), min(i0 + 1, g.gh - 1)
        idx = ((i0, j0), (i0, j1), (i1, j0), (i1, j1))
        direct = float(sum(wt * self.direct[i, j] for wt, (i, j) in zip(wts, idx,
                                                                        strict=True)))
        l_w = sum(wt * self.l_w[i, j] for wt, (i, j) in zip(wts, idx, strict=True))
        sun = (self.sky.e_sun * direct * self.sky.sun_rgb).astype(np.float32)
        return sun, np.asarray(l_w, np.float32)


#: the wind at cloud height over the surface wind, and how far it veers (degrees
#: counter-clockwise): a video's clouds and their shadows drift at this speed
CLOUD_WIND = 2.0
CLOUD_VEER = 15.0


def build_sky(params: WaterParams, textures: WaterTextures) -> Sky:
    """The :class:`Sky` of ``params``: clouds fixed in the world where it moves (its
    ``origin``), drifting with the wind aloft over its ``time``."""
    u = uniforms(params.seed, 0x5C1, 2)
    ox, oy = params.origin  # world-fixed clouds (and their shadows) for a moving camera
    if params.time:  # carried by the wind aloft: stronger and veered from the surface's
        aloft = math.radians(params.wind_dir + CLOUD_VEER)
        ox -= CLOUD_WIND * params.wind * math.cos(aloft) * params.time
        oy -= CLOUD_WIND * params.wind * math.sin(aloft) * params.time
    off = (u[0] * textures.clouds.size + ox / params.cloud_scale,
           u[1] * textures.clouds.size + oy / params.cloud_scale)
    return make_sky(params.sky, params.sun_elevation, params.sun_azimuth, params.cloud_cover,
                    textures.clouds, params.cloud_height, params.cloud_scale, off,
                    params.cloud_bright, params.visibility)


def auto_exposure(lum: np.ndarray, weights: np.ndarray, target: float = 0.18,
                  clip: float = METER_CLIP, iterations: int = 6,
                  fixed: np.ndarray | None = None) -> float:
    """Exposure gain ``g`` with ``sum(w min(g L + F, clip)) / sum(w) = target`` for metered
    luminances ``lum`` (any shape, linear, >= 0), weights ``weights`` (same shape) and an
    optional part ``fixed`` F that does not scale with the exposure (clipped glitter): a
    camera's average (or, with centre-heavy weights, centre-weighted) metering, highlights
    clipping as on a sensor. Fixed-point iterations from the unclipped mean (the metered
    mean grows monotonically with ``g``); ``g`` stays within [1e-3, 1e4] / mean."""
    lum = np.asarray(lum, np.float64).ravel()
    w = np.asarray(weights, np.float64).ravel()
    w = w / max(w.sum(), 1e-12)
    f = np.zeros_like(lum) if fixed is None else np.asarray(fixed, np.float64).ravel()
    mean = max(float((lum * w).sum()), 1e-9)
    g = target / mean
    for _ in range(iterations):
        m = float((np.minimum(g * lum + f, clip) * w).sum())
        if m <= 0:
            break
        fm = float((np.minimum(f, clip) * w).sum())  # (the fixed part's own share)
        g *= max(target - fm, 0.1 * target) / max(m - fm, 1e-9)
        if abs(m - target) < 1e-3 * target:
            break
    return float(min(max(g, 1e-3 / mean), 1e4 / mean))


def sea_terms(plan, basis, alt, params: WaterParams, sky: Sky, textures: WaterTextures,
               waves: WaveState, e_u, e_c, world_off, levels_rows, flev, fp_rows) -> dict:
    grid = plan.sea
    gh, gw = grid.gh, grid.gw
    d = plan.sea_rays.reshape(-1, 3) @ basis  # (G, 3) world rays
    down = np.maximum(-d[:, 2], 1e-6)
    t = alt / down  # distance
    gx, gy = d[:, 0] * t, d[:, 1] * t  # metres from the point under the camera
    ox, oy = params.origin  # world metres of that point
    pu = gx * e_u[0] + gy * e_u[1] + (world_off[0] + (ox * e_u[0] + oy * e_u[1]))
    pc = gx * e_c[0] + gy * e_c[1] + (world_off[1] + (ox * e_c[0] + oy * e_c[1]))
    wx, wy = gx + ox, gy + oy  # world metres
    prow = grid.pixel_rows()
    lev_rows = levels_rows[prow]
    lev = np.repeat(lev_rows, gw)  # (G,) level tile drawn per pixel
    tick("st.geometry")
    n_g = len(t)
    # smooth random fields (one batched look-up): slicks, constituents, depth
    fx, fy, names = [], [], []
    offs = np.array(uniforms(params.seed, 0xF1E1D, 8)).reshape(4, 2) * textures.clouds.size
    if params.slicks > 0:  # streaked along the wind, ~20-50 m long
        fx.append(pu / 9.0 + offs[0, 0])
        fy.append(pc / 2.5 + offs[0, 1])
        names.append("slick")
    if params.patchiness > 0:
        k = 12.0 / params.patch_scale
        for i, nm in ((1, "f1"), (2, "f2")):
            fx.append(wx * k + offs[i, 0])
            fy.append(wy * k + offs[i, 1])
            names.append(nm)
    if params.depth is not None:
        fx.append(wx / 40.0 + offs[3, 0])
        fy.append(wy / 40.0 + offs[3, 1])
        names.append("depth")
    fields = {}
    if names:
        vals = textures.clouds.sample(np.concatenate(fx), np.concatenate(fy), 3.0)
        vals = vals.astype(np.float64) / math.sqrt(float(textures.clouds.variance[3]))
        for i, nm in enumerate(names):
            fields[nm] = vals[i * n_g:(i + 1) * n_g]
    slick = np.zeros(n_g)
    if "slick" in fields:
        thr = norm_quantile(1.0 - params.slicks)
        slick = 1.0 / (1.0 + np.exp(-(fields["slick"] - thr) * 6.0))
    tick("st.fields")
    # drawn and unresolved slope statistics: per grid row (one level per row)
    if plan.nadir:
        f0 = float(flev[0])
        rs_row = np.broadcast_to(waves.resolved_sd(f0), (grid.gh, 2))
        un_row = np.broadcast_to(waves.unres_at(f0), (grid.gh, 2))
    else:
        ok = lev_rows < N_LEVELS
        rs_row = np.where(ok[:, None], waves.resolved_sd(np.minimum(lev_rows, N_LEVELS - 1)),
                          0.0)
        un_row = waves.unres[lev_rows]
    res_sd = np.repeat(rs_row, gw, axis=0)
    unres = np.repeat(un_row, gw, axis=0)
    if params.slicks > 0:
        res_sd = res_sd * (1.0 - 0.35 * slick)[:, None]
        unres = unres * (1.0 - 0.8 * slick)[:, None]
    # long waves from the coarse levels, and swell (world slopes)
    tick("st.levels")
    long_uc = long_waves(textures, waves, pu, pc, lev)
    tick("st.long_waves")
    slope = long_uc[:, :1] * e_u[None] + long_uc[:, 1:] * e_c[None]
    if params.swell_height > 0:
        slope = slope + swell_slopes(params, wx, wy)
    # the water body: patchy constituents, Gordon reflectance, shallow bottom. The patches
    # change ln(R_rs) linearly in the two fields (sensitivities by finite differences of
    # the exact model at the mean constituents: the scene's R_rs needs 3 model evaluations)
    a, bb, rrs = _patchy_rrs(params, fields, n_g)
    tick("st.iops")
    direct = sky.direct_fraction(gx, gy).astype(np.float64)
    tick("st.shadow")
    e_dir = (sky.e_sun * float(sky.sun[2])) * sky.sun_rgb  # (3,)
    e_d = direct[:, None] * e_dir[None] + sky.e_sky_rgb[None]
    l_w = rrs * e_d  # (G, 3) water-leaving radiance at nadir view
    tick("st.body")

    # radiance for the mean normal and for normals tilted by 1 sd of the drawn slopes
    # along the tile's two axes (one-sided differences: the texture's response)
    slopes = np.stack([slope, slope + res_sd[:, :1] * e_u, slope + res_sd[:, 1:] * e_c])
    nrm = np.concatenate([-slopes, np.ones((3, n_g, 1))], -1)
    nrm /= np.sqrt((nrm * nrm).sum(-1, keepdims=True))
    cos_i = np.clip(-(nrm * d).sum(-1), 1e-4, 1.0)  # (3, G)
    refl = d + 2.0 * cos_i[..., None] * nrm  # reflected rays
    blur = np.tile(2.0 * np.sqrt(unres.sum(1)), 3)  # radians: spread of reflected rays
    tick("st.normals")
    l_sky = sky.radiance(refl.reshape(-1, 3), blur).reshape(3, n_g, 3)
    tick("st.sky_radiance")
    r = fresnel(cos_i)[..., None]
    # light leaving the water towards the camera: transmitted (1 - R) and, below the
    # surface, brighter away from the vertical: 1 + LW_ANISO (1 - cos) of the refracted ray
    cos_w = np.sqrt(1.0 - (1.0 - cos_i ** 2) / N_WATER ** 2)  # refracted, from the normal
    cos_wz = np.clip(cos_w * nrm[..., 2] - np.sqrt(np.maximum(1 - cos_w ** 2, 0)) *
                     np.sqrt(np.maximum(1 - nrm[..., 2] ** 2, 0)), -1, 1)
    aniso = (1.0 + LW_ANISO * (1.0 - np.abs(cos_wz))) / (1.0 + LW_ANISO * (
        1.0 - np.sqrt(1.0 - (1.0 - down ** 2) / N_WATER ** 2)))[None]
    view_t = ((1.0 - r[..., 0]) * aniso)[..., None] * (1.0 / (1.0 - R0))
    haze = np.exp(-t / params.visibility)[:, None]
    rad = (r * l_sky + view_t * l_w) * haze + sky.horizon_rgb * (1.0 - haze)
    tick("st.combine")
    gl = _glint_terms(d, sky, slope, e_u, e_c, unres, res_sd, direct)
    tick("st.glint")
    # the glitter's expected share of white per pixel (what the metering sees)
    n_fac = np.repeat(facets(fp_rows[prow]), gw)
    dens = SPARKLE_DENSITY * n_fac / N_REF  # sparkles per pixel per unit glint radiance
    lam = _saturate(gl["mean"] * haze[:, 0] * dens, n_fac)
    q_white = quantum(n_fac)
    glint_white = lam * q_white
    return {
        "shape": (gh, gw), "L0": rad[0], "Lu": rad[1], "Lc": rad[2],
        "glint_white": glint_white, "glint_log": gl, "density": dens, "lam": lam,
        "quantum": q_white,
        "res_sd": res_sd, "unres": unres, "lev": lev,
        "haze": haze[:, 0], "l_w": l_w, "a": a, "bb": bb, "direct": direct, "e_d": e_d,
        "slick": slick, "long_slope": slope, "foam_scale": params.foam_scale,
    }


def facets(fp):
    """Unresolved facets per pixel of footprint ``fp`` metres: ``(fp / FACET)**2``, at
    least 1/4 (a sparkle is the sun's disc in a facet: ~3 px across at 416 px)."""
    return np.clip((np.asarray(fp, np.float64) / FACET) ** 2, 0.25, 1e5)


def _saturate(lam, n_fac):
    """Sparkles per pixel cannot exceed its facets: ``n (1 - exp(-lam / n))``."""
    return n_fac * -np.expm1(-np.asarray(lam) / n_fac)


N_REF = (40.0 / REF_F416 / FACET) ** 2  # facets per pixel of the reference frame (416, 40 m)


def quantum(n_fac):
    """Share of white one sparkle adds to its pixel: SPARKLE_QUANTUM in the reference frame,
    inversely with the facets per pixel, at most 1 (a saturated sun's disc)."""
    return np.minimum(SPARKLE_QUANTUM * N_REF / np.asarray(n_fac, np.float64), 1.0)


RGB_RRS = 0.03  # 1/sr: remote-sensing reflectance of a custom colour's sRGB 255 channel


def _patchy_rrs(params: WaterParams, fields: dict, n_g: int):
    """(a, b_b, R_rs) per grid point (G, 3): the IOPs at the mean constituents, R_rs (above
    the surface) with the patches (fields f1, f2: log-normal constituents) applied through
    its log-sensitivities, and the shallow bottom (field ``depth``) exactly."""
    var = params.patchiness
    pert = [(0.0, 0.0), (var, 0.0), (0.0, var)]  # (f1, f2) = 0, +var along each
    cs = np.array([[params.chl * math.exp(p1), params.cdom * math.exp(0.5 * p2),
                    params.tsm * math.exp(0.6 * p1 + 0.8 * p2)] for p1, p2 in pert])
    a3, bb3 = optics.iops(cs[:, 0], cs[:, 1], cs[:, 2])  # (3, 3)
    a, bb = a3[0], bb3[0]
    if params.depth is not None:
        dep = params.depth * np.exp(0.5 * fields["depth"])
        rrs = optics.above_rrs(optics.shallow_rrs(a, bb, dep, np.asarray(SAND)))
        if var > 0:
            lr = np.log(optics.above_rrs(optics.subsurface_rrs(a3, bb3)))
            sens = (lr[1:] - lr[0]) / max(var, 1e-9)
            rrs = rrs * np.exp(np.asarray(fields.get("f1", 0.0))[..., None] * var * sens[0]
                               + np.asarray(fields.get("f2", 0.0))[..., None] * var * sens[1])
    else:
        lr = np.log(optics.above_rrs(optics.subsurface_rrs(a3, bb3)))  # (3 cases, 3 ch)
        if var > 0:
            sens = (lr[1:] - lr[0]) / max(var, 1e-9) * var
            rrs = np.exp(lr[0] + fields["f1"][:, None] * sens[0] + fields["f2"][:, None]
                         * sens[1])
        else:
            rrs = np.broadcast_to(np.exp(lr[0]), (n_g, 3))
    if params.rgb is not None:  # a custom colour: its own reflectance, the patches kept
        want = srgb_to_linear(np.asarray(params.rgb, np.float32) / 255.0) * RGB_RRS
        rrs = np.asarray(rrs) * (want / np.maximum(np.asarray(rrs).mean(0), 1e-9))
    return a, bb, rrs


def _glint_terms(d, sky: Sky, slope, e_u, e_c, unres, res_sd, direct) -> dict:
    """Cox-Munk glint at the grid points: ``L = E_sun R(omega) p(z) G / (4 cos theta_v
    cos^4 beta)`` with ``p`` the slope PDF around the long-wave slope and ``G = 1 / (1 +
    Lambda_v + Lambda_sun)`` the share of mirroring facets neither hidden from the camera
    nor shadowed from the sun by other waves (:func:`~.waves.masking`: without it the
    glint grows as 1 / cos theta_v towards the horizon): ``mean`` with the drawn slopes
    counted as unresolved, and the parts the sparkles need."""
    v = -d
    s = sky.sun[None, :]
    hvec = v + s
    hvec /= np.linalg.norm(hvec, axis=1, keepdims=True)
    cos_b = np.maximum(hvec[:, 2], 1e-3)
    req = -hvec[:, :2] / cos_b[:, None]  # facet slope that mirrors the sun
    dev = req - slope
    du = dev @ e_u
    dc = dev @ e_c
    cos_w = np.clip((hvec * s).sum(1), 0.0, 1.0)
    cos_v = np.maximum(v[:, 2], 1e-3)
    su2 = unres[:, 0] + res_sd[:, 0] ** 2
    sc2 = unres[:, 1] + res_sd[:, 1] ** 2
    hidden = masking(v, e_u, e_c, su2, sc2) + masking(s, e_u, e_c, su2, sc2)
    geo = sky.e_sun * direct * fresnel(cos_w) / (4.0 * cos_v * cos_b ** 4 * (1.0 + hidden))
    mean = geo * slope_pdf(du, dc, su2, sc2)
    return {"mean": mean, "geo": geo, "du": du, "dc": dc}


def sky_grid_terms(plan, basis, sky: Sky) -> dict:
    """Sky radiance on the sky grid, the clouds blurred to the grid's angular spacing (no
    aliasing; cloud detail finer than a cell is not drawn)."""
    d = plan.sky_rays.reshape(-1, 3) @ basis
    cell = max(plan.width / plan.sky.gw, (plan.sky.r1 - plan.sky.r0) / plan.sky.gh)
    blur = np.full(len(d), 1.5 * cell / plan.fx)
    return {"L": sky.radiance(d, blur), "d": d}


def draw_sky(img, sky_terms, gain, plan) -> None:
    g = plan.sky
    srgb = to_u8(optics.srgb_encode(sky_terms["L"] * gain).reshape(g.gh, g.gw, 3) * 255.0)
    g.upsample(srgb, out=img)


def srgb_terms(sea: dict, gain: float) -> tuple[np.ndarray, dict]:
    """Coarse sRGB (0..255 float) of the mean radiance and the responses per unit drawn
    slope code along the tile's upwind and crosswind axes (one-sided secant over 1 sd)."""
    gh, gw = sea["shape"]
    lin = np.stack([sea["L0"], sea["Lu"], sea["Lc"]]).astype(np.float32)
    enc = optics.srgb_encode(lin * np.float32(gain)) * np.float32(255.0)
    a = enc[0].reshape(gh, gw, 3)
    return a, {"u": (enc[1] - enc[0]).reshape(gh, gw, 3),
               "c": (enc[2] - enc[0]).reshape(gh, gw, 3)}


def water_light(sky: Sky, sea: dict, gain: float, grid: Grid) -> WaterLight:
    """The :class:`WaterLight` of a view from its sky, coarse sea terms (:func:`sea_terms`,
    on ``grid``) and exposure ``gain``: irradiances and IOPs at the image centre, with the
    grids of the direct-sun fraction (cloud shadows) and the water-leaving radiance (patches,
    shallows) for :meth:`WaterLight.at`."""
    gh, gw = sea["shape"]
    centre = (gh // 2) * gw + gw // 2
    a = np.asarray(sea["a"])
    bb = np.asarray(sea["bb"])
    cos_sw = float(optics.refracted_cos(max(float(sky.sun[2]), 0.05)))
    return WaterLight(
        sky=sky, sun=sky.sun.copy(),
        sun_irradiance=(sky.e_sun * float(sea["direct"][centre]) * sky.sun_rgb).astype(
            np.float32),
        sky_irradiance=sky.e_sky_rgb.copy(),
        water_radiance=sea["l_w"].mean(0).astype(np.float32),
        absorption=a.astype(np.float32), backscatter=bb.astype(np.float32),
        beam_attenuation=optics.beam_attenuation(a, bb).astype(np.float32),
        diffuse_attenuation=optics.diffuse_attenuation(a, bb, cos_sw).astype(np.float32),
        gain=float(gain), grid=grid,
        direct=np.asarray(sea["direct"], np.float32).reshape(gh, gw),
        l_w=np.asarray(sea["l_w"], np.float32).reshape(gh, gw, 3))
