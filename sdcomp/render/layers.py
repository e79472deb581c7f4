"""Layers: every floating object of a scene as an atlas sprite placed, lit and submerged.

For each placement: the stored pose nearest to the view of the (tilted) body
(:func:`sprite_view`), the camera's projection linearised at the object (scale, rotation,
foreshortening: a 2x3 affine map from sprite to image pixels), the mip level suited to that
scale, the sprite's colour lit by the sun, the sky and the sea with the parts under a wavy
waterline seen through the water (:func:`shade`), its weight for the mask rule, and its shadow
in the water (:func:`shadow`). The derivations are in docs/architecture.md.
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
from .foam import (
    FOAM_ALBEDO,
    FoamRing,
    contact_foam,
    draw_ring,
    ring_share,
    ring_strength,
    splash_strength,
)
from .gloss import add_gloss, roughness
from .lighting import Lighting, irradiance_terms, lambert
from .submerge import (
    BLUR_PER_METRE,
    LUMA,
    WaterColumn,
    refract,
    submerge,
    water_columns,
    waterline_level,
)
from .wake import place_wake, wake_cover
from .water.optics import N_WATER

RIPPLE_LENGTH = 0.6  # metres: wavelength of the waves that make a waterline wavy


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
    full_area: float = 0.0  # pixels: the whole projected silhouette, inside the frame or not


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


def shade(out: np.ndarray, prepared: tuple, height: np.ndarray, view: SpriteView,
          pl: Placement, scene: Scene, lit: Lighting, column: WaterColumn,
          pitch_m: float, ripple_seed: tuple[int, int]) -> np.ndarray:
    """Write the lit, submerged, premultiplied sRGB colour (0..255) of a sprite level
    ``prepared`` (:meth:`SpriteSource.prepared`) to ``out[..., :3]`` and its weight to
    ``out[..., 4]``; ``out`` is (n, n, 5) float32, ``height`` (n, n) float32 metres above
    the sea level of the floating body, ``pitch_m`` metres per sprite pixel,
    ``ripple_seed`` the seed of its waterline's ripples. Returns the depth (n, n) float32
    of each pixel under the wavy surface, metres (negative: above it).

    Linear radiance: Lambertian under the sun, the sky and the sea's upwelling light
    (:func:`~sdcomp.render.lighting.lambert`) with a glossy surface's mirrored sky and sun
    highlight (:func:`~sdcomp.render.gloss.add_gloss`) above a wavy waterline; below it,
    lit by the refracted sun and seen through the water (:func:`~sdcomp.render.submerge.submerge`);
    hazed with the distance; times the exposure gain, then sRGB."""
    alpha, albedo, normal = prepared[:3]
    water = lit.water
    to_view = (view.basis @ view.rot.T).astype(np.float32)  # world -> the pose's frame
    up_dir = to_view[:, 2]
    sun, sky, up = irradiance_terms(water, column.sun, column.deep)
    tinted = albedo * np.asarray(pl.tint, np.float32)
    sun_pose = to_view @ lit.sun.astype(np.float32)
    above = lambert(tinted, normal, sun_pose, up_dir, sun, sky, up)
    if (rough := roughness(pl.asset)) is not None:
        add_gloss(above, alpha, normal, to_view.T, sun_pose, sun, lit.sky_table,
                  up / np.float32(math.pi), rough)
    params = scene.water
    ripples = waterline_level(height.shape, pitch_m, ripple_height(params.wind),
                              RIPPLE_LENGTH, ripple_seed)
    depth = (np.float32(pl.draft) + ripples) - height
    if float(depth.max()) > -0.02:
        below = lambert(tinted, normal, to_view @ column.sun_dir.astype(np.float32), up_dir,
                        sun, sky, up)
        lin, weight = submerge(above, below, alpha, depth, column, pitch_m,
                               BLUR_PER_METRE + 0.25 * slope_sd(params.wind))
    else:
        lin, weight = above, alpha
    haze = math.exp(-float(np.linalg.norm(scene.camera.position - np.array([pl.x, pl.y, 0.0])))
                    / params.visibility)
    if haze < 0.999:
        lin = lin * np.float32(haze) + water.sky.horizon_rgb * np.float32(1.0 - haze)
    lin *= np.float32(water.gain)
    out[..., 4] = weight
    np.multiply(linear_to_srgb(lin), (255.0 * alpha)[..., None], out=out[..., :3])
    return depth


def slope_sd(wind: float) -> float:
    """Standard deviation of the sea's slope along one axis at ``wind`` m/s (Cox & Munk
    1954, clean surface: mean square slope 0.003 + 0.00512 U)."""
    return math.sqrt((0.003 + 0.00512 * max(wind, 0.0)) / 2.0)


def ripple_height(wind: float) -> float:
    """Standard deviation (metres) of the waves shorter than an object that run along its
    hull: slope times wavelength over 2 pi at :data:`RIPPLE_LENGTH`."""
    return slope_sd(wind) * RIPPLE_LENGTH / (2 * math.pi)


def shadow(view: SpriteView, model: CameraModel, scene: Scene, lit: Lighting,
           column: WaterColumn, size_m: float) -> tuple[tuple[float, float], float, float]:
    """The object's shadow in the water: (offset pixels, strength, blur sigma pixels).

    What a shadow takes away is the direct sun's share of the light scattered back up by
    the water under it (or reflected by a shallow bottom): that light comes from a depth of
    about ``1 / (2 K_d)`` (or the bottom's), where the shadow lies displaced away from the
    sun along the refracted sun ray and spread by scattering, so a shadow is strong and
    sharp in turbid water and faint and diffuse in clear water. ``size_m`` is the object's
    size across, metres."""
    water = lit.water
    s = lit.sun
    l_w = column.deep
    e_dir = column.sun * max(float(s[2]), 0.0)
    e_all = e_dir + water.sky_irradiance
    lum = LUMA.astype(np.float64)
    share = float(e_dir @ lum) / max(float(e_all @ lum), 1e-9)
    if share <= 0.01:
        return (0.0, 0.0), 0.0, 0.0
    from_water = float(l_w @ lum) / max(float((l_w + column.reflection) @ lum), 1e-9)
    kd = float(np.mean(water.diffuse_attenuation))
    z = 1.0 / (2.0 * max(kd, 1e-3))
    if scene.water.depth is not None:
        z = min(z, scene.water.depth)
    sw = column.sun_dir
    sun_h = max(math.hypot(float(sw[0]), float(sw[1])), 1e-9)
    drift = z * sun_h / max(float(sw[2]), 0.05)  # metres: horizontal shift at depth z
    spread = 0.3 * z + 0.5 * drift
    off = view.jac @ np.array([-sw[0] / sun_h * drift, -sw[1] / sun_h * drift,
                               -z / N_WATER])
    strength = share * from_water * size_m / (size_m + spread)
    blur = max(spread * model.fx / view.depth, 0.0)
    return (float(off[0]), float(off[1])), float(strength), blur


def make_layers(i: int, pl: Placement, src: SpriteSource, view: SpriteView, scene: Scene,
                lit: Lighting, column: WaterColumn) -> tuple[Layer, list[FoamRing]]:
    """Placement ``i`` of ``scene`` drawn from ``src`` as a :class:`Layer`, seen as ``view``
    (:func:`sprite_view`) through the water ``column``, and the foam it makes on the water:
    the ring around its waterline (:func:`foam_ring`) and its wake when it moves
    (:func:`wake_foam`)."""
    model = scene.model
    prepared = src.prepared(view.pose, view.level)
    height = prepared[3]
    if pl.roll or pl.pitch:
        height = tilted_heights(height, view.basis, src, view.level, view.rot[2])
    pitch_m = src.metres_per_pixel * (1 << view.level)
    # channels: premultiplied sRGB colour (3), coverage, weight
    stack = np.empty(prepared[0].shape + (5,), np.float32)
    stack[..., 3] = prepared[0]
    depth = shade(stack, prepared, height, view, pl, scene, lit, column, pitch_m,
                  (scene.water.seed, i))
    stack = refract(stack, depth, (view.basis @ view.rot.T)[:, 2], pitch_m)
    x0, y0, x1, y1 = view.roi
    warped = cv2.warpAffine(stack, view.affine, (x1 - x0, y1 - y0), flags=cv2.INTER_LINEAR,
                            borderMode=cv2.BORDER_CONSTANT, borderValue=0)
    if warped.ndim == 2:
        warped = warped[..., None]
    # coverage and weight: bilinear mixes of values in [0, 1] with weights >= 0 summing
    # to 1 (within rounding): capped at 1 in place
    coverage = warped[..., 3:5]
    np.minimum(coverage, 1.0, out=coverage)
    size_m = math.sqrt(float(prepared[0].sum())) * pitch_m
    offset, strength, blur = shadow(view, model, scene, lit, column, size_m)
    a = view.affine
    # the silhouette as the surface shows it (refracted), inside the frame or not
    full = float(stack[..., 3].sum()) * abs(float(a[0, 0] * a[1, 1] - a[0, 1] * a[1, 0]))
    layer = Layer(i, pl.role, pl.category_id, view.depth, view.roi, warped[..., :3],
                  warped[..., 3], warped[..., 4], offset, strength, blur, full)
    foam = [foam_ring(i, view, prepared[0], depth, pitch_m, scene, lit, column),
            wake_foam(i, pl, view, size_m, src.waterline, scene, lit, column)]
    return layer, [f for f in foam if f is not None]


def foam_ring(i: int, view: SpriteView, alpha: np.ndarray, depth: np.ndarray,
              pitch_m: float, scene: Scene, lit: Lighting, column: WaterColumn
              ) -> FoamRing | None:
    """The contact foam around placement ``i``'s waterline (:func:`contact_foam`): the
    waves' froth against a body that stands in their way (:func:`ring_share`), or the
    splash of one moving through the water (:func:`splash_strength`), whichever is
    stronger; lit like the water's surface, placed in the frame; None when there is
    none."""
    dry_m = math.sqrt(float(np.count_nonzero((alpha >= 0.5) & (depth < 0.0)))) * pitch_m
    strength = max(ring_strength(scene.water.wind) * ring_share(dry_m),
                   splash_strength(scene.placements[i].speed))
    ring = contact_foam(alpha, depth, pitch_m, strength, (scene.water.seed, i))
    if ring is None:
        return None
    pad, cover = ring
    placed = canvas_placement(view.to_frame, alpha.shape[0], pad, scene.model)
    if placed is None:
        return None
    affine, roi = placed
    return FoamRing(view.depth, cover, affine, roi, foam_colour(lit, column))


def foam_colour(lit: Lighting, column: WaterColumn) -> tuple[float, ...]:
    """sRGB levels (0..255, 3 floats) of foam on the water at an object: a diffuse white of
    :data:`FOAM_ALBEDO` under the sun and sky there, at the image's exposure."""
    water = lit.water
    e = column.sun * max(float(lit.sun[2]), 0.0) + water.sky_irradiance
    lin = np.clip(e * (FOAM_ALBEDO / math.pi * water.gain), 0.0, 1.0)
    return tuple(float(v) for v in linear_to_srgb(lin.astype(np.float32)) * 255.0)


def wake_foam(i: int, pl: Placement, view: SpriteView, size_m: float, waterline: float,
              scene: Scene, lit: Lighting, column: WaterColumn) -> FoamRing | None:
    """The wake of placement ``i`` moving at ``pl.speed`` m/s along its heading
    (:func:`wake_cover`, hull about 1.4 x 0.7 ``size_m``), one raster pixel about one frame
    pixel, placed on the water in the frame (``waterline``: metres from the body origin up
    to its waterline); None when it has none or misses the frame."""
    if pl.speed <= 0:
        return None
    track = view.rot[:2, 0] / max(float(np.hypot(*view.rot[:2, 0])), 1e-9)
    jac = view.jac[:, :2]
    across = np.array([-track[1], track[0]])
    px_per_m = max(float(np.hypot(*(jac @ track))), float(np.hypot(*(jac @ across))))
    made = wake_cover(1.4 * size_m, 0.7 * size_m, pl.speed, 1.0 / max(px_per_m, 1e-6),
                      (scene.water.seed, i, 1))
    if made is None:
        return None
    cover, u0, v0, res = made
    # the object's centre on the water: the body origin raised to the surface
    lift = waterline * view.rot[:, 2] + np.array([0.0, 0.0, pl.draft])
    centre = np.asarray(view.centre) + view.jac @ lift
    placed = place_wake(cover.shape, u0, v0, res, track, jac, centre, scene.model.width,
                        scene.model.height)
    if placed is None:
        return None
    affine, roi = placed
    return FoamRing(view.depth, cover, affine, roi, foam_colour(lit, column))


def build_layers(scene: Scene, lit: Lighting, sprites: Mapping[str, SpriteSource],
                 foam_onto: np.ndarray | None = None) -> list[Layer]:
    """The layers of every placement in the frame (but the scene's ``hidden`` ones), far to
    near; ``sprites`` maps asset
    keys to their sprites. The foam rings are drawn on ``foam_onto`` (the uint8 (H, W, 3)
    background, in place) as they are made, far first: under every object, so they never
    change a mask, and never held (a ring round a large object in a huge frame is
    gigabytes of layer); none without ``foam_onto``."""
    seen = []
    for i, pl in enumerate(scene.placements):
        if i in scene.hidden:
            continue
        src = sprites[pl.asset]
        view = sprite_view(scene.model, lit, scene.camera.position, pl, src)
        if view is not None:
            seen.append((i, pl, src, view))
    if not seen:
        return []
    local = [lit.water.at(*view.centre) for *_, view in seen]  # (sun, l_w) at each
    columns = water_columns(lit.water, np.array([view.towards_camera for *_, view in seen]),
                            np.array([lw for _, lw in local]), np.array([s for s, _ in local]),
                            slope_sd(scene.water.wind))
    made = [make_layers(i, pl, src, view, scene, lit, column)
            for (i, pl, src, view), column in zip(seen, columns, strict=True)]
    if foam_onto is not None:
        rings = sorted((ring for _, foam in made for ring in foam), key=lambda r: -r.depth)
        for ring in rings:
            draw_ring(foam_onto, ring)
    layers = [layer for layer, _ in made]
    layers.sort(key=lambda lay: -lay.depth)  # far first
    return layers
