"""Pinhole camera: intrinsics of the presets, GSD, projection and rays."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sdcomp.errors import UserError
from sdcomp.scene.camera import (
    PRESETS,
    CameraModel,
    CameraPose,
    camera_basis,
    ground_points,
    pixel_rays,
    project,
)


@pytest.mark.parametrize("name", list(PRESETS))
def test_preset_diagonal_fov_and_gsd_match_the_pinhole_formula(name):
    sw, sh, fov = PRESETS[name]
    cam = CameraModel.preset(name, width=sw, height=sh)
    # the diagonal of the sensor seen under the preset's diagonal field of view
    half_diag = math.hypot(sw, sh) / 2
    assert 2 * math.degrees(math.atan(half_diag / cam.fx)) == pytest.approx(fov, abs=1e-9)
    for altitude in (10.0, 30.0, 50.0):
        # ground footprint width at nadir: 2 h tan(hfov / 2), over the pixel count
        footprint = 2 * altitude * math.tan(math.radians(cam.horizontal_fov) / 2)
        gx, gy = cam.nadir_gsd(altitude)
        assert gx == pytest.approx(footprint / sw, rel=1e-12)
        assert gy == pytest.approx(gx, rel=1e-12)  # square sensor pixels


@pytest.mark.parametrize("photo", ["mavic2pro", "phantom4pro", "zenmuse-x5"])
def test_video_presets_are_16_9_with_the_photo_horizontal_fov(photo):
    """``NAME-video`` is DJI's 4K video of the camera: 3840 x 2160 made from the full sensor
    width, so the photo's horizontal field of view and a narrower diagonal one; its look is
    the camera's."""
    from sdcomp.scene.config import GeneratorConfig

    still = CameraModel.preset(photo, *PRESETS[photo][:2])
    video = CameraModel.preset(f"{photo}-video", 1920, 1080)
    assert PRESETS[f"{photo}-video"][:2] == (3840, 2160)
    assert video.width / video.height == 16 / 9
    assert video.horizontal_fov == pytest.approx(still.horizontal_fov, abs=0.01)
    assert video.diagonal_fov < still.diagonal_fov
    assert video.fx == pytest.approx(video.fy, rel=1e-12)  # square pixels at 16:9 output
    config = GeneratorConfig(camera=f"{photo}-video", width=640, height=360)
    assert config.look_preset == photo


def test_mavic_object_size_at_10_m_matches_a_real_photo():
    """A 0.46 m BlueROV2 at 10 m under a Mavic 2 Pro spans 0.46 / GSD pixels (within 2 %)."""
    cam = CameraModel.preset("mavic2pro", width=5472, height=3648)
    pose = CameraPose(altitude=10.0, pitch=90.0)
    uv, depth = project(cam, pose, np.array([[-0.23, 0, 0], [0.23, 0, 0]]))
    # 77 deg diagonal -> 65.5 deg horizontal: 12.87 m footprint over 5472 px = 2.35 mm/px
    expected = 0.46 / (2 * 10 * math.tan(math.radians(cam.horizontal_fov) / 2) / 5472)
    assert np.linalg.norm(uv[1] - uv[0]) == pytest.approx(expected, rel=0.02)
    assert (depth == pytest.approx(10.0))


def test_resized_output_scales_focal_lengths_per_axis():
    full = CameraModel.preset("phantom4pro", width=5472, height=3648)
    small = CameraModel.preset("phantom4pro", width=416, height=416)
    assert small.fx == pytest.approx(full.fx * 416 / 5472)
    assert small.fy == pytest.approx(full.fy * 416 / 3648)
    gx, gy = small.nadir_gsd(20)
    # the 3:2 frame squeezed to 1:1: the shorter vertical footprint spreads over as many rows
    assert gx == pytest.approx(20 / small.fx) and gy == pytest.approx(gx * 3648 / 5472)


def test_from_sensor_mm_matches_the_fov_formula():
    cam = CameraModel.from_sensor_mm(13.2, 8.8, 10.26, 5472, 3648)
    assert cam.diagonal_fov == pytest.approx(
        2 * math.degrees(math.atan(math.hypot(13.2, 8.8) / (2 * 10.26))))
    assert cam.sensor_focal_px == pytest.approx(10.26 / 13.2 * 5472, rel=1e-9)


def test_camera_basis_nadir_and_heading():
    right, down, forward = camera_basis(90, 0)
    np.testing.assert_allclose(forward, [0, 0, -1], atol=1e-12)
    np.testing.assert_allclose(-down, [1, 0, 0], atol=1e-12)  # image up = heading
    np.testing.assert_allclose(np.cross(right, down), forward, atol=1e-12)
    right, down, forward = camera_basis(30, 90)
    assert forward[1] > 0 and forward[2] == pytest.approx(-0.5)


def test_projection_and_rays_are_inverse():
    cam = CameraModel.preset("mavic2pro", width=640, height=480)
    pose = CameraPose(altitude=25.0, pitch=20.0, heading=33.0)
    rng = np.random.default_rng(0)
    u, v = rng.uniform(0, 640, 500), rng.uniform(0, 480, 500)
    pts, hit = ground_points(cam, pose, u, v)
    # vertical field of view 47.6 degrees: at pitch 20 the horizon is in the frame
    assert hit.any() and not hit.all()
    uv, depth = project(cam, pose, pts[hit])
    np.testing.assert_allclose(uv, np.stack([u[hit], v[hit]], 1), atol=1e-6)
    assert (depth > 0).all() and np.allclose(pts[hit][:, 2], 0.0)
    rays = pixel_rays(cam, pose, u, v)
    np.testing.assert_allclose(np.linalg.norm(rays, axis=-1), 1.0)
    assert np.isnan(pts[~hit]).all()


def test_image_centre_at_nadir_is_below_the_camera():
    cam = CameraModel()
    pose = CameraPose(altitude=12.0)
    pts, hit = ground_points(cam, pose, np.array(208.0), np.array(208.0))
    assert hit and np.allclose(pts, [0, 0, 0], atol=1e-9)


@pytest.mark.parametrize("kwargs", [dict(altitude=0), dict(altitude=-5), dict(pitch=1),
                                    dict(pitch=91), dict(heading=float("nan"))])
def test_bad_pose_is_a_user_error(kwargs):
    with pytest.raises(UserError):
        CameraPose(**kwargs)


@pytest.mark.parametrize("kwargs", [dict(width=0), dict(height=-1), dict(diagonal_fov=0),
                                    dict(diagonal_fov=180)])
def test_bad_model_is_a_user_error(kwargs):
    with pytest.raises(UserError):
        CameraModel(**kwargs)
    with pytest.raises(UserError, match="mavic2pro"):
        CameraModel.preset("gopro")
