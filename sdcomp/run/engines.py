"""Engines: how the images of a run get rendered, behind one interface.

An engine is ``engine(config, options, scheduler) -> counts``: it writes the dataset of
``config`` into ``options.out`` (:mod:`sdcomp.run.output` owns the folder's life cycle for
all of them) and returns the counts dataset.json records. ``local`` renders in this
process or a pool of worker processes (:mod:`sdcomp.run.local`, also behind ``--shard K/N``
and the job arrays that :mod:`sdcomp.run.merge` joins); ``dask`` submits shards to a Dask
cluster at ``scheduler`` (or a local one) and merges them (:mod:`sdcomp.run.dask_engine`,
imported only when used: dask is optional). Add one by adding a line to :data:`ENGINES`.

Video runs (``sdcomp video``) take the same ``--engine`` names from :data:`VIDEO_ENGINES`:
``video_engine(video, options, scheduler) -> counts`` writes the sequences of a
:class:`~sdcomp.scene.video.VideoConfig`; each still engine has its video twin.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING

from ..scene.config import GeneratorConfig
from .local import run
from .options import RunOptions

if TYPE_CHECKING:
    from ..scene.video import VideoConfig

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

VideoEngine = Callable[["VideoConfig", RunOptions, "str | None"], dict]


def local_video_engine(video: VideoConfig, options: RunOptions,
                       scheduler: str | None = None) -> dict:
    """Sequences rendered here (:func:`sdcomp.run.video.run_video`; no ``scheduler``)."""
    from .video import run_video

    return run_video(video, options)


def dask_video_engine(video: VideoConfig, options: RunOptions,
                      scheduler: str | None = None) -> dict:
    """Sequences as shard tasks on the Dask cluster at ``scheduler`` (None: a local one)."""
    from .video_dask import run_video_dask  # dask is optional: imported only here

    return run_video_dask(video, options, scheduler)


#: engine name (``sdcomp video --engine``) -> video engine: the same names as ENGINES
VIDEO_ENGINES: dict[str, VideoEngine] = {"local": local_video_engine,
                                         "dask": dask_video_engine}
