"""Blur of the rendered uint8 image: motion along a line and defocus (Gaussian).

Blur comes after the masks are made and never changes them. Motion blur along a line of
``n`` taps is a convolution for short lines and, from :data:`LINE_TAPS_MIN` taps on,
:func:`line_mean`: sums of ``2**k`` consecutive taps built by doubling, ``n`` put together
from its binary digits (see docs/architecture.md). Frames larger than
:data:`BLUR_EXACT_MAX` are blurred reduced (:func:`blur`).
"""

from __future__ import annotations

import math

import cv2
import numpy as np

BLUR_EXACT_MAX = 8192  # pixels: larger frames are blurred at BLUR_WORK_SIZE and magnified
BLUR_WORK_SIZE = 4096  # pixels: at most this size (an integer reduction factor)
LINE_TAPS_MIN = 16  # motion blur this long or longer sums shifted frames (line_mean)
LINE_BAND_BYTES = 8 << 20  # line_mean works in bands of rows of about this many bytes


def motion_blur(image: np.ndarray, length: float, angle: float) -> np.ndarray:
    """Motion blur of a uint8 (H, W, C) ``image`` along a line of ``length`` pixels at
    ``angle`` degrees, borders reflected: a convolution with :func:`motion_kernel` for
    short lines, :func:`line_mean` (the same line, its taps one pixel apart) from
    :data:`LINE_TAPS_MIN` taps on, where a dense kernel costs seconds per 20-megapixel
    frame."""
    if round(length) < LINE_TAPS_MIN:
        return cv2.filter2D(image, -1, motion_kernel(length, angle),
                            borderType=cv2.BORDER_REFLECT)
    return line_mean(image, int(round(length)), angle)


def line_mean(image: np.ndarray, n: int, angle: float) -> np.ndarray:
    """Mean of ``n`` taps of a uint8 (H, W, C) ``image`` one pixel apart along ``angle``
    degrees, centred on each pixel, borders reflected; uint8 (H, W, C). Sums of ``2**k``
    taps built by doubling, in bands of rows of about :data:`LINE_BAND_BYTES` (taps up to
    ``log2(n) / 2`` pixels off the exact line; see docs/architecture.md)."""
    dx, dy = math.cos(math.radians(angle)), math.sin(math.radians(angle))

    def at(t: float) -> tuple[int, int]:
        return int(round(t * dx)), int(round(t * dy))

    pad = n + 2
    h, w, c = image.shape[0], image.shape[1], (image.shape[2] if image.ndim == 3 else 1)
    dtype = np.uint16 if n <= 257 else np.int32
    row_bytes = (w + 2 * pad) * c * np.dtype(dtype).itemsize
    rows = max(LINE_BAND_BYTES // row_bytes - 2 * pad, 8 * pad)  # overlap at most 1/4
    out = np.empty_like(image)
    cx, cy = at(-(n - 1) / 2)  # centre the line on the pixel
    for y in range(0, h, rows):
        y1 = min(h, y + rows)
        # rows y - pad .. y1 + pad, reflected at the frame's top and bottom only
        top, bottom = max(0, y - pad), min(h, y1 + pad)
        slab = cv2.copyMakeBorder(image[top:bottom], pad - (y - top), pad - (bottom - y1),
                                  pad, pad, cv2.BORDER_REFLECT)
        piece = (slab.astype(dtype), 0, 0)
        total, start, m = None, 0, 1
        while True:
            if n & m:  # the next m taps, from tap `start` on
                ox, oy = at(start)
                moved = (piece[0], piece[1] - ox, piece[2] - oy)
                total = moved if total is None else sum_shifted(total, moved, (0, 0))
                start += m
            if 2 * m > n:
                break
            piece = sum_shifted(piece, piece, at(m))
            m *= 2
        assert total is not None  # n >= 1: at least one piece
        arr: np.ndarray = total[0]
        x0, y0 = total[1], total[2]
        ys, xs = pad + cy - y0, pad + cx - x0  # the band's corner in `arr`
        band = cv2.convertScaleAbs(arr[ys:ys + y1 - y, xs:xs + w], alpha=1.0 / n)
        out[y:y1] = band.reshape(out[y:y1].shape)
    return out


def sum_shifted(a: tuple, b: tuple, shift: tuple[int, int]) -> tuple:
    """``c(q) = a(q) + b(q + shift)`` over the points ``q`` where both are defined.

    Each argument and the result is ``(array, x0, y0)``: ``array[y, x]`` holds the value at
    canvas point ``(x0 + x, y0 + y)``."""
    (pa, ax, ay), (pb, bx, by), (sx, sy) = a, b, shift
    x0, y0 = max(ax, bx - sx), max(ay, by - sy)
    x1 = min(ax + pa.shape[1], bx - sx + pb.shape[1])
    y1 = min(ay + pa.shape[0], by - sy + pb.shape[0])
    out = cv2.add(pa[y0 - ay:y1 - ay, x0 - ax:x1 - ax],
                  pb[y0 + sy - by:y1 + sy - by, x0 + sx - bx:x1 + sx - bx])
    return out, x0, y0


def motion_kernel(length: float, angle: float) -> np.ndarray:
    """Normalised line kernel of ``length`` pixels at ``angle`` degrees."""
    k = int(max(3, round(length) | 1))
    kernel = np.zeros((k, k), np.float32)
    c = k // 2
    dx, dy = math.cos(math.radians(angle)), math.sin(math.radians(angle))
    for t in np.linspace(-length / 2, length / 2, 4 * k):
        kernel[int(round(c + t * dy)) % k, int(round(c + t * dx)) % k] += 1
    return kernel / kernel.sum()


def blur(image: np.ndarray, motion: tuple[float, float] | None,
         defocus: float | None) -> np.ndarray:
    """``image`` (H, W, 3) uint8 blurred by ``motion`` (length px, angle degrees) and
    ``defocus`` (Gaussian sigma px), either may be None: a new array, or ``image`` changed
    in place for frames larger than :data:`BLUR_EXACT_MAX` (frames of gigabytes are not
    copied): their kernels grow with the frame (hundreds of pixels at 30000 px), so a copy
    reduced to :data:`BLUR_WORK_SIZE` is blurred and magnified back (detail finer than the
    reduction factor, 8 px at 30000, is lost; an integer factor takes OpenCV's fast
    area-averaging path)."""
    if motion is None and defocus is None:
        return image
    h, w = image.shape[:2]
    if max(h, w) > BLUR_EXACT_MAX:
        f = math.ceil(max(h, w) / BLUR_WORK_SIZE)
        small = cv2.resize(image, (max(1, round(w / f)), max(1, round(h / f))),
                           interpolation=cv2.INTER_AREA)
        small = blur(small, None if motion is None else (motion[0] / f, motion[1]),
                     None if defocus is None else defocus / f)
        cv2.resize(small, (w, h), dst=image, interpolation=cv2.INTER_LINEAR)
        return image
    if motion is not None:
        image = motion_blur(image, *motion)
    if defocus is not None:
        image = cv2.GaussianBlur(image, (0, 0), defocus)
    return image
