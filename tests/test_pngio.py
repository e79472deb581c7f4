"""The 16-bit grayscale PNG encoder: round trips through OpenCV, format details, bad input."""

from __future__ import annotations

import struct
import zlib

import cv2
import numpy as np
import pytest

from sdcomp.io import png as pngio
from sdcomp.io.png import decode_png16, encode_png16


def cv2_read(data: bytes) -> np.ndarray:
    img = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_UNCHANGED)
    assert img is not None
    return img


def chunks(data: bytes) -> list[tuple[bytes, bytes]]:
    """Split PNG bytes into (type, data) chunks, checking signature, lengths and CRCs."""
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    out, pos = [], 8
    while pos < len(data):
        (n,) = struct.unpack(">I", data[pos:pos + 4])
        kind, body = data[pos + 4:pos + 8], data[pos + 8:pos + 8 + n]
        (crc,) = struct.unpack(">I", data[pos + 8 + n:pos + 12 + n])
        assert crc == zlib.crc32(kind + body)
        out.append((kind, body))
        pos += 12 + n
    assert pos == len(data)
    return out


def id_mask(h: int, w: int, rng: np.random.Generator, k: int = 5) -> np.ndarray:
    """Mostly zero with a few rectangles of ids, like a generator's instance mask."""
    m = np.zeros((h, w), np.uint16)
    for i in range(k):
        y, x = rng.integers(0, h), rng.integers(0, w)
        m[y:y + rng.integers(1, h + 1), x:x + rng.integers(1, w + 1)] = i + 1
    return m


@pytest.mark.parametrize("shape", [(1, 1), (1, 7), (9, 1), (1, 300), (300, 1), (3, 5),
                                   (17, 31), (416, 416), (233, 611)])
def test_round_trip_random(shape):
    rng = np.random.default_rng(sum(shape))
    for mask in (rng.integers(0, 65536, shape, dtype=np.uint16),
                 id_mask(*shape, rng)):
        data = encode_png16(mask)
        img = cv2_read(data)
        assert img.dtype == np.uint16 and img.shape == shape
        np.testing.assert_array_equal(img, mask)
        np.testing.assert_array_equal(decode_png16(data), mask)


def test_extreme_values_and_all_zero():
    mask = np.array([[0, 1, 255, 256], [65535, 65534, 32768, 4660]], np.uint16)
    np.testing.assert_array_equal(decode_png16(encode_png16(mask)), mask)
    zero = np.zeros((416, 416), np.uint16)
    data = encode_png16(zero)
    np.testing.assert_array_equal(cv2_read(data), zero)
    assert len(data) < 2000  # 346 kB of scanlines compress to almost nothing


@pytest.mark.parametrize("level", [0, 1, 6, 9])
def test_levels(level):
    mask = id_mask(64, 80, np.random.default_rng(level))
    np.testing.assert_array_equal(decode_png16(encode_png16(mask, level=level)), mask)


def test_deterministic():
    rng = np.random.default_rng(3)
    mask = id_mask(200, 300, rng)
    a = encode_png16(mask)
    encode_png16(rng.integers(0, 65536, (50, 999), dtype=np.uint16))  # other sizes between
    assert encode_png16(mask.copy()) == a


def test_format_header_and_chunks():
    mask = id_mask(37, 53, np.random.default_rng(1))
    parts = chunks(encode_png16(mask))
    kinds = [k for k, _ in parts]
    assert kinds[0] == b"IHDR" and kinds[-1] == b"IEND" and set(kinds[1:-1]) == {b"IDAT"}
    assert struct.unpack(">IIBBBBB", parts[0][1]) == (53, 37, 16, 0, 0, 0, 0)
    raw = zlib.decompress(b"".join(body for k, body in parts if k == b"IDAT"))
    rows = np.frombuffer(raw, np.uint8).reshape(37, 1 + 2 * 53)
    assert (rows[:, 0] == 0).all()  # filter None
    np.testing.assert_array_equal(rows[:, 1:].copy().view(">u2"), mask)


def test_bands_and_several_idat(monkeypatch):
    """Several scanline bands and IDAT chunks (small limits) still give the same image."""
    mask = np.random.default_rng(2).integers(0, 65536, (123, 45), dtype=np.uint16)
    monkeypatch.setattr(pngio, "BAND_BYTES", 1000)
    monkeypatch.setattr(pngio, "IDAT_MAX", 777)
    data = encode_png16(mask)
    assert sum(k == b"IDAT" for k, _ in chunks(data)) > 1
    np.testing.assert_array_equal(cv2_read(data), mask)
    np.testing.assert_array_equal(decode_png16(data), mask)


def test_non_contiguous_input_and_buffer_reuse():
    rng = np.random.default_rng(4)
    big = rng.integers(0, 65536, (100, 200), dtype=np.uint16)
    for mask in (big[::3, ::2], np.asfortranarray(big), big[5:40, 7:8], big.T, big):
        np.testing.assert_array_equal(decode_png16(encode_png16(mask)), mask)


@pytest.mark.parametrize("bad", [
    np.zeros((4,), np.uint16),
    np.zeros((2, 3, 1), np.uint16),
    np.zeros((0, 5), np.uint16),
    np.zeros((5, 0), np.uint16),
    np.zeros((4, 4), np.uint8),
    np.zeros((4, 4), np.int32),
    np.zeros((4, 4), np.float32),
])
def test_bad_input(bad):
    with pytest.raises(ValueError):
        encode_png16(bad)


def test_bad_level():
    with pytest.raises(ValueError):
        encode_png16(np.zeros((2, 2), np.uint16), level=10)


def test_decode_rejects_other_pngs():
    with pytest.raises(ValueError):
        decode_png16(b"not a png")
    with pytest.raises(ValueError):
        decode_png16(b"")
    ok, rgb8 = cv2.imencode(".png", np.zeros((4, 4, 3), np.uint8))
    assert ok
    with pytest.raises(ValueError):
        decode_png16(rgb8.tobytes())
    ok, gray8 = cv2.imencode(".png", np.zeros((4, 4), np.uint8))
    with pytest.raises(ValueError):
        decode_png16(gray8.tobytes())


@pytest.mark.parametrize("band_bytes", [1, 300, 1 << 20])
def test_zero_row_runs_of_every_length(monkeypatch, band_bytes):
    """Runs of zero rows (cached deflate pieces, Adler-32 updated arithmetically) between
    rows with ids, at the top, at the bottom and alone: zlib's own checksum test and
    OpenCV's decoder both accept the stream, and the rows come back."""
    monkeypatch.setattr(pngio, "BAND_BYTES", band_bytes)
    rng = np.random.default_rng(band_bytes)
    mask = np.zeros((320, 37), np.uint16)
    y = 1
    for run in range(1, 24):  # id rows separated by zero runs of 1, 2, ... 23 rows
        mask[y, rng.integers(0, 37)] = run
        y += run + 1
    assert y < 320 and not mask[y:].any() and not mask[0].any()
    parts = chunks(encode_png16(mask))
    raw = zlib.decompress(b"".join(body for k, body in parts if k == b"IDAT"))  # checks Adler-32
    rows = np.frombuffer(raw, np.uint8).reshape(320, 1 + 2 * 37)
    np.testing.assert_array_equal(rows[:, 1:].copy().view(">u2"), mask)
    np.testing.assert_array_equal(cv2_read(encode_png16(mask)), mask)
    for m in (mask[:1] * 0, mask[1:2], np.zeros((1000, 3), np.uint16)):
        np.testing.assert_array_equal(cv2_read(encode_png16(m)), m)
