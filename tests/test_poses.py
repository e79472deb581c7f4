"""Pose grid coverage and camera bases."""

from __future__ import annotations

import numpy as np
import pytest

from sdcomp.atlas.poses import PoseGrid, nearest_pose, view_basis, view_direction


def _max_error(grid: PoseGrid, samples: int = 200_000, seed: int = 0) -> float:
    poses = grid.poses()
    dirs = view_direction(poses[:, 0], poses[:, 1])
    rng = np.random.default_rng(seed)
    limit = np.radians(min(grid.max_off_nadir + grid.off_nadir_step / 2, 90))
    # uniform on the spherical cap up to `limit`
    cos_t = rng.uniform(np.cos(limit), 1.0, samples)
    phi = rng.uniform(0, 2 * np.pi, samples)
    sin_t = np.sqrt(1 - cos_t**2)
    v = np.stack([sin_t * np.cos(phi), sin_t * np.sin(phi), cos_t], axis=1)
    # plus the worst places: between rings, between azimuths
    theta = np.radians(np.arange(0, np.degrees(limit) + 1e-9, 0.25))
    p = np.radians(np.arange(0, 360, 0.25))
    tt, pp = np.meshgrid(theta, p)
    grid_v = np.stack([np.sin(tt) * np.cos(pp), np.sin(tt) * np.sin(pp), np.cos(tt)], -1)
    v = np.concatenate([v, grid_v.reshape(-1, 3)])
    best = np.full(len(v), -1.0)
    for chunk in np.array_split(np.arange(len(v)), 20):
        best[chunk] = (v[chunk] @ dirs.T).max(axis=1)
    return float(np.degrees(np.arccos(np.clip(best, -1, 1))).max())


def test_default_grid_covers_oblique_views_within_7_5_degrees():
    grid = PoseGrid()
    assert grid.max_off_nadir >= 75
    assert _max_error(grid) <= 7.5


@pytest.mark.parametrize("step,err", [(5, 4.0), (15, 10.0), (20, 12.0)])
def test_other_grids_keep_their_promise(step, err):
    grid = PoseGrid(max_off_nadir=60, off_nadir_step=step, max_error=err)
    assert _max_error(grid, samples=50_000) <= err


def test_view_basis_is_orthonormal_and_right_handed():
    for theta, phi in [(0, 0), (0, 180), (33, 71), (80, 250), (90, 90)]:
        b = view_basis(theta, phi)
        np.testing.assert_allclose(b @ b.T, np.eye(3), atol=1e-12)
        np.testing.assert_allclose(np.cross(b[0], b[1]), b[2], atol=1e-12)
        np.testing.assert_allclose(b[2], view_direction(theta, phi), atol=1e-12)


def test_nadir_from_behind_has_forward_up_and_port_left():
    right, up, toward = view_basis(0, 180)
    np.testing.assert_allclose(toward, [0, 0, 1], atol=1e-12)
    np.testing.assert_allclose(up, [1, 0, 0], atol=1e-12)
    np.testing.assert_allclose(right, [0, -1, 0], atol=1e-12)


def test_oblique_up_vector_points_away_and_upwards():
    right, up, toward = view_basis(60, 0)  # camera in front of the object, looking back
    assert up[2] > 0 and up[0] < 0 and abs(right[2]) < 1e-12


def test_nearest_pose_finds_stored_poses():
    poses = PoseGrid().poses()
    assert (poses[:, 2:] == 0).all()  # the tilt columns of the atlas format stay 0
    rng = np.random.default_rng(1)
    for i in rng.choice(len(poses), 50, replace=False):
        assert nearest_pose(poses, *poses[i, :2]) == i or (
            poses[i, 0] == 0 and poses[nearest_pose(poses, *poses[i, :2]), 0] == 0)


@pytest.mark.parametrize("kwargs", [
    dict(max_off_nadir=95), dict(off_nadir_step=0), dict(off_nadir_step=10, max_error=4),
    dict(max_error=50),
])
def test_invalid_grids_are_refused(kwargs):
    with pytest.raises(ValueError):
        PoseGrid(**kwargs)
