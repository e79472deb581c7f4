"""Splitting a run's image indices into shards (``--shard K/N``), for job arrays and Dask.

Shard ``K`` of ``N`` (``K`` from 0 to ``N - 1``) is the contiguous block of image indices
``[K * n // N, (K + 1) * n // N)``: the blocks are as equal as integers allow, together cover
``0 .. n - 1`` once, and depend only on (n, K, N). Image ``i`` depends only on (config, i), so
shards rendered anywhere and merged (:mod:`sdcomp.merge`) equal one local run, byte for byte.
"""

from __future__ import annotations

import re

from ..errors import UserError

MAX_SHARDS = 1_000_000


def parse_shard(text: str) -> tuple[int, int]:
    """``(K, N)`` from ``"K/N"`` (0 <= K < N); UserError naming the value otherwise."""
    m = re.fullmatch(r"\s*(\d+)\s*/\s*(\d+)\s*", str(text))
    if not m:
        raise UserError(f"--shard {text!r} is not K/N: give this shard's number K (0 to N-1) "
                        f"and the number of shards N, e.g. --shard 0/4")
    k, n = int(m.group(1)), int(m.group(2))
    if not 1 <= n <= MAX_SHARDS:
        raise UserError(f"--shard {text}: N = {n} is out of range: use 1 to {MAX_SHARDS} shards")
    if not 0 <= k < n:
        raise UserError(f"--shard {text}: K = {k} is out of range: shards are numbered 0 to "
                        f"{n - 1} (with SLURM: --array=0-{n - 1})")
    return k, n


def shard_range(n_images: int, k: int, n: int) -> range:
    """The image indices of shard ``k`` of ``n`` in a run of ``n_images`` images."""
    if not 0 <= k < n:
        raise ValueError(f"shard {k} of {n}: k must be in 0..{n - 1}")
    return range(k * n_images // n, (k + 1) * n_images // n)


def shard_text(shard: tuple[int, int]) -> str:
    """``"K/N"``: how a shard is written in dataset.json and on the command line."""
    return f"{shard[0]}/{shard[1]}"


def shard_folder(k: int, n: int) -> str:
    """A folder name for shard ``k`` of ``n`` that sorts in shard order: ``shard-003-of-016``."""
    w = max(3, len(str(n - 1)))
    return f"shard-{k:0{w}d}-of-{n:0{w}d}"
