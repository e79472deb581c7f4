"""The per-user sprite-atlas cache: where it is, what the first run says, and that a run
from another working folder builds nothing."""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

import trimesh

from sdcomp.atlas.cache import SPRITES_ENV, sprites_folder, user_cache_dir

from .datasets import cli

REPO = Path(__file__).resolve().parents[1]


def test_folder_precedence(monkeypatch, tmp_path):
    """--sprites wins over $SDCOMP_SPRITES, which wins over the user's cache folder."""
    monkeypatch.delenv(SPRITES_ENV, raising=False)
    assert sprites_folder() == user_cache_dir() / "sprites"
    assert sprites_folder().is_absolute()
    monkeypatch.setenv(SPRITES_ENV, str(tmp_path / "env"))
    assert sprites_folder() == tmp_path / "env"
    assert sprites_folder(tmp_path / "flag") == tmp_path / "flag"


def first_run(cache: Path, cwd: Path, mesh: Path) -> tuple[list[tuple[float, str]], float]:
    """``python -m sdcomp.generate`` of one small mesh, without a terminal, its atlas folder
    ``cache`` given by the environment: (stderr lines with their arrival time, total time)."""
    env = {**os.environ, SPRITES_ENV: str(cache),
           "PYTHONPATH": os.pathsep.join([str(REPO), os.environ.get("PYTHONPATH", "")])}
    start = time.perf_counter()
    proc = subprocess.Popen(
        [sys.executable, "-m", "sdcomp.generate", "--object", str(mesh), "--clutter", "0",
         "--n", "2", "--size", "64", "--workers", "1", "--out", "data"],
        cwd=cwd, env=env, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE, text=True)
    assert proc.stderr is not None
    lines = [(time.perf_counter() - start, line.rstrip()) for line in proc.stderr]
    assert proc.wait() == 0, lines
    return lines, time.perf_counter() - start


def test_first_run_says_what_it_builds_and_a_second_folder_builds_nothing(tmp_path):
    """Without a terminal, the first line on stderr names what is built and where, before
    the build; a run from another folder with the same cache builds nothing."""
    mesh = tmp_path / "crate.stl"
    trimesh.creation.box(extents=(1.2, 0.8, 0.5)).export(mesh)
    cache = tmp_path / "cache"
    (tmp_path / "one").mkdir()
    (tmp_path / "two").mkdir()
    lines, total = first_run(cache, tmp_path / "one", mesh)
    at, first = lines[0]
    assert first.startswith(f"building 1 sprite atlas once into {cache} (")
    assert "on this machine)" in first
    assert at < total / 2 or at < 2.0, (at, total)  # said at the start, not after the build
    assert (cache / "crate.json").exists() and not (tmp_path / "one" / "sprites").exists()
    built = {p.name: p.stat().st_mtime_ns for p in cache.iterdir()}
    lines, _ = first_run(cache, tmp_path / "two", mesh)
    assert not any("building" in line for _, line in lines), lines
    assert {p.name: p.stat().st_mtime_ns for p in cache.iterdir()} == built
    assert not (tmp_path / "two" / "sprites").exists()


def test_in_process_run_uses_the_environment_folder(tmp_path, monkeypatch, sprites_dir):
    """The generator's default folder is $SDCOMP_SPRITES: a run with atlases there builds
    none and says nothing about atlases."""
    monkeypatch.setenv(SPRITES_ENV, str(sprites_dir))
    monkeypatch.chdir(tmp_path)
    rc, _, err = cli(["--n", "1", "--size", "64", "--clutter", "0", "--workers", "1",
                      "--no-progress", "--out", tmp_path / "d"])
    assert rc == 0, err
    assert "building" not in err and not (tmp_path / "sprites").exists()


def test_one_progress_bar_over_the_atlases(tmp_path, monkeypatch, capsys):
    """With a progress display (a terminal), atlases built for a run are counted by one bar,
    'sprite atlases', after the announcing line, not by one bar per atlas (atlases built
    small here: the bar is what is tested)."""
    import sdcomp.atlas.cache as cache
    from sdcomp import Generator, GeneratorConfig
    from sdcomp.atlas.poses import PoseGrid
    from sdcomp.atlas.store import AtlasConfig

    real = cache.build_atlas

    def small(mesh, config, **kw):
        return real(mesh, AtlasConfig(size=16, supersample=1, grid=PoseGrid(80.0, 40.0, 40.0)),
                    **kw)

    monkeypatch.setattr(cache, "build_atlas", small)
    meshes = []
    for name, size in (("crate", (1.2, 0.8, 0.5)), ("barrel", (0.6, 0.6, 0.9))):
        meshes.append(tmp_path / f"{name}.stl")
        trimesh.creation.box(extents=size).export(meshes[-1])
    config = GeneratorConfig.from_mapping({"objects": [
        {"mesh": str(m), "category": m.stem} for m in meshes], "clutter": 0})
    Generator(config, tmp_path / "cache", progress=True, build_workers=1)
    err = capsys.readouterr().err
    assert err.startswith(f"building 2 sprite atlases once into {tmp_path / 'cache'} (")
    assert "sprite atlases: 100%" in err and "2/2" in err
    assert "atlas crate" not in err and "atlas barrel" not in err
