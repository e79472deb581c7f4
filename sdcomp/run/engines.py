"""Engines: how the images of a run get rendered, behind one interface.

An engine is ``engine(config, options, scheduler) -> counts``: it writes the dataset of
``config`` into ``options.out`` (:mod:`sdcomp.run.output` owns the folder's life cycle for
all of them) and returns the counts dataset.json records. ``local`` renders in this
process or a pool of worker processes (:mod:`sdcomp.run.local`, also behind ``--shard K/N``
and the job arrays that :mod:`sdcomp.run.merge` joins); ``dask`` submits shards to a Dask
cluster at ``scheduler`` (or a local one) and merges them (:mod:`sdcomp.run.dask_engine`,
imported only when used: dask is optional). Add one by adding a line to :data:`ENGINES`.
"""

from __future__ import annotations

from collections.abc import Callable

from ..scene.config import GeneratorConfig
from .local import run
from .options import RunOptions

Engine = Callable[[GeneratorConfig, RunOptions, "str | None"], dict]


def local_engine(config: GeneratorConfig, options: RunOptions,
                 scheduler: str | None = None) -> dict:
    """The local engine (``scheduler`` is not used: there is none)."""
    return run(config, options)


def dask_engine(config: GeneratorConfig, options: RunOptions,
                scheduler: str | None = None) -> dict:
    """The Dask engine, on the cluster at ``scheduler`` (None: a local cluster)."""
    from .dask_engine import run_dask  # dask is optional: imported only here

    return run_dask(config, options, scheduler)


#: engine name (``--engine``) -> engine
ENGINES: dict[str, Engine] = {"local": local_engine, "dask": dask_engine}
