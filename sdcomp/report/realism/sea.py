"""Which pixels of a generated image are sea: not sky, not land (and, optionally, not near
unannotated clutter), for the realism report's "empty water".

Sky: the rows above the horizon plus :data:`SKY_MARGIN_ROWS` (hills are drawn down to a row
below it), from the run's camera and the image's gimbal pitch. Land and clutter: the image's
scene is drawn again (:func:`sdcomp.scene.sample.sample_scene`, a pure function of the
config and the index) and used only if its camera pose, shore flag and object and clutter
counts agree with the image's ``meta`` (a dataset written by another sdcomp version may
draw other scenes); then the pixels whose ground point is on its land, widened by the
rip-rap along the coast, are left out. Otherwise land is "unknown, accepted" and the report says so.

Both are decided in the renderer's pinhole image; each pixel of the recorded image is looked
up where the camera stage's lens (:mod:`sdcomp.render.camera.lens`: zoom and radial
distortion) took it from, as the image's COCO ``camera`` record (``K``, ``dist_coeffs``) says
(:func:`pinhole_pixels`).
"""

from __future__ import annotations

import math
from collections.abc import Callable

import cv2
import numpy as np

from ...assets.library import kind_of
from ...errors import UserError
from ...render.camera.lens import undistort
from ...render.land import shore_band
from ...scene.camera import CameraModel, CameraPose, ground_points, horizon_row
from ...scene.config import GeneratorConfig
from ...scene.objects import CLUTTER_PREFIX
from ...scene.sample import sample_scene
from ...scene.scene import Role, Scene, on_land

ALTITUDE_KEY = "height_above_takeoff(meter)"
PITCH_KEY = "gimbal_pitch(degrees)"
HEADING_KEY = "gimbal_heading(degrees)"
GSD_KEY = "gsd(m/px)"
SKY_MARGIN_ROWS = 2.0
#: metres around a clutter object's centre left out by ``exclude_clutter``: half its kind's
#: longest length (log 2.2 m, foam 1.5 m; the search-and-rescue kinds' largest variants:
#: boats 12 m, jet skis 3.5 m) plus 1 m for its shadow
CLUTTER_RADIUS = {"buoy": 1.8, "log": 2.1, "boat": 7.0, "foam": 1.8, "swimmer": 2.0,
                  "jetski": 2.8, "life_saving_appliances": 2.0}


def num(meta: dict, key: str) -> float | None:
    """``meta[key]`` as a finite float, None when absent or not a number."""
    v = meta.get(key) if isinstance(meta, dict) else None
    try:
        x = float(v)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        return None
    return x if math.isfinite(x) else None


class SeaOracle:
    """Valid-pixel masks (sea: not sky, not land) of the images of one run, from its
    config (dataset.json's ``config``); ``exclude_clutter`` also leaves out the pixels within
    :data:`CLUTTER_RADIUS` metres of each floating clutter object."""

    def __init__(self, config: dict, exclude_clutter: bool = False):
        self.exclude_clutter = exclude_clutter
        try:
            self.config: GeneratorConfig | None = GeneratorConfig.from_mapping(dict(config))
        except (UserError, TypeError, ValueError):
            self.config = None

    def bind(self, index: int, meta: dict, camera: dict | None = None) -> Callable:
        """The ``valid(shape)`` callable of image ``index`` (see :meth:`mask`)."""
        return lambda shape: self.mask(index, meta, shape, camera)

    def scene(self, index: int, meta: dict, model: CameraModel) -> Scene | None:
        """The image's scene drawn again, or None when it disagrees with ``meta``."""
        if self.config is None:
            return None
        try:
            scene = sample_scene(self.config, index, model)
        except (UserError, ValueError):
            return None
        pose = scene.camera
        alt, pitch = num(meta, ALTITUDE_KEY), num(meta, PITCH_KEY)
        if alt is None or pitch is None or abs(pose.altitude - alt) > 1e-3 or abs(
                pose.pitch - pitch) > 1e-3:
            return None
        if bool(meta.get("shore", scene.shore is not None)) != (scene.shore is not None):
            return None
        for key, role in (("objects_placed", Role.OBJECT), ("clutter", Role.CLUTTER)):
            if key in meta and int(meta[key]) != scene.count(role):
                return None
        return scene

    def mask(self, index: int, meta: dict, shape: tuple[int, int], camera: dict | None = None
             ) -> tuple[np.ndarray | None, str]:
        """((H, W) bool valid pixels or None = all, how it was made) of image ``index``;
        ``camera``: its COCO camera record (the recorded image's lens), None for a pinhole."""
        h, w = shape
        pitch = num(meta, PITCH_KEY)
        if self.config is None or pitch is None:
            return None, "unknown: land and sky accepted"
        c = self.config.camera_model()
        model = CameraModel(c.sensor_width, c.sensor_height, c.diagonal_fov, w, h)
        valid = None
        u, v = pinhole_pixels(model, camera)
        if pitch < 90:
            valid = v >= horizon_row(model, pitch) + SKY_MARGIN_ROWS
        how = ["sky excluded" if valid is not None else "no sky in view"]
        scene = self.scene(index, meta, model)
        clutter = ([p for p in scene.placements if p.role is Role.CLUTTER]
                   if scene is not None and self.exclude_clutter else [])
        bad = np.zeros((h, w), bool)
        if scene is not None and (scene.shore is not None or clutter):
            pts, hit = ground_points(model, scene.camera, u, v)
            x, y = pts[..., 0], pts[..., 1]
            if scene.shore is not None:
                land = np.zeros((h, w), np.uint8)
                land[hit] = on_land(scene.shore, x[hit], y[hit])
                # the rip-rap reaches half its width past the coast, then 2 px more
                r = math.ceil(shore_band(scene.shore) / 2 / max(_gsd(model, scene.camera),
                                                                1e-6)) + 2
                bad |= cv2.dilate(land, np.ones((2 * r + 1, 2 * r + 1), np.uint8)) > 0
                how.append("land excluded")
            for p in clutter:
                name = p.asset.removeprefix(CLUTTER_PREFIX)
                radius = CLUTTER_RADIUS.get(kind_of(name) or name,
                                            max(CLUTTER_RADIUS.values()))
                bad |= hit & (np.hypot(x - p.x, y - p.y) < radius)
            if clutter:
                how.append("clutter excluded")
        elif bool(meta.get("shore", False)):
            how.append("land unknown, accepted")
        if bad.any():
            valid = ~bad if valid is None else valid & ~bad
        return valid, "; ".join(how)


def pinhole_pixels(model: CameraModel, camera: dict | None) -> tuple[np.ndarray, np.ndarray]:
    """(u, v), each (H, W) float64 pixels (centres at +0.5) of ``model``'s size: where each
    pixel of the recorded image lies in the renderer's pinhole image of ``model``, undoing
    the zoom and radial distortion (k1, k2) of its COCO ``camera`` record (``K`` 3 x 3 with
    the zoomed focal lengths, ``dist_coeffs``; OpenCV's convention, pixel (0, 0)'s centre at
    0). The pixel centres themselves without a record, or with one of another size."""
    w, h = model.width, model.height
    u, v = np.meshgrid(np.arange(w) + 0.5, np.arange(h) + 0.5)
    if not camera:
        return u, v
    try:
        k = np.asarray(camera["K"], np.float64)
        k1, k2 = (float(c) for c in camera["dist_coeffs"][:2])
        size = (int(camera["width"]), int(camera["height"]))
    except (KeyError, TypeError, ValueError, IndexError):
        return u, v
    if k.shape != (3, 3) or size != (w, h) or not np.isfinite(k).all() or k[0, 0] <= 0 or (
            k[1, 1] <= 0):
        return u, v
    cx, cy = k[0, 2], k[1, 2]
    xd = np.stack([(u - 0.5 - cx) / k[0, 0], (v - 0.5 - cy) / k[1, 1]], axis=-1)
    xu = undistort(xd, k1, k2)
    return cx + 0.5 + model.fx * xu[..., 0], cy + 0.5 + model.fy * xu[..., 1]


def _gsd(model: CameraModel, pose: CameraPose) -> float:
    return pose.altitude / math.sin(math.radians(pose.pitch)) / model.fx
