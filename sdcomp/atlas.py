"""The sprite atlas: a mesh pre-rendered once at every pose of a :class:`PoseGrid`.

Per pose it stores coverage alpha, albedo, camera-frame normals and heights above the
waterline, so that a compositor can scale, relight and submerge the sprite later. On disk:

- ``<out>/<name>.npz``: plain arrays (``np.load(path, allow_pickle=False)``):
  ``poses`` (P, 4) float64 degrees (off-nadir, azimuth, roll, pitch);
  ``alpha`` (P, S, S) uint8 coverage x 255 (rounded; > 0 exactly where any sub-pixel is hit);
  ``albedo`` (P, S, S, 3) uint8 sRGB; ``normal`` (P, S, S, 3) int8 unit normal x 127 in the
  camera frame (x right, y up, z towards the camera); ``height`` (P, S, S) float16 metres
  above the waterline.
- ``<out>/<name>.json``: the index (format version, mesh name and hash, metres per pixel,
  grid and render parameters, pose angles, checksum of the npz), written last.
- ``<out>/<name>_sheet.png``: contact sheet of all poses, shaded with a default sun.

Command line::

    python -m sdcomp.atlas build [--mesh bluerov2|bluerov2-heavy|PATH] [--out sprites/]
    python -m sdcomp.atlas info sprites/bluerov2.npz
"""

from __future__ import annotations

import argparse
import hashlib
import json
import math
import os
import shlex
import signal
import sys
import time
import zipfile
import zlib
from collections.abc import Sequence
from concurrent.futures import ProcessPoolExecutor
from dataclasses import asdict, dataclass, field
from pathlib import Path

import cv2
import numpy as np

from . import __version__
from .cli import prog
from .coloredmesh import ColoredMesh
from .errors import UserError, run_cli
from .fileio import atomic_path, atomic_write_bytes
from .log import get_logger
from .mesh import MeshSpec, add_mesh_arguments, mesh_spec_from_args
from .poses import PoseGrid, nearest_pose, tilt_matrix, view_basis
from .progress import Progress
from .render import Sprite, render
from .shading import shade, sun_direction

FORMAT = "sdcomp-atlas"
FORMAT_VERSION = 1
DEFAULT_OUT = "sprites"
SHEET_SUN = (50.0, 135.0)  # elevation, azimuth (degrees) of the contact sheet's sun
SHEET_BACKGROUND = (70, 90, 105)  # sRGB behind the contact sheet's sprites


class AtlasError(UserError):
    """An atlas file that is missing, corrupt, truncated or of another format version."""


@dataclass(frozen=True)
class AtlasConfig:
    """How to render an atlas; validated on construction.

    Attributes:
        size: side of each square sprite, output pixels.
        supersample: sub-pixels per output pixel along each axis (anti-aliasing).
        grid: the poses to render.
    """

    size: int = 128
    supersample: int = 4
    grid: PoseGrid = field(default_factory=PoseGrid)

    def __post_init__(self) -> None:
        if not (isinstance(self.size, int) and 8 <= self.size <= 2048):
            raise UserError(f"--size {self.size} is out of range: use 8 to 2048 pixels")
        if not (isinstance(self.supersample, int) and 1 <= self.supersample <= 16):
            raise UserError(f"--supersample {self.supersample} is out of range: use 1 to 16")

    def to_dict(self) -> dict:
        d = asdict(self)
        # equal grids hash equally whether given as ints (Python) or floats (command line)
        d["grid"] = {k: float(v) for k, v in d["grid"].items()}
        return d


@dataclass(frozen=True, eq=False)
class Atlas:
    """Sprites of one mesh at every pose (arrays as described in the module docstring, but
    decoded: ``alpha`` float32 in [0, 1], ``normal`` float32, ``height`` float32)."""

    name: str
    poses: np.ndarray
    alpha: np.ndarray
    albedo: np.ndarray
    normal: np.ndarray
    height: np.ndarray
    metres_per_pixel: float
    index: dict

    @property
    def mask(self) -> np.ndarray:
        """(P, S, S) bool: exactly the pixels with non-zero coverage."""
        return self.alpha > 0

    def __len__(self) -> int:
        return len(self.poses)

    def sprite(self, i: int) -> Sprite:
        return Sprite(self.alpha[i], self.albedo[i], self.normal[i], self.height[i],
                      self.alpha[i] > 0)

    def nearest(self, off_nadir: float, azimuth: float, roll: float = 0.0,
                pitch: float = 0.0) -> int:
        """Index of the stored pose nearest to a view (see :func:`poses.nearest_pose`)."""
        return nearest_pose(self.poses, off_nadir, azimuth, roll, pitch)


# --------------------------------------------------------------------------- building

def metres_per_pixel(mesh: ColoredMesh, config: AtlasConfig) -> float:
    """Pixel pitch so the mesh fits its canvas at every pose and tilt, with a 3 % margin
    and at least one empty pixel on each side (the 3 % alone is under a pixel below ~70 px)."""
    pivot = np.array([0.0, 0.0, mesh.waterline])
    radius = 0.0
    for roll, pitch in config.grid.tilts():
        v = (mesh.vertices - pivot) @ tilt_matrix(roll, pitch).T + pivot
        radius = max(radius, float(np.linalg.norm(v, axis=1).max()))
    return 2.0 * radius * max(1.03 / config.size, 1.01 / (config.size - 2))


_WORKER: dict = {}


def _init_worker(mesh: ColoredMesh, size: int, mpp: float, ss: int,
                 subprocess: bool = False) -> None:
    if subprocess:  # Ctrl-C is the parent's to handle: no traceback from every worker
        signal.signal(signal.SIGINT, signal.SIG_IGN)
    _WORKER.update(mesh=mesh, size=size, mpp=mpp, ss=ss)


def _render_pose(pose: Sequence[float]) -> Sprite:
    w = _WORKER
    return render(w["mesh"], pose[0], pose[1], roll=pose[2], pitch=pose[3], size=w["size"],
                  metres_per_pixel=w["mpp"], supersample=w["ss"])


def build_atlas(mesh: ColoredMesh, config: AtlasConfig = AtlasConfig(), *,
                workers: int | None = None, progress: bool | None = None) -> Atlas:
    """Render ``mesh`` at every pose of ``config.grid`` (in ``workers`` processes).

    The result does not depend on the number of workers.
    """
    poses = config.grid.poses()
    mpp = metres_per_pixel(mesh, config)
    workers = max(1, min(workers or os.cpu_count() or 1, len(poses)))
    bar = Progress(len(poses), f"atlas {mesh.name}", enabled=progress, unit="poses")
    sprites: list[Sprite] = []
    args = (mesh, config.size, mpp, config.supersample)
    if workers == 1:
        _init_worker(*args)
        for p in poses:
            sprites.append(_render_pose(p))
            bar.update()
    else:
        ex = ProcessPoolExecutor(workers, initializer=_init_worker, initargs=(*args, True))
        try:
            for s in ex.map(_render_pose, list(poses), chunksize=4):
                sprites.append(s)
                bar.update()
        finally:  # on Ctrl-C or an error, do not wait for the remaining poses
            ex.shutdown(wait=False, cancel_futures=True)
    bar.close()
    encoded = _encode(poses, *(np.stack([getattr(s, k) for s in sprites])
                               for k in ("alpha", "albedo", "normal", "height")))
    index = _index(mesh, config, mpp, poses)
    return _decode(mesh.name, encoded, index)


def _encode(poses: np.ndarray, alpha: np.ndarray, albedo: np.ndarray, normal: np.ndarray,
            height: np.ndarray) -> dict[str, np.ndarray]:
    """The on-disk arrays (see the module docstring) from stacked (P, S, S, ...) arrays.

    Encoding decoded arrays again gives the same bytes: saving a loaded atlas is lossless.
    """
    return {
        "poses": poses.astype(np.float64),
        # round up from zero so that a single covered sub-pixel never rounds to 0
        "alpha": np.where(alpha > 0, np.maximum(np.rint(alpha * 255), 1), 0).astype(np.uint8),
        "albedo": albedo.astype(np.uint8),
        "normal": np.rint(normal * 127).astype(np.int8),
        "height": height.astype(np.float16),
    }


def _decode(name: str, arrays: dict[str, np.ndarray], index: dict) -> Atlas:
    normal = arrays["normal"].astype(np.float32) / 127.0
    return Atlas(
        name=name,
        poses=arrays["poses"],
        alpha=arrays["alpha"].astype(np.float32) / 255.0,
        albedo=arrays["albedo"],
        normal=normal,
        height=arrays["height"].astype(np.float32),
        metres_per_pixel=float(index["metres_per_pixel"]),
        index=index,
    )


def cache_key(mesh: ColoredMesh, config: AtlasConfig) -> str:
    """Hash of everything an atlas depends on: format, mesh content, render parameters."""
    blob = json.dumps({"format_version": FORMAT_VERSION, "mesh": mesh.content_hash(),
                       "config": config.to_dict()}, sort_keys=True)
    return hashlib.sha256(blob.encode()).hexdigest()


def _index(mesh: ColoredMesh, config: AtlasConfig, mpp: float, poses: np.ndarray) -> dict:
    return {
        "format": FORMAT,
        "format_version": FORMAT_VERSION,
        "sdcomp_version": __version__,
        "name": mesh.name,
        "mesh": {
            "name": mesh.name,
            "hash": mesh.content_hash(),
            "triangles": int(len(mesh.faces)),
            "extents_m": [round(float(e), 6) for e in mesh.extents],
            "waterline_m": mesh.waterline,
        },
        "metres_per_pixel": mpp,
        "size_px": config.size,
        "supersample": config.supersample,
        "grid": asdict(config.grid),
        "rings": [[t, n] for t, n in config.grid.rings()],
        "pose_columns": ["off_nadir_deg", "azimuth_deg", "roll_deg", "pitch_deg"],
        "poses": np.round(poses, 6).tolist(),
        "cache_key": cache_key(mesh, config),
    }


# --------------------------------------------------------------------------- files

def atlas_paths(out_dir: str | Path, name: str) -> tuple[Path, Path, Path]:
    """(npz, json index, contact sheet png) paths of atlas ``name`` in ``out_dir``."""
    out = Path(out_dir)
    return out / f"{name}.npz", out / f"{name}.json", out / f"{name}_sheet.png"


def save_atlas(atlas: Atlas, out_dir: str | Path, rebuild_command: str = "") -> tuple[Path, Path]:
    """Write the atlas's npz then its index (last, so a complete index means a complete atlas).

    Every file is written atomically. Returns (npz path, index path).
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    npz, idx, _ = atlas_paths(out, atlas.name)
    arrays = _encode(atlas.poses, atlas.alpha, atlas.albedo, atlas.normal, atlas.height)
    with atomic_path(npz) as tmp:
        with open(tmp, "wb") as fh:
            np.savez_compressed(fh, **arrays)
    index = dict(atlas.index)
    index.update(npz_file=npz.name, npz_sha256=_sha256(npz), npz_bytes=npz.stat().st_size,
                 rebuild_command=rebuild_command or index.get("rebuild_command", ""))
    atomic_write_bytes(idx, (json.dumps(index, indent=1) + "\n").encode())
    object.__setattr__(atlas, "index", index)
    return npz, idx


def _sha256(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def _resolve(path: str | Path) -> tuple[Path, Path]:
    """(npz, index) for a path given as the npz, the json, or the name without suffix."""
    p = Path(path)
    if p.suffix in (".npz", ".json"):
        p = p.with_suffix("")
    return p.with_suffix(".npz"), p.with_suffix(".json")


def read_index(path: str | Path) -> dict:
    """The atlas index (json) for ``path``; AtlasError if missing, corrupt or of another version."""
    npz, idx = _resolve(path)
    how = _how_to_rebuild(None)
    if not idx.is_file():
        raise AtlasError(f"no atlas index {str(idx)!r}: {how}")
    try:
        index = json.loads(idx.read_text())
        if not isinstance(index, dict):
            raise ValueError("not an object")
    except OSError as exc:
        raise AtlasError(f"atlas index {str(idx)!r} cannot be read ({exc.strerror}): "
                         f"{how}") from None
    except (ValueError, UnicodeDecodeError) as exc:
        raise AtlasError(f"atlas index {str(idx)!r} is corrupt ({exc}): {how}") from None
    how = _how_to_rebuild(index)
    if index.get("format") != FORMAT:
        raise AtlasError(f"{str(idx)!r} is not an sdcomp atlas index: {how}")
    if index.get("format_version") != FORMAT_VERSION:
        raise AtlasError(
            f"atlas {str(idx)!r} has format version {index.get('format_version')!r}, this "
            f"sdcomp {__version__} reads version {FORMAT_VERSION}: {how}")
    try:
        len(index["poses"]), int(index["size_px"]), int(index["supersample"])
        float(index["metres_per_pixel"])
        str(index["mesh"]["name"]), str(index["mesh"]["hash"]), int(index["mesh"]["triangles"])
    except (KeyError, TypeError, ValueError):
        raise AtlasError(f"atlas index {str(idx)!r} lacks fields or has wrong types: "
                         f"{how}") from None
    return index


def load_atlas(path: str | Path, verify: bool = True) -> Atlas:
    """Load an atlas (npz + index), checking checksum, arrays, shapes and dtypes.

    Raises AtlasError, whose message says how to rebuild, for any missing, corrupt,
    truncated or wrong-version file. Never unpickles anything.
    """
    npz, idx = _resolve(path)
    index = read_index(path)
    how = _how_to_rebuild(index)
    if not npz.exists():
        raise AtlasError(f"atlas data {str(npz)!r} is missing: {how}")
    if verify and index.get("npz_sha256") != _sha256(npz):
        raise AtlasError(f"atlas data {str(npz)!r} is corrupt or truncated "
                         f"(checksum differs from its index): {how}")
    try:
        data = np.load(npz, allow_pickle=False)
        if not isinstance(data, np.lib.npyio.NpzFile):  # a bare .npy array, not an archive
            raise ValueError("not an npz archive")
        with data:
            arrays = {k: data[k] for k in ("poses", "alpha", "albedo", "normal", "height")}
    except (OSError, ValueError, KeyError, zipfile.BadZipFile, EOFError, zlib.error,
            NotImplementedError) as exc:
        raise AtlasError(f"atlas data {str(npz)!r} cannot be read ({exc}): {how}") from None
    _check_arrays(arrays, index, npz, how)
    return _decode(index.get("name", npz.stem), arrays, index)


def _check_arrays(arrays: dict, index: dict, npz: Path, how: str) -> None:
    p, s = len(index["poses"]), int(index["size_px"])  # fields checked by read_index
    want = {"poses": ((p, 4), np.float64), "alpha": ((p, s, s), np.uint8),
            "albedo": ((p, s, s, 3), np.uint8), "normal": ((p, s, s, 3), np.int8),
            "height": ((p, s, s), np.float16)}
    for k, (shape, dtype) in want.items():
        a = arrays[k]
        if a.shape != shape or a.dtype != dtype:
            raise AtlasError(f"atlas data {str(npz)!r}: array {k!r} is {a.dtype}{a.shape}, "
                             f"expected {np.dtype(dtype)}{shape}: {how}")


def _how_to_rebuild(index: dict | None) -> str:
    cmd = (index or {}).get("rebuild_command") or "python -m sdcomp.atlas build --mesh NAME_OR_PATH"
    return f"rebuild it with `{cmd} --force`"


def ensure_atlas(mesh: ColoredMesh, config: AtlasConfig, out_dir: str | Path, *,
                 force: bool = False, workers: int | None = None,
                 progress: bool | None = None, rebuild_command: str = "",
                 sheet: bool = True) -> tuple[Atlas, bool]:
    """Load the cached atlas of ``mesh`` and ``config`` from ``out_dir``, or build and save it.

    A cached atlas is reused only when its cache key (format, mesh content, parameters)
    matches and its files are intact; otherwise it is rebuilt. Returns (atlas, built).
    """
    npz, idx, png = atlas_paths(out_dir, mesh.name)
    if not force and idx.exists() and npz.exists():
        try:
            if read_index(idx).get("cache_key") == cache_key(mesh, config):
                atlas = load_atlas(idx)
                if sheet and not png.exists():
                    write_contact_sheet(atlas, png)
                return atlas, False
        except AtlasError as e:  # damaged: say which file, then rebuild it below
            get_logger(__name__).warning(
                "the sprite atlas %s is damaged or unreadable (%s); rebuilding it",
                idx, str(e).split(": rebuild it")[0])
    atlas = build_atlas(mesh, config, workers=workers, progress=progress)
    save_atlas(atlas, out_dir, rebuild_command)
    if sheet:
        write_contact_sheet(atlas, png)
    return atlas, True


# --------------------------------------------------------------------------- contact sheet

def contact_sheet(atlas: Atlas, cell: int = 96, columns: int = 20,
                  sun: tuple[float, float] = SHEET_SUN) -> np.ndarray:
    """(H, W, 3) uint8 RGB image of every pose, shaded with a sun at (elevation, azimuth)
    degrees in the body frame, on a grey-blue background, labelled off-nadir/azimuth."""
    n = len(atlas)
    rows = math.ceil(n / columns)
    sheet = np.empty((rows * cell, columns * cell, 3), np.uint8)
    sheet[:] = SHEET_BACKGROUND
    sun_w = sun_direction(*sun)
    bg = np.array(SHEET_BACKGROUND, np.float32)
    for i in range(n):
        theta, phi = atlas.poses[i, 0], atlas.poses[i, 1]
        s_cam = view_basis(theta, phi) @ sun_w
        lit = shade(atlas.albedo[i], atlas.normal[i], s_cam).astype(np.float32)
        a = atlas.alpha[i][..., None]
        img = (lit * a + bg * (1 - a)).astype(np.uint8)
        img = cv2.resize(img, (cell, cell), interpolation=cv2.INTER_AREA)
        r, c = divmod(i, columns)
        tile = sheet[r * cell:(r + 1) * cell, c * cell:(c + 1) * cell]
        tile[:] = img
        label = f"{theta:.0f}/{phi:.0f}"
        if atlas.poses[i, 2] or atlas.poses[i, 3]:
            label += f" t{atlas.poses[i, 2]:.0f},{atlas.poses[i, 3]:.0f}"
        cv2.putText(tile, label, (2, cell - 4), cv2.FONT_HERSHEY_SIMPLEX, 0.3,
                    (235, 235, 235), 1, cv2.LINE_AA)
    return sheet


def write_contact_sheet(atlas: Atlas, path: str | Path) -> Path:
    """Write :func:`contact_sheet` as a PNG, atomically."""
    path = Path(path)
    ok, buf = cv2.imencode(".png", cv2.cvtColor(contact_sheet(atlas), cv2.COLOR_RGB2BGR))
    if not ok:
        raise OSError(f"could not encode {path}")
    atomic_write_bytes(path, buf.tobytes())
    return path


# --------------------------------------------------------------------------- command line

def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog=prog("atlas"),
                                description="Pre-render a mesh into a pose-indexed sprite atlas.")
    sub = p.add_subparsers(dest="command", required=True)
    b = sub.add_parser("build", help="build (or reuse) the atlas of a mesh",
                       formatter_class=argparse.ArgumentDefaultsHelpFormatter)
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
    b.add_argument("--tilt-max", type=float, default=g.tilt_max, metavar="DEG",
                   help="vehicle roll/pitch (wave tilt) up to this, 0 = none")
    b.add_argument("--tilt-step", type=float, default=g.tilt_step, metavar="DEG",
                   help="spacing of the tilt values")
    b.add_argument("--workers", type=int, default=None, metavar="N",
                   help="render processes (default: all cores)")
    b.add_argument("--force", action="store_true", help="rebuild even if a matching atlas exists")
    i = sub.add_parser("info", help="describe and check an atlas file")
    i.add_argument("path", metavar="PATH", help="atlas .npz or .json (or the name without suffix)")
    return p


_GRID_FLAGS = (("max off-nadir", "max_off_nadir"), ("off-nadir step", "off_nadir_step"),
               ("max error", "max_error"), ("tilt max", "tilt_max"), ("tilt step", "tilt_step"))


def _config_from_args(args: argparse.Namespace) -> AtlasConfig:
    try:
        grid = PoseGrid(max_off_nadir=args.max_off_nadir, off_nadir_step=args.off_nadir_step,
                        max_error=args.max_error, tilt_max=args.tilt_max,
                        tilt_step=args.tilt_step)
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
    defaults = build_parser()._subparsers._group_actions[0].choices["build"]  # type: ignore
    for opt in ("size", "supersample", "max_off_nadir", "off_nadir_step", "max_error",
                "tilt_max", "tilt_step"):
        if getattr(args, opt) != defaults.get_default(opt):
            parts.append(f"--{opt.replace('_', '-')} {getattr(args, opt)}")
    return " ".join(parts)


def _fmt_bytes(n: int) -> str:
    return f"{n / 1e6:.1f} MB" if n >= 1e5 else f"{n / 1e3:.1f} kB"


def info(path: str | Path) -> str:
    """A description of the atlas at ``path``, after checking it loads."""
    atlas = load_atlas(path)
    ix = atlas.index
    npz, _ = _resolve(path)
    rings = ", ".join(f"{t:g}:{n}" for t, n in ix.get("rings", []))
    covered = atlas.mask.reshape(len(atlas), -1).mean(axis=1)
    return "\n".join([
        f"atlas:        {npz} ({_fmt_bytes(npz.stat().st_size)}, format {ix['format_version']}, "
        f"sdcomp {ix.get('sdcomp_version')})",
        f"mesh:         {ix['mesh']['name']} ({ix['mesh']['triangles']} triangles, "
        f"hash {ix['mesh']['hash'][:12]})",
        f"poses:        {len(atlas)}; rings (off-nadir:azimuths) {rings}",
        f"tilts:        {len({(r, p) for r, p in atlas.poses[:, 2:]})}",
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
