"""Viewing geometry of the atlas: camera bases for a pose, and the pose grid.

A pose is (off-nadir, azimuth, roll, pitch) in degrees:

- ``off_nadir``: angle between the view ray and straight down; 0 looks straight down on the
  object, 90 looks at it from the horizon.
- ``azimuth``: direction from the object towards the camera, seen from above, measured from
  the body's +x (forward) towards +y (port), counter-clockwise.
- ``roll``, ``pitch``: small tilt of the object on the waves, rotations about body x then y
  (right-handed, degrees), about the point where the waterline meets the body's z axis. The
  atlas stores untilted views only (its pose rows keep two tilt columns, always 0): a
  tilted body seen from a direction is the untilted body seen from that direction rotated
  back, which the renderer works out; only the waterline's cut differs, and the renderer
  tilts the stored heights for it.

The camera is orthographic. Its frame: ``right`` (image x, columns), ``up`` (image -y, rows
go down), ``toward`` (from the object to the camera). Image up is the direction away from the
camera along the ground, so the horizon would be level; in-plane rotation for a given view is
the compositor's job.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


def view_basis(off_nadir_deg: float, azimuth_deg: float) -> np.ndarray:
    """Camera basis for a view, as a (3, 3) float64 matrix of row vectors (right, up, toward).

    Each row is a unit vector in the world frame (x forward, y port, z up). Multiplying
    world points (N, 3) by the transpose gives camera coordinates (x right, y up, z toward
    the camera).
    """
    t, p = math.radians(off_nadir_deg), math.radians(azimuth_deg)
    toward = np.array([math.sin(t) * math.cos(p), math.sin(t) * math.sin(p), math.cos(t)])
    up = np.array([-math.cos(t) * math.cos(p), -math.cos(t) * math.sin(p), math.sin(t)])
    right = np.cross(up, toward)
    return np.stack([right, up, toward])


def tilt_matrix(roll_deg: float, pitch_deg: float) -> np.ndarray:
    """(3, 3) rotation of the body by ``roll`` about x, then ``pitch`` about y (degrees)."""
    r, p = math.radians(roll_deg), math.radians(pitch_deg)
    rx = np.array([[1, 0, 0], [0, math.cos(r), -math.sin(r)], [0, math.sin(r), math.cos(r)]])
    ry = np.array([[math.cos(p), 0, math.sin(p)], [0, 1, 0], [-math.sin(p), 0, math.cos(p)]])
    return ry @ rx


def view_direction(off_nadir_deg, azimuth_deg) -> np.ndarray:
    """Unit vectors from the object towards the camera, (..., 3) float64, world frame."""
    t = np.radians(np.asarray(off_nadir_deg, dtype=float))
    p = np.radians(np.asarray(azimuth_deg, dtype=float))
    return np.stack([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)], axis=-1)


@dataclass(frozen=True)
class PoseGrid:
    """The poses an atlas stores; validated on construction.

    Off-nadir rings are spaced ``off_nadir_step`` degrees from 0 to ``max_off_nadir``; each
    ring gets as many azimuths as it needs so that every view direction with off-nadir up to
    ``max_off_nadir + off_nadir_step / 2`` is within ``max_error`` degrees of a stored one.
    """

    max_off_nadir: float = 80.0
    off_nadir_step: float = 10.0
    max_error: float = 7.5

    def __post_init__(self) -> None:
        if not 0 <= self.max_off_nadir <= 90:
            raise ValueError(f"max off-nadir must be in [0, 90] degrees, got {self.max_off_nadir}")
        if not 0 < self.off_nadir_step <= 45:
            raise ValueError(
                f"off-nadir step must be in (0, 45] degrees, got {self.off_nadir_step}")
        if not self.off_nadir_step / 2 < self.max_error <= 45:
            raise ValueError(
                f"max error must be in ({self.off_nadir_step / 2:g}, 45] degrees "
                f"(more than half the off-nadir step), got {self.max_error}")

    def rings(self) -> list[tuple[float, int]]:
        """(off-nadir degrees, number of azimuths) for each ring, nadir first."""
        half = self.off_nadir_step / 2
        # azimuth half-gap g at a ring: a point half a ring step away and g off in azimuth
        # is within max_error when cos(max_error) <= cos(half) * cos(g') with g' the
        # great-circle half-gap at the ring's outer edge.
        g = math.degrees(math.acos(math.cos(math.radians(self.max_error))
                                   / math.cos(math.radians(half))))
        out = []
        n_rings = int(math.floor(self.max_off_nadir / self.off_nadir_step + 1e-9)) + 1
        for k in range(n_rings):
            theta = k * self.off_nadir_step
            if theta == 0:
                out.append((0.0, 1))
                continue
            outer = min(theta + half, 90.0)
            s = math.sin(math.radians(g)) / math.sin(math.radians(outer))
            dphi = 2 * math.degrees(math.asin(min(1.0, s)))
            out.append((float(theta), max(1, math.ceil(360.0 / dphi - 1e-9))))
        return out

    def poses(self) -> np.ndarray:
        """(P, 4) float64 poses: off-nadir, azimuth, and the two tilt columns (0), degrees."""
        rows = [(theta, 360.0 * j / n, 0.0, 0.0) for theta, n in self.rings()
                for j in range(n)]
        return np.array(rows, dtype=np.float64).reshape(-1, 4)


def nearest_pose(poses: np.ndarray, off_nadir_deg: float, azimuth_deg: float) -> int:
    """Index of the stored pose (rows of ``poses``, (P, 4) degrees) whose view direction
    makes the smallest angle with the view (``off_nadir_deg``, ``azimuth_deg``)."""
    dirs = view_direction(poses[:, 0], poses[:, 1])
    return int(np.argmax(dirs @ view_direction(off_nadir_deg, azimuth_deg)))


def sun_direction(elevation_deg: float, azimuth_deg: float) -> np.ndarray:
    """(3,) unit vector towards the sun in the world frame (x forward, y port, z up).

    ``azimuth_deg`` is measured from +x towards +y, ``elevation_deg`` above the horizon.
    """
    e, a = math.radians(elevation_deg), math.radians(azimuth_deg)
    return np.array([math.cos(e) * math.cos(a), math.cos(e) * math.sin(a), math.sin(e)])
