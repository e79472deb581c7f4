"""Reading the periodic level tiles without repeating them (issue 48, item 3).

A level tile repeats every ``N_TILE`` texels (its finer band every ``N_TILE / 2``), so a
frame wider than that drew the same waves and whitecaps again (1920 x 1080 straight down: the
autocorrelation of the band-passed luma 0.74 at 512 px). The renderer reads a level through
this module instead: the level's world texels are cut into square cells of :data:`CELL`
texels; each cell reads :data:`READ` texels each way from its own start in the tile, with or
without the sign of the field (a hash of the tiles' seed, the direction set, the level and
the cell: a world texel has one value in every view, layer and video frame); neighbouring
cells cross-fade over :data:`BLEND` texels with the variance-preserving blend of Heitz &
Neyret (2018, "High-performance by-example noise using a histogram-preserving blending
operator"): ``128 + sum_i w_i (s_i - 128)`` with ``sum_i w_i**2 = 1`` (separable: ``cos``
and ``sin`` of a smoothstep across each edge). Every channel of a tile is a unit-variance
Gaussian code centred on 128 (the slopes, the grain and the foam placement:
:mod:`sdcomp.render.water.textures`): a negated read has the same statistics, and a
variance-preserving blend of independent Gaussian reads is Gaussian with the same variance
and, where the weights vary slowly, the same spectrum, so the slope variance, grain and
whitecap coverage are the tile's. A read spans at most ``N_TILE / 2`` texels: none repeats
within itself. What remains is the tile's finite variety: a 1920 x 1080 frame straight down
shows about eight tiles' worth of texels, so neighbouring cells often show parts of the
same field at some random displacement (half of them negated).

:func:`window` gives a rectangle of a level's world texels (straight down, one texel per
pixel, that rectangle is the layer); :func:`remap_rows` samples a level along rows of
arbitrary affine coordinates (oblique and turned views) from windows around pieces of the
rows; a still's reads no larger than :data:`PLAIN` texels (where nothing can repeat) come
from the tile itself. Plateaus are copies of the tile; the cross-fades are
``cv2.addWeighted`` passes on the uint8 codes (a column or a row of every edge of a group of
bands at a time). :func:`mosaic` reads the glitter noise in blocks at their own offsets
without cross-fades (independent per pixel: blocks have no edges to hide).
"""

from __future__ import annotations

import math
import threading
import weakref

import cv2
import numpy as np

from ...util.tiles import wrap_window
from .base import scratch
from .textures import N_TILE

CELL = 128  # texels between cell edges
BLEND = 32  # texels over which two cells cross-fade (centred on their edge)
HALF = BLEND // 2
READ = CELL + BLEND  # texels a cell reads along each axis (its cell and half an edge each side)
EDGE_WORDS = 1 << 17  # int32 words of a group of bands' edge reads at most (cache-sized)
PIECE_MAX = 1 << 20  # pixels: remap_rows samples at most this many from one window
PLAIN = N_TILE // 2  # texels: a still's reads no larger than this (the finest band's
# period) come from the tile itself
_M64 = (1 << 64) - 1


def _ramp() -> tuple[list[float], list[float], list[float]]:
    """Per texel ``t`` across an edge: the weights of the cell before it (cos) and after it
    (sin) of a smoothstep angle, and addWeighted's constant ``128 (1 - cos - sin)``."""
    c, s, g = [], [], []
    for t in range(BLEND):
        u = (t + 0.5) / BLEND
        th = 0.5 * math.pi * u * u * (3.0 - 2.0 * u)
        c.append(math.cos(th))
        s.append(math.sin(th))
        g.append(128.0 * (1.0 - c[-1] - s[-1]))
    return c, s, g


_RAMP = _ramp()


def cell_offsets(key: tuple[int, int, int], ky: np.ndarray, kx: np.ndarray,
                 period: int = N_TILE) -> np.ndarray:
    """(len(ky), len(kx), 3) int64 tile offsets (y, x) in [0, period) and a sign bit of
    cells (ky, kx) of ``key`` = (tiles' seed, direction set, level): a splitmix64 hash of
    them."""
    seed, s, level = (int(k) for k in key)
    base = (seed * 0x9E3779B97F4A7C15 + (s * 64 + level + 1) * 0xD1B54A32D192ED03) & _M64
    if len(ky) * len(kx) <= 64:  # the same hash in Python integers (faster for a few)
        out = np.empty((len(ky), len(kx), 3), np.int64)
        for i, y in enumerate(ky.tolist()):
            for j, x in enumerate(kx.tolist()):
                z = (base + y * 0x8CB92BA72F3D8DD7 + x * 0xC2B2AE3D27D4EB4F) & _M64
                z = ((z ^ (z >> 30)) * 0xBF58476D1CE4E5B9) & _M64
                z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) & _M64
                z ^= z >> 31
                out[i, j] = ((z >> 32) % period, z % period, (z >> 29) & 1)
        return out
    z = (np.uint64(base) + ky.astype(np.uint64)[:, None] * np.uint64(0x8CB92BA72F3D8DD7)
         + kx.astype(np.uint64)[None, :] * np.uint64(0xC2B2AE3D27D4EB4F))
    z ^= z >> np.uint64(30)
    z *= np.uint64(0xBF58476D1CE4E5B9)
    z ^= z >> np.uint64(27)
    z *= np.uint64(0x94D049BB133111EB)
    z ^= z >> np.uint64(31)
    n = np.uint64(period)
    return np.stack([(z >> np.uint64(32)) % n, z % n, (z >> np.uint64(29)) & np.uint64(1)],
                    -1).astype(np.int64)


def cells(lo: int, size: int) -> list[int]:
    """The cells whose reads (their cell and half an edge each side) meet [lo, lo + size)."""
    return list(range((lo - HALF) // CELL, (lo + size - 1 + HALF) // CELL + 1))


def window(tile: np.ndarray, key: tuple[int, int, int], x0: int, y0: int, w: int, h: int,
           out: np.ndarray, need: np.ndarray | None = None) -> np.ndarray:
    """Fill ``out`` ((h, w, 4) uint8, C-contiguous) with world texels ``(x0 + c, y0 + r)``
    (unbounded integers) of the non-repeating level ``key`` read from its periodic
    (N + 1, N + 1, 4) ``tile``, and return it. A cell reads :data:`READ` texels each way
    from its start in the tile (a hash: at most N + 1 - READ, so that no read wraps); the
    bands of cell rows are drawn in groups (at most :data:`EDGE_WORDS` words of edges).
    ``need`` ((cell rows, cell columns) bool over :func:`cells` of the window): the cells
    whose texels are read (the others are left undrawn)."""
    words = _words(tile)  # texels as 32-bit words: copies move 4 codes
    o32 = out.view(np.int32)[..., 0]
    kx, ky = cells(x0, w), cells(y0, h)
    starts = cell_offsets(key, np.array(ky), np.array(kx), N_TILE + 2 - READ)
    if need is not None:
        starts[..., 2] += 2 * ~need  # (bit 1: not needed)
    starts = starts.tolist()
    group = max(1, min(len(ky), EDGE_WORDS // (BLEND * READ * max(1, len(kx) - 1))))
    keep = scratch("dt_keep", (BLEND, w), np.int32)
    for g0 in range(0, len(ky), group):
        _bands(words, starts[g0:g0 + group], ky[g0:g0 + group], kx, x0, y0, o32, keep)
    return out


def _negation() -> np.ndarray:
    """(1, 256, 4) uint8 LUT: a code's negative, ``256 - code`` (at most 255), but the foam
    channel's 0 (a level without whitecaps is all 0) stays 0."""
    lut = np.minimum(256 - np.arange(256), 255).astype(np.uint8)
    four = np.repeat(lut[None, :, None], 4, axis=2)
    four[0, 0, 3] = 0
    return four


_NEGATION = _negation()


def _words(tile: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The tile's texels as 32-bit words (a texel's 4 codes) and those of its negative
    (:data:`_NEGATION`: a cell with its sign bit reads it; Gaussian codes negated have the
    same statistics, and twice the tile's variety), the negative made once per tile (the
    last eight kept)."""
    with _LOCK:
        hit = _NEGATED.get(id(tile))
    if hit is None or hit[0]() is not tile:
        hit = (weakref.ref(tile), cv2.LUT(tile, _NEGATION))
        with _LOCK:
            while len(_NEGATED) >= 8:
                _NEGATED.pop(next(iter(_NEGATED)))
            _NEGATED[id(tile)] = hit
    return tile.view(np.int32)[..., 0], hit[1].view(np.int32)[..., 0]


_NEGATED: dict = {}
_LOCK = threading.Lock()


def _bands(words: tuple, starts: list, ky: list[int], kx: list[int], x0: int, y0: int,
           o32: np.ndarray, keep: np.ndarray) -> None:
    """Draw the consecutive bands of cell rows ``ky`` into ``o32`` ((h, w) int32 words of
    the window from (x0, y0)): each band's READ rows (those in the window) in a slot of a
    scratch stack (slot 0: ``keep``, the bottom edge of the band above), each cell's plateau
    copied from its read, the edges between cells cross-faded (:func:`_edges`), then the
    plateau rows copied out and the edges between bands cross-faded a row at a time over
    every band. ``keep`` gets the last band's bottom edge."""
    h, w = o32.shape
    nbd, nb = len(ky), len(kx) - 1
    bands = scratch("dt_b", (nbd + 1, READ, w), np.int32)
    bands[0, CELL:] = keep
    spans = [(max(0, y0 - top), min(READ, y0 + h - top)) for top in
             (cy * CELL - HALF for cy in ky)]  # each band's rows in the window
    for j, (lo, hi) in enumerate(spans):
        for i, cx in enumerate(kx):
            a0, a1 = max(x0, cx * CELL + HALF), min(x0 + w, (cx + 1) * CELL - HALF)
            if a1 > a0:
                sy, sx, neg = starts[j][i]
                if neg > 1:
                    continue
                u = sx + a0 - (cx * CELL - HALF)
                bands[j + 1, lo:hi, a0 - x0:a1 - x0] = words[neg][sy + lo:sy + hi,
                                                                  u:u + a1 - a0]
    if nb:
        _edges(words, starts, spans, kx, x0, bands)
    ed = None
    if any(lo < BLEND for lo, _ in spans):  # an edge between bands lies in the window
        ed = scratch("dt_ed", (BLEND, nbd, w), np.int32)
        _fade(bands[:nbd, CELL:].swapaxes(0, 1), bands[1:, :BLEND].swapaxes(0, 1), ed)
    for j, cy in enumerate(ky):
        top = cy * CELL - HALF  # the world row of the band's first row
        p0, p1 = max(y0, cy * CELL + HALF), min(y0 + h, (cy + 1) * CELL - HALF)
        if p1 > p0:
            o32[p0 - y0:p1 - y0] = bands[j + 1, p0 - top:p1 - top]
        e0, e1 = max(y0, top), min(y0 + h, top + BLEND)  # the edge with the band above
        if e1 > e0 and ed is not None:
            o32[e0 - y0:e1 - y0] = ed[e0 - top:e1 - top, j]
    keep[:] = bands[nbd, CELL:]


def _edges(words: tuple, starts: list, spans: list, kx: list[int], x0: int,
           bands: np.ndarray) -> None:
    """The edges between the cells of each band (rows ``spans``) into ``bands``: both
    cells' reads of every edge stacked transposed (a column of every edge one contiguous
    block), cross-faded a column at a time, transposed back."""
    nbd, nb, w = len(spans), len(kx) - 1, bands.shape[2]
    lt, rt, ot = (scratch(n, (BLEND, nbd * nb, READ), np.int32)
                  for n in ("dt_l", "dt_r", "dt_o"))
    for j, (lo, hi) in enumerate(spans):
        for i in range(nb):
            e = j * nb + i
            if starts[j][i][2] > 1 and starts[j][i + 1][2] > 1:
                continue
            for side, (sy, sx, neg), u in ((lt, starts[j][i], CELL), (rt, starts[j][i + 1], 0)):
                cv2.transpose(words[neg & 1][sy + lo:sy + hi, sx + u:sx + u + BLEND],
                              dst=side[:, e, lo:hi])
    r0, r1 = min(lo for lo, _ in spans), max(hi for _, hi in spans)
    _fade(lt[:, :, r0:r1], rt[:, :, r0:r1], ot[:, :, r0:r1])
    for j, (lo, hi) in enumerate(spans):
        for i in range(nb):
            if starts[j][i][2] > 1 and starts[j][i + 1][2] > 1:
                continue
            e0 = kx[i + 1] * CELL - HALF
            c0, c1 = max(e0, x0), min(e0 + BLEND, x0 + w)
            cv2.transpose(ot[c0 - e0:c1 - e0, j * nb + i, lo:hi],
                          dst=bands[j + 1, lo:hi, c0 - x0:c1 - x0])


def _fade(a: np.ndarray, b: np.ndarray, dst: np.ndarray) -> None:
    """``dst[t] = 128 + c_t (a[t] - 128) + s_t (b[t] - 128)`` per code for ``t`` across
    an edge (:data:`_RAMP`); (BLEND, n, m) int32 words each, rows contiguous."""
    c, s, g = _RAMP
    a8, b8, d8 = (x.view(np.uint8) for x in (a, b, dst))
    for t in range(BLEND):
        cv2.addWeighted(a8[t], c[t], b8[t], s[t], g[t], dst=d8[t])


def remap_rows(dst: np.ndarray, tile: np.ndarray, key: tuple[int, int, int],
               coords: tuple[np.ndarray, ...], xs: np.ndarray,
               interp: int = cv2.INTER_LINEAR, plain: bool = False) -> None:
    """Fill ``dst`` ((rows, cols, 4) uint8, rows contiguous) with the non-repeating level
    ``key`` sampled (``interp``) at world texel ``(bx + sx xs[c], by + sy xs[c])`` for row
    ``r`` (``coords`` = (bx, sx, by, sy), (rows,) float64 each; ``xs`` (cols,)): pieces of
    the rows whose coordinates span a compact rectangle (split in halves until the
    rectangle is at most four times the piece and the piece at most :data:`PIECE_MAX`
    pixels), each remapped from a :func:`window` of that rectangle. With ``plain`` (a
    still image, whose reads need not agree with another view's) rows spanning at most
    :data:`PLAIN` texels each way are remapped from the tile itself (nothing can repeat
    within them)."""
    bx, sx, by, sy = coords
    margin = 1 if interp == cv2.INTER_LINEAR else 2
    xs64 = np.asarray(xs, np.float64)
    xs32 = xs64.astype(np.float32)
    todo = [(0, dst.shape[0], 0, dst.shape[1])]
    while todo:
        r0, r1, c0, c1 = todo.pop()
        ends = xs64[[c0, c1 - 1]]
        ex = bx[r0:r1, None] + sx[r0:r1, None] * ends
        ey = by[r0:r1, None] + sy[r0:r1, None] * ends
        x0, y0 = math.floor(ex.min()) - margin, math.floor(ey.min()) - margin
        ww = math.floor(ex.max()) + margin + 2 - x0
        hh = math.floor(ey.max()) + margin + 2 - y0
        px = (r1 - r0) * (c1 - c0)
        if plain and max(ww, hh) <= PLAIN + 2 * margin + 2:
            win = tile[:N_TILE, :N_TILE]
            x0, y0 = x0 - x0 % N_TILE, y0 - y0 % N_TILE  # (maps within two periods)
        elif (ww * hh > 4 * px + 4096 or px > PIECE_MAX) and px > 256:
            if r1 - r0 >= c1 - c0:
                mid = (r0 + r1) // 2
                todo += [(r0, mid, c0, c1), (mid, r1, c0, c1)]
            else:
                mid = (c0 + c1) // 2
                todo += [(r0, r1, c0, mid), (r0, r1, mid, c1)]
            plain = False  # (rows that need cells: every piece through cells)
            continue
        else:
            win = window(tile, key, x0, y0, ww, hh, scratch("dt_win", (hh, ww, 4)),
                         _needed(coords, xs64, r0, r1, c0, c1, x0, y0, ww, hh))
        maps = []
        for b, sl, o, name in ((bx, sx, x0, "dt_mx"), (by, sy, y0, "dt_my")):
            m = scratch(name, (r1 - r0, c1 - c0), np.float32)
            np.multiply(sl[r0:r1, None].astype(np.float32), xs32[None, c0:c1], out=m)
            m += (b[r0:r1] - o).astype(np.float32)[:, None]
            maps.append(m)
        cv2.remap(win, maps[0], maps[1], interp, dst=dst[r0:r1, c0:c1],
                  borderMode=cv2.BORDER_WRAP)


def _needed(coords, xs: np.ndarray, r0: int, r1: int, c0: int, c1: int, x0: int, y0: int,
            ww: int, hh: int) -> np.ndarray:
    """The cells of the window (x0, y0, ww, hh) that rows r0..r1, columns c0..c1 at
    ``coords`` read: those of every 16th sample and their neighbours (samples 16 pixels
    apart are less than a cell apart: none is missed). A turned view's window is about
    twice the footprint it samples; the other cells are not drawn."""
    bx, sx, by, sy = coords
    rows = np.r_[r0:r1:16, r1 - 1]
    x = xs[np.r_[c0:c1:16, c1 - 1]]
    kx, ky = cells(x0, ww), cells(y0, hh)
    need = np.zeros((len(ky), len(kx)), np.uint8)
    ix = np.floor((bx[rows, None] + sx[rows, None] * x) / CELL).astype(np.int64) - kx[0]
    iy = np.floor((by[rows, None] + sy[rows, None] * x) / CELL).astype(np.int64) - ky[0]
    need[np.clip(iy, 0, len(ky) - 1), np.clip(ix, 0, len(kx) - 1)] = 1
    return cv2.dilate(need, np.ones((3, 3), np.uint8)).astype(bool)


NOISE_BLOCK = 256  # pixels: the glitter noise's blocks


def mosaic(tile: np.ndarray, y0: int, x0: int, h: int, w: int, out: np.ndarray) -> np.ndarray:
    """Fill ``out`` ((h, w)) with the window from (y0, x0) of a periodic (n, n) ``tile`` of
    independent per-pixel values (the glitter noise), each :data:`NOISE_BLOCK` block of the
    window's grid (from (0, 0)) read at its own hashed offset, and return it: the window
    does not repeat however large it is (a sparkle pattern 1024 px apart at 4K before)."""
    by = list(range(y0 // NOISE_BLOCK, (y0 + h - 1) // NOISE_BLOCK + 1))
    bx = list(range(x0 // NOISE_BLOCK, (x0 + w - 1) // NOISE_BLOCK + 1))
    offs = cell_offsets((0x6117, 0, 0), np.array(by), np.array(bx), tile.shape[0]).tolist()
    for i, b in enumerate(by):
        r0, r1 = max(y0, b * NOISE_BLOCK), min(y0 + h, (b + 1) * NOISE_BLOCK)
        for j, a in enumerate(bx):
            c0, c1 = max(x0, a * NOISE_BLOCK), min(x0 + w, (a + 1) * NOISE_BLOCK)
            oy, ox, _ = offs[i][j]
            wrap_window(tile, r0 + oy, c0 + ox, r1 - r0, c1 - c0,
                        out[r0 - y0:r1 - y0, c0 - x0:c1 - x0])
    return out
