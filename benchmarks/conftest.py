"""The machine's speed, measured next to each benchmark, so that throughput floors and time
limits hold on a slow or loaded CI machine as on the development machine.

A benchmark's floor is stated for the 2-core development machine at rest. On a machine
where a fixed single-core workload (the generator's kind of work: FFT, blur, remap, JPEG,
float arithmetic on a 1024x1024 image) takes ``k`` times as long, a floor is divided by ``k``
and a time limit multiplied by it (never the other way: ``k`` is at least 1). The workload
is timed just before and just after the benchmark and the mean of the two is taken, since
a shared machine's speed drifts.
"""

from __future__ import annotations

import statistics
import time
from collections.abc import Iterator
from dataclasses import dataclass

import cv2
import numpy as np
import pytest

#: seconds the workload takes on the development machine (medians of 3 measured 0.228-0.254 s
#: on 2026-11-26, a slow day for the generator: 30 images/s in memory against 60-67 at rest;
#: so the slowdown understates a day like that and the floors keep a margin of their own)
REFERENCE_S = 0.22


def _workload(side: int = 1024) -> None:
    """About 0.2 s of single-core image work on a ``side`` x ``side`` float32 RGB image (12
    MB at 1024: larger than the caches, as the generator's frames are)."""
    rng = np.random.default_rng(0)
    img = rng.random((side, side, 3), dtype=np.float32)
    ys, xs = np.mgrid[0:side, 0:side].astype(np.float32)
    map_x, map_y = xs + 3.3 * np.sin(ys / 17.0), ys + 2.1 * np.cos(xs / 23.0)
    for _ in range(2):
        spec = np.fft.rfft2(img[..., 0])
        img[..., 0] = np.fft.irfft2(spec * 0.9, s=(side, side))
        img = cv2.GaussianBlur(img, (0, 0), 2.0)
        img = cv2.remap(img, map_x, map_y, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REFLECT)
        img = np.sqrt(img * img + 0.01).astype(np.float32)
        cv2.imencode(".jpg", np.clip(img * 255.0, 0, 255).astype(np.uint8))


def workload_seconds(repeats: int = 3) -> float:
    """Median wall time (s) of the reference workload, cv2 on one thread."""
    threads = cv2.getNumThreads()
    cv2.setNumThreads(1)
    try:
        times = []
        for _ in range(repeats):
            t0 = time.perf_counter()
            _workload()
            times.append(time.perf_counter() - t0)
    finally:
        cv2.setNumThreads(threads)
    return statistics.median(times)


@dataclass
class MachineSpeed:
    """How much slower than the development machine this one runs, from the workload
    timed before a benchmark and, once :meth:`measure_after` is called, after it."""

    before_s: float
    after_s: float | None = None

    @property
    def slowdown(self) -> float:
        """``k >= 1``: the mean workload time over the reference (1 where faster)."""
        seconds = self.before_s if self.after_s is None else (self.before_s + self.after_s) / 2
        return max(1.0, seconds / REFERENCE_S)

    def measure_after(self) -> float:
        """Time the workload again (call it once the benchmarked code has run); the
        slowdown."""
        self.after_s = workload_seconds()
        return self.slowdown

    def floor(self, rate: float) -> float:
        """A throughput floor stated for the development machine, for this one."""
        return rate / self.slowdown

    def limit(self, seconds: float) -> float:
        """A time limit stated for the development machine, for this one."""
        return seconds * self.slowdown


@pytest.fixture
def machine(benchmark) -> Iterator[MachineSpeed]:
    """The machine's speed around one benchmark, put in its ``extra_info`` and printed."""
    speed = MachineSpeed(workload_seconds())
    yield speed
    benchmark.extra_info.update(slowdown=round(speed.slowdown, 3),
                                workload_s=[round(speed.before_s, 4),
                                            None if speed.after_s is None
                                            else round(speed.after_s, 4)])
