"""``--engine dask``: the images of a run as shard tasks on a Dask distributed cluster.

The client (the ``python -m sdcomp.generate`` process) splits the image indices into N shards
(:mod:`sdcomp.shards`) and submits one task per shard. Each task renders its shard, as a
``--shard K/N`` run would, into ``OUT/.shards/shard-K-of-N/`` on the shared output path; when
all are done the client merges them into OUT (:mod:`sdcomp.merge`: hard links, the journal in
index order, the annotation files) and removes ``OUT/.shards``. The result is byte-identical to
a local run of the same options.

Without ``--scheduler`` a :class:`distributed.LocalCluster` of ``--workers`` processes (one
thread each) is started and stopped again. With ``--scheduler ADDRESS`` the tasks run on that
cluster: its workers must see OUT, the sprites folder and any mesh or background files at the
same paths (a shared file system), with the same sdcomp installed.

Faults: a task that raises, or whose worker dies more often than Dask's
``distributed.scheduler.allowed-failures``, fails its shard; the other shards finish, nothing
is merged, and the error names the shard. ``--resume`` re-runs only what is missing: each
shard continues from its own journal. dask is imported only in this module.
"""

from __future__ import annotations

import shutil
import sys
from pathlib import Path

from ..errors import UserError
from ..pipeline import Generator, cached_generator
from ..scene.config import GeneratorConfig
from ..util.progress import Progress
from .frame_memory import check_run_memory
from .local import run
from .merge import merge
from .options import RunOptions
from .output import (
    on_sigterm,
    os_error_message,
    prepare_output,
    restore_sigterm,
    resumable,
    write_annotations,
)
from .shards import shard_folder, shard_text

WORK = ".shards"  # OUT/.shards/: the shard folders while a run is on
SHARDS_PER_WORKER = 4  # load balance: more, smaller shards than workers

def render_shard(config_dict: dict, folder: str, k: int, n: int, sprites: str) -> dict:
    """A Dask task: render shard ``k`` of ``n`` into ``folder``, continuing what an earlier
    attempt left there; returns the shard's counts (as :func:`sdcomp.writer.run`)."""
    config = GeneratorConfig.from_mapping(config_dict, None, "config")
    out = Path(folder)
    resume = (out / "dataset.json").is_file()  # else a fresh folder, or one never begun
    options = RunOptions(out, workers=1, resume=resume, overwrite=not resume, progress=False,
                         sprites_dir=Path(sprites), shard=(k, n))
    return run(config, options, gen=cached_generator(config, sprites))


def local_cluster(cluster_class, workers: int):
    """A LocalCluster of ``workers`` single-threaded processes, started without the
    ``MALLOC_TRIM_THRESHOLD_`` that Dask's nanny sets by default: with it glibc hands every
    large array back to the system at once, and rendering runs about 1.6 times slower."""
    import dask

    env = dict(dask.config.get("distributed.nanny.pre-spawn-environ", {}) or {})
    env.pop("MALLOC_TRIM_THRESHOLD_", None)
    with dask.config.set({"distributed.nanny.pre-spawn-environ": env}):
        return cluster_class(n_workers=workers, threads_per_worker=1, processes=True,
                             dashboard_address=None)


def existing_shards(work: Path) -> int | None:
    """N of the shard folders already in ``work`` (a run being resumed), else None."""
    ns = set()
    for p in work.glob("shard-*-of-*") if work.is_dir() else ():
        try:
            ns.add(int(p.name.rsplit("-of-", 1)[1]))
        except ValueError:
            continue
    return ns.pop() if len(ns) == 1 else None


def _prepare(config: GeneratorConfig, options: RunOptions) -> tuple[Path, bool]:
    """Check or clear OUT like a local run; returns (OUT/.shards, whether all is done: a
    complete local run being resumed)."""
    out = options.out
    work = out / WORK
    shards_begun = options.resume and work.is_dir()
    had_entries = out.is_dir() and any(out.iterdir())
    prepare_output(config, options, extra=(WORK,), check_resume=False)
    if options.resume and had_entries and not shards_begun:
        done = resumable(config, out)  # refuses other options
        if len(done) == config.n:
            return work, True
        raise UserError(f"--resume --engine dask: {out} holds a local run ({len(done)} of "
                        f"{config.n} images); continue it with --engine local --resume, or "
                        f"use --overwrite")
    return work, False


def dask_modules(options: RunOptions) -> tuple:
    """(Client, LocalCluster, as_completed) of dask.distributed; UserError when it is not
    installed, or when ``options`` asks for a shard (the Dask engine makes its own)."""
    if options.shard is not None:
        raise UserError(f"--shard {shard_text(options.shard)} and --engine dask exclude each "
                        f"other (the Dask engine makes its own shards): drop one")
    try:
        from dask.distributed import Client, LocalCluster, as_completed
    except ImportError:
        raise UserError("--engine dask needs dask.distributed: pip install 'sdcomp[dask]', "
                        "or use --engine local") from None
    return Client, LocalCluster, as_completed


def run_dask(config: GeneratorConfig, options: RunOptions, scheduler: str | None = None,
             shards: int | None = None) -> dict:
    """Generate the dataset of ``config`` into ``options.out`` on a Dask cluster (at
    ``scheduler``, else a local one of ``options.workers`` processes), in ``shards`` shards
    (default: 4 per worker, or those of the run being resumed); returns the counts."""
    Client, LocalCluster, as_completed = dask_modules(options)  # noqa: N806
    try:
        return _run(config, options, scheduler, shards, Client, LocalCluster, as_completed)
    except OSError as e:
        raise UserError(os_error_message(e, options.out)) from None


def _run(config: GeneratorConfig, options: RunOptions, scheduler: str | None,
         shards: int | None, Client, LocalCluster, as_completed) -> dict:  # noqa: N803
    if scheduler is None:  # a local cluster: its workers share this machine's memory
        check_run_memory(config.width, config.height, options.workers, config.n)
    # build or check the sprite atlases (and every input) once, here, before any task
    Generator(config, options.sprites_dir, progress=options.progress)
    work, finished = _prepare(config, options)
    out = options.out
    if finished:
        return write_annotations(config, out, "complete")
    cluster = None
    old_term = on_sigterm()  # a job scheduler's SIGTERM stops the run like Ctrl-C
    try:
        client, cluster = open_client(Client, LocalCluster, scheduler, options.workers)
        with client:
            n_workers = max(1, len(client.scheduler_info().get("workers", {})))
            n = existing_shards(work) or shards or min(config.n, SHARDS_PER_WORKER * n_workers)
            work.mkdir(parents=True, exist_ok=True)
            folders = [work / shard_folder(k, n) for k in range(n)]
            failed = submit_shards(client, as_completed, render_shard, config.to_dict(),
                                   options, folders, "sdcomp-shard")
        check_failed(failed, n, work)
    finally:
        restore_sigterm(old_term)
        if cluster is not None:
            cluster.close()
    counts = merge(folders, out, overwrite=True, remove=True, progress=options.progress)
    shutil.rmtree(work, ignore_errors=True)
    return counts


def open_client(Client, LocalCluster, scheduler: str | None, workers: int  # noqa: N803
                ) -> tuple:
    """(a client, the local cluster it runs on or None): of the cluster at ``scheduler``,
    else of a new local cluster of ``workers`` processes (close it after the client)."""
    if scheduler is None:
        cluster = local_cluster(LocalCluster, workers)
        return Client(cluster), cluster
    return connect(Client, scheduler), None


def connect(Client, scheduler: str):  # noqa: N803
    """A client of the cluster at ``scheduler``; UserError when it cannot be reached."""
    try:
        return Client(scheduler, timeout=30)
    except (OSError, TimeoutError, ValueError) as e:
        raise UserError(f"--scheduler {scheduler}: cannot connect ({e}); check the "
                        f"address (tcp://HOST:PORT) and that the scheduler runs") from None


def submit_shards(client, as_completed, task, cfg: dict, options: RunOptions,
                  folders: list[Path], key: str) -> list[tuple[int, BaseException]]:
    """Submit ``task(cfg, folder, k, n, sprites)`` for each shard folder and wait for them
    all; returns the failed ones (shard number, exception). Ctrl-C cancels the tasks (the
    finished shards stay)."""
    n, out = len(folders), options.out
    sprites = str(Path(options.sprites_dir).resolve())
    futures = {client.submit(task, cfg, str(folders[k].resolve()), k, n, sprites,
                             key=f"{key}-{k}-of-{n}-{out.resolve()}", pure=False): k
               for k in range(n)}
    bar = Progress(n, "shards", options.progress, unit="shard")
    failed: list[tuple[int, BaseException]] = []
    try:
        for fut in as_completed(list(futures)):
            if fut.status == "error":
                failed.append((futures[fut], fut.exception()))
            elif fut.status != "finished":  # cancelled, lost
                failed.append((futures[fut], RuntimeError(f"task {fut.status}")))
            bar.update(1)
    except BaseException:
        client.cancel(list(futures))
        print(f"stopped; the finished shards are kept in {out / WORK}. Continue with the "
              f"same command and --resume.", file=sys.stderr)
        raise
    finally:
        bar.close()
    return failed


def check_failed(failed: list[tuple[int, BaseException]], n: int, work: Path) -> None:
    """UserError naming the first of the ``failed`` shards of ``n`` (the others are kept in
    ``work`` for --resume); nothing when none failed."""
    if failed:
        k, exc = min(failed, key=lambda f: f[0])
        others = f" (and {len(failed) - 1} more shards)" if len(failed) > 1 else ""
        msg = " ".join(str(exc).split()) or type(exc).__name__
        raise UserError(f"shard {shard_text((k, n))}{others} failed: {msg}; the other "
                        f"shards are kept in {work}: re-run the same command with --resume")
