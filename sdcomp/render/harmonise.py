"""Objects over the user's footage, recorded as the footage was (``--backgrounds``).

The footage has been through a real camera: its lens and sensor blurred it, its sensor
added noise, and the frame was resized to the output (magnified by ``m`` output pixels per
frame pixel, or reduced). Rendered objects are as sharp as a pixel and clean: pasted on
as they are, they would be the sharpest, cleanest thing in the frame, the cue a detector
learns first. So after compositing, the objects (and a rim of the footage around them, where
their edges blend into it) get the footage's camera, the rest of the frame is left as it
was:

- **blur**: a Gaussian of ``sqrt(max(s_f^2 - s_r^2, 0))`` output pixels, where ``s_f =
  sqrt((b m)^2 + RESAMPLE^2)`` is the footage's own blur at the output (``b`` the camera's
  blur at its native resolution, ``--footage-blur``; :data:`RESAMPLE` the resize's) and
  ``s_r`` (:data:`RENDER_BLUR`) what a render's anti-aliasing already has;
- **noise**: white Gaussian noise of the footage's measured level (:func:`sdcomp.util.noise.
  noise_level` on the frame's luma), the same in the three channels and a third of it
  apart in each (sensor noise is mostly luminance after a camera's processing), weighted by
  the objects' coverage, so the water keeps its own grain.

Deterministic: the noise comes from the image's photo seed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from ..util.noise import noise_level
from .layers import Layer

RESAMPLE = 0.35  #: pixels: the blur of resizing a frame to the output (area or bilinear)
RENDER_BLUR = 0.45  #: pixels: the blur of a render's sprite anti-aliasing and warp
CHROMA_NOISE = 0.33  #: independent noise per channel, a share of the luminance noise


@dataclass(frozen=True)
class FootageCamera:
    """What the objects of one image over footage get: ``blur`` (Gaussian sigma, output
    pixels) and ``noise`` (std, 8-bit levels)."""

    blur: float
    noise: float


def footage_camera(photo: np.ndarray, magnification: float, native_blur: float
                   ) -> FootageCamera:
    """The :class:`FootageCamera` of a background ``photo`` (H, W, 3) uint8 (the output's
    pixels) cut from a frame at ``magnification`` output pixels per frame pixel, whose
    camera blurs by ``native_blur`` frame pixels (Gaussian sigma)."""
    own = math.hypot(native_blur * magnification, RESAMPLE)
    blur = math.sqrt(max(own * own - RENDER_BLUR * RENDER_BLUR, 0.0)) if native_blur > 0 else 0.0
    y = cv2.cvtColor(np.ascontiguousarray(photo), cv2.COLOR_RGB2GRAY).astype(np.float32)
    return FootageCamera(blur, noise_level(y))


def coverage(shape: tuple[int, int], layers: list[Layer], origin: tuple[int, int] = (0, 0)
             ) -> np.ndarray:
    """(h, w) float32: the union of the layers' coverage (their maximum) over a window of
    ``shape`` whose top-left pixel is frame pixel ``origin`` (x, y)."""
    out = np.zeros(shape, np.float32)
    ox, oy = origin
    for layer in layers:
        x0, y0, x1, y1 = layer.roi
        np.maximum(out[y0 - oy:y1 - oy, x0 - ox:x1 - ox], layer.alpha,
                   out=out[y0 - oy:y1 - oy, x0 - ox:x1 - ox])
    return out


def harmonise(image: np.ndarray, layers: list[Layer], camera: FootageCamera,
              seed: tuple[int, ...]) -> None:
    """Give the objects of a composited ``image`` (H, W, 3) uint8 (in place) the footage's
    ``camera`` (see the module docstring): blurred within their coverage, dilated by the
    blur's reach and feathered, and noise in proportion to their coverage."""
    if not layers or (camera.blur < 0.05 and camera.noise < 0.05):
        return
    h, w = image.shape[:2]
    # the coverage over the layers' boxes only (not a frame-sized array), then its extent
    bx0, by0 = min(lay.roi[0] for lay in layers), min(lay.roi[1] for lay in layers)
    bx1, by1 = max(lay.roi[2] for lay in layers), max(lay.roi[3] for lay in layers)
    cover = coverage((by1 - by0, bx1 - bx0), layers, (bx0, by0))
    rows, cols = np.flatnonzero(cover.any(axis=1)), np.flatnonzero(cover.any(axis=0))
    if not len(rows):
        return
    reach = int(math.ceil(3 * camera.blur)) + 2
    y0, y1 = max(by0 + int(rows[0]) - reach, 0), min(by0 + int(rows[-1]) + reach + 1, h)
    x0, x1 = max(bx0 + int(cols[0]) - reach, 0), min(bx0 + int(cols[-1]) + reach + 1, w)
    region = image[y0:y1, x0:x1].astype(np.float32)
    size = (y1 - y0, x1 - x0)
    c = np.zeros(size, np.float32)  # the coverage over the region
    iy0, iy1, ix0, ix1 = max(y0, by0), min(y1, by1), max(x0, bx0), min(x1, bx1)
    c[iy0 - y0:iy1 - y0, ix0 - x0:ix1 - x0] = cover[iy0 - by0:iy1 - by0, ix0 - bx0:ix1 - bx0]
    if camera.blur >= 0.05:
        blurred = cv2.GaussianBlur(region, (0, 0), camera.blur)
        # where the blur reaches: the objects and the rim their edges spread over
        mix = np.minimum(cv2.GaussianBlur(c, (0, 0), camera.blur + 0.5) * 3.0, 1.0)
        region = region + (blurred - region) * mix[..., None]
    if camera.noise >= 0.05:
        rng = np.random.default_rng([*seed, 0x4A2D])
        grain = rng.standard_normal(size).astype(np.float32)[..., None]
        grain = grain + np.float32(CHROMA_NOISE) * rng.standard_normal(
            size + (3,)).astype(np.float32)
        scale = np.float32(camera.noise / math.sqrt(1.0 + CHROMA_NOISE ** 2))
        region = region + grain * (scale * c)[..., None]
    image[y0:y1, x0:x1] = np.clip(region + 0.5, 0, 255).astype(np.uint8)
