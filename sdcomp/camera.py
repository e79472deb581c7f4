"""Pinhole drone camera: intrinsics from real drone presets, pose over the water, projection.

World frame: metres, z up, the sea surface at z = 0, the camera above the origin at
(0, 0, altitude). Angles in degrees:

- ``pitch``: gimbal pitch below the horizon; 90 looks straight down (as SeaDronesSee's
  ``gimbal_pitch``), 15 looks 15 degrees below the horizon.
- ``heading``: direction of the camera's forward axis seen from above, from world +x
  towards +y (counter-clockwise).

Image frame: columns ``u`` to the right, rows ``v`` down, pixel centres at integers + 0.5,
principal point at the image centre. The output image may have another size and aspect
than the sensor: it is the sensor image resized (as the paper resized 5472 x 3648 frames to
416 x 416), so ``fx`` and ``fy`` differ when the aspect changes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from .errors import UserError

#: name: (sensor width px, sensor height px, diagonal field of view degrees)
PRESETS: dict[str, tuple[int, int, float]] = {
    "mavic2pro": (5472, 3648, 77.0),
    "phantom4pro": (5472, 3648, 84.0),
}


@dataclass(frozen=True)
class CameraModel:
    """Intrinsics of a drone camera and the size of the images made with it; validated.

    Attributes:
        sensor_width, sensor_height: native resolution, pixels.
        diagonal_fov: diagonal field of view, degrees, in (1, 170).
        width, height: output image size, pixels (the sensor image resized to it).
    """

    sensor_width: int = 5472
    sensor_height: int = 3648
    diagonal_fov: float = 77.0
    width: int = 416
    height: int = 416

    def __post_init__(self) -> None:
        for name in ("sensor_width", "sensor_height", "width", "height"):
            v = getattr(self, name)
            if not (isinstance(v, int) and 1 <= v <= 100_000):
                raise UserError(f"camera {name} {v!r} is out of range: use 1 to 100000 pixels")
        if not 1.0 < float(self.diagonal_fov) < 170.0:
            raise UserError(f"camera diagonal field of view {self.diagonal_fov} is out of "
                            f"range: use more than 1 and less than 170 degrees")

    @classmethod
    def preset(cls, name: str, width: int = 416, height: int = 416) -> CameraModel:
        """A named drone camera (see :data:`PRESETS`) producing ``width`` x ``height`` images."""
        if name not in PRESETS:
            raise UserError(f"unknown camera preset {name!r}; use one of {', '.join(PRESETS)}")
        sw, sh, fov = PRESETS[name]
        return cls(sw, sh, fov, width, height)

    @classmethod
    def from_sensor_mm(cls, sensor_width_mm: float, sensor_height_mm: float, focal_mm: float,
                       sensor_width: int, sensor_height: int, width: int = 416,
                       height: int = 416) -> CameraModel:
        """A camera given by its sensor size and focal length in millimetres."""
        if min(sensor_width_mm, sensor_height_mm, focal_mm) <= 0:
            raise UserError("sensor size and focal length must be positive millimetres")
        diag = math.hypot(sensor_width_mm, sensor_height_mm)
        fov = 2 * math.degrees(math.atan(diag / (2 * focal_mm)))
        return cls(sensor_width, sensor_height, fov, width, height)

    @cached_property
    def sensor_focal_px(self) -> float:
        """Focal length in sensor pixels (square sensor pixels)."""
        half_diag = math.hypot(self.sensor_width, self.sensor_height) / 2
        return half_diag / math.tan(math.radians(self.diagonal_fov) / 2)

    @cached_property
    def fx(self) -> float:
        """Focal length in output pixels along the image x axis."""
        return self.sensor_focal_px * self.width / self.sensor_width

    @cached_property
    def fy(self) -> float:
        """Focal length in output pixels along the image y axis."""
        return self.sensor_focal_px * self.height / self.sensor_height

    @property
    def horizontal_fov(self) -> float:
        """Horizontal field of view, degrees."""
        return 2 * math.degrees(math.atan(self.sensor_width / 2 / self.sensor_focal_px))

    @property
    def vertical_fov(self) -> float:
        """Vertical field of view, degrees."""
        return 2 * math.degrees(math.atan(self.sensor_height / 2 / self.sensor_focal_px))

    def nadir_gsd(self, altitude: float) -> tuple[float, float]:
        """Ground sampling distance (metres per output pixel, x and y) at the image centre
        of a camera looking straight down from ``altitude`` metres."""
        return altitude / self.fx, altitude / self.fy


def camera_basis(pitch: float, heading: float) -> np.ndarray:
    """(3, 3) float64 rows (right, down, forward) of the camera in the world frame.

    ``forward`` is the optical axis; ``right`` and ``down`` follow image columns and rows.
    """
    p, h = math.radians(pitch), math.radians(heading)
    forward = np.array([math.cos(p) * math.cos(h), math.cos(p) * math.sin(h), -math.sin(p)])
    right = np.array([math.sin(h), -math.cos(h), 0.0])
    down = np.array([-math.sin(p) * math.cos(h), -math.sin(p) * math.sin(h), -math.cos(p)])
    return np.stack([right, down, forward])  # down = forward x right, written out


@dataclass(frozen=True)
class CameraPose:
    """Where the camera is: ``altitude`` metres above the sea, ``pitch`` and ``heading`` degrees.

    Pitch is limited to [15, 90]: from 15 degrees below the horizon to straight down.
    """

    altitude: float = 10.0
    pitch: float = 90.0
    heading: float = 0.0

    def __post_init__(self) -> None:
        if not (math.isfinite(self.altitude) and 0 < self.altitude <= 10_000):
            raise UserError(f"altitude {self.altitude} m is out of range: use more than 0 "
                            f"and at most 10000 metres")
        if not 15.0 <= self.pitch <= 90.0:
            raise UserError(f"pitch {self.pitch} is out of range: use 15 (15 degrees below the "
                            f"horizon) to 90 (straight down) degrees")
        if not math.isfinite(self.heading):
            raise UserError(f"heading {self.heading} must be a finite number of degrees")

    @property
    def position(self) -> np.ndarray:
        return np.array([0.0, 0.0, self.altitude])


def project(model: CameraModel, pose: CameraPose, points: np.ndarray
            ) -> tuple[np.ndarray, np.ndarray]:
    """Project world points (N, 3) metres to pixels.

    Returns (uv (N, 2) float64 pixel coordinates, depth (N,) metres along the optical axis;
    points behind the camera have depth <= 0 and meaningless uv).
    """
    basis = camera_basis(pose.pitch, pose.heading)
    cam = (np.asarray(points, np.float64) - pose.position) @ basis.T
    depth = cam[:, 2]
    safe = np.where(depth > 1e-9, depth, np.nan)
    u = model.fx * cam[:, 0] / safe + model.width / 2
    v = model.fy * cam[:, 1] / safe + model.height / 2
    return np.stack([u, v], axis=1), depth


def pixel_rays(model: CameraModel, pose: CameraPose, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Unit view rays (..., 3) in the world frame through pixel coordinates ``u``, ``v``."""
    x = (np.asarray(u, np.float64) - model.width / 2) / model.fx
    y = (np.asarray(v, np.float64) - model.height / 2) / model.fy
    d = np.stack([x, y, np.ones_like(x)], axis=-1) @ camera_basis(pose.pitch, pose.heading)
    return d / np.linalg.norm(d, axis=-1, keepdims=True)


def ground_points(model: CameraModel, pose: CameraPose, u: np.ndarray, v: np.ndarray
                  ) -> tuple[np.ndarray, np.ndarray]:
    """Where the rays through pixels (u, v) meet the sea surface z = 0.

    Returns (points (..., 3) metres, hit (...) bool: False for rays at or above the horizon,
    whose points are NaN).
    """
    rays = pixel_rays(model, pose, u, v)
    hit = rays[..., 2] < -1e-9
    t = np.where(hit, pose.altitude / np.where(hit, -rays[..., 2], 1.0), np.nan)
    return pose.position + rays * t[..., None], hit
