"""``python -m sdcomp.mesh export|info``: export or describe a mesh, and the options that
choose and read a mesh (shared with ``sdcomp atlas build``).

    python -m sdcomp.mesh export bluerov2 rov.glb        # PLY, GLB or OBJ, with colours
    python -m sdcomp.mesh export swimmer swimmers.glb    # every variant of a kind, in a row
    python -m sdcomp.mesh export boat-07 boat.ply        # one variant
    python -m sdcomp.mesh export boat.stl boat.ply --units mm --color 200,40,40
    python -m sdcomp.mesh info bluerov2-heavy            # (info KIND: a line per variant)
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence

from ..assets import sar
from ..assets.export import describe, describe_kind, export_mesh
from ..assets.library import BUILTIN, MeshSpec
from ..assets.meshfile import UNITS, UP_AXES
from ..errors import UserError, run_cli
from . import Parser


def add_mesh_arguments(parser: argparse.ArgumentParser, positional: bool = False) -> None:
    """Add the options that choose and read a mesh to ``parser``."""
    help_src = (f"built-in mesh or kind ({', '.join(BUILTIN)}), one variant of a kind "
                f"(e.g. swimmer-03), or a mesh file (STL, OBJ, PLY, GLB, GLTF, OFF)")
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


def build_parser() -> argparse.ArgumentParser:
    p = Parser(prog="python -m sdcomp.mesh",
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
    spec = mesh_spec_from_args(args)
    if args.command == "info" and spec.source in sar.KINDS:
        print(describe_kind(spec.source))
        return 0
    mesh = spec.load()
    if args.command == "export":
        out = export_mesh(mesh, args.out)
        print(f"wrote {out} ({len(mesh.faces)} triangles, {out.stat().st_size} bytes)")
    else:
        print(describe(mesh))
    return 0


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
    r, g, b = rgb
    return r, g, b


if __name__ == "__main__":
    sys.exit(run_cli(main))
