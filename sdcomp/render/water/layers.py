"""The per-pixel wave layers: level tiles seen through the camera (straight down: tile crops, one
texel per pixel; oblique: one remap per run of rows of one level, cross-faded at level
changes)."""

from __future__ import annotations

import cv2
import numpy as np

from ...util.tiles import wrap_window
from .base import LAYERS, scratch, tick
from .geometry import row_geometry
from .textures import N_LEVELS, N_TILE, WaterTextures, pitch
from .waves import level_continuous


def wave_layers(plan, textures: WaterTextures, alt, frame, world_off, row_geo) -> dict:
    """The per-pixel wave layers of the sea rows (see LAYERS): ``a4`` (H - sea_row0, W, 4)
    uint8 codes (upwind slope, crosswind slope, grain, foam) of level ``l`` at full
    resolution, ``b4`` of level ``l + 2`` at 1/4 and ``c4`` of level ``l + 4`` at 1/16 of
    the resolution (their samples at the centres of 4 x 4 and 16 x 16 blocks), with the
    level of their rows
    (``levels_a`` ...). Straight down: crops of the tiles, one texel per sample. Oblique:
    the tiles sampled through the camera, rows along tile rows; rows near a level change
    cross-fade the two levels."""
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
                _nadir_warp(textures.ensure(s, lev), plan, alt, div, pitch(lev), rot, dst)
            else:
                p = pitch(lev)
                ox = int(world_off[0] / p) % N_TILE
                oy = int(world_off[1] / p) % N_TILE
                dst = _periodic_crop(textures.ensure(s, lev), ox, oy, wl, hl, dst)
            levels = np.full(hl, lev, np.int64)
        else:
            # rows and columns at the centres of div x div blocks
            v = r0 + (np.arange(hl) + 0.5) * (hs / hl)
            geo = row_geometry((v - h / 2) / plan.fy, plan.fx, plan.fy, plan.pitch, alt)
            fp = np.maximum(geo["across"], geo["along"])
            fl = np.where(geo["ok"], level_continuous(np.where(geo["ok"], fp, 1.0)), N_LEVELS)
            x = ((np.arange(wl) + 0.5) * (w / wl) - w / 2) / plan.fx
            levels = _remap_layer(dst, textures, s, fl + off, geo["t"], geo["fwd"], x,
                                  world_off, name, fade=div < 16, rot=rot)
        out[name + "4"] = dst
        out["levels_" + name] = levels
    return out


FADE = 0.08  # level units on each side of a level change over which the levels cross-fade


def _remap_layer(dst, textures, s, flev, t, fwd, x, world_off, name,
                 fade: bool = True, rot: dict | None = None) -> np.ndarray:
    """Fill ``dst`` (rows, cols, 4) with level tiles of set ``s`` sampled through the
    camera: row ``i`` of level ``ceil(flev[i])`` at tile x ``t_i x_j / p + N/2`` (across
    the view, tile columns hold x + N/2) and tile y ``t_i fwd_i / p + oy`` (forward); rows
    within FADE of a level change blend in the neighbouring level. The sampling maps of all
    rows are made at once; one remap per run of rows of one level. Returns the level of
    each row (N_LEVELS: none)."""
    tick()
    levels = np.clip(np.ceil(flev - 1e-9), 0, N_LEVELS).astype(np.int64)
    xs = np.asarray(x, np.float32)
    rows, cols = dst.shape[:2]
    frac = flev - (levels - 1)  # in (0, 1]: position within the level's range
    mx = scratch("mapx" + name, (rows, cols), np.float32)
    my = scratch("mapy" + name, (rows, cols), np.float32)
    _maps(levels, t, fwd, xs, world_off, mx, my, rot)
    tick("r.maps")
    for lev, a, b in level_runs(levels):
        if lev >= N_LEVELS:
            dst[a:b] = _neutral(cols)
            continue
        cv2.remap(_source(textures.ensure(s, lev), rot), mx[a:b], my[a:b], cv2.INTER_LINEAR,
                  dst=dst[a:b], borderMode=cv2.BORDER_WRAP)
    tick("r.main")
    # cross-fade zones: towards the coarser level near its boundary, the finer one near
    # the other, half-way at the boundary
    w_up = np.clip((frac - (1 - FADE)) / (2 * FADE), 0, 0.5)
    w_dn = np.clip((FADE - frac) / (2 * FADE), 0, 0.5)
    for step, wts in ((1, w_up), (-1, w_dn)) if fade else ():
        sel = (wts > 0.02) & (levels < N_LEVELS) & (levels + step >= 0)
        if not sel.any():
            continue
        other = np.minimum(levels + step, N_LEVELS)
        idx = np.flatnonzero(sel)
        ox = scratch("omapx" + name, (len(idx), cols), np.float32)
        oy = scratch("omapy" + name, (len(idx), cols), np.float32)
        _maps(other[idx], t[idx], fwd[idx], xs, world_off, ox, oy, rot)
        wo_all = scratch("bw" + name, (len(idx), cols), np.float32)
        wo_all[:] = wts[idx, None]
        wi_all = scratch("bwi" + name, (len(idx), cols), np.float32)
        np.subtract(np.float32(1.0), wo_all, out=wi_all)
        cut = np.flatnonzero((np.diff(idx) != 1) | (np.diff(other[idx]) != 0)) + 1
        start = 0
        for stop in [int(c) for c in cut] + [len(idx)]:
            a, b = int(idx[start]), int(idx[stop - 1]) + 1
            lev = int(other[a])
            block = dst[a:b]
            tmp = scratch("blend" + name, block.shape)
            if lev >= N_LEVELS:
                tmp[:] = _neutral(cols)
            else:
                cv2.remap(_source(textures.ensure(s, lev), rot), ox[start:stop],
                          oy[start:stop], cv2.INTER_LINEAR, dst=tmp,
                          borderMode=cv2.BORDER_WRAP)
            cv2.blendLinear(block, tmp, wi_all[start:stop], wo_all[start:stop], dst=block)
            start = stop
    tick("r.blend")
    return levels


def _maps(levels, t, fwd, xs, world_off, mx, my, rot: dict | None = None) -> None:
    """Remap coordinates of rows at ``levels`` (see :func:`_remap_layer`) into ``mx``,
    ``my`` (rows, cols) float32; rows wider than twice the tile are wrapped explicitly
    (slightly wider ones wrap through BORDER_WRAP). With ``rot`` (:func:`_rotation`: a
    world-fixed frame or a camera away from the world origin) the camera's right and
    forward axes are turned into the tile frame and the offset is the world position."""
    ok = levels < N_LEVELS
    p = pitch(0) * np.exp2(np.where(ok, levels, 0).astype(np.float64))
    tt = np.where(ok & np.isfinite(t), t, 0.0)
    if rot is not None:
        _rotated_maps(p, tt, np.where(ok, fwd, 0.0), xs, rot, mx, my)
        return
    a = (tt / p).astype(np.float32)
    ty = np.mod(tt * fwd / p + world_off[1] / p, N_TILE).astype(np.float32)
    np.multiply(a[:, None], xs[None, :], out=mx)
    mx += np.float32(N_TILE // 2)
    if float(np.max(a)) * float(xs[-1] - xs[0]) > 2 * N_TILE:
        wide = np.flatnonzero(a * float(xs[-1] - xs[0]) > 2 * N_TILE)
        blk = mx[wide]
        blk -= np.floor(blk * np.float32(1.0 / N_TILE)) * np.float32(N_TILE)
        mx[wide] = blk
    my[:] = ty[:, None]


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


def _source(tile: np.ndarray, rot: dict | None) -> np.ndarray:
    """What a layer remaps from: a still's whole (N + 1, N + 1, 4) tile (its maps stay
    within it but for a texel), a rotated view's (N, N) period of it (a view: remap's
    BORDER_WRAP then wraps any coordinate exactly, and its maps need no reduction)."""
    return tile if rot is None else tile[:N_TILE, :N_TILE]


def _rotated_maps(p, tt, fwd, xs, rot: dict, mx, my) -> None:
    """Oblique maps through a rotation: a row's ground point at ``t x`` metres right and
    ``t fwd`` forward of the camera's nadir is at ``m @ (right, forward) + off`` metres in
    the tile frame; coordinates in texels (column c holding x = c - N/2), each row's start
    reduced mod N and rows spanning more than two periods reduced whole (the others wrap in
    remap: :func:`_source`)."""
    m, off = rot["m"], rot["off"]
    a = tt / p  # (rows,) texels per unit image x
    f = tt * fwd / p  # texels forward
    width = float(xs[-1] - xs[0]) if len(xs) > 1 else 0.0
    for out, row, half in ((mx, 0, N_TILE // 2), (my, 1, 0)):
        base = np.mod(f * m[row, 1] + off[row] / p + half, N_TILE).astype(np.float32)
        slope = (a * m[row, 0]).astype(np.float32)
        np.multiply(slope[:, None], xs[None, :], out=out)
        out += base[:, None]
        wide = np.flatnonzero(np.abs(slope) * width > 2 * N_TILE)
        if len(wide):
            blk = out[wide]
            blk -= np.floor(blk * np.float32(1.0 / N_TILE)) * np.float32(N_TILE)
            out[wide] = blk


def _nadir_warp(tile: np.ndarray, plan, alt: float, div: int, p: float, rot: dict,
                dst: np.ndarray) -> None:
    """Straight down through a rotation: layer pixel (i, j) (the centre of a div x div block
    of image pixels) at ground ``((j + 0.5) div - W/2) alt/fx`` right and ``((i + 0.5) div
    - H/2) alt/fy`` down of the nadir, in texels of ``div`` footprints (one texel per layer
    pixel, as the crops), turned into the tile frame, plus the world offset: the still
    crop's start (the hash part: the same texels as the crop when nothing turns or moves)
    and the origin in texels of ``div`` footprints (the sea moves with the image); one
    warpAffine with wrap-around, bicubic."""
    fpx, fpy = alt / plan.fx, alt / plan.fy
    fp = max(fpx, fpy) * div  # metres per texel
    m = rot["m"]
    sx, sy = div * fpx / fp, div * fpy / fp  # texels per layer pixel along right, down
    hl, wl = dst.shape[:2]
    cj, ci = plan.width / (2 * div) - 0.5, plan.height / (2 * div) - 0.5  # image centre
    n = N_TILE
    start = []
    for ax, size in ((0, wl), (1, hl)):
        x0 = int(rot["hash"][ax] / p) % n
        start.append(min(x0, n + 1 - size) if wl <= n + 1 and hl <= n + 1 else x0)
    aff = np.empty((2, 3))
    for row in range(2):
        aff[row, 0] = m[row, 0] * sx
        aff[row, 1] = m[row, 1] * sy
        aff[row, 2] = (start[row] + (cj, ci)[row] - m[row, 0] * sx * cj - m[row, 1] * sy * ci
                       + np.mod(rot["origin"][row] / fp, n))
    cv2.warpAffine(tile[:n, :n], aff, (dst.shape[1], dst.shape[0]), dst=dst,
                   flags=cv2.INTER_CUBIC | cv2.WARP_INVERSE_MAP, borderMode=cv2.BORDER_WRAP)


_NEUTRAL: dict = {}


def _neutral(width: int) -> np.ndarray:
    """(1, width, 4) uint8 codes of a flat surface without grain or foam (channels: slope
    u, slope c, grain, foam)."""
    row = _NEUTRAL.get(width)
    if row is None:
        row = _NEUTRAL[width] = np.tile(np.array([128, 128, 128, 0], np.uint8), (1, width, 1))
    return row


def _periodic_crop(tile: np.ndarray, x0: int, y0: int, cw: int, ch: int,
                   out: np.ndarray) -> np.ndarray:
    """A (ch, cw) window of the periodic tile (period N_TILE; the tile has one extra
    wrapped row and column) starting near texel (x0, y0): a view when it fits (moved left
    or up if needed: any start is as good), else assembled in ``out`` from wrapped
    blocks."""
    n = N_TILE
    if cw <= n + 1 and ch <= n + 1:
        x0 = min(x0, n + 1 - cw)
        y0 = min(y0, n + 1 - ch)
        return tile[y0:y0 + ch, x0:x0 + cw]
    return wrap_window(tile[:n, :n], y0, x0, ch, cw, out)


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
