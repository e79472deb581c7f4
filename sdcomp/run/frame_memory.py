"""The memory a run of frames of a given size needs, and refusing one that cannot fit.

A run holds the generator once (this process: interpreter, textures, sprite atlases,
:data:`BASE_BYTES`) and renders in up to ``workers`` processes at once, each with its own
copies (:data:`WORKER_BYTES`) and the arrays of the frame it renders
(:func:`image_bytes`). The figures are peaks measured with ``/usr/bin/time -v`` and the
processes' proportional set sizes (docs/generate.md, "Memory": 416 px to 30000 px, one and
two workers, 10 m altitude with four objects and blur, the dear case), rounded up:

* frames up to :data:`~sdcomp.render.camera.pipeline.HUGE_SIDE` px a side go through the
  camera's whole pipeline: the lower of 80 bytes a pixel and 900 MiB + 21 bytes a pixel
  (measured at most 2.2 GiB for an 8192 x 8192 frame beside the base);
* larger frames get its point-wise stages only, in bands: 200 MiB + 6.5 bytes a pixel
  (30000 x 30000: 5.6 GiB in all);
* a video frame adds :data:`VIDEO_BYTES_PER_PIXEL` (12000 x 12000 video frames peaked at
  2.7 GiB, images of that size at 1.6 GiB).

:func:`check_run_memory` refuses, before anything is rendered or written, a run whose
estimate is over :func:`sdcomp.util.memory.machine_bytes`.
"""

from __future__ import annotations

from ..render.camera.pipeline import HUGE_SIDE
from ..util.memory import check_fits, gib, machine_bytes

MIB = 1 << 20
BASE_BYTES = 400 * MIB  #: the generator, held once (measured 375-470 MiB)
WORKER_BYTES = 250 * MIB  #: a rendering process's own, beside its frame (measured 237)
#: a frame through the camera's whole pipeline: min(SMALL * px, FIXED + LARGE * px) bytes
CAMERA_SMALL_BYTES_PER_PIXEL = 80
CAMERA_FIXED_BYTES = 900 * MIB
CAMERA_LARGE_BYTES_PER_PIXEL = 21
#: a huge frame (a side over HUGE_SIDE): HUGE_FIXED + HUGE_PER_PIXEL * px bytes
HUGE_FIXED_BYTES = 200 * MIB
HUGE_BYTES_PER_PIXEL = 6.5
VIDEO_BYTES_PER_PIXEL = 9  #: what a video frame needs on top (measured 8.4 at 12000 px)


def image_bytes(width: int, height: int, video: bool = False) -> int:
    """Peak memory of rendering and writing one ``width`` x ``height`` frame, bytes, beyond
    what its process holds anyway (``video``: a video frame)."""
    px = width * height
    if max(width, height) > HUGE_SIDE:
        need = HUGE_FIXED_BYTES + HUGE_BYTES_PER_PIXEL * px
    else:
        need = min(CAMERA_SMALL_BYTES_PER_PIXEL * px,
                   CAMERA_FIXED_BYTES + CAMERA_LARGE_BYTES_PER_PIXEL * px)
    return int(need + (VIDEO_BYTES_PER_PIXEL * px if video else 0))


def run_bytes(width: int, height: int, workers: int, video: bool = False) -> int:
    """Peak memory of a run of ``width`` x ``height`` frames rendered by ``workers``
    processes at once, bytes."""
    return BASE_BYTES + max(1, workers) * (WORKER_BYTES + image_bytes(width, height, video))


def check_run_memory(width: int, height: int, workers: int, frames: int,
                     video: bool = False) -> None:
    """UserError, before anything is rendered, when ``frames`` frames of ``width`` x
    ``height`` px rendered by ``workers`` processes (no more at once than there are frames)
    need more memory than this machine has; the message names the size, the workers, the
    figure and what fits."""
    busy = max(1, min(workers, frames))
    need = run_bytes(width, height, busy, video)
    if need <= machine_bytes():
        return
    each = WORKER_BYTES + image_bytes(width, height, video)
    fit = (machine_bytes() - BASE_BYTES) // each
    kind = "video frames" if video else "frames"
    what = (f"rendering {width}x{height} px {kind} with {busy} worker"
            f"{'s' if busy != 1 else ''} (about {gib(each)} each)")
    if fit >= 1:
        fewer = "--workers 1" if fit == 1 else f"--workers {fit} or fewer"
        fix = f"use {fewer}, or smaller frames (--size, --width, --height)"
    else:
        side = _largest_square(max(width, height), video)
        fix = (f"use smaller frames (--size, --width, --height): up to about {side}x{side} px "
               f"fits with one worker" if side else
               "this machine's memory is too small for the generator itself")
    check_fits(need, what, fix)


def _largest_square(most: int, video: bool) -> int:
    """The largest side (px, at most ``most``) of square frames whose run with one worker
    fits in this machine's memory, 0 for none. The estimate grows with the side within
    each regime (the camera's whole pipeline up to HUGE_SIDE, its point-wise stages
    above), so a binary search per regime finds it."""
    have = machine_bytes()
    best = 0
    for lo, hi in ((1, min(most, HUGE_SIDE)), (HUGE_SIDE + 1, most)):
        if lo > hi or run_bytes(lo, lo, 1, video) > have:
            continue
        while lo < hi:
            mid = (lo + hi + 1) // 2
            lo, hi = (mid, hi) if run_bytes(mid, mid, 1, video) <= have else (lo, mid - 1)
        best = max(best, lo)
    return best
