"""Periodic ground textures: sea-surface waves, sea floor and land, as mip pyramids.

Everything here is a pure function of its arguments. Conventions:

- Texture tiles are periodic, stored padded to twice their period (so any crop up to one
  period long starts anywhere in the first period) and as a mip pyramid (level ``k`` has a
  pixel pitch of ``pitch * 2**k`` metres).
- Wave tiles have 3 uint8 channels (3, not 4: OpenCV's per-pixel colour transform is fast
  for 3): slope along x and y (``128 + 40 * slope / sd``) and sparkle (0..255, high on steep
  facets near crests: they flash in the sun and break into whitecaps in strong wind).
- Floor and land tiles are sRGB uint8 albedo.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import cv2
import numpy as np

from .optics import SLOPE_SCALE

WAVE_DIRECTIONS = (0.0, 45.0, 90.0, 135.0)  # degrees: one wave tile per swell direction

@dataclass(frozen=True, eq=False)
class Texture:
    """A periodic tile as a mip pyramid: ``levels[k]`` (2P_k, 2P_k, C) uint8 holds a tile of
    period ``P_k = period >> k`` pixels, padded to twice the period; pixel pitch
    ``pitch * 2**k`` metres."""

    levels: tuple[np.ndarray, ...]
    period: int
    pitch: float

    @cached_property
    def mean(self) -> np.ndarray:
        """(C,) float32 mean value of each channel (from the coarsest level)."""
        top = self.levels[-1]
        return top.reshape(-1, top.shape[-1]).mean(0).astype(np.float32)

    def crop_size(self, width_m: float, height_m: float, out_w: int) -> tuple[int, int, int]:
        """(mip level, crop width, crop height) in texels that :meth:`view` reads for a
        ground rectangle of ``width_m`` x ``height_m`` metres drawn ``out_w`` pixels wide:
        the finest level whose crop fits in one period and is at most twice ``out_w``."""
        k = 0
        while k + 1 < len(self.levels) and (max(width_m, height_m) / (self.pitch * 2 ** k)
                                             > (self.period >> k)
                                             or width_m / (self.pitch * 2 ** k) > 2 * out_w):
            k += 1
        per = self.period >> k
        px = self.pitch * 2 ** k
        # whole-pixel crop (its size rounded: under half a pixel of scale error)
        cw = int(min(max(round(width_m / px), 1), 2 * per))
        ch = int(min(max(round(height_m / px), 1), 2 * per))
        return k, cw, ch

    def view(self, x0: float, y0: float, width_m: float, height_m: float,
             out_w: int, out_h: int) -> np.ndarray:
        """The axis-aligned ground rectangle from (x0, y0) metres, ``width_m`` x
        ``height_m``, resampled to (out_h, out_w, C) uint8 (wrapping periodically)."""
        k, cw, ch = self.crop_size(width_m, height_m, out_w)
        tile = self.levels[k]
        per = self.period >> k
        px = self.pitch * 2 ** k
        ix = min(int(x0 / px) % per, 2 * per - cw)
        iy = min(int(y0 / px) % per, 2 * per - ch)
        crop = tile[iy:iy + ch, ix:ix + cw]
        interp = cv2.INTER_AREA if (cw > out_w or ch > out_h) else cv2.INTER_LINEAR
        return cv2.resize(crop, (out_w, out_h), interpolation=interp)

    def sample_rows(self, x0: float, y0: float, scale: np.ndarray, u: np.ndarray,
                    y_rows: np.ndarray, pitch_m: float) -> np.ndarray:
        """Texture at the ground points ``(x0 + scale[i] * u[j], y0 + y_rows[i])`` metres
        (rows ``i``, columns ``j``: a perspective view's rows lie along its ground lines),
        (len(scale), len(u), C) uint8, through the mip level suited to a pixel footprint of
        ``pitch_m`` metres."""
        k = int(np.clip(math.floor(math.log2(max(pitch_m / self.pitch, 1.0))), 0,
                        len(self.levels) - 1))
        per = self.period >> k
        px = self.pitch * 2 ** k
        tile = self.levels[k][:per, :per]
        # texel coordinates within the first period (remap's fast path; BORDER_WRAP only
        # for the samples that straddle its edge); y is one value per row
        mx = np.multiply.outer((np.asarray(scale) / px).astype(np.float32),
                               np.asarray(u, np.float32))
        mx += np.float32((x0 / px) % per)
        mx -= np.floor(mx * np.float32(1.0 / per)) * np.float32(per)  # (np.remainder: slow)
        my = np.empty_like(mx)
        my[:] = ((np.asarray(y_rows) / px + y0 / px) % per).astype(np.float32)[:, None]
        return cv2.remap(tile, mx, my, cv2.INTER_LINEAR, borderMode=cv2.BORDER_WRAP)


def _pyramid(tile: np.ndarray, pitch: float, min_period: int = 16) -> Texture:
    levels = []
    t = tile
    period = tile.shape[0]
    while True:
        levels.append(np.ascontiguousarray(np.tile(t, (2, 2, 1))))
        if t.shape[0] // 2 < min_period:
            break
        t = cv2.resize(t, (t.shape[1] // 2, t.shape[0] // 2), interpolation=cv2.INTER_AREA)
        if t.ndim == 2:
            t = t[..., None]
    return Texture(tuple(levels), period, pitch)


def _spectral_noise(rng: np.random.Generator, n: int, amplitude: np.ndarray) -> np.ndarray:
    """Periodic real field (n, n) float64: white noise filtered by ``amplitude`` (n, n) in
    the FFT domain, normalised to zero mean and unit standard deviation."""
    white = rng.standard_normal((n, n))
    f = np.fft.fft2(white) * amplitude
    field = np.real(np.fft.ifft2(f))
    field -= field.mean()
    return field / max(field.std(), 1e-12)


def _frequencies(n: int, pitch: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """FFT frequency grids (n, n) of a periodic tile of n pixels of ``pitch`` metres: kx,
    ky and |k| in cycles per metre (|k| set to 1 at the zero frequency, to divide by)."""
    k = np.fft.fftfreq(n, d=pitch)
    kx, ky = np.meshgrid(k, k)
    kk = np.hypot(kx, ky)
    kk[0, 0] = 1.0
    return kx, ky, kk


def wave_tile(seed: int, direction_deg: float, n: int = 512, pitch: float = 0.04) -> Texture:
    """A periodic sea-surface tile: wind waves (a power-law spectrum, mostly along
    ``direction_deg`` in the tile frame, x to the right, y down) plus a swell.

    Returns a :class:`Texture` of 3 uint8 channels (see the module docstring).
    """
    rng = np.random.default_rng([seed, 7919, int(round(direction_deg * 10))])
    kx, ky, kk = _frequencies(n, pitch)
    theta = math.radians(direction_deg)
    cos_d = (kx * math.cos(theta) + ky * math.sin(theta)) / kk
    spread = 0.35 + 0.65 * cos_d ** 2  # waves travel mostly along the wind
    wind = kk ** -1.9 * spread * (kk > 1 / (n * pitch) * 1.5) * (kk < 4.0)
    swell_k = 1.0 / (n * pitch / 3)  # three swell crests per period
    swell = np.exp(-((kk - swell_k) / (0.35 * swell_k)) ** 2) * cos_d ** 8
    swell *= wind.max() * 0.6
    h = _spectral_noise(rng, n, np.sqrt(wind + swell))
    gy, gx = np.gradient(h)
    sd = max(np.std(gx), np.std(gy), 1e-12)
    sx, sy = gx / sd, gy / sd
    steep = np.hypot(sx, sy) * (0.6 + 0.4 * np.clip(h, 0, 2))  # steep, high on crests
    sparkle = np.clip((steep - 1.4) / 1.6, 0, 1) ** 2
    tile = np.stack([128 + SLOPE_SCALE * sx, 128 + SLOPE_SCALE * sy, 255 * sparkle], axis=-1)
    return _pyramid(np.clip(np.rint(tile), 0, 255).astype(np.uint8), pitch)


def floor_tile(seed: int, rocks: float, n: int = 512, pitch: float = 0.04) -> Texture:
    """A periodic sea-floor albedo tile (sRGB uint8, 3 channels): rippled sand with rocks
    and debris covering about ``rocks`` (0..1) of the area."""
    rng = np.random.default_rng([seed, 104729])
    kx, ky, kk = _frequencies(n, pitch)
    coarse = _spectral_noise(rng, n, kk ** -1.6 * (kk > 0.1))
    ripples = _spectral_noise(rng, n, np.exp(-((kk - 1.5) / 0.3) ** 2) * (kx != 0))
    sand = np.array([150, 134, 100], np.float32)
    shade = 1.0 + 0.10 * coarse + 0.05 * ripples
    img = sand[None, None, :] * shade[..., None]
    if rocks > 0:
        area = float(n * n) * float(rocks)
        drawn = 0.0
        canvas = np.zeros((n, n), np.float32)
        colours = np.zeros((n, n, 3), np.float32)
        while drawn < area:
            r = rng.uniform(0.15, 0.9) / pitch  # radius in pixels
            cx, cy = rng.uniform(0, n, 2)
            ax, ay = r, r * rng.uniform(0.5, 1.0)
            angle = rng.uniform(0, 180)
            tone = rng.uniform(0.25, 0.65)
            rgb = np.array([95, 90, 80], np.float32) * tone / 0.45
            for dx in (-n, 0, n):  # draw wrapped copies so the tile stays periodic
                for dy in (-n, 0, n):
                    centre = (int(cx + dx), int(cy + dy))
                    if -2 * r < centre[0] < n + 2 * r and -2 * r < centre[1] < n + 2 * r:
                        cv2.ellipse(canvas, centre, (int(ax), int(ay)), angle, 0, 360, 1.0, -1)
                        cv2.ellipse(colours, centre, (int(ax), int(ay)), angle, 0, 360,
                                    rgb.tolist(), -1)
            drawn += math.pi * ax * ay
        rock_shade = 1.0 + 0.25 * coarse[..., None]
        mask = cv2.GaussianBlur(canvas, (0, 0), 1.0)[..., None]
        img = img * (1 - mask) + colours * rock_shade * mask
    return _pyramid(np.clip(np.rint(img), 0, 255).astype(np.uint8), pitch)


def land_tile(seed: int, n: int = 256, pitch: float = 0.25) -> Texture:
    """A periodic land-cover tile (sRGB uint8, 3 channels): grass, scrub and bare soil."""
    rng = np.random.default_rng([seed, 15485863])
    _, _, kk = _frequencies(n, pitch)
    a = _spectral_noise(rng, n, kk ** -1.5 * (kk > 0.02))
    b = _spectral_noise(rng, n, kk ** -0.8 * (kk > 0.02))
    grass = np.array([70, 96, 48], np.float32)
    soil = np.array([128, 110, 82], np.float32)
    t = np.clip(0.5 + 0.35 * a, 0, 1)[..., None]
    img = (grass * t + soil * (1 - t)) * (1 + 0.12 * b)[..., None]
    return _pyramid(np.clip(np.rint(img), 0, 255).astype(np.uint8), pitch)


@dataclass(frozen=True, eq=False)
class Textures:
    """The ground textures of a run: wave tiles (one per :data:`WAVE_DIRECTIONS`), the sea
    floor and land."""

    waves: tuple[Texture, ...]
    floor: Texture
    land: Texture

    @classmethod
    def build(cls, seed: int, rocks: float) -> Textures:
        """The textures of a run of ``seed`` with ``rocks`` (0..1) of the floor covered."""
        return cls(tuple(wave_tile(seed, d) for d in WAVE_DIRECTIONS), floor_tile(seed, rocks),
                   land_tile(seed))
