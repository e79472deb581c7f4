"""An input that would need more memory than the machine has is refused before anything is
allocated, with the figure (sdcomp.util.memory, sdcomp.run.frame_memory,
sdcomp.assets.mesh_faces). ``SDCOMP_MEMORY_BYTES`` pretends a small machine."""

from __future__ import annotations

import os
import struct
from pathlib import Path

import pytest
import trimesh

from sdcomp.assets.mesh_faces import claimed_faces
from sdcomp.assets.meshfile import load_mesh_file
from sdcomp.atlas.budget import build_bytes, fitting_workers
from sdcomp.cli.atlas import main as atlas_main
from sdcomp.cli.mesh import main as mesh_main
from sdcomp.cli.video import main as video_main
from sdcomp.errors import UserError
from sdcomp.run.frame_memory import run_bytes
from sdcomp.util import memory

from .datasets import cli, generate

SMALL = "2G"  # the pretend machine of the generator tests
BILLION = 10**9


@pytest.fixture
def small_machine(monkeypatch):
    monkeypatch.setenv(memory.ENV, SMALL)


def one_line(err: str) -> str:
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), err
    assert "Traceback" not in err
    return lines[0]


# ------------------------------------------------------------------------ the machine


def test_machine_bytes_is_the_override_or_at_most_the_physical_memory(monkeypatch):
    monkeypatch.delenv(memory.ENV, raising=False)
    physical = os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    assert 0 < memory.machine_bytes() <= physical
    for text, value in [("2G", 2 << 30), ("1.5GiB", 3 << 29), ("512m", 512 << 20),
                        ("123456789", 123456789)]:
        monkeypatch.setenv(memory.ENV, text)
        assert memory.machine_bytes() == value


@pytest.mark.parametrize("text", ["lots", "0", "-2G", "2X"])
def test_a_bad_override_is_named(monkeypatch, text):
    monkeypatch.setenv(memory.ENV, text)
    with pytest.raises(UserError, match=memory.ENV):
        memory.machine_bytes()


def test_a_lower_cgroup_limit_wins(monkeypatch, tmp_path):
    monkeypatch.delenv(memory.ENV, raising=False)
    (tmp_path / "v2").write_text("1073741824\n")
    (tmp_path / "v1").write_text("9223372036854771712\n")  # v1's "no limit"
    (tmp_path / "none").write_text("max\n")
    files = [tmp_path / "v1", tmp_path / "none", tmp_path / "v2", tmp_path / "missing"]
    monkeypatch.setattr(memory, "_cgroup_limit_files", lambda: files)
    assert memory.machine_bytes() == 1 << 30
    monkeypatch.setattr(memory, "_cgroup_limit_files", lambda: files[:2])
    assert memory.machine_bytes() > 1 << 30  # no limit: the physical memory


def test_check_fits_message(monkeypatch):
    monkeypatch.setenv(memory.ENV, "8G")
    memory.check_fits(8 << 30, "this", "that")
    with pytest.raises(UserError) as e:
        memory.check_fits(int(14.2 * (1 << 30)), "a frame", "use a smaller one")
    assert str(e.value) == ("a frame needs about 14.2 GiB, more than this machine's 8.0 GiB; "
                            "use a smaller one")


# ------------------------------------------------------------------------ frames


def test_a_huge_frame_is_refused_before_anything_is_written(small_machine, tmp_path,
                                                            sprites_dir):
    out = tmp_path / "out"
    rc, _, err = generate(["--n", "1", "--size", "8000"], out, sprites_dir)
    line = one_line(err)
    assert rc == 2
    assert "8000x8000" in line and "1 worker" in line and "GiB" in line
    assert "this machine's 2.0 GiB" in line and "smaller frames" in line
    assert not out.exists()


def test_too_many_workers_are_refused_naming_how_many_fit(small_machine, tmp_path,
                                                          sprites_dir):
    out = tmp_path / "out"
    rc, _, err = generate(["--n", "8", "--size", "2000"], out, sprites_dir, workers=6)
    line = one_line(err)
    assert rc == 2
    assert "2000x2000" in line and "6 workers" in line and "--workers" in line
    assert not out.exists()


def test_workers_beyond_the_images_do_not_count(small_machine, tmp_path, sprites_dir):
    """One image is rendered in this process whatever --workers says: the estimate is one
    worker's (it would be refused with six busy workers)."""
    assert run_bytes(1500, 1500, 6) > 2 << 30 > run_bytes(1500, 1500, 1)
    rc, _, err = generate(["--n", "1", "--size", "1500", "--altitude", "50"], tmp_path / "o",
                          sprites_dir, workers=6)
    assert rc == 0, err


def test_a_normal_run_still_runs_on_the_small_machine(small_machine, tmp_path, sprites_dir):
    rc, _, err = generate(["--n", "4", "--size", "128"], tmp_path / "out", sprites_dir,
                          workers=2)
    assert rc == 0, err
    assert len(list((tmp_path / "out" / "images").rglob("*.jpg"))) == 4


def test_the_huge_frame_benchmark_fits_the_development_machine():
    """30000 x 30000 with one worker (benchmarks: test_bench_huge_frame, 5.6 GiB) fits on
    the 24 GiB development machine: the estimate stays under 8 GiB."""
    assert run_bytes(30_000, 30_000, 1) < 8 << 30


def test_huge_video_frames_are_refused(small_machine, tmp_path, sprites_dir):
    out = tmp_path / "clips"
    rc, _, err = cli(["--sequences", "1", "--frames", "2", "--size", "12000", "--out", out,
                      "--sprites", sprites_dir, "--workers", 1, "--no-progress"],
                     entry=video_main)
    line = one_line(err)
    assert rc == 2 and "12000x12000 px video frames" in line
    assert not out.exists()


# ------------------------------------------------------------------------ meshes

PLY_BILLION = (b"ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\n"
               b"property float y\nproperty float z\nelement face 1000000000\nproperty list "
               b"uchar int vertex_indices\nend_header\n")
GLB_BILLION = (b'{"asset":{"version":"2.0"},"accessors":[{"count":3000000000,'
               b'"componentType":5125,"type":"SCALAR"}],"meshes":[{"primitives":'
               b'[{"attributes":{},"indices":0}]}]}')


def _glb(json_chunk: bytes) -> bytes:
    json_chunk += b" " * (-len(json_chunk) % 4)
    return (b"glTF" + struct.pack("<II", 2, 20 + len(json_chunk))
            + struct.pack("<I", len(json_chunk)) + b"JSON" + json_chunk)


@pytest.mark.parametrize("name,data,faces", [
    ("billion.ply", PLY_BILLION, "1,000,000,000"),
    ("billion.glb", _glb(GLB_BILLION), "1,000,000,000"),
    ("billion.off", b"OFF\n3 1000000000 0\n", "1,000,000,000"),
])
def test_a_mesh_header_claiming_huge_counts_is_refused_by_the_count(small_machine, tmp_path,
                                                                    name, data, faces):
    """The header's count is refused before trimesh reads the file (which holds no faces at
    all: a parse would fail with another message)."""
    path = tmp_path / name
    path.write_bytes(data)
    with pytest.raises(UserError) as e:
        load_mesh_file(path)
    msg = str(e.value)
    assert f"({faces} faces" in msg and name in msg and "needs about" in msg, msg
    assert "more than this machine's 2.0 GiB" in msg and "simplify it" in msg
    rc, _, err = cli(["info", path], entry=mesh_main)
    assert rc == 2 and faces in one_line(err)


def test_a_binary_stl_of_ten_million_faces_is_refused_unread(small_machine, tmp_path):
    """A binary STL's count is refused before a byte of its 500 MB is read (a sparse file
    of zeros: nothing on disk); a count the file's size cannot hold is left to the reader,
    whose message says what is wrong."""
    path = tmp_path / "ten_million.stl"
    with path.open("wb") as f:
        f.write(b"\0" * 80 + struct.pack("<I", 10**7))
        f.truncate(84 + 50 * 10**7)
    with pytest.raises(UserError, match=r"\(10,000,000 faces, about 800 bytes each"):
        load_mesh_file(path)
    short = tmp_path / "short.stl"
    short.write_bytes(b"\0" * 80 + struct.pack("<I", 10**8) + b"\0" * 500)
    assert claimed_faces(short, ".stl") == 10
    with pytest.raises(UserError) as e:
        load_mesh_file(short)
    assert "needs about" not in str(e.value)  # the reader's own message


def test_a_long_obj_is_counted_by_streaming(monkeypatch, tmp_path):
    monkeypatch.setenv(memory.ENV, "256M")  # room for about 125,000 faces
    path = tmp_path / "long.obj"
    path.write_bytes(b"v 0 0 0\nv 1 0 0\nv 0 1 0\n" + b"f 1 2 3\n" * 200_000)
    assert claimed_faces(path, ".obj") == 200_000
    with pytest.raises(UserError, match=r"\(200,000 faces"):
        load_mesh_file(path)


def test_an_ascii_stl_is_counted_by_streaming(tmp_path):
    path = tmp_path / "box.stl"
    box = trimesh.creation.box()
    path.write_bytes(trimesh.exchange.stl.export_stl_ascii(box).encode())
    assert claimed_faces(path, ".stl") == len(box.faces) == 12


@pytest.mark.parametrize("suffix", [".ply", ".stl", ".obj", ".glb", ".off"])
def test_a_real_small_mesh_still_loads_on_the_small_machine(monkeypatch, tmp_path, suffix):
    monkeypatch.setenv(memory.ENV, "256M")
    path = tmp_path / f"box{suffix}"
    trimesh.creation.box(extents=(2.0, 1.0, 0.5)).export(path)
    assert claimed_faces(path, suffix) == 12
    mesh = load_mesh_file(Path(path))
    assert len(mesh.faces) == 12


# ------------------------------------------------------------------------ atlases


def test_an_atlas_build_uses_the_workers_that_fit(small_machine):
    held, each = build_bytes(11_372, 256, 4, 188)
    fit = fitting_workers("bluerov2", 11_372, 256, 4, 188, 8)
    assert 1 <= fit < 8
    assert held + fit * each <= 2 << 30 < held + (fit + 1) * each
    assert fitting_workers("bluerov2", 11_372, 128, 4, 188, 2) == 2  # the default fits


def test_an_atlas_too_big_for_the_machine_is_refused_before_rendering(small_machine, tmp_path):
    rc, _, err = cli(["build", "--mesh", "bluerov2", "--size", "1024", "--supersample", "8",
                      "--out", tmp_path / "sprites"], entry=atlas_main)
    line = one_line(err)
    assert rc == 2 and "188 poses of 1024 px at supersample 8" in line and "GiB" in line
    assert not list((tmp_path / "sprites").glob("*.npz"))
