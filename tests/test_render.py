"""The rasteriser: exact masks, albedo, normals, heights, scale, occlusion."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from sdcomp.assets.mesh import ColoredMesh
from sdcomp.atlas.poses import view_basis
from sdcomp.atlas.raster import render

from .conftest import box_mesh

POSES = [(0, 0), (0, 37), (20, 10), (35, 200), (50, 95), (70, 300), (80, 45), (90, 0)]


@pytest.mark.parametrize("theta,phi", POSES)
def test_mask_is_alpha_positive_and_attributes_defined(theta, phi):
    mesh = box_mesh(colour=(200, 60, 40))
    s = render(mesh, theta, phi, size=64, metres_per_pixel=0.025, supersample=4)
    assert s.mask.dtype == bool and np.array_equal(s.mask, s.alpha > 0)
    assert s.mask.sum() > 100
    assert (s.alpha[s.mask] > 0).all() and (s.alpha <= 1).all()
    assert (s.albedo[s.mask] == (200, 60, 40)).all()  # one colour: every covered pixel has it
    assert (s.albedo[~s.mask] == 0).all() and (s.normal[~s.mask] == 0).all()
    np.testing.assert_allclose(np.linalg.norm(s.normal[s.mask], axis=-1), 1.0, atol=1e-5)
    assert (s.normal[s.mask][:, 2] > 0).all()  # visible surfaces face the camera


@pytest.mark.parametrize("theta,phi", POSES)
def test_extent_matches_metres_per_pixel(theta, phi):
    """A box of known size spans its projected size / metres-per-pixel, to 1 px."""
    size = np.array([1.0, 0.6, 0.3])
    mesh = box_mesh(size=tuple(size))
    mpp = 0.02
    s = render(mesh, theta, phi, size=96, metres_per_pixel=mpp, supersample=4)
    corners = np.array([[x, y, z] for x in (-.5, .5) for y in (-.5, .5) for z in (-.5, .5)]) * size
    cam = corners @ view_basis(theta, phi).T
    # projected edges in pixel coordinates (origin at the canvas centre, rows go down)
    left, right = 48 + cam[:, 0].min() / mpp, 48 + cam[:, 0].max() / mpp
    top, bottom = 48 - cam[:, 1].max() / mpp, 48 - cam[:, 1].min() / mpp
    cols = np.nonzero(s.mask.any(axis=0))[0]
    rows = np.nonzero(s.mask.any(axis=1))[0]
    assert abs(cols.min() - left) <= 1.0 and abs(cols.max() + 1 - right) <= 1.0
    assert abs(rows.min() - top) <= 1.0 and abs(rows.max() + 1 - bottom) <= 1.0
    # and with sub-pixel coverage, the width of the widest row is right to a pixel
    assert abs(s.alpha.sum(axis=1).max() - _widest_row(cam, mpp)) <= 1.0


def _widest_row(cam: np.ndarray, mpp: float) -> float:
    """Widest horizontal chord of the convex hull of the projected corners, pixels."""
    import cv2

    hull = cv2.convexHull((cam[:, :2] / mpp).astype(np.float32))[:, 0]
    ys = np.linspace(hull[:, 1].min() + 0.5, hull[:, 1].max() - 0.5, 200)
    poly = np.concatenate([hull, hull[:1]])
    best = 0.0
    for y in ys:
        xs = []
        for (x0, y0), (x1, y1) in zip(poly[:-1], poly[1:], strict=True):
            if (y0 - y) * (y1 - y) <= 0 and y0 != y1:
                xs.append(x0 + (y - y0) * (x1 - x0) / (y1 - y0))
        if len(xs) >= 2:
            best = max(best, max(xs) - min(xs))
    return best


def test_coverage_is_antialiased_and_sums_to_area():
    mesh = box_mesh(size=(1.0, 0.6, 0.3))
    mpp = 0.0137  # edges fall inside pixels
    s = render(mesh, 0, 23, size=128, metres_per_pixel=mpp, supersample=8)
    partial = (s.alpha > 0) & (s.alpha < 1)
    assert partial.sum() > 20
    assert (s.alpha == 1).sum() > 1000
    area = s.alpha.sum() * mpp**2
    assert area == pytest.approx(0.6, rel=0.01)


def test_heights_relative_to_waterline():
    mesh = box_mesh(size=(1.0, 0.6, 0.3), waterline=0.05)
    top = render(mesh, 0, 0, size=64, metres_per_pixel=0.025, supersample=2)
    np.testing.assert_allclose(top.height[top.alpha == 1], 0.15 - 0.05, atol=1e-4)
    assert np.abs(top.normal[top.alpha == 1] - [0, 0, 1]).max() < 1e-5
    side = render(mesh, 90, 0, size=64, metres_per_pixel=0.025, supersample=2)
    h = side.height[side.alpha == 1]
    assert h.min() == pytest.approx(-0.2, abs=0.02) and h.max() == pytest.approx(0.1, abs=0.02)
    # rows go down the image, heights go down with them
    col = side.height[:, 32][side.alpha[:, 32] == 1]
    assert (np.diff(col) < 0).all()


def test_wave_tilt_changes_heights_about_the_waterline():
    mesh = box_mesh(size=(1.0, 0.6, 0.3), waterline=0.0)
    flat = render(mesh, 0, 0, size=64, metres_per_pixel=0.025, supersample=2)
    rolled = render(mesh, 0, 0, size=64, metres_per_pixel=0.025, supersample=2, roll=10)
    assert np.ptp(flat.height[flat.alpha == 1]) < 1e-4
    # the top face (normal cos 10 deg towards the camera) tilts across its 0.6 m width,
    # about the waterline at the body axis: its mean height drops by 0.15 (1 - cos 10)
    top_face = (rolled.alpha == 1) & (rolled.normal[..., 2] > 0.95)
    h = rolled.height[top_face]
    assert np.ptp(h) == pytest.approx(0.6 * np.sin(np.radians(10)), rel=0.1)
    assert h.mean() == pytest.approx(0.15 * np.cos(np.radians(10)), abs=0.01)


def test_zbuffer_occlusion_nearest_wins():
    low = trimesh.creation.box(extents=(1.0, 1.0, 0.1))
    high = trimesh.creation.box(extents=(0.4, 0.4, 0.1))
    high.apply_translation((0.2, 0.0, 0.5))
    verts = np.concatenate([low.vertices, high.vertices])
    faces = np.concatenate([low.faces, high.faces + len(low.vertices)])
    cols = np.concatenate([np.tile([10, 200, 10], (len(low.faces), 1)),
                           np.tile([220, 20, 20], (len(high.faces), 1))]).astype(np.uint8)
    # draw order must not matter: try both face orders
    for order in (slice(None), slice(None, None, -1)):
        mesh = ColoredMesh(verts, faces[order], cols[order], 0.0, "two", closed=True)
        top = render(mesh, 0, 180, size=64, metres_per_pixel=0.025, supersample=2)
        red = (top.albedo == (220, 20, 20)).all(-1)
        green = (top.albedo == (10, 200, 10)).all(-1)
        assert red.sum() == pytest.approx((0.4 / 0.025) ** 2, rel=0.15)
        assert green.sum() > red.sum()
        # the high box is nearer the camera: it hides the low one where they overlap
        assert (top.height[red] > 0.4).all()


def test_open_mesh_is_two_sided():
    quad = ColoredMesh(np.array([[-.5, -.5, 0], [.5, -.5, 0], [.5, .5, 0], [-.5, .5, 0.]]),
                       np.array([[0, 1, 2], [0, 2, 3]]), np.full((2, 3), 90, np.uint8),
                       0.0, "quad", closed=False)
    above = render(quad, 0, 0, size=32, metres_per_pixel=0.05, supersample=2)
    below = render(quad, 0, 0, size=32, metres_per_pixel=0.05, supersample=2, roll=180)
    assert above.mask.sum() == below.mask.sum() > 0
    assert (below.normal[below.mask][:, 2] > 0).all()


def test_closed_mesh_back_faces_culled_does_not_change_result():
    closed = box_mesh()
    opened = ColoredMesh(closed.vertices, closed.faces, closed.face_colors, 0.0, "box")
    a = render(closed, 40, 30, size=48, metres_per_pixel=0.03, supersample=2)
    b = render(opened, 40, 30, size=48, metres_per_pixel=0.03, supersample=2)
    np.testing.assert_array_equal(a.mask, b.mask)
    np.testing.assert_allclose(a.normal, b.normal, atol=1e-6)


def test_bad_arguments():
    with pytest.raises(ValueError):
        render(box_mesh(), 0, 0, size=0, metres_per_pixel=0.01)
    with pytest.raises(ValueError):
        render(box_mesh(), 0, 0, size=8, metres_per_pixel=0.0)
