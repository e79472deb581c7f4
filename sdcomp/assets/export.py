"""Writing a mesh with its colours (PLY, GLB, OBJ) and describing it in a few lines."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import UserError
from ..util.files import atomic_write_bytes
from . import sar
from .mesh import ColoredMesh

EXPORT_FORMATS = (".ply", ".glb", ".obj")


def export_mesh(mesh: ColoredMesh, out: str | Path) -> Path:
    """Write ``mesh`` with its colours as PLY (face colours), GLB or OBJ (vertex colours).

    The file appears atomically (written to a temporary name, then renamed).
    """
    out = Path(out)
    suffix = out.suffix.lower()
    if suffix not in EXPORT_FORMATS:
        raise UserError(f"cannot export to {str(out)!r}: use a name ending in "
                        f"{', '.join(EXPORT_FORMATS)}")
    if not out.parent.exists():
        raise UserError(f"output folder {str(out.parent)!r} does not exist")
    tm = mesh.to_trimesh()
    if suffix in (".glb", ".obj"):
        # these formats carry colours per vertex: give every face its own vertices
        tm = _unshared(mesh)
    if suffix == ".glb":
        # glTF is y-up: turn our z-up into y-up so viewers show the object upright
        tm.apply_transform(np.array([[1, 0, 0, 0], [0, 0, 1, 0], [0, -1, 0, 0], [0, 0, 0, 1.0]]))
    data = tm.export(file_type=suffix[1:])
    if isinstance(data, str):
        data = data.encode()
    atomic_write_bytes(out, data)
    return out


def _unshared(mesh: ColoredMesh):
    import trimesh

    verts = mesh.vertices[mesh.faces].reshape(-1, 3)
    faces = np.arange(len(verts)).reshape(-1, 3)
    rgba = np.concatenate([np.repeat(mesh.face_colors, 3, axis=0),
                           np.full((len(verts), 1), 255, np.uint8)], axis=1)
    return trimesh.Trimesh(verts, faces, vertex_colors=rgba, process=False)


def describe(mesh: ColoredMesh) -> str:
    """A few lines about ``mesh``: size, triangles, colours, waterline, hash."""
    ext = mesh.extents
    colours = np.unique(mesh.face_colors, axis=0)
    return "\n".join([
        f"name:       {mesh.name}",
        f"size:       {ext[0]:.4f} x {ext[1]:.4f} x {ext[2]:.4f} m (length x width x height)",
        f"triangles:  {len(mesh.faces)}  closed: {mesh.closed}",
        f"colours:    {len(colours)}: " + " ".join("#" + bytes(c).hex() for c in colours[:8]),
        f"waterline:  z = {mesh.waterline:+.4f} m ({mesh.waterline - mesh.bounds[0, 2]:.4f} m "
        f"above the lowest point)",
        f"hash:       {mesh.content_hash()[:16]}",
    ])


def describe_kind(kind: str) -> str:
    """One line per variant of the search-and-rescue ``kind``: name, sub-type, size,
    triangles, height of the waterline above the lowest point (metres)."""
    lines = [f"{kind}: {sar.VARIANTS[kind]} variants (metres: length x width x height; "
             f"waterline above the lowest point)"]
    for v in range(sar.VARIANTS[kind]):
        m = sar.build(kind, v)
        x, y, z = m.extents
        lines.append(f"  {m.name:27s} {sar.describe_variant(kind, v)['sub_type']:14s} "
                     f"{x:6.2f} x {y:5.2f} x {z:5.2f}  {len(m.faces):5d} triangles  "
                     f"waterline {m.waterline - m.bounds[0, 2]:.2f}")
    return "\n".join(lines)
