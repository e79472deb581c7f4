"""Shared fixtures: the optional reference data, small meshes."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest
import trimesh

from sdcomp.assets.mesh import ColoredMesh

REPO = Path(__file__).resolve().parents[1]
REFERENCE = Path(os.environ.get("SDCOMP_REFERENCE", REPO.parent / "shared" / "reference"))


@pytest.fixture(scope="session")
def reference() -> Path:
    """The reference data folder (../shared/reference); skips the test where it is absent."""
    if not (REFERENCE / "bluerov2" / "SPEC.md").exists():
        pytest.skip(f"reference data not found at {REFERENCE} (validation only; "
                    "set SDCOMP_REFERENCE to point at it)")
    return REFERENCE


def box_mesh(size=(1.0, 0.6, 0.3), colour=(200, 60, 40), waterline=0.0,
             name="box") -> ColoredMesh:
    """A closed box centred on the origin with one colour per face pair."""
    b = trimesh.creation.box(extents=size)
    cols = np.tile(np.array(colour, np.uint8), (len(b.faces), 1))
    return ColoredMesh(b.vertices, b.faces, cols, waterline, name, closed=True)



@pytest.fixture(scope="session")
def water_textures():
    """The water's periodic tiles of seed 1 (direction set 0 up front, the tiles of the
    other sets on first use), shared by the water tests."""
    from sdcomp.render.water import WaterTextures

    return WaterTextures.build(1)


def water_like(h: int, w: int, seed: int = 0) -> np.ndarray:
    """(h, w, 3) uint8 test frame for the camera stage: a smooth blue-green field with
    band-limited ripples and a few bright and dark discs (edges for ringing and halos)."""
    import cv2

    rng = np.random.default_rng(seed)
    base = np.array([40.0, 90.0, 110.0]) + rng.uniform(-20, 20, 3)
    coarse = cv2.resize(rng.normal(0, 18, (max(2, h // 64), max(2, w // 64), 3)), (w, h),
                        interpolation=cv2.INTER_CUBIC)
    ripples = cv2.GaussianBlur(rng.normal(0, 25, (h, w, 1)), (0, 0), 1.5)
    img = base + coarse + ripples.reshape(h, w, 1)
    for _ in range(6):
        x, y = int(rng.integers(0, w)), int(rng.integers(0, h))
        r = int(rng.integers(3, max(4, min(h, w) // 12)))
        cv2.circle(img, (x, y), r, tuple(float(v) for v in rng.uniform(0, 255, 3)), -1)
    return np.clip(img, 0, 255).astype(np.uint8)


def squares(h: int, w: int, boxes) -> np.ndarray:
    """(h, w) uint16 instance map with id k + 1 on box k = (x, y, size)."""
    ins = np.zeros((h, w), np.uint16)
    for k, (x, y, s) in enumerate(boxes):
        ins[y:y + s, x:x + s] = k + 1
    return ins


@pytest.fixture
def frame416() -> tuple[np.ndarray, np.ndarray]:
    """A 416 x 416 camera-stage test frame and its instance map of four squares."""
    img = water_like(416, 416, 1)
    ins = squares(416, 416, [(100, 100, 20), (200, 180, 30), (260, 300, 12), (150, 250, 16)])
    return img, ins
