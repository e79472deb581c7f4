"""Tests for reading user mesh files (sdcomp.meshfile) and the mesh CLI (sdcomp.mesh)."""

from __future__ import annotations

import math
import os
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pytest
import trimesh
from PIL import Image

from sdcomp.assets import bluerov2
from sdcomp.assets.export import export_mesh
from sdcomp.assets.library import MeshSpec
from sdcomp.assets.mesh import ColoredMesh
from sdcomp.assets.meshfile import (
    DEFAULT_COLOR,
    DEFAULT_WATERLINE_FRACTION,
    MAX_EXTENT_M,
    MIN_EXTENT_M,
    UNITS,
    load_mesh_file,
)
from sdcomp.errors import UserError

ROOT = Path(__file__).resolve().parents[1]
SIZE = np.array([2.0, 1.0, 0.5])  # the test box: length x width x height in the file's units
RED = (200, 40, 40)
BLUE = (30, 60, 220)
# z-up (ours) to y-up (glTF's): (x, y, z) -> (x, z, -y)
Z_UP_TO_Y_UP = np.array([[1, 0, 0, 0], [0, 0, 1, 0], [0, -1, 0, 0], [0, 0, 0, 1.0]])


# ----------------------------------------------------------------------------- helpers


def _box(extents=SIZE) -> trimesh.Trimesh:
    return trimesh.creation.box(extents=np.asarray(extents, float))


def _rgba(rgb) -> list[int]:
    return [*rgb, 255]


def _split_colours(mesh: trimesh.Trimesh) -> np.ndarray:
    """(F, 4) RED for faces whose centroid has x > 0, BLUE for the others."""
    cx = mesh.vertices[mesh.faces][:, :, 0].mean(axis=1)
    return np.where(cx[:, None] > 0, _rgba(RED), _rgba(BLUE)).astype(np.uint8)


def _face_coloured_box() -> trimesh.Trimesh:
    b = _box()
    return trimesh.Trimesh(b.vertices, b.faces, face_colors=_split_colours(b), process=False)


def _vertex_coloured_box(y_up: bool = False) -> trimesh.Trimesh:
    """The split-coloured box with one vertex per face corner (colours per vertex)."""
    b = _box()
    colours = _split_colours(b)
    verts = b.vertices[b.faces].reshape(-1, 3)
    faces = np.arange(len(verts)).reshape(-1, 3)
    m = trimesh.Trimesh(verts, faces, vertex_colors=np.repeat(colours, 3, axis=0),
                        process=False)
    if y_up:
        m.apply_transform(Z_UP_TO_Y_UP)
    return m


def _write_gltf(mesh: trimesh.Trimesh, path: Path) -> Path:
    """Write ``mesh`` as a .gltf named ``path`` with its buffers beside it."""
    files = mesh.export(file_type="gltf")
    (name,) = [k for k in files if k.endswith(".gltf")]
    for key, data in files.items():
        (path.parent / (path.name if key == name else key)).write_bytes(data)
    return path


def _write(fmt: str, folder: Path) -> Path:
    """The test box as ``box.<fmt>``; colours where the format carries them."""
    path = folder / f"box.{fmt}"
    if fmt in ("stl", "off"):
        _box().export(str(path))
    elif fmt == "ply":
        _face_coloured_box().export(str(path))
    elif fmt == "obj":
        _vertex_coloured_box().export(str(path))
    elif fmt == "glb":
        _vertex_coloured_box(y_up=True).export(str(path))
    elif fmt == "gltf":
        _write_gltf(_vertex_coloured_box(y_up=True), path)
    else:
        raise AssertionError(fmt)
    return path


def _centroids(mesh: ColoredMesh) -> np.ndarray:
    return mesh.vertices[mesh.faces].mean(axis=1)


def _signed_volume(mesh: ColoredMesh) -> float:
    tri = mesh.vertices[mesh.faces]
    return float(np.einsum("ij,ij->i", tri[:, 0], np.cross(tri[:, 1], tri[:, 2])).sum() / 6)


def _colour_set(mesh: ColoredMesh) -> set[tuple[int, ...]]:
    return {tuple(int(c) for c in row) for row in np.unique(mesh.face_colors, axis=0)}


def _assert_centred(mesh: ColoredMesh) -> None:
    lo, hi = mesh.bounds
    np.testing.assert_allclose(lo + hi, 0.0, atol=1e-9 * max(1.0, float(hi.max())))
    np.testing.assert_allclose(lo, -hi, rtol=1e-9)


def _run_cli(*args: str, cwd: Path) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    return subprocess.run([sys.executable, "-m", "sdcomp.mesh", *args], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=60)


def _run_clis(calls: dict[str, tuple[str, ...]], cwd: Path) -> dict:
    """Run several CLI commands at once (they spend most of their time importing)."""
    with ThreadPoolExecutor(max_workers=4) as pool:
        futures = {key: pool.submit(_run_cli, *args, cwd=cwd) for key, args in calls.items()}
        return {key: f.result() for key, f in futures.items()}


def _assert_cli_error(proc: subprocess.CompletedProcess, *needles: str) -> str:
    """Exit 2, one ``error:`` line on stderr, no traceback; returns that line."""
    assert proc.returncode == 2, (proc.returncode, proc.stdout, proc.stderr)
    assert "Traceback" not in proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1, proc.stderr
    assert lines[0].startswith("error: "), proc.stderr
    for needle in needles:
        assert needle in lines[0], (needle, lines[0])
    return lines[0]


# ----------------------------------------------------------------------------- formats


@pytest.mark.parametrize("fmt", ["stl", "obj", "ply", "glb", "gltf", "off"])
def test_each_format_loads_with_size_centre_and_colours(tmp_path, fmt):
    path = _write(fmt, tmp_path)
    mesh = load_mesh_file(path)
    assert isinstance(mesh, ColoredMesh)
    assert len(mesh.faces) == 12
    assert mesh.face_colors.shape == (12, 3)
    assert mesh.name == "box"
    np.testing.assert_allclose(mesh.extents, SIZE, rtol=1e-6)
    _assert_centred(mesh)
    if fmt in ("stl", "off"):  # no colours in the file: the default grey
        assert _colour_set(mesh) == {DEFAULT_COLOR}
    else:  # the file's colours, on the faces they were on (x is kept by every up axis)
        right = _centroids(mesh)[:, 0] > 0
        assert right.any() and (~right).any()
        assert (mesh.face_colors[right] == RED).all()
        assert (mesh.face_colors[~right] == BLUE).all()


@pytest.mark.parametrize("fmt", ["stl", "off", "ply", "obj", "glb"])
def test_forced_colour_colours_every_face(tmp_path, fmt):
    mesh = load_mesh_file(_write(fmt, tmp_path), color=(1, 2, 3))
    assert len(mesh.faces) == 12
    assert (mesh.face_colors == (1, 2, 3)).all()


def test_ply_vertex_colours_are_averaged_per_face(tmp_path):
    b = _box()
    rng = np.random.default_rng(7)
    vc = np.concatenate([rng.integers(0, 256, (len(b.vertices), 3)),
                         np.full((len(b.vertices), 1), 255)], axis=1).astype(np.uint8)
    trimesh.Trimesh(b.vertices, b.faces, vertex_colors=vc, process=False).export(
        str(tmp_path / "vc.ply"))
    mesh = load_mesh_file(tmp_path / "vc.ply")
    expected = np.rint(vc[b.faces, :3].astype(float).mean(axis=1)).astype(np.uint8)
    np.testing.assert_array_equal(mesh.face_colors, expected)
    assert mesh.closed  # one shared-vertex box: a closed surface


def test_obj_material_colours(tmp_path):
    """An OBJ whose faces use two MTL materials (Kd) gets those colours."""
    kd = {"hull": (0.8, 0.1, 0.1), "deck": (0.1, 0.2, 0.9)}
    (tmp_path / "boat.mtl").write_text(
        "".join(f"newmtl {n}\nKd {r} {g} {b}\n" for n, (r, g, b) in kd.items()))
    b = _box()
    top = b.face_normals[:, 2] > 0.5
    lines = ["mtllib boat.mtl"] + [f"v {x:.9g} {y:.9g} {z:.9g}" for x, y, z in b.vertices]
    for name, sel in (("hull", ~top), ("deck", top)):
        lines.append(f"usemtl {name}")
        lines += [f"f {i + 1} {j + 1} {k + 1}" for i, j, k in b.faces[sel]]
    (tmp_path / "boat.obj").write_text("\n".join(lines) + "\n")

    mesh = load_mesh_file(tmp_path / "boat.obj")
    np.testing.assert_allclose(mesh.extents, SIZE, rtol=1e-6)
    _assert_centred(mesh)
    assert len(mesh.faces) == 12
    expected = {n: np.rint(np.array(c) * 255) for n, c in kd.items()}
    cz = _centroids(mesh)[:, 2]
    up = cz > SIZE[2] / 2 - 1e-9  # the top faces (z = +h/2)
    assert up.sum() == top.sum()
    np.testing.assert_allclose(mesh.face_colors[up], np.tile(expected["deck"], (up.sum(), 1)),
                               atol=1)
    np.testing.assert_allclose(mesh.face_colors[~up],
                               np.tile(expected["hull"], ((~up).sum(), 1)), atol=1)


def test_glb_material_base_colour(tmp_path):
    b = _box()
    b.apply_transform(Z_UP_TO_Y_UP)
    colour = (255, 128, 0)
    b.visual = trimesh.visual.TextureVisuals(
        material=trimesh.visual.material.PBRMaterial(baseColorFactor=_rgba(colour)))
    b.export(str(tmp_path / "pbr.glb"))
    mesh = load_mesh_file(tmp_path / "pbr.glb")
    np.testing.assert_allclose(mesh.extents, SIZE, rtol=1e-6)
    assert _colour_set(mesh) == {colour}


def test_glb_texture_colour_sampled(tmp_path):
    b = _box()
    colour = (10, 120, 240)
    b.visual = trimesh.visual.TextureVisuals(
        uv=np.full((len(b.vertices), 2), 0.5),
        material=trimesh.visual.material.PBRMaterial(
            baseColorTexture=Image.new("RGB", (4, 4), colour)))
    b.export(str(tmp_path / "tex.glb"))
    mesh = load_mesh_file(tmp_path / "tex.glb", up="z")
    np.testing.assert_allclose(mesh.extents, SIZE, rtol=1e-6)
    assert _colour_set(mesh) == {colour}


def test_latin1_text_files_load(tmp_path):
    """Text formats with a non-UTF-8 byte (a Latin-1 comment or name) still load."""
    b = _box()
    obj = "# mod\xe8le bateau\n" + "".join(f"v {x:.9g} {y:.9g} {z:.9g}\n" for x, y, z in b.vertices)
    obj += "".join(f"f {i + 1} {j + 1} {k + 1}\n" for i, j, k in b.faces)
    (tmp_path / "l.obj").write_bytes(obj.encode("latin-1"))
    stl = b.export(file_type="stl_ascii").replace("solid", "solid c\xf4t\xe9", 1)
    (tmp_path / "l.stl").write_bytes(stl.encode("latin-1"))
    for name in ("l.obj", "l.stl"):
        mesh = load_mesh_file(tmp_path / name)
        assert len(mesh.faces) == 12
        np.testing.assert_allclose(mesh.extents, SIZE, rtol=1e-6)


# ----------------------------------------------------------------------------- units, up


@pytest.mark.parametrize("units", list(UNITS))
def test_units_scale_extents(tmp_path, units):
    path = _write("ply", tmp_path)
    mesh = load_mesh_file(path, units=units)
    np.testing.assert_allclose(mesh.extents, SIZE * UNITS[units], rtol=1e-6)
    _assert_centred(mesh)


def test_mm_is_a_thousandth_of_m(tmp_path):
    path = _write("stl", tmp_path)
    in_m = load_mesh_file(path, units="m").extents
    in_mm = load_mesh_file(path, units="mm").extents
    np.testing.assert_allclose(in_mm * 1000, in_m, rtol=1e-9)


@pytest.mark.parametrize("up", ["x", "y", "z", "-x", "-y", "-z"])
def test_up_axis_goes_to_plus_z(tmp_path, up):
    """The file's ``up`` axis becomes +z: its extent is the height, the faces on its
    positive side end up on top, and the rotation is proper (outward normals stay out)."""
    file_ext = np.array([0.6, 2.0, 1.2])
    b = _box(file_ext)
    axis = "xyz".index(up[-1])
    sign = -1.0 if up.startswith("-") else 1.0
    on_top = sign * b.vertices[b.faces][:, :, axis].mean(axis=1) > 0
    colours = np.where(on_top[:, None], _rgba(RED), _rgba(BLUE)).astype(np.uint8)
    trimesh.Trimesh(b.vertices, b.faces, face_colors=colours, process=False).export(
        str(tmp_path / "long.ply"))

    mesh = load_mesh_file(tmp_path / "long.ply", up=up)
    assert mesh.extents[2] == pytest.approx(file_ext[axis], rel=1e-6)  # PLY has float32
    assert sorted(mesh.extents) == pytest.approx(sorted(file_ext), rel=1e-6)
    _assert_centred(mesh)
    red = (mesh.face_colors == RED).all(axis=1)
    assert red.sum() == on_top.sum() > 0
    cz = _centroids(mesh)[:, 2]
    assert (cz[red] > 0).all() and (cz[~red] < 0).all()
    assert _signed_volume(mesh) == pytest.approx(np.prod(file_ext), rel=1e-6)


def test_long_along_y_with_up_y_is_long_along_z(tmp_path):
    _box([0.5, 2.0, 1.0]).export(str(tmp_path / "tall.stl"))
    assert int(np.argmax(load_mesh_file(tmp_path / "tall.stl").extents)) == 1
    assert int(np.argmax(load_mesh_file(tmp_path / "tall.stl", up="y").extents)) == 2
    assert int(np.argmax(load_mesh_file(tmp_path / "tall.stl", up="-y").extents)) == 2


def test_gltf_auto_up_is_y(tmp_path):
    """A z-up mesh written to GLB by export_mesh (which turns it y-up) reads back as it was
    with up='auto'; with up='z' its height and width are swapped."""
    b = _box()
    src = ColoredMesh(b.vertices, b.faces, _split_colours(b)[:, :3], 0.0, "box")
    out = export_mesh(src, tmp_path / "rt.glb")
    back = load_mesh_file(out)  # up='auto' = y for glTF
    np.testing.assert_allclose(back.extents, SIZE, rtol=1e-6)
    # export_mesh gives every face its own vertices, in face order
    np.testing.assert_allclose(back.vertices[back.faces], src.vertices[src.faces], atol=1e-6)
    np.testing.assert_array_equal(back.face_colors, src.face_colors)
    as_z = load_mesh_file(out, up="z")
    np.testing.assert_allclose(as_z.extents, SIZE[[0, 2, 1]], rtol=1e-6)
    # the same box in an STL (auto = z there) is not turned
    b.export(str(tmp_path / "rt.stl"))
    np.testing.assert_allclose(load_mesh_file(tmp_path / "rt.stl").extents, SIZE, rtol=1e-6)


# ----------------------------------------------------------------------------- scenes


def test_glb_scene_parts_are_merged_with_transforms_and_colours(tmp_path):
    """Two parts, each with its own colour; the second one turned and moved (y-up file)."""
    a = _box()  # x [-1, 1], y [-0.5, 0.5], z [-0.25, 0.25] in the file
    a.visual = trimesh.visual.TextureVisuals(
        material=trimesh.visual.material.PBRMaterial(baseColorFactor=_rgba(RED)))
    bb = _box([1.0, 0.2, 0.2])
    bb.visual = trimesh.visual.ColorVisuals(bb, vertex_colors=np.tile(_rgba(BLUE), (8, 1)))
    turn = trimesh.transformations.rotation_matrix(math.pi / 2, [0, 0, 1])  # about file z
    move = trimesh.transformations.translation_matrix([3.0, 0.0, 0.0])
    scene = trimesh.Scene()
    scene.add_geometry(a, node_name="hull", geom_name="hull")
    scene.add_geometry(bb, node_name="mast", geom_name="mast", transform=move @ turn)
    scene.export(str(tmp_path / "scene.glb"))

    mesh = load_mesh_file(tmp_path / "scene.glb")
    assert len(mesh.faces) == 24
    assert _colour_set(mesh) == {RED, BLUE}
    # in the file the parts span x [-1, 3.1], y [-0.5, 0.5], z [-0.25, 0.25];
    # y-up -> z-up: file z becomes -y and file y becomes z
    np.testing.assert_allclose(mesh.extents, [4.1, 0.5, 1.0], rtol=1e-6)
    _assert_centred(mesh)
    blue = (mesh.face_colors == BLUE).all(axis=1)
    assert blue.sum() == 12
    used = np.unique(mesh.faces[blue])
    x_centre = (-1.0 + 3.1) / 2
    bv = mesh.vertices[used]
    # the turned part: 0.2 along x, 1.0 along file y (now z), 0.2 along file z (now y)
    np.testing.assert_allclose(bv.min(axis=0), [2.9 - x_centre, -0.1, -0.5], atol=1e-6)
    np.testing.assert_allclose(bv.max(axis=0), [3.1 - x_centre, 0.1, 0.5], atol=1e-6)


# ----------------------------------------------------------------------------- waterline


def test_default_waterline_is_a_quarter_up(tmp_path):
    mesh = load_mesh_file(_write("ply", tmp_path))
    lo, hi = mesh.bounds[:, 2]
    assert mesh.waterline == pytest.approx(lo + DEFAULT_WATERLINE_FRACTION * (hi - lo))
    assert DEFAULT_WATERLINE_FRACTION == 0.25


@pytest.mark.parametrize("units", ["m", "cm"])
def test_explicit_waterline_is_honoured(tmp_path, units):
    path = _write("stl", tmp_path)
    height = SIZE[2] * UNITS[units]
    for w in (0.0, 0.3 * height, height):
        mesh = load_mesh_file(path, units=units, waterline=w)
        assert mesh.waterline == pytest.approx(mesh.bounds[0, 2] + w, abs=1e-12)


@pytest.mark.parametrize("w", [-0.01, SIZE[2] + 0.01, math.nan, math.inf, -math.inf])
def test_waterline_outside_the_mesh_is_a_user_error(tmp_path, w):
    with pytest.raises(UserError, match="--waterline"):
        load_mesh_file(_write("stl", tmp_path), waterline=w)


def test_mesh_spec_waterline_must_be_finite():
    with pytest.raises(UserError, match="--waterline"):
        MeshSpec(source="x.stl", waterline=math.nan)


# ----------------------------------------------------------------------------- bad input


def test_bad_units_and_up_arguments(tmp_path):
    path = _write("stl", tmp_path)
    with pytest.raises(UserError, match="'km'"):
        load_mesh_file(path, units="km")
    with pytest.raises(UserError, match="'w'"):
        load_mesh_file(path, up="w")
    with pytest.raises(UserError, match="'km'"):
        MeshSpec(source=str(path), units="km")


def _random_bytes(n: int = 2000) -> bytes:
    return np.random.default_rng(1234).integers(0, 256, n, dtype=np.uint8).tobytes()


def _vertices_only_obj() -> bytes:
    return b"v 0 0 0\nv 1 0 0\nv 0 1 0\n"


def _non_finite_obj() -> bytes:
    return b"v 0 0 0\nv 1 0 0\nv 0 nan 0\nf 1 2 3\n"


# name, what to create (None: nothing), its bytes, words the error message must contain
BAD_FILES = {
    "missing": ("nope.ply", None, None, ("does not exist",)),
    "folder": ("dir.ply", "dir", None, ("not a file",)),
    "txt": ("notes.txt", "file", b"hello\n", ("unsupported format", "'.txt'")),
    "no suffix": ("noext", "file", b"hello\n", ("unsupported format", "(none)")),
    "random ply": ("r.ply", "file", _random_bytes(), ()),
    "random glb": ("r.glb", "file", _random_bytes(), ()),
    "random stl": ("r.stl", "file", _random_bytes(), ()),
    "random obj": ("r.obj", "file", _random_bytes(), ()),
    "random off": ("r.off", "file", _random_bytes(), ()),
    "empty stl": ("e.stl", "file", b"", ()),
    "vertices only": ("pts.obj", "file", _vertices_only_obj(), ("no triangles",)),
    "not finite": ("nan.obj", "file", _non_finite_obj(), ("not finite",)),
}
UNREADABLE = ("cannot read", "no triangles")


def _make_bad(tmp_path: Path, case: str) -> Path:
    name, kind, data, _ = BAD_FILES[case]
    path = tmp_path / name
    if kind == "dir":
        path.mkdir()
    elif kind == "file":
        path.write_bytes(data)
    return path


@pytest.mark.parametrize("case", list(BAD_FILES))
def test_bad_file_is_a_user_error(tmp_path, case):
    path = _make_bad(tmp_path, case)
    with pytest.raises(UserError) as info:
        load_mesh_file(path)
    msg = str(info.value)
    assert "\n" not in msg
    assert repr(str(path)) in msg
    for needle in BAD_FILES[case][3]:
        assert needle in msg
    if case.startswith(("random", "empty")):
        assert any(w in msg for w in UNREADABLE), msg
        assert "No module" not in msg  # about the file, not about a missing package


BAD_COLOURS = ("300,0,0", "red", "1,2", "-1,0,0", "#12345")


def test_bad_input_through_the_cli(tmp_path):
    """Every bad input: exit status 2, one 'error:' line naming the culprit, no traceback."""
    for case in BAD_FILES:
        _make_bad(tmp_path, case)
    _write("stl", tmp_path)
    calls = {case: ("info", BAD_FILES[case][0]) for case in BAD_FILES}
    calls.update({f"colour {v}": ("info", "box.stl", f"--color={v}") for v in BAD_COLOURS})
    calls["waterline"] = ("info", "box.stl", "--waterline", "5")
    calls["builtin"] = ("info", "foo")
    calls["export suffix"] = ("export", "bluerov2", "rov.stl")
    calls["export folder"] = ("export", "bluerov2", str(tmp_path / "no" / "rov.ply"))
    before = sorted(p.name for p in tmp_path.iterdir())
    procs = _run_clis(calls, tmp_path)

    for case, (name, _, _, words) in BAD_FILES.items():
        line = _assert_cli_error(procs[case], repr(name), *words)
        if case.startswith(("random", "empty")):
            assert any(w in line for w in UNREADABLE), line
    for v in BAD_COLOURS:
        _assert_cli_error(procs[f"colour {v}"], "--color", repr(v), "R,G,B")
    _assert_cli_error(procs["waterline"], "--waterline 5.0", "outside the mesh")
    _assert_cli_error(procs["builtin"], "'foo'", "neither a built-in", *bluerov2.VARIANTS)
    _assert_cli_error(procs["export suffix"], "'rov.stl'", ".ply, .glb, .obj")
    _assert_cli_error(procs["export folder"], repr(str(tmp_path / "no")), "does not exist")
    # nothing written, not even a temporary file
    assert sorted(p.name for p in tmp_path.iterdir()) == before


def test_over_1_km_suggests_mm(tmp_path):
    _box([2000.0, 10.0, 10.0]).export(str(tmp_path / "big.stl"))
    assert 2000.0 > MAX_EXTENT_M
    with pytest.raises(UserError) as info:
        load_mesh_file(tmp_path / "big.stl")
    msg = str(info.value)
    for needle in ("big.stl", "2000 m", "more than 1 km", "wrong units", "--units mm"):
        assert needle in msg, msg
    procs = _run_clis({"m": ("info", "big.stl"), "mm": ("info", "big.stl", "--units", "mm")},
                      tmp_path)
    _assert_cli_error(procs["m"], "'big.stl'", "more than 1 km", "wrong units", "--units mm")
    # read in mm as suggested it is 2 m long
    mesh = load_mesh_file(tmp_path / "big.stl", units="mm")
    np.testing.assert_allclose(mesh.extents, [2.0, 0.01, 0.01], rtol=1e-6)
    ok = procs["mm"]
    assert ok.returncode == 0, ok.stderr
    assert "2.0000 x 0.0100 x 0.0100 m" in ok.stdout


def test_under_1_mm_suggests_m(tmp_path):
    _box([0.5, 0.4, 0.3]).export(str(tmp_path / "tiny.stl"))
    assert 0.5 * UNITS["mm"] < MIN_EXTENT_M
    with pytest.raises(UserError) as info:
        load_mesh_file(tmp_path / "tiny.stl", units="mm")
    msg = str(info.value)
    for needle in ("tiny.stl", "read in mm", "under 1 mm", "wrong units", "--units m"):
        assert needle in msg, msg
    assert "--units mm" not in msg
    _assert_cli_error(_run_cli("info", "tiny.stl", "--units", "mm", cwd=tmp_path),
                      "'tiny.stl'", "under 1 mm", "wrong units", "--units m")
    np.testing.assert_allclose(load_mesh_file(tmp_path / "tiny.stl").extents,
                               [0.5, 0.4, 0.3], rtol=1e-6)


def test_unknown_builtin_name():
    with pytest.raises(UserError, match="neither a built-in"):
        MeshSpec(source="foo").load()


def test_cli_info_and_colour_override(tmp_path):
    """`info` prints the size, triangles, colours and waterline; --color replaces colours."""
    _write("ply", tmp_path)
    procs = _run_clis({"plain": ("info", "box.ply"),
                       "rgb": ("info", "box.ply", "--color", "1,2,3"),
                       "hex": ("info", "box.ply", "--color", "#010203")}, tmp_path)
    for key in ("rgb", "hex"):
        assert procs[key].returncode == 0, procs[key].stderr
        assert "colours:    1: #010203" in procs[key].stdout
    plain = procs["plain"]
    assert plain.returncode == 0, plain.stderr
    assert plain.stderr == ""
    assert f"size:       {SIZE[0]:.4f} x {SIZE[1]:.4f} x {SIZE[2]:.4f} m" in plain.stdout
    assert "triangles:  12  closed: True" in plain.stdout
    assert f"({DEFAULT_WATERLINE_FRACTION * SIZE[2]:.4f} m above the lowest point)" in plain.stdout
    assert "colours:    2:" in plain.stdout
    assert "#" + bytes(RED).hex() in plain.stdout and "#" + bytes(BLUE).hex() in plain.stdout


# ----------------------------------------------------------------------------- export


@pytest.fixture(scope="module")
def rov() -> ColoredMesh:
    return bluerov2.build("bluerov2")


EXPORTS = (".ply", ".glb", ".obj")


@pytest.fixture(scope="module")
def exported(tmp_path_factory) -> tuple[Path, dict]:
    """`export bluerov2 rov.<suffix>` for each format, each into its own folder."""
    base = tmp_path_factory.mktemp("export")
    for suffix in EXPORTS:
        (base / suffix[1:]).mkdir()
    calls = {s: ("export", "bluerov2", str(base / s[1:] / f"rov{s}")) for s in EXPORTS}
    return base, _run_clis(calls, base)


@pytest.mark.parametrize("suffix", EXPORTS)
def test_cli_export_bluerov2_loads_back(exported, rov, suffix):
    base, procs = exported
    proc = procs[suffix]
    out_dir = base / suffix[1:]
    out = out_dir / f"rov{suffix}"
    assert proc.returncode == 0, proc.stderr
    assert proc.stderr == ""
    assert proc.stdout.startswith(f"wrote {out}")
    assert f"({len(rov.faces)} triangles" in proc.stdout
    assert [p.name for p in out_dir.iterdir()] == [out.name]  # no temporary file left
    back = load_mesh_file(out)
    assert len(back.faces) == len(rov.faces)
    np.testing.assert_allclose(back.extents, rov.extents, atol=1e-4)
    _assert_centred(back)
    colours = _colour_set(back)
    assert bluerov2.FOAM in colours and bluerov2.BLACK in colours
    assert colours == _colour_set(rov)
    # the colour of each face survives, not just the set of colours
    counts = {c: int((back.face_colors == c).all(axis=1).sum()) for c in colours}
    assert counts == {c: int((rov.face_colors == c).all(axis=1).sum()) for c in colours}


def test_cli_export_of_a_file_with_options(tmp_path):
    """A user's file exported with --units and --color: the written mesh has them."""
    _write("ply", tmp_path)
    proc = _run_cli("export", "box.ply", "box_out.obj", "--units", "cm", "--color", "9,8,7",
                    cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    back = load_mesh_file(tmp_path / "box_out.obj")
    np.testing.assert_allclose(back.extents, SIZE * UNITS["cm"], rtol=1e-6)
    assert _colour_set(back) == {(9, 8, 7)}
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]


@pytest.mark.parametrize("suffix", [".ply", ".glb", ".obj"])
def test_export_mesh_round_trip_keeps_face_colours(tmp_path, suffix):
    b = _box()
    src = ColoredMesh(b.vertices, b.faces, _split_colours(b)[:, :3], 0.0, "box")
    out = export_mesh(src, tmp_path / f"box{suffix}")
    back = load_mesh_file(out)
    np.testing.assert_allclose(back.vertices[back.faces], src.vertices[src.faces], atol=1e-6)
    np.testing.assert_array_equal(back.face_colors, src.face_colors)


def test_export_is_atomic(tmp_path, monkeypatch):
    """A failed write leaves the old file as it was and no temporary file behind."""
    b = _box()
    src = ColoredMesh(b.vertices, b.faces, _split_colours(b)[:, :3], 0.0, "box")
    out = tmp_path / "box.ply"
    out.write_bytes(b"old")

    real_write = Path.write_bytes

    def fail(self, data):  # a write that stops half-way
        real_write(self, data[: len(data) // 2])
        raise OSError("disk full")

    monkeypatch.setattr(Path, "write_bytes", fail)
    with pytest.raises(OSError, match="disk full"):
        export_mesh(src, out)
    monkeypatch.undo()
    assert out.read_bytes() == b"old"
    assert [p.name for p in tmp_path.iterdir()] == ["box.ply"]
    export_mesh(src, out)  # and a good write replaces it
    assert [p.name for p in tmp_path.iterdir()] == ["box.ply"]
    assert len(load_mesh_file(out).faces) == 12
