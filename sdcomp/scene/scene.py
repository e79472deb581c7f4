"""The scene description: everything the pixels of one image depend on, as plain data.

A :class:`Scene` is kept apart from the renderer (kubric-style): :mod:`sdcomp.scene.sample`
draws it from (config, index), :mod:`sdcomp.render` turns it into pixels with the assets
(sprites, textures, photos) and nothing else. It names its assets by key, carries the
feature switches and one seed per feature, so the renderer never reads the run config.

World frame: metres, z up, sea surface z = 0, camera above the origin. Angles in degrees;
headings and azimuths counter-clockwise from world +x.
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass

import numpy as np

from .camera import CameraModel, CameraPose, centre_gsd
from .look import CameraLook
from .water import WaterParams


class Role(enum.Enum):
    """What a floating object is in the dataset."""

    OBJECT = "object"  # an object of interest: annotated
    CLUTTER = "clutter"  # a distractor: never annotated


@dataclass(frozen=True)
class Placement:
    """One floating object: which asset (its sprite key), its role, its COCO category (0 for
    clutter), where its waterline centre meets the sea (x, y metres), its heading, wave tilt
    (roll, pitch degrees), ``draft`` (metres below its natural waterline; negative: higher),
    ``tint`` (albedo gain per channel) and ``speed`` (m/s through the water along its
    heading: it leaves a wake)."""

    role: Role
    asset: str
    category_id: int
    x: float
    y: float
    heading: float
    roll: float
    pitch: float
    draft: float
    tint: tuple[float, float, float] = (1.0, 1.0, 1.0)
    speed: float = 0.0


@dataclass(frozen=True)
class Shore:
    """Land beyond a wavy coastline: points p with p . (cos a, sin a) > distance + wiggle;
    ``along_offset`` (m) shifts the wiggle along the coast (a moving camera's frames)."""

    angle: float
    distance: float
    seed: int
    along_offset: float = 0.0

    def wiggle(self, along):
        """Offset (metres) of the coastline from its straight line at ``along`` metres."""
        r = np.random.default_rng(self.seed)
        along = np.asarray(along) + self.along_offset
        out = np.zeros(np.shape(along), np.float64)
        for wavelength in (60.0, 23.0, 9.0, 3.5):
            phase = r.uniform(0, 2 * math.pi)
            out = out + wavelength * 0.08 * np.sin(2 * math.pi * np.asarray(along)
                                                   / wavelength + phase)
        return out

    def coast(self, along):
        """Across (metres along the normal) of the coastline at ``along`` metres."""
        return self.distance + self.wiggle(along)

    def local(self, x, y):
        """(along, across) metres of sea points (x, y) in the coast's frame: ``along`` the
        coast (-sin a, cos a), ``across`` its normal (cos a, sin a), towards the land."""
        a = math.radians(self.angle)
        x, y = np.asarray(x), np.asarray(y)
        return -x * math.sin(a) + y * math.cos(a), x * math.cos(a) + y * math.sin(a)

    def sea(self, along, across):
        """(x, y) metres on the sea of the point ``along``, ``across`` (:meth:`local`)."""
        a = math.radians(self.angle)
        return (-along * math.sin(a) + across * math.cos(a),
                along * math.cos(a) + across * math.sin(a))


@dataclass(frozen=True)
class FeatureSeeds:
    """Seed sequences of the renderer's random choices, one per feature (each a
    ``numpy.random.default_rng`` seed): ``land`` the land texture's offset, ``photo`` the
    choice and crop of a user's photo, ``noise_tile`` the sensor-noise tile of the run
    (shared by its images; each image reads a window of it at its look's offsets). The
    water's own offsets come from :attr:`WaterParams.seed`."""

    land: tuple[int, ...]
    photo: tuple[int, ...]
    noise_tile: tuple[int, ...]

    @classmethod
    def of(cls, texture_seed: int, run_seed: int) -> FeatureSeeds:
        """The seeds of an image whose texture seed is ``texture_seed`` in a run of
        ``run_seed``."""
        t = int(texture_seed)
        return cls((t, 3), (t, 4), (int(run_seed), 31337))


@dataclass(frozen=True)
class Scene:
    """Everything that varies per image (see the module docstring for frames and units):
    the camera and its pose, the water and sky (:class:`WaterParams`: its sun, wind, waves,
    clouds), the floating objects, land, the camera's look (:class:`CameraLook`), a defocus
    blur (Gaussian sigma, pixels) or None, the file's JPEG quality and the feature seeds."""

    index: int
    model: CameraModel
    camera: CameraPose
    water: WaterParams
    placements: tuple[Placement, ...]
    shore: Shore | None
    hills: int | None  # seed of the ridge line when hills are drawn, else None
    look: CameraLook
    defocus_blur: float | None
    jpeg_quality: int
    seeds: FeatureSeeds
    shadows: bool = True  # object shadows on the water and floor
    glitter: bool = True  # the sun's glitter drawn as sparkles
    hidden: tuple[int, ...] = ()  # placements not drawn (--unlabelled skip)
    #: over the user's footage: its camera's blur at the frame's native resolution
    #: (Gaussian sigma, frame pixels), given to the objects with its noise
    #: (:mod:`sdcomp.render.harmonise`); None: the objects as rendered
    footage_blur: float | None = None

    @property
    def gsd(self) -> float:
        """Metres per pixel (along x) at the image centre."""
        return centre_gsd(self.model, self.camera)

    def count(self, role: Role) -> int:
        """How many placements have ``role``."""
        return sum(1 for p in self.placements if p.role is role)


def on_land(shore: Shore | None, x, y):
    """Whether ground points (x, y) metres lie on the land of ``shore`` (array or bool)."""
    if shore is None:
        return np.zeros(np.shape(x), bool)
    along, across = shore.local(x, y)
    return across > shore.coast(along)
