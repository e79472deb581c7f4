"""Sky radiance by direction: clear-sky gradient, sun aureole, procedural clouds, haze.

World frame as in :mod:`sdcomp.scene.camera`: metres, z up, sea surface z = 0. Directions are unit
vectors (..., 3). Radiance is relative linear RGB (see :mod:`sdcomp.render.water.optics`), scaled so
that the global downwelling irradiance of the clear sky with an unobstructed sun is 1.

- Clear sky luminance: CIE general sky, type 12 ("clear, low turbidity"; CIE S 011/E:2003):
  ``L / L_z = f(chi) phi(Z) / (f(Z_s) phi(0))`` with ``phi(Z) = 1 + a exp(b / cos Z)`` and
  ``f(chi) = 1 + c (exp(d chi) - exp(d pi / 2)) + e cos^2 chi`` (Z: zenith angle, chi:
  angle from the sun). Colour: blue at the zenith and away from the sun, whiter towards the
  horizon and the sun. ``L_z`` is set so the sky's irradiance is the clear-sky diffuse
  fraction of the global irradiance.
- Overcast: CIE overcast sky ``L = L_z (1 + 2 cos Z) / 3``, grey, with low-contrast texture.
- Broken clouds: a cloud deck at ``cloud_height`` metres whose opacity is a thresholded
  periodic fBm field (:class:`CloudField`); the threshold gives the cover fraction. Clouds
  fade into the horizon haze with their distance. Blurred look-ups (the sky seen in a rough
  sea) widen the opacity's edge by the variance the blur removes from the field.
- The sun: direct irradiance ``E_sun`` on a surface facing it, hidden where a cloud lies on
  the sun's ray (cloud shadows on the sea, no glitter).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from .optics import luminance

CIE_CLEAR = (-1.0, -0.32, 10.0, -3.0, 0.45)  # CIE general sky type 12: a, b, c, d, e
ZENITH_BLUE = np.array([0.52, 0.98, 1.95], np.float32)  # chroma of the deep clear sky
HORIZON_WHITE = np.array([0.93, 1.0, 1.08], np.float32)  # chroma of the horizon haze
OVERCAST_GREY = np.array([0.96, 1.0, 1.04], np.float32)
CLOUD_WHITE = np.array([0.97, 1.0, 1.03], np.float32)
MIN_UP = 0.002  # directions are kept at least this far above the horizon (sin elevation)


def sun_direction(elevation_deg: float, azimuth_deg: float) -> np.ndarray:
    """(3,) unit vector towards the sun; azimuth from world +x towards +y (as sdcomp)."""
    e, a = math.radians(elevation_deg), math.radians(azimuth_deg)
    return np.array([math.cos(e) * math.cos(a), math.cos(e) * math.sin(a), math.sin(e)])


def sun_colour(elevation_deg: float) -> np.ndarray:
    """Relative colour of direct sunlight (white-balanced daylight = 1): warmer when low."""
    t = min(max((35.0 - elevation_deg) / 30.0, 0.0), 1.0)
    return np.array([1.0 + 0.06 * t, 0.98 - 0.06 * t, 0.94 - 0.22 * t], np.float32)


@dataclass(frozen=True, eq=False)
class CloudField:
    """A periodic unit-variance fBm field and blurred copies of it.

    ``stack``: (n, n, L) float32, channel ``k`` the field blurred by a Gaussian of ``2**k - 1``
    texels (channel 0: unblurred); ``variance``: (L,) variance left in each channel.
    """

    stack: np.ndarray
    variance: np.ndarray

    @property
    def size(self) -> int:
        return self.stack.shape[0]

    def sample(self, tx, ty, level) -> np.ndarray:
        """Bilinear samples at texel coordinates ``tx``, ``ty`` (any shape, wrapping) of blur
        level ``level`` (same shape or scalar, fractional: blended between channels);
        float32 shaped like ``tx``."""
        n, nl = self.size, self.stack.shape[2]
        shape = np.shape(tx)
        tx = np.asarray(tx, np.float32).ravel()
        ty = np.asarray(ty, np.float32).ravel()
        lev = np.clip(np.broadcast_to(np.asarray(level, np.float32), shape).ravel(), 0,
                      nl - 1.001)
        x0 = np.floor(tx)
        y0 = np.floor(ty)
        fx = tx - x0
        fy = ty - y0
        ix = x0.astype(np.int64) % n
        iy = y0.astype(np.int64) % n
        ix1 = (ix + 1) % n
        l0 = lev.astype(np.int64)
        fl = lev - l0
        flat = self.stack.reshape(-1)
        r0 = iy * (n * nl)
        r1 = ((iy + 1) % n) * (n * nl)
        c0 = ix * nl + l0
        c1 = ix1 * nl + l0
        out = np.zeros(tx.shape, np.float32)
        for dl, wl in ((0, 1.0 - fl), (1, fl)):
            v00 = flat[r0 + c0 + dl]
            v01 = flat[r0 + c1 + dl]
            v10 = flat[r1 + c0 + dl]
            v11 = flat[r1 + c1 + dl]
            out += wl * ((v00 + (v01 - v00) * fx) * (1 - fy) + (v10 + (v11 - v10) * fx) * fy)
        return out.reshape(shape)

    def residual_variance(self, level) -> np.ndarray:
        """Variance of the field removed by blur ``level`` (interpolated), float32."""
        lev = np.clip(np.asarray(level, np.float32), 0, self.stack.shape[2] - 1.001)
        return np.float32(1.0) - np.interp(lev, np.arange(len(self.variance)),
                                           self.variance).astype(np.float32)


def _erf_sigmoid(x):
    """A cheap smooth step from 0 to 1 shaped like the normal CDF (logistic, 1.702 x)."""
    return 1.0 / (1.0 + np.exp(-1.702 * x))


@dataclass(frozen=True, eq=False)
class Sky:
    """The sky of one image (see the module docstring). Build with :func:`make_sky`.

    Attributes:
        kind: ``"clear"``, ``"broken"`` or ``"overcast"``.
        sun: (3,) unit vector towards the sun.
        sun_rgb: (3,) float32 relative colour of sunlight.
        e_sun: direct solar irradiance on a surface facing the sun (unobstructed).
        e_sky: diffuse irradiance of the sky on a horizontal surface.
        l_zenith: luminance of the clear (or overcast) sky at the zenith.
        cover: cloud cover fraction.
        clouds: the :class:`CloudField` (None for a clear sky).
        cloud_height, cloud_texel: metres; cloud_offset: (2,) texels; cloud_threshold,
        cloud_soft: field value of cloud edges and their softness; cloud_bright: luminance
        of a thin sunlit cloud.
        visibility: metres, horizontal visibility of the haze.
        horizon_rgb: (3,) float32 radiance of the sky at the horizon (haze colour).
    """

    kind: str
    sun: np.ndarray
    sun_rgb: np.ndarray
    e_sun: float
    e_sky: float
    l_zenith: float
    cover: float
    clouds: CloudField | None
    cloud_height: float
    cloud_texel: float
    cloud_offset: tuple[float, float]
    cloud_threshold: float
    cloud_soft: float
    cloud_bright: float
    visibility: float
    horizon_rgb: np.ndarray
    sun_visible: float  # 0..1: the sun's ray at the scene's origin is clear of clouds
    e_sky_rgb: np.ndarray = None  # type: ignore[assignment]  # (3,) float32 diffuse irradiance of the sky per channel

    # ------------------------------------------------------------------ clear part
    def _clear(self, d: np.ndarray) -> np.ndarray:
        """Cloudless radiance (N, 3) float32 for unit directions (N, 3) float32 (z >= 0)."""
        z = np.maximum(d[:, 2], MIN_UP)
        cos_chi = np.clip(d @ self.sun.astype(np.float32), -1.0, 1.0)
        if self.kind == "overcast":
            lum = self.l_zenith * (1.0 + 2.0 * z) / 3.0
            return lum[:, None] * OVERCAST_GREY
        a, b, c, dd, e = CIE_CLEAR
        zs = max(float(self.sun[2]), 1e-3)
        chi = np.arccos(cos_chi)
        f = 1.0 + c * (np.exp(dd * chi) - math.exp(dd * math.pi / 2)) + e * cos_chi ** 2
        chi_zs = math.acos(min(max(zs, -1.0), 1.0))  # angle between zenith and sun
        f_s = 1.0 + c * (math.exp(dd * chi_zs) - math.exp(dd * math.pi / 2)) + e * zs ** 2
        phi = 1.0 + a * np.exp(b / z)
        phi0 = 1.0 + a * math.exp(b)
        lum = self.l_zenith * f * phi / (f_s * phi0)
        # colour: blue overhead and away from the sun, white at the horizon and near the sun
        blue = np.sqrt(z) * (1.0 - np.exp(-2.5 * chi))
        col = HORIZON_WHITE + (ZENITH_BLUE - HORIZON_WHITE) * blue[:, None]
        return (lum[:, None] * col).astype(np.float32)

    # ------------------------------------------------------------------ clouds
    def cloud_opacity(self, px, py, blur_m=None, want_thickness: bool = False):
        """Cloud opacity (and core thickness) at points ``(px, py)`` metres of the cloud
        deck, the field blurred over ``blur_m`` metres (None: unblurred). float32, shaped
        like ``px``."""
        cf = self.clouds
        if cf is None:
            z = np.zeros(np.shape(px), np.float32)
            return (z, z) if want_thickness else z
        tx = np.asarray(px, np.float32) / self.cloud_texel + self.cloud_offset[0]
        ty = np.asarray(py, np.float32) / self.cloud_texel + self.cloud_offset[1]
        if blur_m is None:
            level = np.zeros(np.shape(tx), np.float32)
        else:
            level = np.log2(1.0 + np.asarray(blur_m, np.float32) / self.cloud_texel)
        n = cf.sample(tx, ty, level)
        soft = np.sqrt(self.cloud_soft ** 2 + cf.residual_variance(level))
        alpha = _erf_sigmoid((n - self.cloud_threshold) / soft).astype(np.float32)
        if want_thickness:
            thick = np.clip((n - self.cloud_threshold) / 1.2, 0.0, 1.0).astype(np.float32)
            return alpha, thick
        return alpha

    def radiance(self, d, blur=None) -> np.ndarray:
        """Sky radiance (..., 3) float32 in unit directions ``d`` (..., 3) (directions below
        the horizon are lifted to it), seen through a blur of ``blur`` radians (..., the
        angular spread of a rough sea's reflection; None: sharp)."""
        shape = np.shape(d)[:-1]
        d = np.asarray(d, np.float32).reshape(-1, 3).copy()
        d[:, 2] = np.maximum(d[:, 2], MIN_UP)
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        out = self._clear(d)
        if self.clouds is not None:
            z = d[:, 2]
            dist = self.cloud_height / z  # metres along the ray to the deck
            px, py = d[:, 0] * dist, d[:, 1] * dist
            blur_m = None
            if blur is not None:
                # angular blur -> metres on the deck (foreshortened along the ray)
                blur_m = np.asarray(blur, np.float32).reshape(-1) * dist / np.sqrt(z)
            fade = np.exp(-dist / (3.0 * self.visibility))  # clouds fade into the haze
            if self.kind == "overcast":
                n = self._field(px, py, blur_m)
                out = out * (1.0 + 0.25 * n * fade)[:, None]
            else:
                alpha, thick = self.cloud_opacity(px, py, blur_m, want_thickness=True)
                alpha = alpha * fade
                cos_chi = d @ self.sun.astype(np.float32)
                lit = self.cloud_bright * (1.0 - 0.45 * thick) * (
                    1.0 + 1.5 * np.exp(-(1.0 - cos_chi) * 12.0) * self.sun_visible)
                cloud = lit[:, None] * CLOUD_WHITE
                out = out + (cloud - out) * alpha[:, None]
        # haze towards the horizon (aerial perspective of the sky's lowest degrees)
        h = np.exp(-d[:, 2] * 25.0)[:, None]
        out = out + (self.horizon_rgb - out) * h * 0.5
        return out.reshape(shape + (3,)).astype(np.float32)

    def _field(self, px, py, blur_m) -> np.ndarray:
        cf = self.clouds
        tx = np.asarray(px, np.float32) / self.cloud_texel + self.cloud_offset[0]
        ty = np.asarray(py, np.float32) / self.cloud_texel + self.cloud_offset[1]
        level = (np.zeros(np.shape(tx), np.float32) if blur_m is None else
                 np.log2(1.0 + np.asarray(blur_m, np.float32) / self.cloud_texel))
        assert cf is not None, "a clear sky has no cloud field"
        return cf.sample(tx, ty, level)

    def direct_fraction(self, gx, gy) -> np.ndarray:
        """Fraction (float32, shaped like ``gx``) of direct sunlight reaching sea points
        ``(gx, gy)`` metres: 1 minus the cloud opacity on the ray towards the sun."""
        if self.kind == "overcast" or self.e_sun <= 0:
            return np.zeros(np.shape(gx), np.float32)
        if self.clouds is None:
            return np.ones(np.shape(gx), np.float32)
        s = self.sun
        k = self.cloud_height / max(float(s[2]), 0.05)
        a = self.cloud_opacity(np.asarray(gx) + s[0] * k, np.asarray(gy) + s[1] * k,
                               np.full(np.shape(gx), 30.0, np.float32))
        return (1.0 - a).astype(np.float32)


def clear_diffuse_fraction(sun_elevation_deg: float) -> float:
    """Diffuse share of the global irradiance under a clear sky (0.10 high sun .. ~0.2)."""
    s = math.sin(math.radians(max(sun_elevation_deg, 3.0)))
    return 0.09 + 0.11 * (1.0 - s) ** 1.5 + 0.02 / (s + 0.1)


def _hemisphere(n_el: int = 6, n_az: int = 16) -> tuple[np.ndarray, np.ndarray]:
    """Directions (M, 3) float32 and weights ``cos Z dOmega`` (M,) covering the upper
    hemisphere (midpoint rule)."""
    el = (np.arange(n_el) + 0.5) / n_el * (math.pi / 2)
    az = (np.arange(n_az) + 0.5) / n_az * 2 * math.pi
    e, a = np.meshgrid(el, az, indexing="ij")
    d = np.stack([np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), np.sin(e)], -1).reshape(-1, 3)
    w = (np.sin(e) * np.cos(e) * (math.pi / 2 / n_el) * (2 * math.pi / n_az)).reshape(-1)
    return d.astype(np.float32), w.astype(np.float32)


_HEMI = _hemisphere()


@lru_cache(maxsize=8192)
def _clear_normalisation(kind: str, elev_q: int) -> tuple[float, tuple[float, float, float],
                                                        tuple[float, float, float]]:
    """Zenith luminance, RGB irradiance and horizon radiance of the cloudless (or overcast)
    sky shape for a sun at ``elev_q / 10`` degrees (the irradiance of a clear sky on a
    horizontal surface does not depend on the sun's azimuth)."""
    elev = elev_q / 10.0
    sun = sun_direction(elev, 0.0)
    s = max(float(sun[2]), 0.02)
    fd = clear_diffuse_fraction(elev)
    target = 0.35 if kind == "overcast" else fd
    bare = Sky(kind, sun, sun_colour(elev), 0.0, 0.0, 1.0, 0.0, None, 1.0, 1.0, (0.0, 0.0),
               9.0, 0.18, 0.0, 1e9, HORIZON_WHITE, 1.0, HORIZON_WHITE)
    d, w = _HEMI
    rad = bare._clear(d)
    l_z = target / max(float((luminance(rad) * w).sum()), 1e-9)
    irr = (rad * w[:, None]).sum(0) * l_z
    hor = bare._clear(np.array([[1.0, 0.0, MIN_UP]], np.float32))[0] * l_z
    del s
    return l_z, (float(irr[0]), float(irr[1]), float(irr[2])), (float(hor[0]), float(hor[1]),
                                                                float(hor[2]))


def make_sky(kind: str, sun_elevation: float, sun_azimuth: float, cover: float,
             clouds: CloudField | None, cloud_height: float, cloud_texel: float,
             cloud_offset: tuple[float, float], cloud_bright: float, visibility: float
             ) -> Sky:
    """Build the :class:`Sky` of one image. The zenith luminance of the cloudless sky is
    solved so that its irradiance on a horizontal surface is the clear-sky diffuse share of
    the global irradiance (overcast: 0.35 of a clear day's global irradiance, all diffuse;
    cached per 0.1 degree of sun elevation). Broken clouds add their own light: sunlit
    cloud has ``cloud_bright`` times the radiance of a white surface under the clear sky;
    their irradiance is that of a hemisphere covered in the ``cover`` fraction
    (``e_sky``, ``e_sky_rgb``)."""
    sun = sun_direction(sun_elevation, sun_azimuth)
    s = max(float(sun[2]), 0.02)
    fd = clear_diffuse_fraction(sun_elevation)
    if kind == "overcast":
        e_sun, cover = 0.0, 1.0
    else:
        e_sun = (1.0 - fd) / s
    if kind == "clear":
        cover = 0.0
    cover = min(max(cover, 0.0), 1.0)
    # threshold of the unit-variance field for the cover fraction (normal quantile)
    thr = float(norm_ppf(1.0 - cover)) if 0 < cover < 1 else (9.0 if cover <= 0 else -9.0)
    sun_rgb = sun_colour(sun_elevation)
    l_z, irr_t, hor_t = _clear_normalisation(kind, int(round(sun_elevation * 10)))
    irr = np.asarray(irr_t, np.float32)
    horizon = np.asarray(hor_t, np.float32)
    bright = cloud_bright * (e_sun * s + fd) / math.pi
    cl = clouds if kind != "clear" else None
    vis = 0.0 if kind == "overcast" else 1.0
    if kind == "broken":
        horizon = horizon * (1 - 0.5 * cover) + 0.5 * cover * bright * CLOUD_WHITE
        irr = irr * (1.0 - cover) + cover * 0.8 * math.pi * bright * CLOUD_WHITE
    sky = Sky(kind, sun, sun_rgb, e_sun, float(luminance(irr)), l_z, cover, cl, cloud_height,
              cloud_texel, cloud_offset, thr, 0.18, bright, visibility,
              horizon.astype(np.float32), vis, irr.astype(np.float32))
    if kind == "broken":
        vis = float(sky.direct_fraction(np.zeros(1), np.zeros(1))[0])
        sky = Sky(kind, sun, sun_rgb, e_sun, sky.e_sky, l_z, cover, cl, cloud_height,
                  cloud_texel, cloud_offset, thr, 0.18, bright, visibility, sky.horizon_rgb,
                  vis, sky.e_sky_rgb)
    return sky


def norm_ppf(p: float) -> float:
    """Inverse of the standard normal CDF (Acklam's rational approximation, |err| < 1e-8
    after one Newton step)."""
    p = min(max(p, 1e-9), 1 - 1e-9)
    a = (-3.969683028665376e+01, 2.209460984245205e+02, -2.759285104469687e+02,
         1.383577518672690e+02, -3.066479806614716e+01, 2.506628277459239e+00)
    b = (-5.447609879822406e+01, 1.615858368580409e+02, -1.556989798598866e+02,
         6.680131188771972e+01, -1.328068155288572e+01)
    c = (-7.784894002430293e-03, -3.223964580411365e-01, -2.400758277161838e+00,
         -2.549732539343734e+00, 4.374664141464968e+00, 2.938163982698783e+00)
    dd = (7.784695709041462e-03, 3.224671290700398e-01, 2.445134137142996e+00,
          3.754408661907416e+00)
    if p < 0.02425:
        q = math.sqrt(-2 * math.log(p))
        x = (((((c[0] * q + c[1]) * q + c[2]) * q + c[3]) * q + c[4]) * q + c[5]) / \
            ((((dd[0] * q + dd[1]) * q + dd[2]) * q + dd[3]) * q + 1)
    elif p > 1 - 0.02425:
        q = math.sqrt(-2 * math.log(1 - p))
        x = -(((((c[0] * q + c[1]) * q + c[2]) * q + c[3]) * q + c[4]) * q + c[5]) / \
            ((((dd[0] * q + dd[1]) * q + dd[2]) * q + dd[3]) * q + 1)
    else:
        q = p - 0.5
        r = q * q
        x = (((((a[0] * r + a[1]) * r + a[2]) * r + a[3]) * r + a[4]) * r + a[5]) * q / \
            (((((b[0] * r + b[1]) * r + b[2]) * r + b[3]) * r + b[4]) * r + 1)
    e = 0.5 * math.erfc(-x / math.sqrt(2)) - p
    u = e * math.sqrt(2 * math.pi) * math.exp(x * x / 2)
    return x - u / (1 + x * u / 2)
