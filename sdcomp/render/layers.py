"""Layers: every floating object of a scene as an atlas sprite placed, lit and submerged.

For each placement: where its sprite lands in the frame (:mod:`.sprite_view`: pose, mip
level, the affine map from sprite to image pixels), the sprite's colour lit by the sun, the
sky and the sea with the parts under a wavy waterline seen through the water
(:func:`shade`), its weight for the mask rule, its shadow in the water (:func:`shadow`: as
long as the object is tall, :func:`shadow_step`) and the foam it makes on the water (contact
foam, a swimmer's stirred water, splash, wake). The derivations are in
docs/architecture.md.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import cv2
import numpy as np

from ..atlas.sprites import SpriteSource
from ..scene.camera import CameraModel
from ..scene.objects import stirring
from ..scene.scene import Placement, Role, Scene
from ..util.colour import linear_to_srgb
from .foam import (
    FOAM_ALBEDO,
    RING_WIDTH,
    STIR_PEAK,
    STIR_WIDTH,
    FoamRing,
    contact_foam,
    draw_ring,
    ring_share,
    ring_strength,
    splash_strength,
)
from .gloss import add_gloss, roughness
from .lighting import Lighting, irradiance_terms, lambert
from .sprite_view import SpriteView, canvas_placement, sprite_view, tilted_heights
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
    #: fraction of the light the shadow takes away, per R, G, B channel (one float: the
    #: same in all three)
    shadow_strength: tuple[float, float, float] | float
    shadow_blur: float  # pixels (Gaussian sigma)
    full_area: float = 0.0  # pixels: the whole projected silhouette, inside the frame or not
    #: (h, w) float32 coverage times metres above the water (what casts the shadow's
    #: length), or None: the shadow is the silhouette alone
    shadow_height: np.ndarray | None = None
    shadow_step: tuple[float, float] = (0.0, 0.0)  # pixels the shadow moves per metre up
    #: sRGB levels (0..255, 3) of the water at the object as the renderer models it (deep
    #: water's light and the surface's reflection, exposed): what a submerged part's
    #: colour holds of water, replaced by the actual background where it is drawn
    #: (:func:`sdcomp.render.composite.over`); None: nothing to replace
    water_srgb: tuple[float, float, float] | None = None


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


def water_srgb(scene: Scene, pl: Placement, lit: Lighting, column: WaterColumn
               ) -> tuple[float, float, float]:
    """sRGB levels (0..255) of the water at placement ``pl`` as :func:`shade` models it
    (its deep water's light and the surface's reflected sky, hazed and exposed): what the
    colour of a part deep under the surface tends to."""
    params, water = scene.water, lit.water
    lin = np.asarray(column.deep, np.float64) + np.asarray(column.reflection, np.float64)
    haze = math.exp(-float(np.linalg.norm(scene.camera.position - np.array([pl.x, pl.y, 0.0])))
                    / params.visibility)
    if haze < 0.999:
        lin = lin * haze + np.asarray(water.sky.horizon_rgb, np.float64) * (1.0 - haze)
    lin = lin * float(water.gain)
    srgb = linear_to_srgb(lin.reshape(1, 1, 3).astype(np.float32)).reshape(3) * 255.0
    r, g, b = (float(v) for v in srgb)
    return r, g, b


def slope_sd(wind: float) -> float:
    """Standard deviation of the sea's slope along one axis at ``wind`` m/s (Cox & Munk
    1954, clean surface: mean square slope 0.003 + 0.00512 U)."""
    return math.sqrt((0.003 + 0.00512 * max(wind, 0.0)) / 2.0)


def ripple_height(wind: float) -> float:
    """Standard deviation (metres) of the waves shorter than an object that run along its
    hull: slope times wavelength over 2 pi at :data:`RIPPLE_LENGTH`."""
    return slope_sd(wind) * RIPPLE_LENGTH / (2 * math.pi)


def shadow(view: SpriteView, model: CameraModel, scene: Scene, lit: Lighting,
           column: WaterColumn, size_m: float
           ) -> tuple[tuple[float, float], tuple[float, float, float], float]:
    """The object's shadow in the water: (offset pixels, strength per R, G, B channel,
    blur sigma pixels).

    What a shadow takes away is the direct sun's share of the light scattered back up by
    the water under it (or reflected by a shallow bottom), channel by channel: the sun is
    warmer than the sky that still lights the shadow, and the sky's reflection on the
    surface stays, so a shadow on sunlit water is darker and bluer than the water around
    it. That light comes from a depth of about ``1 / (2 K_d)`` (or the bottom's), where
    the shadow lies displaced away from the sun along the refracted sun ray and spread by
    scattering, so a shadow is strong and sharp in turbid water and faint and diffuse in
    clear water. ``size_m`` is the object's size across, metres."""
    water = lit.water
    s = lit.sun
    l_w = np.asarray(column.deep, np.float64)
    e_dir = np.asarray(column.sun, np.float64) * max(float(s[2]), 0.0)
    e_all = e_dir + np.asarray(water.sky_irradiance, np.float64)
    lum = LUMA.astype(np.float64)
    if float(e_dir @ lum) / max(float(e_all @ lum), 1e-9) <= 0.01:
        return (0.0, 0.0), (0.0, 0.0, 0.0), 0.0
    share = e_dir / np.maximum(e_all, 1e-9)
    from_water = l_w / np.maximum(l_w + np.asarray(column.reflection, np.float64), 1e-9)
    kd = float(np.mean(water.diffuse_attenuation))
    z = 1.0 / (2.0 * max(kd, 1e-3))
    if scene.water.depth is not None:
        z = min(z, scene.water.depth)
    sw = column.sun_dir
    sun_h = max(math.hypot(float(sw[0]), float(sw[1])), 1e-9)
    drift = z * sun_h / max(float(sw[2]), 0.05)  # metres: horizontal shift at depth z
    spread = 0.15 * z + 0.25 * drift  # sharp near the surface: most light comes from there
    off = view.jac @ np.array([-sw[0] / sun_h * drift, -sw[1] / sun_h * drift,
                               -z / N_WATER])
    r, g, b = (float(v) for v in share * from_water * size_m / (size_m + spread))
    blur = max(spread * model.fx / view.depth, 0.0)
    return (float(off[0]), float(off[1])), (r, g, b), blur


def shadow_step(view: SpriteView, lit: Lighting) -> tuple[float, float]:
    """(dx, dy) frame pixels from a point's image to the image of the shadow it casts on
    the water, per metre of the point's height above it: the sun's ray through a point
    ``h`` metres up meets the water ``h / tan(elevation)`` metres away from the sun, ``h``
    lower (both seen through the camera's projection at the object, ``view.jac``); (0, 0)
    with the sun at or below 5 degrees."""
    s = np.asarray(lit.sun, np.float64)
    if s[2] <= math.sin(math.radians(5.0)):
        return 0.0, 0.0
    d = view.jac @ (-s / s[2])  # a point h up and its shadow: h (s / s_z) apart
    return float(d[0]), float(d[1])


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
    # channels: premultiplied sRGB colour (3), coverage, weight, coverage x metres above
    # the water (the shadow's caster)
    stack = np.empty(prepared[0].shape + (6,), np.float32)
    stack[..., 3] = prepared[0]
    depth = shade(stack, prepared, height, view, pl, scene, lit, column, pitch_m,
                  (scene.water.seed, i))
    np.multiply(prepared[0], np.maximum(-depth, 0.0), out=stack[..., 5])
    stack = refract(stack, depth, (view.basis @ view.rot.T)[:, 2], pitch_m)
    x0, y0, x1, y1 = view.roi
    # each warped on its own (contiguous): the colour is released once drawn, the shadow's
    # caster once cast (:func:`sdcomp.render.composite.composite`)
    colour, alpha, weight, caster = (_warp(stack[..., c], view.affine, (x1 - x0, y1 - y0))
                                     for c in (slice(0, 3), 3, 4, 5))
    # coverage and weight: bilinear mixes of values in [0, 1] with weights >= 0 summing
    # to 1 (within rounding): capped at 1 in place
    np.minimum(alpha, 1.0, out=alpha)
    np.minimum(weight, 1.0, out=weight)
    size_m = math.sqrt(float(prepared[0].sum())) * pitch_m
    offset, strength, blur = shadow(view, model, scene, lit, column, size_m)
    a = view.affine
    # the silhouette as the surface shows it (refracted), inside the frame or not
    full = float(stack[..., 3].sum()) * abs(float(a[0, 0] * a[1, 1] - a[0, 1] * a[1, 0]))
    layer = Layer(i, pl.role, pl.category_id, view.depth, view.roi, colour, alpha, weight,
                  offset, strength, blur, full, caster, shadow_step(view, lit),
                  water_srgb(scene, pl, lit, column))
    foam = [foam_ring(i, view, prepared[0], depth, pitch_m, scene, lit, column),
            wake_foam(i, pl, view, size_m, src.waterline, scene, lit, column)]
    return layer, [f for f in foam if f is not None]


def _warp(channels: np.ndarray, affine: np.ndarray, size: tuple[int, int]) -> np.ndarray:
    """``channels`` (n, n[, c]) float32 warped by ``affine`` into a (size[1], size[0][, c])
    float32 array of its own: bilinear, zero outside."""
    return cv2.warpAffine(np.ascontiguousarray(channels), affine, size, flags=cv2.INTER_LINEAR,
                          borderMode=cv2.BORDER_CONSTANT, borderValue=0)


def foam_ring(i: int, view: SpriteView, alpha: np.ndarray, depth: np.ndarray,
              pitch_m: float, scene: Scene, lit: Lighting, column: WaterColumn
              ) -> FoamRing | None:
    """The contact foam around placement ``i``'s waterline (:func:`contact_foam`): the
    waves' froth against a body that stands in their way (:func:`ring_share`), or the
    splash of one moving through the water (:func:`splash_strength`), whichever is
    stronger; lit like the water's surface, placed in the frame; None when there is
    none."""
    pl = scene.placements[i]
    dry_m = math.sqrt(float(np.count_nonzero((alpha >= 0.5) & (depth < 0.0)))) * pitch_m
    strength = max(ring_strength(scene.water.wind) * ring_share(dry_m),
                   splash_strength(pl.speed))
    stir = STIR_PEAK * stirring(pl.asset) if pl.speed <= 0 else 0.0
    width = RING_WIDTH
    if stir > strength:  # a swimmer treading water: a wider ring of disturbed water
        strength, width = stir, STIR_WIDTH
    ring = contact_foam(alpha, depth, pitch_m, strength, (scene.water.seed, i), width)
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
