"""Ambient occlusion: how much of the sky each visible point of a sprite sees.

A point at the bottom of a cockpit, under a canopy, in the crease between a swimmer's arm
and body or under a jet ski's handlebars sees little of the sky: its diffuse light is a
fraction of an open deck's. Per sprite pixel, the occlusion ``A`` is the cosine-weighted
share of the sky hemisphere (the body's upper half-space) that no part of the mesh hides:

    A(p) = sum_k V(p, d_k) max(0, n(p) . d_k) / sum_k max(0, n(p) . d_k)

over :data:`DIRECTIONS` directions ``d_k`` spread evenly over the hemisphere (a Fibonacci
spiral, uniform in height), ``p`` the pixel's visible surface point (from its position in
the view and its height above the waterline), ``n(p)`` its normal, ``V`` whether the ray
from ``p`` (lifted off the surface along ``n`` by :data:`LIFT_PX` map pixels) towards
``d_k`` leaves the mesh: a shadow-map test against the mesh z-buffered orthographically
along ``d_k`` (:func:`sdcomp.atlas.raster.depth_map`) at :data:`CANVAS` pixels across its
bounding sphere. A point that faces no sky direction (a hull's bottom) has ``A = 1``: the
sea's light from below is not occluded here; nor is any light by the water, which the
renderer puts the submerged part under itself.

The renderer uses ``A`` as a factor on the diffuse reflectance (:func:`diffuse_factor`: the
sun's light in a cockpit is blocked about as often as the sky's; the walls' bounce returns
some of it), so that the atlas's albedo stays the mesh's colours.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..assets.mesh import ColoredMesh
from .poses import view_basis
from .raster import DepthMap, Sprite, depth_map

DIRECTIONS = 48  #: sky directions sampled
CANVAS = 384  #: pixels across the mesh's bounding sphere in each direction's depth map
LIFT_PX = 1.5  #: a point is lifted this many depth-map pixels along its normal
BIAS_PX = 1.0  #: and counts as seen while within this many pixels of the nearest surface
BOUNCE = 0.2  #: share of the occluded light the surroundings reflect back (diffuse_factor)


def sky_directions(n: int = DIRECTIONS) -> np.ndarray:
    """(n, 3) float64 unit vectors over the upper hemisphere (z > 0), evenly spread: heights
    uniform in (0, 1) (equal areas), azimuths on the golden-angle spiral."""
    k = np.arange(n, dtype=np.float64)
    z = (k + 0.5) / n
    r = np.sqrt(np.maximum(1.0 - z * z, 0.0))
    phi = k * math.pi * (3.0 - math.sqrt(5.0))
    return np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=1)


@dataclass(frozen=True)
class SkyMaps:
    """The depth maps of a mesh from each sky direction (:func:`sky_maps`) and the pitch of
    their pixels (metres)."""

    directions: np.ndarray
    maps: tuple[DepthMap, ...]
    pitch: float

    def occlusion(self, points: np.ndarray, normals: np.ndarray) -> np.ndarray:
        """(k,) float32 occlusion ``A`` (module docstring) of surface ``points`` (k, 3) with
        unit ``normals`` (k, 3), the mesh's frame."""
        p = np.asarray(points, np.float64)
        n = np.asarray(normals, np.float64)
        lifted = p + n * (LIFT_PX * self.pitch)
        seen = np.zeros(len(p))
        total = np.zeros(len(p))
        for d, dm in zip(self.directions, self.maps, strict=True):
            w = np.maximum(n @ d, 0.0)
            if not (w > 0).any():
                continue
            total += w
            seen += w * dm.visible(lifted, BIAS_PX * self.pitch)
        return np.where(total > 0, seen / np.maximum(total, 1e-12), 1.0).astype(np.float32)


def sky_maps(mesh: ColoredMesh, directions: int = DIRECTIONS, canvas: int = CANVAS
             ) -> SkyMaps:
    """The :class:`SkyMaps` of ``mesh`` (body frame, z up)."""
    v = np.asarray(mesh.vertices, np.float64)
    centre = v.mean(axis=0) if len(v) else np.zeros(3)
    radius = max(float(np.linalg.norm(v - centre, axis=1).max()) if len(v) else 0.0, 1e-6)
    pitch = 2.0 * radius * 1.02 / canvas
    dirs = sky_directions(directions)
    return SkyMaps(dirs, tuple(depth_map(mesh, d, pitch, canvas, centre) for d in dirs),
                   pitch)


def sprite_occlusion(sprite: Sprite, off_nadir: float, azimuth: float, metres_per_pixel: float,
                     waterline: float, maps: SkyMaps) -> np.ndarray:
    """(S, S) float32 occlusion of each covered pixel of ``sprite`` (1 where empty), a view
    from (``off_nadir``, ``azimuth``) degrees at ``metres_per_pixel`` (the atlas's: the body
    origin at the canvas centre, heights above ``waterline`` metres): each pixel's surface
    point is where its view ray meets its height (views at most 80 degrees off nadir)."""
    size = sprite.alpha.shape[0]
    out = np.ones((size, size), np.float32)
    rows, cols = np.nonzero(sprite.mask)
    if len(rows) == 0:
        return out
    basis = view_basis(off_nadir, azimuth)  # rows right, up, toward
    right, up, toward = basis
    x = (cols + 0.5 - size / 2.0) * metres_per_pixel
    y = -(rows + 0.5 - size / 2.0) * metres_per_pixel
    z = sprite.height[rows, cols].astype(np.float64) + waterline
    t = (z - x * right[2] - y * up[2]) / max(float(toward[2]), 1e-3)
    points = x[:, None] * right + y[:, None] * up + t[:, None] * toward
    normals = sprite.normal[rows, cols].astype(np.float64) @ basis  # camera -> body frame
    out[rows, cols] = maps.occlusion(points, normals)
    return out


def diffuse_factor(occlusion: np.ndarray) -> np.ndarray:
    """The factor on a pixel's diffuse reflectance for occlusion ``A`` (float32 array):
    ``A + BOUNCE (1 - A)``."""
    return (occlusion + np.float32(BOUNCE) * (np.float32(1.0) - occlusion)).astype(np.float32)
