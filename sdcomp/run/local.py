"""The local engine: a dataset written by this process or a pool of worker processes.

Images are rendered in chunks (:func:`chunk_size`) by :func:`sdcomp.util.pool.imap_ordered`
workers, forked where the platform can (they inherit the generator: textures and sprites
for free) or spawned (they build their own, :func:`sdcomp.pipeline.cached_generator`); their
records are journaled in index order, and the label files are rewritten from the journal at
checkpoints and at the end (:mod:`sdcomp.run.output`).
"""

from __future__ import annotations

import functools
import math
import multiprocessing as mp
import sys
import time
from collections.abc import Generator as Generator_
from contextlib import closing
from pathlib import Path

import cv2

from ..errors import UserError
from ..io.journal import Journal
from ..io.layout import DatasetLayout
from ..io.writers import writers_for
from ..pipeline import Generator, cached_generator
from ..scene.config import GeneratorConfig
from ..util.pool import imap_ordered, note
from ..util.progress import Progress
from .frame_memory import check_run_memory
from .options import RunOptions, run_indices
from .output import (
    on_sigterm,
    os_error_message,
    prepare_output,
    restore_sigterm,
    sweep_tmp,
    write_annotations,
)
from .record import make_record

CHUNK = 32  # images per task handed to a worker, at most
CHUNK_PIXELS = 8_000_000  # pixels per task at most: a full-resolution frame is a task
TASKS_PER_WORKER = 4  # short runs are cut into at least this many tasks per worker
CHECKPOINT_SECONDS = 60.0  # label files are rewritten at least this often during a run


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


def render_chunk(gen: Generator | tuple[GeneratorConfig, str], out: str,
                 indices: list[int]) -> list[dict]:
    """Render, write and return the records of ``indices`` into the folder ``out`` with
    ``gen`` (or, given (config, sprites folder), this process's generator of them)."""
    if not isinstance(gen, Generator):
        gen = cached_generator(*gen)
    layout = DatasetLayout(Path(out))
    writers = writers_for(gen.config)
    records = []
    for i in indices:
        note(i)  # named by WorkerDied should this image kill the worker
        records.append(make_record(gen, i, layout, writers))
    return records


def _results(gen: Generator, chunks: list[list[int]], options: RunOptions
             ) -> Generator_[list[dict], None, None]:
    """Records per chunk, in order, from this process or a pool of workers."""
    if options.workers <= 1 or len(chunks) <= 1:
        for c in chunks:
            yield render_chunk(gen, str(options.out), c)
        return
    # forked workers inherit the generator; spawned ones build it
    if "fork" in mp.get_all_start_methods():
        gen.warm()  # its sprites prepared once, here, instead of in every worker
        source: Generator | tuple[GeneratorConfig, str] = gen
    else:
        source = (gen.config, str(options.sprites_dir))
    yield from imap_ordered(functools.partial(render_chunk, source, str(options.out)),
                            chunks, options.workers, initializer=cv2.setNumThreads,
                            initargs=(1,), what="image")


def run(config: GeneratorConfig, options: RunOptions, gen: Generator | None = None) -> dict:
    """Generate the dataset of ``config`` into ``options.out``; returns the counts.

    Ctrl-C (KeyboardInterrupt) or an error stops the run after writing valid label files and
    dataset.json for the images finished so far, then re-raises.
    A file-system error (disk full, no permission) becomes a one-line UserError naming the
    file and how many images are kept; a worker that dies,
    :class:`sdcomp.util.pool.WorkerDied`. Neither leaves a partial file under a final name,
    and ``--resume`` continues the run. A run that would need more memory than the machine
    has (:mod:`sdcomp.run.frame_memory`) is refused first, before anything is written.
    """
    check_run_memory(config.width, config.height, options.workers,
                     len(run_indices(config, options.shard)))
    try:
        if gen is None:  # first: a bad mesh or backgrounds folder must not leave files behind
            gen = Generator(config, options.sprites_dir, progress=options.progress)
        done = prepare_output(config, options)
        return _run(config, options, gen, done)
    except OSError as e:
        raise UserError(os_error_message(e, options.out)) from None


def _run(config: GeneratorConfig, options: RunOptions, gen: Generator, done: set[int]) -> dict:
    out = options.out
    indices = run_indices(config, options.shard)
    pending = [i for i in indices if i not in done]
    size = chunk_size(config.width, config.height, len(pending), options.workers)
    chunks = [pending[k:k + size] for k in range(0, len(pending), size)]
    progress = Progress(len(pending), "generate", options.progress, unit="img")
    status = "interrupted"
    failure: OSError | None = None
    old_term = on_sigterm()
    try:  # from the first write on, Ctrl-C or SIGTERM ends with the final write below
        write_annotations(config, out, "running", options.shard)
        _journal(config, options, gen, chunks, progress)
        status = "complete"
    except OSError as e:
        status, failure = "failed", e
    except Exception:
        status = "failed"
        raise
    finally:
        progress.close()
        sweep_tmp(DatasetLayout(out), writers_for(config))
        counts: dict | None = None
        try:  # SIGTERM still raises KeyboardInterrupt here: no write is cut off by SIG_DFL
            counts = write_annotations(config, out, status, options.shard)
        except OSError as e:
            if status == "complete":
                raise
            failure = failure or e  # the files of the last checkpoint stay, whole
        finally:
            restore_sigterm(old_term)
        if status == "interrupted" and counts is not None:
            print(f"stopped after {counts['images']} of {len(indices)} images; the annotation "
                  f"files cover them. Continue with the same command and --resume.",
                  file=sys.stderr)
    if failure is not None:
        kept = (f"{counts['images']} of {len(indices)} images are saved; "
                if counts is not None else "the images finished so far are kept; ")
        raise UserError(os_error_message(failure, out, kept))
    assert counts is not None
    return counts


def _journal(config: GeneratorConfig, options: RunOptions, gen: Generator,
             chunks: list[list[int]], progress: Progress) -> None:
    """Render ``chunks``, journal their records in order, rewrite the label files every
    :data:`CHECKPOINT_SECONDS`."""
    last = time.monotonic()
    with Journal(DatasetLayout(options.out).journal) as journal, \
            closing(_results(gen, chunks, options)) as results:
        for records in results:
            journal.append(records)
            progress.update(len(records))
            if time.monotonic() - last > CHECKPOINT_SECONDS:
                write_annotations(config, options.out, "running", options.shard)
                last = time.monotonic()
