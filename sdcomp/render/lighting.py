"""The light of one image: sun, camera gain and the water's own radiance, computed once."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..atlas.poses import sun_direction
from ..scene.camera import camera_basis
from ..scene.scene import Scene
from ..util.colour import srgb_to_linear
from .optics import refracted_cos

SUN = 2.2  # linear radiance of direct sunlight on a surface facing the sun


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
