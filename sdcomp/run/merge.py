"""Joining shard folders into one dataset (``python -m sdcomp.merge SHARD_DIR... --out DIR``,
:mod:`sdcomp.cli.merge`).

Each ``--shard K/N`` run (see :mod:`sdcomp.run.shards`) writes a dataset folder of its own images
(its ``dataset.json`` says ``"shard": "K/N"``). Merging checks that the folders are the N
shards of one config, each complete, then puts every image, mask (and YOLO label) into the
output folder (a hard link where the file system allows, else a copy; each file through a
temporary name), writes ``records.jsonl`` in index order and the annotation files and
``dataset.json`` from it: the result is byte-identical to one local run of the same config.

The shard folders are left as they were unless ``--remove-shards`` is given; a merge that
was stopped is redone with ``--overwrite``.
"""

from __future__ import annotations

import errno
import json
import os
import shutil
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from ..errors import UserError
from ..io.journal import read_journal
from ..io.layout import ENTRIES, FORMAT, DatasetLayout, check_format_version
from ..io.writers import writers_for
from ..scene.config import GeneratorConfig
from ..util.files import atomic_path
from ..util.progress import Progress
from .output import folders as run_folders
from .output import image_files, os_error_message, remove_dataset, write_annotations
from .record import split_of
from .shards import parse_shard, shard_range, shard_text


@dataclass(frozen=True)
class Shard:
    """One shard folder: where, which shard (k of n), its config and journal offsets."""

    folder: Path
    k: int
    n: int
    config: GeneratorConfig
    offsets: dict[int, int]  # {image index: byte offset in its records.jsonl}


def _relative_files(config: GeneratorConfig, index: int) -> list[Path]:
    """The per-image files of image ``index`` relative to a dataset folder."""
    return image_files(config, DatasetLayout(Path()), index)


def _ignore_file(config: GeneratorConfig, index: int) -> Path:
    """Image ``index``'s ignore mask relative to a dataset folder (written only for images
    with ignore regions)."""
    return DatasetLayout(Path()).ignore_file(index, split_of(config.seed, index,
                                                              config.val_fraction))


def _place_image(config: GeneratorConfig, shard: Path, out: Path, index: int) -> None:
    """Put image ``index``'s files from the folder ``shard`` into ``out`` (its ignore mask
    too, where it has one)."""
    for f in _relative_files(config, index):
        place_file(shard / f, out / f)
    ignore = _ignore_file(config, index)
    if (shard / ignore).is_file():
        place_file(shard / ignore, out / ignore)


def read_shard(folder: str | Path) -> Shard:
    """The shard in ``folder``; UserError naming the folder when it is not a shard's."""
    folder = Path(folder)
    try:
        meta = json.loads((folder / "dataset.json").read_text())
        if not isinstance(meta, dict) or meta.get("format") != FORMAT:
            raise ValueError
    except (OSError, ValueError):
        raise UserError(f"{folder} is not an sdcomp dataset folder (no valid dataset.json): "
                        f"give the --out folders of the --shard runs") from None
    check_format_version(meta, folder, "merge")
    if "shard" not in meta:
        raise UserError(f"{folder} is a whole dataset, not a shard (its run had no --shard): "
                        f"give the --out folders of the --shard K/N runs")
    try:
        k, n = parse_shard(meta["shard"])
    except UserError:
        raise UserError(f"{folder}/dataset.json: shard {meta['shard']!r} is not K/N; the "
                        f"file was edited: re-run that shard with --overwrite") from None
    config = GeneratorConfig.from_mapping(meta.get("config", {}), None,
                                          f"{folder}/dataset.json config")
    journal = folder / "records.jsonl"
    offsets = read_journal(journal) if journal.exists() else {}
    return Shard(folder, k, n, config, offsets)


def check_shards(shards: Sequence[Shard]) -> GeneratorConfig:
    """The common config of ``shards`` once they are checked to be all N shards of one run,
    each with every image's record and files; UserError naming what is wrong otherwise."""
    if not shards:
        raise UserError("give the shard folders to merge: python -m sdcomp.merge DIR... "
                        "--out DATASET")
    first = shards[0]
    want = first.config.to_dict()
    for s in shards[1:]:
        if s.n != first.n:
            raise UserError(f"{s.folder} is shard {shard_text((s.k, s.n))} but {first.folder} "
                            f"is shard {shard_text((first.k, first.n))}: merge the shards of "
                            f"one run (the same N)")
        have = s.config.to_dict()
        diff = [k for k in want if have.get(k) != want[k]]
        if diff:
            key = diff[0]
            raise UserError(f"{s.folder} was made with {key} = {have.get(key)!r} but "
                            f"{first.folder} with {want[key]!r}: merge the shards of one run")
    seen: dict[int, Path] = {}
    for s in shards:
        if s.k in seen:
            raise UserError(f"shard {shard_text((s.k, s.n))} is given twice ({seen[s.k]} and "
                            f"{s.folder}): give each shard folder once")
        seen[s.k] = s.folder
    missing = [k for k in range(first.n) if k not in seen]
    if missing:
        shown = ", ".join(shard_text((k, first.n)) for k in missing[:8])
        more = f" and {len(missing) - 8} more" if len(missing) > 8 else ""
        raise UserError(f"shard {shown}{more} missing: merge needs all {first.n} shard "
                        f"folders (run the missing ones with --shard K/{first.n})")
    config = first.config
    for s in shards:
        rng = shard_range(config.n, s.k, s.n)
        lacking = [i for i in rng if i not in s.offsets or not all(
            (s.folder / f).is_file() for f in _relative_files(config, i))]
        if lacking:
            raise UserError(f"shard {shard_text((s.k, s.n))} in {s.folder} is incomplete "
                            f"({len(rng) - len(lacking)} of {len(rng)} images, image "
                            f"{lacking[0]} missing): re-run it with its command plus --resume, "
                            f"then merge again")
    return config


def place_file(src: Path, dst: Path) -> None:
    """Put ``src``'s bytes at ``dst`` (a hard link, else a copy) through a temporary name."""
    tmp = dst.with_name(f".{dst.name}.{os.getpid()}.tmp")
    tmp.unlink(missing_ok=True)
    try:
        try:
            os.link(src, tmp)
        except OSError as e:
            if e.errno not in (errno.EXDEV, errno.EPERM, errno.EMLINK, errno.ENOTSUP,
                               errno.EOPNOTSUPP):
                raise
            shutil.copyfile(src, tmp)
        os.replace(tmp, dst)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


def merge(folders: Sequence[str | Path], out: str | Path, *, overwrite: bool = False,
          remove: bool = False, progress: bool | None = None) -> dict:
    """Merge the shard ``folders`` into the dataset folder ``out``; returns its counts.

    ``out`` must not hold a dataset already unless ``overwrite`` (which replaces only the
    dataset's own entries; other files, the shard folders among them, stay). ``remove``
    deletes the shard folders once the merged dataset is complete.
    """
    out = Path(out)
    shards = sorted((read_shard(f) for f in folders), key=lambda s: s.k)
    config = check_shards(shards)
    for s in shards:
        if out.resolve() == s.folder.resolve():
            raise UserError(f"--out {out} is the shard folder {s.folder}: merge into another "
                            f"folder")
    if out.exists() and not out.is_dir():
        raise UserError(f"--out {out} is a file; give a folder")
    ours = [out / name for name in ENTRIES if (out / name).exists()] if out.exists() else []
    if ours and not overwrite:
        raise UserError(f"--out {out} already holds a dataset ({ours[0].name}): add "
                        f"--overwrite to replace it, or choose another --out")
    try:
        remove_dataset(out)
        for folder in run_folders(DatasetLayout(out), writers_for(config)):
            folder.mkdir(parents=True, exist_ok=True)
        bar = Progress(config.n, "merge", progress, unit="img")
        with atomic_path(out / "records.jsonl") as tmp, open(tmp, "wb") as journal:
            for s in shards:
                with open(s.folder / "records.jsonl", "rb") as src:
                    for i in shard_range(config.n, s.k, s.n):
                        _place_image(config, s.folder, out, i)
                        src.seek(s.offsets[i])
                        line = src.readline()
                        journal.write(line if line.endswith(b"\n") else line + b"\n")
                        bar.update(1)
            journal.flush()
            os.fsync(journal.fileno())
        bar.close()
        counts = write_annotations(config, out, "complete")
        if remove:
            for s in shards:
                shutil.rmtree(s.folder)
    except OSError as e:
        raise UserError(os_error_message(e, out).replace(
            "continue with the same command and --resume",
            "merge again with --overwrite")) from None
    return counts
