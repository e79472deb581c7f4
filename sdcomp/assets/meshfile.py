"""Reading a user's mesh file (STL, OBJ, PLY, GLB/GLTF, OFF) into a :class:`ColoredMesh`.

Colours come from the file where it has them (face colours, vertex colours averaged per face,
material base colour or texture sampled at the vertices) unless one colour is forced. A scene
with several parts is merged with each part's colour kept. Units and the up axis are the
caller's to state; the result is in metres, z up, centred on its bounding box.
"""

from __future__ import annotations

import io
import math
import re
from pathlib import Path

import numpy as np

from ..errors import UserError
from .mesh import ColoredMesh, centred
from .mesh_faces import check_mesh_memory

SUPPORTED = (".stl", ".obj", ".ply", ".glb", ".gltf", ".off")
_TEXT_FORMATS = (".stl", ".obj", ".off")  # may be text in a non-UTF-8 encoding
UNITS = {"m": 1.0, "dm": 0.1, "cm": 0.01, "mm": 0.001}
UP_AXES = ("auto", "x", "y", "z", "-x", "-y", "-z")
DEFAULT_COLOR = (170, 170, 170)
MAX_EXTENT_M = 1000.0
MIN_EXTENT_M = 0.001
DEFAULT_WATERLINE_FRACTION = 0.25  # of the height, from the bottom, when none is given


def safe_name(path: Path) -> str:
    """A file-name-safe short name for a mesh file: its stem, other characters as '_'."""
    return re.sub(r"[^A-Za-z0-9._-]+", "_", path.stem).strip("._") or "mesh"


def _up_rotation(up: str) -> np.ndarray:
    """(3, 3) rotation taking the file's ``up`` axis to +z (x stays forward where it can)."""
    sign = -1.0 if up.startswith("-") else 1.0
    axis = up[-1]
    rot = {
        "z": np.eye(3),
        "y": np.array([[1, 0, 0], [0, 0, -1], [0, 1, 0]], float),  # +y -> +z, +z -> -y
        "x": np.array([[0, 0, -1], [0, 1, 0], [1, 0, 0]], float),  # +x -> +z, +z -> -x
    }[axis]
    if sign < 0:
        rot = np.diag([1.0, -1.0, -1.0]) @ rot  # flip: a half turn about x
    return rot


def _face_colours(geom, override: tuple[int, int, int] | None) -> np.ndarray:
    """(F, 3) uint8 sRGB colours of a ``trimesh.Trimesh``'s faces."""
    nf = len(geom.faces)
    if override is not None:
        return np.tile(np.array(override, np.uint8), (nf, 1))
    visual = geom.visual
    kind = getattr(visual, "kind", None)
    try:
        if kind == "face":
            return np.asarray(visual.face_colors)[:, :3].astype(np.uint8)
        if kind == "vertex":
            vc = np.asarray(visual.vertex_colors)[:, :3].astype(np.float64)
            return np.rint(vc[geom.faces].mean(axis=1)).astype(np.uint8)
        if kind == "texture":
            material = getattr(visual, "material", None)
            try:
                vc = np.asarray(visual.to_color().vertex_colors)[:, :3].astype(np.float64)
                if len(vc) == len(geom.vertices):
                    return np.rint(vc[geom.faces].mean(axis=1)).astype(np.uint8)
            except Exception:  # no UVs or no image: fall back to the material's colour
                pass
            if material is not None:
                main = np.asarray(material.main_color)[:3].astype(np.uint8)
                return np.tile(main, (nf, 1))
    except Exception:  # a broken colour table: the geometry is still usable
        pass
    return np.tile(np.array(DEFAULT_COLOR, np.uint8), (nf, 1))


def check_read_options(units: str, up: str) -> None:
    """UserError unless ``units`` and ``up`` are ones :func:`load_mesh_file` understands."""
    if units not in UNITS:
        raise UserError(f"--units {units!r} is not a unit; use one of {', '.join(UNITS)}")
    if up not in UP_AXES:
        raise UserError(f"--up {up!r} is not an axis; use one of {', '.join(UP_AXES)}")


def load_mesh_file(path: str | Path, *, units: str = "m", up: str = "auto",
                   color: tuple[int, int, int] | None = None,
                   waterline: float | None = None) -> ColoredMesh:
    """Load a mesh file as a :class:`ColoredMesh` (metres, z up, centred on its bounds).

    Args:
        path: an STL, OBJ, PLY, GLB, GLTF or OFF file.
        units: the file's length unit, one of ``m``, ``dm``, ``cm``, ``mm``.
        up: the file's up axis (``x``, ``y``, ``z``, ``-x``, ...); ``auto`` is ``y`` for
            glTF (its convention) and ``z`` for the others.
        color: one sRGB colour for every face instead of the file's colours.
        waterline: height of the waterline above the mesh's lowest point, metres; by
            default a quarter of its height.

    Raises:
        UserError: missing or unreadable file, unsupported format, no triangles, more
            triangles than this machine's memory can load (:mod:`sdcomp.assets.mesh_faces`),
            or a size over 1 km or under 1 mm (the message suggests the right ``--units``).
    """
    path = Path(path)
    check_read_options(units, up)
    suffix = path.suffix.lower()
    _check_mesh_path(path, suffix)
    check_mesh_memory(path, suffix)  # before trimesh allocates what the file claims
    geoms = _read_geometries(path, suffix)
    if not geoms:
        raise UserError(f"mesh file {str(path)!r} contains no triangles")
    if up == "auto":
        up = "y" if suffix in (".glb", ".gltf") else "z"
    rot = _up_rotation(up) * UNITS[units]
    v, f, cols, closed = _merge_parts(path, geoms, rot, color)
    _check_extent(path, v, units)
    v, wl = centred(v, _waterline_z(v, waterline))
    return ColoredMesh(v, f, cols, wl, safe_name(path), closed=closed)


def _check_mesh_path(path: Path, suffix: str) -> None:
    """UserError unless ``path`` is an existing file of a supported format (``suffix``:
    its lower-case extension, with the dot)."""
    if not path.exists():
        raise UserError(f"mesh file {str(path)!r} does not exist")
    if not path.is_file():
        raise UserError(f"mesh path {str(path)!r} is not a file")
    if suffix not in SUPPORTED:
        raise UserError(f"mesh file {str(path)!r} has an unsupported format {suffix or '(none)'!r};"
                        f" use one of {', '.join(SUPPORTED)}")


def _merge_parts(path: Path, geoms: list, rot: np.ndarray, color: tuple[int, int, int] | None
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray, bool]:
    """The parts ``geoms`` (``trimesh.Trimesh``) as one mesh, each vertex multiplied by
    ``rot`` ((3, 3): the up-axis rotation times the unit's size in metres).

    Returns (vertices (V, 3) float64 metres, faces (F, 3) int64 indices into them, colours
    (F, 3) uint8 sRGB, closed: every part is a proper volume). UserError for a part with
    vertices that are not finite or faces that refer to vertices it does not have.
    """
    import trimesh

    verts, faces, cols, closed = [], [], [], True
    offset = 0
    for g in geoms:
        if not np.isfinite(np.asarray(g.vertices, np.float64)).all():
            raise UserError(f"mesh file {str(path)!r} has vertices that are not finite numbers")
        fi = np.asarray(g.faces)
        if fi.ndim != 2 or fi.shape[1] != 3 or fi.min() < 0 or fi.max() >= len(g.vertices):
            raise UserError(f"mesh file {str(path)!r} is damaged: its faces refer to vertices "
                            f"it does not have; re-export it")
        verts.append(np.asarray(g.vertices, np.float64) @ rot.T)
        faces.append(np.asarray(g.faces, np.int64) + offset)
        cols.append(_face_colours(g, color))
        offset += len(g.vertices)
        # closed (back faces may be culled) only if it is a proper volume once duplicate
        # vertices are merged (STL, for one, stores every triangle's corners separately)
        closed = closed and bool(trimesh.Trimesh(g.vertices, g.faces, process=True).is_volume)
    return np.concatenate(verts), np.concatenate(faces), np.concatenate(cols), closed


def _check_extent(path: Path, v: np.ndarray, units: str) -> None:
    """UserError if the mesh (vertices ``v``, (V, 3) metres, read in ``units``) is over 1 km
    or under 1 mm across: the message suggests the right ``--units``."""
    extent = float((v.max(axis=0) - v.min(axis=0)).max())
    if extent > MAX_EXTENT_M:
        fix = "try --units mm" if units != "mm" else "even in mm it is too large: rescale the file"
        raise UserError(f"mesh {str(path)!r} is {extent:.4g} m across read in {units}, "
                        f"more than 1 km: wrong units? {fix}")
    if extent < MIN_EXTENT_M:
        fix = "try --units m" if units != "m" else "even in m it is too small: rescale the file"
        raise UserError(f"mesh {str(path)!r} is {extent:.3g} m across read in {units}, "
                        f"under 1 mm: wrong units? {fix}")


def _waterline_z(v: np.ndarray, waterline: float | None) -> float:
    """The waterline's z (metres, in the frame of the vertices ``v``, (V, 3)): ``waterline``
    metres above the lowest vertex, by default :data:`DEFAULT_WATERLINE_FRACTION` of the
    height; UserError if it lies outside the mesh."""
    height = float(v[:, 2].max() - v[:, 2].min())
    if waterline is None:
        return float(v[:, 2].min()) + DEFAULT_WATERLINE_FRACTION * height
    if not math.isfinite(waterline) or not 0 <= waterline <= height:
        raise UserError(f"--waterline {waterline} is outside the mesh: use a height in "
                        f"[0, {height:.4g}] m above its lowest point")
    return float(v[:, 2].min()) + waterline


def _read_geometries(path: Path, suffix: str) -> list:
    """The triangle meshes in a file, scene transforms applied; UserError if unreadable."""
    import trimesh

    try:
        try:
            loaded = trimesh.load(str(path), file_type=suffix[1:], process=False)
        except ImportError:
            # trimesh decodes text that is not UTF-8 with charset_normalizer, an optional
            # package: read such text as Latin-1 (any byte is a character) instead
            if suffix not in _TEXT_FORMATS:
                raise
            text = path.read_bytes().decode("latin-1").encode("utf-8")
            loaded = trimesh.load(io.BytesIO(text), file_type=suffix[1:], process=False,
                                  resolver=trimesh.resolvers.FilePathResolver(str(path)))
    except Exception as exc:  # trimesh raises many kinds on bad bytes
        reason = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        if suffix == ".gltf" and isinstance(exc, KeyError):
            reason = (f"not glTF JSON, or a file it refers to is missing "
                      f"({exc.args[0] if exc.args else '?'})")
        raise UserError(f"cannot read mesh file {str(path)!r}: {reason[:200]}") from None
    if isinstance(loaded, trimesh.Scene):
        geoms = []
        for node in loaded.graph.nodes_geometry:
            transform, name = loaded.graph[node]
            g = loaded.geometry.get(name)
            if isinstance(g, trimesh.Trimesh) and len(g.faces):
                g = g.copy()
                g.apply_transform(transform)
                geoms.append(g)
        return geoms
    if isinstance(loaded, trimesh.Trimesh):
        return [loaded] if len(loaded.faces) else []
    return []
