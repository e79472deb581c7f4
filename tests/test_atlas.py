"""Tests of the sprite atlas: build, save/load round trip, cache, corruption, contact sheet,
command line, and the canvas fitting the mesh."""

from __future__ import annotations

import hashlib
import json
import math
import os
import re
import struct
import subprocess
import sys
import zipfile
from pathlib import Path

import cv2
import numpy as np
import pytest
import trimesh

from sdcomp.assets.mesh import ColoredMesh
from sdcomp.atlas.cache import ensure_atlas
from sdcomp.atlas.poses import PoseGrid
from sdcomp.atlas.raster import _block_sum, render
from sdcomp.atlas.sheet import contact_sheet, write_contact_sheet
from sdcomp.atlas.store import (
    FORMAT_VERSION,
    AtlasConfig,
    AtlasError,
    atlas_paths,
    build_atlas,
    cache_key,
    load_atlas,
    read_index,
    save_atlas,
)
from sdcomp.errors import UserError

ROOT = Path(__file__).resolve().parents[1]
GRID = PoseGrid(max_off_nadir=40, off_nadir_step=20, max_error=15)
CONFIG = AtlasConfig(size=24, supersample=2, grid=GRID)
ARRAYS = {"poses": np.float64, "alpha": np.uint8, "albedo": np.uint8, "normal": np.int8,
          "height": np.float16, "occlusion": np.uint8}
BG_RGB = (70, 90, 105)
GRID_FLAGS = ["--size", "24", "--supersample", "2", "--max-off-nadir", "40",
              "--off-nadir-step", "20", "--max-error", "15"]
# two colours, every channel non-zero
COLOURS = ((200, 40, 40), (30, 160, 90))


def box_mesh(extents=(0.6, 0.3, 0.2), colours=COLOURS, waterline=-0.05,
             name="box") -> ColoredMesh:
    box = trimesh.creation.box(extents=extents)
    fc = np.empty((len(box.faces), 3), np.uint8)
    fc[0::2], fc[1::2] = colours[0], colours[1 % len(colours)]
    return ColoredMesh(box.vertices, box.faces, fc, waterline, name, closed=True)


def npz_arrays(path: Path) -> dict[str, np.ndarray]:
    with np.load(path, allow_pickle=False) as data:
        return {k: data[k] for k in data.files}


def cli(*args: str) -> subprocess.CompletedProcess:
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    return subprocess.run([sys.executable, "-m", "sdcomp.atlas", *args], capture_output=True,
                          text=True, env=env, timeout=120)


def assert_one_error_line(proc: subprocess.CompletedProcess, *needles: str) -> str:
    assert proc.returncode == 2, (proc.stdout, proc.stderr)
    assert "Traceback" not in proc.stderr
    lines = proc.stderr.splitlines()
    assert len(lines) == 1, proc.stderr
    assert lines[0].startswith("error:"), lines[0]
    for needle in needles:
        assert needle in lines[0], (needle, lines[0])
    return lines[0]


@pytest.fixture(scope="module")
def mesh() -> ColoredMesh:
    return box_mesh()


@pytest.fixture(scope="module")
def atlas(mesh):
    return build_atlas(mesh, CONFIG, workers=1, progress=False)


@pytest.fixture(scope="module")
def saved(atlas, tmp_path_factory):
    out = tmp_path_factory.mktemp("saved")
    npz, idx = save_atlas(atlas, out)
    return npz, idx


@pytest.fixture
def mesh_file(tmp_path) -> Path:
    """A small coloured box as a PLY file with face colours."""
    box = trimesh.creation.box(extents=(0.5, 0.25, 0.2))
    rgba = np.tile(np.array([180, 60, 30, 255], np.uint8), (len(box.faces), 1))
    box.visual.face_colors = rgba
    path = tmp_path / "crate.ply"
    path.write_bytes(box.export(file_type="ply"))
    return path


# --------------------------------------------------------------------------- round trip

def test_npz_holds_exactly_plain_arrays_of_documented_dtypes(atlas, saved):
    npz, _ = saved
    arrays = npz_arrays(npz)  # allow_pickle=False: fails on any object array
    assert set(arrays) == set(ARRAYS)
    p, s = len(CONFIG.grid.poses()), CONFIG.size
    shapes = {"poses": (p, 4), "alpha": (p, s, s), "albedo": (p, s, s, 3),
              "normal": (p, s, s, 3), "height": (p, s, s), "occlusion": (p, s, s)}
    for k, dtype in ARRAYS.items():
        assert arrays[k].dtype == np.dtype(dtype), k
        assert arrays[k].shape == shapes[k], k
    np.testing.assert_array_equal(arrays["poses"], CONFIG.grid.poses())


def test_load_matches_built_atlas(atlas, saved):
    npz, _ = saved
    loaded = load_atlas(npz)
    assert len(loaded) == len(atlas) == len(CONFIG.grid.poses())
    assert loaded.name == atlas.name == "box"
    assert loaded.metres_per_pixel == atlas.metres_per_pixel
    np.testing.assert_array_equal(loaded.poses, atlas.poses)
    np.testing.assert_allclose(loaded.alpha, atlas.alpha, rtol=0, atol=1 / 255)
    np.testing.assert_array_equal(loaded.albedo, atlas.albedo)
    np.testing.assert_allclose(loaded.normal, atlas.normal, rtol=0, atol=1 / 127)
    h16 = np.abs(atlas.height).astype(np.float16)
    assert np.all(np.abs(loaded.height - atlas.height) <= np.spacing(h16).astype(np.float32))
    for a in (atlas, loaded):
        assert a.alpha.dtype == np.float32 and a.normal.dtype == np.float32
        assert a.height.dtype == np.float32
        assert a.alpha.min() >= 0 and a.alpha.max() <= 1
    # the .json and the extension-less name load the same atlas
    for other in (npz.with_suffix(".json"), npz.with_suffix("")):
        np.testing.assert_array_equal(load_atlas(other).alpha, loaded.alpha)


def test_atlas_matches_direct_render_and_mask_is_exact(mesh, atlas, saved):
    """Every stored pose agrees with rendering that pose directly, before and after the
    round trip: same mask, alpha and normals rounded to the nearest 1/255 and 1/127 (so
    within half a step), heights to float16 precision."""
    loaded = load_atlas(saved[0])
    for i, (off, az, roll, pitch) in enumerate(CONFIG.grid.poses()):
        sp = render(mesh, off, az, roll=roll, pitch=pitch, size=CONFIG.size,
                    metres_per_pixel=atlas.metres_per_pixel, supersample=CONFIG.supersample)
        assert sp.mask.any(), i
        for a in (atlas, loaded):
            np.testing.assert_array_equal(a.mask[i], sp.mask)
            np.testing.assert_array_equal(a.mask[i], a.alpha[i] > 0)
            np.testing.assert_array_equal(a.sprite(i).mask, sp.mask)
            np.testing.assert_allclose(a.alpha[i], sp.alpha, rtol=0, atol=0.5 / 255 + 1e-6)
            np.testing.assert_array_equal(a.albedo[i], sp.albedo)
            np.testing.assert_allclose(a.normal[i], sp.normal, rtol=0, atol=0.5 / 127 + 1e-6)
            tol = np.spacing(np.abs(sp.height).astype(np.float16)).astype(np.float32)
            assert np.all(np.abs(a.height[i] - sp.height) <= tol), i


@pytest.mark.parametrize("ss", [1, 2, 3, 4])
def test_block_sums_equal_a_reduction_over_the_blocks(ss):
    """The supersampling's block sums: exact on integers (albedo), within float32 rounding
    of a float64 reduction otherwise, for every supersampling factor."""
    rng = np.random.default_rng(ss)
    ints = rng.integers(0, 256, (5 * ss, 7 * ss, 3)).astype(np.float32)
    floats = rng.normal(size=(5 * ss, 7 * ss)).astype(np.float32)
    for a in (ints, floats):
        ref = a.astype(np.float64).reshape(5, ss, 7, ss, *a.shape[2:]).sum(axis=(1, 3))
        got = _block_sum(a, ss)
        assert got.shape == ref.shape and got.dtype == np.float32
        np.testing.assert_allclose(got, ref, rtol=0, atol=4e-7 * ss * ss * np.abs(a).max())
    np.testing.assert_array_equal(_block_sum(ints, ss), ints.reshape(
        5, ss, 7, ss, 3).astype(np.int64).sum(axis=(1, 3)))


def test_albedo_nonzero_exactly_where_covered(atlas, saved):
    loaded = load_atlas(saved[0])
    assert np.asarray(COLOURS).min() > 0
    for a in (atlas, loaded):
        m = a.mask
        assert m.any() and not m.all()
        assert np.all(a.albedo[m] > 0)  # every channel of every covered pixel
        assert np.all(a.albedo[~m] == 0)
        assert np.all(a.normal[~m] == 0) and np.all(a.height[~m] == 0)
        # covered normals are unit length and face the camera (closed mesh, culled backs)
        n = np.linalg.norm(a.normal[m], axis=-1)
        assert np.all(np.abs(n - 1) < 0.02)
        assert np.all(a.normal[m][:, 2] > 0)
    # only the mesh's colours (and their anti-aliased mixes) appear
    lo, hi = np.min(COLOURS, axis=0), np.max(COLOURS, axis=0)
    assert np.all((atlas.albedo[atlas.mask] >= lo) & (atlas.albedo[atlas.mask] <= hi))


def test_index_contents(mesh, atlas, saved):
    npz, idx = saved
    index = json.loads(idx.read_text())
    assert index == read_index(npz)
    assert index["format_version"] == FORMAT_VERSION
    assert index["metres_per_pixel"] == atlas.metres_per_pixel > 0
    assert index["name"] == index["mesh"]["name"] == mesh.name
    assert index["mesh"]["hash"] == mesh.content_hash()
    assert index["mesh"]["triangles"] == len(mesh.faces)
    np.testing.assert_allclose(index["mesh"]["extents_m"], mesh.extents, atol=1e-6)
    assert index["mesh"]["waterline_m"] == mesh.waterline
    assert index["size_px"] == CONFIG.size and index["supersample"] == CONFIG.supersample
    assert index["grid"] == {"max_off_nadir": 40, "off_nadir_step": 20, "max_error": 15}
    assert [tuple(r) for r in index["rings"]] == GRID.rings()
    poses = npz_arrays(npz)["poses"]
    assert len(index["poses"]) == len(poses)
    np.testing.assert_allclose(np.array(index["poses"]), poses, rtol=0, atol=1e-6)
    assert index["cache_key"] == cache_key(mesh, CONFIG)
    assert index["npz_file"] == npz.name
    assert index["npz_sha256"] == hashlib.sha256(npz.read_bytes()).hexdigest()
    assert index["npz_bytes"] == npz.stat().st_size


# --------------------------------------------------------------------------- determinism

def test_workers_do_not_change_the_result(mesh, tmp_path):
    a1 = build_atlas(mesh, CONFIG, workers=1, progress=False)
    a2 = build_atlas(mesh, CONFIG, workers=2, progress=False)
    npz1, _ = save_atlas(a1, tmp_path / "w1")
    npz2, _ = save_atlas(a2, tmp_path / "w2")
    x1, x2 = npz_arrays(npz1), npz_arrays(npz2)
    assert set(x1) == set(x2) == set(ARRAYS)
    for k in ARRAYS:
        assert x1[k].dtype == x2[k].dtype
        assert x1[k].tobytes() == x2[k].tobytes(), k
    assert a1.index["cache_key"] == a2.index["cache_key"]


# --------------------------------------------------------------------------- cache

def _ensure_after(barrier, folder: Path, results) -> None:
    """Child process: wait for the other, then ensure the slow atlas in ``folder``."""
    barrier.wait()
    _, built = ensure_atlas(box_mesh(), SLOW, folder, workers=1, progress=False)
    results.put(built)


#: an atlas that takes a few tenths of a second to build: two processes started together overlap
SLOW = AtlasConfig(size=48, supersample=2,
                   grid=PoseGrid(max_off_nadir=60, off_nadir_step=20, max_error=12))


def test_processes_sharing_a_folder_build_an_atlas_once(tmp_path):
    """Two processes (two shards of a job array) wanting the same missing atlas at the same
    moment: one builds it, the other waits and loads it; the files are whole."""
    import multiprocessing as mp

    ctx = mp.get_context("fork")
    barrier, results = ctx.Barrier(2), ctx.Queue()
    procs = [ctx.Process(target=_ensure_after, args=(barrier, tmp_path, results))
             for _ in range(2)]
    for proc in procs:
        proc.start()
    built = sorted(results.get(timeout=300) for _ in procs)
    for proc in procs:
        proc.join(timeout=60)
        assert proc.exitcode == 0
    assert built == [False, True]
    assert len(load_atlas(atlas_paths(tmp_path, "box")[1])) > 0
    assert not list(tmp_path.glob("*.tmp"))


def test_ensure_atlas_reuses_then_rebuilds_on_any_change(mesh, tmp_path):
    npz, idx, png = atlas_paths(tmp_path, mesh.name)
    a, built = ensure_atlas(mesh, CONFIG, tmp_path, workers=1, progress=False)
    assert built and npz.is_file() and idx.is_file() and png.is_file()
    before = {p: (p.stat().st_ino, p.stat().st_mtime_ns) for p in (npz, idx, png)}
    key0 = read_index(idx)["cache_key"]

    b, built = ensure_atlas(mesh, CONFIG, tmp_path, workers=1, progress=False)
    assert not built
    assert {p: (p.stat().st_ino, p.stat().st_mtime_ns) for p in (npz, idx, png)} == before
    np.testing.assert_array_equal(b.alpha, a.alpha)
    np.testing.assert_array_equal(b.normal, a.normal)

    # an equal config given with ints instead of floats is the same atlas
    same = AtlasConfig(size=24, supersample=2,
                       grid=PoseGrid(max_off_nadir=40.0, off_nadir_step=20.0, max_error=15.0))
    assert cache_key(mesh, same) == key0
    assert not ensure_atlas(mesh, same, tmp_path, workers=1, progress=False)[1]

    keys = {key0}
    bigger = AtlasConfig(size=32, supersample=2, grid=GRID)
    finer = AtlasConfig(size=24, supersample=3, grid=GRID)
    denser = AtlasConfig(size=24, supersample=2,
                         grid=PoseGrid(max_off_nadir=40, off_nadir_step=20, max_error=12))
    recoloured = box_mesh(colours=((10, 20, 250), (30, 160, 90)))
    resized = box_mesh(extents=(0.9, 0.3, 0.2))
    for m, cfg in ((mesh, bigger), (mesh, finer), (mesh, denser), (recoloured, CONFIG),
                   (resized, CONFIG)):
        assert m.name == mesh.name  # same files, so only the cache key tells them apart
        c, built = ensure_atlas(m, cfg, tmp_path, workers=1, progress=False)
        assert built
        index = read_index(idx)
        assert index["cache_key"] == cache_key(m, cfg)
        assert index["cache_key"] not in keys
        keys.add(index["cache_key"])
        assert index["size_px"] == cfg.size and c.alpha.shape[1:] == (cfg.size, cfg.size)
        assert index["supersample"] == cfg.supersample
        assert len(c) == len(index["poses"]) == len(cfg.grid.poses())
        assert index["mesh"]["hash"] == m.content_hash()
    # the last rebuild really holds the resized box's rendering
    np.testing.assert_array_equal(load_atlas(npz).alpha, c.alpha)
    assert not np.array_equal(c.alpha, a.alpha)

    ino = npz.stat().st_ino
    assert not ensure_atlas(resized, CONFIG, tmp_path, workers=1, progress=False)[1]
    assert npz.stat().st_ino == ino
    _, built = ensure_atlas(resized, CONFIG, tmp_path, force=True, workers=1, progress=False)
    assert built and npz.stat().st_ino != ino
    assert read_index(idx)["cache_key"] == cache_key(resized, CONFIG)


# --------------------------------------------------------------------------- corruption

def _truncate(npz: Path, idx: Path) -> Path:
    data = npz.read_bytes()
    npz.write_bytes(data[: len(data) // 2])
    return npz


def _random_bytes(npz: Path, idx: Path) -> Path:
    npz.write_bytes(np.random.default_rng(0).integers(0, 256, npz.stat().st_size,
                                                       np.uint8).tobytes())
    return npz


def _garbage_index(npz: Path, idx: Path) -> Path:
    idx.write_bytes(b"{not json at all\xff\xfe")
    return idx


def _future_version(npz: Path, idx: Path) -> Path:
    index = json.loads(idx.read_text())
    index["format_version"] = 999
    idx.write_text(json.dumps(index))
    return idx


def _delete_npz(npz: Path, idx: Path) -> Path:
    npz.unlink()
    return npz


def _delete_index(npz: Path, idx: Path) -> Path:
    idx.unlink()
    return idx


def _rehash(npz: Path, idx: Path) -> None:
    index = json.loads(idx.read_text())
    index["npz_sha256"] = hashlib.sha256(npz.read_bytes()).hexdigest()
    index["npz_bytes"] = npz.stat().st_size
    idx.write_text(json.dumps(index))


def _bare_npy(npz: Path, idx: Path) -> Path:
    """A plain .npy array under the npz name, with its checksum in the index."""
    with open(npz, "wb") as fh:
        np.save(fh, np.zeros((3, 4)))
    _rehash(npz, idx)
    return npz


def _bad_deflate(npz: Path, idx: Path) -> Path:
    """Garbage at the start of one member's compressed stream (an invalid deflate block,
    not a CRC mismatch), with the damaged file's checksum in the index."""
    with zipfile.ZipFile(npz) as z:
        info = z.getinfo("alpha.npy")
    assert info.compress_type == zipfile.ZIP_DEFLATED
    raw = bytearray(npz.read_bytes())
    off = info.header_offset
    name_len, extra_len = struct.unpack("<HH", raw[off + 26:off + 30])
    start = off + 30 + name_len + extra_len
    raw[start:start + 16] = b"\xff" * 16
    npz.write_bytes(bytes(raw))
    _rehash(npz, idx)
    return npz


CORRUPTIONS = {"truncated": _truncate, "random_bytes": _random_bytes,
               "garbage_index": _garbage_index, "future_version": _future_version,
               "npz_deleted": _delete_npz, "index_deleted": _delete_index,
               "bare_npy": _bare_npy, "bad_deflate": _bad_deflate}


@pytest.mark.parametrize("how", list(CORRUPTIONS))
def test_corrupt_atlas_is_refused_then_rebuilt(how, mesh, tmp_path):
    original, _ = ensure_atlas(mesh, CONFIG, tmp_path, workers=1, progress=False, sheet=False)
    npz, idx, _ = atlas_paths(tmp_path, mesh.name)
    bad = CORRUPTIONS[how](npz, idx)

    for verify in (True, False):
        with pytest.raises(AtlasError) as err:
            load_atlas(npz, verify=verify)
        assert isinstance(err.value, UserError)
        assert "rebuild" in str(err.value)
        assert str(bad) in str(err.value)
        assert "\n" not in str(err.value)

    assert_one_error_line(cli("info", str(npz)), "rebuild", str(bad))

    atlas, built = ensure_atlas(mesh, CONFIG, tmp_path, workers=1, progress=False, sheet=False)
    assert built
    again = load_atlas(npz)
    np.testing.assert_array_equal(again.alpha, original.alpha)
    np.testing.assert_array_equal(again.albedo, original.albedo)
    assert again.index["format_version"] == FORMAT_VERSION


def test_pickled_object_array_is_refused_without_unpickling(mesh, tmp_path):
    ensure_atlas(mesh, CONFIG, tmp_path, workers=1, progress=False, sheet=False)
    npz, idx, _ = atlas_paths(tmp_path, mesh.name)
    arrays = npz_arrays(npz)
    marker = tmp_path / "unpickled"

    class Payload:  # unpickling it creates `marker`
        def __reduce__(self):
            return os.mkdir, (str(marker),)

    evil = np.empty(1, dtype=object)
    evil[0] = Payload()
    arrays["alpha"] = evil
    with open(npz, "wb") as fh:
        np.savez(fh, allow_pickle=True, **arrays)
    _rehash(npz, idx)

    with pytest.raises(AtlasError) as err:
        load_atlas(npz)
    assert "rebuild" in str(err.value) and str(npz) in str(err.value)
    assert not marker.exists()
    assert_one_error_line(cli("info", str(npz)), "rebuild", str(npz))
    assert not marker.exists()

    # the payload is live: loading with pickles allowed would have run it
    with np.load(npz, allow_pickle=True) as data:
        data["alpha"]
    assert marker.is_dir()
    marker.rmdir()

    _, built = ensure_atlas(mesh, CONFIG, tmp_path, workers=1, progress=False, sheet=False)
    assert built
    assert npz_arrays(npz)["alpha"].dtype == np.uint8
    load_atlas(npz)
    assert not marker.exists()


# --------------------------------------------------------------------------- contact sheet

def _tiles(img: np.ndarray, n: int, cell: int, columns: int):
    for i in range(n):
        r, c = divmod(i, columns)
        yield i, img[r * cell:(r + 1) * cell, c * cell:(c + 1) * cell]


@pytest.mark.parametrize("cell,columns", [(96, 20), (40, 5), (30, None)])
def test_contact_sheet(atlas, tmp_path, cell, columns):
    n = len(atlas)
    if columns is None:  # a column count that fills the last row exactly
        columns = next(c for c in range(n // 2, 0, -1) if n % c == 0)
        assert columns > 1 and n % columns == 0
    rows = math.ceil(n / columns)
    if (cell, columns) == (96, 20):
        path = write_contact_sheet(atlas, tmp_path / "sheet.png")
        bgr = cv2.imread(str(path), cv2.IMREAD_COLOR)
        assert bgr is not None and bgr.dtype == np.uint8
        img = cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB)
        np.testing.assert_array_equal(img, contact_sheet(atlas))  # PNG is lossless
    else:
        img = contact_sheet(atlas, cell=cell, columns=columns)
    assert img.shape == (rows * cell, columns * cell, 3)
    bg = np.array(BG_RGB, np.uint8)
    assert not np.all(img == bg)
    for i, tile in _tiles(img, n, cell, columns):
        # the sprite sits in the middle of its cell, the corners are background
        assert np.any(tile[cell // 2, cell // 2] != bg), i
        np.testing.assert_array_equal(tile[0, 0], bg)
        np.testing.assert_array_equal(tile[0, -1], bg)
        sprite = tile[: cell * 3 // 4]  # above the label
        assert np.any(np.any(sprite != bg, axis=-1)), i
    # cells after the last pose are plain background
    for j in range(n, rows * columns):
        r, c = divmod(j, columns)
        assert np.all(img[r * cell:(r + 1) * cell, c * cell:(c + 1) * cell] == bg), j


# --------------------------------------------------------------------------- command line

def test_cli_build_reuse_info(mesh_file, tmp_path):
    out = tmp_path / "atlases"
    args = ["build", "--mesh", str(mesh_file), "--out", str(out), *GRID_FLAGS]
    first = cli(*args)
    assert first.returncode == 0, first.stderr
    assert "Traceback" not in first.stderr
    npz, idx, png = atlas_paths(out, "crate")
    assert npz.is_file() and idx.is_file() and png.is_file()
    assert "reused" not in first.stdout and "built" in first.stdout
    n = len(GRID.poses())
    assert f"{n} poses" in first.stdout
    assert cv2.imread(str(png)) is not None
    stamp = npz.stat().st_mtime_ns, npz.stat().st_ino

    second = cli(*args)
    assert second.returncode == 0, second.stderr
    assert "reused" in second.stdout
    assert (npz.stat().st_mtime_ns, npz.stat().st_ino) == stamp

    atlas = load_atlas(npz)
    assert len(atlas) == n and atlas.alpha.shape[1:] == (24, 24)
    index = read_index(npz)
    assert index["mesh"]["name"] == "crate"
    assert "--size 24" in index["rebuild_command"]
    # the file's face colour made it into the sprites
    assert np.all(atlas.albedo[atlas.mask] == (180, 60, 30))

    info = cli("info", str(npz))
    assert info.returncode == 0, info.stderr
    m = re.search(r"poses:\s+(\d+)", info.stdout)
    assert m and int(m.group(1)) == n
    assert "ok" in info.stdout and "crate" in info.stdout


BAD_FLAGS = [("--size", "0"), ("--supersample", "0"), ("--max-off-nadir", "120"),
             ("--off-nadir-step", "0"), ("--max-error", "50"), ("--workers", "0")]


@pytest.mark.parametrize("flag,value", BAD_FLAGS + [("--out", None)],
                         ids=[f for f, _ in BAD_FLAGS] + ["--out-file"])
def test_cli_bad_flag(flag, value, mesh_file, tmp_path):
    out = tmp_path / "atlases"
    args = ["build", "--mesh", str(mesh_file), "--out", str(out), *GRID_FLAGS]
    if value is None:  # --out names an existing regular file
        out = tmp_path / "taken.txt"
        out.write_text("keep me")
        args += ["--out", str(out)]
    else:
        args += [flag, value]
    proc = cli(*args)
    assert_one_error_line(proc, flag)
    assert proc.stdout == ""
    if value is None:
        assert out.read_text() == "keep me"
    else:
        assert not out.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(
        ["crate.ply"] + (["taken.txt"] if value is None else []))


# --------------------------------------------------------------------------- canvas fit

@pytest.mark.parametrize("grid", [
    GRID,
    PoseGrid(max_off_nadir=90, off_nadir_step=30, max_error=20),
], ids=["plain", "horizon"])
@pytest.mark.parametrize("extents,waterline", [((0.6, 0.3, 0.2), -0.05),
                                               ((0.2, 0.2, 0.8), -0.4)],
                         ids=["flat", "tall-waterline-at-bottom"])
def test_mesh_fits_canvas_at_every_pose(grid, extents, waterline):
    mesh = box_mesh(extents=extents, waterline=waterline)
    config = AtlasConfig(size=24, supersample=2, grid=grid)
    atlas = build_atlas(mesh, config, workers=1, progress=False)
    diameter = float(np.linalg.norm(extents))  # bounding sphere of a box about its centre
    assert atlas.index["metres_per_pixel"] == atlas.metres_per_pixel
    assert atlas.metres_per_pixel * config.size >= diameter
    m = atlas.mask
    assert m.reshape(len(atlas), -1).any(axis=1).all()  # something at every pose
    ring = m[:, 0, :].any() or m[:, -1, :].any() or m[:, :, 0].any() or m[:, :, -1].any()
    assert not ring
    # and not wastefully small: the widest view spans most of the canvas
    ys, xs = np.nonzero(m.any(axis=0))
    assert max(ys.max() - ys.min(), xs.max() - xs.min()) + 1 >= 0.7 * config.size
