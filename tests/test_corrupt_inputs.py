"""Corrupt and hostile input files: sprite atlases, meshes, config files, background photos
(a decompression bomb among them), and names that try to leave the output folder.

Each gives a clear one-line error naming the file, or is skipped (a damaged atlas cache is
rebuilt) with a warning naming it; nothing is ever unpickled; unknown config keys are refused.
"""

from __future__ import annotations

import json
import logging
import struct
import zlib
from pathlib import Path

import cv2
import numpy as np
import pytest
import trimesh
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from sdcomp.assets.meshfile import load_mesh_file
from sdcomp.atlas.cache import ensure_atlas
from sdcomp.atlas.poses import PoseGrid
from sdcomp.atlas.store import AtlasConfig, AtlasError, load_atlas
from sdcomp.errors import UserError
from sdcomp.render.photos import MAX_PIXELS, Backgrounds

from .conftest import box_mesh
from .datasets import check_intact, cli, one_line_error

pytestmark = pytest.mark.filterwarnings("ignore:__array__ implementation:DeprecationWarning")

TINY = AtlasConfig(size=16, supersample=1, grid=PoseGrid(off_nadir_step=45.0, max_error=30.0))


# --------------------------------------------------------------------------- atlases

@pytest.fixture(scope="module")
def atlas_dir(tmp_path_factory) -> Path:
    d = tmp_path_factory.mktemp("atlas")
    ensure_atlas(box_mesh(), TINY, d, sheet=False)
    return d


class Payload:
    """Unpickling this creates a marker file: proof that something was unpickled."""

    def __init__(self, marker: str):
        self.marker = marker

    def __reduce__(self):
        return (Path(self.marker).touch, ())


def _damaged(atlas_dir: Path, tmp: Path, how: str) -> Path:
    """A copy of the atlas with its npz or json damaged ``how``; returns the index path."""
    d = tmp / how
    d.mkdir()
    for p in atlas_dir.iterdir():
        (d / p.name).write_bytes(p.read_bytes())
    npz, idx = d / "box.npz", d / "box.json"
    data = npz.read_bytes()
    if how == "truncated":
        npz.write_bytes(data[: len(data) // 2])
    elif how == "random":
        npz.write_bytes(np.random.default_rng(1).bytes(len(data)))
    elif how == "empty":
        npz.write_bytes(b"")
    elif how in ("pickle", "pickle-checksummed"):
        arrays = dict(np.load(npz))
        arrays["alpha"] = np.array([Payload(str(tmp / "UNPICKLED"))], dtype=object)
        with open(npz, "wb") as fh:
            np.savez(fh, **arrays)
        if how == "pickle-checksummed":  # even with a matching checksum: not unpickled
            import hashlib
            index = json.loads(idx.read_text())
            index["npz_sha256"] = hashlib.sha256(npz.read_bytes()).hexdigest()
            idx.write_text(json.dumps(index))
    elif how == "json-random":
        idx.write_bytes(np.random.default_rng(2).bytes(200))
    elif how == "json-truncated":
        idx.write_bytes(idx.read_bytes()[:100])
    elif how == "json-wrong-types":
        index = json.loads(idx.read_text())
        index["size_px"] = "big"
        idx.write_text(json.dumps(index))
    elif how == "npy":
        np.save(npz.with_suffix(".npy"), np.zeros(3))
        npz.write_bytes(npz.with_suffix(".npy").read_bytes())
    return idx


DAMAGE = ["truncated", "random", "empty", "pickle", "pickle-checksummed", "json-random",
          "json-truncated", "json-wrong-types", "npy"]


@pytest.mark.parametrize("how", DAMAGE)
def test_damaged_atlas_is_a_clear_error_and_never_unpickled(how, atlas_dir, tmp_path):
    idx = _damaged(atlas_dir, tmp_path, how)
    with pytest.raises(AtlasError) as exc:
        load_atlas(idx)
    msg = str(exc.value)
    assert "\n" not in msg and "box." in msg and "rebuild" in msg, msg
    assert not (tmp_path / "UNPICKLED").exists()


@pytest.mark.parametrize("how", ["truncated", "pickle-checksummed", "json-random"])
def test_damaged_atlas_cache_is_rebuilt_with_a_warning(how, atlas_dir, tmp_path, caplog):
    idx = _damaged(atlas_dir, tmp_path, how)
    with caplog.at_level(logging.WARNING, logger="sdcomp"):
        atlas, built = ensure_atlas(box_mesh(), TINY, idx.parent, sheet=False)
    assert built and len(atlas) > 0
    warned = [r.getMessage() for r in caplog.records if r.levelno == logging.WARNING]
    assert any(str(idx) in w and "rebuilding" in w for w in warned), warned
    assert load_atlas(idx).poses.shape == atlas.poses.shape  # the cache is whole again
    assert not (tmp_path / "UNPICKLED").exists()


# --------------------------------------------------------------------------- meshes

MESH_SUFFIXES = (".stl", ".obj", ".ply", ".glb", ".gltf", ".off")


@pytest.fixture(scope="module")
def good_meshes(tmp_path_factory) -> dict[str, bytes]:
    d = tmp_path_factory.mktemp("meshes")
    box = trimesh.creation.box(extents=(1.0, 0.6, 0.3))
    out = {}
    for s in MESH_SUFFIXES:
        box.export(d / f"box{s}")
        out[s] = (d / f"box{s}").read_bytes()
    return out


def _check_mesh_file(path: Path) -> None:
    try:
        mesh = load_mesh_file(path)
    except UserError as e:
        msg = str(e)
        assert "\n" not in msg and path.name in msg, msg
        return
    assert len(mesh.faces) > 0 and np.isfinite(mesh.vertices).all()
    assert mesh.faces.min() >= 0 and mesh.faces.max() < len(mesh.vertices)


@settings(max_examples=60, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(suffix=st.sampled_from(MESH_SUFFIXES), cut=st.floats(0, 1),
       flips=st.lists(st.tuples(st.floats(0, 1), st.integers(0, 255)), max_size=8),
       junk=st.binary(max_size=64))
def test_truncated_or_garbled_meshes(good_meshes, tmp_path, suffix, cut, flips, junk):
    data = bytearray(good_meshes[suffix][: int(len(good_meshes[suffix]) * cut)] + junk)
    for where, byte in flips:
        if data:
            data[int(where * (len(data) - 1))] = byte
    path = tmp_path / f"fuzzed{suffix}"
    path.write_bytes(bytes(data))
    _check_mesh_file(path)


HOSTILE_MESHES = {
    "huge_count.stl": b"\0" * 80 + struct.pack("<I", 2**31) + b"\0" * 100,
    "huge_vertex_count.ply": (b"ply\nformat binary_little_endian 1.0\nelement vertex "
                              b"1000000000000\nproperty float x\nproperty float y\nproperty "
                              b"float z\nend_header\n" + b"\0" * 50),
    "bad_index.ply": (b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty "
                      b"float y\nproperty float z\nelement face 1\nproperty list uchar int "
                      b"vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 99\n"),
    "bad_index.obj": b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n",
    "nan.obj": b"v nan 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
    "huge_counts.off": b"OFF\n1000000000 1000000000 0\n0 0 0\n",
    "escaping_buffer.gltf": (b'{"asset":{"version":"2.0"},"buffers":[{"uri":'
                             b'"../../../../etc/passwd","byteLength":100}]}'),
    "huge_chunk.glb": b"glTF" + struct.pack("<III", 2, 2**31, 2**31 - 100) + b"JSON{}",
    "random.stl": bytes(range(256)) * 4,
}


@pytest.mark.parametrize("name", sorted(HOSTILE_MESHES))
def test_hostile_mesh_files(name, tmp_path):
    path = tmp_path / name
    path.write_bytes(HOSTILE_MESHES[name])
    _check_mesh_file(path)


def test_hostile_mesh_through_the_generator(tmp_path, sprites_dir):
    path = tmp_path / "bad_index.ply"
    path.write_bytes(HOSTILE_MESHES["bad_index.ply"])
    out = tmp_path / "out"
    rc, _, err = cli(["--n", "2", "--size", "32", "--object", path, "--out", out,
                      "--sprites", sprites_dir, "--no-progress"])
    assert rc == 2
    one_line_error(err)
    assert "--object" in err and "bad_index.ply" in err
    assert not out.exists()


# --------------------------------------------------------------------------- config files

@pytest.mark.parametrize("text,key", [
    ("bogus = 1\n", "bogus"),
    ("[generate]\naltitude = 10\nbogus_key = 2\n", "bogus_key"),
    ('objects = [{mesh = "bluerov2", colour = "red"}]\n', "colour"),
    ("altitude = 10\n[other]\nx = 1\n", "other"),
])
def test_unknown_config_keys_are_refused(text, key, tmp_path, sprites_dir):
    conf = tmp_path / "c.toml"
    conf.write_text(text)
    out = tmp_path / "out"
    rc, _, err = cli(["--config", conf, "--n", "1", "--size", "16", "--out", out,
                      "--sprites", sprites_dir, "--no-progress"])
    assert rc == 2
    one_line_error(err)
    assert key in err
    assert not out.exists()


@pytest.mark.parametrize("data", [b"\xff\xfe\x00bad", b"altitude = [\n", b"\x00" * 10,
                                  b"n = 99999999999999999999\n",
                                  np.random.default_rng(3).bytes(64)])
def test_corrupt_config_file(data, tmp_path, sprites_dir):
    conf = tmp_path / "c.toml"
    conf.write_bytes(data)
    rc, _, err = cli(["--config", conf, "--n", "1", "--size", "16", "--out", tmp_path / "o",
                      "--sprites", sprites_dir, "--no-progress"])
    assert rc == 2
    one_line_error(err)
    assert "--config" in err or "--n" in err


# --------------------------------------------------------------------------- background photos

def _png_header(width: int, height: int, idat: bytes = b"") -> bytes:
    """A PNG claiming ``width`` x ``height`` RGB pixels, with ``idat`` as its only data."""
    def chunk(kind: bytes, body: bytes) -> bytes:
        return (struct.pack(">I", len(body)) + kind + body
                + struct.pack(">I", zlib.crc32(kind + body) & 0xFFFFFFFF))
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 2,
                                                               0, 0, 0))
            + chunk(b"IDAT", idat) + chunk(b"IEND", b""))


def _photo(path: Path, seed: int = 0) -> None:
    rng = np.random.default_rng(seed)
    cv2.imwrite(str(path), rng.integers(0, 255, (60, 80, 3), dtype=np.uint8))


BOMB_SIDE = 60_000  # 3.6 gigapixels claimed by a file of a few hundred bytes


@pytest.mark.parametrize("case", ["random.jpg", "random.png", "truncated.jpg",
                                  "truncated.png", "bomb.png", "bomb-compressed.png",
                                  "empty.jpg", "text.png"])
def test_corrupt_background_photo_is_named(case, tmp_path, sprites_dir):
    bg = tmp_path / "bg"
    bg.mkdir()
    _photo(bg / "good.jpg")
    path = bg / case
    if case.startswith("random"):
        path.write_bytes(np.random.default_rng(4).bytes(2000))
    elif case.startswith("truncated"):
        ok = tmp_path / f"whole{path.suffix}"
        _photo(ok, 1)
        path.write_bytes(ok.read_bytes()[: ok.stat().st_size // 2])
    elif case == "bomb.png":
        path.write_bytes(_png_header(BOMB_SIDE, BOMB_SIDE))
    elif case == "bomb-compressed.png":
        # 200 real rows of zeros (a few kB compressed) under the 3.6 gigapixel header
        z = zlib.compressobj(9)
        row = b"\0" * (1 + 3 * BOMB_SIDE)
        idat = b"".join(z.compress(row) for _ in range(200)) + z.flush()
        path.write_bytes(_png_header(BOMB_SIDE, BOMB_SIDE, idat))
    elif case == "empty.jpg":
        path.write_bytes(b"")
    else:
        path.write_text("not an image")
    out = tmp_path / "out"
    rc, _, err = cli(["--n", "4", "--size", "32", "--clutter", "0", "--backgrounds", bg,
                      "--out", out, "--sprites", sprites_dir, "--workers", 1,
                      "--no-progress"])
    assert rc == 2, err
    one_line_error(err)
    assert "--backgrounds" in err and case in err, err
    if case.startswith("bomb"):
        assert "megapixels" in err
    # refused before anything was written: a truncated photo too (its end marker is
    # checked with the header, not when the photo is first drawn)
    assert not out.exists() or not any(out.rglob("*")), sorted(out.rglob("*"))


def test_bomb_is_refused_before_decoding(tmp_path):
    bg = tmp_path / "bg"
    bg.mkdir()
    (bg / "a.png").write_bytes(_png_header(20_000, 20_000))
    with pytest.raises(UserError, match="megapixels"):
        Backgrounds(bg)
    assert 20_000 * 20_000 > MAX_PIXELS


# --------------------------------------------------------------------------- paths

def test_names_in_the_config_never_leave_the_output_folder(tmp_path, sprites_dir):
    """Category names, mesh file names and clutter with path-like text: every file the run
    writes lies in --out (or the sprites folder)."""
    work = tmp_path / "work"
    meshes = work / "meshes"
    meshes.mkdir(parents=True)
    mesh = meshes / "..%2f..%2fevil name ..stl"
    trimesh.creation.box(extents=(1.0, 0.6, 0.3)).export(mesh)
    conf = work / "c.toml"
    conf.write_text(
        "objects = [\n"
        '  {mesh = "bluerov2", category = "../../escaped"},\n'
        f'  {{mesh = "{mesh.as_posix()}", category = "/etc/passwd"}},\n'
        "]\n"
        'format = ["coco", "yolo"]\n')
    out = work / "out"
    sprites = work / "sprites"
    for p in sprites_dir.iterdir():  # reuse the session's atlases (a copy: it is written)
        if p.is_file():
            (sprites / p.name).parent.mkdir(exist_ok=True)
            (sprites / p.name).write_bytes(p.read_bytes())
    before = {p for p in tmp_path.rglob("*")}
    rc, _, err = cli(["--config", conf, "--n", "3", "--size", "48", "--clutter", "0",
                      "--altitude", "4", "--out", out, "--sprites", sprites, "--workers", 1,
                      "--no-progress"])
    assert rc == 0, err
    new = {p for p in tmp_path.rglob("*")} - before
    outside = [p for p in new if out not in p.parents and sprites not in p.parents
               and p not in (out, sprites)]
    assert not outside, outside
    assert not (tmp_path / "escaped").exists() and not (work / "escaped").exists()
    cats = json.loads((out / "annotations" / "instances_train.json").read_text())["categories"]
    assert [c["name"] for c in cats] == ["../../escaped", "/etc/passwd"]
    assert check_intact(out) == 3
