"""Fixtures shared by tests/ and benchmarks/."""

from __future__ import annotations

import os
from pathlib import Path

import pytest


@pytest.fixture(scope="session")
def sprites_dir(tmp_path_factory) -> Path:
    """One sprite-atlas folder for the whole test session (atlases are built on first use
    and reused, as a user's cache would be); never the repository's own nor the user's.
    ``SDCOMP_TEST_SPRITES=DIR`` names a folder to use instead (atlases kept between runs)."""
    if os.environ.get("SDCOMP_TEST_SPRITES"):
        return Path(os.environ["SDCOMP_TEST_SPRITES"])
    if os.environ.get("PYTEST_XDIST_WORKER"):
        # one folder for every pytest-xdist worker: an atlas is built once, by whichever
        # worker needs it first, while the others wait (sdcomp.atlas.cache's lock)
        shared = tmp_path_factory.getbasetemp().parent / "sprites"
        shared.mkdir(exist_ok=True)
        return shared
    return tmp_path_factory.mktemp("sprites")


@pytest.fixture
def one_torch_thread():
    """One torch thread during the test (two threads on a loaded 2-core machine are many
    times slower than one), the previous count restored after it."""
    import torch  # only the tests that ask for this fixture need torch

    n = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(n)


@pytest.fixture(scope="session", autouse=True)
def sprites_env(sprites_dir):
    """``$SDCOMP_SPRITES`` is the session's atlas folder: code that takes the default folder
    uses the shared test atlases, never the user's cache."""
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("SDCOMP_SPRITES", str(sprites_dir))
        yield

