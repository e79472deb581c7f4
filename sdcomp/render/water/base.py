"""Constants and helpers shared by the water renderer's modules.

Glitter: a camera clips each sparkle on the sensor (the sun's image in a facet is far
brighter than white) before the frame is made smaller, so the glitter of a pixel is set by HOW
MANY sparkles it holds, not by the glint's energy: ``lam = SPARKLE_DENSITY x (the Cox-Munk
glint radiance, unexposed: irradiance units) x (facets per pixel / N_REF)``, at most the facets
per pixel, each sparkle adding ``SPARKLE_QUANTUM x N_REF / (facets per pixel)``, at most 1, of
white (N_REF: facets per pixel of a 416 px frame from 40 m).
"""

from __future__ import annotations

import math
import threading

import numpy as np

from .optics import fresnel

Z_SCALE = 16.0  # uint8 codes per standard deviation of the shaded texture variable
# the texture layers: (name, resolution divisor, level offset). Layer k draws level tile
# l + 2k (bands l + 2k, l + 2k + 1) at 1/4**k of the resolution; bands from l + 6 on are
# the coarse grid's long waves.
LAYERS = (("a", 1, 0), ("b", 4, 2), ("c", 16, 4))
SPARKLE_DENSITY = 400.0
SPARKLE_QUANTUM = 0.15
SUN_DISC = math.radians(0.53)  # angular diameter of the sun: a flat facet's sparkle
SPARKLE_BLUR = True  # spread each sparkle over the sun's disc (False: one pixel; tests)
REF_F416 = 314.3  # focal length (px) of the reference camera (Mavic 2 Pro) at 416 px
SLOPE_NU = 20.0  # unresolved slopes: bivariate Student-t (heavier tails than Gaussian)
GLINT_MIN = 2e-3  # the glitter region: where a pixel's glint may reach this (of white)
GLINT_LN0, GLINT_LN_STEP = -9.0, 0.25  # rows of the glint table: ln(lam) = -9 + row / 4
FACET = 0.04  # metres: size of the facets finer than a pixel (their number sets the grain)
LW_ANISO = 0.6  # water-leaving radiance grows as 1 + LW_ANISO (1 - cos) of the refracted angle
FOAM_ALBEDO = 0.55  # fresh whitecaps
METER_CLIP = 1.0  # metering: exposed radiance clips here (as a sensor's highlights)
R0 = float(fresnel(1.0))

_local = threading.local()
PROFILE: dict | None = None  # set to a dict to accumulate section times (thread CPU time)
_last = [0.0]


def tick(label: str | None = None) -> None:
    """Section timer for profiling (a no-op unless PROFILE is a dict)."""
    if PROFILE is None:
        return
    import time
    now = time.thread_time()
    if label is not None:
        PROFILE[label] = PROFILE.get(label, 0.0) + now - _last[0]
    _last[0] = now


def uniforms(seed: int, stream: int, n: int) -> list[float]:
    """``n`` uniform numbers in [0, 1) from (seed, stream): splitmix64 (a deterministic
    hash: ~1 us, where a numpy Generator costs ~30 us to make)."""
    out = []
    x = (int(seed) * 0x9E3779B97F4A7C15 + int(stream) * 0xD1B54A32D192ED03) & (2 ** 64 - 1)
    for _ in range(n):
        x = (x + 0x9E3779B97F4A7C15) & (2 ** 64 - 1)
        z = x
        z = ((z ^ (z >> 30)) * 0xBF58476D1CE4E5B9) & (2 ** 64 - 1)
        z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) & (2 ** 64 - 1)
        z ^= z >> 31
        out.append((z >> 11) / float(2 ** 53))
    return out


def scratch(name: str, shape: tuple, dtype=np.uint8) -> np.ndarray:
    """A scratch array of ``shape`` reused between calls of this thread (fresh arrays
    page-fault): one growing flat buffer per name and dtype, viewed in the shape asked."""
    cache = getattr(_local, "bufs", None)
    if cache is None:
        cache = _local.bufs = {}
    dt = np.dtype(dtype)
    n = math.prod(shape)
    key = (name, dt.str)
    a = cache.get(key)
    if a is None or a.size < n:
        a = cache[key] = np.empty(max(n, 1), dt)
    return a[:n].reshape(shape)


# --------------------------------------------------------------------------- public data


# --------------------------------------------------------------------------- waves


# --------------------------------------------------------------------------- helpers


def to_u8(a: np.ndarray) -> np.ndarray:
    return np.clip(a + 0.5, 0, 255).astype(np.uint8)


# --------------------------------------------------------------------------- main

