"""Stage 7, runs: a dataset folder written from a config, kill-safe and resumable.

- :mod:`~sdcomp.run.options`: how a run is carried out (:class:`RunOptions`);
- :mod:`~sdcomp.run.record`: one image: render, write its files, its journal record;
- :mod:`~sdcomp.run.output`: the output folder's life cycle (prepare, resume, finish);
- :mod:`~sdcomp.run.engines`: the engines (local, Dask) behind one interface;
- :mod:`~sdcomp.run.local`, :mod:`~sdcomp.run.dask_engine`: the engines;
- :mod:`~sdcomp.run.shards`, :mod:`~sdcomp.run.merge`: job-array shards and joining them.
"""

from .local import run
from .options import RunOptions

__all__ = ["RunOptions", "run"]
