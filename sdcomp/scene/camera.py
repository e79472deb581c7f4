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

from ..errors import UserError

#: camera altitude above the sea, metres (the config's --altitude and CameraPose check these)
ALTITUDE_RANGE = (1.0, 1000.0)
#: gimbal pitch below the horizon, degrees: 2 (nearly level: the horizon just above the frame's
#: centre, as in SeaDronesSee's flattest frames) to 90 (straight down); at 0 the frame's centre
#: would look at the horizon (no ground sampling distance there)
PITCH_RANGE = (2.0, 90.0)
#: the photo frames of the drone cameras: (sensor width px, sensor height px, diagonal field
#: of view degrees)
PHOTO_PRESETS: dict[str, tuple[int, int, float]] = {
    "mavic2pro": (5472, 3648, 77.0),
    "phantom4pro": (5472, 3648, 84.0),
    "zenmuse-x5": (4608, 3456, 72.0),
}


def video_frame(sensor_width: int, sensor_height: int, diagonal_fov: float,
                video: tuple[int, int] = (3840, 2160)) -> tuple[int, int, float]:
    """The 16:9 video frame of a photo frame (sensor px, diagonal FOV degrees): the full
    sensor width cropped to 16:9 and resized to ``video`` (DJI's 4K recording), so the same
    horizontal field of view and a narrower diagonal one."""
    f = math.hypot(sensor_width, sensor_height) / 2 / math.tan(math.radians(diagonal_fov) / 2)
    half_diag = math.hypot(sensor_width, sensor_width * video[1] / video[0]) / 2
    return video[0], video[1], round(2 * math.degrees(math.atan(half_diag / f)), 2)


#: SeaDronesSee's 1920 x 1080 frames: a DJI Zenmuse Z30 zoom camera (30x optical, 63.7 to
#: 2.3 degrees across) on a Matrice 210, at the zoom that gives their boxes: its val split's
#: 1789 swimmers in those frames measure 36.7 px at the median (p10 25.4, p90 67.3), as its
#: Mavic 2 Pro 4K frames' 3926 do at fx 2987 px (37.1 px): the same focal length in pixels,
#: 2987 px at 1920 wide, 35.6 degrees across, 40.5 diagonally
ZOOM_PRESETS: dict[str, tuple[int, int, float]] = {"zenmuse-z30": (1920, 1080, 40.5)}

#: name: (sensor width px, sensor height px, diagonal field of view degrees); ``NAME-video``
#: is the camera's 16:9 4K video (SeaDronesSee's and most drone footage)
PRESETS: dict[str, tuple[int, int, float]] = {
    **PHOTO_PRESETS,
    **{f"{k}-video": video_frame(*v) for k, v in PHOTO_PRESETS.items()},
    **ZOOM_PRESETS,
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

    Altitude and pitch are limited to :data:`ALTITUDE_RANGE` and :data:`PITCH_RANGE`.
    """

    altitude: float = 10.0
    pitch: float = 90.0
    heading: float = 0.0

    def __post_init__(self) -> None:
        lo, hi = ALTITUDE_RANGE
        if not (math.isfinite(self.altitude) and lo <= self.altitude <= hi):
            raise UserError(f"altitude {self.altitude} m is out of range: use {lo:g} to "
                            f"{hi:g} metres")
        lo, hi = PITCH_RANGE
        if not lo <= self.pitch <= hi:
            raise UserError(f"pitch {self.pitch} is out of range: use {lo:g} ({lo:g} degrees "
                            f"below the horizon) to {hi:g} (straight down) degrees")
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


def camera_rays(model: CameraModel, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Unit view rays (..., 3) float64 in the camera frame (right, down, forward) through
    pixel coordinates ``u``, ``v``."""
    d = np.stack([(np.asarray(u, np.float64) - model.width / 2) / model.fx,
                  (np.asarray(v, np.float64) - model.height / 2) / model.fy,
                  np.ones(np.shape(u))], axis=-1)
    return d / np.linalg.norm(d, axis=-1, keepdims=True)


def pixel_rays(model: CameraModel, pose: CameraPose, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Unit view rays (..., 3) in the world frame through pixel coordinates ``u``, ``v``."""
    return camera_rays(model, u, v) @ camera_basis(pose.pitch, pose.heading)


def _sea_ray(model: CameraModel, pose: CameraPose, u, v):
    """(dx, dy, dz) of the unnormalised world ray ``x right + y down + forward`` through
    pixel coordinates (u, v): floats or float64 arrays alike (the same arithmetic)."""
    x = (u - model.width / 2) / model.fx
    y = (v - model.height / 2) / model.fy
    p, h = math.radians(pose.pitch), math.radians(pose.heading)
    cp, sp, ch, sh = math.cos(p), math.sin(p), math.cos(h), math.sin(h)
    # the rows of camera_basis written out: right (sh, -ch, 0),
    # down (-sp ch, -sp sh, -cp), forward (cp ch, cp sh, -sp)
    return (x * sh - y * sp * ch + cp * ch, -x * ch - y * sp * sh + cp * sh, -y * cp - sp)


def ground_point(model: CameraModel, pose: CameraPose, u: float, v: float
                 ) -> tuple[float, float] | None:
    """Where the ray through pixel (u, v) meets the sea, (x, y) metres; None at or above
    the horizon. (One pixel: :func:`ground_points` for arrays gives the same numbers.)"""
    dx, dy, dz = _sea_ray(model, pose, u, v)
    if dz > -1e-9:
        return None
    t = pose.altitude / -dz
    return dx * t, dy * t


def ground_points(model: CameraModel, pose: CameraPose, u: np.ndarray | float,
                  v: np.ndarray | float) -> tuple[np.ndarray, np.ndarray]:
    """Where the rays through pixels (u, v) meet the sea surface z = 0.

    Returns (points (..., 3) metres, hit (...) bool: False for rays at or above the horizon,
    whose points are NaN). Scalars give 0-d arrays.
    """
    dx, dy, dz = _sea_ray(model, pose, np.asarray(u, np.float64), np.asarray(v, np.float64))
    hit = ~(dz > -1e-9)
    t = np.where(hit, pose.altitude / np.where(hit, -dz, 1.0), np.nan)
    return np.stack([dx * t, dy * t, np.where(hit, 0.0, np.nan)], axis=-1), hit


def pixel_centres(model: CameraModel, axis: int, count: int | None = None,
                  dtype: type = np.float64) -> np.ndarray:
    """Normalised image coordinates (pixel centre minus principal point, over the focal
    length) of the first ``count`` (default: all) columns (``axis`` 0) or rows (1): (count,)
    of ``dtype``."""
    size, f = (model.width, model.fx) if axis == 0 else (model.height, model.fy)
    n = size if count is None else count
    return (np.arange(n, dtype=dtype) + 0.5 - size / 2) / f


def row_directions(pitch: float, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(forward, up): the horizontal (along the heading) and vertical components of the
    unnormalised rays through normalised rows ``v`` (image centre column) of a camera
    pitched ``pitch`` degrees below the horizon; rays with ``up >= 0`` miss the sea."""
    p = math.radians(pitch)
    return math.cos(p) - v * math.sin(p), -math.sin(p) - v * math.cos(p)


def horizon_row(model: CameraModel, pitch: float) -> float:
    """Image row (pixels from the top) of the horizon; -1 looking straight down."""
    p = math.radians(pitch)
    return model.height / 2 - model.fy * math.tan(p) if p < math.pi / 2 else -1.0


def centre_gsd(model: CameraModel, pose: CameraPose) -> float:
    """Metres per pixel (along x) at the image centre: the slant distance over fx."""
    return pose.altitude / math.sin(math.radians(pose.pitch)) / model.fx


def local_projection(model: CameraModel, basis: np.ndarray, offset: np.ndarray,
                     near: float = 0.05) -> tuple[float, float, float, np.ndarray] | None:
    """The projection of the world point at ``offset`` (3,) metres from the camera, and its
    derivative: (u, v) pixels, depth z metres along the optical axis, and the (2, 3)
    Jacobian of (u, v) with respect to the world point; ``basis`` is :func:`camera_basis`.
    None for points nearer than ``near`` metres (or behind the camera)."""
    xc = basis @ offset
    z = float(xc[2])
    if z <= near:
        return None
    fx, fy = model.fx, model.fy
    jac = np.array([[fx / z, 0, -fx * xc[0] / z ** 2],
                    [0, fy / z, -fy * xc[1] / z ** 2]]) @ basis
    return (float(fx * xc[0] / z + model.width / 2), float(fy * xc[1] / z + model.height / 2),
            z, jac)
