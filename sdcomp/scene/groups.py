"""Swimmers in groups, as search-and-rescue footage shows them (``--groups P``).

SeaDronesSee's val set holds 4 swimmers an image at the median (p10-p90 1-9), each one's
nearest other swimmer 3.8 box sizes away (p10 1.7, p90 11.1; 15 % within 2, 53 % within
4): people in the water are found together. sdcomp placed each object alone: 60 frames of
``--preset seadronessee`` at 1080p held 1 swimmer an image, the nearest other one 10.9 box
sizes away. :func:`group` gives each swimmer, with chance P, one to :data:`COMPANIONS`
others of its object's variants at distances drawn about that median (:data:`SPACING`), in
any direction, each in view, on water and clear of every other object's disc; they are
objects of interest like any other, appended after all the placements.

Frames and units: metres on the sea, headings in degrees (:class:`~.scene.Placement`'s).
A swimmer's "box size" here is its footprint's: ``1.4 x`` its footprint radius (the square
root of a box of a body about twice as long as it is wide).
"""

from __future__ import annotations

import math
from dataclasses import replace
from statistics import NormalDist

import numpy as np

from .camera import CameraModel, CameraPose, project
from .config import MAX_INSTANCES, GeneratorConfig
from .objects import CLUTTER_PREFIX, footprint_radius, low_enough, object_assets, object_kind
from .scene import Placement, Role, Shore, on_land

KINDS = ("swimmer",)  #: the kinds that come in groups
COMPANIONS = 3  #: at most this many others join a swimmer
#: the distance to a companion, in box sizes: lognormal, median and sigma of its log (the
#: real nearest-neighbour distances' median and spread), kept in this range
SPACING = (3.8, 0.6)
SPACING_RANGE = (1.4, 15.0)
DRAWS = 2 + 5 * COMPANIONS  #: numbers drawn per swimmer


def box_size(asset: str) -> float:
    """Metres: the size of the box of the object drawn from ``asset`` (see the module)."""
    return 1.4 * footprint_radius(asset)


def _in_view(model: CameraModel, pose: CameraPose, x: float, y: float) -> bool:
    uv, depth = project(model, pose, np.array([[x, y, 0.0]]))
    return bool(depth[0] > 0 and 0 <= uv[0, 0] < model.width and 0 <= uv[0, 1] < model.height)


def group(rng: np.random.Generator, config: GeneratorConfig,
          placements: tuple[Placement, ...], view: tuple[CameraModel, CameraPose],
          shore: Shore | None) -> tuple[Placement, ...]:
    """``placements`` with, for each swimmer and with chance ``config.groups``, one to
    :data:`COMPANIONS` other swimmers around it (see the module), appended: variants of its
    object low enough for the camera, tilted up to ``config.tilt`` (they swim or drift as
    any object does: speeds come after, :func:`~.sample._travel`); a companion
    that would leave the ``view`` ((model, pose)), lie on land, touch another object's disc
    or pass the image's instance limit is left out.

    Draws :data:`DRAWS` numbers from ``rng`` (a stream of its own) per swimmer, whatever
    is placed, so one swimmer's draws never shift another's."""
    if config.groups <= 0:
        return placements
    discs = [(p.x, p.y, footprint_radius(p.asset)) for p in placements
             if p.asset.removeprefix(CLUTTER_PREFIX) != "foam"]
    room = MAX_INSTANCES - sum(p.role is Role.OBJECT for p in placements)
    added: list[Placement] = []
    for p in placements:
        if p.role is not Role.OBJECT or object_kind(p.asset) not in KINDS:
            continue
        u = rng.random(DRAWS)
        if u[0] >= config.groups:
            continue
        assets = low_enough(object_assets(config.objects[p.category_id - 1].mesh),
                            view[1].altitude)
        for c in range(1 + int(u[1] * COMPANIONS)):
            spacing, angle, heading, pick, tilt = u[2 + 5 * c: 7 + 5 * c]
            asset = assets[min(int(pick * len(assets)), len(assets) - 1)]
            d = box_size(p.asset) * float(np.clip(
                SPACING[0] * math.exp(SPACING[1] * _normal(spacing)), *SPACING_RANGE))
            x = p.x + d * math.cos(2 * math.pi * angle)
            y = p.y + d * math.sin(2 * math.pi * angle)
            r = footprint_radius(asset)
            if (len(added) >= room or not _in_view(*view, x, y) or on_land(shore, x, y)
                    or any(math.hypot(x - dx, y - dy) < r + dr for dx, dy, dr in discs)):
                continue
            roll = (2 * tilt - 1) * config.tilt
            added.append(replace(p, asset=asset, x=x, y=y, heading=360.0 * heading,
                                 roll=roll, pitch=-roll))
            discs.append((x, y, r))
    return placements + tuple(added)


def _normal(u: float) -> float:
    """The standard normal quantile of ``u`` in (0, 1) (clipped away from 0 and 1)."""
    return NormalDist().inv_cdf(min(max(float(u), 1e-6), 1 - 1e-6))
