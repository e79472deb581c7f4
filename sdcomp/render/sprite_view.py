"""Where a placement's sprite lands in the frame: the stored pose nearest to the view of the
(tilted) body, the camera's projection linearised at the object (scale, rotation,
foreshortening: a 2x3 affine map from sprite to image pixels) and the mip level suited to
that scale; and the heights of a tilted body. The derivations are in docs/architecture.md.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..atlas.poses import tilt_matrix
from ..atlas.sprites import SpriteSource
from ..scene.camera import CameraModel, local_projection
from ..scene.scene import Placement
from .lighting import Lighting


@dataclass(frozen=True)
class SpriteView:
    """Where and how a placement's sprite lands in the frame (see :func:`sprite_view`)."""

    pose: int  # index of the atlas pose
    level: int  # mip level
    rot: np.ndarray  # (3, 3) body -> world rotation (heading and tilt)
    basis: np.ndarray  # (3, 3) rows right, up, toward of the pose in the body frame
    towards_camera: np.ndarray  # (3,) unit vector from the object to the camera, world
    centre: tuple[float, float]  # the body origin's image position, pixels
    depth: float  # metres along the optical axis
    jac: np.ndarray  # (2, 3) image pixels per world metre at the object
    to_frame: np.ndarray  # (2, 3) float64 sprite pixels -> frame pixels
    affine: np.ndarray  # (2, 3) float32 sprite pixels -> roi pixels
    roi: tuple[int, int, int, int]  # x0, y0, x1, y1 pixels, inside the frame


def body_rotation(pl: Placement) -> np.ndarray:
    """(3, 3) rotation from the placement's body frame to the world: heading, then tilt."""
    hd = math.radians(pl.heading)
    rz = np.array([[math.cos(hd), -math.sin(hd), 0], [math.sin(hd), math.cos(hd), 0],
                   [0, 0, 1]])
    return rz @ tilt_matrix(pl.roll, pl.pitch)


def sprite_view(model: CameraModel, lit: Lighting, camera: np.ndarray, pl: Placement,
                src: SpriteSource) -> SpriteView | None:
    """The view of placement ``pl`` from the camera at ``camera`` (3,) metres: None when it
    is behind the camera or outside the frame."""
    rot = body_rotation(pl)
    origin = np.array([pl.x, pl.y, -pl.draft]) - src.waterline * rot[:, 2]
    to_cam = camera - origin
    d_world = to_cam / math.sqrt(float(to_cam @ to_cam))
    pose_i = src.nearest(d_world @ rot)  # rot.T @ d_world
    vb = src.bases[pose_i]  # rows right, up, toward in the body frame
    proj = local_projection(model, lit.basis, -to_cam)
    if proj is None:
        return None
    u0, v0, z, jac = proj
    # (2, 2): image pixels per sprite pixel along the sprite's right and down
    a = (jac @ rot) @ (vb[:2].T * np.array([src.metres_per_pixel,
                                            -src.metres_per_pixel]))
    scale = math.sqrt(abs(a[0, 0] * a[1, 1] - a[0, 1] * a[1, 0]))
    if scale <= 0:
        return None
    level = min(max(math.floor(math.log2(1.0 / scale)), 0), src.max_level) \
        if scale < 1 else 0
    n = src.size >> level
    (a00, a01), (a10, a11) = (a * (1 << level)).tolist()
    c = 0.5 - n / 2
    tx, ty = u0 - 0.5 + (a00 + a01) * c, v0 - 0.5 + (a10 + a11) * c
    to_frame = np.array([[a00, a01, tx], [a10, a11, ty]])
    placed = canvas_placement(to_frame, n, 0, model)
    if placed is None:
        return None
    affine, roi = placed
    return SpriteView(pose_i, level, rot, vb, d_world, (u0, v0), z, jac, to_frame, affine,
                      roi)


def canvas_placement(to_frame: np.ndarray, n: int, pad: int, model: CameraModel
                     ) -> tuple[np.ndarray, tuple[int, int, int, int]] | None:
    """(affine (2, 3) float32 canvas pixels -> roi pixels, roi (x0, y0, x1, y1) inside the
    frame) of an (n + 2 pad)-pixel square canvas whose pixel ``pad`` is the sprite's pixel 0
    (``to_frame``: sprite pixels -> frame pixels); None when it misses the frame."""
    (a00, a01, tx), (a10, a11, ty) = to_frame.tolist()
    tx, ty = tx - (a00 + a01) * pad, ty - (a10 + a11) * pad
    # the canvas's corners (-0.5 and n + 2 pad - 0.5 in each direction) in the frame
    lo, hi = -0.5, n + 2 * pad - 0.5
    xs = [a00 * p + a01 * q + tx for p in (lo, hi) for q in (lo, hi)]
    ys = [a10 * p + a11 * q + ty for p in (lo, hi) for q in (lo, hi)]
    x0 = max(math.floor(min(xs)), 0)
    y0 = max(math.floor(min(ys)), 0)
    x1 = min(math.ceil(max(xs)) + 1, model.width)
    y1 = min(math.ceil(max(ys)) + 1, model.height)
    if x1 <= x0 or y1 <= y0:
        return None
    return (np.array([[a00, a01, tx - x0], [a10, a11, ty - y0]], np.float32),
            (x0, y0, x1, y1))


def tilted_heights(height: np.ndarray, vb: np.ndarray, src: SpriteSource, level: int,
                   row: np.ndarray) -> np.ndarray:
    """(n, n) float32 heights above the sea of the body tilted by the placement's roll and
    pitch, from the level body's ``height`` (n, n) float32 of a sprite of mip ``level``;
    ``vb`` (3, 3) is the pose's basis (rows right, up, toward, body frame) and ``row`` (3,)
    the last row of the body's rotation. Linear in (x, y, h): ``h * k + plane(x, y)``
    (derivation in docs/architecture.md; uncovered pixels get a height too, unused)."""
    n = height.shape[0]
    pitch_m = src.metres_per_pixel * (1 << level)
    c = (np.arange(n, dtype=np.float32) + np.float32(0.5 - n / 2)) * np.float32(pitch_m)
    wl = src.waterline
    r_, u_, t_ = vb
    k = float(t_ @ row) / max(float(t_[2]), 1e-3)
    kx = float(r_ @ row) - k * float(r_[2])
    ky = float(u_ @ row) - k * float(u_[2])
    const = k * wl - wl * float(row[2])
    # x = c along columns, y = -c along rows
    tilted = height * np.float32(k)
    tilted += (c * np.float32(kx))[None, :]
    tilted += (c * np.float32(-ky) + np.float32(const))[:, None]
    return tilted
