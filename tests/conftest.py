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

