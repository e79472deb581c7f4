"""The lens: radial distortion, lateral chromatic aberration and vignetting, one cached
remap for the image and the same geometry for instance maps and amodal masks.

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

import math
from collections import OrderedDict
from dataclasses import dataclass

import cv2
import numpy as np

from ...util.colour import srgb_to_linear

MAP_GRID = 8  # frames wider than MAP_GRID_MIN get their remap maps from a grid this coarse
MAP_GRID_MIN = 640
MAP_CACHE_BYTES = 256 << 20  # the lens map cache keeps at most about this many bytes
LABEL_GAP = 16  # rows: label rows closer than this are remapped as one window
LABEL_RUNS_MAX = 8  # more runs of label rows than this: one full-frame label remap
# flat (log) profile: LOG_BLACK + (1 - LOG_BLACK) log(1 + LOG_K x) / log(1 + LOG_K LOG_MAX):
# lifted black, 18 % grey at 0.45, the renderer's white at 0.75, 2 stops of headroom

VIGNETTE_POWER = 1 / 2.2  # sRGB level gain of a linear gain g is about g ** VIGNETTE_POWER


# ============================================================================ encoding


LEVEL_LINEAR = srgb_to_linear(np.arange(256) / 255.0)  # (256,) linear value of each level


# ============================================================================ scale rules


# ============================================================================ lens


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
    (float64 arrays, index coordinates) for a channel magnified by ``1 + ca``."""
    cx, cy = (w - 1) / 2, (h - 1) / 2
    xd = (x - cx) / (zoom * fx * (1 + ca))
    yd = (y - cy) / (zoom * fy * (1 + ca))
    rd = np.sqrt(xd * xd + yd * yd)
    g = np.where(rd > 0, undistort_radius(rd, k1, k2) / np.maximum(rd, 1e-300), 1.0)
    return cx + fx * xd * g, cy + fy * yd * g


def lens_zoom(w: int, h: int, fx: float, fy: float, k1: float, k2: float,
              cas: tuple[float, ...] = (0.0,)) -> float:
    """The zoom z (output focal = z x rendered focal) at which every output pixel of every
    channel (magnifications ``1 + ca`` for ca in ``cas``) samples inside the rendered
    frame, [0, W-1] x [0, H-1], as tightly as possible (``getOptimalNewCameraMatrix``
    with alpha = 0): > 1 for barrel distortion. Bisection over the frame's border."""
    n = 257
    t = np.linspace(0.0, 1.0, n)
    bx = np.concatenate([t * (w - 1), t * (w - 1), np.zeros(n), np.full(n, w - 1.0)])
    by = np.concatenate([np.zeros(n), np.full(n, h - 1.0), t * (h - 1), t * (h - 1)])

    def inside(z):
        for ca in cas:
            sx, sy = _source(bx, by, w, h, fx, fy, k1, k2, z, ca)
            if sx.min() < -1e-9 or sy.min() < -1e-9 or sx.max() > w - 1 + 1e-9 or (
                    sy.max() > h - 1 + 1e-9):
                return False
        return True

    lo, hi = 0.25, 4.0
    for _ in range(50):
        mid = math.sqrt(lo * hi)
        if inside(mid):
            hi = mid
        else:
            lo = mid
    return hi


@dataclass(frozen=True)
class LensMaps:
    """Cached geometry of one (size, lens) combination.

    ``maps``: per channel (1 entry: all channels alike, or 3: R, G, B with lateral CA) a
    pair of OpenCV fixed-point maps (CV_16SC2, CV_16UC1) for bilinear remapping; ``nearest``:
    (H, W, 2) int16 map (rounded, green geometry) for labels; ``zoom``: see
    :func:`lens_zoom`; ``field_r2``: (H, W) float32 squared undistorted normalised radius
    of each output pixel's ray (tan^2 of the field angle; for vignetting);
    ``max_shift``: the largest distance (px) between an output pixel and its source."""

    maps: tuple
    nearest: np.ndarray
    zoom: float
    field_r2: np.ndarray
    max_shift: float
    lens: tuple  # (w, h, fx, fy, k1, k2): the arguments of lens_maps (without CA)

    def forward(self, src: np.ndarray) -> np.ndarray:
        """Output pixel coordinates (..., 2) float64 of rendered-image points ``src``
        (..., 2) (index coordinates; green channel): the inverse of the maps."""
        w, h, fx, fy, k1, k2 = self.lens
        c = np.array([(w - 1) / 2, (h - 1) / 2])
        f = np.array([fx, fy])
        return c + self.zoom * f * distort((np.asarray(src, np.float64) - c) / f, k1, k2)

    @property
    def nbytes(self) -> int:
        return sum(m.nbytes for pair in self.maps for m in pair) + self.nearest.nbytes + (
            self.field_r2.nbytes)


_MAP_CACHE: OrderedDict = OrderedDict()


def lens_maps(w: int, h: int, fx: float, fy: float, k1: float, k2: float,
              ca_red: float = 0.0, ca_blue: float = 0.0) -> LensMaps:
    """The remap maps of output size ``w`` x ``h`` for a rendered image of focal lengths
    ``fx``, ``fy`` (px) seen through a lens with radial distortion ``k1``, ``k2`` and lateral
    CA (red and blue images scaled by ``1 + ca_red``, ``1 + ca_blue`` about the centre),
    zoomed by :func:`lens_zoom`. LRU-cached per arguments (the look quantises them) up to
    :data:`MAP_CACHE_BYTES`.

    Output pixel p of channel c samples the rendered image at
    ``c0 + f x_u`` with ``x_u = undistort((p - c0) / (zoom f (1 + ca_c)))``. Frames wider than
    :data:`MAP_GRID_MIN` compute this on a grid every :data:`MAP_GRID` px and interpolate
    bilinearly (the maps are smooth: error < 0.001 px); OpenCV's fixed-point maps then
    resolve 1/32 px.
    """
    key = (w, h, round(fx, 6), round(fy, 6), k1, k2, ca_red, ca_blue)
    hit = _MAP_CACHE.get(key)
    if hit is not None:
        _MAP_CACHE.move_to_end(key)
        return hit
    cas = (ca_red, 0.0, ca_blue) if (ca_red or ca_blue) else (0.0,)
    zoom = lens_zoom(w, h, fx, fy, k1, k2, cas)
    step = MAP_GRID if max(w, h) > MAP_GRID_MIN else 1
    if step == 1:
        gx, gy = np.meshgrid(np.arange(w, dtype=np.float64), np.arange(h, dtype=np.float64))
    else:
        # grid points at (i + 0.5) step - 0.5, one extra on each side: cv2.resize by `step`
        # then puts grid point i at pixel (i + 0.5) step - 0.5 exactly (see _upsample)
        nx, ny = math.ceil(w / step) + 2, math.ceil(h / step) + 2
        gx, gy = np.meshgrid((np.arange(nx) - 0.5) * step - 0.5,
                             (np.arange(ny) - 0.5) * step - 0.5)

    def full(a):
        a = a.astype(np.float32)
        return a if step == 1 else _upsample(a, step, w, h)

    def clip(a, hi):
        return np.clip(a, 0, hi, out=a)

    maps = []
    for ca in cas:
        sx, sy = _source(gx, gy, w, h, fx, fy, k1, k2, zoom, ca)
        mx = clip(full(sx), w - 1)
        my = clip(full(sy), h - 1)
        maps.append(cv2.convertMaps(mx, my, cv2.CV_16SC2))
        if ca == 0.0:
            green = (mx, my, sx, sy)
    mx, my, sx, sy = green
    nearest, _ = cv2.convertMaps(mx, my, cv2.CV_16SC2, nninterpolation=True)
    cx, cy = (w - 1) / 2, (h - 1) / 2
    # on the grid (exact at its points; the smooth field in between)
    r2 = full(((sx - cx) / fx) ** 2 + ((sy - cy) / fy) ** 2)
    shift = float(np.sqrt((sx - gx) ** 2 + (sy - gy) ** 2).max())
    out = LensMaps(tuple(maps), nearest, zoom, r2.astype(np.float32), shift,
                   (w, h, fx, fy, k1, k2))
    _MAP_CACHE[key] = out
    total = sum(v.nbytes for v in _MAP_CACHE.values())
    while total > MAP_CACHE_BYTES and len(_MAP_CACHE) > 1:
        _, old = _MAP_CACHE.popitem(last=False)
        total -= old.nbytes
    return out


def _upsample(grid: np.ndarray, step: int, w: int, h: int) -> np.ndarray:
    """Bilinear upsampling of a float32 grid whose point i lies at pixel
    ``(i - 0.5) step - 0.5`` (i = 0 is one step outside the frame) to (h, w)."""
    gh, gw = grid.shape
    up = cv2.resize(grid, (gw * step, gh * step), interpolation=cv2.INTER_LINEAR)
    # resized pixel X samples grid index (X + 0.5) / step - 0.5, i.e. frame pixel X - step
    return up[step:step + h, step:step + w]


def remap_image(image: np.ndarray, lens: LensMaps) -> np.ndarray:
    """(H, W, 3) uint8 image through the lens geometry (bilinear, one resampling per
    channel: a 3-channel remap, or 3 single-channel remaps with lateral CA)."""
    if len(lens.maps) == 1:
        m1, m2 = lens.maps[0]
        return cv2.remap(image, m1, m2, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
    planes = cv2.split(image)
    out = [cv2.remap(p, m1, m2, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
           for p, (m1, m2) in zip(planes, lens.maps, strict=True)]
    return cv2.merge(out)


def remap_labels(labels: np.ndarray, lens: LensMaps, window: bool = True) -> np.ndarray:
    """(H, W) or (H, W, C) uint8/uint16 label image through the lens geometry by nearest
    neighbour (the green channel's geometry; lateral CA is sub-pixel and ignored): every
    output pixel takes the label of the rendered pixel nearest to its source point, so ids
    are never mixed.

    With ``window`` only the output rectangles that can see labels are remapped: the rows
    holding labels are grouped into runs (gaps of more than :data:`LABEL_GAP` rows split
    them), each run's bounding box is carried to the output with :meth:`LensMaps.forward`
    on its border (2 px margin) and remapped alone. The result is the same (rectangles that
    overlap compute the same pixels); sparse labels, the usual case, cost a fraction."""
    h, w = labels.shape[:2]
    if not window:
        return cv2.remap(labels, lens.nearest, None,  # type: ignore[call-overload]
                         cv2.INTER_NEAREST, borderMode=cv2.BORDER_REPLICATE)
    flat: np.ndarray = labels if labels.ndim == 2 else np.any(labels, axis=2)
    rows = np.flatnonzero(flat.any(axis=1))
    out = np.zeros_like(labels)
    if rows.size == 0:
        return out
    breaks = np.flatnonzero(np.diff(rows) > LABEL_GAP)
    starts = np.concatenate([[rows[0]], rows[breaks + 1]])
    ends = np.concatenate([rows[breaks], [rows[-1]]])
    if len(starts) > LABEL_RUNS_MAX:
        return remap_labels(labels, lens, window=False)
    cx, cy = (w - 1) / 2, (h - 1) / 2
    for r0, r1 in zip(starts.tolist(), ends.tolist(), strict=True):
        cols = np.flatnonzero(flat[r0:r1 + 1].any(axis=0))
        x0, x1, y0, y1 = cols[0] - 1.0, cols[-1] + 1.0, r0 - 1.0, r1 + 1.0
        # a radial model moves an edge's points monotonically with their distance from the
        # centre: its extremes are the corners and the edge's point nearest the centre
        nx, ny = min(max(cx, x0), x1), min(max(cy, y0), y1)
        p = lens.forward(np.array([[x0, y0], [x1, y0], [x0, y1], [x1, y1],
                                   [nx, y0], [nx, y1], [x0, ny], [x1, ny]]))
        ox0, oy0 = int(p[:, 0].min()) - 2, int(p[:, 1].min()) - 2
        ox1, oy1 = int(p[:, 0].max()) + 3, int(p[:, 1].max()) + 3
        ox0, oy0, ox1, oy1 = max(ox0, 0), max(oy0, 0), min(ox1, w), min(oy1, h)
        if ox1 <= ox0 or oy1 <= oy0:
            continue
        win = out[oy0:oy1, ox0:ox1]
        win[...] = cv2.remap(labels, lens.nearest[oy0:oy1, ox0:ox1],  # type: ignore[call-overload]
                             None, cv2.INTER_NEAREST,
                             borderMode=cv2.BORDER_REPLICATE).reshape(win.shape)
    return out


def remap_masks(masks: np.ndarray, lens: LensMaps) -> np.ndarray:
    """(N, H, W) bool masks through :func:`remap_labels`, 16 per uint16 bit plane and up to
    4 planes per remap call (bits survive nearest-neighbour remapping exactly)."""
    n, h, w = masks.shape
    out = np.zeros_like(masks, dtype=bool)
    for start in range(0, n, 64):
        group = masks[start:start + 64]
        planes = math.ceil(len(group) / 16)
        packed = np.zeros((h, w, planes), np.uint16)
        for k, m in enumerate(group):
            packed[..., k // 16] |= m.astype(np.uint16) << np.uint16(k % 16)
        if planes == 3:  # OpenCV remaps 1, 2, 3 or 4 channels; keep to 1, 2 or 4
            packed = np.concatenate([packed, np.zeros((h, w, 1), np.uint16)], axis=2)
        moved = remap_labels(packed, lens).reshape(h, w, -1)
        for k in range(len(group)):
            out[start + k] = (moved[..., k // 16] >> np.uint16(k % 16)) & 1
    return out


def vignette_gain(field_r2: np.ndarray, strength: float) -> np.ndarray:
    """Linear vignetting gain ``1 - s (1 - cos^4 theta)`` with ``cos^2 theta = 1 / (1 +
    tan^2 theta)``; ``field_r2`` = tan^2 theta (float32, any shape). Same shape, float32."""
    cos4 = 1.0 / np.square(1.0 + field_r2)
    return (1.0 - strength * (1.0 - cos4)).astype(np.float32)


_FALLOFF_CACHE: OrderedDict = OrderedDict()


def falloff_index(lens: LensMaps) -> np.ndarray:
    """(H, W, 3) uint8: ``255 (1 - cos^4 theta)`` of each output pixel's field angle, the
    vignetting's fall-off quantised to 256 steps (a fall-off of at most ~0.8 at the corners
    of the widest presets: steps of 0.004 in the linear gain). Cached per lens (8 entries):
    a look's strength then costs one 256-entry table (:func:`vignette_map`)."""
    hit = _FALLOFF_CACHE.get(id(lens))
    if hit is not None and hit[0] is lens:
        return hit[1]
    cos4 = 1.0 / np.square(1.0 + lens.field_r2)
    idx = np.clip(np.rint(255.0 * (1.0 - cos4)), 0, 255).astype(np.uint8)
    out = np.repeat(idx[..., None], 3, axis=2)
    _FALLOFF_CACHE[id(lens)] = (lens, out)
    while len(_FALLOFF_CACHE) > 8:
        _FALLOFF_CACHE.popitem(last=False)
    return out


def vignette_map(lens: LensMaps, strength: float) -> np.ndarray:
    """(H, W, 3) uint8 gain map on sRGB levels: ``255 g^(1/2.2)`` of the linear gain g of
    :func:`vignette_gain` (multiplying sRGB levels by ``g^(1/2.2)`` scales the linear value
    by g to within the sRGB curve's departure from a 2.2 power), through a table of the
    quantised fall-off (:func:`falloff_index`)."""
    x = np.arange(256, dtype=np.float64) / 255.0
    g = np.maximum(1.0 - strength * x, 0.0) ** VIGNETTE_POWER
    table = np.clip(np.rint(255.0 * g), 0, 255).astype(np.uint8)
    return cv2.LUT(falloff_index(lens), table)


def apply_vignette(image: np.ndarray, gain_map: np.ndarray) -> np.ndarray:
    """(H, W, 3) uint8 image times a uint8 gain map / 255 (rounded)."""
    return cv2.multiply(image, gain_map, scale=1 / 255.0)


# ============================================================================ motion blur


# ============================================================================ photometric


# ============================================================================ noise


# ============================================================================ demosaicing


# ============================================================================ sharpening


# ============================================================================ compression


SIGMA_121 = math.sqrt(1 / (2 * math.log(2)))  # a 3-tap Gaussian of this sigma is [1, 2, 1] / 4

