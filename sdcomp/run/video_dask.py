"""``sdcomp video --engine dask``: a video run's sequences as shard tasks on a Dask cluster.

As :mod:`sdcomp.run.dask_engine` does for stills: the client splits the sequences into N
shards and submits one task per shard, each a ``--shard K/N`` video run into
``OUT/.shards/shard-K-of-N/`` on the shared output path; when all are done they are merged
into OUT (:mod:`sdcomp.run.video_merge`: the bytes of one local run) and ``OUT/.shards`` is
removed. ``--resume`` continues each shard from its finished sequences. dask is imported only
here.
"""

from __future__ import annotations

import shutil
from pathlib import Path

from ..clips import ClipGenerator
from ..errors import UserError
from ..io.clip_layout import ClipLayout
from ..pipeline import cached_generator
from ..scene.video import VideoConfig
from .dask_engine import (
    SHARDS_PER_WORKER,
    WORK,
    check_failed,
    dask_modules,
    existing_shards,
    open_client,
    submit_shards,
)
from .frame_memory import check_run_memory
from .options import RunOptions
from .output import on_sigterm, os_error_message, restore_sigterm
from .shards import shard_folder
from .video import remove_clips, run_video
from .video_merge import merge_video, video_config


def render_video_shard(video_dict: dict, folder: str, k: int, n: int, sprites: str) -> dict:
    """A Dask task: make shard ``k`` of ``n`` of the video run ``video_dict`` (its
    :meth:`VideoConfig.to_dict`) in ``folder``, continuing what an earlier attempt left."""
    video = video_config({"config": video_dict})
    out = Path(folder)
    resume = (out / "video.json").is_file()
    options = RunOptions(out, workers=1, resume=resume, overwrite=not resume, progress=False,
                         sprites_dir=Path(sprites), shard=(k, n))
    clips = ClipGenerator(video, sprites, generator=cached_generator(video.generator, sprites))
    return run_video(video, options, clips=clips)


def run_video_dask(video: VideoConfig, options: RunOptions, scheduler: str | None = None
                   ) -> dict:
    """Make the sequences of ``video`` in ``options.out`` on a Dask cluster (at
    ``scheduler``, else a local one of ``options.workers`` processes); returns the counts."""
    Client, LocalCluster, as_completed = dask_modules(options)  # noqa: N806
    if scheduler is None:  # a local cluster: its workers share this machine's memory
        g = video.generator
        check_run_memory(g.width, g.height, options.workers, video.sequences * video.frames,
                         video=True)
    try:
        ClipGenerator(video, options.sprites_dir, progress=options.progress)  # atlases, once
        work = _prepare(options)
        cluster = None
        old_term = on_sigterm()
        try:
            client, cluster = open_client(Client, LocalCluster, scheduler, options.workers)
            with client:
                n_workers = max(1, len(client.scheduler_info().get("workers", {})))
                n = existing_shards(work) or min(video.sequences, SHARDS_PER_WORKER * n_workers)
                work.mkdir(parents=True, exist_ok=True)
                folders = [work / shard_folder(k, n) for k in range(n)]
                failed = submit_shards(client, as_completed, render_video_shard,
                                       video.to_dict(), options, folders, "sdcomp-video")
            check_failed(failed, n, work)
        finally:
            restore_sigterm(old_term)
            if cluster is not None:
                cluster.close()
        counts = merge_video(folders, options.out, overwrite=True, remove=True)
        shutil.rmtree(work, ignore_errors=True)
        return counts
    except OSError as e:
        raise UserError(os_error_message(e, options.out)) from None


def _prepare(options: RunOptions) -> Path:
    """Check or clear OUT; returns OUT/.shards."""
    out = options.out
    work = out / WORK
    if options.resume and options.overwrite:
        raise UserError("--resume and --overwrite exclude each other; pick one")
    if out.exists() and not out.is_dir():
        raise UserError(f"--out {out} is a file; give a folder")
    entries = [p for p in out.iterdir() if p.name != WORK] if out.is_dir() else []
    if options.overwrite:
        shutil.rmtree(work, ignore_errors=True)
        remove_clips(ClipLayout(out))
    elif options.resume and entries and not work.is_dir():
        raise UserError(f"--resume --engine dask: {out} holds a local run; continue it with "
                        f"--engine local --resume, or use --overwrite")
    elif entries and not options.resume:
        raise UserError(f"output folder {out} is not empty: add --resume to continue the "
                        f"run that made it, or --overwrite to replace it")
    return work
