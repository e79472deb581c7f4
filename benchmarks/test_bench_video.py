"""Video throughput (pytest-benchmark): frames per second written to disk by ``sdcomp
video`` with 2 workers at 416x416 and 1920x1080, beside stills of the same size and count
made the same way. The video issue's target: a video frame costs no more than a still.
Floors far below the figures (scaled by the ``machine`` fixture's slowdown); the rates and
the ratio go to ``extra_info``."""

from __future__ import annotations

import time
from pathlib import Path

import pytest

from sdcomp.clips import ClipGenerator
from sdcomp.run import RunOptions, run
from sdcomp.run.video import run_video
from sdcomp.scene.config import GeneratorConfig
from sdcomp.scene.video import VideoConfig


def _rate(benchmark, fn, rounds: int, frames: int) -> float:
    benchmark.pedantic(fn, rounds=rounds, iterations=1)
    return frames / benchmark.stats.stats.mean


@pytest.mark.parametrize("size,sequences,frames", [((416, 416), 4, 30),
                                                   ((1920, 1080), 2, 4)], ids=["416", "1080"])
def test_bench_video_to_disk(benchmark, machine, sprites_dir, tmp_path, size, sequences,
                             frames):
    w, h = size
    camera = "mavic2pro" if w == h else "mavic2pro-video"
    config = GeneratorConfig(n=sequences * frames, width=w, height=h, camera=camera)
    video = VideoConfig(config, sequences=sequences, frames=frames)
    clips = ClipGenerator(video, sprites_dir, progress=False)
    clips.warm()
    videos, stills = iter(range(100)), iter(range(100))

    def video_once():
        out = tmp_path / f"v{next(videos)}"
        run_video(video, RunOptions(out, workers=2, progress=False), clips=clips)

    def stills_once():
        out = tmp_path / f"s{next(stills)}"
        run(config, RunOptions(out, workers=2, progress=False), gen=clips.gen)

    t0 = time.perf_counter()
    stills_once()
    still_rate = sequences * frames / (time.perf_counter() - t0)
    rate = _rate(benchmark, video_once, 1, sequences * frames)
    benchmark.extra_info.update(size=f"{w}x{h}", frames=sequences * frames,
                                video_frames_per_s=round(rate, 2),
                                still_images_per_s=round(still_rate, 2),
                                video_over_still=round(rate / still_rate, 3))
    print(f"\nvideo {w}x{h}: {rate:.1f} frames/s, stills {still_rate:.1f} images/s "
          f"(ratio {rate / still_rate:.2f})")
    machine.measure_after()
    assert rate > machine.floor(9.0 if w < 1000 else 0.75)  # 35-41/s and 2.8-3.1/s at rest
    assert (tmp_path / "v0" / "sdcomp-0000" / "gt" / "gt.txt").exists()
    assert Path(tmp_path / "v0" / "video.json").exists()
