"""The per-pixel wave layers: level tiles seen through the camera, read without repeating
(:mod:`sdcomp.render.water.detile`; straight down: a window of world texels, one texel per
pixel; oblique and turned views: remapped per run of rows of one level from windows around
them, cross-faded at level changes)."""

from __future__ import annotations

import math

import cv2
import numpy as np

from .base import LAYERS, scratch, tick
from .detile import PLAIN, remap_rows, window
from .geometry import row_geometry
from .textures import N_LEVELS, N_TILE, WaterTextures, pitch
from .waves import level_continuous


def wave_layers(plan, textures: WaterTextures, alt, frame, world_off, row_geo) -> dict:
    """The per-pixel wave layers of the sea rows (see LAYERS): ``a4`` (H - sea_row0, W, 4)
    uint8 codes (upwind slope, crosswind slope, grain, foam) of level ``l`` at full
    resolution, ``b4`` of level ``l + 2`` at 1/4 and ``c4`` of level ``l + 4`` at 1/16 of
    the resolution (their samples at the centres of 4 x 4 and 16 x 16 blocks), with the
    level of their rows
    (``levels_a`` ...). Straight down: windows of the levels' world texels, one texel per
    sample. Oblique: the levels sampled through the camera, rows along tile rows; rows near
    a level change cross-fade the two levels. Every read goes through
    :mod:`~sdcomp.render.water.detile` (cells of the tile at their own offsets: nothing
    repeats within a frame) but a still's reads no larger than ``PLAIN`` texels, which come
    from the tile itself."""
    w, h = plan.width, plan.height
    r0 = plan.sea_row0
    hs = h - r0
    s = frame["set"]
    rot = _rotation(frame, world_off)
    out = {}
    for name, div, off in LAYERS:
        wl, hl = max(1, -(-w // div)), max(1, -(-hs // div))
        dst = scratch("tex" + name, (hl, wl, 4))
        if plan.nadir:
            lev = int(round(frame["flev"][0])) + off
            if lev >= N_LEVELS:
                dst[:] = _neutral(wl)
            elif rot is not None:
                _nadir_warp(textures, s, lev, plan, alt, div, rot, dst)
            else:
                p = pitch(lev)
                x0, y0 = int(world_off[0] / p), int(world_off[1] / p)
                if max(wl, hl) <= PLAIN:  # nothing can repeat: the tile itself
                    dst = _periodic_crop(textures.ensure(s, lev), x0 % N_TILE, y0 % N_TILE,
                                         wl, hl)
                else:
                    window(textures.ensure(s, lev), (textures.seed, s, lev), x0, y0, wl, hl,
                           dst)
            levels = np.full(hl, lev, np.int64)
        else:
            # rows and columns at the centres of div x div blocks
            v = r0 + (np.arange(hl) + 0.5) * (hs / hl)
            geo = row_geometry((v - h / 2) / plan.fy, plan.fx, plan.fy, plan.pitch, alt)
            fp = np.maximum(geo["across"], geo["along"])
            fl = np.where(geo["ok"], level_continuous(np.where(geo["ok"], fp, 1.0)), N_LEVELS)
            x = ((np.arange(wl) + 0.5) * (w / wl) - w / 2) / plan.fx
            levels = _remap_layer(dst, textures, s, fl + off, geo["t"], geo["fwd"], x,
                                  world_off, fade=div < 16, rot=rot)
        out[name + "4"] = dst
        out["levels_" + name] = levels
    return out


FADE = 0.08  # level units on each side of a level change over which the levels cross-fade


def _remap_layer(dst, textures, s, flev, t, fwd, x, world_off, fade: bool = True,
                 rot: dict | None = None) -> np.ndarray:
    """Fill ``dst`` (rows, cols, 4) with the levels of set ``s`` sampled through the camera:
    row ``i`` of level ``ceil(flev[i])`` at tile x ``t_i x_j / p + N/2`` (across the view,
    tile columns hold x + N/2) and tile y ``t_i fwd_i / p + oy`` (forward); rows within FADE
    of a level change blend in the neighbouring level (variance-preserving: the two levels'
    reads are independent). One :func:`~sdcomp.render.water.detile.remap_rows` per run of
    rows that need a level (its own rows and the fading rows next to them). Returns the
    level of each row (N_LEVELS: none)."""
    tick()
    levels = np.clip(np.ceil(flev - 1e-9), 0, N_LEVELS).astype(np.int64)
    xs = np.asarray(x, np.float64)
    rows, cols = dst.shape[:2]
    # cross-fade zones: towards the coarser level near its boundary, the finer one near
    # the other, half-way at the boundary
    frac = flev - (levels - 1)  # in (0, 1]: position within the level's range
    partner = np.full(rows, -1, np.int64)
    wo = np.zeros(rows)
    for step, wts in (((1, np.clip((frac - (1 - FADE)) / (2 * FADE), 0, 0.5)),
                       (-1, np.clip((FADE - frac) / (2 * FADE), 0, 0.5))) if fade else ()):
        sel = (wts > 0.02) & (levels < N_LEVELS) & (levels + step >= 0)
        partner[sel] = np.minimum(levels[sel] + step, N_LEVELS)
        wo[sel] = wts[sel]
    other = scratch("partner", (rows, cols, 4))
    tick("r.maps")
    pl = partner.tolist()
    done = np.zeros(rows, bool)
    for lev, a, b in level_runs(levels):
        a2, b2 = a, b  # with the fading rows next to the run that blend this level in
        while a2 > 0 and pl[a2 - 1] == lev:
            a2 -= 1
        while b2 < rows and pl[b2] == lev:
            b2 += 1
        c = _row_coords(np.full(b2 - a2, lev), t[a2:b2], fwd[a2:b2], world_off, rot)
        if a2 == a and b2 == b:
            _sample(dst[a:b], textures, s, lev, c, xs, rot is None)
            continue
        tmp = scratch("level_rows", (b2 - a2, cols, 4))
        _sample(tmp, textures, s, lev, c, xs, rot is None)
        dst[a:b] = tmp[a - a2:b - a2]
        other[a2:a], other[b:b2] = tmp[:a - a2], tmp[b - a2:]
        done[a2:a] = done[b:b2] = True
    for lev, a, b in level_runs(np.where(done, -1, partner)):  # fading rows apart from
        if lev >= 0:  # their partner's rows (the flat surface past the last level)
            c = _row_coords(np.full(b - a, lev), t[a:b], fwd[a:b], world_off, rot)
            _sample(other[a:b], textures, s, lev, c, xs, rot is None)
    tick("r.main")
    wl = wo.tolist()
    for r in np.flatnonzero(partner >= 0).tolist():
        w = wl[r]
        # independent reads: weights of unit square sum; a fade to the flat surface past
        # the last level stays linear (the waves fade out)
        g = 1.0 if pl[r] >= N_LEVELS else 1.0 / math.hypot(1.0 - w, w)
        cv2.addWeighted(dst[r], (1.0 - w) * g, other[r], w * g, 128.0 * (1.0 - g), dst=dst[r])
    tick("r.blend")
    return levels


def _sample(dst, textures, s: int, lev: int, coords, xs, still: bool) -> None:
    """Rows of level ``lev`` of set ``s`` at ``coords`` (:func:`_row_coords`) into ``dst``
    (the flat surface past the last level); ``still``: a still image's (small runs read the
    tile itself)."""
    if lev >= N_LEVELS:
        dst[:] = _neutral(dst.shape[1])
        return
    remap_rows(dst, textures.ensure(s, lev), (textures.seed, s, lev), tuple(coords), xs,
               plain=still)


def _row_coords(levels, t, fwd, world_off, rot: dict | None = None) -> list[np.ndarray]:
    """World texel coordinates of rows at ``levels`` (see :func:`_remap_layer`): (bx, sx,
    by, sy), (rows,) float64 each, texel ``(bx + sx x, by + sy x)`` at image x ``x``
    (``t x`` metres right of the camera's nadir). With ``rot`` (:func:`_rotation`: a
    world-fixed frame or a camera away from the world origin) the camera's right and
    forward axes are turned into the tile frame and the offset is the world position: a
    row's ground point at ``t x`` metres right and ``t fwd`` forward is at ``m @ (right,
    forward) + off`` metres in the tile frame (column c holding x = c - N/2)."""
    ok = levels < N_LEVELS
    p = pitch(0) * np.exp2(np.where(ok, levels, 0).astype(np.float64))
    tt = np.where(ok & np.isfinite(t), t, 0.0)
    a = tt / p  # texels per unit image x
    f = tt * np.where(ok, fwd, 0.0) / p  # texels forward
    if rot is None:
        return [np.full(len(p), float(N_TILE // 2)), a, f + world_off[1] / p,
                np.zeros(len(p))]
    m, off = rot["m"], rot["off"]
    return [f * m[0, 1] + off[0] / p + N_TILE // 2, a * m[0, 0], f * m[1, 1] + off[1] / p,
            a * m[1, 0]]


def _rotation(frame: dict, world_off) -> dict | None:
    """The camera's axes in the tile frame (``m``: (2, 2), camera (right, down or forward)
    -> tile (x, y)), the camera's ``origin`` in metres along tile x, y and the per-image
    ``hash`` offset, for views that are not stills (a world-fixed frame, an origin away
    from 0, or a time: every frame of a video is sampled alike); None for a still image
    (its sampling, unchanged)."""
    origin = frame.get("origin")
    moved = origin is not None and bool(np.any(np.asarray(origin) != 0.0))
    if not frame.get("fixed") and not moved and not frame.get("video"):
        return None
    o = np.zeros(2) if origin is None else np.asarray(origin, np.float64)
    x_ax, y_ax = frame["x"], frame["y"]
    cx, cy = frame["cam_x"], frame["cam_y"]
    m = np.array([[cx @ x_ax, cy @ x_ax], [cx @ y_ax, cy @ y_ax]])  # camera -> tile
    org = np.array([o @ x_ax, o @ y_ax])
    # (oblique rows have no hash offset across: as the still images' maps)
    return {"m": m, "off": org + np.array([0.0, world_off[1]]), "hash": world_off,
            "origin": org}


def _nadir_warp(textures, s: int, lev: int, plan, alt: float, div: int, rot: dict,
                dst: np.ndarray) -> None:
    """Straight down through a rotation: layer pixel (i, j) (the centre of a div x div block
    of image pixels) at ground ``((j + 0.5) div - W/2) alt/fx`` right and ``((i + 0.5) div
    - H/2) alt/fy`` down of the nadir, in texels of ``div`` footprints (one texel per layer
    pixel, as the windows of stills), turned into the tile frame, plus the world offset:
    the still's window start (the hash part) and the origin in texels of ``div``
    footprints (the sea moves with the image); bicubic."""
    fpx, fpy = alt / plan.fx, alt / plan.fy
    fp = max(fpx, fpy) * div  # metres per texel
    m = rot["m"]
    sx, sy = div * fpx / fp, div * fpy / fp  # texels per layer pixel along right, down
    hl, wl = dst.shape[:2]
    cj, ci = plan.width / (2 * div) - 0.5, plan.height / (2 * div) - 0.5  # image centre
    rows = np.arange(hl, dtype=np.float64)
    coords = []
    for row in range(2):
        c0 = (int(rot["hash"][row] / pitch(lev)) + (cj, ci)[row] - m[row, 0] * sx * cj
              - m[row, 1] * sy * ci + rot["origin"][row] / fp)
        coords += [c0 + m[row, 1] * sy * rows, np.full(hl, m[row, 0] * sx)]
    remap_rows(dst, textures.ensure(s, lev), (textures.seed, s, lev), tuple(coords),
               np.arange(wl, dtype=np.float64), cv2.INTER_CUBIC)


_NEUTRAL: dict = {}


def _neutral(width: int) -> np.ndarray:
    """(1, width, 4) uint8 codes of a flat surface without grain or foam (channels: slope
    u, slope c, grain, foam)."""
    row = _NEUTRAL.get(width)
    if row is None:
        row = _NEUTRAL[width] = np.tile(np.array([128, 128, 128, 0], np.uint8), (1, width, 1))
    return row


def level_runs(levels: np.ndarray):
    """(level, start, stop) of each run of equal values."""
    lv = np.asarray(levels)
    if lv.size == 0:
        return []
    if lv[0] == lv[-1] and (lv.size < 3 or lv.min() == lv.max()):
        return [(int(lv[0]), 0, int(lv.size))]
    cut = np.flatnonzero(np.diff(lv)) + 1
    starts = np.concatenate([[0], cut])
    stops = np.concatenate([cut, [lv.size]])
    return [(int(lv[a]), int(a), int(b)) for a, b in zip(starts, stops, strict=True)]


def resize_box(grid: np.ndarray, rows: int, width: int, x0: int, y0: int, x1: int,
                y1: int) -> np.ndarray:
    """The box (x0..x1, y0..y1) of ``cv2.resize(grid, (width, rows))`` (cell-centred
    bilinear magnification), computed from the grid cells around the box only when the
    cells are a whole number of pixels (else from the full magnification)."""
    gh, gw = grid.shape[:2]
    cw, ch = width / gw, rows / gh
    if cw == int(cw) and ch == int(ch) and cw >= 1 and ch >= 1:
        cw, ch = int(cw), int(ch)
        j0, j1 = max(0, x0 // cw - 1), min(gw, -(-x1 // cw) + 1)
        i0, i1 = max(0, y0 // ch - 1), min(gh, -(-y1 // ch) + 1)
        sub = cv2.resize(np.ascontiguousarray(grid[i0:i1, j0:j1]),
                         ((j1 - j0) * cw, (i1 - i0) * ch), interpolation=cv2.INTER_LINEAR)
        # the block's edge cells clamp differently from the full grid: they lie outside
        # the box unless the box touches the grid's edge (where both clamp alike)
        return sub[y0 - i0 * ch:y1 - i0 * ch, x0 - j0 * cw:x1 - j0 * cw]
    full = cv2.resize(grid, (width, rows), interpolation=cv2.INTER_LINEAR)
    return full[y0:y1, x0:x1]


def _periodic_crop(tile: np.ndarray, x0: int, y0: int, cw: int, ch: int) -> np.ndarray:
    """A (ch, cw) view of the periodic tile (period N_TILE; the tile has one extra wrapped
    row and column; cw, ch <= N_TILE + 1) starting near texel (x0, y0), moved left or up
    if needed (any start is as good)."""
    x0 = min(x0, N_TILE + 1 - cw)
    y0 = min(y0, N_TILE + 1 - ch)
    return tile[y0:y0 + ch, x0:x0 + cw]
