"""The background of an image: the sea and sky (:mod:`sdcomp.render.water`) or the user's
photo, with land beyond a shoreline and hills on the horizon (:mod:`sdcomp.render.land`).

:meth:`Background.draw` also returns the light the objects are lit with
(:class:`~sdcomp.render.water.WaterLight`): the water model's coarse terms give it for any
background; over a photo its exposure gain is scaled so the objects are as bright, relative
to the photo, as they would be relative to water exposed like it.
"""

from __future__ import annotations

from dataclasses import replace

import cv2
import numpy as np

from ..scene.camera import CameraModel
from ..scene.scene import Scene
from ..util.colour import srgb_to_linear
from .land import add_hills, add_land
from .photos import Backgrounds
from .textures import Textures
from .water import WaterLight
from .water.optics import luminance
from .water.surface import draw_water, view_water

PHOTO_METER_SIZE = 64  # pixels: a photo is metered on a thumbnail this wide


class Background:
    """Draws the backgrounds of ``model``'s images (which may be smaller than the scene's
    camera: large frames are drawn small and magnified)."""

    def __init__(self, model: CameraModel, textures: Textures, photos: Backgrounds | None):
        self.model = model
        self.textures = textures
        self.photos = photos

    def draw(self, scene: Scene) -> tuple[np.ndarray, WaterLight, float | None]:
        """(image (H, W, 3) uint8 sRGB at this background's size, the objects' light, and
        over a photo its magnification: output pixels per pixel of the frame it was cut
        from; None for procedural water)."""
        model, pose = self.model, scene.camera
        view = view_water(model, pose, scene.water, self.textures.water)
        if self.photos is not None:
            photo, mag = self.photos.pick_scaled(scene.seeds.photo, model.width, model.height)
            return photo, photo_light(photo, view.light, scene.water.exposure_target), mag
        image, _ = draw_water(view, self.textures.water,
                              glint="sparkles" if scene.glitter else "mean")
        if scene.shore is not None:
            add_land(image, model, pose, scene.shore, self.textures.land,
                     self.textures.stones, view.light, scene.seeds.land)
        if scene.hills is not None:
            add_hills(image, model, pose, scene.hills, view.light, scene.water.visibility)
        return image, view.light, None


def photo_light(photo: np.ndarray, light: WaterLight, target: float) -> WaterLight:
    """``light`` with its exposure gain scaled by the photo's mean linear luminance over
    ``target`` (the mean the water would have been exposed to): objects on a dark photo are
    dark, on a bright one bright."""
    h, w = photo.shape[:2]
    f = PHOTO_METER_SIZE / max(w, h)
    thumb = cv2.resize(photo, (max(1, round(w * f)), max(1, round(h * f))),
                       interpolation=cv2.INTER_AREA) if f < 1 else photo
    mean = float(np.mean(luminance(srgb_to_linear(thumb.astype(np.float32) / 255.0))))
    return replace(light, gain=light.gain * max(mean, 1e-3) / target)
