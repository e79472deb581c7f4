"""Painted-out regions of real frames (SeaDronesSee paints what it does not label black):
found, and kept out of the water that ``sdcomp fit``, the realism report and the per-object
statistics measure."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from sdcomp import GeneratorConfig
from sdcomp.fitting.footage import read_footage
from sdcomp.fitting.stats import SCALES
from sdcomp.pipeline import Generator
from sdcomp.render.camera.codec import jpeg_roundtrip
from sdcomp.report.realism.objects import box_statistics
from sdcomp.report.realism.painted import PAINT_MARGIN, painted_mask, shrink_valid
from sdcomp.report.realism.sources import PAINT_HOW, load_frame, load_real

SIZE = 256


def _frames(sprites_dir: Path, n: int, count: str = "1-3") -> list[np.ndarray]:
    """``n`` default frames (BlueROV2s, whose thrusters are black, and clutter) of SIZE px."""
    config = GeneratorConfig.from_mapping({"width": SIZE, "height": SIZE, "count": count,
                                           "seed": 5})
    gen = Generator(config, sprites_dir, progress=False)
    return [gen.render_scene(gen.scene(i)).image.copy() for i in range(n)]


def _paint(rgb: np.ndarray, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """A copy of ``rgb`` with 1-3 black rectangles 10-60 px a side, and where they are."""
    rng = np.random.default_rng(seed)
    out, where = rgb.copy(), np.zeros(rgb.shape[:2], bool)
    h, w = where.shape
    for _ in range(int(rng.integers(1, 4))):
        bw, bh = (int(v) for v in rng.integers(10, 61, 2))
        x, y = int(rng.integers(0, w - bw)), int(rng.integers(0, h - bh))
        out[y:y + bh, x:x + bw] = 0
        where[y:y + bh, x:x + bw] = True
    return out, where


def _jpeg(rgb: np.ndarray, quality: int) -> np.ndarray:
    return jpeg_roundtrip(rgb, quality)[0]


@pytest.fixture(scope="module")
def frames(sprites_dir):
    return _frames(sprites_dir, 12)


@pytest.mark.parametrize("quality", [95, 70])
def test_paint_is_found_after_compression_and_nothing_else(frames, quality):
    """Every painted rectangle is covered, with its compression ringing (the margin), at
    JPEG 95 and 70; nothing PAINT_MARGIN + 8 px away from paint is marked, and the same
    frames unpainted (water, sun glitter, the robots' black thrusters) have none."""
    for k, rgb in enumerate(frames):
        assert painted_mask(_jpeg(rgb, quality)) is None, k
        painted, where = _paint(rgb, k)
        mask = painted_mask(_jpeg(painted, quality))
        assert mask is not None and mask[where].all(), k
        ring = cv2.dilate(where.astype(np.uint8), np.ones((3, 3), np.uint8), iterations=2)
        assert mask[ring > 0].all(), k  # the edge's ringing too
        side = 2 * (PAINT_MARGIN + 8) + 1
        near = cv2.dilate(where.astype(np.uint8), np.ones((side, side), np.uint8)) > 0
        assert not mask[~near].any(), k


def test_dark_water_and_thin_dark_lines_are_not_paint():
    """Water crushed to the camera's black level (8-12, not 0) and black lines 3 px wide
    (a wetsuit's edge, a mooring line) are not paint."""
    from .conftest import water_like

    dark = np.clip(water_like(SIZE, SIZE, 3).astype(np.float32) * 0.05 + 5, 7, 12)
    dark = dark.astype(np.uint8)
    assert dark.max() <= 12 and painted_mask(dark) is None
    lines = water_like(SIZE, SIZE, 4)
    lines[:, 100:103] = 0
    lines[40:43, :] = 0
    assert painted_mask(lines) is None


def test_a_reduced_mask_keeps_a_single_invalid_pixel():
    valid = np.ones((64, 64), bool)
    valid[13, 50] = False
    small = shrink_valid(valid, 16, 16)
    assert small.shape == (16, 16) and not small[3, 12] and small.sum() == 255


def test_fit_keeps_paint_out_of_the_water(frames, tmp_path, monkeypatch):
    """The footage's statistics with a painted rectangle in every other frame are the clean
    footage's (the frame-wide blockiness and vignetting too); without the mask they are not
    (the test can fail), and the report's notes say how many frames had paint."""
    clean, paint = tmp_path / "clean", tmp_path / "paint"
    clean.mkdir()
    paint.mkdir()
    for k, rgb in enumerate(frames):
        cv2.imwrite(str(clean / f"f{k:03d}.png"), cv2.cvtColor(_jpeg(rgb, 95), cv2.COLOR_RGB2BGR))
        out = _paint(rgb, k)[0] if k % 2 == 0 else rgb
        cv2.imwrite(str(paint / f"f{k:03d}.png"), cv2.cvtColor(_jpeg(out, 95), cv2.COLOR_RGB2BGR))
    a, b = read_footage(clean), read_footage(paint)
    assert any("painted-out (black) regions kept out of 6 frames" in n for n in b.notes)
    assert not any("painted" in n for n in a.notes)
    for stat, tol in (("blockiness", 0.01), ("vignetting", 0.005)):  # over whole frames
        assert abs(b.summary[stat][1] - a.summary[stat][1]) <= tol, (stat, a.summary, b.summary)
    for stat in ("luminance", "highpass_std", "noise"):  # fewer patches: half a loss unit
        assert abs(b.summary[stat][1] - a.summary[stat][1]) <= SCALES[stat] / 2, stat
    monkeypatch.setattr("sdcomp.report.realism.sources.painted_mask", lambda rgb: None)
    c = read_footage(paint)
    assert abs(c.summary["blockiness"][1] - a.summary["blockiness"][1]) > 0.01, c.summary


def test_realism_reads_paint_as_invalid(frames, tmp_path):
    painted, where = _paint(frames[0], 0)
    cv2.imwrite(str(tmp_path / "f.png"), cv2.cvtColor(painted, cv2.COLOR_RGB2BGR))
    loaded = load_frame(load_real(tmp_path).frames[0])
    assert loaded is not None and loaded.valid is not None and loaded.painted is not None
    assert not loaded.valid[where].any() and loaded.valid.mean() > 0.5
    assert loaded.valid_how == PAINT_HOW


def test_paint_is_not_a_boxes_surrounding_water():
    """A box beside a painted rectangle measures against its water only: the contrast is
    the unpainted image's within 0.1 with the valid mask, and far from it without."""
    rng = np.random.default_rng(0)
    y = np.clip(rng.normal(100, 8, (200, 200)), 0, 255)
    img = np.repeat(y[..., None], 3, axis=2).astype(np.uint8)
    img[90:110, 90:110] = 70
    box = [[90, 90, 20, 20]]
    plain = box_statistics(img, box, min_size=5)[0, 0]
    painted = img.copy()
    painted[60:140, 115:135] = 0
    valid = ~painted_mask(painted)
    assert abs(box_statistics(painted, box, min_size=5, valid=valid)[0, 0] - plain) < 0.1
    assert abs(box_statistics(painted, box, min_size=5)[0, 0] - plain) > 1.0


def test_real_objects_measure_against_their_water_only(tmp_path):
    """``sdcomp realism --objects`` on real frames: a labelled box beside a painted
    rectangle measures as in the same frame unpainted."""
    import json

    from sdcomp.report.realism.object_sets import measure_objects

    rng = np.random.default_rng(1)
    y = np.clip(rng.normal(110, 6, (160, 160)), 0, 255)
    img = np.repeat(y[..., None], 3, axis=2).astype(np.uint8)
    img[70:90, 70:90] = 60
    painted = img.copy()
    painted[40:120, 95:115] = 0
    coco = {"images": [], "annotations": [], "categories": [{"id": 1, "name": "swimmer"}]}
    for k, rgb in enumerate((img, painted)):
        cv2.imwrite(str(tmp_path / f"f{k}.png"), cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR))
        coco["images"].append({"id": k + 1, "file_name": f"f{k}.png", "width": 160,
                               "height": 160})
        coco["annotations"].append({"id": k + 1, "image_id": k + 1, "category_id": 1,
                                    "bbox": [70, 70, 20, 20], "area": 400, "iscrowd": 0})
    (tmp_path / "labels.json").write_text(json.dumps(coco))
    table = measure_objects(load_real(tmp_path, tmp_path / "labels.json"))
    assert table.values.shape[0] == 2
    assert abs(table.values[0, 0] - table.values[1, 0]) < 0.1, table.values[:, :3]
    assert abs(table.values[0, 1] - table.values[1, 1]) < 0.02  # the dark share
