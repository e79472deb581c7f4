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



# --------------------------------------------------------------------------- small datasets

@pytest.fixture(scope="session")
def small_datasets(tmp_path_factory, sprites_dir):
    """``make(name, *flags)``: a generated dataset folder at 192 px (no progress line, one
    worker), made once per session and name; shared by the realism and sim2real tests."""
    from .datasets import generate

    made: dict[str, Path] = {}
    root = tmp_path_factory.mktemp("small_datasets")

    def make(name: str, *flags) -> Path:
        if name not in made:
            out = root / name
            rc, _, err = generate(["--size", "192", *flags], out, sprites_dir)
            assert rc == 0, err
            made[name] = out
        return made[name]

    return make


@pytest.fixture(scope="session")
def gen_default(small_datasets) -> Path:
    """32 images of the default settings (10-50 m, straight down, brown/blue/green water)."""
    return small_datasets("default", "--n", "32", "--seed", "1")


@pytest.fixture(scope="session")
def gen_grey(small_datasets) -> Path:
    """16 images of grey water (120, 130, 125): a stand-in for real frames."""
    return small_datasets("grey", "--n", "16", "--seed", "2", "--water", "120,130,125")
