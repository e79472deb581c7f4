"""Camera effects on the rendered uint8 image: motion and defocus blur, sensor noise.

Exposure, white balance and vignetting are gains applied where colours are computed
(:mod:`sdcomp.render.lighting`); what is left for the finished image is here. Blur and noise
come after the masks are made and never change them.

Motion blur along a line of ``n`` taps is a convolution for short lines and, from
:data:`LINE_TAPS_MIN` taps on, :func:`line_mean`: sums of ``2**k`` consecutive taps built by
doubling, ``n`` put together from its binary digits (see docs/architecture.md).
"""

from __future__ import annotations

import math

import cv2
import numpy as np

from ..scene.scene import Effects

BLUR_EXACT_MAX = 8192  # pixels: larger frames are blurred at BLUR_WORK_SIZE and magnified
BLUR_WORK_SIZE = 4096  # pixels: at most this size (an integer reduction factor)
LINE_TAPS_MIN = 16  # motion blur this long or longer sums shifted frames (line_mean)
LINE_BAND_BYTES = 8 << 20  # line_mean works in bands of rows of about this many bytes
NOISE_SCALE = 32.0  # uint8 levels per standard deviation in the noise tile


def noise_tile(seed: tuple[int, ...], h: int, w: int) -> np.ndarray:
    """The sensor-noise tile of frames of (h, w) pixels: (nh, nw, 3) uint8,
    ``128 + NOISE_SCALE x N(0, 1)``, a function of the seed sequence ``seed``
    (:attr:`sdcomp.scene.scene.FeatureSeeds.noise_tile`), at least 1021 pixels larger than
    the frame in each direction up to 1024 (frames larger than it get it added block by
    block: :func:`add_noise`)."""
    rng = np.random.default_rng(list(seed))
    nh, nw = min(h, 1024) + 1021, min(w, 1024) + 1031
    noise = 128.0 + NOISE_SCALE * rng.standard_normal((nh, nw, 1))
    return np.repeat(np.clip(np.rint(noise), 0, 255).astype(np.uint8), 3, axis=2)


def add_noise(image: np.ndarray, noise: np.ndarray, s: float, rng) -> np.ndarray:
    """``image + s * (noise - 128)`` for a uint8 (H, W, 3) ``image`` and a uint8 noise tile
    (at least 1021 pixels larger than the image in each direction up to 1024 pixels).
    A frame that fits the tile gets a random window of it (a new array); a larger frame
    gets the tile added block by block in place (frames of gigabytes are not copied), at a
    random offset."""
    h, w = image.shape[:2]
    nh, nw = noise.shape[:2]
    if h <= nh and w <= nw:
        oy = int(rng.integers(nh - h + 1))
        ox = int(rng.integers(nw - w + 1))
        return cv2.addWeighted(image, 1.0, noise[oy:oy + h, ox:ox + w], s, -128.0 * s)
    oy, ox = int(rng.integers(nh)), int(rng.integers(nw))
    for y in range(-oy, h, nh):
        for x in range(-ox, w, nw):
            ty0, tx0 = max(y, 0), max(x, 0)
            ty1, tx1 = min(y + nh, h), min(x + nw, w)
            block = image[ty0:ty1, tx0:tx1]
            cv2.addWeighted(block, 1.0, noise[ty0 - y:ty1 - y, tx0 - x:tx1 - x], s,
                            -128.0 * s, dst=block)
    return image


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


def apply_effects(image: np.ndarray, fx: Effects, noise: np.ndarray | None,
                  rng: np.random.Generator) -> np.ndarray:
    """Blur and sensor noise of ``fx`` on the uint8 (H, W, 3) ``image`` (changed in place for
    huge frames, else a new array is returned); ``noise`` is the run's noise tile
    (:func:`noise_tile`), ``rng`` draws its window."""
    h, w = image.shape[:2]
    if max(h, w) > BLUR_EXACT_MAX and (fx.motion_blur or fx.defocus_blur):
        # huge frames: the blur kernels grow with the frame (hundreds of pixels at
        # 30000 px); blur a copy reduced to BLUR_WORK_SIZE and magnify it back into
        # the frame (detail finer than the reduction factor, 8 px at 30000, is lost);
        # an integer factor takes OpenCV's fast area-averaging path
        f = math.ceil(max(h, w) / BLUR_WORK_SIZE)
        small = cv2.resize(image, (max(1, round(w / f)), max(1, round(h / f))),
                           interpolation=cv2.INTER_AREA)
        if fx.motion_blur is not None:
            length, angle = fx.motion_blur
            small = motion_blur(small, length / f, angle)
        if fx.defocus_blur is not None:
            small = cv2.GaussianBlur(small, (0, 0), fx.defocus_blur / f)
        cv2.resize(small, (w, h), dst=image, interpolation=cv2.INTER_LINEAR)
    else:
        if fx.motion_blur is not None:
            image = motion_blur(image, *fx.motion_blur)
        if fx.defocus_blur is not None:
            image = cv2.GaussianBlur(image, (0, 0), fx.defocus_blur)
    if fx.noise > 0 and noise is not None:
        image = add_noise(image, noise, fx.noise / NOISE_SCALE, rng)
    return image
