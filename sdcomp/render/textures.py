"""The textures of a run (:class:`Textures`): the water's tiles
(:class:`~sdcomp.render.water.WaterTextures`) and the land's albedo tile.

Ground tiles here are periodic, stored padded to twice their period (so any crop up to one
period long starts anywhere in the first period) and as a mip pyramid (level ``k`` has a pixel
pitch of ``pitch * 2**k`` metres); land tiles are sRGB uint8 albedo. Pure functions of their
arguments.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import cv2
import numpy as np

from .water import WaterTextures


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


def stone_tile(seed: int, n: int = 1024, pitch: float = 0.08, stone: float = 0.5
               ) -> Texture:
    """A periodic tile of rip-rap (sRGB uint8, 3 channels, ``n`` texels of ``pitch``
    metres): rounded grey-white to buff stones about ``stone`` metres across (the cells of a
    jittered grid, each its own shade, lit from one side, dark gaps between them), as lake
    and harbour shores are armoured. Its 82 m period spans the frames whose pixels can show
    a stone (4 cm a pixel at 800 px across: 32 m)."""
    rng = np.random.default_rng([seed, 0x570E])
    m = max(1, int(round(n * pitch / stone)))  # cells a side
    c = np.float32(n / m)  # texels a cell
    jitter = rng.uniform(0.1, 0.9, (2, m, m)).astype(np.float32)
    shade = rng.uniform(0.0, 1.0, (m, m)).astype(np.float32)
    stretch = rng.uniform(0.75, 1.3, (m, m)).astype(np.float32)  # elongated stones
    y, x = np.mgrid[0:n, 0:n].astype(np.float32) + np.float32(0.5)
    ix, iy = np.floor(x / c).astype(np.int32), np.floor(y / c).astype(np.int32)
    f1 = np.full((n, n), np.inf, np.float32)  # distance to the nearest cell's centre
    f2 = f1.copy()  # to the second nearest
    cell = np.zeros((n, n), np.int64)
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            wx, wy = (ix + dx) % m, (iy + dy) % m
            e = stretch[wy, wx]
            d = np.hypot((x - ((ix + dx).astype(np.float32) + jitter[0, wy, wx]) * c) * e,
                         (y - ((iy + dy).astype(np.float32) + jitter[1, wy, wx]) * c) / e)
            closer = d < f1
            f2 = np.where(closer, f1, np.minimum(f2, d))
            cell = np.where(closer, wy * m + wx, cell)
            f1 = np.where(closer, d, f1)
    gap = np.clip((f2 - f1) / (0.18 * c), 0, 1) ** 0.6  # 0 between stones
    dome = np.clip(1 - f1 / (0.8 * c), 0, 1).astype(np.float32)
    slope = cv2.Sobel(dome, cv2.CV_32F, 1, 0) + cv2.Sobel(dome, cv2.CV_32F, 0, 1)
    lit = 1 + 0.22 * np.clip(-0.7 * slope, -1, 1)
    t = (0.35 + 0.65 * shade.reshape(-1)[cell])[..., None]
    pale = np.array([206, 204, 198], np.float32)  # sRGB
    buff = np.array([170, 152, 130], np.float32)
    img = (pale * t + buff * (1 - t)) * ((0.25 + 0.75 * gap) * lit)[..., None]
    return _pyramid(np.clip(np.rint(img), 0, 255).astype(np.uint8), pitch)


@dataclass(frozen=True, eq=False)
class Textures:
    """The textures of a run: the water's tiles, the land's and the shore's rip-rap."""

    water: WaterTextures
    land: Texture
    seed: int = 0

    @classmethod
    def build(cls, seed: int) -> Textures:
        """The textures of a run of ``seed`` (0.5 s, 40 MB; more water tiles are made on
        first use: :meth:`WaterTextures.build`, the shore's stones too)."""
        return cls(WaterTextures.build(seed), land_tile(seed), seed)

    @cached_property
    def stones(self) -> Texture:
        """The rip-rap along a shore (:func:`stone_tile`), made on first use (0.8 s)."""
        return stone_tile(self.seed)
