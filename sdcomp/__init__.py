"""sdcomp: synthetic aerial datasets of objects on water, with exact masks.

The package reads as its data flow, one subpackage per stage (see docs/architecture.md):

    assets -> atlas -> scene -> render -> annotate -> io -> run -> cli

The public API is importable from here (loaded on first use, so ``python -m sdcomp.<job>``
starts fast and ``import sdcomp`` imports neither torch nor OpenCV)::

    from sdcomp import GeneratorConfig, Generator, RunOptions, run
    from sdcomp import fit          # your footage -> the GeneratorConfig that looks like it
    from sdcomp import SyntheticDetection, GeneratedCoco, collate      # needs torch

Module paths of earlier versions (``sdcomp.config``, ``sdcomp.generator``, ``sdcomp.writer``,
``sdcomp.yolo``, ``sdcomp.torch``, ...) still import, as aliases of their new homes
(:data:`MOVED`).
"""

from __future__ import annotations

import importlib
import importlib.abc
import importlib.util
import sys
import types
from typing import Any

__version__ = "0.1.0"

#: public name -> the module that defines it
API = {
    "GeneratorConfig": "sdcomp.scene.config", "ObjectSpec": "sdcomp.scene.config",
    "Generator": "sdcomp.pipeline", "Sample": "sdcomp.pipeline",
    "RunOptions": "sdcomp.run.options", "run": "sdcomp.run.local",
    "load_dataset": "sdcomp.io.layout", "contact_sheet": "sdcomp.report.sheet",
    "dataset_stats": "sdcomp.report.stats", "UserError": "sdcomp.errors",
    "SyntheticDetection": "sdcomp.torch_datasets", "GeneratedCoco": "sdcomp.torch_datasets",
    "collate": "sdcomp.torch_datasets", "fit": "sdcomp.fitting.api",
}

#: old module path -> its new home (the old path stays importable as an alias)
MOVED = {
    "sdcomp.config": "sdcomp.scene.config", "sdcomp.params": "sdcomp.scene.params",
    "sdcomp.camera": "sdcomp.scene.camera", "sdcomp.water": "sdcomp.scene.water",
    "sdcomp.generator": "sdcomp.pipeline", "sdcomp.writer": "sdcomp.run.local",
    "sdcomp.engine_dask": "sdcomp.run.dask_engine", "sdcomp.shards": "sdcomp.run.shards",
    "sdcomp.pool": "sdcomp.util.pool", "sdcomp.coco": "sdcomp.io.coco",
    "sdcomp.yolo": "sdcomp.io.yolo", "sdcomp.pngio": "sdcomp.io.png",
    "sdcomp.fileio": "sdcomp.util.files", "sdcomp.progress": "sdcomp.util.progress",
    "sdcomp.log": "sdcomp.util.log", "sdcomp.bluerov2": "sdcomp.assets.bluerov2",
    "sdcomp.clutter": "sdcomp.assets.clutter", "sdcomp.meshfile": "sdcomp.assets.meshfile",
    "sdcomp.coloredmesh": "sdcomp.assets.mesh", "sdcomp.poses": "sdcomp.atlas.poses",
    "sdcomp.sprites": "sdcomp.atlas.sprites", "sdcomp.shading": "sdcomp.util.colour",
    "sdcomp.compositor": "sdcomp.render.compositor",
    "sdcomp.backgrounds": "sdcomp.render.photos", "sdcomp.torch": "sdcomp.torch_datasets",
}


def __getattr__(name: str) -> Any:
    """The public API (:data:`API`), imported on first use."""
    if name in API:
        return getattr(importlib.import_module(API[name]), name)
    raise AttributeError(f"module 'sdcomp' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted([*globals(), *API])


class _Alias(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    """Imports an old module path (:data:`MOVED`) as a module whose attributes are those of
    the module at its new home."""

    def find_spec(self, fullname: str, path: Any = None, target: Any = None) -> Any:
        if fullname not in MOVED:
            return None
        return importlib.util.spec_from_loader(fullname, self)

    def create_module(self, spec: Any) -> types.ModuleType:
        home = MOVED[spec.name]
        module = types.ModuleType(spec.name, f"{spec.name}: moved to {home}")

        def forward(attr: str) -> Any:
            return getattr(importlib.import_module(home), attr)

        module.__getattr__ = forward  # type: ignore[method-assign]
        return module

    def exec_module(self, module: types.ModuleType) -> None:
        importlib.import_module(MOVED[module.__name__])  # its import errors surface here


if not any(isinstance(f, _Alias) for f in sys.meta_path):
    sys.meta_path.append(_Alias())
