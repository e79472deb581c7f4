"""The atlas's contact sheet: every pose of an atlas shaded under a fixed sun, labelled; and
the sheet of a kind's variants (:func:`kind_sheet`: one row per variant, a few views).

Also :func:`shade`, the Lambertian relighting the sheets use (the generator's own lighting
is :mod:`sdcomp.render.lighting`).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING

import cv2
import numpy as np

from ..util.colour import linear_to_srgb, srgb_to_linear
from ..util.files import write_png
from .poses import sun_direction, view_basis

if TYPE_CHECKING:
    from .store import Atlas

SHEET_SUN = (50.0, 135.0)  # elevation, azimuth (degrees) of the contact sheet's sun
SHEET_BACKGROUND = (70, 90, 105)  # sRGB behind the contact sheet's sprites


def contact_sheet(atlas: Atlas, cell: int = 96, columns: int = 20,
                  sun: tuple[float, float] = SHEET_SUN) -> np.ndarray:
    """(H, W, 3) uint8 RGB image of every pose, shaded with a sun at (elevation, azimuth)
    degrees in the body frame, on a grey-blue background, labelled off-nadir/azimuth."""
    n = len(atlas)
    rows = math.ceil(n / columns)
    sheet = np.empty((rows * cell, columns * cell, 3), np.uint8)
    sheet[:] = SHEET_BACKGROUND
    for i in range(n):
        theta, phi = atlas.poses[i, 0], atlas.poses[i, 1]
        r, c = divmod(i, columns)
        tile = sheet[r * cell:(r + 1) * cell, c * cell:(c + 1) * cell]
        tile[:] = _pose_image(atlas, i, cell, sun)
        _label(tile, f"{theta:.0f}/{phi:.0f}")
    return sheet


#: views of :func:`kind_sheet`: (off-nadir, azimuth) degrees, nadir to nearly level
KIND_SHEET_VIEWS = ((0.0, 0.0), (30.0, 45.0), (45.0, 160.0), (60.0, 250.0), (75.0, 90.0))


def kind_sheet(atlases: list[Atlas], cell: int = 128,
               views: tuple[tuple[float, float], ...] = KIND_SHEET_VIEWS,
               sun: tuple[float, float] = SHEET_SUN) -> np.ndarray:
    """(H, W, 3) uint8 RGB sheet of a kind's variants: one row per atlas, one column per
    view (the stored pose nearest to each (off-nadir, azimuth) in ``views``), each sprite
    filling its cell as it fills its atlas, labelled with the mesh name and the view."""
    sheet = np.empty((len(atlases) * cell, len(views) * cell, 3), np.uint8)
    sheet[:] = SHEET_BACKGROUND
    for r, atlas in enumerate(atlases):
        for c, (theta, phi) in enumerate(views):
            tile = sheet[r * cell:(r + 1) * cell, c * cell:(c + 1) * cell]
            tile[:] = _pose_image(atlas, atlas.nearest(theta, phi), cell, sun)
            _label(tile, f"{atlas.name} {theta:.0f}/{phi:.0f}" if c == 0
                   else f"{theta:.0f}/{phi:.0f}")
    return sheet


def _pose_image(atlas: Atlas, i: int, cell: int, sun: tuple[float, float]) -> np.ndarray:
    """(cell, cell, 3) uint8 RGB: pose ``i`` of ``atlas`` shaded under the sun at
    (elevation, azimuth) degrees in the body frame, over the sheet's background."""
    alpha, albedo, normal, _ = atlas.channels(i)
    s_cam = view_basis(atlas.poses[i, 0], atlas.poses[i, 1]) @ sun_direction(*sun)
    lit = shade(albedo, normal, s_cam).astype(np.float32)
    a = alpha[..., None]
    img = (lit * a + np.array(SHEET_BACKGROUND, np.float32) * (1 - a)).astype(np.uint8)
    return cv2.resize(img, (cell, cell), interpolation=cv2.INTER_AREA)


def _label(tile: np.ndarray, text: str) -> None:
    cv2.putText(tile, text, (2, tile.shape[0] - 4), cv2.FONT_HERSHEY_SIMPLEX, 0.3,
                (235, 235, 235), 1, cv2.LINE_AA)


def write_contact_sheet(atlas: Atlas, path: str | Path) -> Path:
    """Write :func:`contact_sheet` as a PNG, atomically."""
    return write_png(contact_sheet(atlas), path)


def shade(albedo: np.ndarray, normal: np.ndarray, sun_cam: np.ndarray,
          ambient: float = 0.35, sun: float = 0.9) -> np.ndarray:
    """Relight a sprite: ``albedo * (ambient + sun * max(0, n . s))``.

    Args:
        albedo: (H, W, 3) uint8 sRGB.
        normal: (H, W, 3) float unit normals in the camera frame.
        sun_cam: (3,) unit vector towards the sun in the same camera frame.
        ambient, sun: light intensities (linear, unitless).

    Returns:
        (H, W, 3) uint8 sRGB.
    """
    lin = srgb_to_linear(albedo.astype(np.float32) / 255.0)
    lambert = np.clip(normal @ np.asarray(sun_cam, np.float32), 0.0, None)[..., None]
    out = linear_to_srgb(lin * (ambient + sun * lambert))
    return np.rint(out * 255.0).astype(np.uint8)
