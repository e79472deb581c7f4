"""``python -m sdcomp.atlas build|info`` (``sdcomp atlas``): build, reuse or check the
sprite atlas of a mesh (:mod:`sdcomp.atlas.store`).

    python -m sdcomp.atlas build [--mesh bluerov2|bluerov2-heavy|KIND|KIND-NN|PATH] [--out sprites/]
    python -m sdcomp.atlas info sprites/bluerov2.npz

A search-and-rescue kind (``--mesh swimmer``) builds the atlas of every variant, with the
parameters the generator uses for it (:mod:`sdcomp.atlas.builtin`) unless flags say
otherwise, and the kind's sheet (``<out>/swimmer_sheet.png``: a row per variant).
"""

from __future__ import annotations

import argparse
import os
import shlex
import sys
import time
from collections.abc import Sequence
from pathlib import Path

from ..assets import sar
from ..assets.library import MeshSpec, kind_of
from ..assets.mesh import ColoredMesh
from ..atlas.builtin import object_atlas
from ..atlas.cache import ensure_atlas, sprites_folder
from ..atlas.poses import PoseGrid
from ..atlas.sheet import kind_sheet, write_png
from ..atlas.store import (
    DEFAULT_OUT,
    Atlas,
    AtlasConfig,
    atlas_paths,
    load_atlas,
    resolve_atlas_path,
)
from ..errors import UserError, run_cli
from . import DefaultsFormatter, Parser, prog
from .mesh import add_mesh_arguments, mesh_spec_from_args


def build_parser() -> argparse.ArgumentParser:
    p = Parser(prog=prog("atlas"),
                                description="Pre-render a mesh into a pose-indexed sprite atlas.")
    sub = p.add_subparsers(dest="command", required=True)
    b = sub.add_parser("build", help="build (or reuse) the atlas of a mesh",
                       formatter_class=DefaultsFormatter)
    add_build_arguments(b)
    i = sub.add_parser("info", help="describe and check an atlas file")
    i.add_argument("path", metavar="PATH", help="atlas .npz or .json (or the name without suffix)")
    return p


def add_build_arguments(b: argparse.ArgumentParser) -> None:
    """The options of ``atlas build``."""
    add_mesh_arguments(b)
    g = PoseGrid()
    kinds = " (search-and-rescue kinds: their own, see sdcomp.atlas.builtin)"
    b.add_argument("--out", default=DEFAULT_OUT, metavar="DIR",
                   help="atlas folder (default: $SDCOMP_SPRITES, else the user's cache folder)")
    b.add_argument("--size", type=int, default=None, metavar="PX",
                   help=f"sprite side, pixels (default: {AtlasConfig.size}{kinds})")
    b.add_argument("--supersample", type=int, default=None, metavar="K",
                   help=f"K x K sub-pixels per pixel for anti-aliased coverage (default: "
                        f"{AtlasConfig.supersample}{kinds})")
    b.add_argument("--max-off-nadir", type=float, default=None, metavar="DEG",
                   help=f"largest camera off-nadir angle stored, 0 = straight down (default: "
                        f"{g.max_off_nadir:g})")
    b.add_argument("--off-nadir-step", type=float, default=None, metavar="DEG",
                   help=f"spacing of the off-nadir rings (default: {g.off_nadir_step:g}"
                        f"{kinds})")
    b.add_argument("--max-error", type=float, default=None, metavar="DEG",
                   help=f"largest angle between any view and its nearest stored pose "
                        f"(default: {g.max_error:g}{kinds})")
    b.add_argument("--workers", type=int, default=None, metavar="N",
                   help="render processes (default: all cores)")
    b.add_argument("--force", action="store_true", help="rebuild even if a matching atlas exists")


_GRID_FLAGS = (("max off-nadir", "max_off_nadir"), ("off-nadir step", "off_nadir_step"),
               ("max error", "max_error"))


def _config_from_args(args: argparse.Namespace, base: AtlasConfig | None = None
                      ) -> AtlasConfig:
    """The atlas parameters of the flags, ``base``'s (default: the defaults) where a flag
    is not given."""
    base = base or AtlasConfig()

    def given(name: str, default):
        value = getattr(args, name)
        return default if value is None else value

    try:
        grid = PoseGrid(max_off_nadir=given("max_off_nadir", base.grid.max_off_nadir),
                        off_nadir_step=given("off_nadir_step", base.grid.off_nadir_step),
                        max_error=given("max_error", base.grid.max_error))
    except ValueError as exc:
        msg = str(exc)
        for text, opt in _GRID_FLAGS:  # name the offending flag, as the other messages do
            if msg.startswith(text):
                msg = f"--{opt.replace('_', '-')}{msg[len(text):]}"
                break
        raise UserError(msg) from None
    return AtlasConfig(size=given("size", base.size),
                       supersample=given("supersample", base.supersample), grid=grid)


def _rebuild_command(spec: MeshSpec, args: argparse.Namespace) -> str:
    q = shlex.quote
    parts = ["python -m sdcomp.atlas build", f"--mesh {q(spec.source)}",
             f"--out {q(str(sprites_folder(args.out)))}"]
    if not spec.is_builtin:
        parts += [f"--units {spec.units}", f"--up {spec.up}"]
        if args.color:
            parts.append(f"--color {q(args.color)}")
        if spec.waterline is not None:
            parts.append(f"--waterline {spec.waterline}")
    for opt in ("size", "supersample", "max_off_nadir", "off_nadir_step", "max_error"):
        if getattr(args, opt) is not None:
            parts.append(f"--{opt.replace('_', '-')} {getattr(args, opt)}")
    return " ".join(parts)


def _fmt_bytes(n: int) -> str:
    return f"{n / 1e6:.1f} MB" if n >= 1e5 else f"{n / 1e3:.1f} kB"


def info(path: str | Path) -> str:
    """A description of the atlas at ``path``, after checking it loads."""
    atlas = load_atlas(path)
    ix = atlas.index
    npz, _ = resolve_atlas_path(path)
    rings = ", ".join(f"{t:g}:{n}" for t, n in ix.get("rings", []))
    covered = atlas.mask.reshape(len(atlas), -1).mean(axis=1)
    return "\n".join([
        f"atlas:        {npz} ({_fmt_bytes(npz.stat().st_size)}, format {ix['format_version']}, "
        f"sdcomp {ix.get('sdcomp_version')})",
        f"mesh:         {ix['mesh']['name']} ({ix['mesh']['triangles']} triangles, "
        f"hash {ix['mesh']['hash'][:12]})",
        f"poses:        {len(atlas)}; rings (off-nadir:azimuths) {rings}",
        f"sprite:       {ix['size_px']} px, {ix['supersample']}x{ix['supersample']} supersampled, "
        f"{1000 * atlas.metres_per_pixel:.3f} mm/px",
        f"coverage:     {covered.min():.1%} to {covered.max():.1%} of the canvas",
        "status:       ok (checksum and arrays verified)",
    ])


def _check_out_dir(out: Path, flag: str = "--out") -> None:
    """UserError unless ``out`` is, or can be created as, a writable folder."""
    probe = out
    while not probe.exists():
        if probe.parent == probe:
            break
        probe = probe.parent
    if not probe.is_dir():
        raise UserError(f"{flag} {str(out)!r}: {str(probe)!r} is a file, not a folder")
    if not os.access(probe, os.W_OK | os.X_OK):
        raise UserError(f"{flag} {str(out)!r}: folder {str(probe)!r} is not writable")


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    if args.command == "info":
        print(info(args.path))
        return 0
    _config_from_args(args)  # flags checked before anything is built
    if args.workers is not None and args.workers < 1:
        raise UserError(f"--workers {args.workers} must be at least 1")
    spec = mesh_spec_from_args(args)
    out = sprites_folder(args.out)
    _check_out_dir(out)
    if spec.source not in sar.KINDS:
        _build_one(spec.load(), kind_of(spec.source) if spec.is_builtin else None, args,
                   out, _rebuild_command(spec, args))
        return 0
    kind, t0 = spec.source, time.perf_counter()
    atlases = [_build_one(sar.build(kind, v), kind, args, out,
                          _rebuild_command(MeshSpec(sar.mesh_name(kind, v)), args))
               for v in range(sar.VARIANTS[kind])]
    sheet = write_png(kind_sheet(atlases), out / f"{kind}_sheet.png")
    print(f"{kind}: {len(atlases)} atlases in {time.perf_counter() - t0:.1f} s; sheet {sheet}")
    return 0


def _build_one(mesh: ColoredMesh, kind: str | None, args: argparse.Namespace, out: Path,
               command: str) -> Atlas:
    """Build (or reuse) the atlas of ``mesh`` in ``out`` with the flags' parameters over
    its defaults (those of its search-and-rescue ``kind``, if any), and say so."""
    config = _config_from_args(args, object_atlas(mesh, kind))
    t0 = time.perf_counter()
    atlas, built = ensure_atlas(mesh, config, out, force=args.force, workers=args.workers,
                                rebuild_command=command)
    npz, _, png = atlas_paths(out, atlas.name)
    what = f"built in {time.perf_counter() - t0:.1f} s" if built else "up to date, reused"
    print(f"atlas {atlas.name}: {len(atlas)} poses, {config.size} px sprites, "
          f"{1000 * atlas.metres_per_pixel:.2f} mm/px, {what}\n"
          f"  {npz} ({_fmt_bytes(npz.stat().st_size)})\n  {png}")
    return atlas


if __name__ == "__main__":
    sys.exit(run_cli(main))
