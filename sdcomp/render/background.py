"""The background of an image: procedural water (or the user's photo), land and sky.

Smooth terms (the water body's colour, the floor seen through the water, Fresnel sky
reflection, the sun's glint lobe, haze, the camera gain) are computed on a coarse grid every
:data:`GRID` pixels (:meth:`Background.environment`) and interpolated; texture detail comes
from periodic tiles seen through the camera (:mod:`sdcomp.render.ground`). Looking straight
down, the water is drawn up to :data:`REDUCE_MAX` times smaller where its textures are
magnified that much anyway, and magnified once (land and sky are then drawn at full size).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from ..scene.camera import CameraModel, camera_rays
from ..scene.scene import Scene
from ..util.colour import linear_to_srgb, srgb_to_linear
from .ground import ground_view, offsets
from .land import add_land, add_sky
from .lighting import SUN, Lighting
from .optics import (
    REFRACTIVE_INDEX,
    SKY_HORIZON_RGB,
    SLOPE_SCALE,
    fresnel,
    refracted_cos,
    sky_linear,
    slope_variance,
)
from .photos import Backgrounds
from .textures import Textures

GRID = 16  # pixels between samples of the smooth background terms
REDUCE_MAX = 8  # nadir water is drawn up to this many times smaller when its texture allows
REDUCE_MIN_SIZE = 16  # pixels: a reduced water background is at least this wide and high
FLOOR_VISIBLE = 0.01  # floor detail is drawn where its transmittance reaches this
HAZE_DISTANCE = 4000.0  # metres: visibility through the air (exponential haze)
GLINT_GAIN = 0.014  # sun glint: Fresnel x sun/sky irradiance ratio / 4 / pi
FLOOR_LIGHT = 0.6  # fraction of the surface light reaching the floor and back
SPARKLE_MATRIX = np.array([[0.0, 0.0, 2.5 / 255.0 * 100.0, 35.0]] * 3, np.float32)


@dataclass(frozen=True)
class Environment:
    """The smooth terms of a background on its coarse grid (gh, gw) (see
    :meth:`Background.environment`); radiances are linear RGB with the camera gain."""

    env: np.ndarray  # (gh, gw, 3) float32 water (or sky) radiance
    glint: np.ndarray  # (gh, gw, 3) float32 sun glint radiance
    t_floor: np.ndarray  # (gh, gw, 1) float32 transmittance down to the floor and back
    gain: np.ndarray  # (gh, gw, 3) float32 camera gain (white balance, vignetting)
    hit: np.ndarray  # (gh, gw) bool: the ray meets the sea
    tint: np.ndarray  # (3,) float32 the water's colour, brightest channel 1
    light: float  # irradiance on the surface, linear


def floor_visible(scene: Scene, lit: Lighting) -> bool:
    """Whether the floor's transmittance straight down reaches :data:`FLOOR_VISIBLE` (it is
    highest there: the shortest path through the water)."""
    path = 1.0 + 1.0 / lit.cos_sun_t
    return math.exp(-scene.attenuation * scene.floor_depth * path) >= FLOOR_VISIBLE


class Background:
    """Draws backgrounds at the size of ``model`` (which may be smaller than the scene's
    camera: large frames and reduced water are drawn small and magnified)."""

    def __init__(self, model: CameraModel, textures: Textures, photos: Backgrounds | None,
                 grid: int = GRID):
        """``grid``: pixels between the samples of the smooth terms."""
        self.model = model
        self.textures = textures
        self.photos = photos
        w, h = model.width, model.height
        grid_w = max(2, math.ceil(w / grid) + 1)
        grid_h = max(2, math.ceil(h / grid) + 1)
        gu, gv = np.meshgrid(np.linspace(0, w, grid_w), np.linspace(0, h, grid_h))
        r2 = ((gu - w / 2) ** 2 + (gv - h / 2) ** 2) / ((w / 2) ** 2 + (h / 2) ** 2)
        self.grid_r2 = r2.astype(np.float32)
        # unit view rays of the grid in the camera frame (the world frame: times the basis)
        self.grid_rays = camera_rays(model, gu, gv).astype(np.float32)
        self._smaller: dict[int, Background] = {}  # reduced(f), made on first use
        self.floor_mean = srgb_to_linear(textures.floor.mean / 255.0)

    def reduction(self, scene: Scene, lit: Lighting) -> int:
        """How many times smaller (1, 2, 4 or 8) the water of ``scene`` can be drawn and
        then magnified without losing detail: the largest power of two, at most
        :data:`REDUCE_MAX`, by which the wave texture and the visible sea floor are already
        magnified at this size (their texels cover at least that many pixels). Only
        straight-down views (oblique ones sample the textures per pixel) of water (not the
        user's photos)."""
        pose, m = scene.camera, self.model
        if self.photos is not None or pose.pitch < 89.999:
            return 1
        textures = [(self.textures.waves[0], pose.altitude)]
        if floor_visible(scene, lit):
            textures.append((self.textures.floor,
                             pose.altitude + scene.floor_depth / REFRACTIVE_INDEX))
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

    def reduced(self, f: int) -> Background:
        """A background of this one's camera ``f`` times smaller (the same number of grid
        samples)."""
        if f not in self._smaller:
            m = self.model
            small = CameraModel(m.sensor_width, m.sensor_height, m.diagonal_fov,
                                max(1, round(m.width / f)), max(1, round(m.height / f)))
            self._smaller[f] = Background(small, self.textures, self.photos,
                                          grid=max(1, GRID // f))
        return self._smaller[f]

    def draw(self, scene: Scene, lit: Lighting, rng: np.random.Generator) -> np.ndarray:
        """(H, W, 3) uint8 sRGB background: the user's photo, or the water drawn
        :meth:`reduction` times smaller and magnified, with land and sky drawn on it at
        full size. ``rng`` is the waves' stream (:attr:`FeatureSeeds.waves`)."""
        model, pose = self.model, scene.camera
        f = self.reduction(scene, lit)
        image, e = (self if f == 1 else self.reduced(f)).water(scene, lit, rng)
        if self.photos is not None:
            return image
        if f > 1:
            image = cv2.resize(image, (model.width, model.height),
                               interpolation=cv2.INTER_LINEAR)
        if scene.shore is not None:
            add_land(image, model, pose, scene.shore, self.textures.land, e.gain,
                     scene.seeds.land)
        if not e.hit.all():
            add_sky(image, model, pose, scene.hills, e.gain)
        return image

    def environment(self, scene: Scene, lit: Lighting) -> Environment:
        """The smooth terms on the coarse grid: ``(1 - R) (body (1 - T) + floor T) + R sky``
        with ``R`` the Fresnel reflectance and ``T`` the floor's transmittance per grid
        point, hazed with distance, the sun's glint lobe from the Cox-Munk slope
        distribution, and the camera gain."""
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
        return Environment(env, glint[..., None] * (1 - haze) * gain, t_floor, gain, hit,
                           tint, light)

    def water(self, scene: Scene, lit: Lighting, rng: np.random.Generator
              ) -> tuple[np.ndarray, Environment]:
        """(H, W, 3) uint8 sRGB water (or the user's photo) at this background's size, and
        the smooth terms it was drawn with."""
        model = self.model
        w, h = model.width, model.height
        e = self.environment(scene, lit)
        if self.photos is not None:
            return self._photo(scene, e), e
        env_srgb = linear_to_srgb(e.env) * 255.0  # (gh, gw, 3)
        tex = self._wave_view(scene, rng)  # (h, w, 3) uint8
        water = cv2.transform(tex, self._wave_shading(scene, env_srgb))
        # the smooth map 2 * env / E corrects the wave pass per pixel
        half = np.maximum(env_srgb.reshape(-1, 3).max(0), 1.0) / 2.0
        ratio = np.clip(env_srgb * np.float32(128.0) / half, 0, 255).astype(np.uint8)
        big = cv2.resize(ratio, (w, h), interpolation=cv2.INTER_LINEAR)
        image = cv2.multiply(water, big, scale=1.0 / 128.0)
        if float(e.glint.max()) > 0.004:
            glint_srgb = linear_to_srgb(np.clip(e.env + e.glint, 0, 1)) * 255.0 - env_srgb
            g = cv2.resize(np.clip(glint_srgb, 0, 255).astype(np.uint8), (w, h),
                           interpolation=cv2.INTER_LINEAR)
            # 100 * (0.35 + 2.5 * sparkle / 255) in every channel
            sparkle = cv2.transform(tex, SPARKLE_MATRIX)
            image = cv2.add(image, cv2.multiply(g, sparkle, scale=1 / 100.0))
        if float(e.t_floor.max()) >= FLOOR_VISIBLE:
            self._add_floor(image, scene, e)
        return image, e

    def _photo(self, scene: Scene, e: Environment) -> np.ndarray:
        """The user's photo of ``scene`` under the camera gain of ``e``."""
        assert self.photos is not None
        w, h = self.model.width, self.model.height
        photo = self.photos.pick(scene.seeds.photo, w, h)
        gain = linear_to_srgb(np.clip(e.gain * 0.5, 0, 1)) * 255.0 / (
            linear_to_srgb(np.asarray(0.5, np.float32)) * 255.0)
        g = cv2.resize(np.clip(gain * 128.0, 0, 255).astype(np.uint8), (w, h),
                       interpolation=cv2.INTER_LINEAR)
        return cv2.multiply(photo, g, scale=1.0 / 128.0)

    @staticmethod
    def _wave_shading(scene: Scene, env_srgb: np.ndarray) -> np.ndarray:
        """(3, 4) float32 colour transform of the wave texture's (slope x, slope y, sparkle)
        channels: ``E * (1 + amp * slope . g) + whitecaps`` with ``E`` the brightest
        background colour and ``g`` the sun's direction in the image."""
        e_max = np.maximum(env_srgb.reshape(-1, 3).max(0), 1.0)
        sigma2 = slope_variance(scene.wind)
        az = math.radians(scene.sun_azimuth - scene.camera.heading)
        gx, gy = math.sin(az), -math.cos(az)
        amp = min(0.55, 2.2 * math.sqrt(sigma2 / 2)) * (
            0.6 + 0.4 * math.cos(math.radians(scene.sun_elevation)))
        k = amp / SLOPE_SCALE
        foam = scene.whitecaps * max(0.0, (scene.wind - 5.0) / 10.0)
        half = e_max / 2.0
        m = np.zeros((3, 4), np.float32)
        m[:, 0] = half * k * gx
        m[:, 1] = half * k * gy
        m[:, 2] = foam * 0.9
        m[:, 3] = half * (1.0 - 128.0 * k * (gx + gy))
        return m

    def _wave_view(self, scene: Scene, rng: np.random.Generator) -> np.ndarray:
        """(H, W, 3) uint8 wave texture seen through the camera: the tile of the swell's
        direction relative to the camera, at a random offset."""
        pose, waves = scene.camera, self.textures.waves
        rel = (scene.swell_direction - pose.heading) % 180.0
        tile = waves[int(round(rel / 180.0 * len(waves))) % len(waves)]
        return ground_view(self.model, pose.altitude, pose.pitch, tile, *offsets(rng))

    def _add_floor(self, image: np.ndarray, scene: Scene, e: Environment) -> None:
        """Sea-floor texture detail (rocks, sand ripples) where the floor shows through,
        added in place to the uint8 ``image`` (the mean floor colour is in the background
        already)."""
        model, pose, floor = self.model, scene.camera, self.textures.floor
        w, h = model.width, model.height
        apparent = pose.altitude + scene.floor_depth / REFRACTIVE_INDEX
        rng = np.random.default_rng(list(scene.seeds.floor))
        tex = ground_view(model, apparent, pose.pitch, floor, *offsets(rng))
        k = e.t_floor * e.gain * e.tint * e.light * (FLOOR_LIGHT * 0.6)
        k8 = np.clip(linear_to_srgb(k) * 255.0, 0, 255).astype(np.uint8)
        kmap = cv2.resize(k8, (w, h), interpolation=cv2.INTER_LINEAR)
        detail = cv2.multiply(tex, kmap, scale=1.0 / 255.0)
        # a per-channel scalar (OpenCV's Scalar; its type stubs know only arrays)
        mean = cv2.multiply(kmap, tuple(float(v) for v in floor.mean) + (0.0,),  # type: ignore[call-overload]
                            scale=1.0 / 255.0)
        cv2.add(image, detail, dst=image)
        cv2.subtract(image, mean, dst=image)
