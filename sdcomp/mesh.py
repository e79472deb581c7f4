"""Choosing a mesh (built-in BlueROV2 or a user's file) and exporting it.

Command line::

    python -m sdcomp.mesh export bluerov2 rov.glb        # PLY, GLB or OBJ, with colours
    python -m sdcomp.mesh export boat.stl boat.ply --units mm --color 200,40,40
    python -m sdcomp.mesh info bluerov2-heavy
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from . import bluerov2
from .coloredmesh import ColoredMesh
from .errors import UserError, run_cli
from .fileio import atomic_write_bytes
from .meshfile import UNITS, UP_AXES, check_read_options, load_mesh_file

BUILTIN = bluerov2.VARIANTS
EXPORT_FORMATS = (".ply", ".glb", ".obj")


def parse_color(text: str) -> tuple[int, int, int]:
    """'R,G,B' (0-255) or '#RRGGBB' to an sRGB triple; UserError otherwise."""
    t = text.strip()
    try:
        if t.startswith("#") and len(t) == 7:
            rgb = tuple(int(t[i:i + 2], 16) for i in (1, 3, 5))
        else:
            rgb = tuple(int(p) for p in t.split(","))
    except ValueError:
        rgb = ()
    if len(rgb) != 3 or not all(0 <= c <= 255 for c in rgb):
        raise UserError(f"--color {text!r} is not a colour; use R,G,B with 0-255 each "
                        f"(e.g. 200,40,40) or #RRGGBB")
    return rgb  # type: ignore[return-value]


@dataclass(frozen=True)
class MeshSpec:
    """Which mesh to use and how to read it; validated on construction.

    Attributes:
        source: a built-in name (``bluerov2``, ``bluerov2-heavy``) or a mesh file path.
        units: length unit of a file (m, dm, cm, mm).
        up: up axis of a file (auto, x, y, z, -x, -y, -z).
        color: one sRGB colour for all faces of a file, or None for the file's colours.
        waterline: waterline height above a file mesh's lowest point (m), None for default.
    """

    source: str = "bluerov2"
    units: str = "m"
    up: str = "auto"
    color: tuple[int, int, int] | None = None
    waterline: float | None = None

    def __post_init__(self) -> None:
        check_read_options(self.units, self.up)
        if self.waterline is not None and not np.isfinite(self.waterline):
            raise UserError(f"--waterline {self.waterline} must be a finite number of metres")

    @property
    def is_builtin(self) -> bool:
        return self.source in BUILTIN

    def load(self) -> ColoredMesh:
        """Build or read the mesh (UserError for a bad file or name)."""
        if self.is_builtin:
            return bluerov2.build(self.source)
        path = Path(self.source)
        if not path.exists() and not path.suffix:
            raise UserError(f"mesh {self.source!r} is neither a built-in mesh "
                            f"({', '.join(BUILTIN)}) nor an existing file")
        return load_mesh_file(path, units=self.units, up=self.up, color=self.color,
                              waterline=self.waterline)


def add_mesh_arguments(parser: argparse.ArgumentParser, positional: bool = False) -> None:
    """Add the options that choose and read a mesh to ``parser``."""
    help_src = (f"built-in mesh ({', '.join(BUILTIN)}) or a mesh file "
                f"(STL, OBJ, PLY, GLB, GLTF, OFF)")
    if positional:
        parser.add_argument("mesh", metavar="NAME_OR_PATH", help=help_src)
    else:
        parser.add_argument("--mesh", default="bluerov2", metavar="NAME_OR_PATH",
                            help=help_src + " (default: %(default)s)")
    parser.add_argument("--units", default="m", choices=list(UNITS),
                        help="length unit of a mesh file (default: %(default)s)")
    parser.add_argument("--up", default="auto", choices=list(UP_AXES),
                        help="up axis of a mesh file; auto = y for glTF, z otherwise "
                             "(default: %(default)s)")
    parser.add_argument("--color", default=None, metavar="R,G,B",
                        help="one sRGB colour for a mesh file, instead of its own colours")
    parser.add_argument("--waterline", type=float, default=None, metavar="M",
                        help="waterline height above a mesh file's lowest point, metres "
                             "(default: a quarter of its height)")


def mesh_spec_from_args(args: argparse.Namespace) -> MeshSpec:
    return MeshSpec(source=args.mesh, units=args.units, up=args.up,
                    color=parse_color(args.color) if args.color else None,
                    waterline=args.waterline)


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


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="python -m sdcomp.mesh",
                                description="Export or describe a mesh (built-in or a file).")
    sub = p.add_subparsers(dest="command", required=True)
    e = sub.add_parser("export", help="write a mesh with its colours to PLY, GLB or OBJ")
    add_mesh_arguments(e, positional=True)
    e.add_argument("out", metavar="OUT", help="output file: .ply, .glb or .obj")
    i = sub.add_parser("info", help="print a mesh's size, triangles, colours and waterline")
    add_mesh_arguments(i, positional=True)
    return p


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    mesh = mesh_spec_from_args(args).load()
    if args.command == "export":
        out = export_mesh(mesh, args.out)
        print(f"wrote {out} ({len(mesh.faces)} triangles, {out.stat().st_size} bytes)")
    else:
        print(describe(mesh))
    return 0


if __name__ == "__main__":
    sys.exit(run_cli(main))
