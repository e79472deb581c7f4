"""Periodic tiles built once per seed: wave slopes by octave band, clouds, glitter noise.

Wave bands (see :mod:`sdcomp.render.water.spectrum`): band ``b`` holds wavelengths
``[BAND0 2**b, BAND0 2**(b+1))``. Each band is ONE random realisation, a sum of Fourier modes
on its own lattice (period ``PERIOD_CYCLES * BAND0 * 2**b`` metres, ~4800 independent modes),
with equal slope variance per band (a ``k**-4`` height spectrum: the saturation range; the
renderer weights bands per image from the real spectrum) and the spreading
``1 + DELTA cos 2 phi`` around the wind. A band's realisation is the same wherever it is
drawn, so views switch between tiles without seams.

**Level tiles**: level ``l`` holds bands ``l`` and ``l + 1`` on an ``N x N`` grid of pitch
``pitch(l) = BAND0 2**l / 4`` metres (the finest wave spans 4 texels; period ``N pitch(l)`` =
one period of band ``l + 1``, two of band ``l``), stored (N + 1, N + 1, 4) uint8 (one wrapped
row and column: bilinear reads never leave the tile): channel 0 the upwind slope, 1 the
crosswind slope, each ``128 + SLOPE_SCALE * s / sd`` (``sd``: the channel's standard
deviation: unit-variance codes), channel 2 white Gaussian noise per texel (same coding: the
graininess of the facets too small to draw), channel 3 a unit-variance Gaussian
foam-placement field, same coding (whitecaps of coverage W where it exceeds the normal
quantile of 1 - W: :func:`foam_exceedance`). Every channel is a unit-variance Gaussian code
centred on 128, so that variance-preserving blends of reads at other offsets keep the
tile's statistics (:mod:`sdcomp.render.water.detile`). (4 channels make OpenCV's remap
fast.) Set ``k`` holds the wind at ``SET_ANGLES[k]`` degrees from the tile's x
axis (views align x with the image rows and pick the set nearest the wind: no rotation when
sampling). Column ``c`` of a tile holds tile x ``c - N/2`` (mod N): rows sampled around x = 0
stay inside the tile. The renderer draws level ``l`` per pixel, level ``l + 2`` at a quarter of the
resolution and levels ``l + 4, l + 6, ...`` (set 0) on its coarse grid. Level tiles are
built on first use (or up front: :meth:`WaterTextures.build`).

**Clouds**: a :class:`~sdcomp.render.water.sky.CloudField`; **glitter noise**: a (1024, 1024)
float32 tile of per-pixel quantile coordinates (see :func:`_noise`) for the glint of each pixel.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .sky import CloudField
from .spectrum import BAND0, N_BANDS

N_TILE = 512  # texels per level tile side
LEVEL_BANDS = 2  # octave bands per level tile
N_LEVELS = N_BANDS - LEVEL_BANDS + 1  # levels 0..12
PERIOD_CYCLES = 64  # band period in units of its shortest wavelength
SLOPE_SCALE = 32.0  # uint8 codes per standard deviation of a slope channel
DELTA = 0.8  # spreading of the tiles' waves: 1 + DELTA cos 2 phi (long-crested)
FOAM_DELTA = 0.85  # foam streaks lie along the wind
SET_ANGLES = (0.0, 45.0, 90.0, 135.0)  # wind direction of each set, degrees from tile x
NOISE_SIZE = 1024
CLOUD_SIZE = 512
CLOUD_LEVELS = 8


def pitch(level: int) -> float:
    """Texel pitch (m) of level tile ``level``."""
    return BAND0 * 2.0 ** level / 4.0


def _lattice() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Integer modes (mx, my) of a band: ``PERIOD_CYCLES / 2 < |m| <= PERIOD_CYCLES``,
    as flat int arrays, and |m|."""
    r = PERIOD_CYCLES
    m = np.arange(-r, r + 1)
    mx, my = np.meshgrid(m, m)
    mm = np.hypot(mx, my)
    keep = (mm > r / 2) & (mm <= r)
    return mx[keep], my[keep], mm[keep]


def _hermitian(c: np.ndarray, mx: np.ndarray, my: np.ndarray) -> np.ndarray:
    """Coefficients made Hermitian: ``(c(m) + conj(c(-m))) / 2`` (the field is real)."""
    r = PERIOD_CYCLES
    grid = np.zeros((2 * r + 1, 2 * r + 1), np.complex128)
    grid[my + r, mx + r] = c
    flipped = np.conj(grid[::-1, ::-1])
    return 0.5 * (c + flipped[my + r, mx + r])


@dataclass(eq=False)
class WaterTextures:
    """All periodic tiles of one seed (see the module docstring). Build with :meth:`build`.

    Attributes:
        seed: the seed.
        levels: ``levels[set][level]`` (N + 1, N + 1, 4) uint8 level tiles (None: not built).
        level_sd: ``level_sd[set][level]`` (2,) float64: the upwind and crosswind slope that
            ``SLOPE_SCALE`` code units stand for, in units where each band has unit total
            slope variance (so the two variances sum to about LEVEL_BANDS).
        uc_stack: (N_LEVELS, N + 1, N + 1, 2) uint8: the slope channels of set 0's level
            tiles (the coarse grid samples the long waves from it).
        clouds: :class:`CloudField`.
        noise: (1024, 1024) float32 glitter noise ``ln E``.
    """

    seed: int
    levels: list[list[np.ndarray | None]]
    level_sd: list[list[np.ndarray | None]]
    uc_stack: np.ndarray
    clouds: CloudField
    noise: np.ndarray
    _coef: dict = field(default_factory=dict, repr=False)

    # ------------------------------------------------------------------ build
    @classmethod
    def build(cls, seed: int, levels: range | None = None,
              sets: tuple[int, ...] = (1, 2, 3)) -> WaterTextures:
        """Build the tiles of ``seed`` (0.4 s, 36 MB): set 0's level tiles (all: the coarse
        grid samples them), clouds and noise; level tiles ``levels`` of direction ``sets``
        too when given (default none: built on first use, ~25 ms each; a generator that
        forks workers can build ``levels=range(1, 13)`` first: 1.7 s, 74 MB, shared).
        Deterministic in ``seed`` (tiles built later are the same)."""
        levels = range(0) if levels is None else levels
        mx, my, mm = _lattice()
        coef, raw = {}, {}
        for b in range(N_BANDS):
            rng = np.random.default_rng([int(seed), 0x5EA, b])
            c = rng.standard_normal(mx.size) + 1j * rng.standard_normal(mx.size)
            raw[b] = c
            coef[b] = _hermitian(c, mx, my)
        tex = cls(int(seed), [[None] * N_LEVELS for _ in SET_ANGLES],
                  [[None] * N_LEVELS for _ in SET_ANGLES],
                  np.empty((N_LEVELS, N_TILE + 1, N_TILE + 1, 2), np.uint8),
                  _clouds(seed), _noise(seed))
        tex._coef = {"modes": (mx, my, mm), "bands": coef, "raw": raw, "code_sd": {}}
        for lev in range(N_LEVELS):
            tex.uc_stack[lev] = tex.ensure(0, lev)[..., :2]
        for s in sets:
            if s == 0:
                continue
            for lev in levels:
                tex.ensure(s, lev)
        return tex

    def build_all(self) -> None:
        """Build every level tile of every direction set now (about 1.3 s and 40 MB more):
        a process that forks workers calls it first, so they share them instead of each
        building the ones it meets (~25 ms each)."""
        for s in range(len(SET_ANGLES)):
            for lev in range(N_LEVELS):
                self.ensure(s, lev)

    def _weights(self, angle_deg: float, delta: float, power: float) -> np.ndarray:
        """Mode amplitudes ``|m|**-power * sqrt(1 + delta cos 2 phi)``, phi from the wind at
        ``angle_deg`` in the tile frame."""
        mx, my, mm = self._coef["modes"]
        phi = np.arctan2(my, mx) - math.radians(angle_deg)
        return mm ** -power * np.sqrt(np.maximum(1.0 + delta * np.cos(2 * phi), 0.0))

    def _band_spectrum(self, b: int, angle_deg: float) -> tuple[np.ndarray, float]:
        """Slope-x and slope-y coefficients of band ``b`` normalised to unit total slope
        variance (as (2, M) complex128), for the wind at ``angle_deg``, and the norm."""
        mx, my, _ = self._coef["modes"]
        c = self._coef["bands"][b]
        h = c * self._weights(angle_deg, DELTA, 2.0)  # height, k^-4 power spectrum
        sx, sy = 1j * mx * h, 1j * my * h
        var = float((np.abs(sx) ** 2 + np.abs(sy) ** 2).sum())  # Parseval (field = sum)
        return np.stack([sx, sy]) / math.sqrt(var), math.sqrt(var)

    def ensure(self, s: int, level: int) -> np.ndarray:
        """Level tile ``level`` of direction set ``s`` (built now if it was not)."""
        tile = self.levels[s][level]
        if tile is not None:
            return tile
        n = N_TILE
        mx, my, _ = self._coef["modes"]
        angle = SET_ANGLES[s]
        spec = np.zeros((n, n), np.complex64)
        for b in range(level, min(level + LEVEL_BANDS, N_BANDS)):
            q = 2 ** (level + LEVEL_BANDS - 1 - b)  # FFT index per lattice unit
            sxy, _ = self._band_spectrum(b, angle)
            spec[(my * q) % n, (mx * q) % n] += (sxy[0] + 1j * sxy[1]).astype(np.complex64)
        field_ = np.fft.ifft2(spec)
        a = math.radians(angle)
        ca, sa = np.float32(math.cos(a)), np.float32(math.sin(a))
        sx, sy = field_.real, field_.imag
        su = ca * sx + sa * sy
        sc = ca * sy - sa * sx
        sd = np.array([su.std(), sc.std()], np.float64)
        self._coef["code_sd"][(s, level)] = sd
        fo = _foam_field(self.seed, level, angle, n)
        out = np.empty((n + 1, n + 1, 4), np.uint8)
        out[:n, :n, 0] = np.clip(su * np.float32(SLOPE_SCALE / sd[0]) + np.float32(128.5),
                                 0, 255)
        out[:n, :n, 1] = np.clip(sc * np.float32(SLOPE_SCALE / sd[1]) + np.float32(128.5),
                                 0, 255)
        grain = np.random.default_rng([self.seed, 0x62A1, s, level]).standard_normal(
            (n, n)).astype(np.float32)
        out[:n, :n, 2] = np.clip(grain * np.float32(SLOPE_SCALE) + np.float32(128.5), 0, 255)
        out[:n, :n, 3] = np.clip(fo * np.float32(SLOPE_SCALE) + np.float32(128.5), 0, 255)
        out[:n, :n] = np.roll(out[:n, :n], n // 2, axis=1)  # column c holds x = c - n/2
        out[n, :n] = out[0, :n]
        out[:, n] = out[:, 0]
        # the slope codes are rounded: the standard deviation one code unit stands for is
        # that of the stored channel (quantisation adds 1/12 code^2 of variance)
        self.levels[s][level] = out
        # (ifft2 divides by n^2: the band fields are sums of their modes)
        self.level_sd[s][level] = sd * (n * n) * np.array([
            out[:n, :n, 0].std(), out[:n, :n, 1].std()]) / SLOPE_SCALE
        return out

    def coarse_level(self, level: int) -> np.ndarray:
        """(N + 1, N + 1, 2) uint8 slope codes (upwind, crosswind) of set 0's level tile
        ``level``: what the coarse grid samples its long waves from."""
        return self.uc_stack[level]

    def band_modes(self, b: int, angle_deg: float) -> dict:
        """The Fourier modes of band ``b`` for the wind at ``angle_deg`` (tile frame):
        ``mx``, ``my`` (M,) int lattice indices (cycles per band period ``PERIOD_CYCLES
        BAND0 2**b`` metres along tile x, y), ``raw`` (M,) complex128 the band's random
        coefficients BEFORE the Hermitian symmetrisation (the height coefficient of the
        tiles is ``weight (raw(m) + conj(raw(-m))) / 2``), ``weight`` (M,) the height
        amplitude ``|m|**-2 sqrt(1 + DELTA cos 2 phi)``, ``norm``: the band's slope norm
        (its slope coefficients are divided by it: unit slope variance), ``neg`` (M,) int:
        the index of mode ``-m``."""
        mx, my, _ = self._coef["modes"]
        _, norm = self._band_spectrum(b, angle_deg)
        r = PERIOD_CYCLES
        idx = np.full((2 * r + 1, 2 * r + 1), -1, np.int64)
        idx[my + r, mx + r] = np.arange(mx.size)
        return {"mx": mx, "my": my, "raw": self._coef["raw"][b],
                "weight": self._weights(angle_deg, DELTA, 2.0), "norm": norm,
                "neg": idx[r - my, r - mx]}

    def code_sd(self, s: int, level: int) -> np.ndarray:
        """(2,) float64: the standard deviations (upwind, crosswind; FFT units, before the
        codes) that ``SLOPE_SCALE`` code units stand for in level tile ``level`` of set
        ``s`` (builds the tile if needed)."""
        self.ensure(s, level)
        return self._coef["code_sd"][(s, level)]

    def level_share(self, s: int, level: int) -> np.ndarray:
        """(LEVEL_BANDS, 2) upwind/crosswind slope variance of each band of level tile
        ``level`` of set ``s`` in tile units (rows: bands level, level + 1, ...)."""
        out = []
        for b in range(level, min(level + LEVEL_BANDS, N_BANDS)):
            sxy, _ = self._band_spectrum(b, SET_ANGLES[s])
            a = math.radians(SET_ANGLES[s])
            su = math.cos(a) * sxy[0] + math.sin(a) * sxy[1]
            sc = -math.sin(a) * sxy[0] + math.cos(a) * sxy[1]
            out.append([float((np.abs(su) ** 2).sum()), float((np.abs(sc) ** 2).sum())])
        return np.array(out)

    @property
    def nbytes(self) -> int:
        total = self.noise.nbytes + self.clouds.stack.nbytes
        total += self.uc_stack.nbytes
        total += sum(t.nbytes for ss in self.levels for t in ss if t is not None)
        return total


def erfc_nonneg(z: np.ndarray) -> np.ndarray:
    """erfc(z) for z >= 0 (Abramowitz & Stegun 7.1.26, |err| < 1.5e-7), in ``z``'s float
    dtype."""
    t = 1.0 / (1.0 + 0.3275911 * z)
    poly = t * (0.254829592 + t * (-0.284496736 + t * (1.421413741 + t * (
        -1.453152027 + t * 1.061405429))))
    return poly * np.exp(-z * z)


def foam_exceedance() -> np.ndarray:
    """(256,) float64: the fraction of a tile whose foam code (channel 3) exceeds each code
    (the normal tail at ``(code - 128) / SLOPE_SCALE``)."""
    z = (np.arange(256) - 128.0) / (SLOPE_SCALE * math.sqrt(2.0))
    return np.array([0.5 * math.erfc(float(v)) for v in z])


FOAM_SIZE = (0.5, 4.0)  # metres: sizes of whitecap patches and their streaks


def _foam_field(seed: int, level: int, angle_deg: float, n: int) -> np.ndarray:
    """A periodic (n, n) float32 unit-variance Gaussian field for whitecaps: patches of
    FOAM_SIZE metres (texels of ``pitch(level)``) with ragged, streaky edges (a red spectrum
    down to 3 texels), streaked along the wind at ``angle_deg``. Zero where the patches
    would be smaller than 3 texels (the level's texels are too coarse to draw them)."""
    rng = np.random.default_rng([int(seed), 0xF0A, level])
    p = BAND0 * 2.0 ** level / 4.0
    k_lo = max(1.5, n * p / FOAM_SIZE[1])
    k_hi = min(n / 3.0, n * p / (0.25 * FOAM_SIZE[0]))
    if k_lo >= n / 3.0:
        return np.zeros((n, n), np.float32) - 9.0  # (no foam at this level)
    k = np.fft.fftfreq(n) * n
    kx, ky = np.meshgrid(k, k)
    kk = np.hypot(kx, ky)
    kk[0, 0] = 1.0
    phi = np.arctan2(ky, kx) - math.radians(angle_deg)
    band = (kk >= k_lo) & (kk <= k_hi)
    amp = kk ** -1.35 * band * np.sqrt(np.maximum(1 - FOAM_DELTA * np.cos(2 * phi), 0.05))
    white = (rng.standard_normal((n, n)) + 1j * rng.standard_normal((n, n))).astype(
        np.complex64)
    f = np.fft.ifft2(white * amp.astype(np.float32)).real.astype(np.float32)
    return f / max(float(f.std()), 1e-30)


def _clouds(seed: int) -> CloudField:
    """Periodic fBm (power spectrum ~ k**-3.4, unit variance) and its blurred copies."""
    n = CLOUD_SIZE
    rng = np.random.default_rng([int(seed), 0xC10D])
    k = np.fft.fftfreq(n) * n
    kx, ky = np.meshgrid(k, k)
    kk = np.hypot(kx, ky)
    kk[0, 0] = 1.0
    amp = kk ** -1.7 * (kk >= 2.0) * np.exp(-(kk / (n / 3)) ** 2)
    white = rng.standard_normal((n, n)) + 1j * rng.standard_normal((n, n))
    spec = (white * amp).astype(np.complex64)
    f0 = np.fft.ifft2(spec).real
    spec /= np.float32(f0.std())
    stack = np.empty((n, n, CLOUD_LEVELS), np.float32)
    var = np.empty(CLOUD_LEVELS)
    k2 = (kx ** 2 + ky ** 2).astype(np.float32)
    for lev in range(CLOUD_LEVELS):
        sigma = 2.0 ** lev - 1.0
        gauss = np.exp(np.float32(-2 * (math.pi * sigma / n) ** 2) * k2)
        b = np.fft.ifft2(spec * gauss).real
        stack[..., lev] = b
        var[lev] = float(np.mean(b * b))
    return CloudField(stack, var.astype(np.float32))


NOISE_DECADES = 6.0  # the glitter noise resolves probabilities down to 10**-6


def _noise(seed: int) -> np.ndarray:
    """(NOISE_SIZE, NOISE_SIZE) float32 ``-log10(1 - u) * 255 / NOISE_DECADES`` (clipped to
    255) of uniform ``u``: the column of the glint table (:mod:`sdcomp.render.water.glitter`)
    a pixel reads,
    i.e. the quantile it draws, on a log scale of its exceedance probability."""
    rng = np.random.default_rng([int(seed), 0x6117])
    u = rng.random((NOISE_SIZE, NOISE_SIZE), dtype=np.float64)
    c = -np.log10(1.0 - u) * (255.0 / NOISE_DECADES)
    return np.clip(c, 0.0, 255.0).astype(np.float32)

