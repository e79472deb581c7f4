"""Fixtures shared by tests/ and benchmarks/."""

from __future__ import annotations

from pathlib import Path

import pytest


@pytest.fixture(scope="session")
def sprites_dir(tmp_path_factory) -> Path:
    """One sprite-atlas folder for the whole test session (atlases are built on first use
    and reused, as a user's ``sprites/`` would be); never the repository's own."""
    return tmp_path_factory.mktemp("sprites")
