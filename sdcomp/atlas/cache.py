"""An atlas cache folder: the saved atlas of a mesh and atlas parameters is loaded when
intact and current, otherwise built and saved (:mod:`sdcomp.atlas.store`), one process at a
time. The folder is the user's (:func:`sprites_folder`: ``--sprites``, else
``$SDCOMP_SPRITES``, else the platform's per-user cache folder), shared by every working
folder, run and shard."""

from __future__ import annotations

import os
import sys
from pathlib import Path

from ..assets.mesh import ColoredMesh
from ..util.files import held_lock
from ..util.log import get_logger
from .sheet import write_contact_sheet
from .store import (
    Atlas,
    AtlasConfig,
    AtlasError,
    atlas_paths,
    build_atlas,
    cache_key,
    load_atlas,
    read_index,
    save_atlas,
)

#: the environment variable that names the sprite-atlas folder (``--sprites`` wins over it)
SPRITES_ENV = "SDCOMP_SPRITES"


def user_cache_dir() -> Path:
    """sdcomp's per-user cache folder: the platform's (``~/.cache/sdcomp`` on Linux,
    ``~/Library/Caches/sdcomp`` on macOS, ``%LOCALAPPDATA%\\sdcomp\\Cache`` on Windows)."""
    try:
        from platformdirs import user_cache_path
    except ImportError:  # platformdirs missing: the XDG rule, right on Linux
        base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
        return Path(base) / "sdcomp"
    return Path(user_cache_path("sdcomp", appauthor=False))


def sprites_folder(given: str | Path | None = None) -> Path:
    """The sprite-atlas folder: ``given`` (``--sprites``), else ``$SDCOMP_SPRITES``, else
    ``sprites`` in the user's cache folder (:func:`user_cache_dir`)."""
    if given is not None and str(given) != "":
        return Path(given).expanduser()
    if os.environ.get(SPRITES_ENV):
        return Path(os.environ[SPRITES_ENV]).expanduser()
    return user_cache_dir() / "sprites"


def missing_atlases(folder: Path, names: list[str]) -> list[str]:
    """The ``names`` whose atlas is not saved in ``folder`` yet (no index file)."""
    return [n for n in names if not atlas_paths(folder, n)[1].exists()]


def announce_build(folder: Path, n: int, seconds_each: float = 3.5) -> None:
    """Say on stderr, in one line and at once, that ``n`` atlases are being built, where and
    for about how long (``seconds_each`` an atlas on one core, shared by the cores)."""
    minutes = n * seconds_each / max(1, os.cpu_count() or 1) / 60
    about = f"about {minutes:.0f} min" if minutes >= 1 else "under a minute"
    print(f"building {n} sprite atlas{'es' if n != 1 else ''} once into {folder} "
          f"({about} on this machine)", file=sys.stderr, flush=True)


def ensure_atlas(mesh: ColoredMesh, config: AtlasConfig, out_dir: str | Path, *,
                 force: bool = False, workers: int | None = None,
                 progress: bool | None = None, rebuild_command: str = "",
                 sheet: bool = True) -> tuple[Atlas, bool]:
    """Load the cached atlas of ``mesh`` and ``config`` from ``out_dir``, or build and save it.

    A cached atlas is reused only when its cache key (format, mesh content, parameters)
    matches and its files are intact; otherwise it is rebuilt. Processes sharing
    ``out_dir`` build an atlas one at a time (a lock file ``.NAME.lock``): the others wait
    and load it. Returns (atlas, built).
    """
    npz, idx, png = atlas_paths(out_dir, mesh.name)
    if not force and (atlas := _cached(mesh, config, npz, idx, png, sheet)) is not None:
        return atlas, False
    idx.parent.mkdir(parents=True, exist_ok=True)
    with held_lock(idx.with_name(f".{mesh.name}.lock")):
        if not force and (atlas := _cached(mesh, config, npz, idx, png, sheet)) is not None:
            return atlas, False  # another process built it while this one waited
        atlas = build_atlas(mesh, config, workers=workers, progress=progress)
        save_atlas(atlas, out_dir, rebuild_command)
        if sheet:
            write_contact_sheet(atlas, png)
    return atlas, True


def _cached(mesh: ColoredMesh, config: AtlasConfig, npz: Path, idx: Path, png: Path,
            sheet: bool) -> Atlas | None:
    """The intact saved atlas of ``mesh`` and ``config`` (its sheet written if missing and
    ``sheet``), or None (a damaged one is named in a warning)."""
    if not (idx.exists() and npz.exists()):
        return None
    try:
        if read_index(idx).get("cache_key") != cache_key(mesh, config):
            return None
        atlas = load_atlas(idx)
    except AtlasError as e:  # damaged: say which file; the caller rebuilds it
        get_logger(__name__).warning(
            "the sprite atlas %s is damaged or unreadable (%s); rebuilding it",
            idx, str(e).split(": rebuild it")[0])
        return None
    if sheet and not png.exists():
        write_contact_sheet(atlas, png)
    return atlas
