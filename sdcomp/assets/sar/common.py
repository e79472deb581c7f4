"""What the search-and-rescue meshes share besides geometry: seeded variant randomness and
circle resolutions.

Variant parameters are drawn from a NumPy PCG64 generator seeded by (CRC-32 of the kind,
variant index): the same numbers on every run and platform (no Python ``hash()`` salt).
"""

from __future__ import annotations

import zlib
from collections.abc import Sequence

import numpy as np

from ..solids import RGB

SEG = 24  # circular segments for large round parts
SEG_S = 12  # ... for small ones
SEG_XS = 8  # ... for tiny ones (fingers of a few pixels at drone range)


def rng_for(kind: str, variant: int) -> np.random.Generator:
    """The generator of (``kind``, ``variant``): seeded by (CRC-32 of ``kind``, ``variant``)."""
    seed = np.random.SeedSequence([zlib.crc32(kind.encode("utf-8")), int(variant)])
    return np.random.Generator(np.random.PCG64(seed))


def jitter(rgb: Sequence[int], rng: np.random.Generator, amount: float = 0.06) -> RGB:
    """``rgb`` (sRGB 0-255) with each channel scaled by 1 +- ``amount`` (uniform), clipped."""
    scale = 1.0 + rng.uniform(-amount, amount, 3)
    r, g, b = (int(v) for v in np.clip(np.rint(np.asarray(rgb) * scale), 0, 255))
    return r, g, b


def pick(rng: np.random.Generator, options: Sequence):
    """One element of ``options``, uniformly."""
    return options[int(rng.integers(len(options)))]
