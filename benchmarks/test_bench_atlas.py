"""Atlas build throughput (pytest-benchmark). Target: default BlueROV2 atlas in <= 30 s."""

from __future__ import annotations

import os

import pytest

from sdcomp.assets import bluerov2
from sdcomp.atlas.raster import render
from sdcomp.atlas.store import AtlasConfig, build_atlas, save_atlas

TARGET_S = 30.0


@pytest.fixture(scope="module")
def rov():
    return bluerov2.build("bluerov2")


def test_bench_build_mesh(benchmark):
    mesh = benchmark(bluerov2.build, "bluerov2")
    benchmark.extra_info["triangles"] = len(mesh.faces)


def test_bench_render_one_pose(benchmark, rov):
    s = benchmark(render, rov, 40.0, 30.0, size=128, metres_per_pixel=0.0052, supersample=4)
    assert s.mask.any()


def test_bench_default_atlas_build(benchmark, machine, rov, tmp_path):
    """The default atlas (all cores), saved: time and size on disk in extra_info; the target
    scaled by the machine's slowdown."""
    config = AtlasConfig()
    atlas = benchmark.pedantic(build_atlas, args=(rov, config),
                               kwargs={"workers": os.cpu_count(), "progress": False},
                               rounds=1, iterations=1)
    npz, _ = save_atlas(atlas, tmp_path)
    benchmark.extra_info.update(poses=len(atlas), size_px=config.size,
                                npz_bytes=npz.stat().st_size, workers=os.cpu_count())
    machine.measure_after()
    limit = machine.limit(TARGET_S)
    assert benchmark.stats.stats.mean <= limit, (
        f"default atlas took {benchmark.stats.stats.mean:.1f} s, target {TARGET_S} s "
        f"({limit:.0f} s on this machine)")
