"""What the water does to a floating object: where its surface cuts the body (a soft, wavy
waterline), and how the parts below it are seen (attenuated, veiled by the water column,
blurred with depth, behind the surface's reflection of the sky).

Below the surface, the object's light and the water column's follow the shallow-water model
of Lee et al. (1999) (the same IOPs the water is drawn from): sunlight reaches depth ``d``
attenuated by ``exp(-K_d d)``, the object's reflected light comes back up attenuated by
``exp(-k_B d)`` with ``k_B = 1.04 (1 + 5.4 u)**0.5 (a + b_b) / cos(theta_w)``, the water
column in front of it adds the deep water's radiance times ``1 - exp(-(K_d + k_C) d)`` with
``k_C = 1.03 (1 + 2.4 u)**0.5 (a + b_b) / cos(theta_w)`` (``u = b_b / (a + b_b)``,
``theta_w`` the refracted view angle), and the light crossing the surface upwards keeps
``(1 - R) / n**2`` of its radiance. The surface above reflects the sky with Fresnel's
``R``. Everything is per sprite pixel at the sprite's mip level, before the affine warp.

Of the object's light that comes back up, only the unscattered part forms its image: it
decays with the beam attenuation ``c`` (``exp(-(K_d + c / cos(theta_w)) d)``, the direct
component of the Jaffe-McGlamery imaging model); the rest (``exp(-(K_d + k_B) d)`` minus
that) has been scattered on the way and arrives as a veil over the object's surroundings,
drawn as the object's light blurred by :data:`VEIL_PER_METRE` per metre of depth (what
spreads beyond the object's footprint is not drawn: a thin limb fades, a broad hull keeps
its brightness). The water's own light from behind the object is scattered the same way:
the part of it that the object blocks from the image (``exp(-(K_d + k_C) d)`` minus the
image's share) comes back into the footprint as the blurred surroundings, so a thin limb's
shadow fills in with the water's colour (its contrast decays with ``c``, as Duntley's
contrast transmittance has it) while a broad hull keeps its shadow. Seen through the
surface, a submerged point also lies shallower than it is (:func:`refract`: a body hanging
under a swimmer's shoulders looks shorter the more obliquely it is seen). In clear
ocean water a body half a metre down keeps most of its image; in coastal water about half;
in turbid, lake and algal water next to nothing below a few decimetres. The mask rule's
weight is the image's share.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from ..util.colour import LUMA as COLOUR_LUMA
from .water import WaterLight
from .water.optics import N_WATER, fresnel, refracted_cos

LUMA = COLOUR_LUMA.astype(np.float32)  # Rec. 709 luminance weights, float32
RIPPLES = 3  # sinusoids in the waterline's wave field
BLUR_PER_METRE = 0.08  # metres of blur (Gaussian sigma) per metre of depth, calm water
#: metres of blur (Gaussian sigma) per metre of depth of the scattered light's veil: the
#: forward-scattering particles' few-degree phase function widened by the wavy surface
#: (Mobley, *Light and Water*, 1994, ch. 3; the small-angle blur of a submerged target)
VEIL_PER_METRE = 0.35


@dataclass(frozen=True)
class WaterColumn:
    """The water between the surface and a submerged point, for one object and view (see
    the module docstring): ``k_obj`` and ``k_col`` (3,) float32 per metre of depth (the
    object's path ``K_d + k_B`` and the column's ``K_d + k_C``), ``deep`` (3,) the deep
    water's radiance, ``reflection`` (3,) the surface's reflected sky (``R L_sky``),
    ``transmission`` ``(1 - R) / n**2``, ``sun_dir`` (3,) the refracted sun (world), ``sun``
    (3,) the direct sun's irradiance at the object (cloud shadows)."""

    k_obj: np.ndarray
    k_col: np.ndarray
    k_img: np.ndarray
    deep: np.ndarray
    reflection: np.ndarray
    transmission: float
    sun_dir: np.ndarray
    sun: np.ndarray


def water_columns(light: WaterLight, towards_camera: np.ndarray, deep: np.ndarray,
                  sun: np.ndarray, roughness: float) -> list[WaterColumn]:
    """The :class:`WaterColumn` of each of N objects: seen along the unit vectors
    ``towards_camera`` (N, 3) (world, from each object to the camera) in water of radiance
    ``deep`` (N, 3) under direct sun ``sun`` (N, 3) whose surface slopes have the standard
    deviation ``roughness`` (radians, blurring the reflected sky). One evaluation of the
    sky for all of them."""
    t = np.asarray(towards_camera, np.float64).reshape(-1, 3)
    cz = np.clip(t[:, 2], 1e-3, 1.0)
    cos_w = np.asarray(refracted_cos(cz))
    a = np.asarray(light.absorption, np.float64)
    bb = np.asarray(light.backscatter, np.float64)
    u = bb / np.maximum(a + bb, 1e-9)
    k_b = (1.04 * np.sqrt(1 + 5.4 * u) * (a + bb))[None] / cos_w[:, None]  # (N, 3)
    k_c = (1.03 * np.sqrt(1 + 2.4 * u) * (a + bb))[None] / cos_w[:, None]
    kd = np.asarray(light.diffuse_attenuation, np.float64)[None]
    k_i = np.asarray(light.beam_attenuation, np.float64)[None] / cos_w[:, None]
    r = np.asarray(fresnel(cz), np.float64)
    mirror = np.stack([-t[:, 0], -t[:, 1], cz], axis=1)
    sky = light.sky.radiance(mirror, np.full(len(t), 2.0 * roughness))
    reflection = (r[:, None] * sky).astype(np.float32)
    k_obj, k_col = (kd + k_b).astype(np.float32), (kd + k_c).astype(np.float32)
    k_img = np.maximum(kd + k_i, kd + k_b).astype(np.float32)
    sun_w = refracted_sun(np.asarray(light.sun, np.float64))
    deep = np.asarray(deep, np.float32).reshape(-1, 3)
    sun = np.asarray(sun, np.float32).reshape(-1, 3)
    return [WaterColumn(k_obj[i], k_col[i], k_img[i], deep[i], reflection[i],
                        float((1.0 - r[i]) / N_WATER ** 2), sun_w, sun[i])
            for i in range(len(t))]


def refracted_sun(sun: np.ndarray) -> np.ndarray:
    """(3,) unit vector towards the sun as seen under the water (Snell's law at a flat
    surface); ``sun`` itself when it is below the horizon."""
    s_h = math.hypot(float(sun[0]), float(sun[1]))
    if sun[2] <= 0:
        return sun
    sin_w = min(s_h / N_WATER, 1.0)
    return np.array([sun[0] / max(s_h, 1e-9) * sin_w, sun[1] / max(s_h, 1e-9) * sin_w,
                     math.sqrt(1.0 - sin_w ** 2)])


def waterline_level(shape: tuple[int, int], pitch_m: float, amplitude: float,
                    wavelength: float, seed: tuple[int, ...]) -> np.ndarray:
    """(n, n) float32 height of the water surface (metres, about 0) over a sprite of
    ``shape`` pixels of ``pitch_m`` metres: :data:`RIPPLES` sinusoids of about
    ``wavelength`` metres in random directions and phases from ``seed``, with a standard
    deviation of ``amplitude`` metres: the small waves running along the hull that make the
    waterline wavy (the long ones lift the whole object)."""
    n_y, n_x = shape
    if amplitude <= 0:
        return np.zeros(shape, np.float32)
    rng = np.random.default_rng([*seed, 0x3A7E])
    x = (np.arange(n_x, dtype=np.float32) - n_x / 2) * np.float32(pitch_m)
    y = (np.arange(n_y, dtype=np.float32) - n_y / 2) * np.float32(pitch_m)
    out = np.zeros(shape, np.float32)
    for _ in range(RIPPLES):
        th = rng.uniform(0, 2 * math.pi)
        k = 2 * math.pi / (wavelength * rng.uniform(0.6, 1.5))
        kx, ky = np.float32(k * math.cos(th)), np.float32(k * math.sin(th))
        # sin(kx x + ky y + p) = sin(kx x + p) cos(ky y) + cos(kx x + p) sin(ky y)
        p = rng.uniform(0, 2 * math.pi)
        out += np.outer(np.cos(ky * y), np.sin(kx * x + p))
        out += np.outer(np.sin(ky * y), np.cos(kx * x + p))
    out *= np.float32(amplitude * math.sqrt(2.0 / RIPPLES))
    return out


def _veil_levels(max_sigma: float) -> list[float]:
    """Blur levels (Gaussian sigma, pixels) that cover spreads 0..``max_sigma``: 0, then
    powers of two from 1 up to the first at or above ``max_sigma``."""
    grid = [0.0]
    s = 1.0
    while grid[-1] < max_sigma:
        grid.append(s)
        s *= 2.0
    return grid


def _hat(x: np.ndarray, grid: list[float], k: int) -> np.ndarray:
    """(n, n) float32 weight of level ``k`` of ``grid`` at spreads ``x``: the piecewise-linear
    hat on the grid (the weights of all levels sum to 1; beyond the last level, its)."""
    one = np.zeros(len(grid))
    one[k] = 1.0
    return np.interp(x, grid, one).astype(np.float32)


def _wide_blur(img: np.ndarray, sigma: float) -> np.ndarray:
    """``img`` (n, m[, c]) float32 blurred by a Gaussian of ``sigma`` pixels, zero outside.
    A wide blur runs on an image reduced by a power of two (area mean), so it costs about
    what a 4-pixel one does, and is brought back by bilinear interpolation."""
    if sigma < 0.5:
        return img.copy()
    h, w = img.shape[:2]
    f = 1
    while sigma / f > 4.0 and min(h, w) >= 16 * f:
        f *= 2
    if f == 1:
        return cv2.GaussianBlur(img, (0, 0), sigma, borderType=cv2.BORDER_CONSTANT)
    ph, pw = -(-h // f) * f, -(-w // f) * f
    pad = np.zeros((ph, pw) + img.shape[2:], np.float32)
    pad[:h, :w] = img
    small = cv2.resize(pad, (pw // f, ph // f), interpolation=cv2.INTER_AREA)
    # the area mean already spread each pixel over f pixels (sigma about f / sqrt(12))
    rest = math.sqrt(max(sigma * sigma - f * f / 12.0, 0.25)) / f
    small = cv2.GaussianBlur(small, (0, 0), rest, borderType=cv2.BORDER_CONSTANT)
    big = cv2.resize(small, (pw, ph), interpolation=cv2.INTER_LINEAR)
    return big[:h, :w]


def submerge(above: np.ndarray, below: np.ndarray, alpha: np.ndarray, depth: np.ndarray,
             column: WaterColumn, pitch_m: float, blur_per_metre: float
             ) -> tuple[np.ndarray, np.ndarray]:
    """(radiance (n, n, 3) float32, weight (n, n) float32) of a sprite cut by the water.

    ``above`` and ``below`` (n, n, 3) float32 are its linear radiance lit from above the
    surface and from below it (before the water's attenuation); ``alpha`` (n, n) its
    coverage; ``depth`` (n, n) float32 metres under the (wavy) surface, negative above it.
    The waterline is soft over one sprite pixel (``pitch_m`` metres, at least a centimetre);
    submerged parts are blurred by ``blur_per_metre`` metres (Gaussian sigma) per metre of
    depth (one blur, for 1.5 times the submerged part's mean depth, mixed in with depth).
    The light scattered on its way up (``exp(-k_obj d) - exp(-k_img d)``) is blurred by
    :data:`VEIL_PER_METRE` metres per metre of each pixel's own depth (a few blur levels,
    mixed per pixel), and the water's light that the object blocks beyond its image
    (``exp(-k_col d) - exp(-k_img d)`` of ``deep``) comes back where the coverage blurred
    at the pixel's depth leaves room: a limb hanging a metre down fills in, the broad body
    just awash above it keeps its shadow. The weight
    (:mod:`sdcomp.annotate`) is ``alpha`` times the luminance of the image's transmittance
    ``exp(-k_img d)``: the fraction of the pixel's light that is the object's image."""
    eps = max(pitch_m, 0.01)
    under = np.clip(depth * np.float32(1.0 / eps) + np.float32(0.5), 0.0, 1.0)
    d = np.maximum(depth, 0.0)
    if not under.any():
        return above, alpha.copy()
    t_img = np.exp(d[..., None] * -column.k_img)  # (n, n, 3)
    t_col = np.exp(d[..., None] * -column.k_col)
    wet = d[under > 0.5]
    mean_depth = float(wet.mean()) if wet.size else 0.0
    a = alpha[..., None]
    # the scattered light and the water's light past the object spread by
    # VEIL_PER_METRE per metre of each pixel's own depth: a few blur levels, each pixel
    # mixed from the two levels around its spread (hat weights in the level's sigma)
    grid = _veil_levels(VEIL_PER_METRE * float(d.max()) / pitch_m)
    spread = d * np.float32(VEIL_PER_METRE / pitch_m)
    scattered = below * (np.exp(d[..., None] * -column.k_obj) - t_img) * a
    veil = np.zeros_like(scattered)
    covered = np.zeros_like(alpha)
    for k, sigma in enumerate(grid):
        w = _hat(spread, grid, k)
        if not w.any():
            continue
        # what a pixel scatters lands around it (spread at the source's depth); what it
        # receives of the water past the object depends on the cover around it (at the
        # receiving pixel's depth)
        veil += _wide_blur(scattered * w[..., None], sigma)
        covered += w * _wide_blur(alpha, sigma)
    # the water behind the object, seen past it by the same small-angle scattering: the
    # object's shadow in the water's light is blurred too, a thin limb's filled in
    # (the water's light is radiance above the surface already: not transmitted again)
    around = np.clip(1.0 - covered, 0.0, 1.0)[..., None]
    seen = below * t_img + veil / np.maximum(a, 1e-4)
    seen *= np.float32(column.transmission)
    seen += (1.0 - t_col) * column.deep + column.reflection
    seen += np.maximum(t_col - t_img, 0.0) * column.deep * around
    sigma = blur_per_metre * 1.5 * mean_depth / pitch_m
    if sigma >= 0.5:
        # premultiplied blur, so the transparent surround does not darken the edge
        k = np.clip(d * np.float32(1.0 / max(float(d.max()), 1e-6)), 0.0, 1.0)[..., None]
        soft = cv2.GaussianBlur(seen * a, (0, 0), sigma)
        soft_a = cv2.GaussianBlur(alpha, (0, 0), sigma)[..., None]
        seen = seen + (soft / np.maximum(soft_a, 1e-4) - seen) * k
    u3 = under[..., None]
    out = above * (1.0 - u3) + seen * u3
    trans = (t_img @ LUMA) * under + (1.0 - under)
    return out.astype(np.float32), (alpha * trans).astype(np.float32)


def apparent_depth(cos_view: float) -> float:
    """The factor by which the flat surface's refraction lifts a submerged point towards it,
    seen along a ray ``cos_view`` from the vertical: its image lies where the refracted ray
    through it crosses the surface, as a point at ``k`` times its depth would in air, ``k =
    tan(theta_w) / tan(theta)`` (``1 / n`` looking straight down, about 0.63 at 45 degrees,
    0.49 at 60)."""
    c = min(max(float(cos_view), 1e-3), 1.0)
    s = math.sqrt(max(1.0 - c * c, 0.0))
    if s < 1e-6:
        return 1.0 / N_WATER
    c_w = float(refracted_cos(c))
    return math.sqrt(max(1.0 - c_w * c_w, 0.0)) / c_w * c / s


def refract(stack: np.ndarray, depth: np.ndarray, up: np.ndarray, pitch_m: float
            ) -> np.ndarray:
    """``stack`` (n, n, c) float32, channels linear in coverage (premultiplied colour,
    coverage, weight; coverage in channel 3), with every submerged pixel moved to where
    the surface's refraction shows it: raised by ``(1 - k) d`` (:func:`apparent_depth`)
    along the world's up as the sprite sees it, ``up`` (3,) (right, up, towards the camera:
    the world's vertical in the pose's frame). ``depth`` (n, n) float32 is each pixel's
    metres under the surface (negative above it), ``pitch_m`` metres per sprite pixel.
    Parts above the water stay where they are, in front of what moves behind them; what
    the body leaves below is water. Returns ``stack`` itself when nothing moves by a
    quarter pixel (looking straight down, nothing under the water, a small sprite)."""
    sin_v = math.hypot(float(up[0]), float(up[1]))
    alpha = stack[..., 3]
    covered = alpha > 0
    wet = covered & (depth > 0.0)
    if sin_v < 0.02 or not wet.any():
        return stack
    lift = 1.0 - apparent_depth(math.sqrt(max(1.0 - sin_v * sin_v, 0.0)))
    # sprite pixels a point moves per metre of depth: (columns, rows), rows run down
    vx, vy = lift * float(up[0]) / pitch_m, -lift * float(up[1]) / pitch_m
    reach = math.hypot(vx, vy) * float(depth[wet].max())
    if reach < 0.25:  # a quarter pixel at most: nothing to see
        return stack
    # the work is confined to the submerged part and where it can move to
    rows, cols = np.flatnonzero(wet.any(axis=1)), np.flatnonzero(wet.any(axis=0))
    pad = int(math.ceil(reach)) + 1
    n_y, n_x = depth.shape
    y0, y1 = max(int(rows[0]) - pad, 0), min(int(rows[-1]) + pad + 1, n_y)
    x0, x1 = max(int(cols[0]) - pad, 0), min(int(cols[-1]) + pad + 1, n_x)
    box = (slice(y0, y1), slice(x0, x1))
    cov = covered[box]
    d = np.where(cov, np.maximum(depth[box], 0.0), 0.0).astype(np.float32)
    # the depth carried on past the body's outline (a normalised blur), so that the
    # search below sees a smooth field: a point that would come from beyond the body
    # comes from the water
    a = cov.astype(np.float32)
    sigma = max(n_y / 16.0, 1.0)
    spread = _wide_blur(d * a, sigma) / np.maximum(_wide_blur(a, sigma), 1e-4)
    field = np.where(cov, d, spread).astype(np.float32)
    gx, gy = np.meshgrid(np.arange(x1 - x0, dtype=np.float32),
                         np.arange(y1 - y0, dtype=np.float32))
    mx, my = gx, gy
    # each pixel shows the point q with q + v d(q) = p: a contraction (|v grad d| < 1),
    # found by fixed-point steps from q = p
    for _ in range(3):
        dq = cv2.remap(field, mx, my, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
        mx = gx - np.float32(vx) * dq
        my = gy - np.float32(vy) * dq
    part = stack[box]
    dry = (cov & (depth[box] < 0.0)).astype(np.float32)[..., None]
    moved = cv2.remap(part * (1.0 - dry), mx, my, cv2.INTER_LINEAR,
                      borderMode=cv2.BORDER_CONSTANT, borderValue=0)
    if moved.ndim == 2:
        moved = moved[..., None]
    front = part * dry
    out = stack.copy()
    out[box] = front + moved * (1.0 - front[..., 3:4])
    return out
