"""The output folder of a run, written once for every engine: prepare (check, clear or
resume), sweep temporary files, and finish (label files and dataset.json from the journal).

Every file appears whole or not at all (temporary name, then rename). Image ``i`` depends
only on (config, i), the journal is read back in index order, and nothing records times, so
the same config gives byte-identical images, masks, label files and dataset.json whatever
the number of workers and however often the run was interrupted and resumed.
"""

from __future__ import annotations

import errno
import json
import shutil
import signal
from collections.abc import Callable
from pathlib import Path
from typing import Any, NoReturn

from .. import __version__
from ..annotate.masks import MASK_RULE
from ..errors import UserError
from ..io.journal import iter_records, read_journal
from ..io.layout import (
    CORE_FOLDERS,
    ENTRIES,
    FORMAT,
    FORMAT_VERSION,
    LAYOUT_ORDER,
    DatasetLayout,
    check_format_version,
)
from ..io.writers import LabelWriter, writers_for
from ..scene.config import GeneratorConfig
from ..util.files import atomic_write_bytes
from .options import RunOptions, run_indices
from .record import split_of
from .shards import shard_text


def prepare_output(config: GeneratorConfig, options: RunOptions,
                   extra: tuple[str, ...] = (), check_resume: bool = True) -> set[int]:
    """Check or clear the output folder and make its folders; return the indices already
    done (a resumed run). ``extra``: more names of the run's own that --overwrite removes
    (an engine's work folder); ``check_resume`` False: the engine checks what a resumed
    folder holds itself (none are done here)."""
    out = options.out
    if out.exists() and not out.is_dir():
        raise UserError(f"--out {out} is a file; give a folder")
    entries = list(out.iterdir()) if out.exists() else []
    if entries and not (options.resume or options.overwrite):
        raise UserError(f"output folder {out} is not empty: add --resume to continue the "
                        f"run that made it, or --overwrite to replace it")
    if options.resume and options.overwrite:
        raise UserError("--resume and --overwrite exclude each other; pick one")
    done: set[int] = set()
    if entries and options.overwrite:
        remove_dataset(out, extra)
    elif entries and options.resume and check_resume:
        done = resumable(config, out, options.shard)
    layout = DatasetLayout(out)
    try:
        for folder in folders(layout, writers_for(config)):
            folder.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise UserError(f"--out {out}: cannot create the folder ({e.strerror})") from None
    sweep_tmp(layout, writers_for(config))
    return done


def remove_dataset(out: Path, extra: tuple[str, ...] = ()) -> None:
    """Remove a dataset's own entries from ``out`` (other files stay)."""
    for name in (*ENTRIES, *extra):
        p = out / name
        if p.is_dir():
            shutil.rmtree(p)
        elif p.exists():
            p.unlink()


def folders(layout: DatasetLayout, writers: list[LabelWriter]) -> list[Path]:
    """The folders a run makes: images and masks with their split sub-folders, and the
    label writers' (annotations/, labels/ and its split sub-folders)."""
    out = []
    for name in CORE_FOLDERS:
        out += [layout.root / name, *layout.split_folders(layout.root / name)]
    for w in writers:
        out += [f for f in w.folders(layout) if f not in out]
    return out


def sweep_tmp(layout: DatasetLayout, writers: list[LabelWriter]) -> None:
    """Remove the temporary files a killed run can leave (``.NAME.*.tmp``)."""
    for folder in folders(layout, writers):
        for tmp in folder.glob(".*.tmp"):
            tmp.unlink(missing_ok=True)
    for tmp in layout.root.glob(".dataset.json.*.tmp"):
        tmp.unlink(missing_ok=True)


def image_files(config: GeneratorConfig, layout: DatasetLayout, index: int) -> list[Path]:
    """Every file a run writes for image ``index``: image, mask and label files (in the
    image's split folders)."""
    split = split_of(config.seed, index, config.val_fraction)
    return [layout.image_file(index, config.image_format, split), layout.mask_file(index, split),
            *(p for w in writers_for(config) for p in w.image_files(layout, index, split))]


def _never_begun(out: Path) -> bool:
    """Whether ``out`` holds only the empty start of a run: our folders and temporary or
    annotation files, no image, no journal line."""
    layout = DatasetLayout(out)
    for p in out.iterdir():
        if p.name not in ENTRIES and not p.name.endswith(".tmp"):
            return False
        if p in (layout.images, layout.masks) and any(
                q for q in p.rglob("*") if q.is_file() and not q.name.endswith(".tmp")):
            return False
        if p == layout.journal and p.stat().st_size:
            return False
    return True


def resumable(config: GeneratorConfig, out: Path,
              shard: tuple[int, int] | None = None) -> set[int]:
    """The images of ``out`` a resumed run of ``config`` (and ``shard``) keeps: those with a
    journal line and all their files (the ignore mask too, for an image whose record names
    one). UserError when ``out`` was made with other options
    (a larger ``n`` without a shard is allowed: the run grows) or another dataset format."""
    layout = DatasetLayout(out)
    if not layout.meta.exists() and _never_begun(out):
        return set()  # killed between creating the folders and writing dataset.json
    try:
        meta = json.loads(layout.meta.read_text())
        if meta.get("format") != FORMAT:
            raise ValueError
    except (OSError, ValueError):
        raise UserError(f"--resume: {out} is not an sdcomp dataset (no valid dataset.json); "
                        f"use --overwrite to replace it or choose another --out") from None
    check_format_version(meta, out, "--resume")
    _check_same_run(config, meta, out, shard)
    if not layout.journal.exists():
        return set()
    indices = run_indices(config, shard)
    offsets = {i: off for i, off in read_journal(layout.journal).items() if i in indices
               and all(p.exists() for p in image_files(config, layout, i))}
    return {rec["index"] for rec in iter_records(layout.journal, offsets)
            if not rec["image"].get("ignore_file")
            or (layout.masks / rec["image"]["ignore_file"]).is_file()}


def _check_same_run(config: GeneratorConfig, meta: dict, out: Path,
                    shard: tuple[int, int] | None) -> None:
    """UserError unless dataset.json ``meta`` records ``config`` and ``shard``; a larger
    ``n`` (the run grows: image i depends only on (config, i)) is allowed without a shard."""
    old = meta.get("config", {})
    new = config.to_dict()
    # a field the folder's sdcomp did not have yet is at its default (the old behaviour)
    defaults = GeneratorConfig().to_dict()
    diff = [k for k in new if old.get(k, defaults[k]) != new[k]]
    if diff and diff[0] == "n" and isinstance(old.get("n"), int):
        if shard is not None or meta.get("shard"):
            raise UserError(f"--resume --n {new['n']}: {out} is a shard of a run of --n "
                            f"{old['n']}; shards cannot grow (their image ranges depend on "
                            f"--n): grow the merged dataset instead")
        if new["n"] < old["n"]:
            raise UserError(f"--resume --n {new['n']}: {out} holds a run of --n {old['n']}; "
                            f"a resumed run can only grow: use --n {old['n']} or larger, or "
                            f"--overwrite")
        diff = diff[1:]
    if diff:
        different_option(diff[0], old, new)
    check_same_shard(meta, out, shard)


def different_option(key: str, old: dict, new: dict) -> NoReturn:
    """The UserError of a resumed run whose option ``key`` differs from the folder's."""
    raise UserError(f"--resume: the folder was made with {key} = {old.get(key)!r}, not "
                    f"{new[key]!r}; run with the same options, or use --overwrite")


def check_same_shard(meta: dict, out: Path, shard: tuple[int, int] | None) -> None:
    """UserError unless the folder's metadata ``meta`` records ``shard`` (None: no shard)."""
    want = shard_text(shard) if shard else None
    if meta.get("shard") != want:
        was = f"--shard {meta['shard']}" if meta.get("shard") else "without --shard"
        now = f"--shard {want}" if want else "without --shard"
        raise UserError(f"--resume: {out} was made {was}, not {now}; resume it as it was "
                        f"made, or use --overwrite")


def _tally(layout: DatasetLayout, offsets: dict[int, int]) -> dict[str, Any]:
    """One pass over the journal: images per split (in order of first appearance),
    annotations, objects dropped (no visible pixel), truncated (labelled, cut by the frame's
    edge), ignored (visible, not labelled: an ignore region), skipped (not drawn:
    ``--unlabelled skip``), images without objects."""
    splits: dict[str, int] = {}
    annotations = empty = 0
    objects = {"dropped": 0, "truncated": 0, "ignored": 0, "skipped": 0}
    for rec in iter_records(layout.journal, offsets):
        splits[rec["split"]] = splits.get(rec["split"], 0) + 1
        annotations += len(rec["annotations"])
        meta = rec["image"]["meta"]
        for k in objects:
            objects[k] += int(meta.get(f"objects_{k}", 0))
        empty += not rec["annotations"]
    return {"splits": splits, "annotations": annotations, "empty": empty, **objects}


def write_annotations(config: GeneratorConfig, out: Path, status: str,
                      shard: tuple[int, int] | None = None) -> dict:
    """The label files of ``config.format`` and dataset.json from the journal (the images
    of ``shard`` only, when given); returns the counts."""
    layout = DatasetLayout(out)
    offsets = read_journal(layout.journal) if layout.journal.exists() else {}
    indices = run_indices(config, shard)
    offsets = {i: o for i, o in offsets.items() if i in indices}
    if not layout.journal.exists():
        layout.journal.touch()
    info = {"description": "sdcomp synthetic drone-over-water dataset",
            "version": __version__, "seed": config.seed, "url": "", "contributor": "sdcomp",
            "year": 0, "date_created": ""}
    writers = writers_for(config)
    counts: dict[str, int] = {"images": len(offsets), "annotations": 0}
    for w in writers:
        counts.update(w.finish(layout, offsets, config.categories, info))
    tally = _tally(layout, offsets)
    counts["annotations"] = tally["annotations"]
    for split, n in tally["splits"].items():
        counts.setdefault(split, n)
    counts.setdefault("train", 0)
    counts.setdefault("val", 0)
    for k in ("dropped", "truncated", "ignored", "skipped"):
        counts[f"objects_{k}"] = tally[k]
    counts["empty_images"] = tally["empty"]
    entries = {"images": "images/train/, images/val/",
               "masks": "masks/train/, masks/val/ (16-bit PNG instance ids)",
               "journal": "records.jsonl"}
    for w in writers:
        entries.update(w.layout_entries())
    meta: dict[str, Any] = {
        "format": FORMAT, "format_version": FORMAT_VERSION, "sdcomp_version": __version__,
        "seed": config.seed, "status": status, "counts": counts,
        "layout": {k: entries[k] for k in sorted(entries, key=_layout_position)},
        "mask_rule": MASK_RULE, "config": config.to_dict()}
    if shard is not None:
        meta["shard"] = shard_text(shard)
    atomic_write_bytes(layout.meta, (json.dumps(meta, indent=1, sort_keys=False) + "\n")
                       .encode())
    return counts


def _layout_position(key: str) -> int:
    return LAYOUT_ORDER.index(key) if key in LAYOUT_ORDER else len(LAYOUT_ORDER)


def on_sigterm() -> Callable | int | None:
    """Treat SIGTERM (e.g. a job scheduler stopping the run) like Ctrl-C; returns the old
    handler, or None when not in the main thread."""
    def handler(signum, frame):
        signal.signal(signal.SIGTERM, signal.SIG_IGN)  # once: let the clean-up finish
        raise KeyboardInterrupt
    try:
        return signal.signal(signal.SIGTERM, handler)
    except ValueError:
        return None


def restore_sigterm(old: Callable | int | None) -> None:
    """Put back the SIGTERM handler :func:`on_sigterm` replaced."""
    if old is not None:
        signal.signal(signal.SIGTERM, old)


def os_error_message(e: OSError, out: Path, kept: str = "") -> str:
    """One line for a file-system error: the file, the reason, what is kept, the fix."""
    where = e.filename if e.filename is not None else out
    why = e.strerror or str(e) or type(e).__name__
    if e.errno in (errno.ENOSPC, errno.EDQUOT, errno.EFBIG):
        fix = "free some disk space"
    elif e.errno in (errno.EACCES, errno.EPERM, errno.EROFS):
        fix = f"make {out} writable"
    else:
        fix = "fix the cause"
    return f"{where}: {why}; {kept}{fix}, then continue with the same command and --resume"
