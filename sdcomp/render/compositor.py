"""The compositor: renders a :class:`~sdcomp.scene.scene.Scene` to an image with its assets.

Per image, in this order (each stage its own module):

1. **Background** (:mod:`~sdcomp.render.background`): the sea and sky
   (:mod:`~sdcomp.render.water`), land and hills, or one of the user's photos; with the light
   the objects are lit by.
2. **Layers** (:mod:`~sdcomp.render.layers`): every floating object as an atlas sprite,
   lit like the water around it, cut by a wavy waterline and seen through the water below it
   (:mod:`~sdcomp.render.submerge`), mapped to the image by the camera's projection at the
   object.
3. **Composite** (:mod:`~sdcomp.render.composite`): shadows, then the layers far to near,
   premultiplied ``over``; each layer's *weight* ends as the fraction of each pixel's colour
   the object supplies, from which :mod:`sdcomp.annotate` makes the masks.
4. **Defocus** (:mod:`~sdcomp.render.effects`).

That is the scene's light on a pinhole camera's image plane. The camera that records it (lens,
exposure, noise, compression: :mod:`sdcomp.render.camera`) comes after the masks are made,
with them: :meth:`Compositor.record`. The compositor reads nothing but the scene and its
:class:`RenderAssets`.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

import cv2
import numpy as np

from ..atlas.sprites import SpriteSource
from ..scene.camera import CameraModel
from ..scene.scene import Scene
from .background import Background
from .camera import apply_camera
from .camera.sensor import make_noise_tile
from .composite import composite
from .effects import blur
from .harmonise import footage_camera, harmonise
from .layers import Layer, build_layers
from .lighting import lighting
from .photos import Backgrounds
from .textures import Textures
from .water import WaterLight

ONE_THREAD_PIXELS = 512 * 512  # frames up to this size are drawn on one OpenCV thread
BACKGROUND_MAX = 4096  # pixels: larger frames get an upsampled background


@dataclass(frozen=True)
class RenderAssets:
    """What scenes are drawn with: sprites by asset key (:attr:`Placement.asset`), the
    textures and the user's photos (None: procedural water)."""

    sprites: Mapping[str, SpriteSource]
    textures: Textures
    photos: Backgrounds | None = None


@dataclass
class Rendered:
    """A rendered image: ``image`` (H, W, 3) uint8 sRGB (exposed, before the camera's
    look), the ``layers`` drawn on it, far to near, with their final weights, and the
    ``light`` they were lit by."""

    image: np.ndarray
    layers: list[Layer] = field(default_factory=list)
    light: WaterLight | None = None


class Compositor:
    """Renders scenes with one set of :class:`RenderAssets` (see the module docstring).

    Per camera model it keeps a :class:`Background` and a sensor-noise tile, made by
    :meth:`prepare` (call it before forking workers: they inherit them) or on first use."""

    def __init__(self, assets: RenderAssets):
        self.assets = assets
        self._backgrounds: dict[CameraModel, Background] = {}
        self._noise: dict[tuple, np.ndarray] = {}

    def prepare(self, model: CameraModel, noise_seed: tuple[int, ...]) -> None:
        """Make what images of ``model`` need (the background, the noise tile of the run
        whose noise seed is ``noise_seed``) now."""
        self.background(model)
        self.noise_tile(model, noise_seed)

    def render(self, scene: Scene) -> Rendered:
        """``scene`` rendered. Frames of up to :data:`ONE_THREAD_PIXELS` are drawn with
        OpenCV on one thread (its thread pool costs more than it gives on them); the
        process's thread count is restored after."""
        with _threads_for(scene.model):
            return self._render(scene)

    def _render(self, scene: Scene) -> Rendered:
        image, light, magnified = self.draw_background_scaled(scene)
        # over the user's footage: its camera, measured before anything is drawn on it
        footage = (footage_camera(image, magnified, scene.footage_blur)
                   if magnified is not None and scene.footage_blur is not None else None)
        lit = lighting(scene, light)
        layers = build_layers(scene, lit, self.assets.sprites, foam_onto=image)
        composite(image, layers, scene.shadows)
        if footage is not None:
            harmonise(image, layers, footage, scene.seeds.photo)
        image = blur(image, None, scene.defocus_blur)
        return Rendered(image, layers, light)

    def draw_background(self, scene: Scene) -> tuple[np.ndarray, WaterLight]:
        """(the background of ``scene`` (H, W, 3) uint8 at the scene's frame size, the
        objects' light): drawn by :meth:`background` (frames over :data:`BACKGROUND_MAX`
        drawn small, then magnified)."""
        image, light, _ = self.draw_background_scaled(scene)
        return image, light

    def draw_background_scaled(self, scene: Scene
                               ) -> tuple[np.ndarray, WaterLight, float | None]:
        """:meth:`draw_background`'s (image, light) and, over the user's footage, the
        photo's magnification (output pixels per frame pixel; None for procedural water)."""
        model = scene.model
        background = self.background(model)
        image, light, magnified = background.draw(scene)
        if background.model != model:
            scale = model.width / background.model.width
            image = cv2.resize(image, (model.width, model.height),
                               interpolation=cv2.INTER_LINEAR)
            magnified = None if magnified is None else magnified * scale
        return image, light, magnified

    def record(self, scene: Scene, image: np.ndarray, instances: np.ndarray,
               amodal: np.ndarray | None = None
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray | None, dict]:
        """The camera's recording of a rendered ``image`` (H, W, 3) uint8 with its instance
        map (H, W) uint16 and amodal masks (N, H, W) bool (or None): :func:`apply_camera`
        with the scene's look and the run's noise tile (see it for what it returns)."""
        with _threads_for(scene.model):
            tile = self.noise_tile(scene.model, scene.seeds.noise_tile)
            return apply_camera(image, instances, scene.look, tile, amodal)

    def background(self, model: CameraModel) -> Background:
        """The background drawer of ``model``: at most :data:`BACKGROUND_MAX` wide (larger
        frames: the water's light and textures magnified)."""
        bg = self._backgrounds.get(model)
        if bg is None:
            small = model
            if max(model.width, model.height) > BACKGROUND_MAX:
                f = BACKGROUND_MAX / max(model.width, model.height)
                small = CameraModel(model.sensor_width, model.sensor_height,
                                    model.diagonal_fov, max(1, round(model.width * f)),
                                    max(1, round(model.height * f)))
            bg = self._backgrounds[model] = Background(small, self.assets.textures,
                                                       self.assets.photos)
        return bg

    def noise_tile(self, model: CameraModel, seed: tuple[int, ...]) -> np.ndarray:
        """The sensor-noise tile of images of ``model`` in the run of noise seed ``seed``
        (:func:`make_noise_tile`), made once."""
        key = (seed, model.height, model.width)
        tile = self._noise.get(key)
        if tile is None:
            tile = self._noise[key] = make_noise_tile(*key)
        return tile


class _threads_for:
    """Context: OpenCV on one thread for frames of up to :data:`ONE_THREAD_PIXELS` (its
    thread pool costs more than it gives on them), the thread count restored after."""

    def __init__(self, model: CameraModel):
        self.small = model.width * model.height <= ONE_THREAD_PIXELS
        self.threads = 1

    def __enter__(self) -> None:
        self.threads = cv2.getNumThreads()
        if self.small and self.threads != 1:
            cv2.setNumThreads(1)

    def __exit__(self, *exc) -> None:
        if self.small and self.threads != 1:
            cv2.setNumThreads(self.threads)
