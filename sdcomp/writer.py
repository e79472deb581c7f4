"""Writing a dataset folder: images, masks, COCO, with workers, resume and atomic files.

Layout of ``out``::

    images/000000.jpg            the images (or .png), sRGB
    masks/000000.png             16-bit instance ids (0 = none; k = annotation with
                                 instance_id k of that image)
    annotations/instances_train.json, annotations/instances_val.json   COCO
    records.jsonl                one JSON line per finished image (the journal a resumed
                                 run continues from; COCO files are made from it)
    dataset.json                 config, package version, seed, status and counts

Every file appears whole or not at all (temporary name, then rename). Image ``i`` depends
only on (config, i), the journal is read back in index order, and nothing records times, so
the same config gives byte-identical images, masks, COCO files and dataset.json whatever
the number of workers and however often the run was interrupted and resumed.
"""

from __future__ import annotations

import errno
import json
import math
import multiprocessing as mp
import os
import shutil
import signal
import sys
import time
from collections.abc import Iterable
from contextlib import closing
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import cv2
import numpy as np

from . import __version__, yolo
from .coco import Journal, crop_to_rle, iter_records, mask_to_rle, read_journal, write_coco
from .compositor import MASK_THRESHOLD
from .config import GeneratorConfig
from .errors import UserError
from .fileio import atomic_write_bytes
from .generator import DEFAULT_SPRITES, Generator, annotations, metadata
from .pngio import encode_png16
from .pool import imap_ordered, note
from .progress import Progress
from .shards import shard_range, shard_text

FORMAT = "sdcomp-dataset"
FORMAT_VERSION = 1
OURS = ("images", "masks", "annotations", "records.jsonl", "dataset.json", "labels",
        "train.txt", "val.txt", "data.yaml")
SPLIT_BLOCK = 100  # val images are exactly round(f * 100) of every 100 consecutive ones
CHUNK = 32  # images per task handed to a worker, at most
CHUNK_PIXELS = 8_000_000  # pixels per task at most: a full-resolution frame is a task
TASKS_PER_WORKER = 4  # short runs are cut into at least this many tasks per worker
CHECKPOINT_SECONDS = 60.0  # COCO files are rewritten at least this often during a run
MASK_RULE = (f"a pixel belongs to an object when the object supplies at least "
             f"{MASK_THRESHOLD:g} of its colour (coverage x water transmittance x what is "
             f"not hidden by nearer objects), inside the frame")


@dataclass(frozen=True)
class RunOptions:
    """How to run (does not change the output): folder, workers, resume/overwrite."""

    out: Path
    workers: int = 1
    resume: bool = False
    overwrite: bool = False
    progress: bool | None = None
    sprites_dir: Path = Path(DEFAULT_SPRITES)
    #: (K, N): render only shard K of N of the image indices (see sdcomp.shards)
    shard: tuple[int, int] | None = None


def split_of(seed: int, index: int, val_fraction: float) -> str:
    """``"val"`` or ``"train"`` for image ``index``: in every block of 100 consecutive
    images, exactly ``round(100 * val_fraction)`` chosen by a seeded permutation are val."""
    block, pos = divmod(int(index), SPLIT_BLOCK)
    k = int(round(val_fraction * SPLIT_BLOCK))
    if k <= 0:
        return "train"
    return "val" if _block_order(int(seed), block)[pos] < k else "train"


@lru_cache(maxsize=16)
def _block_order(seed: int, block: int) -> tuple[int, ...]:
    """The seeded permutation of a block of :data:`SPLIT_BLOCK` images (kept for the
    block's other images: drawing it costs more than writing an image's record)."""
    return tuple(np.random.default_rng([seed, block, 0x5B11]).permutation(SPLIT_BLOCK)
                 .tolist())


def image_name(index: int, ext: str) -> str:
    return f"{index:06d}.{ext}"


# --------------------------------------------------------------------------- one image

def make_record(gen: Generator, index: int, out: Path) -> dict:
    """Render image ``index``, write its image and mask files, return its journal record."""
    config = gen.config
    frame = gen.render(index)
    q = frame.scene.effects.jpeg_quality
    bgr = _rgb_to_bgr_in_place(frame.image)
    if config.image_format == "jpg":
        ok, data = cv2.imencode(".jpg", bgr, [cv2.IMWRITE_JPEG_QUALITY, q])
    else:
        ok, data = cv2.imencode(".png", bgr, [cv2.IMWRITE_PNG_COMPRESSION, 1])
    if not ok:
        raise RuntimeError(f"could not encode image {index}")
    name = image_name(index, config.image_format)
    mask_name = image_name(index, "png")
    _write(out / "images" / name, data.tobytes())
    _write(out / "masks" / mask_name, encode_png16(frame.instances))
    anns = []
    for ann, inst in zip(annotations(config, frame), frame.objects, strict=True):
        x, y, w, h = ann["bbox"]
        crop = frame.instances[y:y + h, x:x + w] == inst.instance_id
        rle = crop_to_rle(crop, x, y, *frame.instances.shape)
        rec = {"instance_id": ann["instance_id"], "category_id": ann["category_id"],
               "bbox": ann["bbox"], "area": ann["area"], "segmentation": rle,
               "iscrowd": 0, "pose": ann["pose"]}
        if inst.amodal is not None:
            rec["amodal_segmentation"] = mask_to_rle(inst.amodal)
            rec["amodal_area"] = inst.amodal_area
            ys, xs = np.nonzero(inst.amodal)
            rec["amodal_bbox"] = ([int(xs.min()), int(ys.min()), int(xs.max() - xs.min() + 1),
                                   int(ys.max() - ys.min() + 1)] if len(xs) else [0, 0, 0, 0])
        anns.append(rec)
    if "yolo" in config.format:  # before the record is returned (and journaled)
        _write(out / "labels" / yolo.label_name(name),
               yolo.label_text(frame.instances, anns, config.yolo_seg).encode())
    h, w = frame.instances.shape
    image = {"id": index + 1, "file_name": name, "width": w, "height": h,
             "mask_file": mask_name, "meta": metadata(frame)}
    return {"index": index, "split": split_of(config.seed, index, config.val_fraction),
            "image": image, "annotations": anns}


def _rgb_to_bgr_in_place(image: np.ndarray, band_bytes: int = 1 << 24) -> np.ndarray:
    """Swap an (H, W, 3) uint8 image to OpenCV's BGR order in place, in bands of rows (a
    30000 x 30000 frame is 2.7 GB: no room for a whole copy, which OpenCV makes even when
    asked to convert in place). Returns ``image``."""
    rows = max(1, band_bytes // max(1, image.shape[1] * 3))
    for y in range(0, image.shape[0], rows):
        band = image[y:y + rows]
        cv2.cvtColor(band, cv2.COLOR_RGB2BGR, dst=band)
    return image


def _write(path: Path, data: bytes) -> None:
    """Write ``data`` to ``path`` through a temporary name (removed again on any error)."""
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        with open(tmp, "wb") as fh:
            fh.write(data)
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


# --------------------------------------------------------------------------- workers

_WORKER: dict = {}


def _init_worker(out: str, rebuild) -> None:
    """Set up a pool worker (signals: see :mod:`sdcomp.pool`); ``rebuild`` = (config,
    sprites folder) where the generator was not inherited through fork."""
    cv2.setNumThreads(1)
    _WORKER["out"] = Path(out)
    if rebuild is not None:
        config, sprites = rebuild
        _WORKER["gen"] = Generator(config, sprites, progress=False)


def _work(indices: list[int]) -> list[dict]:
    gen = _WORKER["gen"]
    records = []
    for i in indices:
        note(i)  # named by WorkerDied should this image kill the worker
        records.append(make_record(gen, i, _WORKER["out"]))
    return records


def chunk_size(width: int, height: int, pending: int, workers: int) -> int:
    """Images per task: up to :data:`CHUNK` small images (fewer round trips to the
    workers), fewer for large frames (:data:`CHUNK_PIXELS`), and small enough that each of
    ``workers`` gets :data:`TASKS_PER_WORKER` tasks, so no worker idles while another
    renders the last big task."""
    by_pixels = CHUNK_PIXELS // max(1, width * height)
    size = min(CHUNK, by_pixels)
    if workers > 1:
        size = min(size, math.ceil(pending / (TASKS_PER_WORKER * workers)))
    return max(1, size)


def _results(gen: Generator, chunks: list[list[int]], options: RunOptions) -> Iterable[list]:
    """Records per chunk, in order, from this process or a pool of workers."""
    _WORKER["gen"] = gen  # forked workers inherit it: textures and sprites for free
    if options.workers <= 1 or len(chunks) <= 1:
        _WORKER["out"] = options.out
        for c in chunks:
            yield _work(c)
        return
    # forked workers (see sdcomp.pool) inherit the generator; spawned ones rebuild it
    forked = "fork" in mp.get_all_start_methods()
    if forked:
        gen.warm()  # its sprites prepared once, here, instead of in every worker
    yield from imap_ordered(_work, chunks, options.workers, initializer=_init_worker,
                            initargs=(str(options.out), None if forked
                                      else (gen.config, str(options.sprites_dir))),
                            what="image")


# --------------------------------------------------------------------------- the run

def prepare_output(config: GeneratorConfig, options: RunOptions) -> set[int]:
    """Check or clear the output folder; return the indices already done (resume)."""
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
        for name in OURS:
            p = out / name
            if p.is_dir():
                shutil.rmtree(p)
            elif p.exists():
                p.unlink()
    elif entries and options.resume:
        done = _resumable(config, out, options.shard)
    elif options.resume and not entries:
        pass  # nothing to resume: a fresh run
    try:
        for sub in ("images", "masks", "annotations", *_yolo_dirs(config)):
            (out / sub).mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise UserError(f"--out {out}: cannot create the folder ({e.strerror})") from None
    _sweep_tmp(out, config)
    return done


def _sweep_tmp(out: Path, config: GeneratorConfig) -> None:
    """Remove the temporary files a killed run can leave (``.NAME.*.tmp``)."""
    for sub in ("images", "masks", "annotations", *_yolo_dirs(config)):
        for tmp in (out / sub).glob(".*.tmp"):
            tmp.unlink(missing_ok=True)
    for tmp in out.glob(".dataset.json.*.tmp"):
        tmp.unlink(missing_ok=True)


def run_indices(config: GeneratorConfig, shard: tuple[int, int] | None) -> range:
    """The image indices a run renders: all, or those of shard (K, N)."""
    return range(config.n) if shard is None else shard_range(config.n, *shard)


def _yolo_dirs(config: GeneratorConfig) -> tuple[str, ...]:
    return ("labels",) if "yolo" in config.format else ()


def _never_begun(out: Path) -> bool:
    """Whether ``out`` holds only the empty start of a run: our folders and temporary or
    annotation files, no image, no journal line."""
    for p in out.iterdir():
        if p.name not in OURS and not p.name.endswith(".tmp"):
            return False
        if p.name in ("images", "masks") and any(q for q in p.iterdir()
                                                 if not q.name.endswith(".tmp")):
            return False
        if p.name == "records.jsonl" and p.stat().st_size:
            return False
    return True


def _resumable(config: GeneratorConfig, out: Path,
               shard: tuple[int, int] | None = None) -> set[int]:
    meta_path = out / "dataset.json"
    if not meta_path.exists() and _never_begun(out):
        return set()  # killed between creating the folders and writing dataset.json
    try:
        meta = json.loads(meta_path.read_text())
        if meta.get("format") != FORMAT:
            raise ValueError
    except (OSError, ValueError):
        raise UserError(f"--resume: {out} is not an sdcomp dataset (no valid dataset.json); "
                        f"use --overwrite to replace it or choose another --out") from None
    old = meta.get("config", {})
    new = config.to_dict()
    # a field the folder's sdcomp did not have yet is at its default (the old behaviour)
    defaults = GeneratorConfig().to_dict()
    diff = [k for k in new if old.get(k, defaults[k]) != new[k]]
    if diff:
        k = diff[0]
        raise UserError(f"--resume: the folder was made with {k} = {old.get(k)!r}, not "
                        f"{new[k]!r}; run with the same options, or use --overwrite")
    want = shard_text(shard) if shard else None
    if meta.get("shard") != want:
        was = f"--shard {meta['shard']}" if meta.get("shard") else "without --shard"
        now = f"--shard {want}" if want else "without --shard"
        raise UserError(f"--resume: {out} was made {was}, not {now}; resume it as it was "
                        f"made, or use --overwrite")
    journal = out / "records.jsonl"
    if not journal.exists():
        return set()
    offsets = read_journal(journal)
    done = set()
    for i, _ in offsets.items():
        name = image_name(i, config.image_format)
        if (out / "images" / name).exists() and (out / "masks" / image_name(i, "png")).exists() \
                and all((out / d / image_name(i, "txt")).exists() for d in _yolo_dirs(config)):
            done.add(i)
    indices = run_indices(config, shard)
    return {i for i in done if i in indices}


def write_annotations(config: GeneratorConfig, out: Path, status: str,
                      shard: tuple[int, int] | None = None) -> dict:
    """COCO files of both splits and dataset.json from the journal (the images of
    ``shard`` only, when given); returns the counts."""
    journal = out / "records.jsonl"
    offsets = read_journal(journal) if journal.exists() else {}
    indices = run_indices(config, shard)
    offsets = {i: o for i, o in offsets.items() if i in indices}
    if not journal.exists():
        journal.touch()
    info = {"description": "sdcomp synthetic drone-over-water dataset",
            "version": __version__, "seed": config.seed, "url": "", "contributor": "sdcomp",
            "year": 0, "date_created": ""}
    counts = {"images": len(offsets), "annotations": 0}
    for split in ("train", "val") if "coco" in config.format else ():
        c = write_coco(out / "annotations" / f"instances_{split}.json", journal, offsets,
                       split, config.categories, info)
        counts[split] = c["images"]
        counts["annotations"] += c["annotations"]
    dropped = empty = 0
    for rec in iter_records(journal, offsets):
        dropped += int(rec["image"]["meta"].get("objects_dropped", 0))
        empty += not rec["annotations"]
        if "coco" not in config.format:  # the counts that write_coco gives otherwise
            counts[rec["split"]] = counts.get(rec["split"], 0) + 1
            counts["annotations"] += len(rec["annotations"])
    counts.setdefault("train", 0)
    counts.setdefault("val", 0)
    counts["objects_dropped"] = dropped
    counts["empty_images"] = empty
    if "yolo" in config.format:
        yolo.write_lists(out, iter_records(journal, offsets), config.categories, __version__,
                         config.yolo_seg)
    meta = {"format": FORMAT, "format_version": FORMAT_VERSION, "sdcomp_version": __version__,
            "seed": config.seed, "status": status, "counts": counts,
            "layout": {"images": "images/", "masks": "masks/ (16-bit PNG instance ids)",
                       "train": "annotations/instances_train.json",
                       "val": "annotations/instances_val.json", "journal": "records.jsonl"},
            "mask_rule": MASK_RULE, "config": config.to_dict()}
    if "yolo" in config.format:
        meta["layout"].update(yolo.LAYOUT)
    if "coco" not in config.format:
        del meta["layout"]["train"], meta["layout"]["val"]
    if shard is not None:
        meta["shard"] = shard_text(shard)
    atomic_write_bytes(out / "dataset.json",
                       (json.dumps(meta, indent=1, sort_keys=False) + "\n").encode())
    return counts


def _on_sigterm():
    """Treat SIGTERM (e.g. a job scheduler stopping the run) like Ctrl-C; returns the old
    handler, or None when not in the main thread."""
    def handler(signum, frame):
        signal.signal(signal.SIGTERM, signal.SIG_IGN)  # once: let the clean-up finish
        raise KeyboardInterrupt
    try:
        return signal.signal(signal.SIGTERM, handler)
    except ValueError:
        return None


def run(config: GeneratorConfig, options: RunOptions, gen: Generator | None = None) -> dict:
    """Generate the dataset of ``config`` into ``options.out``; returns the counts.

    Ctrl-C (KeyboardInterrupt) or an error stops the run after writing valid COCO files and
    dataset.json for the images finished so far, then re-raises.
    A file-system error (disk full, no permission) becomes a one-line UserError naming the
    file and how many images are kept; a worker that dies, :class:`sdcomp.pool.WorkerDied`.
    Neither leaves a partial file under a final name, and ``--resume`` continues the run.
    """
    try:
        if gen is None:  # first: a bad mesh or backgrounds folder must not leave files behind
            gen = Generator(config, options.sprites_dir, progress=options.progress)
        done = prepare_output(config, options)
        return _run(config, options, gen, done)
    except OSError as e:
        raise UserError(os_error_message(e, options.out)) from None


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


def _run(config: GeneratorConfig, options: RunOptions, gen: Generator, done: set[int]) -> dict:
    out = options.out
    indices = run_indices(config, options.shard)
    pending = [i for i in indices if i not in done]
    size = chunk_size(config.width, config.height, len(pending), options.workers)
    chunks = [pending[k:k + size] for k in range(0, len(pending), size)]
    progress = Progress(len(pending), "generate", options.progress, unit="img")
    last = time.monotonic()
    status = "interrupted"
    failure: OSError | None = None
    old_term = _on_sigterm()
    try:  # from the first write on, Ctrl-C or SIGTERM ends with the final write below
        write_annotations(config, out, "running", options.shard)
        with Journal(out / "records.jsonl") as journal, \
                closing(_results(gen, chunks, options)) as results:
            for records in results:
                journal.append(records)
                progress.update(len(records))
                if time.monotonic() - last > CHECKPOINT_SECONDS:
                    write_annotations(config, out, "running", options.shard)
                    last = time.monotonic()
        status = "complete"
    except OSError as e:
        status, failure = "failed", e
    except Exception:
        status = "failed"
        raise
    finally:
        progress.close()
        _sweep_tmp(out, config)
        try:  # SIGTERM still raises KeyboardInterrupt here: no write is cut off by SIG_DFL
            counts = write_annotations(config, out, status, options.shard)
        except OSError as e:
            if status == "complete":
                raise
            failure = failure or e  # the files of the last checkpoint stay, whole
            counts = None
        finally:
            if old_term is not None:
                signal.signal(signal.SIGTERM, old_term)
        if status == "interrupted" and counts is not None:
            print(f"stopped after {counts['images']} of {len(indices)} images; the annotation "
                  f"files cover them. Continue with the same command and --resume.",
                  file=sys.stderr)
    if failure is not None:
        kept = (f"{counts['images']} of {len(indices)} images are saved; "
                if counts is not None else "the images finished so far are kept; ")
        raise UserError(os_error_message(failure, out, kept))
    return counts
