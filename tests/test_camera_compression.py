"""The drone camera's compression (sdcomp.render.camera.codec): the block-DCT proxy of the
video codec, bits per pixel and quality, blockiness, deblocking, the scale rule."""

from __future__ import annotations

import numpy as np
import pytest

from sdcomp.render.camera import apply_camera
from sdcomp.render.camera import codec as C
from sdcomp.render.camera.photometric import LUMA
from sdcomp.render.camera.sensor import make_noise_tile
from sdcomp.scene.look import QUALITY_BPP, quality_for_bpp, video_bpp
from sdcomp.scene.look_table import sample_look

from .conftest import water_like


def blockiness(img: np.ndarray) -> float:
    """Mean luma step across 8 px block boundaries / mean step inside blocks (1: none)."""
    y = img.astype(float) @ LUMA
    dh, dv = np.abs(np.diff(y, axis=1)), np.abs(np.diff(y, axis=0))
    edge = dh[:, 7::8].mean() + dv[7::8].mean()
    inner = np.delete(dh, np.s_[7::8], axis=1).mean() + np.delete(dv, np.s_[7::8], axis=0).mean()
    return edge / inner


def test_quality_mapping_inverts_the_table_and_is_monotonic():
    for q, b in QUALITY_BPP:
        assert quality_for_bpp(b) == q
    qs = [quality_for_bpp(b) for b in np.geomspace(0.05, 10, 200)]
    assert qs == sorted(qs) and qs[0] == 10 and qs[-1] == 100
    # 100 Mbit/s of 30 fps 4K: bitrate / (fps x pixels)
    assert video_bpp(100, 30, 3840, 2160) == pytest.approx(100e6 / (30 * 3840 * 2160))
    assert video_bpp(100, 30, 3840, 2160) == pytest.approx(0.402, abs=1e-3)


def test_jpeg_bits_fall_with_quality():
    img = water_like(256, 256, 2)
    sizes = [C.jpeg_roundtrip(img, q)[1] for q in (30, 60, 90, 98)]
    assert sizes == sorted(sizes) and sizes[0] < sizes[-1] / 2
    # and the error grows as the quality falls
    err = [np.abs(C.jpeg_roundtrip(img, q)[0].astype(int) - img).mean() for q in (30, 90)]
    assert err[0] > err[1]


def test_blocks_visible_at_native_scale_and_gone_far_from_it():
    img = water_like(416, 416, 3)
    assert blockiness(img) < 1.1
    native, info = C.block_compress(img, 40, 0.0, 1.0, 1.0)
    assert blockiness(native) > 1.5 and info["factor"] == (1, 1)
    assert info["bpp"] > 0
    small = water_like(96, 96, 3)
    far, info = C.block_compress(small, 40, 0.0, 13.0, 13.0)  # blocks of 8/13 px
    assert info["factor"] == (13, 13) and blockiness(far) < 1.2
    # and the pipeline at f = 13 does not run it at all
    look = sample_look("mavic2pro", np.random.default_rng(0), 416, 416, recording="photo")
    assert min(look.scale) > 8
    out, _, _, info = apply_camera(img, np.zeros((416, 416), np.uint16), look,
                                   make_noise_tile((0,), 416, 416))
    assert "compression" not in info["stages"] and blockiness(out) < 1.1


def test_deblocking_softens_block_edges_only():
    img = water_like(256, 256, 4)
    coded, _ = C.block_compress(img, 30, 0.0, 1, 1)
    smoothed = C.deblock(coded, 0.8)
    assert blockiness(smoothed) < blockiness(coded) - 0.3
    inside = np.ones(256, bool)
    inside[7::8] = inside[8::8] = False
    assert np.array_equal(smoothed[:, inside][inside], coded[:, inside][inside])
    assert C.deblock(coded, 0.0) is coded  # strength 0: untouched


def test_deblocking_is_the_121_filter_across_boundaries():
    """Each pixel next to a boundary (p0 | q0) moves by s towards (p1 + 2 p0 + q0) / 4."""
    rng = np.random.default_rng(5)
    img = rng.integers(40, 200, (16, 16, 3)).astype(np.uint8)
    s = 0.5
    out = C.deblock(img, s).astype(float)
    f = img.astype(float)
    # vertical boundary between columns 7 | 8, away from the horizontal one (rows 7, 8)
    for col, (a, b, c) in ((7, (6, 7, 8)), (8, (9, 8, 7))):
        want = f[:6, b] + s * ((f[:6, a] + 2 * f[:6, b] + f[:6, c]) / 4 - f[:6, b])
        assert np.abs(out[:6, col] - want).max() <= 1.0
    # horizontal boundary between rows 7 | 8, away from the vertical one
    want = f[7, :6] + s * ((f[6, :6] + 2 * f[7, :6] + f[8, :6]) / 4 - f[7, :6])
    assert np.abs(out[7, :6] - want).max() <= 1.0


def test_unsharp_mask_overshoots_an_edge():
    img = np.full((32, 32, 3), 60, np.uint8)
    img[:, 16:] = 180
    out = C.unsharp(img, 1.0, 1.2).astype(int)
    row = out[16, :, 1]
    assert row[:10].tolist() == [60] * 10 and row[-10:].tolist() == [180] * 10  # flat: same
    assert row.min() < 60 and row.max() > 180  # halos on both sides of the step
    assert np.array_equal(C.unsharp(img, 0.0, 1.2), img)


def test_deblocking_in_place_and_the_smoothing_rounds_half_to_even():
    """``in_place`` filters the given array with the same bytes as a copy; the boundary
    pixels' [1, 2, 1] / 4 smoothing rounds half to even, as float arithmetic does, for every
    pair of a uint16 sum p1 + q0 and a uint8 p0."""
    rng = np.random.default_rng(11)
    for h, w in ((64, 64), (37, 53), (8, 100), (101, 9)):
        img = rng.integers(0, 256, (h, w, 3), dtype=np.uint8)
        want = C.deblock(img, 0.6)
        work = img.copy()
        assert C.deblock(work, 0.6, in_place=True) is work
        assert np.array_equal(work, want) and not np.array_equal(want, img)
    # every uint16 sum p1 + q0 with every p0; s = 1 leaves p0 at the smoothing itself
    p1q0, p0 = np.meshgrid(np.arange(511), np.arange(256))
    p1 = np.minimum(p1q0, 255).astype(np.uint8)
    q0 = (p1q0 - p1).astype(np.uint8)
    moved = p0.astype(np.uint8)
    C._smooth_pairs(p1, moved, q0.copy(), np.zeros_like(p1), 1.0)
    assert np.array_equal(moved, np.round((p1q0 + 2 * p0) / 4.0))  # numpy: half to even


@pytest.mark.parametrize("nx,ny", [(1, 1), (2, 2), (3, 2)])
def test_block_compress_is_the_plain_roundtrip(nx, ny):
    """The compression's shortcuts (the encoder's channel order swapped before the
    magnification, the decoder's own RGB output, the deblocking's sums in NumPy) give the
    bytes of the plain chain: magnify, RGB -> BGR, JPEG encode and decode, BGR -> RGB,
    deblock, reduce."""
    import cv2

    img = water_like(96, 104, 7)
    got, info = C.block_compress(img, 70, 0.6, nx, ny)
    big = img if (nx, ny) == (1, 1) else cv2.resize(img, (104 * nx, 96 * ny),
                                                     interpolation=cv2.INTER_LINEAR)
    params = [cv2.IMWRITE_JPEG_QUALITY, 70, cv2.IMWRITE_JPEG_SAMPLING_FACTOR,
              cv2.IMWRITE_JPEG_SAMPLING_FACTOR_420]
    ok, data = cv2.imencode(".jpg", cv2.cvtColor(big, cv2.COLOR_RGB2BGR), params)
    want = cv2.cvtColor(cv2.imdecode(data, cv2.IMREAD_COLOR), cv2.COLOR_BGR2RGB)
    want = _deblock_reference(want, 0.6)
    if (nx, ny) != (1, 1):
        want = cv2.resize(want, (104, 96), interpolation=cv2.INTER_AREA)
    assert ok and np.array_equal(got, want)
    assert info["bpp"] == pytest.approx(8.0 * data.size / (big.shape[0] * big.shape[1]))


def _deblock_reference(img: np.ndarray, s: float) -> np.ndarray:
    """The deblocking written out per boundary in integers: p0 <- p0 + s (smooth - p0)
    rounded as OpenCV's addWeighted rounds (half to even of the float sum), the smoothing
    (p1 + 2 p0 + q0) / 4 rounded half up across columns (the [1, 2, 1] Gaussian's fixed
    point) and half to even across rows; columns first."""
    out = img.astype(np.int64)
    h, w = out.shape[:2]

    def blend(p0, smooth):
        return np.rint(np.float32(1 - s) * p0.astype(np.float32)
                       + np.float32(s) * smooth.astype(np.float32)).clip(0, 255)

    for x in range(8, (w // 8) * 8 - 1, 8):  # boundary between columns x - 1 | x
        p1, p0, q0, q1 = (out[:, x + d].copy() for d in (-2, -1, 0, 1))
        out[:, x - 1] = blend(p0, (p1 + 2 * p0 + q0 + 2) >> 2)
        out[:, x] = blend(q0, (q1 + 2 * q0 + p0 + 2) >> 2)
    for y in range(8, (h // 8) * 8, 8):
        p1, p0, q0, q1 = (out[y + d].copy() for d in (-2, -1, 0, 1))
        out[y - 1] = blend(p0, np.round((p1 + 2 * p0 + q0) / 4.0))
        out[y] = blend(q0, np.round((q1 + 2 * q0 + p0) / 4.0))
    return out.astype(np.uint8)
