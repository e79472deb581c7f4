"""Running cells: datasets, training, scoring, one JSON per cell; done cells are skipped.

Results folder::

    OUT/grid.json                 the grid (preset, tables, training config, test set)
    OUT/cells/<cell>.json         per cell: config, seeds, datasets, device, wall times,
                                  losses, val and test metrics (written last, atomically)
    OUT/checkpoints/<cell>.pt     the cell's training checkpoint (resume point)
    OUT/datasets/<name>-<hash>/   generated datasets (``--cache`` moves them)

A cell whose JSON exists with the same training key and test set is skipped; one with a
checkpoint continues from it; a finished checkpoint with a new test set is only re-scored.
"""

from __future__ import annotations

import json
import platform
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from .. import __version__
from ..errors import UserError
from ..util.files import atomic_write_bytes
from . import require_torch
from .datasets import (
    CacheOptions,
    EvalSet,
    RealTrain,
    check_disjoint,
    config_key,
    ensure_dataset,
    merged_split,
    val_set,
)
from .evaluate import evaluate_detector
from .grid import Cell, DatasetPart, GridSpec, RealCell
from .train import train, train_key, training_items

FORMAT = "sdcomp-bench-cell"


@dataclass(frozen=True)
class RunContext:
    """Where and on what a grid runs (none of it changes a cell's training)."""

    out: Path
    cache: CacheOptions
    device: str = "cpu"
    progress: bool | None = None
    eval_batch: int = 4


def cell_path(out: Path, cell_id: str) -> Path:
    return Path(out) / "cells" / f"{cell_id}.json"


def checkpoint_path(out: Path, cell_id: str) -> Path:
    return Path(out) / "checkpoints" / f"{cell_id}.pt"


def write_json(path: Path, data: dict) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_bytes(path, (json.dumps(data, indent=1) + "\n").encode())


def read_cell(path: Path) -> dict | None:
    try:
        data = json.loads(Path(path).read_text())
    except (OSError, ValueError):
        return None
    return data if isinstance(data, dict) and data.get("format") == FORMAT else None


def run_cell(cell: Cell | RealCell, grid: GridSpec, test: EvalSet, ctx: RunContext,
             rows: list[tuple[int, str]] | None = None, on_iteration=None,
             real: RealTrain | None = None) -> dict:
    """Train and score ``cell`` (or return its finished result); returns the cell's JSON.

    ``rows``: (table number, row label) pairs the cell stands for, recorded in its JSON;
    ``real``: the user's real training frames, which a :class:`RealCell` trains on (it has
    no synthetic val split: its ``val`` is None).
    """
    t_all = time.perf_counter()
    if isinstance(cell, RealCell):
        if real is None:
            raise UserError(f"cell {cell.id} (Table 6) trains on your real frames: give "
                            f"--real-train FILE --real-train-images DIR")
        parts: list[DatasetPart] = []
        configs: list = []
        keys = [real.key, f"real{grid.images(cell.n)}", f"seed{grid.seed}"]  # which frames
    else:
        parts = grid.parts(cell)
        configs = [p.generator_config() for p in parts]
        keys = [config_key(c) for c in configs]
    key = train_key(grid.train, keys, grid.image_size)
    path = cell_path(ctx.out, cell.id)
    old = read_cell(path)
    if old is not None and old.get("train_key") == key and old.get("test", {}).get(
            "test_set") == test.label:
        return old
    t0 = time.perf_counter()
    folders, reused = _ensure_datasets(parts, configs, ctx.cache)
    t_data = time.perf_counter() - t0
    if isinstance(cell, RealCell):
        assert real is not None
        items = real.pick(grid.images(cell.n), grid.seed)
    else:
        items = training_items(merged_split(folders, "train"))
    ckpt_file = checkpoint_path(ctx.out, cell.id)
    model, history = train(grid.train, items, grid.image_size, ckpt_file, key, ctx.device,
                           ctx.progress, on_iteration)
    t0 = time.perf_counter()
    val = evaluate_detector(model, val_set(folders), ctx.device, ctx.eval_batch) \
        if folders else None
    result = evaluate_detector(model, test, ctx.device, ctx.eval_batch)
    t_eval = time.perf_counter() - t0
    record = _config_record(cell, grid, parts, configs, keys, folders, reused) \
        if isinstance(cell, Cell) else _real_record(cell, grid, real)
    data = {
        "format": FORMAT, "cell": cell.id, "rows": [list(r) for r in rows or []],
        "grid": grid.name, "train_key": key, "config": record,
        "seed": {"datasets": [p.seed for p in parts], "train": grid.train.seed},
        **_environment(ctx.device),
        "train_images": len(items),
        # train: seconds of training summed over interrupted runs; the rest: this run
        "wall_time_s": {"datasets": round(t_data, 3), "train": history["wall_s"],
                        "eval": round(t_eval, 3),
                        "total": round(time.perf_counter() - t_all, 3)},
        "training": {"iterations": len(history["losses"]),
                     "resumed_from": history["resumed_from"],
                     "loss_columns": ["total", "loss_classifier", "loss_box_reg",
                                      "loss_objectness", "loss_rpn_box_reg"],
                     "losses": history["losses"]},
        "val": val, "test": {**result, "kind": test.kind},
    }
    write_json(path, data)
    return data


def ensure_cell_datasets(grid: GridSpec, cell: Cell | RealCell, cache: CacheOptions
                         ) -> list[Path]:
    """Generate (or find in ``cache``) the datasets ``cell`` trains on; returns their
    folders (none for a real cell)."""
    if isinstance(cell, RealCell):
        return []
    parts = grid.parts(cell)
    return _ensure_datasets(parts, [p.generator_config() for p in parts], cache)[0]


def _ensure_datasets(parts: list[DatasetPart], configs: list, cache: CacheOptions
                     ) -> tuple[list[Path], list[bool]]:
    """Generate (or find in the cache) the dataset of each of a cell's ``parts``, made with
    the generator ``configs`` (one per part); returns (their folders, whether each one was
    already there)."""
    folders, reused = [], []
    for part, config in zip(parts, configs, strict=True):
        folder, was_cached = ensure_dataset(config, part.name, cache)
        folders.append(folder)
        reused.append(was_cached)
    return folders, reused


def _config_record(cell: Cell, grid: GridSpec, parts: list[DatasetPart], configs: list,
                   keys: list[str], folders: list[Path], reused: list[bool]) -> dict:
    """The ``config`` entry of a cell's JSON: the cell, the training settings and every
    dataset of its ``parts`` (generator config, key, folder, whether it was reused)."""
    return {"cell": {"altitude": cell.altitude, "water": cell.water,
                     "paper_images": cell.n, "green_images": cell.green},
            "train": grid.train.to_dict(), "image_size": grid.image_size,
            "datasets": [{"name": p.name, "images": p.n, "seed": p.seed,
                          "key": k, "folder": str(f), "reused": r,
                          "generator": c.to_dict()}
                         for p, c, k, f, r in zip(parts, configs, keys, folders, reused,
                                                  strict=True)]}


def _real_record(cell: RealCell, grid: GridSpec, real: RealTrain | None) -> dict:
    """The ``config`` entry of a Table 6 cell's JSON: the cell, the training settings and
    the real frames it drew from (``datasets`` empty)."""
    assert real is not None
    return {"cell": {"paper_images": cell.n, "real_images": grid.images(cell.n)},
            "train": grid.train.to_dict(), "image_size": grid.image_size,
            "real_train": {"label": real.label, "files": list(real.files), "key": real.key,
                           "pool": len(real.items)},
            "datasets": []}


def _environment(device: str) -> dict:
    """The ``device``, ``device_name``, ``threads`` and ``versions`` entries of a cell's
    JSON: what it ran on."""
    torch, torchvision = require_torch()
    return {"device": device, "device_name": _device_name(torch, device),
            "threads": torch.get_num_threads(),
            "versions": {"sdcomp": __version__, "torch": torch.__version__,
                         "torchvision": torchvision.__version__,
                         "python": sys.version.split()[0]}}


def _device_name(torch, device: str) -> str:
    if device.startswith("cuda"):
        return torch.cuda.get_device_name(torch.device(device))
    return platform.processor() or platform.machine() or "cpu"


def _settings(grid: dict) -> dict:
    """What a grid.json must share with a new run into the same folder."""
    train = {k: v for k, v in grid.get("train", {}).items() if k != "checkpoint_every"}
    return {"train": train, "image_size": grid.get("image_size"),
            "size_scale": grid.get("size_scale"), "seed": grid.get("seed")}


def prepare_results(grid: GridSpec, test: EvalSet, ctx: RunContext,
                    overwrite: bool = False, real: RealTrain | None = None) -> None:
    """Check the results folder (a grid run with other training settings is refused unless
    ``overwrite``, which removes its cells and checkpoints) and write ``grid.json``."""
    out = Path(ctx.out)
    if out.exists() and not out.is_dir():
        raise UserError(f"--out {out} is a file; give a folder")
    meta_path = out / "grid.json"
    meta: dict[str, Any] = {
        "format": "sdcomp-bench-grid", "grid": grid.to_dict(), "test_set": test.label,
        "test_kind": test.kind, "test_files": test.files, "device": ctx.device,
        "real_train": None if real is None else real.label}
    if meta_path.exists() and not overwrite:
        try:
            old = json.loads(meta_path.read_text())
        except (OSError, ValueError):
            old = {}
        if _settings(old.get("grid", {})) != _settings(meta["grid"]):
            raise UserError(f"--out {out} holds a grid run with other settings; use another "
                            f"--out, or --overwrite to retrain its cells")
    if overwrite:
        for sub in ("cells", "checkpoints"):
            for f in (out / sub).glob("*") if (out / sub).is_dir() else []:
                f.unlink()
    write_json(meta_path, meta)


def check_real(grid: GridSpec, test: EvalSet | None, real: RealTrain | None) -> None:
    """UserError, before anything is written, when the grid's Table 6 has no real frames,
    fewer than its largest cell asks, or frames of the ``test`` set (unless None) among
    them."""
    if not grid.real:
        return
    if real is None:
        raise UserError(f"--preset {grid.name}: Table 6 trains on your real frames; give "
                        f"--real-train FILE --real-train-images DIR (COCO, category "
                        f"bluerov2)")
    real.pick(max(grid.images(c.n) for c in grid.cells() if isinstance(c, RealCell)),
              grid.seed)
    if test is not None:
        check_disjoint(real, test)


def run_grid(grid: GridSpec, test: EvalSet, ctx: RunContext, overwrite: bool = False,
             log=print, real: RealTrain | None = None) -> list[dict]:
    """Every cell of ``grid`` (finished ones skipped); writes grid.json; returns the cells'
    JSON dicts in table order. ``log`` gets one line per cell; ``real``: Table 6's real
    training frames (:func:`check_real`)."""
    check_real(grid, test, real)
    prepare_results(grid, test, ctx, overwrite, real)
    out = Path(ctx.out)
    rows: dict[Cell | RealCell, list] = {}
    for table, label, cell in grid.rows():
        rows.setdefault(cell, []).append((table.number, label))
    results = []
    cells = grid.cells()
    for k, cell in enumerate(cells):
        t0 = time.perf_counter()
        was = read_cell(cell_path(out, cell.id))
        data = run_cell(cell, grid, test, ctx, rows[cell], real=real)
        m = data["test"]["metrics"]
        state = "done earlier" if was is not None and was == data else (
            f"{time.perf_counter() - t0:.1f} s")
        val = "real frames, no val split" if data["val"] is None else (
            f"val AP {data['val']['metrics']['AP']:.3f}")
        log(f"[{k + 1}/{len(cells)}] {cell.id}: test AP {m['AP']:.3f} AP50 {m['AP50']:.3f}, "
            f"{val} ({state})")
        results.append(data)
    return results


__all__ = ["RunContext", "run_cell", "run_grid", "check_real", "cell_path", "checkpoint_path",
           "read_cell"]
