"""Regions of real frames that are not the scene: flat black areas painted over it.

SeaDronesSee paints what it does not label black in its images (its category 0,
``ignored``, has no boxes); letterbox bars and masked-out overlays are black too. Such a
region is no water: the realism report, ``sdcomp fit`` and the per-object statistics keep it
out of the water they measure. Daylight water is never this dark in all three channels
over several pixels; a compressed image keeps painted black within a few levels, and its
ringing beside the paint within the edge's 8 x 8 block.
"""

from __future__ import annotations

import cv2
import numpy as np

PAINT_LEVEL = 12  #: 8-bit levels: a painted pixel's three channels are all at most this
#: 8-bit levels: a painted region's mean brightest channel is at most this. Paint is 0,
#: lifted to 4-6 by JPEG 70 in a small region among bright water; water crushed to black
#: keeps the camera's black level (5-12 in sdcomp's frames into the sun: 9 regions of
#: 36 px or more in 2600 frames have 6 or less, black objects among them)
PAINT_MEAN = 6.0
PAINT_SIDE = 5  #: pixels: darker areas narrower than this square are not paint
PAINT_AREA = 36  #: pixels: painted regions are at least this large (their dark core)
PAINT_MARGIN = 8  #: pixels around a painted region also left out (a JPEG block of ringing)


def painted_mask(rgb: np.ndarray) -> np.ndarray | None:
    """(H, W) bool, True on the painted-out regions of the (H, W, 3) uint8 image ``rgb``
    and :data:`PAINT_MARGIN` pixels around them: connected areas of at least
    :data:`PAINT_AREA` pixels whose channels are all at most :data:`PAINT_LEVEL` (their
    mean brightest channel at most :data:`PAINT_MEAN`), without the parts narrower than
    :data:`PAINT_SIDE` (a morphological opening); None when there is none (most frames:
    one threshold and one count over the image)."""
    dark = cv2.inRange(rgb, (0, 0, 0), (PAINT_LEVEL,) * 3)
    if cv2.countNonZero(dark) < PAINT_AREA:
        return None
    solid = cv2.morphologyEx(dark, cv2.MORPH_OPEN, np.ones((PAINT_SIDE, PAINT_SIDE), np.uint8))
    n, labels, stats, _ = cv2.connectedComponentsWithStats(solid, connectivity=8)
    area = stats[:, cv2.CC_STAT_AREA]
    level = np.bincount(labels.ravel(), rgb.max(axis=2).ravel(), n) / np.maximum(area, 1)
    big = ((area >= PAINT_AREA) & (level <= PAINT_MEAN)).astype(np.uint8)
    big[0] = 0  # the background
    if not big.any():
        return None
    side = 2 * PAINT_MARGIN + 1
    return cv2.dilate(big[labels], np.ones((side, side), np.uint8)) > 0


def shrink_valid(valid: np.ndarray, width: int, height: int) -> np.ndarray:
    """The (H, W) bool pixel mask ``valid`` at ``width`` x ``height``: a pixel is valid
    where every source pixel it covers is (area average, so a small invalid region is not
    lost in a reduction)."""
    if valid.shape == (height, width):
        return valid
    area = cv2.resize(valid.astype(np.float32), (width, height), interpolation=cv2.INTER_AREA)
    return area >= 1.0 - 1e-4
