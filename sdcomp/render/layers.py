"""Layers: every floating object of a scene as an atlas sprite placed, lit and submerged.

For each placement: the stored pose nearest to the view of the (tilted) body
(:func:`sprite_view`), the camera's projection linearised at the object (scale, rotation,
foreshortening: a 2x3 affine map from sprite to image pixels), the mip level suited to that
scale, the sprite's colour relit by the sun with the parts under the waterline attenuated and
tinted by the water (:func:`shade`), its weight for the mask rule, and its shadow on the water
(:func:`shadow`). The derivations are in docs/architecture.md.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import cv2
import numpy as np

from ..atlas.poses import tilt_matrix
from ..atlas.sprites import SpriteSource
from ..scene.camera import CameraModel, local_projection
from ..scene.scene import Placement, Role, Scene
from ..util.colour import linear_to_srgb
from .lighting import SUN, Lighting
from .optics import REFRACTIVE_INDEX, fresnel, refracted_cos, sky_linear


@dataclass
class Layer:
    """One sprite placed in the frame. Arrays cover ``roi`` = (x0, y0, x1, y1) pixels.

    ``weight`` is the fraction of each pixel's colour that comes from the object itself:
    coverage times the water's transmittance, then times ``1 - coverage`` of every nearer
    layer (:func:`sdcomp.render.composite.over`); :mod:`sdcomp.annotate` makes the masks
    from it."""

    placement: int  # index into scene.placements
    role: Role
    category_id: int
    depth: float  # metres along the optical axis
    roi: tuple[int, int, int, int]
    colour: np.ndarray  # (h, w, 3) float32 premultiplied sRGB 0..255
    alpha: np.ndarray  # (h, w) float32 coverage
    weight: np.ndarray  # (h, w) float32
    shadow_offset: tuple[float, float]  # pixels
    shadow_strength: float  # fraction of the light the shadow takes away
    shadow_blur: float  # pixels (Gaussian sigma)


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
    # the sprite's corners (-0.5 and n - 0.5 in each direction) in the frame
    lo, hi = -0.5, n - 0.5
    xs = [a00 * p + a01 * q + tx for p in (lo, hi) for q in (lo, hi)]
    ys = [a10 * p + a11 * q + ty for p in (lo, hi) for q in (lo, hi)]
    x0 = max(math.floor(min(xs)), 0)
    y0 = max(math.floor(min(ys)), 0)
    x1 = min(math.ceil(max(xs)) + 1, model.width)
    y1 = min(math.ceil(max(ys)) + 1, model.height)
    if x1 <= x0 or y1 <= y0:
        return None
    affine = np.array([[a00, a01, tx - x0], [a10, a11, ty - y0]], np.float32)
    return SpriteView(pose_i, level, rot, vb, d_world, (u0, v0), z, jac, affine,
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


def shade(out: np.ndarray, prepared: tuple, height: np.ndarray, view: SpriteView,
          pl: Placement, scene: Scene, lit: Lighting) -> None:
    """Write the relit, submerged, premultiplied sRGB colour (0..255) of a sprite level
    ``prepared`` (:meth:`SpriteSource.prepared`) to ``out[..., :3]`` and its weight
    (coverage x water transmittance) to ``out[..., 4]``; ``out`` is (n, n, 5) float32,
    ``height`` (n, n) float32 metres above the sea level of the floating body.

    In linear RGB, with ``t`` the water's transmittance down to a pixel and back, ``r`` the
    Fresnel reflectance toward the camera and ``u`` 1 under water, 0 above:
    ``albedo x light x t x (1 - r u) + body x (1 - r) x (1 - t) + sky x r u``, times the
    camera gain.
    """
    alpha, albedo, normal = prepared[:3]
    sun, wb, body = lit.sun, lit.wb, lit.body
    sun_view = (view.basis @ (view.rot.T @ sun)).astype(np.float32)
    light = normal @ sun_view
    np.maximum(light, 0.0, out=light)
    light *= np.float32(SUN * 0.5 * float(sun[2] > 0))
    light += np.float32(scene.ambient)
    w, h = scene.model.width, scene.model.height
    u0, v0 = view.centre
    r2 = ((u0 - w / 2) ** 2 + (v0 - h / 2) ** 2) / ((w / 2) ** 2 + (h / 2) ** 2)
    gain = wb * np.float32(1.0 - scene.effects.vignetting * min(r2, 1.0))
    cz = float(view.towards_camera[2])
    r = float(fresnel(cz))
    k = scene.attenuation * (1.0 / float(refracted_cos(cz)) + 1.0 / lit.cos_sun_t)
    depth = np.subtract(np.float32(pl.draft), height)  # metres under the surface
    np.maximum(depth, 0.0, out=depth)
    under = depth > 0
    trans = np.exp(depth * np.float32(-k))
    np.multiply(alpha, trans, out=out[..., 4])
    light *= trans
    light *= 1.0 - np.float32(r) * under
    lin = albedo * (np.asarray(pl.tint, np.float32) * gain)
    lin *= light[..., None]
    # + (1 - t) x body x (1 - r) + u x sky x r: one (n, n, 2) @ (2, 3) product
    terms = np.stack([1.0 - trans, under], axis=-1, dtype=np.float32)
    lin += terms @ np.stack([body * gain * np.float32(1.0 - r),
                             sky_linear(cz) * gain * np.float32(r)])
    np.multiply(linear_to_srgb(lin), (255.0 * alpha)[..., None], out=out[..., :3])


def shadow(view: SpriteView, model: CameraModel, scene: Scene, lit: Lighting
           ) -> tuple[tuple[float, float], float, float]:
    """The object's shadow on the water: (offset pixels, strength, blur sigma pixels).

    It falls under water at the depth light scatters back from (or on the floor in clear
    water), displaced away from the sun."""
    c = scene.attenuation
    d_s = min(1.0 / c, scene.floor_depth)
    sx, sy, _ = lit.sun.tolist()
    sun_h = max(math.hypot(sx, sy), 1e-9)
    k = d_s * (sun_h / REFRACTIVE_INDEX) / max(lit.cos_sun_t, 0.05) / sun_h
    off = view.jac @ np.array([-sx * k, -sy * k, -d_s / REFRACTIVE_INDEX])
    t_floor = math.exp(-c * scene.floor_depth * 2)
    strength = 0.45 * (1 - math.exp(-2 * c * d_s)) + 0.45 * t_floor
    blur = min(max(0.08 * d_s * model.fx / view.depth, 0.0), 12.0)  # metres / (m per px)
    return (float(off[0]), float(off[1])), float(strength), blur


def make_layer(i: int, pl: Placement, src: SpriteSource, scene: Scene, lit: Lighting
               ) -> Layer | None:
    """Placement ``i`` of ``scene`` drawn from ``src`` as a :class:`Layer`; None when it is
    not in the frame."""
    model = scene.model
    view = sprite_view(model, lit, scene.camera.position, pl, src)
    if view is None:
        return None
    prepared = src.prepared(view.pose, view.level)
    height = prepared[3]
    if pl.roll or pl.pitch:
        height = tilted_heights(height, view.basis, src, view.level, view.rot[2])
    # channels: premultiplied sRGB colour (3), coverage, weight
    stack = np.empty(prepared[0].shape + (5,), np.float32)
    stack[..., 3] = prepared[0]
    shade(stack, prepared, height, view, pl, scene, lit)
    x0, y0, x1, y1 = view.roi
    warped = cv2.warpAffine(stack, view.affine, (x1 - x0, y1 - y0), flags=cv2.INTER_LINEAR,
                            borderMode=cv2.BORDER_CONSTANT, borderValue=0)
    if warped.ndim == 2:
        warped = warped[..., None]
    # coverage and weight: bilinear mixes of values in [0, 1] with weights >= 0 summing
    # to 1 (within rounding): capped at 1 in place
    coverage = warped[..., 3:5]
    np.minimum(coverage, 1.0, out=coverage)
    offset, strength, blur = shadow(view, model, scene, lit)
    return Layer(i, pl.role, pl.category_id, view.depth, view.roi, warped[..., :3],
                 warped[..., 3], warped[..., 4], offset, strength, blur)


def build_layers(scene: Scene, lit: Lighting, sprites: Mapping[str, SpriteSource]
                 ) -> list[Layer]:
    """The layers of every placement in the frame, far to near; ``sprites`` maps asset
    keys to their sprites."""
    layers = []
    for i, pl in enumerate(scene.placements):
        layer = make_layer(i, pl, sprites[pl.asset], scene, lit)
        if layer is not None:
            layers.append(layer)
    layers.sort(key=lambda lay: -lay.depth)  # far first
    return layers
