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
import signal
import sys
from pathlib import Path

from .config import GeneratorConfig
from .errors import UserError
from .generator import Generator
from .merge import merge
from .progress import Progress
from .shards import shard_folder, shard_text
from .writer import (
    OURS,
    RunOptions,
    _on_sigterm,
    _resumable,
    os_error_message,
    run,
    write_annotations,
)

WORK = ".shards"  # OUT/.shards/: the shard folders while a run is on
SHARDS_PER_WORKER = 4  # load balance: more, smaller shards than workers

_GENERATORS: dict[tuple[str, str], Generator] = {}  # per worker process: built once


def _generator(config: GeneratorConfig, sprites: str) -> Generator:
    key = (repr(sorted(config.to_dict().items())), sprites)
    gen = _GENERATORS.get(key)
    if gen is None:
        _GENERATORS.clear()  # one config at a time: textures and sprites are large
        gen = _GENERATORS[key] = Generator(config, sprites, progress=False)
    return gen


def render_shard(config_dict: dict, folder: str, k: int, n: int, sprites: str) -> dict:
    """A Dask task: render shard ``k`` of ``n`` into ``folder``, continuing what an earlier
    attempt left there; returns the shard's counts (as :func:`sdcomp.writer.run`)."""
    config = GeneratorConfig.from_mapping(config_dict, None, "config")
    out = Path(folder)
    resume = (out / "dataset.json").is_file()  # else a fresh folder, or one never begun
    options = RunOptions(out, workers=1, resume=resume, overwrite=not resume, progress=False,
                         sprites_dir=Path(sprites), shard=(k, n))
    return run(config, options, gen=_generator(config, sprites))


def _local_cluster(local_cluster, workers: int):
    """A LocalCluster of ``workers`` single-threaded processes, started without the
    ``MALLOC_TRIM_THRESHOLD_`` that Dask's nanny sets by default: with it glibc hands every
    large array back to the system at once, and rendering runs about 1.6 times slower."""
    import dask

    env = dict(dask.config.get("distributed.nanny.pre-spawn-environ", {}) or {})
    env.pop("MALLOC_TRIM_THRESHOLD_", None)
    with dask.config.set({"distributed.nanny.pre-spawn-environ": env}):
        return local_cluster(n_workers=workers, threads_per_worker=1, processes=True,
                             dashboard_address=None)


def _existing_shards(work: Path) -> int | None:
    """N of the shard folders already in ``work`` (a run being resumed), else None."""
    ns = set()
    for p in work.glob("shard-*-of-*") if work.is_dir() else ():
        try:
            ns.add(int(p.name.rsplit("-of-", 1)[1]))
        except ValueError:
            continue
    return ns.pop() if len(ns) == 1 else None


def _prepare(config: GeneratorConfig, options: RunOptions) -> tuple[Path, bool]:
    """Check or clear OUT like a local run; returns (OUT/.shards, whether all is done)."""
    out = options.out
    if out.exists() and not out.is_dir():
        raise UserError(f"--out {out} is a file; give a folder")
    if options.resume and options.overwrite:
        raise UserError("--resume and --overwrite exclude each other; pick one")
    entries = list(out.iterdir()) if out.exists() else []
    if entries and not (options.resume or options.overwrite):
        raise UserError(f"output folder {out} is not empty: add --resume to continue the "
                        f"run that made it, or --overwrite to replace it")
    work = out / WORK
    if entries and options.overwrite:
        for name in (*OURS, WORK):
            p = out / name
            if p.is_dir():
                shutil.rmtree(p)
            elif p.exists():
                p.unlink()
    elif entries and options.resume and not work.is_dir():
        done = _resumable(config, out)  # refuses other options
        if len(done) == config.n:
            return work, True
        raise UserError(f"--resume --engine dask: {out} holds a local run ({len(done)} of "
                        f"{config.n} images); continue it with --engine local --resume, or "
                        f"use --overwrite")
    return work, False


def run_dask(config: GeneratorConfig, options: RunOptions, scheduler: str | None = None,
             shards: int | None = None) -> dict:
    """Generate the dataset of ``config`` into ``options.out`` on a Dask cluster (at
    ``scheduler``, else a local one of ``options.workers`` processes), in ``shards`` shards
    (default: 4 per worker, or those of the run being resumed); returns the counts."""
    if options.shard is not None:
        raise UserError(f"--shard {shard_text(options.shard)} and --engine dask exclude each "
                        f"other (the Dask engine makes its own shards): drop one")
    try:
        from dask.distributed import Client, LocalCluster, as_completed
    except ImportError:
        raise UserError("--engine dask needs dask.distributed: pip install 'sdcomp[dask]', "
                        "or use --engine local") from None
    try:
        return _run(config, options, scheduler, shards, Client, LocalCluster, as_completed)
    except OSError as e:
        raise UserError(os_error_message(e, options.out)) from None


def _run(config: GeneratorConfig, options: RunOptions, scheduler: str | None,
         shards: int | None, Client, LocalCluster, as_completed) -> dict:  # noqa: N803
    # build or check the sprite atlases (and every input) once, here, before any task
    Generator(config, options.sprites_dir, progress=options.progress)
    work, finished = _prepare(config, options)
    out = options.out
    if finished:
        return write_annotations(config, out, "complete")
    cluster = None
    old_term = _on_sigterm()  # a job scheduler's SIGTERM stops the run like Ctrl-C
    try:
        if scheduler is None:
            cluster = _local_cluster(LocalCluster, options.workers)
            client = Client(cluster)
        else:
            try:
                client = Client(scheduler, timeout=30)
            except (OSError, TimeoutError, ValueError) as e:
                raise UserError(f"--scheduler {scheduler}: cannot connect ({e}); check the "
                                f"address (tcp://HOST:PORT) and that the scheduler runs") from None
        with client:
            n_workers = max(1, len(client.scheduler_info().get("workers", {})))
            n = _existing_shards(work) or shards or min(config.n, SHARDS_PER_WORKER * n_workers)
            work.mkdir(parents=True, exist_ok=True)
            folders = [work / shard_folder(k, n) for k in range(n)]
            cfg, sprites = config.to_dict(), str(Path(options.sprites_dir).resolve())
            futures = {client.submit(render_shard, cfg, str(folders[k].resolve()), k, n, sprites,
                                     key=f"sdcomp-shard-{k}-of-{n}-{out.resolve()}",
                                     pure=False): k
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
                print(f"stopped; the finished shards are kept in {work}. Continue with the "
                      f"same command and --resume.", file=sys.stderr)
                raise
            finally:
                bar.close()
        if failed:
            k, exc = min(failed, key=lambda f: f[0])
            others = f" (and {len(failed) - 1} more shards)" if len(failed) > 1 else ""
            msg = " ".join(str(exc).split()) or type(exc).__name__
            raise UserError(f"shard {shard_text((k, n))}{others} failed: {msg}; the other "
                            f"shards are kept in {work}: re-run the same command with --resume")
    finally:
        if old_term is not None:
            signal.signal(signal.SIGTERM, old_term)
        if cluster is not None:
            cluster.close()
    counts = merge(folders, out, overwrite=True, remove=True, progress=options.progress)
    shutil.rmtree(work, ignore_errors=True)
    return counts
