"""In-camera sharpening (unsharp mask with its halos) and video-codec-like compression (block DCT
quantisation via JPEG at a quality from the bitrate, 4:2:0 chroma, in-loop deblocking)."""

from __future__ import annotations

import cv2
import numpy as np

from .lens import SIGMA_121


def unsharp(image: np.ndarray, amount: float, sigma: float) -> np.ndarray:
    """In-camera sharpening: ``image + amount (image - gauss(image, sigma))`` on each channel,
    rounded and clipped (halos: over- and undershoot of about ``amount / 2`` of an edge's
    step, ~2 sigma wide); (H, W, 3) uint8."""
    # up to sigma 0.7 a 3 x 3 Gaussian holds all but 0.4 % of the weight
    ksize = (3, 3) if sigma <= 0.7 else (0, 0)
    blurred = cv2.GaussianBlur(image, ksize, sigma)
    return cv2.addWeighted(image, 1.0 + amount, blurred, -amount, 0.0)


def jpeg_roundtrip(image: np.ndarray, quality: int, *, bgr: bool = False
                   ) -> tuple[np.ndarray, int]:
    """JPEG encode and decode of an (H, W, 3) uint8 RGB image (``bgr``: its channels in
    B, G, R order, as the encoder takes them; OpenCV's libjpeg, 4:2:0 chroma, 8 x 8 DCT
    blocks): (decoded image, RGB, encoded bytes)."""
    if not bgr:
        image = cv2.cvtColor(image, cv2.COLOR_RGB2BGR)
    params = [cv2.IMWRITE_JPEG_QUALITY, int(quality)]
    if hasattr(cv2, "IMWRITE_JPEG_SAMPLING_FACTOR"):
        params += [cv2.IMWRITE_JPEG_SAMPLING_FACTOR, cv2.IMWRITE_JPEG_SAMPLING_FACTOR_420]
    ok, data = cv2.imencode(".jpg", image, params)
    if not ok:
        raise RuntimeError("JPEG encoding failed")
    # the decoder's own RGB output (OpenCV >= 4.10) is the same bytes as BGR swapped after
    out = cv2.imdecode(data, _DECODE_RGB or cv2.IMREAD_COLOR)
    if out is None:
        raise RuntimeError("JPEG decoding failed")
    if not _DECODE_RGB:
        out = cv2.cvtColor(out, cv2.COLOR_BGR2RGB)
    return out, int(data.size)


_DECODE_RGB = getattr(cv2, "IMREAD_COLOR_RGB", 0)


def deblock(image: np.ndarray, strength: float, block: int = 8, *,
            in_place: bool = False) -> np.ndarray:
    """A cheap stand-in for the H.264/H.265 in-loop deblocking filter: the two pixels on
    either side of each ``block`` px boundary (p0 | q0, with p1, q1 next to them) move
    towards a [1, 2, 1] / 4 smoothing across the boundary, ``p0 + s ((p1 + 2 p0 + q0) / 4 -
    p0)``, by ``strength`` s in [0, 1]; vertical boundaries first, then horizontal. Unlike
    the real filter it does not spare true edges that fall on a boundary. (H, W, 3) uint8,
    a new array (``in_place``: ``image`` itself, changed); a frame whose size is not a
    multiple of the block keeps its last partial block unfiltered."""
    if strength <= 0:
        return image
    h, w, c = image.shape
    out = image if in_place else image.copy()
    bw, bh = w // block, h // block
    if bw >= 2:  # vertical boundaries: smooth across x everywhere, keep the boundary columns
        smooth = cv2.GaussianBlur(out, (3, 1), SIGMA_121, sigmaY=1.0,
                                  borderType=cv2.BORDER_REFLECT)  # [1, 2, 1] / 4
        cv2.addWeighted(out, 1.0 - strength, smooth, strength, 0.0, dst=smooth)
        cv2.copyTo(smooth, _boundary_columns(h, w, block), out)  # strided writes cost 3x
    if bh >= 2:  # horizontal boundaries: rows 7 and 8 of consecutive 8-row bands
        m = out[:bh * block].reshape(bh, block, w * c)
        _smooth_pairs(m[:-1, block - 2], m[:-1, block - 1], m[1:, 0], m[1:, 1], strength)
    return out


_COLUMNS: dict = {}


def _boundary_columns(h: int, w: int, block: int) -> np.ndarray:
    """(h, w) uint8 mask, 255 on the columns either side of each vertical block boundary
    but the last whole block's right column; cached per size (2 entries)."""
    key = (h, w, block)
    mask = _COLUMNS.get(key)
    if mask is None:
        row = np.zeros(w, np.uint8)
        last = (w // block) * block - 1  # the last whole block's right column is no boundary
        row[block - 1:last:block] = 255
        row[block:last:block] = 255
        while len(_COLUMNS) >= 2:
            _COLUMNS.pop(next(iter(_COLUMNS)))
        mask = _COLUMNS[key] = np.ascontiguousarray(np.broadcast_to(row, (h, w)))
    return mask


def _smooth_pairs(p1, p0, q0, q1, s: float) -> None:
    """In place: p0, q0 (uint8 2-D views) move by ``s`` towards the [1, 2, 1] / 4 smoothing
    across the p0 | q0 boundary (computed from the values before the call). The smoothing
    ``(p1 + 2 p0 + q0) / 4`` is summed in uint16 (NumPy: a third faster than OpenCV's
    mixed-type adds) and rounded half to even by ``convertScaleAbs`` (the same bytes as
    ``addWeighted`` of the uint16 and uint8 terms, at half its cost)."""
    sp = p0.astype(np.uint16)
    sp <<= 1
    sp += p1
    sp += q0
    sq = q0.astype(np.uint16)
    sq <<= 1
    sq += q1
    sq += p0
    sp8, sq8 = cv2.convertScaleAbs(sp, alpha=0.25), cv2.convertScaleAbs(sq, alpha=0.25)
    cv2.addWeighted(p0, 1.0 - s, sp8, s, 0.0, dst=sp8)
    cv2.addWeighted(q0, 1.0 - s, sq8, s, 0.0, dst=sq8)
    p0[...] = sp8
    q0[...] = sq8


def block_compress(image: np.ndarray, quality: int, deblock_strength: float,
                   sx: float, sy: float) -> tuple[np.ndarray, dict]:
    """Block-DCT compression (JPEG proxy of the video codec) as it looks after a reduction
    by ``sx`` x ``sy``: the frame is magnified by the integer factors (round(sx),
    round(sy)) so its 8 x 8 blocks are native-sized, compressed at ``quality``, deblocked,
    and reduced back by area averaging. Returns (image, info with ``bpp`` = JPEG bits per
    (magnified) pixel and ``factor``)."""
    h, w = image.shape[:2]
    nx, ny = max(1, round(sx)), max(1, round(sy))
    # the encoder's channel order before the magnification (a per-channel resize): the
    # swap touches 1 / (nx ny) of the pixels
    work = cv2.cvtColor(image, cv2.COLOR_RGB2BGR)
    if (nx, ny) != (1, 1):
        work = cv2.resize(work, (w * nx, h * ny), interpolation=cv2.INTER_LINEAR)
    out, nbytes = jpeg_roundtrip(work, quality, bgr=True)
    out = deblock(out, deblock_strength, in_place=True)  # out: the decoder's array
    if (nx, ny) != (1, 1):
        out = cv2.resize(out, (w, h), interpolation=cv2.INTER_AREA)
    bpp = 8.0 * nbytes / (work.shape[0] * work.shape[1])
    return out, {"bpp": bpp, "factor": (nx, ny)}
