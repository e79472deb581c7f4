"""The sprite atlas of a mesh: built once at every pose of a :class:`PoseGrid`, stored, loaded.

Per pose it stores coverage alpha, albedo, camera-frame normals and heights above the
waterline, so that the renderer can scale, relight and submerge the sprite later. On disk:

- ``<out>/<name>.npz``: plain arrays (``np.load(path, allow_pickle=False)``):
  ``poses`` (P, 4) float64 degrees (off-nadir, azimuth, and two tilt columns that are always
  0: tilt is the renderer's, see :mod:`sdcomp.atlas.poses`);
  ``alpha`` (P, S, S) uint8 coverage x 255 (rounded; > 0 exactly where any sub-pixel is hit);
  ``albedo`` (P, S, S, 3) uint8 sRGB; ``normal`` (P, S, S, 3) int8 unit normal x 127 in the
  camera frame (x right, y up, z towards the camera); ``height`` (P, S, S) float16 metres
  above the waterline; ``occlusion`` (P, S, S) uint8 the share of the sky each pixel's
  surface sees x 255 (:mod:`sdcomp.atlas.occlusion`; 255 where empty).
- ``<out>/<name>.json``: the index (format version, mesh name and hash, metres per pixel,
  grid and render parameters, pose angles, checksum of the npz), written last.
- ``<out>/<name>_sheet.png``: contact sheet of all poses (:mod:`sdcomp.atlas.sheet`).

Reuse or build (the cache a run reads) is :mod:`sdcomp.atlas.cache`.

The command line (``python -m sdcomp.atlas build|info``) is :mod:`sdcomp.cli.atlas`.
"""

from __future__ import annotations

import functools
import hashlib
import json
import os
import zipfile
import zlib
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from .. import __version__
from ..assets.mesh import ColoredMesh
from ..errors import UserError
from ..util.files import atomic_path, atomic_write_bytes
from ..util.heap import keep_freed_memory
from ..util.pool import imap_ordered
from ..util.progress import Progress
from .budget import fitting_workers
from .occlusion import sky_maps, sprite_occlusion
from .poses import PoseGrid, nearest_pose
from .raster import Sprite, render

FORMAT = "sdcomp-atlas"
FORMAT_VERSION = 2  # 2: the occlusion channel
DEFAULT_OUT = None  # the user's atlas folder: sdcomp.atlas.cache.sprites_folder


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
    """Sprites of one mesh at every pose.

    ``encoded`` holds the arrays as stored on disk (see the module docstring); ``alpha``
    (float32 in [0, 1]), ``albedo`` (uint8 sRGB), ``normal`` (float32) and ``height``
    (float32 metres) are them decoded, made on first use and kept. :meth:`channels`
    decodes one pose only: the renderer's path, which keeps just the encoded arrays (9
    bytes per sprite pixel instead of 23)."""

    name: str
    encoded: dict[str, np.ndarray]
    metres_per_pixel: float
    index: dict
    _decoded: dict = field(default_factory=dict, repr=False, compare=False)

    @property
    def poses(self) -> np.ndarray:
        """(P, 4) float64 poses, degrees (see :mod:`sdcomp.atlas.poses`)."""
        return self.encoded["poses"]

    @property
    def size(self) -> int:
        """Side of the square sprites, pixels."""
        return int(self.encoded["alpha"].shape[1])

    def _full(self, key: str) -> np.ndarray:
        if key not in self._decoded:
            self._decoded[key] = _DECODE[key](self.encoded[key])
        return self._decoded[key]

    @property
    def alpha(self) -> np.ndarray:
        """(P, S, S) float32 coverage in [0, 1]."""
        return self._full("alpha")

    @property
    def albedo(self) -> np.ndarray:
        """(P, S, S, 3) uint8 sRGB albedo."""
        return self.encoded["albedo"]

    @property
    def normal(self) -> np.ndarray:
        """(P, S, S, 3) float32 normals, camera frame (x right, y up, z towards it)."""
        return self._full("normal")

    @property
    def height(self) -> np.ndarray:
        """(P, S, S) float32 heights above the waterline, metres."""
        return self._full("height")

    @property
    def occlusion(self) -> np.ndarray:
        """(P, S, S) float32 ambient occlusion in [0, 1] (1: sees the whole sky)."""
        return self._full("occlusion")

    def occlusion_of(self, i: int) -> np.ndarray:
        """(S, S) float32 ambient occlusion of pose ``i`` (:attr:`occlusion`'s values)."""
        return _DECODE["occlusion"](self.encoded["occlusion"][i])

    @property
    def mask(self) -> np.ndarray:
        """(P, S, S) bool: exactly the pixels with non-zero coverage."""
        return self.encoded["alpha"] > 0

    def __len__(self) -> int:
        return len(self.poses)

    def channels(self, i: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Pose ``i`` decoded: alpha (S, S) float32, albedo (S, S, 3) uint8, normal
        (S, S, 3) float32, height (S, S) float32 (the values of the full decoded arrays)."""
        e = self.encoded
        return (_DECODE["alpha"](e["alpha"][i]), e["albedo"][i],
                _DECODE["normal"](e["normal"][i]), _DECODE["height"](e["height"][i]))

    def sprite(self, i: int) -> Sprite:
        alpha, albedo, normal, height = self.channels(i)
        return Sprite(alpha, albedo, normal, height, alpha > 0)

    def nearest(self, off_nadir: float, azimuth: float) -> int:
        """Index of the stored pose nearest to a view (see :func:`poses.nearest_pose`)."""
        return nearest_pose(self.poses, off_nadir, azimuth)


#: decoders of the stored arrays (uint8 coverage x 255, int8 normal x 127, float16 height)
_DECODE = {
    "alpha": lambda a: a.astype(np.float32) / np.float32(255.0),
    "normal": lambda a: a.astype(np.float32) / np.float32(127.0),
    "height": lambda a: a.astype(np.float32),
    "occlusion": lambda a: a.astype(np.float32) / np.float32(255.0),
}


# --------------------------------------------------------------------------- building

def metres_per_pixel(mesh: ColoredMesh, config: AtlasConfig) -> float:
    """Pixel pitch so the mesh fits its canvas at every pose, with a 3 % margin and at least
    one empty pixel on each side (the 3 % alone is under a pixel below ~70 px): the
    diameter of its bounding sphere about the origin (the bounding-box centre)."""
    radius = float(np.linalg.norm(mesh.vertices, axis=1).max())
    return 2.0 * radius * max(1.03 / config.size, 1.01 / (config.size - 2))


def _render_pose(mesh: ColoredMesh, size: int, mpp: float, supersample: int,
                 pose: np.ndarray) -> Sprite:
    return render(mesh, pose[0], pose[1], size=size, metres_per_pixel=mpp,
                  supersample=supersample)


def build_atlas(mesh: ColoredMesh, config: AtlasConfig = AtlasConfig(), *,
                workers: int | None = None, progress: bool | None = None) -> Atlas:
    """Render ``mesh`` at every pose of ``config.grid`` (in ``workers`` processes of
    :func:`sdcomp.util.pool.imap_ordered`, or in this one when ``workers`` is 1).

    The result does not depend on the number of workers: they are fewer where more would
    not fit in the machine's memory, and a build that does not fit with one is refused
    (:mod:`sdcomp.atlas.budget`). Freed sub-pixel buffers stay in
    the heap (:func:`sdcomp.util.heap.keep_freed_memory`): without it page faults took a
    third of a build's time.
    """
    keep_freed_memory()
    poses = config.grid.poses()
    mpp = metres_per_pixel(mesh, config)
    workers = fitting_workers(mesh.name, len(mesh.faces), config.size, config.supersample,
                              len(poses), max(1, min(workers or os.cpu_count() or 1, len(poses))))
    bar = Progress(len(poses), f"atlas {mesh.name}", enabled=progress, unit="poses")
    one = functools.partial(_render_pose, mesh, config.size, mpp, config.supersample)
    results = map(one, poses) if workers == 1 else imap_ordered(
        one, list(poses), workers, what="pose")
    sprites: list[Sprite] = []
    for sprite in results:
        sprites.append(sprite)
        bar.update()
    bar.close()
    maps = sky_maps(mesh)
    occlusion = np.stack([sprite_occlusion(sp, float(pose[0]), float(pose[1]), mpp,
                                           float(mesh.waterline), maps)
                          for sp, pose in zip(sprites, poses, strict=True)])
    alpha, albedo, normal, height = (np.stack([getattr(s, k) for s in sprites])
                                     for k in ("alpha", "albedo", "normal", "height"))
    encoded = _encode(poses, alpha, albedo, normal, height, occlusion)
    index = _index(mesh, config, mpp, poses)
    return Atlas(mesh.name, encoded, float(index["metres_per_pixel"]), index)


def _encode(poses: np.ndarray, alpha: np.ndarray, albedo: np.ndarray, normal: np.ndarray,
            height: np.ndarray, occlusion: np.ndarray) -> dict[str, np.ndarray]:
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
        "occlusion": np.clip(np.rint(occlusion * 255), 0, 255).astype(np.uint8),
    }


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
    arrays = atlas.encoded
    with atomic_path(npz) as tmp:
        with open(tmp, "wb") as fh:
            # (numpy's stub types the keyword arrays as its allow_pickle flag)
            np.savez_compressed(fh, **arrays)  # type: ignore[arg-type]
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


def resolve_atlas_path(path: str | Path) -> tuple[Path, Path]:
    """(npz, index) for a path given as the npz, the json, or the name without suffix."""
    p = Path(path)
    if p.suffix in (".npz", ".json"):
        p = p.with_suffix("")
    return p.with_suffix(".npz"), p.with_suffix(".json")


def read_index(path: str | Path) -> dict:
    """The atlas index (json) for ``path``; AtlasError if missing, corrupt or of another version."""
    npz, idx = resolve_atlas_path(path)
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
    npz, idx = resolve_atlas_path(path)
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
            arrays = {k: data[k] for k in ("poses", "alpha", "albedo", "normal", "height",
                                           "occlusion")}
    except (OSError, ValueError, KeyError, zipfile.BadZipFile, EOFError, zlib.error,
            NotImplementedError) as exc:
        raise AtlasError(f"atlas data {str(npz)!r} cannot be read ({exc}): {how}") from None
    _check_arrays(arrays, index, npz, how)
    return Atlas(index.get("name", npz.stem), arrays, float(index["metres_per_pixel"]), index)


def _check_arrays(arrays: dict, index: dict, npz: Path, how: str) -> None:
    p, s = len(index["poses"]), int(index["size_px"])  # fields checked by read_index
    want = {"poses": ((p, 4), np.float64), "alpha": ((p, s, s), np.uint8),
            "albedo": ((p, s, s, 3), np.uint8), "normal": ((p, s, s, 3), np.int8),
            "height": ((p, s, s), np.float16), "occlusion": ((p, s, s), np.uint8)}
    for k, (shape, dtype) in want.items():
        a = arrays[k]
        if a.shape != shape or a.dtype != dtype:
            raise AtlasError(f"atlas data {str(npz)!r}: array {k!r} is {a.dtype}{a.shape}, "
                             f"expected {np.dtype(dtype)}{shape}: {how}")


def _how_to_rebuild(index: dict | None) -> str:
    cmd = (index or {}).get("rebuild_command") or "python -m sdcomp.atlas build --mesh NAME_OR_PATH"
    return f"rebuild it with `{cmd} --force`"
