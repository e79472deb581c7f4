"""How a dataset run is carried out (never what it contains): folder, workers, resume."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from ..atlas.cache import sprites_folder
from ..scene.config import GeneratorConfig
from .shards import shard_range


@dataclass(frozen=True)
class RunOptions:
    """How to run (does not change the output): folder, workers, resume/overwrite."""

    out: Path
    workers: int = 1
    resume: bool = False
    overwrite: bool = False
    progress: bool | None = None
    sprites_dir: Path = field(default_factory=sprites_folder)  # the user's atlas folder
    #: (K, N): render only shard K of N of the image indices (see sdcomp.run.shards)
    shard: tuple[int, int] | None = None


def run_indices(config: GeneratorConfig, shard: tuple[int, int] | None) -> range:
    """The image indices a run renders: all, or those of shard (K, N)."""
    return range(config.n) if shard is None else shard_range(config.n, *shard)
