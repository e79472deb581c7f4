"""The drone camera's lens (sdcomp.render.camera.lens): the Brown-Conrady model and its
inverse, the remap maps, lateral chromatic aberration, the labels, vignetting."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from sdcomp.render.camera import lens as L
from sdcomp.render.camera import remap as R
from sdcomp.util.colour import srgb_to_linear

from .conftest import squares

LENSES = [(-0.03, 0.0), (-0.06, 0.01), (-0.02, 0.01), (0.02, 0.0)]


@pytest.mark.parametrize("k1,k2", LENSES)
def test_distort_matches_opencv(k1, k2):
    rng = np.random.default_rng(0)
    xy = rng.uniform(-0.9, 0.9, (200, 2))
    ours = L.distort(xy, k1, k2)
    pts = np.concatenate([xy, np.ones((200, 1))], axis=1)
    cv, _ = cv2.projectPoints(pts, np.zeros(3), np.zeros(3), np.eye(3),
                              np.array([k1, k2, 0, 0, 0.0]))
    assert np.abs(ours - cv.reshape(-1, 2)).max() < 1e-9


@pytest.mark.parametrize("k1,k2", LENSES)
@pytest.mark.parametrize("w,h,fov", [(416, 416, 77.0), (3840, 2160, 84.0)])
def test_round_trip_within_0_05_px(k1, k2, w, h, fov):
    """distort then undistort every border and interior point of the frame: < 0.05 px."""
    f = np.hypot(w, h) / 2 / np.tan(np.radians(fov) / 2)
    u, v = np.meshgrid(np.linspace(0, w - 1, 41), np.linspace(0, h - 1, 41))
    xy = np.stack([(u - (w - 1) / 2) / f, (v - (h - 1) / 2) / f], -1)
    back = L.undistort(L.distort(xy, k1, k2), k1, k2)
    assert np.abs(back - xy).max() * f < 0.05
    again = L.distort(L.undistort(xy, k1, k2), k1, k2)
    assert np.abs(again - xy).max() * f < 0.05
    # the centre stays put and points move radially
    assert np.array_equal(L.undistort(np.zeros(2), k1, k2), np.zeros(2))
    d = L.distort(xy, k1, k2)
    cross = xy[..., 0] * d[..., 1] - xy[..., 1] * d[..., 0]
    assert np.abs(cross).max() < 1e-12


@pytest.mark.parametrize("k1,k2", LENSES)
def test_maps_stay_inside_and_are_tight(k1, k2):
    w, h, f = 640, 480, 520.0
    lens = L.lens_maps(w, h, f, f, k1, k2, full=True)
    mx, my = cv2.convertMaps(*lens.maps[0], cv2.CV_32FC1)
    assert mx.min() >= 0 and my.min() >= 0 and mx.max() <= w - 1 and my.max() <= h - 1
    border = np.concatenate([mx[0], mx[-1], mx[:, 0], mx[:, -1]])
    border_y = np.concatenate([my[0], my[-1], my[:, 0], my[:, -1]])
    slack = min(border.min(), w - 1 - border.max(), border_y.min(), h - 1 - border_y.max())
    assert slack < 0.1  # alpha = 0: the frame's edge is reached (no wasted margin)
    assert (lens.zoom > 1) == (k1 < 0)  # barrel distortion: zoom in; pincushion: out


def test_a_lens_asked_for_again_gets_cached_full_maps():
    """A new lens streams (its grid only: most images draw a new one); asked for again it
    gets full-frame maps, kept and handed out from then on; frames over STREAM_PIXELS
    always stream."""
    L.clear_caches()
    first = L.lens_maps(320, 240, 250.0, 250.0, -0.04, 0.0)
    assert first.streamed and first.maps is None
    second = L.lens_maps(320, 240, 250.0, 250.0, -0.04, 0.0)
    assert not second.streamed and second.grid is first.grid
    assert second.nbytes == first.nbytes + 320 * 240 * (6 + 8)  # the policy's full_bytes
    assert L.lens_maps(320, 240, 250.0, 250.0, -0.04, 0.0) is second
    assert L.lens_maps(320, 240, 250.0, 250.0, -0.05, 0.0).streamed
    assert not L.lens_maps(320, 240, 250.0, 250.0, -0.06, 0.0, full=True).streamed
    w, h = 2600, 1700  # 4.4 MP
    assert w * h > L.STREAM_PIXELS
    assert L.lens_maps(w, h, 2000.0, 2000.0, -0.04, 0.0).streamed
    assert L.lens_maps(w, h, 2000.0, 2000.0, -0.04, 0.0).streamed
    L.clear_caches()


@pytest.mark.parametrize("w,h", [(416, 416), (1280, 720)])
def test_remap_puts_points_where_the_model_says(w, h):
    """A dot drawn at a rendered point lands at LensMaps.forward of it (the effective K with
    OpenCV's distortion model): centroid within 0.1 px."""
    f, k1, k2 = 0.8 * w, -0.05, 0.01
    lens = L.lens_maps(w, h, f, f, k1, k2)
    rng = np.random.default_rng(2)
    yy, xx = np.mgrid[0:h, 0:w]
    for _ in range(8):
        src = rng.uniform([0.1 * w, 0.1 * h], [0.9 * w, 0.9 * h])
        img = np.zeros((h, w, 3), np.uint8)
        blob = np.exp(-((xx - src[0]) ** 2 + (yy - src[1]) ** 2) / (2 * 2.0**2))
        img[..., 1] = np.rint(250 * blob)
        out = R.remap_image(img, lens)[..., 1].astype(float)
        cy, cx = (out * yy).sum() / out.sum(), (out * xx).sum() / out.sum()
        want = lens.forward(src)
        assert np.hypot(cx - want[0], cy - want[1]) < 0.1
        # the same through OpenCV's projection with the effective K and dist
        K = np.array([[f * lens.zoom, 0, (w - 1) / 2], [0, f * lens.zoom, (h - 1) / 2],
                      [0, 0, 1]])
        ray = np.array([[(src[0] - (w - 1) / 2) / f, (src[1] - (h - 1) / 2) / f, 1.0]])
        p, _ = cv2.projectPoints(ray, np.zeros(3), np.zeros(3), K, np.array([k1, k2, 0, 0, 0]))
        assert np.abs(p.reshape(2) - want).max() < 1e-6


def test_lateral_ca_scales_red_and_blue():
    w = h = 600
    f, ca_r, ca_b = 500.0, 2e-3, -2e-3
    lens = L.lens_maps(w, h, f, f, -0.02, 0.0, ca_r, ca_b, full=True)
    assert len(lens.maps) == 3
    src = np.array([520.0, 480.0])
    img = np.zeros((h, w, 3), np.uint8)
    yy, xx = np.mgrid[0:h, 0:w]
    img[:] = np.rint(250 * np.exp(-((xx - src[0]) ** 2 + (yy - src[1]) ** 2) / 8.0))[..., None]
    out = R.remap_image(img, lens).astype(float)
    g = lens.forward(src)
    c = np.array([(w - 1) / 2, (h - 1) / 2])
    for ch, ca in ((0, ca_r), (2, ca_b), (1, 0.0)):
        o = out[..., ch]
        got = np.array([(o * xx).sum() / o.sum(), (o * yy).sum() / o.sum()])
        want = c + (g - c) * (1 + ca)
        assert np.abs(got - want).max() < 0.1


def test_instance_map_follows_with_area_zoom_squared():
    w = h = 416
    f, k1, k2 = 0.75 * w, -0.06, 0.01
    boxes = [(150, 150, 24), (220, 190, 30), (180, 240, 16), (240, 150, 20)]
    ins = squares(h, w, boxes)
    lens = L.lens_maps(w, h, f, f, k1, k2)
    out = R.remap_labels(ins, lens)
    assert out.dtype == np.uint16
    assert set(np.unique(out)) == set(np.unique(ins))
    for k, (_, _, s) in enumerate(boxes):
        area = int((out == k + 1).sum())
        assert abs(area / (lens.zoom**2 * s * s) - 1) < 0.05


def test_windowed_label_remap_is_exact():
    rng = np.random.default_rng(0)
    for (w, h), (k1, k2) in zip([(416, 416), (1280, 720), (500, 300)],
                                [(-0.05, 0.01), (-0.06, 0.0), (0.03, 0.0)], strict=True):
        lens = L.lens_maps(w, h, 0.8 * w, 0.8 * w, k1, k2, 4e-4, -4e-4)
        for _ in range(40):
            boxes = [(int(rng.integers(0, w - 30)), int(rng.integers(0, h - 30)),
                      int(rng.integers(1, 30))) for _ in range(int(rng.integers(0, 12)))]
            ins = squares(h, w, boxes)
            assert np.array_equal(R.remap_labels(ins, lens, window=True),
                                  R.remap_labels(ins, lens, window=False))


def test_amodal_bit_planes_match_one_by_one():
    w = h = 300
    lens = L.lens_maps(w, h, 240.0, 240.0, -0.05, 0.0)
    rng = np.random.default_rng(1)
    masks = rng.random((37, h, w)) < 0.02
    masks = np.stack([cv2.dilate(m.astype(np.uint8), np.ones((5, 5))) > 0 for m in masks])
    got = R.remap_masks(masks, lens)
    for k in range(len(masks)):
        want = R.remap_labels(masks[k].astype(np.uint8), lens, window=False) > 0
        assert np.array_equal(got[k], want)


def test_vignetting_is_one_at_centre_and_cos4_at_the_edge():
    lens = L.lens_maps(401, 401, 300.0, 300.0, 0.0, 0.0, full=True)
    g = L.vignette_gain(lens.field_r2, 1.0)
    assert abs(g[200, 200] - 1) < 1e-6
    t2 = (200 / 300) ** 2
    assert abs(g[200, 400] - 1 / (1 + t2) ** 2) < 1e-4
    # strength s: 1 - s (1 - cos^4)
    assert abs(L.vignette_gain(lens.field_r2, 0.3)[200, 400] - (1 - 0.3 * (1 - g[200, 400]))
               ) < 1e-6
    img = np.full((401, 401, 3), 200, np.uint8)
    out = R.vignette(img, lens, 0.5)
    lin = srgb_to_linear(out[0, 0, 1] / 255) / srgb_to_linear(200 / 255)
    want = L.vignette_gain(lens.field_r2[:1, :1], 0.5)[0, 0]
    assert abs(lin - want) < 0.02  # the 2.2-power approximation of sRGB


@pytest.mark.parametrize("k1,k2", [(-0.06, 0.01), (0.02, 0.0)])
def test_grid_interpolated_maps_match_the_model(k1, k2):
    """Frames over 640 px get their maps from an 8 px grid: within the 1/32 px fixed-point
    resolution of OpenCV's maps (<= 0.023 px) of the exact model everywhere, borders too."""
    w, h, f = 1920, 1080, 1450.0
    lens = L.lens_maps(w, h, f, f, k1, k2, full=True)
    mx, my = cv2.convertMaps(*lens.maps[0], cv2.CV_32FC1)
    ys, xs = np.mgrid[0:h:7, 0:w:7]
    xs = np.concatenate([xs.ravel(), np.arange(w), np.full(h, w - 1)])
    ys = np.concatenate([ys.ravel(), np.full(w, h - 1), np.arange(h)])
    ex, ey = L._source(xs.astype(float), ys.astype(float), w, h, f, f, k1, k2, lens.zoom, 0.0)
    err = np.hypot(mx[ys, xs] - np.clip(ex, 0, w - 1), my[ys, xs] - np.clip(ey, 0, h - 1))
    assert err.max() < 0.025


@pytest.mark.parametrize("ca", [(0.0, 0.0), (4e-4, -4e-4)])
def test_streamed_lens_gives_the_cached_maps_pixels(ca):
    """A streamed lens builds its maps band by band from the lens grid: the image, labels
    (windowed and whole) and vignetting come out byte for byte as with full maps, and the
    streamed lens keeps no full-frame array."""
    w, h = 1000, 700
    rng = np.random.default_rng(3)
    img = rng.integers(0, 256, (h, w, 3), dtype=np.uint8)
    lab = np.zeros((h, w), np.uint16)
    lab[h // 3:h // 2, w // 5:w // 2] = 3
    lab[5:60, 900:990] = 7
    got = {}
    for name in ("full", "streamed"):
        L.clear_caches()
        lens = L.lens_maps(w, h, 0.8 * w, 0.8 * w, -0.04, 0.01, *ca, full=name == "full")
        assert lens.streamed == (name == "streamed")
        got[name] = (R.remap_image(img, lens), R.remap_labels(lab, lens),
                     R.remap_labels(lab, lens, window=False), R.vignette(img, lens, 0.4))
    L.clear_caches()
    assert lens.maps is None and lens.nearest is None and lens.field_r2 is None
    assert lens.nbytes < w * h  # the grid only
    for a, b in zip(got["full"], got["streamed"], strict=True):
        assert np.array_equal(a, b)
    assert not np.array_equal(got["full"][0], img)  # the lens did move the pixels


def test_full_maps_rebuilt_from_the_cached_grid_are_the_same():
    """A lens whose full maps fell out of their cache is rebuilt from its cached grid (the
    zoom's bisection is not redone) with the same bytes as a lens built from nothing."""
    args = (1000, 700, 800.0, 800.0, -0.03, 0.01, 0.0004, -0.0002)
    L.clear_caches()
    cold = L.lens_maps(*args, full=True)
    L._MAP_CACHE.clear()
    warm = L.lens_maps(*args, full=True)
    assert warm is not cold and warm.grid is cold.grid
    for a, b in zip(cold.maps, warm.maps, strict=True):
        assert all(np.array_equal(x, y) for x, y in zip(a, b, strict=True))
    assert np.array_equal(cold.nearest, warm.nearest)
    assert np.array_equal(cold.field_r2, warm.field_r2)
    L.clear_caches()
    assert L.lens_maps(*args).grid is not cold.grid


@pytest.mark.parametrize("w,h", [(416, 416), (1000, 700)])
def test_unclipped_source_points_remap_as_clipped_ones(w, h):
    """The lens's source points are not clipped to the frame: with the remaps' replicated
    border a point past an edge samples what its clipped twin does (image and labels)."""
    rng = np.random.default_rng(8)
    img = rng.integers(0, 256, (h, w, 3), dtype=np.uint8)
    lab = rng.integers(0, 6, (h, w), dtype=np.uint16)
    L.clear_caches()
    lens = L.lens_maps(w, h, 0.6 * w, 0.6 * w, -0.08, 0.02, 0.0006, -0.0004)
    planes, outside = [], 0
    for c, plane in enumerate(cv2.split(img)):
        x, y = lens.grid.points(c, 0, 0, w, h)
        outside += int(np.sum((x < 0) | (x > w - 1) | (y < 0) | (y > h - 1)))
        cx, cy = np.clip(x, 0, w - 1), np.clip(y, 0, h - 1)
        planes.append(cv2.remap(plane, *cv2.convertMaps(cx, cy, cv2.CV_16SC2),
                                cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE))
        if c == 1:
            near = cv2.convertMaps(cx, cy, cv2.CV_16SC2, nninterpolation=True)[0]
    assert outside > 0  # some points do lie past an edge (by thousandths of a pixel)
    assert np.array_equal(R.remap_image(img, lens), cv2.merge(planes))
    assert np.array_equal(R.remap_labels(lab, lens, window=False),
                          cv2.remap(lab, near, None, cv2.INTER_NEAREST))
    L.clear_caches()


def test_a_lens_rebuilt_after_its_grid_left_the_cache_keeps_its_zoom_without_a_bisection():
    """Lenses whose grids dropped out of their cache come back over a long run: the zoom
    (the bisection's 15-20 ms) is remembered apart, and the rebuilt lens is the same."""
    args = (1920, 1080, 1450.0, 1224.0, -0.02, 0.01, 0.0004, 0.0)
    L.clear_caches()
    first = L.lens_maps(*args)
    misses = L.lens_zoom.cache_info().misses
    L._GRID_CACHE.clear()
    again = L.lens_maps(*args)
    assert again.grid is not first.grid and again.zoom == first.zoom
    assert L.lens_zoom.cache_info().misses == misses  # no new bisection
    for a, b in zip(first.grid.src, again.grid.src, strict=True):
        assert all(np.array_equal(x, y) for x, y in zip(a, b, strict=True))
    L.clear_caches()
    assert L.lens_zoom.cache_info().currsize == 0


def test_a_lens_that_comes_back_after_the_cache_would_have_dropped_it_streams(monkeypatch):
    """Full maps are made only for a lens asked for again among the last N lenses, N the
    number of such maps the cache holds (here 3): one that comes back later streams again
    (maps made for it would have left the cache before it came back)."""
    w, h = 320, 240
    L.clear_caches()
    one = L.lens_maps(w, h, 250.0, 250.0, -0.09, 0.0, full=True).nbytes  # its grid and maps
    monkeypatch.setattr(L, "MAP_CACHE_BYTES", 3 * one)
    L.clear_caches()

    def lens(k1):
        return L.lens_maps(w, h, 250.0, 250.0, k1, 0.0)

    assert lens(-0.01).streamed
    for k1 in (-0.02, -0.03):
        assert lens(k1).streamed
    assert not lens(-0.01).streamed  # third back: within the last 3
    for k1 in (-0.04, -0.05, -0.06, -0.07):
        assert lens(k1).streamed
    assert lens(-0.02).streamed  # five other lenses since: gone
    L.clear_caches()
