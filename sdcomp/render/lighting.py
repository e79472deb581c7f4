"""The light on floating objects: the sun, the sky and the water of one image, as the water
model computed them (:class:`~sdcomp.render.water.WaterLight`), so that objects are lit like
the water around them.

Radiances are relative linear RGB before exposure (times :attr:`Lighting.gain`, then sRGB,
as the water is drawn); irradiances are on a surface, radiances per steradian: a Lambertian
surface of albedo ``rho`` under irradiance ``E`` has radiance ``rho E / pi``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from ..scene.camera import camera_basis
from ..scene.scene import Scene
from .gloss import sky_table
from .water import WaterLight

#: Fresnel reflectance of the sea for diffuse light from above (its irradiance albedo)
SEA_DIFFUSE_REFLECTANCE = 0.066


@dataclass(frozen=True)
class Lighting:
    """Per-image quantities every stage uses: the camera ``basis`` (3, 3) float64 (rows
    right, down, forward in the world frame) and the water's :class:`WaterLight`."""

    basis: np.ndarray
    water: WaterLight

    @property
    def sun(self) -> np.ndarray:
        """(3,) float64 unit vector towards the sun (world frame)."""
        return np.asarray(self.water.sun, np.float64)

    @cached_property
    def sky_table(self) -> np.ndarray:
        """The sky as glossy surfaces mirror it (:func:`~sdcomp.render.gloss.sky_table`),
        computed once per image."""
        return sky_table(self.water.sky)

    @property
    def gain(self) -> float:
        """The exposure gain: exposed linear = gain x relative radiance."""
        return self.water.gain


def lighting(scene: Scene, water: WaterLight) -> Lighting:
    """The :class:`Lighting` of ``scene`` whose water was viewed with light ``water``."""
    pose = scene.camera
    return Lighting(camera_basis(pose.pitch, pose.heading), water)


def irradiance_terms(water: WaterLight, sun: np.ndarray, l_w: np.ndarray
                     ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(sun, sky, up) (3,) float32 irradiances on the sea where the direct sun's
    irradiance is ``sun`` (3,) and the water-leaving radiance ``l_w`` (3,) (at a pixel:
    :meth:`WaterLight.at`): the direct sun on a surface facing it, the sky's diffuse
    irradiance on a horizontal surface, and the light coming up from the sea onto a surface
    facing down (the water-leaving light, ``pi L_w``, and the sea's reflection of the
    light from above)."""
    sun = np.asarray(sun, np.float32)
    l_w = np.asarray(l_w, np.float32)
    sky = np.asarray(water.sky_irradiance, np.float32)
    down = sun * np.float32(max(float(water.sun[2]), 0.0)) + sky
    up = np.float32(math.pi) * l_w + np.float32(SEA_DIFFUSE_REFLECTANCE) * down
    return sun, sky, up.astype(np.float32)


def lambert(albedo: np.ndarray, normal: np.ndarray, sun_dir: np.ndarray, up_dir: np.ndarray,
            sun: np.ndarray, sky: np.ndarray, up: np.ndarray) -> np.ndarray:
    """(n, n, 3) float32 linear radiance of Lambertian surfaces: ``albedo`` (n, n, 3) linear,
    unit ``normal`` (n, n, 3) float32 in some frame in which ``sun_dir`` (3,) points to the
    sun and ``up_dir`` (3,) up; ``sun``, ``sky``, ``up`` (3,) irradiances (see
    :func:`irradiance_terms`). The sky's and the sea's light come from the upper and lower
    hemispheres: a surface tilted by ``t`` from the vertical sees ``(1 + cos t) / 2`` of
    the one and ``(1 - cos t) / 2`` of the other."""
    cos_sun = normal @ np.asarray(sun_dir, np.float32)
    np.maximum(cos_sun, 0.0, out=cos_sun)
    cos_up = normal @ np.asarray(up_dir, np.float32)
    half = np.float32(0.5)
    # E = sun cos_sun + (sky + up) / 2 + (sky - up) / 2 cos_up: one (n, n, 2) @ (2, 3)
    terms = np.stack([cos_sun, cos_up], axis=-1)
    e = terms @ np.stack([sun, (sky - up) * half]).astype(np.float32)
    e += ((sky + up) * half).astype(np.float32)
    e *= albedo
    e *= np.float32(1.0 / math.pi)
    return e
