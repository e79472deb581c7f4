"""Camera geometry for the water renderer: rays, the horizon, coarse grids, pixel footprints.

Conventions are those of :mod:`sdcomp.scene.camera`: world frame metres, z up, sea at z = 0,
camera above the origin; image columns ``u``
right, rows ``v`` down, pixel centres at integer + 0.5, principal point at the centre.

Coarse grids. The smooth terms are evaluated on a grid and upsampled in two steps: rows by
linear interpolation between grid rows at arbitrary positions (denser towards the horizon in
oblique views), then columns by ``cv2.resize`` from ``gw`` cell-centred columns (``u_k = (k +
0.5) W / gw``, exactly the sample positions cv2.resize assumes).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import cv2
import numpy as np

from .textures import N_LEVELS, pitch

GRID = 32  # pixels between coarse samples at 416 px (scaled with the frame, 16..64)
RESOLVE = 3.0  # the finest wave drawn per pixel spans at least this many pixel footprints
NADIR = 89.999  # pitch from which a view counts as straight down


def horizon_row(height: int, fy: float, pitch_deg: float) -> float:
    """Image row coordinate (continuous, 0 = top edge) of the horizon; -inf straight down."""
    if pitch_deg >= NADIR:
        return -math.inf
    return height / 2 - fy * math.tan(math.radians(pitch_deg))


def level_for(footprint) -> np.ndarray:
    """Level tile to draw per pixel for pixel footprints ``footprint`` metres: the finest
    level whose shortest wave (4 texels, ``4 pitch(level)``) spans at least RESOLVE
    footprints. int array; ``N_LEVELS`` means "coarser than every level" (no texture)."""
    fp = np.asarray(footprint, np.float64)
    need = RESOLVE * fp / 4.0  # minimum texel pitch
    lev = np.ceil(np.log2(np.maximum(need, 1e-9) / pitch(0)) - 1e-9)
    return np.clip(lev, 0, N_LEVELS).astype(np.int64)


def finest_drawn_wavelength(level) -> np.ndarray:
    """Shortest wavelength (m) a level tile holds: ``4 pitch(level)``."""
    return 4.0 * pitch(0) * 2.0 ** np.asarray(level, np.float64)


@dataclass(frozen=True, eq=False)
class Grid:
    """A cell-centred coarse grid over the image rows ``r0 .. r1`` (all columns): ``gh`` x
    ``gw`` samples at pixel coordinates ``u = (j + 0.5) W / gw``, ``v = r0 + (i + 0.5) (r1 -
    r0) / gh`` - exactly where ``cv2.resize`` of a (gh, gw) array to (r1 - r0, W) puts its
    samples. :meth:`upsample` does that; :meth:`upsample_box` draws a sub-box only."""

    r0: int
    r1: int
    width: int
    gh: int
    gw: int

    @property
    def u(self) -> np.ndarray:
        return (np.arange(self.gw) + 0.5) * (self.width / self.gw)

    @property
    def v(self) -> np.ndarray:
        return self.r0 + (np.arange(self.gh) + 0.5) * ((self.r1 - self.r0) / self.gh)

    def upsample(self, grid: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
        """(gh, gw[, C]) -> (r1 - r0, W[, C]) bilinear (edges held)."""
        return cv2.resize(grid, (self.width, self.r1 - self.r0), dst=out,
                          interpolation=cv2.INTER_LINEAR)

    def upsample_box(self, grid: np.ndarray, x0: int, y0: int, x1: int, y1: int
                     ) -> np.ndarray:
        """The same values as :meth:`upsample` over columns x0..x1 and rows y0..y1 (relative
        to r0) only, float32."""
        sx = self.gw / self.width
        sy = self.gh / (self.r1 - self.r0)
        m = np.array([[sx, 0.0, (x0 + 0.5) * sx - 0.5], [0.0, sy, (y0 + 0.5) * sy - 0.5]],
                     np.float32)
        return cv2.warpAffine(np.asarray(grid, np.float32), m, (x1 - x0, y1 - y0),
                              flags=cv2.INTER_LINEAR | cv2.WARP_INVERSE_MAP,
                              borderMode=cv2.BORDER_REPLICATE)

    def pixel_rows(self) -> np.ndarray:
        """(gh,) pixel row index (absolute) of each grid row."""
        return np.clip(np.floor(self.v).astype(np.int64), self.r0, self.r1 - 1)


@dataclass(frozen=True, eq=False)
class ViewPlan:
    """Everything about a view that depends on the camera model and the pitch only (the
    altitude scales distances; the heading rotates them). See :func:`view_plan`.

    Attributes:
        width, height, fx, fy, pitch: the view.
        nadir: straight down.
        horizon: horizon row coordinate (-inf straight down).
        sea_row0: first pixel row whose centre sees the sea (0 straight down).
        sea: :class:`Grid` of the sea rows; sea_rays: (gh, gw, 3) unit camera-frame rays.
        sky, sky_rays: the same above the horizon (None when the horizon is not in view).
        row_y: (H,) ``(v + 0.5 - H/2) / fy`` of each pixel row.
        col_x: (W,) ``(u + 0.5 - W/2) / fx`` of each column.
    """

    width: int
    height: int
    fx: float
    fy: float
    pitch: float
    nadir: bool
    horizon: float
    sea_row0: int
    sea: Grid | None
    sea_rays: np.ndarray | None
    sky: Grid | None
    sky_rays: np.ndarray | None
    row_y: np.ndarray
    col_x: np.ndarray

    def row_geometry(self, altitude: float) -> dict:
        """Per pixel row (H,) of the sea: ``t`` (ray parameter of the unnormalised camera
        ray ``(x, y, 1)`` to the sea, inf above the horizon), ``fwd`` (horizontal forward
        component of that ray), ``across`` and ``along`` (pixel footprints, metres)."""
        return row_geometry(self.row_y, self.fx, self.fy, self.pitch, altitude)


def row_geometry(y, fx, fy, pitch_deg, altitude) -> dict:
    p = math.radians(pitch_deg)
    y = np.asarray(y, np.float64)
    down = y * math.cos(p) + math.sin(p)  # minus the vertical component
    ok = down > 1e-9
    safe = np.where(ok, down, 1.0)
    t = np.where(ok, altitude / safe, np.inf)
    fwd = math.cos(p) - y * math.sin(p)
    across = t / fx
    along = np.where(ok, altitude / (fy * safe ** 2), np.inf)
    return {"t": t, "fwd": fwd, "across": across, "along": along, "ok": ok}


def _rays(grid: Grid, w: int, h: int, fx: float, fy: float) -> np.ndarray:
    uu, vv = np.meshgrid(grid.u, grid.v)
    d = np.stack([(uu - w / 2) / fx, (vv - h / 2) / fy, np.ones_like(uu)], -1)
    return d / np.linalg.norm(d, axis=-1, keepdims=True)


def grid_cell(width: int, height: int) -> int:
    """Coarse-grid cell (pixels) of a frame: GRID at 416 x 416, proportional to the frame's
    size, 16 to 64 (the coarse grid holds waves of 256 px and longer: 4 cells each)."""
    return int(min(64, max(16, round(GRID * math.sqrt(width * height) / 416.0))))


@lru_cache(maxsize=64)
def view_plan(width: int, height: int, fx: float, fy: float, pitch_deg: float,
              grid: int | None = None) -> ViewPlan:
    """The :class:`ViewPlan` of a view (cached): cells of ``grid`` px (default
    :func:`grid_cell`) over the sea rows (half as tall in oblique views: distances change
    fast towards the horizon) and over the sky rows."""
    w, h = int(width), int(height)
    grid = grid_cell(w, h) if grid is None else grid
    nadir = pitch_deg >= NADIR
    hz = horizon_row(h, fy, pitch_deg)
    gw = max(2, int(round(w / grid)))
    row_y = (np.arange(h) + 0.5 - h / 2) / fy
    col_x = (np.arange(w) + 0.5 - w / 2) / fx
    p = math.radians(pitch_deg)
    sees_sea = row_y * math.cos(p) + math.sin(p) > 1e-6
    sea_row0 = int(np.argmax(sees_sea)) if sees_sea.any() else h
    sea = sea_rays = sky = sky_rays = None
    if sea_row0 < h:
        step = grid if nadir else max(16, grid // 2)
        gh = max(2, int(round((h - sea_row0) / step)))
        sea = Grid(sea_row0, h, w, gh, gw)
        sea_rays = _rays(sea, w, h, fx, fy)
    if sea_row0 > 0:
        gh = max(2, int(round(sea_row0 / grid)))
        sky = Grid(0, sea_row0, w, gh, gw)
        sky_rays = _rays(sky, w, h, fx, fy)
    return ViewPlan(w, h, float(fx), float(fy), float(pitch_deg), nadir, hz, sea_row0, sea,
                    sea_rays, sky, sky_rays, row_y, col_x)
