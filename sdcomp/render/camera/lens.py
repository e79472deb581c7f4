"""The lens: radial distortion, lateral chromatic aberration and vignetting, one cached
geometry per lens for the image, its instance maps and amodal masks (applied by
:mod:`~sdcomp.render.camera.remap`).

The camera's stages are pure functions of arrays and plain parameters.

Conventions: images are (H, W, 3) uint8 RGB; instance maps (H, W) uint16; pixel index
coordinates have pixel centres at integers, so the principal point (image centre) is
``((W - 1) / 2, (H - 1) / 2)``. Lens parameters use normalised image coordinates
``x = (u - cx) / fx``. Linear values are relative to the renderer's full scale (sRGB level
255 = 1.0). Lengths that a stage takes in output pixels are converted from native pixels by
the caller (:mod:`sdcomp.render.camera.pipeline`) with the scale rules in this module
(:func:`scaled_blur`, :func:`scaled_sharpen`, :func:`scaled_noise`).

No function here draws random numbers: noise comes from windows of a pre-drawn tile
(:func:`make_noise_tile`, :func:`noise_window`).
"""

from __future__ import annotations

import functools
import math
from collections import OrderedDict
from dataclasses import dataclass, replace

import cv2
import numpy as np

from ...util.colour import srgb_to_linear

MAP_GRID = 8  # frames wider than MAP_GRID_MIN get their remap maps from a grid this coarse
MAP_GRID_MIN = 640
MAP_CACHE_BYTES = 256 << 20  # the lens map cache keeps at most about this many bytes
ZOOM_CACHE = 4096  # lenses whose zoom is remembered (lens_zoom)
STREAM_PIXELS = 1 << 22  # larger frames keep the grid only (smaller: from a lens's second use)
# flat (log) profile: LOG_BLACK + (1 - LOG_BLACK) log(1 + LOG_K x) / log(1 + LOG_K LOG_MAX):
# lifted black, 18 % grey at 0.45, the renderer's white at 0.75, 2 stops of headroom

VIGNETTE_POWER = 1 / 2.2  # sRGB level gain of a linear gain g is about g ** VIGNETTE_POWER


LEVEL_LINEAR = srgb_to_linear(np.arange(256) / 255.0)  # (256,) linear value of each level


def distort(xy: np.ndarray, k1: float, k2: float) -> np.ndarray:
    """Brown-Conrady radial distortion (OpenCV's k1, k2; no tangential terms): undistorted
    normalised points (..., 2) -> distorted ``x (1 + k1 r^2 + k2 r^4)`` (float64)."""
    xy = np.asarray(xy, np.float64)
    r2 = np.sum(xy * xy, axis=-1, keepdims=True)
    return xy * (1.0 + k1 * r2 + k2 * r2 * r2)


def undistort_radius(rd, k1: float, k2: float, iterations: int = 8):
    """The undistorted radius ``ru`` with ``ru (1 + k1 ru^2 + k2 ru^4) = rd`` (Newton from
    ``ru = rd``; float64, same shape). Valid while the model is monotonic in r (true for
    the small coefficients of the presets within the frame)."""
    rd = np.asarray(rd, np.float64)
    ru = rd.copy()
    for _ in range(iterations):
        r2 = ru * ru
        f = ru * (1 + k1 * r2 + k2 * r2 * r2) - rd
        df = 1 + 3 * k1 * r2 + 5 * k2 * r2 * r2
        ru = ru - f / df
    return ru


def undistort(xy: np.ndarray, k1: float, k2: float) -> np.ndarray:
    """Inverse of :func:`distort`: distorted normalised points (..., 2) -> undistorted."""
    xy = np.asarray(xy, np.float64)
    rd = np.sqrt(np.sum(xy * xy, axis=-1, keepdims=True))
    ru = undistort_radius(rd, k1, k2)
    return xy * np.where(rd > 0, ru / np.maximum(rd, 1e-300), 1.0)


def _source(x, y, w, h, fx, fy, k1, k2, zoom, ca):
    """Source pixel coordinates in the rendered (pinhole) image of output pixels (x, y)
    (float64 arrays, index coordinates) for a channel magnified by ``1 + ca`` (a number,
    or an array of one per point)."""
    cx, cy = (w - 1) / 2, (h - 1) / 2
    xd = (x - cx) / (zoom * fx * (1 + ca))
    yd = (y - cy) / (zoom * fy * (1 + ca))
    rd = np.sqrt(xd * xd + yd * yd)
    g = np.where(rd > 0, undistort_radius(rd, k1, k2) / np.maximum(rd, 1e-300), 1.0)
    return cx + fx * xd * g, cy + fy * yd * g


@functools.lru_cache(maxsize=ZOOM_CACHE)
def lens_zoom(w: int, h: int, fx: float, fy: float, k1: float, k2: float,
              cas: tuple[float, ...] = (0.0,)) -> float:
    """The zoom z (output focal = z x rendered focal) at which every output pixel of every
    channel (magnifications ``1 + ca`` for ca in ``cas``) samples inside the rendered
    frame, [0, W-1] x [0, H-1], as tightly as possible (``getOptimalNewCameraMatrix``
    with alpha = 0): > 1 for barrel distortion. Bisection over the frame's border (15-20
    ms), remembered for :data:`ZOOM_CACHE` lenses (longer than their grids are)."""
    n = 257
    t = np.linspace(0.0, 1.0, n)
    bx = np.concatenate([t * (w - 1), t * (w - 1), np.zeros(n), np.full(n, w - 1.0)])
    by = np.concatenate([np.zeros(n), np.full(n, h - 1.0), t * (h - 1), t * (h - 1)])

    # every channel's border in one evaluation (element-wise: the same numbers as one
    # channel at a time), the channels' magnifications as per-point factors
    k = len(cas)
    bx, by = np.tile(bx, k), np.tile(by, k)
    mag = np.repeat(np.asarray(cas, np.float64), 4 * n)

    def inside(z):
        sx, sy = _source(bx, by, w, h, fx, fy, k1, k2, z, mag)
        return not (sx.min() < -1e-9 or sy.min() < -1e-9 or sx.max() > w - 1 + 1e-9 or (
            sy.max() > h - 1 + 1e-9))

    lo, hi = 0.25, 4.0
    for _ in range(50):
        mid = math.sqrt(lo * hi)
        if inside(mid):
            hi = mid
        else:
            lo = mid
    return hi


@dataclass(frozen=True)
class LensGrid:
    """The lens geometry of one output frame sampled every ``step`` px (``step`` 1: every
    pixel): point (i, j) of a grid lies at output pixel ``((j - 0.5) step - 0.5, (i - 0.5)
    step - 0.5)`` (one point outside the frame on each side), so bilinear magnification by
    ``step`` gives every pixel (:meth:`window`; the maps are smooth: error < 0.001 px).

    ``src``: per channel (1: all alike, or 3: R, G, B with lateral CA) the (gh, gw) float32
    source x and y in the rendered image (:meth:`source` clips them to it); ``r2``: (gh, gw)
    float32 squared undistorted normalised radius (tan^2 of the field angle) of the green
    rays."""

    w: int
    h: int
    step: int
    src: tuple[tuple[np.ndarray, np.ndarray], ...]
    r2: np.ndarray

    def window(self, grid: np.ndarray, x0: int, y0: int, x1: int, y1: int) -> np.ndarray:
        """(y1 - y0, x1 - x0) float32: ``grid`` (one of this lens's grids) at every output
        pixel of the window, by bilinear magnification of the grid points around it (the
        same values as magnifying the whole grid)."""
        s = self.step
        if s == 1:
            return grid[y0:y1, x0:x1]
        # magnified pixel X of a sub-grid starting at point g0 lies at frame pixel
        # X + (g0 - 1) s; sampling it needs points floor((x + s + 0.5) / s - 0.5) and the next
        gy0, gx0 = max((y0 + s) // s - 1, 0), max((x0 + s) // s - 1, 0)
        gy1 = min((y1 - 1 + s) // s + 3, grid.shape[0])
        gx1 = min((x1 - 1 + s) // s + 3, grid.shape[1])
        sub = grid[gy0:gy1, gx0:gx1]
        up = cv2.resize(sub, (sub.shape[1] * s, sub.shape[0] * s),
                        interpolation=cv2.INTER_LINEAR)
        oy, ox = y0 + s - gy0 * s, x0 + s - gx0 * s
        return up[oy:oy + y1 - y0, ox:ox + x1 - x0]

    def full(self, grid: np.ndarray) -> np.ndarray:
        """(H, W) float32: ``grid`` at every output pixel."""
        return np.ascontiguousarray(self.window(grid, 0, 0, self.w, self.h))

    def points(self, channel: int, x0: int, y0: int, x1: int, y1: int
               ) -> tuple[np.ndarray, np.ndarray]:
        """(x, y) (y1 - y0, x1 - x0) float32 source points of the output window [y0:y1,
        x0:x1] for ``channel`` (an index into ``src``). They lie in the rendered frame to
        within the grid's interpolation error (:func:`lens_zoom` keeps every channel's
        border inside; 0.002 px measured) and are not clipped: the remaps replicate the
        border, so a point past an edge samples the edge as its clipped twin would (the
        same bytes; clipping cost 2 full-frame passes per channel)."""
        mx, my = self.src[channel]
        return self.window(mx, x0, y0, x1, y1), self.window(my, x0, y0, x1, y1)

    def source(self, channel: int, x0: int, y0: int, x1: int, y1: int
               ) -> tuple[np.ndarray, np.ndarray]:
        """OpenCV fixed-point maps (CV_16SC2, CV_16UC1) of the output window's
        :meth:`points` for ``channel``, resolved to 1/32 px."""
        return cv2.convertMaps(*self.points(channel, x0, y0, x1, y1), cv2.CV_16SC2)

    def nearest(self, x0: int, y0: int, x1: int, y1: int) -> np.ndarray:
        """(y1 - y0, x1 - x0, 2) int16 map of the output window to the rendered pixels
        nearest to its green source points."""
        sx, sy = self.points(len(self.src) // 2, x0, y0, x1, y1)
        return cv2.convertMaps(sx, sy, cv2.CV_16SC2, nninterpolation=True)[0]


@dataclass(frozen=True)
class LensMaps:
    """Cached geometry of one (size, lens) combination.

    ``grid``: the :class:`LensGrid` everything else is made from; ``zoom``: see
    :func:`lens_zoom`; ``max_shift``: the largest distance (px) between an output pixel and
    its source. A lens may also carry full-frame maps (None without: the remaps then make
    them band by band, :mod:`sdcomp.render.camera.remap`; see :func:`lens_maps`):
    ``maps``, per channel a pair of OpenCV fixed-point maps (CV_16SC2, CV_16UC1) for
    bilinear remapping; ``nearest``, an (H, W, 2) int16 map (rounded, green geometry) for
    labels; ``field_r2``, the grid's ``r2`` at every pixel (H, W) float32."""

    grid: LensGrid
    zoom: float
    max_shift: float
    lens: tuple  # (w, h, fx, fy, k1, k2): the arguments of lens_maps (without CA)
    maps: tuple | None = None
    nearest: np.ndarray | None = None
    field_r2: np.ndarray | None = None

    @property
    def streamed(self) -> bool:
        """True when the remaps build their maps band by band from the grid."""
        return self.maps is None

    def forward(self, src: np.ndarray) -> np.ndarray:
        """Output pixel coordinates (..., 2) float64 of rendered-image points ``src``
        (..., 2) (index coordinates; green channel): the inverse of the maps."""
        w, h, fx, fy, k1, k2 = self.lens
        c = np.array([(w - 1) / 2, (h - 1) / 2])
        f = np.array([fx, fy])
        return c + self.zoom * f * distort((np.asarray(src, np.float64) - c) / f, k1, k2)

    @property
    def nbytes(self) -> int:
        full = 0 if self.maps is None else sum(m.nbytes for pair in self.maps for m in pair)
        for a in (self.nearest, self.field_r2, self.grid.r2,
                  *(g for pair in self.grid.src for g in pair)):
            full += 0 if a is None else a.nbytes
        return full


_MAP_CACHE: OrderedDict = OrderedDict()


def lens_maps(w: int, h: int, fx: float, fy: float, k1: float, k2: float,
              ca_red: float = 0.0, ca_blue: float = 0.0, *, full: bool | None = None
              ) -> LensMaps:
    """The lens geometry of output size ``w`` x ``h`` for a rendered image of focal lengths
    ``fx``, ``fy`` (px) seen through a lens with radial distortion ``k1``, ``k2`` and lateral
    CA (red and blue images scaled by ``1 + ca_red``, ``1 + ca_blue`` about the centre),
    zoomed by :func:`lens_zoom`; with full maps, LRU-cached per arguments (the look quantises
    them) up to :data:`MAP_CACHE_BYTES`. Output pixel p of channel c samples the rendered
    image at ``c0 + f x_u`` with ``x_u = undistort((p - c0) / (zoom f (1 + ca_c)))``.
    Frames wider than :data:`MAP_GRID_MIN` compute this on a grid every :data:`MAP_GRID` px
    (:class:`LensGrid`); OpenCV's fixed-point maps then resolve 1/32 px.

    ``full``: full-frame maps (True), the grid only (False: the remaps build their maps
    band by band, the same pixels) or (None) full maps for a lens that comes back soon
    (:func:`_comes_back`) on a frame of at most :data:`STREAM_PIXELS`: 1080p full maps made
    for one image cost more than they save (55 MB of new memory), a lens that comes back (a
    fixed look, a video) remaps a third faster with them."""
    key = (w, h, round(fx, 6), round(fy, 6), k1, k2, ca_red, ca_blue)
    hit = _recall(_MAP_CACHE, key)
    if hit is not None:
        return hit
    out = _lens_grid(key)
    if full is None:  # a full lens's nbytes: its grid's, then 6 bytes a pixel per channel's
        # maps, 8 for the nearest map and the field
        full_bytes = out.nbytes + w * h * (6 * len(out.grid.src) + 8)
        full = _comes_back(key, full_bytes) and w * h <= STREAM_PIXELS
    if not full:
        return out
    grid = out.grid
    maps, green = [], len(grid.src) // 2
    for c in range(len(grid.src)):  # the green points make the nearest map too
        points = grid.points(c, 0, 0, w, h)
        maps.append(cv2.convertMaps(*points, cv2.CV_16SC2))
        if c == green:
            nearest = cv2.convertMaps(*points, cv2.CV_16SC2, nninterpolation=True)[0]
    out = replace(out, maps=tuple(maps), nearest=nearest, field_r2=grid.full(grid.r2))
    return _remember(_MAP_CACHE, key, out, MAP_CACHE_BYTES)


_RECENT: OrderedDict = OrderedDict()  # lenses asked for lately, least recent first


def _comes_back(key: tuple, full_bytes: int) -> bool:
    """Whether lens ``key`` (of :func:`lens_maps`) was asked for among the last N lenses, N
    how many of its full lenses (``full_bytes`` each) :data:`MAP_CACHE_BYTES` holds (a
    fixed lens: every time; one of the looks' ~96 lenses at 1080p, N = 5: rarely)."""
    seen = key in _RECENT
    _RECENT[key] = None
    _RECENT.move_to_end(key)
    while len(_RECENT) > max(1, MAP_CACHE_BYTES // full_bytes):
        _RECENT.popitem(last=False)
    return seen


def _recall(cache: OrderedDict, key: tuple) -> LensMaps | None:
    """The lens kept in the LRU ``cache`` under ``key`` (now its most recent), or None."""
    hit = cache.get(key)
    if hit is not None:
        cache.move_to_end(key)
    return hit


def _remember(cache: OrderedDict, key: tuple, lens: LensMaps, limit: int) -> LensMaps:
    """Keep ``lens`` in the LRU ``cache`` under ``key``, dropping the least recently used
    lenses while the cache holds more than ``limit`` bytes (never the last one); ``lens``."""
    cache[key] = lens
    total = sum(v.nbytes for v in cache.values())
    while total > limit and len(cache) > 1:
        total -= cache.popitem(last=False)[1].nbytes
    return lens


_GRID_CACHE: OrderedDict = OrderedDict()
GRID_CACHE_BYTES = 64 << 20  # lens grids kept up to this (a 1920 x 1080 frame's: 1 MB)


def _lens_grid(key: tuple) -> LensMaps:
    """The streamed :class:`LensMaps` (grid, zoom, largest shift; no full-frame maps) of a
    :func:`lens_maps` key. Cached apart from the full maps (an LRU
    up to :data:`GRID_CACHE_BYTES`): a frame whose full maps fell out of their cache
    rebuilds those only (the zoom's bisection alone takes 20 ms at 1920 x 1080)."""
    hit = _recall(_GRID_CACHE, key)
    if hit is not None:
        return hit
    w, h, fx, fy, k1, k2, ca_red, ca_blue = key
    cas = (ca_red, 0.0, ca_blue) if (ca_red or ca_blue) else (0.0,)
    zoom = lens_zoom(w, h, fx, fy, k1, k2, cas)
    step = MAP_GRID if max(w, h) > MAP_GRID_MIN else 1
    if step == 1:
        gx, gy = np.meshgrid(np.arange(w, dtype=np.float64), np.arange(h, dtype=np.float64))
    else:
        nx, ny = math.ceil(w / step) + 2, math.ceil(h / step) + 2
        gx, gy = np.meshgrid((np.arange(nx) - 0.5) * step - 0.5,
                             (np.arange(ny) - 0.5) * step - 0.5)
    src = []
    for ca in cas:
        sx, sy = _source(gx, gy, w, h, fx, fy, k1, k2, zoom, ca)
        src.append((sx.astype(np.float32), sy.astype(np.float32)))
        if ca == 0.0:
            green = (sx, sy)
    sx, sy = green
    cx, cy = (w - 1) / 2, (h - 1) / 2
    r2 = (((sx - cx) / fx) ** 2 + ((sy - cy) / fy) ** 2).astype(np.float32)
    shift = float(np.sqrt((sx - gx) ** 2 + (sy - gy) ** 2).max())
    grid = LensGrid(w, h, step, tuple(src), r2)
    return _remember(_GRID_CACHE, key, LensMaps(grid, zoom, shift, (w, h, fx, fy, k1, k2)),
                     GRID_CACHE_BYTES)


def clear_caches() -> None:
    """Forget every cached lens: full maps, grids, zooms and vignetting fall-offs."""
    lens_zoom.cache_clear()
    _RECENT.clear()
    _MAP_CACHE.clear()
    _GRID_CACHE.clear()
    _FALLOFF_CACHE.clear()


def vignette_gain(field_r2: np.ndarray, strength: float) -> np.ndarray:
    """Linear vignetting gain ``1 - s (1 - cos^4 theta)`` with ``cos^2 theta = 1 / (1 +
    tan^2 theta)``; ``field_r2`` = tan^2 theta (float32, any shape). Same shape, float32."""
    cos4 = 1.0 / np.square(1.0 + field_r2)
    return (1.0 - strength * (1.0 - cos4)).astype(np.float32)


_FALLOFF_CACHE: OrderedDict = OrderedDict()


def falloff(field_r2: np.ndarray) -> np.ndarray:
    """(h, w, 3) uint8: ``255 (1 - cos^4 theta)`` of the field angles of ``field_r2`` ((h, w)
    float32 tan^2 theta), the vignetting's fall-off quantised to 256 steps (a fall-off of
    at most ~0.8 at the corners of the widest presets: steps of 0.004 in the linear
    gain)."""
    cos4 = 1.0 / np.square(1.0 + field_r2)
    idx = np.clip(np.rint(255.0 * (1.0 - cos4)), 0, 255).astype(np.uint8)
    return cv2.merge([idx, idx, idx])


def falloff_index(lens: LensMaps) -> np.ndarray:
    """(H, W, 3) uint8 :func:`falloff` of every output pixel of a lens that is not
    streamed. Cached per lens (8 entries): a look's strength then costs one 256-entry
    table (:func:`vignette_map`)."""
    assert lens.field_r2 is not None, "a streamed lens has no full-frame field"
    hit = _FALLOFF_CACHE.get(id(lens))
    if hit is not None and hit[0] is lens:
        return hit[1]
    out = falloff(lens.field_r2)
    _FALLOFF_CACHE[id(lens)] = (lens, out)
    while len(_FALLOFF_CACHE) > 8:
        _FALLOFF_CACHE.popitem(last=False)
    return out


def vignette_table(strength: float) -> np.ndarray:
    """(256,) uint8 gain on sRGB levels per quantised fall-off (:func:`falloff`):
    ``255 g^(1/2.2)`` of the linear gain g of :func:`vignette_gain` (multiplying sRGB levels
    by ``g^(1/2.2)`` scales the linear value by g to within the sRGB curve's departure from
    a 2.2 power)."""
    x = np.arange(256, dtype=np.float64) / 255.0
    g = np.maximum(1.0 - strength * x, 0.0) ** VIGNETTE_POWER
    return np.clip(np.rint(255.0 * g), 0, 255).astype(np.uint8)


def vignette_map(lens: LensMaps, strength: float) -> np.ndarray:
    """(H, W, 3) uint8 gain map on sRGB levels (:func:`vignette_table` of the lens's
    :func:`falloff_index`); for lenses that are not streamed."""
    return cv2.LUT(falloff_index(lens), vignette_table(strength))


SIGMA_121 = math.sqrt(1 / (2 * math.log(2)))  # a 3-tap Gaussian of this sigma is [1, 2, 1] / 4
