"""``python -m sdcomp.atlas build|info`` (``sdcomp atlas``): build, reuse or check the
sprite atlas of a mesh (:mod:`sdcomp.atlas.store`).

    python -m sdcomp.atlas build [--mesh bluerov2|bluerov2-heavy|PATH] [--out sprites/]
    python -m sdcomp.atlas info sprites/bluerov2.npz
"""

from __future__ import annotations

import argparse
import os
import shlex
import sys
import time
from collections.abc import Sequence
from pathlib import Path

from ..assets.library import MeshSpec
from ..atlas.poses import PoseGrid
from ..atlas.store import (
    DEFAULT_OUT,
    AtlasConfig,
    atlas_paths,
    ensure_atlas,
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
    b.add_argument("--out", default=DEFAULT_OUT, metavar="DIR", help="atlas folder")
    b.add_argument("--size", type=int, default=AtlasConfig.size, metavar="PX",
                   help="sprite side, pixels")
    b.add_argument("--supersample", type=int, default=AtlasConfig.supersample, metavar="K",
                   help="K x K sub-pixels per pixel for anti-aliased coverage")
    b.add_argument("--max-off-nadir", type=float, default=g.max_off_nadir, metavar="DEG",
                   help="largest camera off-nadir angle stored (0 = straight down)")
    b.add_argument("--off-nadir-step", type=float, default=g.off_nadir_step, metavar="DEG",
                   help="spacing of the off-nadir rings")
    b.add_argument("--max-error", type=float, default=g.max_error, metavar="DEG",
                   help="largest angle between any view and its nearest stored pose")
    b.add_argument("--workers", type=int, default=None, metavar="N",
                   help="render processes (default: all cores)")
    b.add_argument("--force", action="store_true", help="rebuild even if a matching atlas exists")


_GRID_FLAGS = (("max off-nadir", "max_off_nadir"), ("off-nadir step", "off_nadir_step"),
               ("max error", "max_error"))


def _config_from_args(args: argparse.Namespace) -> AtlasConfig:
    try:
        grid = PoseGrid(max_off_nadir=args.max_off_nadir, off_nadir_step=args.off_nadir_step,
                        max_error=args.max_error)
    except ValueError as exc:
        msg = str(exc)
        for text, opt in _GRID_FLAGS:  # name the offending flag, as the other messages do
            if msg.startswith(text):
                msg = f"--{opt.replace('_', '-')}{msg[len(text):]}"
                break
        raise UserError(msg) from None
    return AtlasConfig(size=args.size, supersample=args.supersample, grid=grid)


def _rebuild_command(spec: MeshSpec, args: argparse.Namespace) -> str:
    q = shlex.quote
    parts = ["python -m sdcomp.atlas build", f"--mesh {q(spec.source)}", f"--out {q(args.out)}"]
    if not spec.is_builtin:
        parts += [f"--units {spec.units}", f"--up {spec.up}"]
        if args.color:
            parts.append(f"--color {q(args.color)}")
        if spec.waterline is not None:
            parts.append(f"--waterline {spec.waterline}")
    defaults = argparse.ArgumentParser()
    add_build_arguments(defaults)
    for opt in ("size", "supersample", "max_off_nadir", "off_nadir_step", "max_error"):
        if getattr(args, opt) != defaults.get_default(opt):
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
    config = _config_from_args(args)
    if args.workers is not None and args.workers < 1:
        raise UserError(f"--workers {args.workers} must be at least 1")
    spec = mesh_spec_from_args(args)
    mesh = spec.load()
    out = Path(args.out)
    _check_out_dir(out)
    t0 = time.perf_counter()
    atlas, built = ensure_atlas(mesh, config, out, force=args.force, workers=args.workers,
                                rebuild_command=_rebuild_command(spec, args))
    npz, _, png = atlas_paths(out, atlas.name)
    what = f"built in {time.perf_counter() - t0:.1f} s" if built else "up to date, reused"
    print(f"atlas {atlas.name}: {len(atlas)} poses, {config.size} px sprites, "
          f"{1000 * atlas.metres_per_pixel:.2f} mm/px, {what}\n"
          f"  {npz} ({_fmt_bytes(npz.stat().st_size)})\n  {png}")
    return 0


if __name__ == "__main__":
    sys.exit(run_cli(main))
