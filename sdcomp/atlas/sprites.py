"""Atlas sprites ready for compositing: pose lookup and premultiplied mip levels.

A :class:`SpriteSource` wraps an :class:`~sdcomp.atlas.Atlas`. For pose ``p`` and mip level
``L`` it gives a (S >> L, S >> L, 8) float32 array of premultiplied channels

    alpha, alpha * albedo (linear RGB, 3), alpha * normal (camera frame, 3), alpha * height

(the albedo times the occlusion's diffuse factor, :func:`sdcomp.atlas.occlusion.diffuse_factor`:
the light a point in a cockpit or under a canopy does not get)

box-filtered from the atlas resolution, so that any level can be relit and then resampled
without dark fringes. Levels are made on first use and kept: the small ones (what a
416-pixel image needs) per source; the large ones (levels 0 and 1, for full-resolution
frames) in one cache shared by every source of the process, bounded in bytes
(:data:`LARGE_CACHE_BYTES`), so that a run of many meshes (the 60 search-and-rescue
variants) holds no more of them than a run of one.
"""

from __future__ import annotations

import itertools
from collections import OrderedDict
from typing import Any

import cv2
import numpy as np

from ..util.colour import srgb_to_linear
from .occlusion import diffuse_factor
from .poses import view_basis, view_direction
from .store import Atlas

LARGE_CACHE_BYTES = 96 * 2**20  #: bytes of levels 0 and 1 kept, all sources of a process
_large: OrderedDict[tuple, Any] = OrderedDict()  # (source token, pose, level[, "p"]): arrays
_large_bytes = [0]
_tokens = itertools.count()


def _nbytes(value: Any) -> int:
    return sum(a.nbytes for a in value) if isinstance(value, tuple) else int(value.nbytes)


def _large_get(key: tuple) -> Any:
    hit = _large.get(key)
    if hit is not None:
        _large.move_to_end(key)
    return hit


def _large_put(key: tuple, value: Any) -> None:
    _large[key] = value
    _large_bytes[0] += _nbytes(value)
    while _large_bytes[0] > LARGE_CACHE_BYTES and len(_large) > 1:
        _, old = _large.popitem(last=False)
        _large_bytes[0] -= _nbytes(old)


def mip_levels(size: int) -> int:
    """The finest-to-coarsest level count of ``size`` px sprites, minus one: levels halve
    exactly (level L is ``size >> L`` pixels, each of ``2**L`` atlas pixels) down to 2 px, so
    a size with an odd factor above 3 (a 144 px atlas: 9 px at level 4) stops there."""
    level = 0
    while size % (2 << level) == 0 and size >> (level + 1) >= 2:
        level += 1
    return level


class SpriteSource:
    """Sprites of one mesh, by pose and mip level (see the module docstring)."""

    def __init__(self, atlas: Atlas):
        self.atlas = atlas
        self.name = atlas.name
        self.metres_per_pixel = float(atlas.metres_per_pixel)
        self.size = atlas.size
        self.waterline = float(atlas.index.get("mesh", {}).get("waterline_m", 0.0))
        poses = atlas.poses
        self.directions = view_direction(poses[:, 0], poses[:, 1])  # (P, 3) body frame
        self.bases = np.stack([view_basis(o, a) for o, a in poses[:, :2]])  # (P, 3, 3)
        self.max_level = mip_levels(self.size)
        # (pose, level): level array; (pose, level, "p"): prepared arrays (levels >= 2; the
        # larger ones are in the shared cache under this source's token)
        self._small: dict[tuple, Any] = {}
        self._token = next(_tokens)
        self._lut = srgb_to_linear(np.arange(256, dtype=np.float32) / 255.0).astype(np.float32)

    def nearest(self, direction_body: np.ndarray) -> int:
        """Index of the stored pose whose view direction (object towards camera, body
        frame, unit (3,)) is nearest to ``direction_body``."""
        return int(np.argmax(self.directions @ direction_body))

    def level(self, pose: int, level: int) -> np.ndarray:
        """(S >> level, S >> level, 8) float32 premultiplied channels of ``pose``."""
        key = (pose, level)
        hit = self._small.get(key) if level >= 2 else _large_get((self._token, *key))
        if hit is not None:
            return hit
        if level == 0:
            out = self.base(pose)
        else:  # halve the next finer level (cached too): a box filter of a box filter
            n = self.size >> level
            out = cv2.resize(self.level(pose, level - 1), (n, n),
                             interpolation=cv2.INTER_AREA)
        out = np.ascontiguousarray(out, dtype=np.float32)
        self._store(key, out)
        return out

    def _store(self, key: tuple, value: Any) -> None:
        if key[1] >= 2:
            self._small[key] = value
        else:
            _large_put((self._token, *key), value)

    def prepared(self, pose: int, level: int) -> tuple:
        """(alpha (n, n), albedo linear (n, n, 3), unit normal (n, n, 3), height (n, n))
        float32 of a level, un-premultiplied, for relighting; cached with it."""
        key = (pose, level, "p")
        hit = self._small.get(key) if level >= 2 else _large_get((self._token, *key))
        if hit is not None:
            return hit
        data = self.level(pose, level)
        alpha = np.ascontiguousarray(data[..., 0])
        inv = np.where(alpha > 1e-6, 1.0 / np.maximum(alpha, 1e-6), 0.0).astype(np.float32)
        albedo = data[..., 1:4] * inv[..., None]
        normal = data[..., 4:7]
        length = np.sqrt(np.einsum("ijk,ijk->ij", normal, normal)) + 1e-6
        normal = (normal / length[..., None]).astype(np.float32)
        height = data[..., 7] * inv
        out = (alpha, albedo, normal, height)
        self._store(key, out)
        return out

    def cached(self) -> int:
        """How many small levels (2 and up) and their prepared arrays this source keeps:
        what :meth:`warm` prepares (the large ones come and go in the shared cache)."""
        return len(self._small)

    def warm(self) -> None:
        """Prepare every pose at every mip level from 2 on (what frames up to about a
        thousand pixels wide use; about 35 MB and 0.2 s for the BlueROV2 and the four kinds
        of clutter together): a process that forks workers calls it first, so they share
        these instead of each drawing them on first use."""
        for pose in range(len(self.directions)):
            for level in range(2, self.max_level + 1):
                self.prepared(pose, level)

    def base(self, pose: int) -> np.ndarray:
        """(S, S, 8) float32 premultiplied channels of ``pose`` at the atlas resolution."""
        alpha, albedo_srgb, normal, height = self.atlas.channels(pose)
        alpha = np.ascontiguousarray(alpha, dtype=np.float32)
        albedo = cv2.LUT(np.ascontiguousarray(albedo_srgb), self._lut)  # linear RGB
        albedo *= diffuse_factor(self.atlas.occlusion_of(pose))[..., None]
        out: np.ndarray = cv2.merge([alpha, albedo, np.ascontiguousarray(normal, np.float32),
                                     np.ascontiguousarray(height, np.float32)])
        np.multiply(out, alpha[..., None], out=out)
        out[..., 0] = alpha
        return out
