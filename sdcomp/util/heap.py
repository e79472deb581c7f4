"""The C heap kept for reuse: frames' temporary arrays without a page fault per page.

Every full-frame temporary (a 1920x1080 float32 plane is 8 MB) is freed within the image
that made it. glibc's malloc serves blocks above its mmap threshold (adaptive, from 128 KiB)
with ``mmap`` and returns them with ``munmap``; below it, it trims the heap's top once
128 KiB-2x the threshold lie free. Either way the next image's arrays touch fresh pages,
and every page costs a fault (on the development VM a 1080p image took about 10,000 faults,
a fifth of its time). :func:`keep_freed_memory` raises the thresholds so that freed frames
stay in the heap and are reused: at 1920x1080 the faults fall from ~10,600 to ~1,600 an
image and a 2-worker run goes about 5 % faster (docs/performance.md). Peak memory is the same:
what is kept is what the previous image used. Blocks above :data:`MMAP_THRESHOLD` (a huge
frame's 2.7 GB) are still mapped and returned at once.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import functools
import os

MMAP_THRESHOLD = 128 << 20  # bytes: larger blocks are mapped and returned at once
TRIM_THRESHOLD = 512 << 20  # bytes: free memory at the heap's top kept up to this
TOP_PAD = 64 << 20  # bytes: extra asked of the system each time the heap grows
_M_TRIM_THRESHOLD, _M_TOP_PAD, _M_MMAP_THRESHOLD = -1, -2, -3  # glibc's mallopt params


@functools.cache
def keep_freed_memory() -> bool:
    """Set glibc's malloc thresholds (:data:`MMAP_THRESHOLD`, :data:`TRIM_THRESHOLD`,
    :data:`TOP_PAD`) for this process and the workers it forks, once. Returns whether they
    are set: False where the C library is not glibc, or where ``SDCOMP_KEEP_HEAP=0`` asks
    to leave malloc as it is."""
    ok = False
    if os.environ.get("SDCOMP_KEEP_HEAP", "1") != "0":
        try:
            libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6")
            mallopt = libc.mallopt
        except (OSError, AttributeError):  # not glibc (musl, macOS, Windows)
            mallopt = None
        if mallopt is not None:
            ok = all(mallopt(param, value) == 1 for param, value in (
                (_M_MMAP_THRESHOLD, MMAP_THRESHOLD), (_M_TRIM_THRESHOLD, TRIM_THRESHOLD),
                (_M_TOP_PAD, TOP_PAD)))
    return ok
