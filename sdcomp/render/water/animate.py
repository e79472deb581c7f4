"""Moving waves for video: level tiles evolved in time, read through the same interface as
:class:`~sdcomp.render.water.textures.WaterTextures`.

Each band of the tiles is a sum of Fourier modes ``m`` (lattice of
:func:`~sdcomp.render.water.textures.WaterTextures.band_modes`; wavenumber ``k = 2 pi |m| /
L_b`` rad/m with ``L_b = PERIOD_CYCLES BAND0 2**b`` metres the band's period). A still tile's
height coefficient is ``w(m) (r(m) + conj(r(-m))) / 2`` (``r``: the band's raw complex
Gaussian numbers, ``w``: the spectral amplitude). Animated, the same numbers are split into
waves TRAVELLING along ``+m``::

    h(m, t) = w(m) (a(m) exp(-i omega t) + conj(a(-m)) exp(+i omega t)),
    a(m) = r(m) sqrt(1 + GAMMA cos phi) / 2,

``omega(k)`` the deep-water dispersion relation with capillarity
(:func:`~sdcomp.render.water.waves.omega`), ``phi`` the angle between ``m`` and the direction
the wind blows TOWARDS (more energy travels downwind; the expected power of every mode at
any time is the still tile's: ``(1 + GAMMA cos phi) + (1 - GAMMA cos phi) = 2``). The slope
codes keep the still tile's code scale (``level_sd``), grain (channel 2) and foam placement
(channel 3), so a code means the same slope in every frame. One inverse FFT per tile (512 x
512 complex, OpenCV's DFT: ~0.7 ms; ~2.1 ms a tile in all), built on first use and kept for
that time.

:func:`textures_for` gives the renderer the tiles of a :class:`~sdcomp.scene.water.WaterParams`:
the still ones without ``time``, else a (cached) :class:`AnimatedTextures`.
"""

from __future__ import annotations

import math
import threading
from functools import lru_cache

import cv2
import numpy as np

from ...scene.water import WaterParams
from .spectrum import BAND0, N_BANDS
from .textures import LEVEL_BANDS, N_TILE, PERIOD_CYCLES, SET_ANGLES, SLOPE_SCALE, WaterTextures
from .waves import omega

_LOCK = threading.Lock()
GAMMA = 0.6  # downwind bias of the travelling waves: amplitude sqrt(1 + GAMMA cos phi)


def band_split(base: WaterTextures, b: int, angle_deg: float, downwind: float) -> dict:
    """The travelling-wave split of band ``b`` (wind axis at ``angle_deg`` in the tile frame;
    ``downwind`` +1: the wind blows towards +axis, -1: towards -axis).

    Returns ``mx``, ``my`` (M,) int modes, ``fwd`` (M,) complex128 ``w(m) a(m) / norm``
    (the wave travelling along +m), ``back`` (M,) complex128 ``w(m) conj(a(-m)) / norm``
    (the conjugate of the wave along -m, stored at m), both in units where the band has
    unit slope variance, ``k`` (M,) rad/m and ``omega`` (M,) rad/s."""
    modes = base.band_modes(b, angle_deg)
    mx, my, neg = modes["mx"], modes["my"], modes["neg"]
    down = math.radians(angle_deg) + (0.0 if downwind >= 0 else math.pi)
    bias = np.sqrt(1.0 + GAMMA * np.cos(np.arctan2(my, mx) - down))
    a = modes["raw"] * bias * 0.5
    scale = modes["weight"] / modes["norm"]
    k = 2 * math.pi * np.hypot(mx, my) / (PERIOD_CYCLES * BAND0 * 2.0 ** b)
    return {"mx": mx, "my": my, "fwd": scale * a, "back": scale * np.conj(a[neg]), "k": k,
            "omega": omega(k)}


@lru_cache(maxsize=128)
def _level_modes(base: WaterTextures, s: int, level: int, downwind: float) -> tuple:
    """The time-independent part of :func:`evolved_spectrum` (cached): flat FFT indices
    (M,) of the level's modes (its bands' indices are disjoint), the factors (M,)
    complex64 ``P = fwd + back`` and ``Q = -i (fwd - back)`` of the forward and backward
    waves (slope packing, axis turn, half-tile roll folded in; at phase ``theta`` the
    mode is ``fwd e^(-i theta) + back e^(i theta) = P cos theta + Q sin theta``) and omega
    (M,) rad/s."""
    n = N_TILE
    angle = SET_ANGLES[s]
    rot = complex(math.cos(math.radians(angle)), -math.sin(math.radians(angle)))
    idx, fwd, back, om = [], [], [], []
    for b in range(level, min(level + LEVEL_BANDS, N_BANDS)):
        q = 2 ** (level + LEVEL_BANDS - 1 - b)  # FFT index per lattice unit
        sp = band_split(base, b, angle, downwind)
        mx, my = sp["mx"], sp["my"]
        # slopes i m h packed as sx + i sy, turned to (upwind, crosswind), rolled by N/2
        f = 1j * (mx + 1j * my) * rot * np.where((mx * q) % 2 == 0, 1.0, -1.0)
        idx.append(((my * q) % n) * n + (mx * q) % n)
        fwd.append(f * sp["fwd"])
        back.append(f * sp["back"])
        om.append(sp["omega"])
    f_all, b_all = np.concatenate(fwd), np.concatenate(back)
    return (np.concatenate(idx), (f_all + b_all).astype(np.complex64),
            (-1j * (f_all - b_all)).astype(np.complex64), np.concatenate(om))


def evolved_spectrum(base: WaterTextures, s: int, level: int, t: float,
                     downwind: float) -> np.ndarray:
    """(N_TILE, N_TILE) complex64 spectrum of level tile ``level`` of set ``s`` at ``t``
    seconds: its inverse FFT is ``su + i sc`` (upwind and crosswind slopes in the still
    tile's FFT units, columns holding tile x ``c - N/2``: the half-tile roll is a phase
    ``(-1)**kx``). The phases ``omega t`` are reduced to [-pi, pi] in double precision,
    their cosines and sines taken in single (a relative error of about 2e-7 in the
    spectrum, that of its complex64 storage; a fifth of the cost of a complex exp)."""
    idx, p, q, om = _level_modes(base, s, level, 1.0 if downwind >= 0 else -1.0)
    phase = om * float(t)
    phase -= np.rint(phase * (0.5 / math.pi)) * (2.0 * math.pi)
    phase32 = phase.astype(np.float32)
    spec = np.zeros(N_TILE * N_TILE, np.complex64)
    spec[idx] = p * np.cos(phase32) + q * np.sin(phase32)
    return spec.reshape(N_TILE, N_TILE)


def evolved_tile(base: WaterTextures, s: int, level: int, t: float,
                 downwind: float) -> np.ndarray:
    """(N + 1, N + 1, 4) uint8 level tile ``level`` of set ``s`` at ``t`` seconds, coded as
    the still tile (same code scale; grain and foam channels copied from it). The inverse
    FFT is OpenCV's 2-D complex DFT (0.7 ms at 512 x 512, where NumPy's row and column
    transforms took 1.3 ms; a code differs by one from NumPy's in about 1e-5 of the
    texels, where a value lies on a code's edge)."""
    n = N_TILE
    still = base.ensure(s, level)
    sd = base.code_sd(s, level)
    f = evolved_spectrum(base, s, level, t, downwind)
    two = cv2.dft(f.view(np.float32).reshape(n, n, 2),
                  flags=cv2.DFT_INVERSE | cv2.DFT_SCALE | cv2.DFT_COMPLEX_OUTPUT)
    # (upwind, crosswind) slopes as codes: truncated after the half-level offset
    m = np.array([[SLOPE_SCALE / float(sd[0]), 0.0, 128.5],
                  [0.0, SLOPE_SCALE / float(sd[1]), 128.5]], np.float32)
    scaled = cv2.transform(two, m)
    np.clip(scaled, 0, 255, out=scaled)
    codes = scaled.astype(np.uint8)
    # channels 0-1 as one 16-bit word beside the still tile's channels 2-3 (little-endian
    # uint32 per texel: a strided byte copy would cost more than the FFT)
    words = still.view(np.uint32)[..., 0] & np.uint32(0xFFFF0000)
    words[:n, :n] |= codes.view(np.uint16)[..., 0]
    words[n, :] = words[0, :]
    words[:, n] = words[:, 0]
    return words.view(np.uint8).reshape(n + 1, n + 1, 4)


#: a level's tiles are evolved at multiples of this fraction of the period of its shortest
#: wave (phase error at most 1/64 of a cycle): slow long waves are reused across frames
TIME_STEP_PERIODS = 1.0 / 32.0


def level_time(level: int, t: float) -> float:
    """The time (seconds) level ``level``'s tile is evolved to for a frame at ``t``: ``t``
    rounded down to a multiple of :data:`TIME_STEP_PERIODS` periods of the level's
    shortest wave (wavelength ``BAND0 2**level``)."""
    k = 2 * math.pi / (BAND0 * 2.0 ** level)
    step = TIME_STEP_PERIODS * 2 * math.pi / float(omega(np.array([k]))[0])
    return math.floor(float(t) / step) * step


_TILES: dict[tuple, np.ndarray] = {}  # (base id, set, level, time, sign) -> tile, LRU
_TILES_SIZE = 24


def tile_at(base: WaterTextures, s: int, level: int, t: float, downwind: float
            ) -> np.ndarray:
    """:func:`evolved_tile` at :func:`level_time` (kept among the last ``_TILES_SIZE``
    tiles of this process, so consecutive frames share the slow levels' tiles)."""
    key = (id(base), s, level, level_time(level, t), 1.0 if downwind >= 0 else -1.0)
    with _LOCK:
        tile = _TILES.pop(key, None)
    if tile is None:
        tile = evolved_tile(base, s, level, key[3], downwind)
    with _LOCK:
        _TILES[key] = tile
        while len(_TILES) > _TILES_SIZE:
            del _TILES[next(iter(_TILES))]
    return tile


class AnimatedTextures:
    """The tiles of ``base`` at ``time`` seconds with the wind blowing towards ``downwind``
    (+1 / -1) along each set's wind axis: the interface the renderer reads from
    :class:`WaterTextures` (``ensure``, ``coarse_level``, ``level_sd``, ``level_share``,
    ``clouds``, ``noise``, ``seed``); level tiles evolved on first use and kept by
    :func:`tile_at`."""

    def __init__(self, base: WaterTextures, time: float, downwind: float = 1.0):
        self.base = base
        self.time = float(time)
        self.downwind = 1.0 if downwind >= 0 else -1.0

    @property
    def seed(self) -> int:
        return self.base.seed

    @property
    def clouds(self):
        return self.base.clouds

    @property
    def noise(self) -> np.ndarray:
        return self.base.noise

    @property
    def level_sd(self) -> list:
        """The still tiles' code scales (the same in every frame)."""
        return self.base.level_sd

    def level_share(self, s: int, level: int) -> np.ndarray:
        return self.base.level_share(s, level)

    def ensure(self, s: int, level: int) -> np.ndarray:
        """(N + 1, N + 1, 4) uint8 level tile ``level`` of set ``s`` at this time (from the
        process's cache of evolved tiles, :func:`tile_at`)."""
        return tile_at(self.base, s, level, self.time, self.downwind)

    def coarse_level(self, level: int) -> np.ndarray:
        """(N + 1, N + 1, 2) uint8 slope codes of set 0's level tile at this time."""
        return self.ensure(0, level)[..., :2]


_CACHE: list[AnimatedTextures] = []
_CACHE_SIZE = 2


def textures_for(params: WaterParams, base: WaterTextures, downwind: float = 1.0):
    """The tiles to draw ``params`` with: ``base`` when ``params.time`` is None, else the
    :class:`AnimatedTextures` of (base, time, downwind sign), reused while it is among the
    last ``_CACHE_SIZE`` asked for (a video's frame builds its tiles once)."""
    if params.time is None or isinstance(base, AnimatedTextures):
        return base
    t, sign = float(params.time), (1.0 if downwind >= 0 else -1.0)
    with _LOCK:
        for i, a in enumerate(_CACHE):
            if a.base is base and a.time == t and a.downwind == sign:
                _CACHE.insert(0, _CACHE.pop(i))
                return a
        a = AnimatedTextures(base, t, sign)
        _CACHE.insert(0, a)
        del _CACHE[_CACHE_SIZE:]
        return a
