"""How much memory this machine has, and refusing work that would need more.

:func:`machine_bytes` is the memory a run can count on, in bytes: the machine's physical
memory, or the limit of the control group (container, job slot) the process runs in where
that is lower. The environment variable ``SDCOMP_MEMORY_BYTES`` replaces it (bytes, or a
number with a binary suffix: ``512M``, ``2G``, ``1.5T``): to pretend a smaller machine in
tests, or to keep a run within a share of a bigger one.

:func:`check_fits` is the refusal: a one-line :class:`~sdcomp.errors.UserError` with the
figure (``frame 40000x40000 px with 4 workers needs about 52.3 GiB, more than this
machine's 24.0 GiB; ...``), raised before anything is allocated. The estimates it is given
are the measured peaks of the work (see docs/generate.md, "Memory").
"""

from __future__ import annotations

import os
import re
from pathlib import Path

from ..errors import UserError

ENV = "SDCOMP_MEMORY_BYTES"  #: environment variable that overrides :func:`machine_bytes`
GIB = 1 << 30
_SUFFIX = {"": 1, "K": 1 << 10, "M": 1 << 20, "G": 1 << 30, "T": 1 << 40}
_CGROUP_ROOT = Path("/sys/fs/cgroup")
#: a cgroup "limit" at or above this is no limit (cgroup v1 writes 2^63 rounded to pages)
_NO_LIMIT = 1 << 60


def machine_bytes() -> int:
    """The memory this process can use, bytes: ``$SDCOMP_MEMORY_BYTES`` when set, else the
    physical memory (``SC_PHYS_PAGES`` x ``SC_PAGE_SIZE``), or its control group's memory
    limit (cgroup v2 ``memory.max``, v1 ``memory.limit_in_bytes``, of its group and the
    groups above) where that is lower. UserError for an override that is not a size."""
    text = os.environ.get(ENV, "").strip()
    if text:
        return parse_bytes(text)
    known = [n for n in (_physical_bytes(), _cgroup_limit()) if n]
    return min(known) if known else _NO_LIMIT  # a system that says nothing: no refusals


def parse_bytes(text: str) -> int:
    """A size in bytes from ``text``: an integer (``2147483648``) or a number with a binary
    suffix K, M, G, T (``2G``, ``1.5GiB``, ``512m``); UserError naming
    ``$SDCOMP_MEMORY_BYTES`` otherwise."""
    m = re.fullmatch(r"\s*(\d+(?:\.\d*)?)\s*([KMGT]?)(?:I?B)?\s*", text.upper())
    value = float(m.group(1)) * _SUFFIX[m.group(2)] if m else 0.0
    if value < 1:
        raise UserError(f"${ENV}={text!r} is not a memory size: use bytes or a number with "
                        f"K, M, G or T (e.g. 2G), or unset it")
    return int(value)


def check_fits(need_bytes: int, what: str, fix: str) -> None:
    """UserError unless ``need_bytes`` (bytes: an estimate of the peak memory of ``what``)
    fits in :func:`machine_bytes`. The message is one line: ``<what> needs about 14.2 GiB,
    more than this machine's 8.0 GiB; <fix>``."""
    have = machine_bytes()
    if need_bytes > have:
        raise UserError(f"{what} needs about {gib(need_bytes)}, more than this machine's "
                        f"{gib(have)}; {fix}")


def gib(n_bytes: float) -> str:
    """``n_bytes`` bytes as GiB with one decimal (``'14.2 GiB'``); MiB below 1 GiB."""
    if n_bytes < GIB:
        return f"{n_bytes / (1 << 20):.0f} MiB"
    return f"{n_bytes / GIB:.1f} GiB"


def _physical_bytes() -> int:
    """Physical memory, bytes (0 where the system does not say)."""
    try:
        return int(os.sysconf("SC_PHYS_PAGES")) * int(os.sysconf("SC_PAGE_SIZE"))
    except (AttributeError, OSError, ValueError):
        return 0


def _cgroup_limit() -> int | None:
    """The lowest memory limit, bytes, of this process's control group and those above it
    (cgroup v2 and v1), None where there is none or no cgroup file system."""
    limits = [n for f in _cgroup_limit_files() if (n := _read_limit(f)) is not None]
    return min(limits) if limits else None


def _cgroup_limit_files() -> list[Path]:
    """The limit files that may apply: those of the group named in /proc/self/cgroup and
    of each group above it, and those at the mount roots (a container sees its own group
    there)."""
    files = [_CGROUP_ROOT / "memory.max", _CGROUP_ROOT / "memory" / "memory.limit_in_bytes"]
    try:
        lines = Path("/proc/self/cgroup").read_text().splitlines()
    except OSError:
        return files
    for line in lines:
        parts = line.split(":", 2)
        if len(parts) != 3:
            continue
        _, controllers, group = parts
        if controllers == "":  # cgroup v2: one hierarchy
            base, name = _CGROUP_ROOT, "memory.max"
        elif "memory" in controllers.split(","):
            base, name = _CGROUP_ROOT / "memory", "memory.limit_in_bytes"
        else:
            continue
        path = Path(group.strip("/"))
        while path != Path("."):
            files.append(base / path / name)
            path = path.parent
    return files


def _read_limit(path: Path) -> int | None:
    """The limit in a cgroup limit file, bytes; None for none (``max``, a huge value) or
    a file that is missing or unreadable."""
    try:
        text = path.read_text().strip()
    except OSError:
        return None
    if not text.isdigit():
        return None
    value = int(text)
    return value if 0 < value < _NO_LIMIT else None
