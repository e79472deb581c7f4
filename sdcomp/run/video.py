"""A video run: sequences of frames written to a folder (:mod:`sdcomp.io.clip_layout`) by
this process or a pool of workers.

Tasks are runs of frames of one sequence (:func:`frame_chunks`); workers render and write
the frames and return their records; this process finishes a sequence once its last frames
are in (gt.txt, flight.json, sequence.json, the MP4, and seqinfo.ini last) and joins the
finished sequences' parts into the COCO-video file at the end (or when stopped). A frame
depends only on (config, s, k) and every joined file is written in sequence order, so the
same config gives the same bytes with any number of workers, and ``--resume`` (which keeps
the finished sequences and redoes the others) equals an uninterrupted run.
"""

from __future__ import annotations

import functools
import json
import math
import multiprocessing as mp
import shutil
import sys
from collections.abc import Generator as Generator_
from contextlib import closing
from pathlib import Path
from typing import Any

import cv2

from .. import __version__
from ..annotate import camera_record
from ..clips import ClipGenerator
from ..errors import UserError
from ..io.clip_layout import VIDEO_FORMAT, VIDEO_FORMAT_VERSION, ClipLayout
from ..io.layout import IGNORE_SUFFIX
from ..io.mot import gt_lines, seqinfo_text
from ..io.png import encode_ignore_png, encode_png16
from ..io.video_coco import join_parts, sequence_part
from ..io.yolo import data_yaml, label_text
from ..scene.video import VideoConfig, sequence_split
from ..util import files
from ..util.pool import imap_ordered, note
from ..util.progress import Progress
from .frame_memory import check_run_memory
from .options import RunOptions
from .output import (
    check_same_shard,
    different_option,
    on_sigterm,
    os_error_message,
    restore_sigterm,
)
from .record import encode_image
from .shards import shard_range, shard_text

CHUNK = 16  # frames per task at most
TASKS_PER_WORKER = 4


def sequence_indices(video: VideoConfig, shard: tuple[int, int] | None) -> range:
    """The sequences a run (or ``shard`` K/N of it) makes."""
    if shard is None:
        return range(video.sequences)
    return shard_range(video.sequences, *shard)


def frame_chunks(sequences: list[int], frames: int, workers: int) -> list[tuple[int, int, int]]:
    """Tasks (s, first frame, end frame) covering ``frames`` frames of each of
    ``sequences``: at most :data:`CHUNK` frames, fewer when that gives each of ``workers``
    :data:`TASKS_PER_WORKER` tasks; a task never spans two sequences."""
    total = len(sequences) * frames
    size = CHUNK if workers <= 1 else max(1, min(CHUNK, math.ceil(
        total / (TASKS_PER_WORKER * workers))))
    return [(s, k, min(k + size, frames)) for s in sequences for k in range(0, frames, size)]


def render_frames(clips: ClipGenerator, out: str, task: tuple[int, int, int]) -> list[dict]:
    """Render and write frames ``task`` = (s, k0, k1) to ``out``; return their records:
    s, k, image entry (file names, size, meta, camera) and objects."""
    s, k0, k1 = task
    layout = ClipLayout(Path(out))
    config = clips.video.generator
    ext = config.image_format
    records = []
    for sub in ("img1", "masks", "gt") + (("labels",) if "yolo" in config.format else ()):
        (layout.seq(s) / sub).mkdir(parents=True, exist_ok=True)
    for k in range(k0, k1):
        note(k)
        f = clips.frame(s, k)
        h, w = f.instances.shape
        camera = camera_record(f.frame_info, config.camera)
        image = {"file_name": f"{layout.name(s)}/img1/{k + 1:06d}.{ext}", "width": w,
                 "height": h, "mask_file": f"{layout.name(s)}/masks/{k + 1:06d}.png",
                 "camera": camera, "meta": f.meta}
        quality = f.frame_info.scene.jpeg_quality
        files.write_file(layout.image(s, k, ext), encode_image(f.image, ext, quality))
        files.write_file(layout.mask(s, k), encode_png16(f.instances))
        if f.ignore is not None:
            files.write_file(layout.ignore_mask(s, k), encode_ignore_png(f.ignore))
            image["ignore_file"] = f"{layout.name(s)}/masks/{k + 1:06d}{IGNORE_SUFFIX}"
        if "yolo" in config.format:
            text = label_text(f.instances, f.objects, seg=config.yolo_seg)
            files.write_file(layout.label(s, k), text.encode())
        records.append({"s": s, "k": k, "image": image, "objects": f.objects + f.ignored})
    return records


def run_video(video: VideoConfig, options: RunOptions,
              clips: ClipGenerator | None = None) -> dict:
    """Make the sequences of ``video`` in ``options.out``; returns the counts. Ctrl-C,
    SIGTERM or an error stops after writing the files of the finished sequences; a
    file-system error becomes a one-line UserError; ``--resume`` continues. A run that
    would need more memory than the machine has is refused first, writing nothing."""
    g = video.generator
    check_run_memory(g.width, g.height, options.workers,
                     len(sequence_indices(video, options.shard)) * video.frames, video=True)
    try:
        clips = clips or ClipGenerator(video, options.sprites_dir, progress=options.progress)
        done = prepare_clips(video, options)
        return _run(video, options, clips, done)
    except OSError as e:
        raise UserError(os_error_message(e, options.out)) from None


def prepare_clips(video: VideoConfig, options: RunOptions) -> set[int]:
    """Check, clear or resume the output folder; returns the finished sequences kept.
    Unfinished sequence folders of a resumed run are removed (they are made again), and
    the temporary files of a killed write (:func:`sweep_clip_tmp`)."""
    out = options.out
    if out.exists() and not out.is_dir():
        raise UserError(f"--out {out} is a file; give a folder")
    entries = list(out.iterdir()) if out.exists() else []
    if options.resume and options.overwrite:
        raise UserError("--resume and --overwrite exclude each other; pick one")
    if entries and not (options.resume or options.overwrite):
        raise UserError(f"output folder {out} is not empty: add --resume to continue the "
                        f"run that made it, or --overwrite to replace it")
    layout = ClipLayout(out)
    done: set[int] = set()
    if entries and options.overwrite:
        remove_clips(layout)
    elif entries and options.resume:
        _check_same(video, layout, options.shard)
        wanted = set(sequence_indices(video, options.shard))
        for s in layout.sequences():
            if layout.complete(s) and s in wanted:
                done.add(s)
            elif s in wanted:
                shutil.rmtree(layout.seq(s))
    (out / "annotations").mkdir(parents=True, exist_ok=True)
    sweep_clip_tmp(layout)
    return done


def sweep_clip_tmp(layout: ClipLayout, sequences: list[int] | tuple = ()) -> None:
    """Remove the temporary files (``.NAME.*.tmp``) a killed run can leave beside
    video.json, data.yaml and the COCO-video file, and those of the frames of ``sequences``
    whose writers were stopped mid-write (a worker ends at SIGTERM)."""
    for path in (layout.meta, layout.data_yaml, layout.coco):
        for tmp in path.parent.glob(f".{path.name}.*.tmp"):
            tmp.unlink(missing_ok=True)
    for s in sequences:
        for tmp in layout.seq(s).glob("*/.*.tmp"):
            tmp.unlink(missing_ok=True)


def remove_clips(layout: ClipLayout) -> None:
    """Remove a video run's own entries (other files stay)."""
    for s in layout.sequences():
        shutil.rmtree(layout.seq(s))
    for p in (layout.meta, layout.coco, layout.data_yaml):
        p.unlink(missing_ok=True)


def _check_same(video: VideoConfig, layout: ClipLayout, shard: tuple[int, int] | None) -> None:
    """UserError unless the folder's video.json records this config (more sequences
    allowed) and shard."""
    try:
        meta = json.loads(layout.meta.read_text())
        if meta.get("format") != VIDEO_FORMAT:
            raise ValueError
    except (OSError, ValueError):
        if not layout.sequences():
            return  # killed before the first write
        raise UserError(f"--resume: {layout.root} is not an sdcomp video folder (no valid "
                        f"video.json); use --overwrite or another --out") from None
    old, new = meta.get("config", {}), video.to_dict()
    old = {**old.pop("generator", {}), **old}
    new = {**new.pop("generator"), **new}
    diff = [k for k in new if k not in ("sequences", "n") and old.get(k) != new[k]]
    if diff:
        different_option(diff[0], old, new)
    check_same_shard(meta, layout.root, shard)


def _results(clips: ClipGenerator, tasks: list, options: RunOptions
             ) -> Generator_[list[dict], None, None]:
    """Records per task, in order, from this process or a pool of workers."""
    if options.workers <= 1 or len(tasks) <= 1:
        for t in tasks:
            yield render_frames(clips, str(options.out), t)
        return
    if "fork" not in mp.get_all_start_methods():
        raise UserError("--workers > 1 needs a platform that can fork; use --workers 1")
    clips.warm()
    yield from imap_ordered(functools.partial(render_frames, clips, str(options.out)), tasks,
                            options.workers, initializer=cv2.setNumThreads, initargs=(1,),
                            what="frame")


def _run(video: VideoConfig, options: RunOptions, clips: ClipGenerator, done: set[int]) -> dict:
    layout = ClipLayout(options.out)
    sequences = list(sequence_indices(video, options.shard))
    pending = [s for s in sequences if s not in done]
    tasks = frame_chunks(pending, video.frames, options.workers)
    progress = Progress(len(pending) * video.frames, "video", options.progress, unit="frame")
    status = "interrupted"
    old_term = on_sigterm()
    try:
        write_video_meta(video, layout, "running", options.shard, sequences)
        current: list[dict] = []
        with closing(_results(clips, tasks, options)) as results:
            for records in results:
                current += records
                progress.update(len(records))
                if current and current[-1]["k"] == video.frames - 1:
                    finish_sequence(video, layout, current[-1]["s"], current)
                    current = []
        status = "complete"
    except Exception:
        status = "failed"
        raise
    finally:
        progress.close()
        sweep_clip_tmp(layout, pending)  # the workers are stopped: what they left half-written
        try:
            counts = write_video_meta(video, layout, status, options.shard, sequences)
        finally:
            restore_sigterm(old_term)
        if status == "interrupted":
            print(f"stopped after {counts['sequences']} of {len(sequences)} sequences; "
                  f"continue with the same command and --resume.", file=sys.stderr)
    return counts


def finish_sequence(video: VideoConfig, layout: ClipLayout, s: int, records: list[dict]
                    ) -> None:
    """Write sequence ``s``'s own files from its frames' ``records`` (in frame order):
    gt.txt, flight.json, sequence.json, the MP4, then seqinfo.ini."""
    config = video.generator
    files.write_file(layout.gt(s), gt_lines((r["k"] + 1, r["objects"]) for r in records)
                     .encode())
    flight = [r["image"]["meta"] for r in records]
    files.write_file(layout.flight(s), (json.dumps(flight) + "\n").encode())
    entry = {"name": layout.name(s), "width": config.width, "height": config.height,
             "fps": video.fps, "length": video.frames,
             "split": sequence_split(s, config.val_fraction),
             "flight": flight[0]["flight"] if flight else ""}
    part = sequence_part(s, entry, ((r["k"], r["image"], r["objects"]) for r in records))
    files.write_file(layout.part(s), (json.dumps(part) + "\n").encode())
    if "yolo" in config.format:
        link = layout.seq(s) / "images"
        if not link.is_symlink():
            link.symlink_to("img1", target_is_directory=True)
    if video.mp4:
        write_mp4(layout, s, video)
    files.write_file(layout.seqinfo(s), seqinfo_text(
        layout.name(s), video.fps, video.frames, config.width, config.height,
        "." + config.image_format).encode())


def write_mp4(layout: ClipLayout, s: int, video: VideoConfig) -> Path:
    """Encode sequence ``s``'s frames (read back from img1/) to its MP4 (OpenCV's mp4v
    writer), atomically."""
    config = video.generator
    dest = layout.mp4(s)
    tmp = dest.with_name(f".{dest.stem}.tmp.mp4")
    writer = cv2.VideoWriter(str(tmp), cv2.VideoWriter.fourcc(*"mp4v"), float(video.fps),
                             (config.width, config.height))
    if not writer.isOpened():
        raise UserError(f"--mp4: OpenCV cannot write {dest} here (no MP4 encoder in this "
                        f"OpenCV build); drop --mp4")
    try:
        for k in range(video.frames):
            path = layout.image(s, k, config.image_format)
            frame = cv2.imread(str(path), cv2.IMREAD_COLOR)
            if frame is None:
                raise UserError(f"--mp4: cannot read {path} back; run again with --overwrite")
            writer.write(frame)
    finally:
        writer.release()
    tmp.replace(dest)
    return dest


def video_yaml(video: VideoConfig, layout: ClipLayout, finished: list[int]) -> str:
    """``data.yaml`` of the ``finished`` sequences: each sequence's ``images/`` folder under
    ``train:`` or ``val:`` by :func:`sequence_split` (whole sequences); without val
    sequences, val lists the train ones (Ultralytics needs a val set) and says so."""
    config = video.generator
    yaml = data_yaml(config.categories, __version__, config.yolo_seg)
    lines = [ln for ln in yaml.splitlines() if not ln.startswith(("train:", "val:"))]
    dirs = {split: [f"{layout.name(s)}/images" for s in finished
                    if sequence_split(s, config.val_fraction) == split]
            for split in ("train", "val")}
    lines += ["train:", *[f"  - {d}" for d in dirs["train"]]]
    if dirs["val"]:
        lines += ["val:", *[f"  - {d}" for d in dirs["val"]]]
    else:
        lines += ["val:  # no val sequences (--val-fraction): the train ones",
                  *[f"  - {d}" for d in dirs["train"]]]
    return "\n".join(lines) + "\n"


def write_video_meta(video: VideoConfig, layout: ClipLayout, status: str,
                shard: tuple[int, int] | None, sequences: list[int]) -> dict:
    """The COCO-video file of the finished sequences (in order), data.yaml with --format
    yolo, and video.json; returns the counts."""
    config = video.generator
    finished = [s for s in sequences if layout.complete(s)]
    parts = (json.loads(layout.part(s).read_text()) for s in finished)
    info = {"description": "sdcomp synthetic drone-over-water video", "version": __version__,
            "seed": config.seed}
    coco = join_parts(parts, config.categories, info)
    files.atomic_write_bytes(layout.coco, (json.dumps(coco) + "\n").encode())
    if "yolo" in config.format:
        files.atomic_write_bytes(layout.data_yaml, video_yaml(video, layout, finished).encode())
    counts = {"sequences": len(finished), "frames": len(coco["images"]),
              "annotations": len(coco["annotations"]), "tracks": len(coco["tracks"])}
    meta: dict[str, Any] = {"format": VIDEO_FORMAT, "format_version": VIDEO_FORMAT_VERSION,
                            "sdcomp_version": __version__, "seed": config.seed,
                            "status": status, "counts": counts, "config": video.to_dict()}
    if shard is not None:
        meta["shard"] = shard_text(shard)
    files.atomic_write_bytes(layout.meta, (json.dumps(meta, indent=1) + "\n").encode())
    return counts
