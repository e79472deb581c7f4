"""The compositor: renders a :class:`~sdcomp.scene.Scene` to an image and exact masks.

Per image, in this order:

1. **Background**: procedural water (body colour, floor seen through the water, Fresnel sky
   reflection, sun glint, wave shading, whitecaps, haze, sky and hills above the horizon,
   land beyond a coastline) or one of the user's photos. Smooth terms are computed on a
   coarse grid (every 16 pixels) and interpolated; texture detail comes from periodic tiles
   sampled through the ground geometry of the camera.
2. **Layers**: every floating object (objects of interest and clutter) as an atlas sprite:
   the nearest stored pose, relit by the sun, parts under the waterline attenuated and tinted
   by the water (Beer-Lambert), mapped to the image by the camera's projection linearised at
   the object (scale, rotation, foreshortening), with its shadow on the water.
3. **Composite**: layers far to near, premultiplied ``over``.
4. **Camera effects**: exposure, white balance, vignetting (applied to the colours above),
   motion or defocus blur, sensor noise.

**Mask rule.** Each layer carries a *weight* per pixel: the fraction of that pixel's colour
that comes from the object itself. It starts as the sprite's coverage times the water's
transmittance to the visible surface (1 above water, ``exp(-c * path)`` below) and is
multiplied by ``1 - coverage`` of every layer composited in front of it. A pixel belongs to
an object's mask when the object's weight there is at least :data:`MASK_THRESHOLD` (0.5):
the object supplies at least half of the pixel's colour. So the mask excludes what other
objects hide, what murky water hides, and everything outside the frame; at most one object
can pass the rule for a pixel except in exact ties, which go to the nearer object. The bbox
and area of an annotation are those of its final mask; blur and noise (step 4) come after and
do not change masks.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from .camera import CameraModel, camera_basis, pixel_rays
from .config import GeneratorConfig
from .poses import tilt_matrix
from .scene import Scene, coast_wiggle
from .shading import linear_to_srgb, srgb_to_linear, sun_direction
from .sprites import SpriteSource
from .water import (
    REFRACTIVE_INDEX,
    Texture,
    fresnel,
    refracted_cos,
    sky_linear,
    slope_variance,
)

MASK_THRESHOLD = 0.5
GRID = 16  # pixels between samples of the smooth background terms
SUN = 2.2  # linear radiance of direct sunlight on a surface facing the sun
HAZE_DISTANCE = 4000.0  # metres: visibility through the air (exponential haze)
GLINT_GAIN = 0.05  # scale of the sun-glint lobe


@dataclass
class Layer:
    """One sprite placed in the frame. Arrays cover ``roi`` = (x0, y0, x1, y1) pixels."""

    placement: int
    kind: str
    model: int
    depth: float
    roi: tuple[int, int, int, int]
    colour: np.ndarray  # (h, w, 3) float32 premultiplied sRGB 0..255
    alpha: np.ndarray  # (h, w) float32 coverage
    weight: np.ndarray  # (h, w) float32 (see the module docstring)
    shadow_offset: tuple[float, float]
    shadow_strength: float
    shadow_blur: float


@dataclass
class Instance:
    """An annotated object in a rendered frame."""

    instance_id: int
    placement: int
    category_id: int
    area: int
    bbox: tuple[int, int, int, int]  # x, y, w, h pixels
    amodal: np.ndarray | None = None  # (H, W) bool, only when asked for
    amodal_area: int = 0


@dataclass
class Frame:
    """A rendered image: ``image`` (H, W, 3) uint8 RGB, ``instances`` (H, W) uint16 ids
    (0 = none), the annotated ``objects`` and the count of objects of interest ``dropped``
    for having fewer visible pixels than ``min_visible_px``."""

    image: np.ndarray
    instances: np.ndarray
    objects: list[Instance]
    dropped: int
    scene: Scene
    gsd: float


class Compositor:
    """Renders scenes of one :class:`GeneratorConfig` (textures and sprites made once)."""

    def __init__(self, config: GeneratorConfig, objects: list[SpriteSource],
                 clutter: list[SpriteSource], waves: list[Texture], floor: Texture,
                 land: Texture, backgrounds=None):
        self.config = config
        self.model: CameraModel = config.camera_model()
        self.objects = objects
        self.clutter = clutter
        self.waves = waves
        self.floor = floor
        self.land = land
        self.backgrounds = backgrounds
        w, h = self.model.width, self.model.height
        self.grid_w = max(2, math.ceil(w / GRID) + 1)
        self.grid_h = max(2, math.ceil(h / GRID) + 1)
        self.gu, self.gv = np.meshgrid(np.linspace(0, w, self.grid_w),
                                       np.linspace(0, h, self.grid_h))
        r2 = ((self.gu - w / 2) ** 2 + (self.gv - h / 2) ** 2) / ((w / 2) ** 2 + (h / 2) ** 2)
        self.grid_r2 = r2.astype(np.float32)
        rng = np.random.default_rng([config.seed, 31337])
        nh, nw = min(h, 1024) + 1021, min(w, 1024) + 1031
        self.noise = rng.standard_normal((nh, nw, 1)).astype(np.float32)
        self.floor_mean = srgb_to_linear(
            floor.levels[-1].reshape(-1, floor.levels[-1].shape[-1]).mean(0) / 255.0)

    # ------------------------------------------------------------------ main entry
    def render(self, scene: Scene, amodal: bool = False) -> Frame:
        model, pose = self.model, scene.camera
        w, h = model.width, model.height
        basis = camera_basis(pose.pitch, pose.heading)
        sun = sun_direction(scene.sun_elevation, scene.sun_azimuth)
        ev = 2.0 ** scene.effects.exposure
        wb = np.asarray(scene.effects.white_balance, np.float32) * ev
        rng = np.random.default_rng([scene.texture_seed, 1])

        image = self._background(scene, basis, sun, wb, rng)
        layers = self._layers(scene, basis, sun, wb)
        if self.config.shadows:
            for layer in layers:
                _shadow(image, layer)
        for k, layer in enumerate(layers):
            _over(image, layer, layers[:k])
        instances, objects, dropped = self._masks(scene, layers, amodal)
        out = self._finish(image, scene, rng)
        gsd = pose.altitude / model.fx if pose.pitch == 90 else _centre_gsd(model, pose)
        return Frame(out, instances, objects, dropped, scene, gsd)

    # ------------------------------------------------------------------ background
    def _background(self, scene: Scene, basis, sun, wb, rng) -> np.ndarray:
        model, pose = self.model, scene.camera
        w, h = model.width, model.height
        rays = pixel_rays(model, pose, self.gu, self.gv).astype(np.float32)  # (gh, gw, 3)
        down = -rays[..., 2]
        hit = down > 1e-4
        cos_v = np.clip(down, 1e-4, 1.0)
        dist = np.where(hit, pose.altitude / cos_v, 1e9).astype(np.float32)
        c = scene.attenuation
        water_lin = srgb_to_linear(np.asarray(scene.water_rgb, np.float32) / 255.0)
        light = scene.ambient + SUN * max(sun[2], 0.0) * 0.55
        tint = water_lin / max(float(water_lin.max()), 1e-3)
        # water body: brighter and more opaque with turbidity
        body = water_lin * (0.45 + 0.55 * scene.turbidity) * light
        cos_t = refracted_cos(cos_v)
        cos_sun_t = float(refracted_cos(max(sun[2], 0.05)))
        path = 1.0 / cos_t + 1.0 / cos_sun_t
        t_floor = np.exp(-c * scene.floor_depth * path)[..., None]  # (gh, gw, 1)
        floor_lin = self.floor_mean * tint * light * 0.6
        reflect = fresnel(cos_v)[..., None]
        sky_refl = sky_linear(cos_v) * (0.55 + 0.45 * light / (0.4 + SUN * 0.55))
        under = body * (1 - t_floor) + floor_lin * t_floor
        water = (1 - reflect) * under + reflect * sky_refl
        # sun glint: Cox-Munk slope distribution of the facets that mirror the sun
        sigma2 = slope_variance(scene.wind)
        half = -rays + sun.astype(np.float32)
        half /= np.linalg.norm(half, axis=-1, keepdims=True)
        tan2 = (half[..., 0] ** 2 + half[..., 1] ** 2) / np.maximum(half[..., 2] ** 2, 1e-6)
        glint = (GLINT_GAIN * SUN * np.exp(-tan2 / sigma2) / sigma2
                 * (sun[2] > 0.02) * hit)[..., None] * np.float32(1.0)
        # haze over distance, and the sky above the horizon
        haze = (1.0 - np.exp(-dist / HAZE_DISTANCE))[..., None]
        sky = sky_linear(np.clip(rays[..., 2], 0, 1))
        horizon_col = np.asarray(sky_linear(0.0), np.float32)
        water = water * (1 - haze) + horizon_col * haze
        glint = glint * (1 - haze)
        gain = (1.0 - scene.effects.vignetting * self.grid_r2)[..., None] * wb
        env = np.where(hit[..., None], water, sky) * gain
        env_srgb = linear_to_srgb(env) * 255.0
        # wave detail: multiplicative shading from slopes, additive glint and whitecaps
        deriv = 255.0 * (linear_to_srgb(np.clip(env * 1.02 + 1e-3, 0, 1))
                         - linear_to_srgb(np.clip(env, 0, 1)))  # d(sRGB)/d(1 % linear)
        slope_sd = math.sqrt(sigma2 / 2)
        small = np.concatenate([env_srgb, glint * gain[..., :1] * 255.0,
                                deriv * 0 + (1 - haze) * hit[..., None]], axis=-1)
        big = cv2.resize(small.astype(np.float32), (w, h), interpolation=cv2.INTER_LINEAR)
        base = big[..., 0:3]
        glint_map = big[..., 3]
        near = big[..., 4]

        if self.backgrounds is not None:
            photo = self.backgrounds.pick(scene.texture_seed, w, h).astype(np.float32)
            return photo * (gain.mean() if False else 1.0) * np.float32(ev)

        tex = self._wave_view(scene, rng)  # (h, w, 4) uint8
        t = tex.astype(np.float32)
        sx = (t[..., 0] - 128.0) / 40.0
        sy = (t[..., 1] - 128.0) / 40.0
        # brighter on facets tilted towards the sun (seen in the image frame)
        az = math.radians(scene.sun_azimuth - pose.heading)
        gx, gy = math.sin(az), -math.cos(az)
        amp = min(0.55, 2.2 * slope_sd) * (0.6 + 0.4 * math.cos(math.radians(
            scene.sun_elevation)))
        mod = 1.0 + amp * near * (gx * sx + gy * sy)
        image = base * mod[..., None]
        sparkle = t[..., 3] * (1.0 / 255.0)
        image += (glint_map * (0.35 + 2.5 * sparkle))[..., None]
        foam_level = self.config.whitecaps * max(0.0, (scene.wind - 5.0) / 10.0)
        if foam_level > 0:
            foam = np.clip(t[..., 2] * (foam_level / 255.0 * 3.0) - 0.25, 0, 0.8) * near
            image += foam[..., None] * (np.float32(225.0) - image)
        tf_max = float(t_floor.max())
        if tf_max > 0.01 and self.config.rocks >= 0:
            self._add_floor(image, scene, t_floor, gain, tint, light)
        if scene.shore is not None:
            self._add_land(image, scene, gain)
        if not hit.all():
            self._add_sky(image, scene, basis, sky, gain)
        return image

    def _wave_view(self, scene: Scene, rng) -> np.ndarray:
        model, pose = self.model, scene.camera
        rel = (scene.swell_direction - pose.heading) % 180.0
        tile = self.waves[int(round(rel / 180.0 * len(self.waves))) % len(self.waves)]
        x0, y0 = rng.uniform(0, 1000, 2)
        if pose.pitch >= 89.999:
            gx, gy = model.nadir_gsd(pose.altitude)
            return tile.view(x0, y0, gx * model.width, gy * model.height, model.width,
                             model.height)
        return self._perspective_sample(tile, scene, x0, y0)

    def _perspective_sample(self, tile: Texture, scene: Scene, x0: float, y0: float
                            ) -> np.ndarray:
        """Sample a ground texture through the camera (oblique views): image rows map to
        ground distance, columns to the lateral offset, in the camera's heading frame."""
        model, pose = self.model, scene.camera
        w, h = model.width, model.height
        u = (np.arange(w, dtype=np.float32) + 0.5 - w / 2) / model.fx
        v = (np.arange(h, dtype=np.float32) + 0.5 - h / 2) / model.fy
        p = math.radians(pose.pitch)
        # camera frame ray (u, v, 1) in (forward-horizontal, right, up) components
        fwd = math.cos(p) - v * math.sin(p)
        up = -math.sin(p) - v * math.cos(p)
        t = np.where(up < -1e-4, pose.altitude / np.maximum(-up, 1e-4), np.nan)
        ground_f = (fwd * t).astype(np.float32)
        ground_r = (t[:, None] * u[None, :]).astype(np.float32)
        mx = np.broadcast_to(ground_r, (h, w)) + np.float32(x0)
        my = np.broadcast_to(-ground_f[:, None], (h, w)) + np.float32(y0)
        valid_row = np.isfinite(t)
        mx = np.where(valid_row[:, None], mx, 0).astype(np.float32)
        my = np.where(valid_row[:, None], my, 0).astype(np.float32)
        centre = min(int(h * 0.75), h - 1)
        pitch_m = float(t[centre]) / model.fx if valid_row[centre] else 1.0
        return tile.sample(mx, my, pitch_m)

    def _add_floor(self, image, scene, t_floor, gain, tint, light) -> None:
        """Sea-floor texture detail (rocks, sand ripples) where the floor shows through."""
        model, pose = self.model, scene.camera
        w, h = model.width, model.height
        apparent = pose.altitude + scene.floor_depth / REFRACTIVE_INDEX
        if pose.pitch >= 89.999:
            gx, gy = model.nadir_gsd(apparent)
            rng = np.random.default_rng([scene.texture_seed, 2])
            tex = self.floor.view(*rng.uniform(0, 1000, 2), gx * w, gy * h, w, h)
        else:
            s = type(scene.camera)(apparent, pose.pitch, pose.heading)
            tex = self._perspective_sample(self.floor, scene.__class__(
                **{**scene.__dict__, "camera": s}), 0.0, 0.0)
        k = (t_floor * gain * (tint * light * 0.6))[..., :]
        k_big = cv2.resize((linear_to_srgb(k) * 255.0).astype(np.float32), (w, h),
                           interpolation=cv2.INTER_LINEAR)
        detail = tex.astype(np.float32) - srgb_mean(self.floor)
        image += detail * (k_big * (1.0 / 255.0))

    def _add_land(self, image, scene: Scene, gain) -> None:
        """Land beyond the coastline: a textured polygon with a foam line at the shore."""
        model, pose = self.model, scene.camera
        w, h = model.width, model.height
        shore = scene.shore
        a = math.radians(shore.angle)
        normal = np.array([math.cos(a), math.sin(a)])
        along_dir = np.array([-math.sin(a), math.cos(a)])
        reach = pose.altitude * 40
        along = np.linspace(-reach, reach, 1500)
        across = shore.distance + coast_wiggle(shore, along)
        coast = along[:, None] * along_dir + across[:, None] * normal
        far = coast + normal * reach
        poly_world = np.concatenate([coast, far[::-1]])
        pts = np.concatenate([poly_world, np.zeros((len(poly_world), 1))], axis=1)
        from .camera import project
        uv, depth = project(model, pose, pts)
        ok = depth > 1e-3
        if ok.sum() < 3:
            return
        mask = np.zeros((h, w), np.uint8)
        poly = np.round(uv[ok] * 16).astype(np.int32)
        cv2.fillPoly(mask, [poly], 255, lineType=cv2.LINE_AA, shift=4)
        if not mask.any():
            return
        line = np.round(uv[: len(coast)][ok[: len(coast)]] * 16).astype(np.int32)
        foam = np.zeros((h, w), np.uint8)
        thick = max(1, int(round(0.6 / max(pose.altitude / model.fx, 1e-6))))
        cv2.polylines(foam, [line], False, 255, thickness=thick, lineType=cv2.LINE_AA,
                      shift=4)
        rng = np.random.default_rng([scene.texture_seed, 3])
        gx, gy = model.nadir_gsd(pose.altitude)
        tex = self.land.view(*rng.uniform(0, 1000, 2), gx * w, gy * h, w, h)
        g = float(np.mean(gain))
        land = tex.astype(np.float32) * g
        m = (mask.astype(np.float32) * (1.0 / 255.0))[..., None]
        image *= 1 - m
        image += land * m
        f = (foam.astype(np.float32) * (0.7 / 255.0))[..., None]
        image *= 1 - f
        image += 230.0 * g * f

    def _add_sky(self, image, scene: Scene, basis, sky, gain) -> None:
        """Sky above the horizon (a sharp line), with hills on it when the scene has them."""
        model, pose = self.model, scene.camera
        w, h = model.width, model.height
        p = math.radians(pose.pitch)
        # rows above the horizon: the ray's vertical component >= 0
        v_h = h / 2 - model.fy * math.tan(p) if p < math.pi / 2 else -1.0  # horizon row
        rows = int(math.ceil(max(0.0, min(h, v_h))))
        if rows <= 0:
            return
        vv = (np.arange(rows, dtype=np.float64) + 0.5 - h / 2) / model.fy
        elev = (math.sin(p) * 0 + (-vv * math.cos(p) - math.sin(p) * -0.0))
        # elevation sine of each row's ray through the image centre column
        up = -math.sin(p) - vv * math.cos(p)
        fwd = math.cos(p) - vv * math.sin(p)
        sin_el = up / np.sqrt(up ** 2 + fwd ** 2)
        col = sky_linear(np.clip(sin_el, 0, 1)) * float(np.mean(gain[0]))
        col = linear_to_srgb(col) * 255.0
        image[:rows] = col[:, None, :].astype(np.float32)
        del elev
        if scene.hills is not None:
            rng = np.random.default_rng(scene.hills)
            x = np.arange(w, dtype=np.float64)
            ridge = np.zeros(w)
            for wl in (w * 1.3, w * 0.45, w * 0.13, w * 0.04):
                ridge += rng.uniform(0.3, 1.0) * wl * np.sin(2 * np.pi * x / wl
                                                             + rng.uniform(0, 6.3))
            height = np.clip(model.fy * math.radians(rng.uniform(0.4, 2.2))
                             * (0.6 + 0.4 * ridge / (np.abs(ridge).max() + 1e-9)), 0, None)
            if rng.random() < 0.5:  # hills on one side only
                side = np.clip((x / w - rng.uniform(0.2, 0.8)) * rng.choice([-1, 1]) * 6, 0, 1)
                height = height * side
            top = v_h - height
            yy = np.arange(h, dtype=np.float64)[:, None]
            cover = np.clip(np.minimum(yy + 0.5 - top[None, :], v_h + 1.0 - yy), 0, 1)
            cover = cover.astype(np.float32)[..., None]
            hill = linear_to_srgb(np.array([0.10, 0.13, 0.09]) * 0.6 + 0.4 * np.array(
                sky_linear(0.0))) * 255.0 * float(np.mean(gain[0]))
            image *= 1 - cover
            image += cover * hill.astype(np.float32)

    # ------------------------------------------------------------------ layers
    def _layers(self, scene: Scene, basis, sun, wb) -> list[Layer]:
        model, pose = self.model, scene.camera
        cam = pose.position
        layers = []
        water_lin = srgb_to_linear(np.asarray(scene.water_rgb, np.float32) / 255.0)
        body = water_lin * (0.45 + 0.55 * scene.turbidity) * (
            scene.ambient + SUN * max(sun[2], 0.0) * 0.55)
        cos_sun_t = float(refracted_cos(max(sun[2], 0.05)))
        for i, pl in enumerate(scene.placements):
            src = (self.objects if pl.kind == "object" else self.clutter)[pl.model]
            layer = self._layer(i, pl, src, scene, basis, cam, sun, wb, body, cos_sun_t)
            if layer is not None:
                layers.append(layer)
        layers.sort(key=lambda lay: -lay.depth)  # far first
        return layers

    def _layer(self, i, pl, src: SpriteSource, scene, basis, cam, sun, wb, body, cos_sun_t):
        model = self.model
        hd = math.radians(pl.heading)
        rz = np.array([[math.cos(hd), -math.sin(hd), 0], [math.sin(hd), math.cos(hd), 0],
                       [0, 0, 1]])
        rot = rz @ tilt_matrix(pl.roll, pl.pitch)  # body -> world
        pivot = np.array([pl.x, pl.y, -pl.draft])
        origin = pivot + rot @ np.array([0.0, 0.0, -src.waterline])
        to_cam = cam - origin
        dist = float(np.linalg.norm(to_cam))
        d_world = to_cam / dist
        pose_i = src.nearest(rot.T @ d_world)
        vb = src.bases[pose_i]  # rows right, up, toward in the body frame
        right_w, up_w = rot @ vb[0], rot @ vb[1]
        xc = basis @ (origin - cam)
        z = float(xc[2])
        if z <= 0.05:
            return None
        fx, fy = model.fx, model.fy
        jac = np.array([[fx / z, 0, -fx * xc[0] / z ** 2],
                        [0, fy / z, -fy * xc[1] / z ** 2]]) @ basis
        a = jac @ np.stack([right_w, -up_w], axis=1) * src.metres_per_pixel  # (2, 2)
        u0 = fx * xc[0] / z + model.width / 2
        v0 = fy * xc[1] / z + model.height / 2
        scale = math.sqrt(abs(np.linalg.det(a)))
        if scale <= 0:
            return None
        level = int(np.clip(math.floor(math.log2(1.0 / scale)), 0, src.max_level)) \
            if scale < 1 else 0
        n = src.size >> level
        a_l = a * (1 << level)
        t = np.array([u0, v0]) - 0.5 + a_l @ np.full(2, 0.5 - n / 2)
        corners = np.array([[-0.5, -0.5], [n - 0.5, -0.5], [-0.5, n - 0.5], [n - 0.5, n - 0.5]])
        dst = corners @ a_l.T + t
        x0 = max(int(math.floor(dst[:, 0].min())), 0)
        y0 = max(int(math.floor(dst[:, 1].min())), 0)
        x1 = min(int(math.ceil(dst[:, 0].max())) + 1, model.width)
        y1 = min(int(math.ceil(dst[:, 1].max())) + 1, model.height)
        if x1 <= x0 or y1 <= y0:
            return None
        data = src.level(pose_i, level)
        colour, weight = self._shade(data, vb, rot, sun, d_world, pl, scene, wb, body,
                                     cos_sun_t, u0, v0)
        stack = np.concatenate([colour, data[..., :1], weight[..., None]], axis=-1)
        m = np.concatenate([a_l, (t - [x0, y0])[:, None]], axis=1).astype(np.float32)
        warped = cv2.warpAffine(stack, m, (x1 - x0, y1 - y0), flags=cv2.INTER_LINEAR,
                                borderMode=cv2.BORDER_CONSTANT, borderValue=0)
        if warped.ndim == 2:
            warped = warped[..., None]
        alpha = np.clip(warped[..., 3], 0.0, 1.0)
        # shadow on the water: under water at the depth light scatters back from (or on
        # the floor in clear water), displaced away from the sun
        c = scene.attenuation
        d_s = min(1.0 / c, scene.floor_depth)
        sun_h = math.hypot(sun[0], sun[1])
        tan_t = (sun_h / REFRACTIVE_INDEX) / max(cos_sun_t, 0.05)
        disp = np.array([-sun[0] / max(sun_h, 1e-9) * d_s * tan_t,
                         -sun[1] / max(sun_h, 1e-9) * d_s * tan_t, -d_s / REFRACTIVE_INDEX])
        off = jac @ disp
        t_floor = math.exp(-c * scene.floor_depth * 2)
        strength = 0.45 * (1 - math.exp(-2 * c * d_s)) + 0.45 * t_floor
        gsd = z / fx
        blur = float(np.clip(0.08 * d_s / gsd, 0.0, 12.0))
        return Layer(i, pl.kind, pl.model, z, (x0, y0, x1, y1),
                     np.ascontiguousarray(warped[..., :3]), alpha,
                     np.clip(warped[..., 4], 0.0, 1.0), (float(off[0]), float(off[1])),
                     float(strength), blur)

    def _shade(self, data, vb, rot, sun, d_world, pl, scene, wb, body, cos_sun_t, u0, v0):
        """Relit, submerged, premultiplied sRGB colour (n, n, 3) and weight (n, n)."""
        alpha = data[..., 0]
        inv = np.where(alpha > 1e-6, 1.0 / np.maximum(alpha, 1e-6), 0.0).astype(np.float32)
        albedo = data[..., 1:4] * inv[..., None]
        normal = data[..., 4:7]
        sun_view = (vb @ (rot.T @ sun)).astype(np.float32)
        nlen = np.sqrt(np.einsum("ijk,ijk->ij", normal, normal)) + 1e-6
        lambert = np.clip((normal @ sun_view) / nlen, 0.0, None)
        light = scene.ambient + SUN * 0.5 * lambert * (sun[2] > 0)
        lin = albedo * np.asarray(pl.tint, np.float32) * light[..., None]
        height = data[..., 7] * inv
        depth = np.maximum(pl.draft - height, 0.0)  # metres under the surface
        if np.any(depth > 0):
            cos_t = float(refracted_cos(d_world[2]))
            trans = np.exp(-scene.attenuation * depth * (1.0 / cos_t + 1.0 / cos_sun_t))
            trans = trans.astype(np.float32)
            wet = (depth > 0)[..., None]
            r = float(fresnel(d_world[2]))
            sky = sky_linear(d_world[2])
            submerged = (lin * trans[..., None] + body * (1 - trans[..., None])) * (1 - r) \
                + sky * r
            lin = np.where(wet, submerged, lin)
        else:
            trans = np.ones_like(alpha)
        w, h = self.model.width, self.model.height
        r2 = ((u0 - w / 2) ** 2 + (v0 - h / 2) ** 2) / ((w / 2) ** 2 + (h / 2) ** 2)
        gain = wb * (1.0 - scene.effects.vignetting * min(r2, 1.0))
        srgb = linear_to_srgb(lin * gain) * 255.0
        return (srgb * alpha[..., None]).astype(np.float32), (alpha * trans).astype(np.float32)

    # ------------------------------------------------------------------ masks
    def _masks(self, scene: Scene, layers: list[Layer], amodal: bool):
        model = self.model
        instances = np.zeros((model.height, model.width), np.uint16)
        objs = [lay for lay in layers if lay.kind == "object"]
        ids = {lay.placement: k + 1 for k, lay in
               enumerate(sorted(objs, key=lambda lay: lay.placement))}
        for lay in objs:  # far to near: ties go to the nearer object
            x0, y0, x1, y1 = lay.roi
            sel = lay.weight >= MASK_THRESHOLD
            instances[y0:y1, x0:x1][sel] = ids[lay.placement]
        out = []
        n_objects = sum(1 for p in scene.placements if p.kind == "object")
        next_id = 0
        relabel = np.zeros(len(objs) + 1, np.uint16)
        for lay in sorted(objs, key=lambda lay: lay.placement):
            old = ids[lay.placement]
            x0, y0, x1, y1 = lay.roi
            region = instances[y0:y1, x0:x1] == old
            area = int(region.sum())
            if area < self.config.min_visible_px:
                continue
            next_id += 1
            relabel[old] = next_id
            ys, xs = np.nonzero(region)
            bbox = (x0 + int(xs.min()), y0 + int(ys.min()), int(xs.max() - xs.min()) + 1,
                    int(ys.max() - ys.min()) + 1)
            inst = Instance(next_id, lay.placement, lay.model + 1, area, bbox)
            if amodal:
                full = np.zeros_like(instances, dtype=bool)
                full[y0:y1, x0:x1] = lay.alpha >= MASK_THRESHOLD
                inst.amodal = full
                inst.amodal_area = int(full.sum())
            out.append(inst)
        if len(out) != len(objs):
            instances = relabel[instances]
        return instances, out, n_objects - len(out)

    # ------------------------------------------------------------------ effects
    def _finish(self, image: np.ndarray, scene: Scene, rng) -> np.ndarray:
        fx = scene.effects
        if fx.motion_blur is not None:
            length, angle = fx.motion_blur
            k = int(max(3, round(length) | 1))
            kernel = np.zeros((k, k), np.float32)
            c = k // 2
            dx, dy = math.cos(math.radians(angle)), math.sin(math.radians(angle))
            for s in np.linspace(-length / 2, length / 2, 4 * k):
                kernel[int(round(c + s * dy)) % k, int(round(c + s * dx)) % k] += 1
            image = cv2.filter2D(image, -1, kernel / kernel.sum(), borderType=cv2.BORDER_REFLECT)
        if fx.defocus_blur is not None:
            image = cv2.GaussianBlur(image, (0, 0), fx.defocus_blur)
        if fx.noise > 0:
            h, w = image.shape[:2]
            nh, nw = self.noise.shape[:2]
            oy, ox = int(rng.integers(nh - min(h, nh) + 1)), int(rng.integers(nw - min(w, nw) + 1))
            if h <= nh - oy and w <= nw - ox:
                image += self.noise[oy:oy + h, ox:ox + w] * np.float32(fx.noise)
            else:
                reps = (math.ceil(h / nh) + 1, math.ceil(w / nw) + 1, 1)
                big = np.tile(self.noise, reps)
                image += big[oy:oy + h, ox:ox + w] * np.float32(fx.noise)
        return np.clip(image + 0.5, 0, 255).astype(np.uint8)


def srgb_mean(tex: Texture) -> np.ndarray:
    top = tex.levels[-1]
    return top.reshape(-1, top.shape[-1]).mean(0).astype(np.float32)


def _centre_gsd(model: CameraModel, pose) -> float:
    """Metres per pixel (along x) at the image centre of an oblique view."""
    p = math.radians(pose.pitch)
    dist = pose.altitude / math.sin(p)
    return dist / model.fx


def _shadow(image: np.ndarray, layer: Layer) -> None:
    """Darken the background under ``layer``'s shadow (in place)."""
    if layer.shadow_strength <= 0.01:
        return
    x0, y0, x1, y1 = layer.roi
    h, w = image.shape[:2]
    pad = int(math.ceil(2 * layer.shadow_blur)) + 1
    a = np.pad(layer.alpha, pad)
    if layer.shadow_blur > 0.3:
        a = cv2.GaussianBlur(a, (0, 0), layer.shadow_blur)
    ox, oy = layer.shadow_offset
    sx, sy = int(round(x0 - pad + ox)), int(round(y0 - pad + oy))
    ax0, ay0 = max(sx, 0), max(sy, 0)
    ax1, ay1 = min(sx + a.shape[1], w), min(sy + a.shape[0], h)
    if ax1 <= ax0 or ay1 <= ay0:
        return
    sub = a[ay0 - sy:ay1 - sy, ax0 - sx:ax1 - sx]
    image[ay0:ay1, ax0:ax1] *= (1.0 - layer.shadow_strength * sub)[..., None]


def _over(image: np.ndarray, layer: Layer, below: list[Layer]) -> None:
    """Composite ``layer`` over ``image`` and reduce the weights of the layers it covers."""
    x0, y0, x1, y1 = layer.roi
    region = image[y0:y1, x0:x1]
    region *= (1.0 - layer.alpha)[..., None]
    region += layer.colour
    for other in below:
        ox0, oy0, ox1, oy1 = other.roi
        ix0, iy0, ix1, iy1 = max(x0, ox0), max(y0, oy0), min(x1, ox1), min(y1, oy1)
        if ix1 <= ix0 or iy1 <= iy0:
            continue
        other.weight[iy0 - oy0:iy1 - oy0, ix0 - ox0:ix1 - ox0] *= (
            1.0 - layer.alpha[iy0 - y0:iy1 - y0, ix0 - x0:ix1 - x0])
