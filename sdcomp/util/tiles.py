"""Windows of periodic tiles (noise and wave textures repeat with their tile's size)."""

from __future__ import annotations

import numpy as np


def wrap_window(tile: np.ndarray, y0: int, x0: int, h: int, w: int,
                out: np.ndarray | None = None) -> np.ndarray:
    """An (h, w, ...) window of the periodic (ny, nx, ...) ``tile`` whose pixel (0, 0) is
    the tile's (``y0`` mod ny, ``x0`` mod nx), wrapping at the tile's edges: pixel (y, x) is
    ``tile[(y0 + y) % ny, (x0 + x) % nx]``. Written into ``out`` when given (its shape
    (h, w, ...)), else a new array of the tile's dtype."""
    ny, nx = tile.shape[:2]
    if out is None:
        out = np.empty((h, w) + tile.shape[2:], tile.dtype)
    y = 0
    while y < h:
        sy = (y0 + y) % ny
        hh = min(h - y, ny - sy)
        x = 0
        while x < w:
            sx = (x0 + x) % nx
            ww = min(w - x, nx - sx)
            out[y:y + hh, x:x + ww] = tile[sy:sy + hh, sx:sx + ww]
            x += ww
        y += hh
    return out


def grid_patches(a: np.ndarray, size: int) -> np.ndarray:
    """(n, size, size, ...) copy of the non-overlapping ``size`` x ``size`` patches of an
    (H, W, ...) array on a grid from its top-left corner, row-major (remainders left out;
    n = (H // size) (W // size)); trailing axes (e.g. colour) are kept."""
    rows, cols = a.shape[0] // size, a.shape[1] // size
    rest = a.shape[2:]
    t = a[:rows * size, :cols * size].reshape(rows, size, cols, size, *rest)
    return t.swapaxes(1, 2).reshape(rows * cols, size, size, *rest)
