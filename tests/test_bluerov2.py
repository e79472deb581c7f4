"""The procedural BlueROV2 against the vendor CAD (skipped without ../shared/reference)."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
import trimesh

from sdcomp.assets import bluerov2
from sdcomp.atlas.raster import render

FOAM = np.array(bluerov2.FOAM)
VIEWS = {"top": (0.0, 180.0), "side": (90.0, 90.0), "front": (90.0, 0.0)}
MIN_IOU = {"top": 0.90, "side": 0.90, "front": 0.85}
CAD = {"bluerov2": "standard", "bluerov2-heavy": "heavy"}


@pytest.fixture(scope="module", params=bluerov2.VARIANTS)
def rov(request):
    return bluerov2.build(request.param)


def _crop(mask: np.ndarray) -> np.ndarray:
    ys, xs = np.nonzero(mask)
    return mask[ys.min():ys.max() + 1, xs.min():xs.max() + 1]


def _iou_aligned(a: np.ndarray, b: np.ndarray) -> float:
    """IoU of two silhouettes aligned on their bounding boxes, best over a left-right flip."""
    a, b = _crop(a), _crop(b)
    h, w = max(a.shape[0], b.shape[0]), max(a.shape[1], b.shape[1])

    def place(m):
        out = np.zeros((h, w), bool)
        y0, x0 = (h - m.shape[0]) // 2, (w - m.shape[1]) // 2
        out[y0:y0 + m.shape[0], x0:x0 + m.shape[1]] = m
        return out

    pa = place(a)
    return max(float((pa & place(m)).sum() / (pa | place(m)).sum()) for m in (b, b[:, ::-1]))


def test_closed_and_coloured(rov):
    tm = rov.to_trimesh()
    assert tm.is_watertight and tm.is_winding_consistent and tm.volume > 0
    colours = {tuple(c) for c in np.unique(rov.face_colors, axis=0)}
    for part in (bluerov2.BLACK, bluerov2.FOAM, bluerov2.ACRYLIC, bluerov2.METAL):
        assert part in colours
    # centred on its bounding box, waterline between the lowest and highest points
    np.testing.assert_allclose(rov.bounds.sum(axis=0), 0.0, atol=1e-9)
    assert rov.bounds[0, 2] < rov.waterline < rov.bounds[1, 2]


def test_waterline_just_under_foam_and_tube_tops(rov):
    """Foam tops and the electronics tube top stand just above the water (1-5 cm)."""
    top = render(rov, 0.0, 180.0, size=256, metres_per_pixel=0.002, supersample=1)
    foam = (np.abs(top.albedo.astype(int) - FOAM).sum(axis=-1) < 10) & top.mask
    tube = (top.albedo == bluerov2.ACRYLIC).all(axis=-1) & top.mask
    assert foam.sum() > 1000 and tube.sum() > 500
    assert 0.01 < np.median(top.height[foam]) < 0.05
    assert 0.005 < top.height[tube].max() < 0.05


def test_top_view_reads_as_bluerov2(rov):
    """From above: foam on both sides of the white tube, dome at the front."""
    top = render(rov, 0.0, 180.0, size=300, metres_per_pixel=0.002, supersample=1)
    foam = (np.abs(top.albedo.astype(int) - FOAM).sum(axis=-1) < 10) & top.mask
    cols = np.nonzero(foam.any(axis=0))[0]
    centre = top.alpha.shape[1] / 2
    assert cols.min() < centre - 20 and cols.max() > centre + 20  # both sides
    assert not foam[:, int(centre) - 5:int(centre) + 5].any()  # tube in between
    dome = (top.albedo == bluerov2.DOME).all(axis=-1) & top.mask
    tube = (top.albedo == bluerov2.ACRYLIC).all(axis=-1) & top.mask
    # image up is forward in this view: the dome lies above (before) the tube
    assert np.nonzero(dome)[0].mean() < np.nonzero(tube)[0].mean()


def test_dimensions_within_two_percent_of_cad(rov, reference):
    cad = trimesh.load(reference / "bluerov2" / f"{CAD[rov.name]}_core.ply", process=False)
    np.testing.assert_allclose(rov.extents, cad.extents, rtol=0.02)


@pytest.mark.parametrize("view", list(VIEWS))
def test_silhouette_iou_against_cad(rov, reference, view):
    path = reference / "bluerov2" / f"{CAD[rov.name]}_{view}_silhouette.png"
    ref = cv2.imread(str(path), cv2.IMREAD_GRAYSCALE) > 127
    theta, phi = VIEWS[view]
    ours = render(rov, theta, phi, size=720, metres_per_pixel=0.001, supersample=2)
    iou = _iou_aligned(ours.alpha >= 0.5, ref)
    assert iou >= MIN_IOU[view], f"{rov.name} {view} silhouette IoU {iou:.3f}"


def test_unknown_variant():
    with pytest.raises(ValueError, match="bluerov2-heavy"):
        bluerov2.build("bluerov3")
