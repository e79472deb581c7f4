"""The C heap kept for reuse (sdcomp.util.heap): a freed frame's memory stays in the heap
for the next frame, and SDCOMP_KEEP_HEAP=0 leaves malloc as it is."""

from __future__ import annotations

import os
import platform
import subprocess
import sys

import pytest

LIBC, VERSION = platform.libc_ver()
pytestmark = pytest.mark.skipif(
    platform.system() != "Linux" or LIBC != "glibc"
    or tuple(int(x) for x in VERSION.split(".")[:2]) < (2, 33),
    reason="mallopt is glibc's; mallinfo2 came in 2.33")

CODE = """
import ctypes, numpy as np
from sdcomp.util.heap import keep_freed_memory

class MallInfo2(ctypes.Structure):
    _fields_ = [(name, ctypes.c_size_t) for name in (
        "arena", "ordblks", "smblks", "hblks", "hblkhd", "usmblks", "fsmblks", "uordblks",
        "fordblks", "keepcost")]

libc = ctypes.CDLL("libc.so.6")
libc.mallinfo2.restype = MallInfo2
kept = keep_freed_memory()
a = np.ones((2160, 3840, 3), np.uint16)  # 50 MB, a 4K frame's temporary
mapped = libc.mallinfo2().hblkhd
del a
print(kept, mapped, libc.mallinfo2().fordblks)
"""


def _run(keep: str) -> tuple[bool, int, int]:
    """(set, bytes mapped apart while the frame lives, bytes free in the heap after)."""
    out = subprocess.run([sys.executable, "-c", CODE], capture_output=True, text=True,
                         check=True, env={**os.environ, "SDCOMP_KEEP_HEAP": keep}).stdout
    kept, mapped, free = out.split()
    return kept == "True", int(mapped), int(free)


def test_a_freed_frame_stays_in_the_heap():
    kept, mapped, free = _run("1")
    assert kept and mapped < 1 << 20 and free >= 50_000_000  # kept for the next frame
    kept, mapped, free = _run("0")
    assert not kept and mapped >= 50_000_000 and free < 50_000_000  # mapped, unmapped
