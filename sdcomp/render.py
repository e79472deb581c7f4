"""A vectorised NumPy z-buffer rasteriser for orthographic sprites of a :class:`ColoredMesh`.

The mesh is drawn on a square canvas at ``supersample`` x the output resolution; every
sub-pixel whose centre lies inside a triangle is a candidate, the nearest candidate per
sub-pixel wins (z-buffer), and the sub-pixels are averaged down to the output pixels. Nothing
is lit: the sprite carries albedo, normals and heights so that a compositor can relight it
and put it under water later.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .coloredmesh import ColoredMesh
from .poses import tilt_matrix, view_basis

_CHUNK = 3_000_000  # candidate sub-pixels per vectorised batch (bounds memory, ~200 MB)
_EMPTY = np.iinfo(np.int64).max


@dataclass(frozen=True, eq=False)
class Sprite:
    """One rendered view, all arrays (H, W, ...) in image order (row 0 at the top).

    Attributes:
        alpha: (H, W) float32 coverage in [0, 1] (fraction of covered sub-pixels).
        albedo: (H, W, 3) uint8 sRGB mean albedo of the covered sub-pixels (0 where empty).
        normal: (H, W, 3) float32 unit surface normal in the camera frame (x right, y up,
            z towards the camera); 0 where empty.
        height: (H, W) float32 metres of the visible surface above the waterline (negative
            under water); 0 where empty.
        mask: (H, W) bool, exactly ``alpha > 0``.
    """

    alpha: np.ndarray
    albedo: np.ndarray
    normal: np.ndarray
    height: np.ndarray
    mask: np.ndarray


def render(mesh: ColoredMesh, off_nadir: float, azimuth: float, *, size: int,
           metres_per_pixel: float, roll: float = 0.0, pitch: float = 0.0,
           supersample: int = 4) -> Sprite:
    """Render ``mesh`` seen from (``off_nadir``, ``azimuth``) degrees, tilted by roll/pitch.

    The body origin projects to the canvas centre; ``metres_per_pixel`` is the output pixel
    pitch; ``size`` the canvas side in output pixels. See :mod:`sdcomp.poses` for the angles.
    """
    if size < 1 or supersample < 1 or metres_per_pixel <= 0:
        raise ValueError("size and supersample must be >= 1 and metres_per_pixel > 0")
    basis = view_basis(off_nadir, azimuth)
    pivot = np.array([0.0, 0.0, mesh.waterline])
    world = (mesh.vertices - pivot) @ tilt_matrix(roll, pitch).T + pivot
    normals_world = _face_normals(world, mesh.faces)

    n = size * supersample
    pitch_px = metres_per_pixel / supersample
    cam = world @ basis.T  # (V, 3): right, up, toward
    sx = cam[:, 0] / pitch_px + n / 2.0
    sy = -cam[:, 1] / pitch_px + n / 2.0
    depth = cam[:, 2]  # larger = nearer the camera

    n_cam = normals_world @ basis.T
    facing = n_cam[:, 2]
    if mesh.closed:
        keep = facing > 1e-9  # back faces of closed surfaces are never visible
    else:
        keep = np.abs(facing) > 1e-9
        n_cam = np.where(facing[:, None] < 0, -n_cam, n_cam)  # two-sided
    faces = mesh.faces[keep]
    tri_ids = np.flatnonzero(keep)

    key = _zbuffer(sx, sy, depth, faces, n)
    hit = np.flatnonzero(key != _EMPTY)
    tri = key[hit] & 0xFFFFFFFF  # index into the kept faces
    tri_global = tri_ids[tri]

    covered = np.zeros(n * n, bool)
    covered[hit] = True
    colours = np.zeros((n * n, 3), np.float32)
    colours[hit] = mesh.face_colors[tri_global]
    normals = np.zeros((n * n, 3), np.float32)
    normals[hit] = n_cam[tri_global]
    # visible-surface world height from the triangle's plane, at sub-pixel centres
    ys, xs = np.divmod(hit, n)
    heights = np.zeros(n * n, np.float32)
    heights[hit] = _plane_eval(sx, sy, world[:, 2] - mesh.waterline, faces[tri],
                               xs + 0.5, ys + 0.5)
    covered, colours = covered.reshape(n, n), colours.reshape(n, n, 3)
    normals, heights = normals.reshape(n, n, 3), heights.reshape(n, n)
    return _downsample(covered, colours, normals, heights, size, supersample)


def _face_normals(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    tri = vertices[faces]
    nrm = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    length = np.linalg.norm(nrm, axis=1, keepdims=True)
    return np.divide(nrm, length, out=np.zeros_like(nrm), where=length > 0)


def _triangle_setup(sx, sy, faces):
    """Per-triangle screen coordinates with counter-clockwise winding and twice the area."""
    x = sx[faces]
    y = sy[faces]
    area2 = (x[:, 1] - x[:, 0]) * (y[:, 2] - y[:, 0]) - (x[:, 2] - x[:, 0]) * (y[:, 1] - y[:, 0])
    return x, y, area2


def _zbuffer(sx, sy, depth, faces, n) -> np.ndarray:
    """(n*n,) int64 z-buffer: per sub-pixel, (quantised distance << 32 | triangle index).

    The smallest key is the nearest triangle; empty sub-pixels hold ``_EMPTY``.
    """
    zbuf = np.full(n * n, _EMPTY, dtype=np.int64)
    if len(faces) == 0:
        return zbuf
    x, y, area2 = _triangle_setup(sx, sy, faces)
    ok = np.abs(area2) > 1e-12
    # pixel centres i + 0.5 inside [min, max]
    x0 = np.clip(np.ceil(x.min(axis=1) - 0.5), 0, n).astype(np.int64)
    x1 = np.clip(np.floor(x.max(axis=1) - 0.5), -1, n - 1).astype(np.int64)
    y0 = np.clip(np.ceil(y.min(axis=1) - 0.5), 0, n).astype(np.int64)
    y1 = np.clip(np.floor(y.max(axis=1) - 0.5), -1, n - 1).astype(np.int64)
    w = np.where(ok, np.maximum(x1 - x0 + 1, 0), 0)
    h = np.where(ok, np.maximum(y1 - y0 + 1, 0), 0)
    count = w * h
    tris = np.flatnonzero(count)
    if len(tris) == 0:
        return zbuf
    # barycentric coordinates are affine in (px, py): l_k = a_k px + b_k py + c_k
    inv = 1.0 / area2[tris]
    xt, yt = x[tris], y[tris]
    coef = np.empty((len(tris), 3, 3))
    for k in range(3):
        i, j = (k + 1) % 3, (k + 2) % 3
        coef[:, k, 0] = (yt[:, i] - yt[:, j]) * inv
        coef[:, k, 1] = (xt[:, j] - xt[:, i]) * inv
        coef[:, k, 2] = (xt[:, i] * yt[:, j] - xt[:, j] * yt[:, i]) * inv
    d = depth[faces[tris]]
    dz = np.einsum("tkc,tk->tc", coef, d)  # depth plane: dz0 px + dz1 py + dz2
    dmax = float(depth.max())
    scale = (2**30) / max(float(depth.max() - depth.min()), 1e-12)

    counts = count[tris]
    ends = np.cumsum(counts)
    start = 0
    while start < len(tris):
        base = ends[start - 1] if start else 0
        stop = int(np.searchsorted(ends, base + _CHUNK, side="right"))
        stop = max(stop, start + 1)
        sl = slice(start, stop)
        c = counts[sl]
        local_t = np.repeat(np.arange(stop - start), c)
        offs = np.arange(int(c.sum())) - np.repeat(np.cumsum(c) - c, c)
        ww = w[tris[sl]][local_t]
        qy, qx = np.divmod(offs, ww)
        px = x0[tris[sl]][local_t] + qx
        py = y0[tris[sl]][local_t] + qy
        fx = px + 0.5
        fy = py + 0.5
        cf = coef[sl][local_t]
        eps = -1e-7
        inside = np.ones(len(px), dtype=bool)
        for k in range(3):
            inside &= cf[:, k, 0] * fx + cf[:, k, 1] * fy + cf[:, k, 2] >= eps
        dzs = dz[sl][local_t[inside]]
        dd = dzs[:, 0] * fx[inside] + dzs[:, 1] * fy[inside] + dzs[:, 2]
        q = np.clip((dmax - dd) * scale, 0, 2**31 - 1).astype(np.int64)
        keys = (q << 32) | tris[sl][local_t[inside]]
        np.minimum.at(zbuf, py[inside] * n + px[inside], keys)
        start = stop
    return zbuf


def _plane_eval(sx, sy, values, tri_faces, fx, fy) -> np.ndarray:
    """Interpolate per-vertex ``values`` linearly over triangle ``tri_faces[i]`` (vertex
    indices) at screen point (fx[i], fy[i])."""
    x = sx[tri_faces]
    y = sy[tri_faces]
    v = values[tri_faces]
    area2 = (x[:, 1] - x[:, 0]) * (y[:, 2] - y[:, 0]) - (x[:, 2] - x[:, 0]) * (y[:, 1] - y[:, 0])
    area2 = np.where(np.abs(area2) > 1e-12, area2, 1.0)
    out = np.zeros(len(tri_faces))
    for k in range(3):
        i, j = (k + 1) % 3, (k + 2) % 3
        lam = ((y[:, i] - y[:, j]) * fx + (x[:, j] - x[:, i]) * fy
               + x[:, i] * y[:, j] - x[:, j] * y[:, i]) / area2
        out += lam * v[:, k]
    return out


def _downsample(covered, colours, normals, heights, size, ss) -> Sprite:
    """Average ss x ss blocks of sub-pixels into output pixels."""
    cov = covered.reshape(size, ss, size, ss)
    count = cov.sum(axis=(1, 3)).astype(np.float32)
    alpha = count / float(ss * ss)
    mask = count > 0
    denom = np.maximum(count, 1.0)
    w = cov[..., None].astype(np.float32)

    def mean(a):
        a = a.reshape(size, ss, size, ss, -1) * w
        return a.sum(axis=(1, 3)) / denom[..., None]

    albedo = np.where(mask[..., None], np.clip(np.rint(mean(colours)), 0, 255), 0).astype(np.uint8)
    nsum = mean(normals)
    length = np.linalg.norm(nsum, axis=-1, keepdims=True)
    normal = np.divide(nsum, length, out=np.zeros_like(nsum), where=length > 1e-6)
    height = np.where(mask, mean(heights[..., None])[..., 0], 0.0).astype(np.float32)
    return Sprite(alpha=alpha, albedo=albedo, normal=normal.astype(np.float32),
                  height=height, mask=mask)
