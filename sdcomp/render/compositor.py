"""The compositor: renders a :class:`~sdcomp.scene.scene.Scene` to an image with its assets.

Per image, in this order (each stage its own module):

1. **Background** (:mod:`~sdcomp.render.background`): procedural water, sea floor, land and
   sky, or one of the user's photos.
2. **Layers** (:mod:`~sdcomp.render.layers`): every floating object as an atlas sprite,
   relit, submerged and mapped to the image by the camera's projection at the object.
3. **Composite** (:mod:`~sdcomp.render.composite`): shadows, then the layers far to near,
   premultiplied ``over``; each layer's *weight* ends as the fraction of each pixel's colour
   the object supplies, from which :mod:`sdcomp.annotate` makes the masks.
4. **Camera effects** (:mod:`~sdcomp.render.effects`): blur and sensor noise.

The compositor reads nothing but the scene and its :class:`RenderAssets`.
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
from .composite import composite
from .effects import apply_effects, noise_tile
from .layers import Layer, build_layers
from .lighting import lighting
from .photos import Backgrounds
from .textures import Textures

ONE_THREAD_PIXELS = 512 * 512  # frames up to this size are drawn on one OpenCV thread
BACKGROUND_MAX = 1400  # pixels: larger frames get an upsampled background


@dataclass(frozen=True)
class RenderAssets:
    """What scenes are drawn with: sprites by asset key (:attr:`Placement.asset`), the
    ground textures and the user's photos (None: procedural water)."""

    sprites: Mapping[str, SpriteSource]
    textures: Textures
    photos: Backgrounds | None = None


@dataclass
class Rendered:
    """A rendered image: ``image`` (H, W, 3) uint8 sRGB and the ``layers`` drawn on it, far
    to near, with their final weights."""

    image: np.ndarray
    layers: list[Layer] = field(default_factory=list)


class Compositor:
    """Renders scenes with one set of :class:`RenderAssets` (see the module docstring).

    Per camera model it keeps a :class:`Background` and a sensor-noise tile, made by
    :meth:`prepare` (call it before forking workers: they inherit them) or on first use."""

    def __init__(self, assets: RenderAssets):
        self.assets = assets
        self._backgrounds: dict[CameraModel, Background] = {}
        self._noise: dict[tuple, np.ndarray] = {}

    def prepare(self, model: CameraModel, noise_seed: tuple[int, ...]) -> None:
        """Make what images of ``model`` need (background grids, the noise tile of the run
        whose noise seed is ``noise_seed``) now."""
        self.background(model)
        self._noise_tile(model, noise_seed)

    def render(self, scene: Scene) -> Rendered:
        """``scene`` rendered. Frames of up to :data:`ONE_THREAD_PIXELS` are drawn with
        OpenCV on one thread (its thread pool costs more than it gives on them); the
        process's thread count is restored after."""
        threads = cv2.getNumThreads()
        model = scene.model
        if threads == 1 or model.width * model.height > ONE_THREAD_PIXELS:
            return self._render(scene)
        cv2.setNumThreads(1)
        try:
            return self._render(scene)
        finally:
            cv2.setNumThreads(threads)

    def _render(self, scene: Scene) -> Rendered:
        model = scene.model
        lit = lighting(scene)
        rng = np.random.default_rng(list(scene.seeds.waves))
        background = self.background(model)
        image = background.draw(scene, lit, rng)
        if background.model != model:
            image = cv2.resize(image, (model.width, model.height),
                               interpolation=cv2.INTER_LINEAR)
        layers = build_layers(scene, lit, self.assets.sprites)
        composite(image, layers, scene.shadows)
        noise = self._noise_tile(model, scene.seeds.noise_tile)
        image = apply_effects(image, scene.effects, noise, rng)
        return Rendered(image, layers)

    def background(self, model: CameraModel) -> Background:
        """The background drawer of ``model``: at most :data:`BACKGROUND_MAX` wide (large
        frames: smooth light and textures magnified from a few-centimetre pitch anyway)."""
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

    def _noise_tile(self, model: CameraModel, seed: tuple[int, ...]) -> np.ndarray:
        key = (seed, model.height, model.width)
        tile = self._noise.get(key)
        if tile is None:
            tile = self._noise[key] = noise_tile(*key)
        return tile
