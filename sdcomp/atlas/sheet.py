"""The atlas's contact sheet: every pose of an atlas shaded under a fixed sun, labelled.

Also :func:`shade`, the Lambertian relighting the sheet uses (the generator's own lighting is
:mod:`sdcomp.render.lighting`).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING

import cv2
import numpy as np

from ..util.colour import linear_to_srgb, srgb_to_linear
from ..util.files import atomic_write_bytes
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
    sun_w = sun_direction(*sun)
    bg = np.array(SHEET_BACKGROUND, np.float32)
    for i in range(n):
        theta, phi = atlas.poses[i, 0], atlas.poses[i, 1]
        s_cam = view_basis(theta, phi) @ sun_w
        lit = shade(atlas.albedo[i], atlas.normal[i], s_cam).astype(np.float32)
        a = atlas.alpha[i][..., None]
        img = (lit * a + bg * (1 - a)).astype(np.uint8)
        img = cv2.resize(img, (cell, cell), interpolation=cv2.INTER_AREA)
        r, c = divmod(i, columns)
        tile = sheet[r * cell:(r + 1) * cell, c * cell:(c + 1) * cell]
        tile[:] = img
        label = f"{theta:.0f}/{phi:.0f}"
        cv2.putText(tile, label, (2, cell - 4), cv2.FONT_HERSHEY_SIMPLEX, 0.3,
                    (235, 235, 235), 1, cv2.LINE_AA)
    return sheet


def write_contact_sheet(atlas: Atlas, path: str | Path) -> Path:
    """Write :func:`contact_sheet` as a PNG, atomically."""
    path = Path(path)
    ok, buf = cv2.imencode(".png", cv2.cvtColor(contact_sheet(atlas), cv2.COLOR_RGB2BGR))
    if not ok:
        raise OSError(f"could not encode {path}")
    atomic_write_bytes(path, buf.tobytes())
    return path


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
