"""The compositor: renders a :class:`~sdcomp.scene.Scene` to an image and exact masks.

Per image, in this order:

1. **Background**: procedural water (body colour, floor seen through the water, Fresnel sky
   reflection, sun glint, wave shading, whitecaps, haze, sky and hills above the horizon,
   land beyond a coastline) or one of the user's photos. Smooth terms are computed on a
   coarse grid (every 16 pixels) and interpolated; texture detail comes from periodic tiles
   sampled through the ground geometry of the camera. Looking straight down, the water is
   drawn up to :data:`REDUCE_MAX` times smaller where its textures are magnified that much
   anyway, and magnified once (land and sky are then drawn at full size).
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

from .camera import CameraModel, CameraPose, camera_basis, project
from .config import GeneratorConfig
from .poses import tilt_matrix
from .scene import Scene, coast_wiggle
from .shading import linear_to_srgb, srgb_to_linear, sun_direction
from .sprites import SpriteSource
from .water import (
    REFRACTIVE_INDEX,
    SKY_HORIZON_RGB,
    SLOPE_SCALE,
    Texture,
    fresnel,
    refracted_cos,
    sky_linear,
    slope_variance,
)

MASK_THRESHOLD = 0.5
SPARKLE_MATRIX = np.array([[0.0, 0.0, 2.5 / 255.0 * 100.0, 35.0]] * 3, np.float32)
GRID = 16  # pixels between samples of the smooth background terms
REDUCE_MAX = 8  # nadir water is drawn up to this many times smaller when its texture allows
REDUCE_MIN_SIZE = 16  # pixels: a reduced water background is at least this wide and high
FLOOR_VISIBLE = 0.01  # floor detail is drawn where its transmittance reaches this
ONE_THREAD_PIXELS = 512 * 512  # frames up to this size are drawn on one OpenCV thread
BACKGROUND_MAX = 1400  # pixels: larger frames get an upsampled background
BLUR_EXACT_MAX = 8192  # pixels: larger frames are blurred at BLUR_WORK_SIZE and magnified
BLUR_WORK_SIZE = 4096  # pixels: at most this size (an integer reduction factor)
LINE_TAPS_MIN = 16  # motion blur this long or longer sums shifted frames (_line_mean)
LINE_BAND_BYTES = 8 << 20  # _line_mean works in bands of rows of about this many bytes
SUN = 2.2  # linear radiance of direct sunlight on a surface facing the sun
HAZE_DISTANCE = 4000.0  # metres: visibility through the air (exponential haze)
GLINT_GAIN = 0.014  # sun glint: Fresnel x sun/sky irradiance ratio / 4 / pi
NOISE_SCALE = 32.0  # uint8 levels per standard deviation in the noise tile
FLOOR_LIGHT = 0.6  # fraction of the surface light reaching the floor and back


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


@dataclass(frozen=True)
class Lighting:
    """Per-image quantities every stage uses (see :func:`lighting`)."""

    basis: np.ndarray  # (3, 3) float64 camera rows right, down, forward (world frame)
    sun: np.ndarray  # (3,) float64 unit vector towards the sun (world frame)
    wb: np.ndarray  # (3,) float32 camera gain per channel: white balance x exposure
    water_lin: np.ndarray  # (3,) float32 linear RGB of the water colour
    light: float  # irradiance on the surface (ambient + sun), linear
    body: np.ndarray  # (3,) float32 radiance of the water body, linear
    cos_sun_t: float  # cosine of the refracted sun angle under water


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
                 land: Texture, backgrounds=None, model: CameraModel | None = None,
                 grid: int = GRID, finishing: bool = True):
        """``grid``: pixels between the samples of the smooth background terms;
        ``finishing``: False for the smaller compositors that only draw backgrounds (they
        get no noise tile)."""
        self.config = config
        self.model: CameraModel = model or config.camera_model()
        self.objects = objects
        self.clutter = clutter
        self.waves = waves
        self.floor = floor
        self.land = land
        self.backgrounds = backgrounds
        w, h = self.model.width, self.model.height
        self.grid_w = max(2, math.ceil(w / grid) + 1)
        self.grid_h = max(2, math.ceil(h / grid) + 1)
        self.gu, self.gv = np.meshgrid(np.linspace(0, w, self.grid_w),
                                       np.linspace(0, h, self.grid_h))
        r2 = ((self.gu - w / 2) ** 2 + (self.gv - h / 2) ** 2) / ((w / 2) ** 2 + (h / 2) ** 2)
        self.grid_r2 = r2.astype(np.float32)
        # unit view rays of the grid in the camera frame (the world frame: times the basis)
        m = self.model
        d = np.stack([(self.gu - w / 2) / m.fx, (self.gv - h / 2) / m.fy,
                      np.ones_like(self.gu)], axis=-1)
        self.grid_rays = (d / np.linalg.norm(d, axis=-1, keepdims=True)).astype(np.float32)
        self._smaller: dict[int, Compositor] = {}  # _reduced(f), made on first use
        # large frames: the background (smooth light, textures magnified from their
        # few-centimetre pitch) is drawn at most BACKGROUND_MAX wide and resized
        self._bg = self
        m = self.model
        if max(m.width, m.height) > BACKGROUND_MAX:
            f = BACKGROUND_MAX / max(m.width, m.height)
            small = CameraModel(m.sensor_width, m.sensor_height, m.diagonal_fov,
                                max(1, round(m.width * f)), max(1, round(m.height * f)))
            self._bg = Compositor(config, objects, clutter, waves, floor, land, backgrounds,
                                  model=small, finishing=False)
        self.floor_mean = srgb_to_linear(floor.mean / 255.0)
        # the sensor-noise tile, made here (forked workers inherit it)
        self.noise = _noise_tile(config.seed, h, w) if finishing else None

    def _reduction(self, scene: Scene, lit: Lighting) -> int:
        """How many times smaller (1, 2, 4 or 8) the water of ``scene`` can be drawn and
        then magnified without losing detail: the largest power of two, at most
        :data:`REDUCE_MAX`, by which the wave texture and the visible sea floor are already
        magnified at this frame's size (their texels cover at least that many pixels).
        Only straight-down views (oblique ones sample the textures per pixel) of water
        (not the user's photos)."""
        pose, m = scene.camera, self.model
        if self.backgrounds is not None or pose.pitch < 89.999:
            return 1
        textures = [(self.waves[0], pose.altitude)]
        if self._floor_visible(scene, lit):
            textures.append((self.floor, pose.altitude + scene.floor_depth / REFRACTIVE_INDEX))
        f = REDUCE_MAX
        for tex, altitude in textures:
            gx, gy = m.nadir_gsd(altitude)
            _, cw, ch = tex.crop_size(gx * m.width, gy * m.height, m.width)
            magnified = min(m.width / cw, m.height / ch)
            while f > 1 and f > magnified:
                f //= 2
        while f > 1 and min(m.width, m.height) < REDUCE_MIN_SIZE * f:
            f //= 2
        return f

    def _reduced(self, f: int) -> Compositor:
        """A compositor of this one's camera with a frame ``f`` times smaller (the same
        number of grid samples)."""
        if f not in self._smaller:
            m = self.model
            small = CameraModel(m.sensor_width, m.sensor_height, m.diagonal_fov,
                                max(1, round(m.width / f)), max(1, round(m.height / f)))
            self._smaller[f] = Compositor(self.config, self.objects, self.clutter, self.waves,
                                          self.floor, self.land, self.backgrounds,
                                          model=small, grid=max(1, GRID // f),
                                          finishing=False)
        return self._smaller[f]

    @staticmethod
    def _floor_visible(scene: Scene, lit: Lighting) -> bool:
        """Whether the floor's transmittance straight down reaches FLOOR_VISIBLE (it is
        highest there: the shortest path through the water)."""
        path = 1.0 + 1.0 / lit.cos_sun_t
        return math.exp(-scene.attenuation * scene.floor_depth * path) >= FLOOR_VISIBLE

    # ------------------------------------------------------------------ main entry
    def render(self, scene: Scene, amodal: bool = False) -> Frame:
        """``scene`` rendered to a :class:`Frame`. Frames of up to
        :data:`ONE_THREAD_PIXELS` are drawn with OpenCV on one thread (its thread pool costs
        more than it gives on them); the process's thread count is restored after."""
        threads = cv2.getNumThreads()
        if threads == 1 or self.model.width * self.model.height > ONE_THREAD_PIXELS:
            return self._render(scene, amodal)
        cv2.setNumThreads(1)
        try:
            return self._render(scene, amodal)
        finally:
            cv2.setNumThreads(threads)

    def _render(self, scene: Scene, amodal: bool) -> Frame:
        model, pose = self.model, scene.camera
        lit = lighting(scene)
        rng = np.random.default_rng([scene.texture_seed, 1])

        image = self._bg._background(scene, lit, rng)
        if self._bg is not self:
            image = cv2.resize(image, (model.width, model.height),
                               interpolation=cv2.INTER_LINEAR)
        layers = self._layers(scene, lit)
        if self.config.shadows:
            for layer in layers:
                _shadow(image, layer)
        for k, layer in enumerate(layers):
            _over(image, layer, layers[:k])
        instances, objects, dropped = self._masks(scene, layers, amodal)
        out = self._finish(image, scene, rng)
        gsd = _centre_gsd(model, pose)
        return Frame(out, instances, objects, dropped, scene, gsd)

    # ------------------------------------------------------------------ background
    def _environment(self, scene: Scene, lit: Lighting) -> dict:
        """Smooth terms of the background on the coarse grid (gh, gw): linear RGB radiance
        of the water and sky with the camera gain applied, the glint lobe and the floor's
        transmittance."""
        pose = scene.camera
        rays = self.grid_rays @ lit.basis.astype(np.float32)
        down = -rays[..., 2]
        hit = down > 1e-4
        all_hit = bool(hit.all())
        cos_v = np.minimum(np.maximum(down, 1e-4), 1.0)
        c = scene.attenuation
        light, sun = lit.light, lit.sun
        tint = lit.water_lin / max(float(lit.water_lin.max()), 1e-3)
        path = 1.0 / refracted_cos(cos_v) + 1.0 / lit.cos_sun_t
        t_floor = np.exp(path * np.float32(-c * scene.floor_depth))[..., None]  # (gh, gw, 1)
        floor_lin = self.floor_mean * tint * light * FLOOR_LIGHT
        reflect = fresnel(cos_v)[..., None]
        sky_refl = sky_linear(cos_v) * np.float32(0.55 + 0.45 * light / (0.4 + SUN * 0.55))
        # (1 - R) (body (1 - T) + floor T) + R sky, with R, T per grid point
        water = lit.body + (floor_lin - lit.body) * t_floor
        water += (sky_refl - water) * reflect
        # sun glint: Cox-Munk slope distribution of the facets that mirror the sun
        sigma2 = slope_variance(scene.wind)
        half = sun.astype(np.float32) - rays
        sq = np.square(half)
        tan2 = (sq[..., 0] + sq[..., 1]) / np.maximum(sq[..., 2], 1e-6)  # of the half vector
        glint = np.exp(tan2 * np.float32(-1.0 / sigma2))
        glint *= np.float32(GLINT_GAIN / sigma2 * float(sun[2] > 0.02))
        dist = pose.altitude / cos_v
        if not all_hit:
            glint *= hit
            dist = np.where(hit, dist, 1e9).astype(np.float32)
        haze = (1.0 - np.exp(dist * np.float32(-1.0 / HAZE_DISTANCE)))[..., None]
        water += (SKY_HORIZON_RGB - water) * haze
        gain = (1.0 - scene.effects.vignetting * self.grid_r2)[..., None] * lit.wb
        if all_hit:
            env = water * gain
        else:
            sky = sky_linear(rays[..., 2])
            env = np.where(hit[..., None], water, sky) * gain
        return {"env": env, "glint": glint[..., None] * (1 - haze) * gain,
                "t_floor": t_floor, "gain": gain, "hit": hit, "tint": tint, "light": light}

    def _background(self, scene: Scene, lit: Lighting, rng) -> np.ndarray:
        """(H, W, 3) uint8 sRGB background (see the module docstring): the user's photo,
        or the water, drawn :meth:`_reduction` times smaller and magnified, with land and
        sky drawn on it at full size."""
        model = self.model
        w, h = model.width, model.height
        f = self._reduction(scene, lit)
        image, e = (self if f == 1 else self._reduced(f))._water(scene, lit, rng)
        if self.backgrounds is not None:
            return image
        if f > 1:
            image = cv2.resize(image, (w, h), interpolation=cv2.INTER_LINEAR)
        if scene.shore is not None:
            self._add_land(image, scene, e["gain"])
        if not e["hit"].all():
            self._add_sky(image, scene, e["gain"])
        return image

    def _water(self, scene: Scene, lit: Lighting, rng) -> tuple[np.ndarray, dict]:
        """(H, W, 3) uint8 sRGB water (or the user's photo) at this compositor's size, and
        the smooth terms it was drawn with (:meth:`_environment`)."""
        model, pose = self.model, scene.camera
        w, h = model.width, model.height
        e = self._environment(scene, lit)
        if self.backgrounds is not None:
            photo = self.backgrounds.pick(scene.texture_seed, w, h)
            gain = linear_to_srgb(np.clip(e["gain"] * 0.5, 0, 1)) * 255.0 / (
                linear_to_srgb(np.float32(0.5)) * 255.0)
            g = cv2.resize(np.clip(gain * 128.0, 0, 255).astype(np.uint8), (w, h),
                           interpolation=cv2.INTER_LINEAR)
            return cv2.multiply(photo, g, scale=1.0 / 128.0), e
        env_srgb = linear_to_srgb(e["env"]) * 255.0  # (gh, gw, 3)
        # one pass over the wave texture: E * (1 + amp * slope . g) + whitecaps, with E the
        # brightest background colour; then the smooth map 2 * env / E corrects it per pixel
        e_max = np.maximum(env_srgb.reshape(-1, 3).max(0), 1.0)
        sigma2 = slope_variance(scene.wind)
        az = math.radians(scene.sun_azimuth - pose.heading)
        gx, gy = math.sin(az), -math.cos(az)
        amp = min(0.55, 2.2 * math.sqrt(sigma2 / 2)) * (
            0.6 + 0.4 * math.cos(math.radians(scene.sun_elevation)))
        k = amp / SLOPE_SCALE
        foam = self.config.whitecaps * max(0.0, (scene.wind - 5.0) / 10.0)
        half = e_max / 2.0
        m = np.zeros((3, 4), np.float32)
        m[:, 0] = half * k * gx
        m[:, 1] = half * k * gy
        m[:, 2] = foam * 0.9
        m[:, 3] = half * (1.0 - 128.0 * k * (gx + gy))
        tex = self._wave_view(scene, rng)  # (h, w, 3) uint8
        water = cv2.transform(tex, m)
        ratio = np.clip(env_srgb * np.float32(128.0) / half, 0, 255).astype(np.uint8)
        big = cv2.resize(ratio, (w, h), interpolation=cv2.INTER_LINEAR)
        image = cv2.multiply(water, big, scale=1.0 / 128.0)
        glint = e["glint"]
        if float(glint.max()) > 0.004:
            glint_srgb = linear_to_srgb(np.clip(e["env"] + glint, 0, 1)) * 255.0 - env_srgb
            g = cv2.resize(np.clip(glint_srgb, 0, 255).astype(np.uint8), (w, h),
                           interpolation=cv2.INTER_LINEAR)
            # 100 * (0.35 + 2.5 * sparkle / 255) in every channel
            sparkle = cv2.transform(tex, SPARKLE_MATRIX)
            image = cv2.add(image, cv2.multiply(g, sparkle, scale=1 / 100.0))
        if float(e["t_floor"].max()) >= FLOOR_VISIBLE:
            self._add_floor(image, scene, e)
        return image, e

    def _wave_view(self, scene: Scene, rng) -> np.ndarray:
        model, pose = self.model, scene.camera
        rel = (scene.swell_direction - pose.heading) % 180.0
        tile = self.waves[int(round(rel / 180.0 * len(self.waves))) % len(self.waves)]
        x0, y0 = rng.uniform(0, 1000, 2)
        if pose.pitch >= 89.999:
            gx, gy = model.nadir_gsd(pose.altitude)
            return tile.view(x0, y0, gx * model.width, gy * model.height, model.width,
                             model.height)
        return self._perspective_sample(tile, pose, x0, y0)

    def _perspective_sample(self, tile: Texture, pose: CameraPose, x0: float, y0: float
                            ) -> np.ndarray:
        """Sample a ground texture through the camera (oblique views): image rows map to
        ground distance, columns to the lateral offset, in the camera's heading frame.

        Rows whose pixels span many texels would alias: they fade to the tile's mean (and
        rows that are all mean, beyond the fade or above the horizon, are not sampled)."""
        model = self.model
        w, h = model.width, model.height
        u = (np.arange(w, dtype=np.float32) + 0.5 - w / 2) / model.fx
        v = (np.arange(h, dtype=np.float32) + 0.5 - h / 2) / model.fy
        p = math.radians(pose.pitch)
        # camera frame ray (u, v, 1) in (forward-horizontal, right, up) components
        fwd = math.cos(p) - v * math.sin(p)
        up = -math.sin(p) - v * math.cos(p)
        valid_row = up < -1e-4
        t = np.where(valid_row, pose.altitude / np.maximum(-up, 1e-4), np.inf)  # distance
        centre = min(int(h * 0.75), h - 1)
        pitch_m = float(t[centre]) / model.fx if valid_row[centre] else 1.0
        row_pitch = t / model.fx  # metres per pixel per row
        over = np.log2(np.maximum(row_pitch / max(pitch_m, 1e-9), 1e-9))
        keep = np.clip(1.5 - over, 0.0, 1.0).astype(np.float32)  # (h,) 1: texture, 0: mean
        mean = tile.mean
        # one row of the mean colour (whole rows are copied fast; a (C,) broadcast is not)
        mean_row = np.tile(np.clip(mean + 0.5, 0, 255).astype(np.uint8), w)
        out = np.empty((h, w, mean.size), np.uint8)
        rows = np.flatnonzero(keep > 0)
        r0, r1 = (int(rows[0]), int(rows[-1]) + 1) if rows.size else (h, h)
        out.reshape(h, -1)[:r0] = mean_row
        out.reshape(h, -1)[r1:] = mean_row
        if r0 == r1:
            return out
        tex = tile.sample_rows(x0, y0, t[r0:r1], u, -fwd[r0:r1] * t[r0:r1], pitch_m)
        out[r0:r1] = tex
        fade = np.flatnonzero(keep[r0:r1] < 1) + r0  # rows of tex x keep + mean x (1 - keep)
        if fade.size:
            f0, f1 = int(fade[0]), int(fade[-1]) + 1
            band = out[f0:f1]
            k = np.repeat(keep[f0:f1, None], w, axis=1)
            means = np.repeat(mean_row[None], f1 - f0, axis=0).reshape(band.shape)
            cv2.blendLinear(band, means, k, 1.0 - k, dst=band)
        return out

    def _add_floor(self, image: np.ndarray, scene: Scene, e: dict) -> None:
        """Sea-floor texture detail (rocks, sand ripples) where the floor shows through,
        added in place to the uint8 ``image`` (the mean floor colour is in the background
        already)."""
        model, pose = self.model, scene.camera
        w, h = model.width, model.height
        apparent = pose.altitude + scene.floor_depth / REFRACTIVE_INDEX
        rng = np.random.default_rng([scene.texture_seed, 2])
        x0, y0 = rng.uniform(0, 1000, 2)
        if pose.pitch >= 89.999:
            gx, gy = model.nadir_gsd(apparent)
            tex = self.floor.view(x0, y0, gx * w, gy * h, w, h)
        else:
            tex = self._perspective_sample(self.floor, CameraPose(apparent, pose.pitch,
                                                                  pose.heading), x0, y0)
        k = e["t_floor"] * e["gain"] * e["tint"] * e["light"] * (FLOOR_LIGHT * 0.6)
        k8 = np.clip(linear_to_srgb(k) * 255.0, 0, 255).astype(np.uint8)
        kmap = cv2.resize(k8, (w, h), interpolation=cv2.INTER_LINEAR)
        detail = cv2.multiply(tex, kmap, scale=1.0 / 255.0)
        mean = cv2.multiply(kmap, tuple(float(v) for v in self.floor.mean) + (0.0,),
                            scale=1.0 / 255.0)
        cv2.add(image, detail, dst=image)
        cv2.subtract(image, mean, dst=image)

    def _add_land(self, image, scene: Scene, gain) -> None:
        """Land beyond the coastline: a textured polygon with a foam line at the shore."""
        model, pose = self.model, scene.camera
        w, h = model.width, model.height
        shore = scene.shore
        a = math.radians(shore.angle)
        normal = np.array([math.cos(a), math.sin(a)])
        along_dir = np.array([-math.sin(a), math.cos(a)])
        reach = pose.altitude * 8  # beyond the frame of any view that sees the coast
        along = np.linspace(-reach, reach, 800)
        across = shore.distance + coast_wiggle(shore, along)
        coast = along[:, None] * along_dir + across[:, None] * normal
        far = coast + normal * reach
        poly_world = np.concatenate([coast, far[::-1]])
        pts = np.concatenate([poly_world, np.zeros((len(poly_world), 1))], axis=1)
        uv, depth = project(model, pose, pts)
        ok = (depth > 1e-3) & np.isfinite(uv).all(axis=1)
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
        bx, by, bw, bh = cv2.boundingRect(cv2.bitwise_or(mask, foam))
        win = (slice(by, by + bh), slice(bx, bx + bw))  # only where land or foam is
        m = mask[win].astype(np.float32) * np.float32(1.0 / 255.0)
        land = cv2.blendLinear(image[win], cv2.convertScaleAbs(tex[win], alpha=g), 1.0 - m, m)
        f = foam[win].astype(np.float32) * np.float32(0.7 / 255.0)
        white = np.full_like(land, min(255, round(230.0 * g)))
        image[win] = cv2.blendLinear(land, white, 1.0 - f, f)

    def _add_sky(self, image, scene: Scene, gain) -> None:
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
        # elevation sine of each row's ray through the image centre column
        up = -math.sin(p) - vv * math.cos(p)
        fwd = math.cos(p) - vv * math.sin(p)
        sin_el = up / np.sqrt(up ** 2 + fwd ** 2)
        col = sky_linear(np.clip(sin_el, 0, 1)) * float(np.mean(gain[0]))
        col = linear_to_srgb(col) * 255.0
        image[:rows] = np.clip(col + 0.5, 0, 255).astype(np.uint8)[:, None, :]
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
            img = image.astype(np.float32) * (1 - cover) + cover * hill.astype(np.float32)
            image[:] = np.clip(img + 0.5, 0, 255).astype(np.uint8)

    # ------------------------------------------------------------------ layers
    def _layers(self, scene: Scene, lit: Lighting) -> list[Layer]:
        cam = scene.camera.position
        layers = []
        for i, pl in enumerate(scene.placements):
            src = (self.objects if pl.kind == "object" else self.clutter)[pl.model]
            layer = self._layer(i, pl, src, scene, lit, cam)
            if layer is not None:
                layers.append(layer)
        layers.sort(key=lambda lay: -lay.depth)  # far first
        return layers

    def _layer(self, i, pl, src: SpriteSource, scene, lit: Lighting, cam):
        model, basis, sun, cos_sun_t = self.model, lit.basis, lit.sun, lit.cos_sun_t
        hd = math.radians(pl.heading)
        rz = np.array([[math.cos(hd), -math.sin(hd), 0], [math.sin(hd), math.cos(hd), 0],
                       [0, 0, 1]])
        rot = rz @ tilt_matrix(pl.roll, pl.pitch)  # body -> world
        origin = np.array([pl.x, pl.y, -pl.draft]) - src.waterline * rot[:, 2]
        to_cam = cam - origin
        d_world = to_cam / math.sqrt(float(to_cam @ to_cam))
        pose_i = src.nearest(d_world @ rot)  # rot.T @ d_world
        vb = src.bases[pose_i]  # rows right, up, toward in the body frame
        xc = basis @ -to_cam
        z = float(xc[2])
        if z <= 0.05:
            return None
        fx, fy = model.fx, model.fy
        jac = np.array([[fx / z, 0, -fx * xc[0] / z ** 2],
                        [0, fy / z, -fy * xc[1] / z ** 2]]) @ basis
        # (2, 2): image pixels per sprite pixel along the sprite's right and down
        a = (jac @ rot) @ (vb[:2].T * np.array([src.metres_per_pixel,
                                                -src.metres_per_pixel]))
        u0 = fx * xc[0] / z + model.width / 2
        v0 = fy * xc[1] / z + model.height / 2
        scale = math.sqrt(abs(a[0, 0] * a[1, 1] - a[0, 1] * a[1, 0]))
        if scale <= 0:
            return None
        level = min(max(math.floor(math.log2(1.0 / scale)), 0), src.max_level) \
            if scale < 1 else 0
        n = src.size >> level
        a_l = a * (1 << level)
        (a00, a01), (a10, a11) = a_l.tolist()
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
        prepared = src.prepared(pose_i, level)
        height = prepared[3]
        if pl.roll or pl.pitch:
            height = _tilted_heights(height, vb, src, level, rot[2])
        # channels: premultiplied sRGB colour (3), coverage, weight
        stack = np.empty(prepared[0].shape + (5,), np.float32)
        stack[..., 3] = prepared[0]
        self._shade(stack, prepared, height, vb, rot, d_world, pl, scene, lit, u0, v0)
        m = np.array([[a00, a01, tx - x0], [a10, a11, ty - y0]], np.float32)
        warped = cv2.warpAffine(stack, m, (x1 - x0, y1 - y0), flags=cv2.INTER_LINEAR,
                                borderMode=cv2.BORDER_CONSTANT, borderValue=0)
        if warped.ndim == 2:
            warped = warped[..., None]
        # coverage and weight: bilinear mixes of values in [0, 1] with weights >= 0 summing
        # to 1 (within rounding): capped at 1 in place
        coverage = warped[..., 3:5]
        np.minimum(coverage, 1.0, out=coverage)
        # shadow on the water: under water at the depth light scatters back from (or on
        # the floor in clear water), displaced away from the sun
        c = scene.attenuation
        d_s = min(1.0 / c, scene.floor_depth)
        sx, sy, _ = sun.tolist()
        sun_h = max(math.hypot(sx, sy), 1e-9)
        k = d_s * (sun_h / REFRACTIVE_INDEX) / max(cos_sun_t, 0.05) / sun_h
        off = jac @ np.array([-sx * k, -sy * k, -d_s / REFRACTIVE_INDEX])
        t_floor = math.exp(-c * scene.floor_depth * 2)
        strength = 0.45 * (1 - math.exp(-2 * c * d_s)) + 0.45 * t_floor
        blur = min(max(0.08 * d_s * fx / z, 0.0), 12.0)  # metres / (z / fx metres per px)
        return Layer(i, pl.kind, pl.model, z, (x0, y0, x1, y1), warped[..., :3],
                     warped[..., 3], warped[..., 4], (float(off[0]), float(off[1])),
                     float(strength), blur)

    def _shade(self, out, prepared, height, vb, rot, d_world, pl, scene, lit: Lighting,
               u0, v0) -> None:
        """Write the relit, submerged, premultiplied sRGB colour (0..255) of ``prepared`` to
        ``out[..., :3]`` and its weight (coverage x water transmittance) to ``out[..., 4]``
        (``out``: (n, n, 5) float32; ``height``: (n, n) float32 metres above the sea level
        of the floating body).

        In linear RGB, with ``t`` the water's transmittance down to a pixel and back and
        ``r`` the Fresnel reflectance toward the camera, a dry pixel is ``albedo x light``
        and a submerged one ``(albedo x light x t + body x (1 - t)) x (1 - r) + sky x r``;
        both are ``albedo x light x t x (1 - r u) + body x (1 - r) x (1 - t) + sky x r u``
        with ``u`` 1 under water and 0 above (where ``t`` is 1), all times the camera gain.
        """
        alpha, albedo, normal = prepared[:3]
        sun, wb, body = lit.sun, lit.wb, lit.body
        sun_view = (vb @ (rot.T @ sun)).astype(np.float32)
        light = normal @ sun_view
        np.maximum(light, 0.0, out=light)
        light *= np.float32(SUN * 0.5 * float(sun[2] > 0))
        light += np.float32(scene.ambient)
        w, h = self.model.width, self.model.height
        r2 = ((u0 - w / 2) ** 2 + (v0 - h / 2) ** 2) / ((w / 2) ** 2 + (h / 2) ** 2)
        gain = wb * np.float32(1.0 - scene.effects.vignetting * min(r2, 1.0))
        cz = float(d_world[2])
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
            # renumber inside each object's box (frames can be huge), in increasing old id:
            # new ids never exceed old ones, so a renumbered pixel is not matched again
            for lay in sorted(objs, key=lambda lay: ids[lay.placement]):
                old = ids[lay.placement]
                x0, y0, x1, y1 = lay.roi
                win = instances[y0:y1, x0:x1]
                win[win == old] = relabel[old]
        return instances, out, n_objects - len(out)

    # ------------------------------------------------------------------ effects
    def _finish(self, image: np.ndarray, scene: Scene, rng) -> np.ndarray:
        """Blur and sensor noise on the uint8 image."""
        fx = scene.effects
        h, w = image.shape[:2]
        if max(h, w) > BLUR_EXACT_MAX and (fx.motion_blur or fx.defocus_blur):
            # huge frames: the blur kernels grow with the frame (hundreds of pixels at
            # 30000 px); blur a copy reduced to BLUR_WORK_SIZE and magnify it back into
            # the frame (detail finer than the reduction factor, 8 px at 30000, is lost);
            # an integer factor takes OpenCV's fast area-averaging path
            f = math.ceil(max(h, w) / BLUR_WORK_SIZE)
            small = cv2.resize(image, (max(1, round(w / f)), max(1, round(h / f))),
                               interpolation=cv2.INTER_AREA)
            if fx.motion_blur is not None:
                length, angle = fx.motion_blur
                small = _motion_blur(small, length / f, angle)
            if fx.defocus_blur is not None:
                small = cv2.GaussianBlur(small, (0, 0), fx.defocus_blur / f)
            cv2.resize(small, (w, h), dst=image, interpolation=cv2.INTER_LINEAR)
        else:
            if fx.motion_blur is not None:
                image = _motion_blur(image, *fx.motion_blur)
            if fx.defocus_blur is not None:
                image = cv2.GaussianBlur(image, (0, 0), fx.defocus_blur)
        if fx.noise > 0:
            image = _add_noise(image, self.noise, fx.noise / NOISE_SCALE, rng)
        return image


def _noise_tile(seed: int, h: int, w: int) -> np.ndarray:
    """The sensor-noise tile of frames of (h, w) pixels: (nh, nw, 3) uint8,
    ``128 + NOISE_SCALE x N(0, 1)``, a function of ``seed``, at least 1021 pixels larger than
    the frame in each direction up to 1024 (frames larger than it get it added block by
    block: :func:`_add_noise`)."""
    rng = np.random.default_rng([seed, 31337])
    nh, nw = min(h, 1024) + 1021, min(w, 1024) + 1031
    noise = 128.0 + NOISE_SCALE * rng.standard_normal((nh, nw, 1))
    return np.repeat(np.clip(np.rint(noise), 0, 255).astype(np.uint8), 3, axis=2)


def _add_noise(image: np.ndarray, noise: np.ndarray, s: float, rng) -> np.ndarray:
    """``image + s * (noise - 128)`` for a uint8 (H, W, 3) ``image`` and a uint8 noise tile
    (at least 1021 pixels larger than the image in each direction up to 1024 pixels).
    A frame that fits the tile gets a random window of it (a new array); a larger frame
    gets the tile added block by block in place (frames of gigabytes are not copied), at a
    random offset."""
    h, w = image.shape[:2]
    nh, nw = noise.shape[:2]
    if h <= nh and w <= nw:
        oy = int(rng.integers(nh - h + 1))
        ox = int(rng.integers(nw - w + 1))
        return cv2.addWeighted(image, 1.0, noise[oy:oy + h, ox:ox + w], s, -128.0 * s)
    oy, ox = int(rng.integers(nh)), int(rng.integers(nw))
    for y in range(-oy, h, nh):
        for x in range(-ox, w, nw):
            ty0, tx0 = max(y, 0), max(x, 0)
            ty1, tx1 = min(y + nh, h), min(x + nw, w)
            block = image[ty0:ty1, tx0:tx1]
            cv2.addWeighted(block, 1.0, noise[ty0 - y:ty1 - y, tx0 - x:tx1 - x], s,
                            -128.0 * s, dst=block)
    return image


def _motion_blur(image: np.ndarray, length: float, angle: float) -> np.ndarray:
    """Motion blur of a uint8 (H, W, C) ``image`` along a line of ``length`` pixels at
    ``angle`` degrees, borders reflected: a convolution with :func:`_motion_kernel` for
    short lines, :func:`_line_mean` (the same line, its taps one pixel apart) from
    :data:`LINE_TAPS_MIN` taps on, where a dense kernel costs seconds per 20-megapixel
    frame."""
    if round(length) < LINE_TAPS_MIN:
        return cv2.filter2D(image, -1, _motion_kernel(length, angle),
                            borderType=cv2.BORDER_REFLECT)
    return _line_mean(image, int(round(length)), angle)


def _line_mean(image: np.ndarray, n: int, angle: float) -> np.ndarray:
    """Mean of ``n`` taps of a uint8 (H, W, C) ``image`` one pixel apart along ``angle``
    degrees, centred on each pixel, borders reflected; uint8 (H, W, C).

    Sums of ``2**k`` consecutive taps are built by doubling (the sum of ``2m`` taps is the
    sum of ``m`` plus the same shifted by ``m`` taps) and ``n`` is put together from its
    binary digits: ``2 log2(n)`` whole-frame additions instead of ``n**2`` multiplications
    per pixel. Tap positions are rounded per piece, so a tap can sit up to about
    ``log2(n) / 2`` pixels off the exact line. The frame is done in bands of rows of about
    :data:`LINE_BAND_BYTES` of sums (at least ``8 n`` rows, so the rows a band shares with its
    neighbours stay under a quarter): fresh frame-sized sums cost more in page faults than
    in additions, and memory at the peak of a huge frame.
    """
    dx, dy = math.cos(math.radians(angle)), math.sin(math.radians(angle))

    def at(t: float) -> tuple[int, int]:
        return int(round(t * dx)), int(round(t * dy))

    pad = n + 2
    h, w, c = image.shape[0], image.shape[1], (image.shape[2] if image.ndim == 3 else 1)
    dtype = np.uint16 if n <= 257 else np.int32
    row_bytes = (w + 2 * pad) * c * np.dtype(dtype).itemsize
    rows = max(LINE_BAND_BYTES // row_bytes - 2 * pad, 8 * pad)  # overlap at most 1/4
    out = np.empty_like(image)
    cx, cy = at(-(n - 1) / 2)  # centre the line on the pixel
    for y in range(0, h, rows):
        y1 = min(h, y + rows)
        # rows y - pad .. y1 + pad, reflected at the frame's top and bottom only
        top, bottom = max(0, y - pad), min(h, y1 + pad)
        slab = cv2.copyMakeBorder(image[top:bottom], pad - (y - top), pad - (bottom - y1),
                                  pad, pad, cv2.BORDER_REFLECT)
        piece = (slab.astype(dtype), 0, 0)
        total, start, m = None, 0, 1
        while True:
            if n & m:  # the next m taps, from tap `start` on
                ox, oy = at(start)
                moved = (piece[0], piece[1] - ox, piece[2] - oy)
                total = moved if total is None else _sum_shifted(total, moved, (0, 0))
                start += m
            if 2 * m > n:
                break
            piece = _sum_shifted(piece, piece, at(m))
            m *= 2
        arr, x0, y0 = total
        ys, xs = pad + cy - y0, pad + cx - x0  # the band's corner in `arr`
        band = cv2.convertScaleAbs(arr[ys:ys + y1 - y, xs:xs + w], alpha=1.0 / n)
        out[y:y1] = band.reshape(out[y:y1].shape)
    return out


def _sum_shifted(a: tuple, b: tuple, shift: tuple[int, int]) -> tuple:
    """``c(q) = a(q) + b(q + shift)`` over the points ``q`` where both are defined.

    Each argument and the result is ``(array, x0, y0)``: ``array[y, x]`` holds the value at
    canvas point ``(x0 + x, y0 + y)``."""
    (pa, ax, ay), (pb, bx, by), (sx, sy) = a, b, shift
    x0, y0 = max(ax, bx - sx), max(ay, by - sy)
    x1 = min(ax + pa.shape[1], bx - sx + pb.shape[1])
    y1 = min(ay + pa.shape[0], by - sy + pb.shape[0])
    out = cv2.add(pa[y0 - ay:y1 - ay, x0 - ax:x1 - ax],
                  pb[y0 + sy - by:y1 + sy - by, x0 + sx - bx:x1 + sx - bx])
    return out, x0, y0


def _motion_kernel(length: float, angle: float) -> np.ndarray:
    """Normalised line kernel of ``length`` pixels at ``angle`` degrees."""
    k = int(max(3, round(length) | 1))
    kernel = np.zeros((k, k), np.float32)
    c = k // 2
    dx, dy = math.cos(math.radians(angle)), math.sin(math.radians(angle))
    for t in np.linspace(-length / 2, length / 2, 4 * k):
        kernel[int(round(c + t * dy)) % k, int(round(c + t * dx)) % k] += 1
    return kernel / kernel.sum()


def _tilted_heights(height: np.ndarray, vb: np.ndarray, src: SpriteSource, level: int,
                    row: np.ndarray) -> np.ndarray:
    """(n, n) float32 heights above the sea of the body tilted by the placement's roll and
    pitch, from the level body's ``height`` (n, n) float32 of a sprite of mip ``level``;
    ``row`` (3,) is the last row of the body's rotation (the tilt's: heading keeps z).

    A pixel at sprite position (x right, y up, metres from the body origin) with level
    height ``h`` is the body-frame point ``p = x r + y u + d t`` (``vb`` rows r, u, t:
    right, up, toward) whose z is ``h + waterline``, so ``d = (h + wl - x r_z - y u_z) /
    t_z``. Its tilted height about the waterline point is ``row . p - wl row_z`` with
    ``row`` the tilt matrix's last row: linear in (x, y, h), computed as
    ``h * k + plane(x, y)``. (Uncovered pixels get a height too; they have no colour.)
    """
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


def lighting(scene: Scene) -> Lighting:
    """The camera basis, sun, camera gain and water light of ``scene``: the water body's
    radiance grows brighter and more opaque with turbidity."""
    pose = scene.camera
    sun = sun_direction(scene.sun_elevation, scene.sun_azimuth)
    wb = np.asarray(scene.effects.white_balance, np.float32) * np.float32(
        2.0 ** scene.effects.exposure)
    water_lin = srgb_to_linear(np.asarray(scene.water_rgb, np.float32) / 255.0)
    light = scene.ambient + SUN * max(float(sun[2]), 0.0) * 0.55
    body = water_lin * np.float32((0.45 + 0.55 * scene.turbidity) * light)
    cos_sun_t = float(refracted_cos(max(float(sun[2]), 0.05)))
    return Lighting(camera_basis(pose.pitch, pose.heading), sun, wb, water_lin, light, body,
                    cos_sun_t)


def _centre_gsd(model: CameraModel, pose) -> float:
    """Metres per pixel (along x) at the image centre (altitude / fx straight down)."""
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
    a = cv2.copyMakeBorder(layer.alpha, pad, pad, pad, pad, cv2.BORDER_CONSTANT, value=0)
    if layer.shadow_blur > 0.3:
        a = cv2.GaussianBlur(a, (0, 0), layer.shadow_blur)
    ox, oy = layer.shadow_offset
    sx, sy = int(round(x0 - pad + ox)), int(round(y0 - pad + oy))
    ax0, ay0 = max(sx, 0), max(sy, 0)
    ax1, ay1 = min(sx + a.shape[1], w), min(sy + a.shape[0], h)
    if ax1 <= ax0 or ay1 <= ay0:
        return
    sub = a[ay0 - sy:ay1 - sy, ax0 - sx:ax1 - sx]
    region = image[ay0:ay1, ax0:ax1]
    shade = (1.0 - layer.shadow_strength * sub)[..., None]
    region[:] = (region.astype(np.float32) * shade + 0.5).astype(np.uint8)


def _over(image: np.ndarray, layer: Layer, below: list[Layer]) -> None:
    """Composite ``layer`` over ``image`` and reduce the weights of the layers it covers."""
    x0, y0, x1, y1 = layer.roi
    region = image[y0:y1, x0:x1]
    out = region.astype(np.float32) * (1.0 - layer.alpha)[..., None] + layer.colour
    region[:] = np.clip(out + 0.5, 0, 255).astype(np.uint8)
    for other in below:
        ox0, oy0, ox1, oy1 = other.roi
        ix0, iy0, ix1, iy1 = max(x0, ox0), max(y0, oy0), min(x1, ox1), min(y1, oy1)
        if ix1 <= ix0 or iy1 <= iy0:
            continue
        other.weight[iy0 - oy0:iy1 - oy0, ix0 - ox0:ix1 - ox0] *= (
            1.0 - layer.alpha[iy0 - y0:iy1 - y0, ix0 - x0:ix1 - x0])
