"""Command line: ``python -m sdcomp.bench grid|train|eval|report``.

::

    python -m sdcomp.bench grid --preset paper --out results/ [--device cuda]
    python -m sdcomp.bench grid --preset smoke --out /tmp/r          # minutes on a CPU
    python -m sdcomp.bench train --preset paper-table1 --cell alt30-brown-n626 --out results/
    python -m sdcomp.bench eval results/ --cell alt10-brown-n626 --test-coco real.json \\
        --test-images frames/
    python -m sdcomp.bench report results/
    python -m sdcomp.bench sim2real --train gen/ --real frames/ --real-labels frames.json \
        --out s2r/ [--map kayak=boat]

``grid`` trains and scores every cell of a preset (finished cells are skipped, interrupted
ones resume) and writes the report; ``train`` does one cell; ``eval`` re-scores a trained
cell on another test set (printed and written to ``OUT/eval/``); ``report`` rewrites
``report.md`` and the plots. Training flags override the preset's values. ``sim2real``
trains on generated datasets of any categories and scores on the user's labelled real
frames (:mod:`sdcomp.bench.sim2real`).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections.abc import Sequence
from dataclasses import fields, replace
from pathlib import Path

from ..atlas.cache import sprites_folder
from ..cli import prog
from ..errors import UserError, run_cli
from ..pipeline import DEFAULT_SPRITES
from .detector import BACKBONES
from .fewshot_cli import cmd_fewshot as fewshot_command
from .fewshot_cli import fewshot_parser, native_training_flags
from .grid import PRESETS, GridSpec, RealCell, preset
from .train import OPTIMIZERS

TRAIN_FLAGS = {  # flag dest: (type, metavar, help)
    "backbone": (str, "NAME", f"detector backbone: {', '.join(BACKBONES)}"),
    "weights": (str, "W", "starting weights: none (from scratch), default (torchvision's "
                          "best: COCO detector for resnet50-fpn, ImageNet backbone otherwise; "
                          "downloads), backbone (ImageNet backbone), or a state-dict FILE"),
    "optimizer": (str, "NAME", f"optimiser: {', '.join(OPTIMIZERS)}"),
    "lr": (float, "LR", "learning rate"),
    "momentum": (float, "M", "SGD momentum"),
    "weight_decay": (float, "WD", "weight decay"),
    "max_iter": (int, "N", "training iterations"),
    "batch_size": (int, "B", "images per iteration"),
    "warmup_iters": (int, "N", "linear learning-rate warm-up iterations"),
    "proposals_train": (int, "K", "RPN proposals per image in training"),
    "proposals_test": (int, "K", "RPN proposals per image when scoring"),
    "roi_batch": (int, "K", "proposals sampled per image to train the box head"),
    "min_scale": (float, "F", "multi-scale training: batches scaled to F..1 x the image "
                              "size (1 = off)"),
    "checkpoint_every": (int, "N", "iterations between checkpoints"),
    "train_seed": (int, "S", "seed of initialisation and batch order"),
}


def _common(p: argparse.ArgumentParser) -> None:
    p.add_argument("--preset", default="smoke", metavar="NAME",
                   help=f"grid preset: {', '.join(PRESETS)} (default: %(default)s)")
    p.add_argument("--device", default="auto", metavar="DEV",
                   help="auto (cuda when present, else cpu), cpu or cuda[:N] (default: auto)")
    p.add_argument("--cache", metavar="DIR", help="generated datasets (default: OUT/datasets)")
    p.add_argument("--sprites", default=DEFAULT_SPRITES, metavar="DIR",
                   help="sprite atlas folder, built there if missing (default: "
                   "$SDCOMP_SPRITES, else the user's cache folder)")
    p.add_argument("--workers", type=int, default=2, metavar="N",
                   help="generator worker processes (default: %(default)s)")
    p.add_argument("--test-coco", metavar="FILE", help="COCO file of your real labelled "
                   "frames (category bluerov2); default: the synthetic field set")
    p.add_argument("--test-images", metavar="DIR", help="folder of the --test-coco images")
    p.add_argument("--real-train", metavar="FILE", help="COCO file of your real labelled "
                   "training frames (category bluerov2): adds the paper's Table 6, the "
                   "detector trained on 500, 1000 and 1500 of them (x --size-scale) alone")
    p.add_argument("--real-train-images", metavar="DIR",
                   help="folder of the --real-train images")
    p.add_argument("--field-n", type=int, metavar="N", help="synthetic field set size")
    p.add_argument("--field-seed", type=int, metavar="S", help="synthetic field set seed")
    p.add_argument("--image-size", type=int, metavar="PX", help="square image size")
    p.add_argument("--size-scale", type=float, metavar="F",
                   help="multiply the paper's image counts by F")
    p.add_argument("--seed", type=int, metavar="S", help="dataset seed")
    p.add_argument("--threads", type=int, metavar="N", help="torch CPU threads")
    p.add_argument("--progress", action=argparse.BooleanOptionalAction, default=None,
                   help="progress line (default: only on a terminal)")
    g = p.add_argument_group("training (override the preset)")
    for dest, (typ, metavar, text) in TRAIN_FLAGS.items():
        g.add_argument("--" + dest.replace("_", "-"), dest=dest, type=typ, metavar=metavar,
                       help=text)
    g.add_argument("--hflip", action=argparse.BooleanOptionalAction, default=None,
                   help="random horizontal flips")


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog=prog("bench"),
                                description="Train and score Faster R-CNN on sdcomp datasets: "
                                            "the SeaDroneSim paper's ablation grid.")
    sub = p.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    g = sub.add_parser("grid", help="run every cell of a preset and write the report")
    g.add_argument("--out", metavar="DIR", help="results folder (required unless --list)")
    g.add_argument("--overwrite", action="store_true",
                   help="retrain every cell even if results exist")
    g.add_argument("--list", action="store_true", help="list the preset's cells and exit")
    g.add_argument("--datasets-only", action="store_true",
                   help="generate every cell's datasets and the test set into the cache, "
                   "train nothing (e.g. on CPU nodes before the GPU job, or before "
                   "`train --cell` runs in parallel)")
    _common(g)
    t = sub.add_parser("train", help="train and score one cell of a preset")
    t.add_argument("--out", required=True, metavar="DIR", help="results folder")
    t.add_argument("--cell", required=True, metavar="ID",
                   help="cell id, e.g. alt10-brown-n626 (see grid --list)")
    _common(t)
    e = sub.add_parser("eval", help="score a trained cell on a test set")
    e.add_argument("results", metavar="DIR", help="results folder of a grid or train run")
    e.add_argument("--cell", required=True, metavar="ID", help="cell id")
    e.add_argument("--device", default="auto", metavar="DEV", help="auto, cpu or cuda")
    e.add_argument("--cache", metavar="DIR", help="generated datasets (default: DIR/datasets)")
    e.add_argument("--sprites", default=DEFAULT_SPRITES, metavar="DIR", help="sprite atlases")
    e.add_argument("--test-coco", metavar="FILE", help="COCO file of real labelled frames")
    e.add_argument("--test-images", metavar="DIR", help="folder of the --test-coco images")
    e.add_argument("--threads", type=int, metavar="N", help="torch CPU threads")
    r = sub.add_parser("report", help="write report.md and plots of a results folder")
    r.add_argument("results", metavar="DIR", help="results folder")
    _sim2real_parser(sub)
    fewshot_parser(sub, TRAIN_FLAGS)
    return p


def _sim2real_parser(sub) -> None:
    s = sub.add_parser("sim2real", help="train on generated data, score on your labelled "
                       "real frames, and say whether the object or the scene is the gap")
    s.add_argument("--train", action="append", required=True, metavar="DIR",
                   help="generated dataset folder (repeat for several); its train split "
                        "trains, its val split is the synthetic reference")
    s.add_argument("--real", required=True, metavar="FRAMES",
                   help="your real frames: a folder (or file) of photos and videos")
    s.add_argument("--real-labels", required=True, metavar="LABELS",
                   help="their labels: a COCO json file or a YOLO labels folder")
    s.add_argument("--map", action="append", default=[], metavar="GEN=REAL",
                   help="generated category GEN is real category REAL (repeatable; "
                        "default: categories of the same name, case-insensitive)")
    s.add_argument("--unlabelled", metavar="PATH", help="unlabelled real photos or videos to "
                   "re-estimate BatchNorm statistics on (default: the --real frames, their "
                   "labels unused)")
    s.add_argument("--unlabelled-max", type=int, default=200, metavar="N",
                   help="at most N of them, evenly spaced (default: %(default)s)")
    s.add_argument("--out", required=True, metavar="DIR", help="results folder")
    s.add_argument("--overwrite", action="store_true",
                   help="retrain even if OUT holds a training of other settings")
    s.add_argument("--score-threshold", type=float, default=0.5, metavar="S",
                   help="detections drawn in detections.jpg score at least S (default: "
                        "%(default)s)")
    native_training_flags(s, "training (default: the paper's schedule, as grid)", TRAIN_FLAGS)


def grid_from_args(args) -> GridSpec:
    """The preset with the flags' overrides (validated by GridSpec and TrainConfig)."""
    spec = preset(args.preset)
    train = {d: getattr(args, d) for d in TRAIN_FLAGS if getattr(args, d, None) is not None}
    if "train_seed" in train:
        train["seed"] = train.pop("train_seed")
    if args.hflip is not None:
        train["hflip"] = args.hflip
    grid = {k: getattr(args, k) for k in ("image_size", "size_scale", "seed")
            if getattr(args, k, None) is not None}
    field = {k: v for k, v in (("n", args.field_n), ("seed", args.field_seed))
             if v is not None}
    if field:
        grid["field"] = replace(spec.field, **field)
    if getattr(args, "real_train", None) is not None and 6 not in spec.tables:
        grid["tables"] = (*spec.tables, 6)
    return spec.with_overrides(train, **grid)


def _real_train(args):
    """Table 6's real training frames (``--real-train``), or None."""
    from .datasets import real_train
    pair = _coco_pair(args, "real_train", "real_train_images")
    return None if pair is None else real_train(*pair)


def _coco_pair(args, coco: str, images: str) -> tuple[str, str] | None:
    """(COCO file, its images' folder) of the flags ``coco`` and ``images`` (dests), None
    when neither is given; UserError when only one is."""
    a, b = getattr(args, coco), getattr(args, images)
    if (a is None) != (b is None):
        raise UserError(f"--{coco.replace('_', '-')} and --{images.replace('_', '-')} go "
                        f"together: the COCO file and the folder of its images")
    return None if a is None else (a, b)


def _test_set(args, grid: GridSpec, cache):
    from .datasets import field_test, real_test
    pair = _coco_pair(args, "test_coco", "test_images")
    if pair is not None:
        return real_test(*pair)
    return field_test(grid.field, grid.image_size, cache)


def _context(args, out: Path, train: bool = True):
    """The run's context from the parsed flags; ``train=False`` (datasets only) leaves the
    device unresolved (cpu), so a GPU job's ``--device`` also runs where there is none."""
    from . import require_torch
    from .datasets import CacheOptions
    from .runner import RunContext
    from .train import resolve_device
    torch, _ = require_torch()
    if getattr(args, "threads", None) is not None:
        if args.threads < 1:
            raise UserError(f"--threads {args.threads} is out of range: use 1 or more")
        torch.set_num_threads(args.threads)
    workers = getattr(args, "workers", 1)
    if workers < 1:
        raise UserError(f"--workers {workers} is out of range: use 1 or more")
    cache_dir = getattr(args, "cache", None)
    cache = CacheOptions(Path(cache_dir) if cache_dir else out / "datasets",
                         sprites_folder(getattr(args, "sprites", DEFAULT_SPRITES)), workers,
                         getattr(args, "progress", None))
    device = resolve_device(args.device) if train else "cpu"
    return RunContext(out, cache, device, getattr(args, "progress", None))


def _find_cell(grid: GridSpec, cell_id: str):
    for cell in grid.cells():
        if cell.id == cell_id:
            return cell
    raise UserError(f"--cell {cell_id!r} is not in preset {grid.name}; its cells: "
                    f"{', '.join(c.id for c in grid.cells())}")


def cmd_grid(args) -> int:
    from .report import write_report
    from .runner import check_real, run_grid
    grid = grid_from_args(args)
    if args.list:
        for table, label, cell in grid.rows():
            n = (f"{grid.images(cell.n)} real" if isinstance(cell, RealCell)
                 else str(sum(p.n for p in grid.parts(cell))))
            print(f"table {table.number}  {label:8s} {cell.id}  ({n} images)")
        return 0
    if not args.out:
        raise UserError("grid needs --out DIR, the results folder")
    out = Path(args.out)
    real = _real_train(args)
    if not args.datasets_only:
        check_real(grid, None, real)
    ctx = _context(args, out, train=not args.datasets_only)
    test = _test_set(args, grid, ctx.cache)
    start = time.perf_counter()
    if args.datasets_only:
        from .runner import ensure_cell_datasets
        for cell in grid.cells():
            ensure_cell_datasets(grid, cell, ctx.cache)
        print(f"grid {grid.name}: the datasets of {len(grid.cells())} cells and the test set "
              f"are in {ctx.cache.cache_dir} ({time.perf_counter() - start:.1f} s)")
        return 0
    print(f"grid {grid.name}: {len(grid.cells())} cells on {ctx.device}, test set: "
          f"{test.label}")
    run_grid(grid, test, ctx, overwrite=args.overwrite, real=real)
    written = write_report(out)
    print(f"done in {time.perf_counter() - start:.1f} s: {written['report']}, plots in "
          f"{out / 'plots'}")
    return 0


def cmd_train(args) -> int:
    from .runner import check_real, prepare_results, run_cell
    grid = grid_from_args(args)
    cell = _find_cell(grid, args.cell)
    out = Path(args.out)
    real = _real_train(args)
    check_real(grid, None, real)
    ctx = _context(args, out)
    test = _test_set(args, grid, ctx.cache)
    rows = [(t.number, label) for t, label, c in grid.rows() if c == cell]
    check_real(grid, test, real)
    prepare_results(grid, test, ctx, real=real)
    data = run_cell(cell, grid, test, ctx, rows, real=real)
    _print_metrics(data["cell"], data["test"], data["val"])
    return 0


def cmd_eval(args) -> int:
    from .datasets import FieldSpec, field_test, real_test
    from .evaluate import evaluate_detector
    from .runner import cell_path, checkpoint_path, read_cell, write_json
    from .train import TrainConfig, load_checkpoint, make_detector
    out = Path(args.results)
    meta_path = cell_path(out, args.cell)
    data = read_cell(meta_path)
    if data is None:
        raise UserError(f"--cell {args.cell}: no finished cell at {meta_path}")
    ctx = _context(args, out)
    size = int(data["config"]["image_size"])
    pair = _coco_pair(args, "test_coco", "test_images")
    if pair is not None:
        test = real_test(*pair)
    else:  # the field set the grid was scored on
        try:
            f = json.loads((out / "grid.json").read_text())["grid"]["field"]
        except (OSError, ValueError, KeyError):
            raise UserError(f"{out}: no readable grid.json to rebuild the field set from; "
                            f"give --test-coco and --test-images") from None
        test = field_test(FieldSpec(**{**f, "water": tuple(f["water"])}), size, ctx.cache)
    names = {f.name for f in fields(TrainConfig)}
    config = TrainConfig(**{k: v for k, v in data["config"]["train"].items() if k in names})
    ckpt = load_checkpoint(checkpoint_path(out, args.cell), data["train_key"])
    if ckpt is None or int(ckpt["iteration"]) < config.max_iter:
        raise UserError(f"--cell {args.cell}: its checkpoint is missing or unfinished; run "
                        f"grid or train first")
    model = make_detector(config, size, "none")
    model.load_state_dict(ckpt["model"])
    model.to(ctx.device)
    result = evaluate_detector(model, test, ctx.device)
    _print_metrics(args.cell, result, None)
    name = "".join(c if c.isalnum() else "_" for c in test.label)[:80]
    write_json(out / "eval" / f"{args.cell}--{name}.json",
               {"cell": args.cell, "train_key": data["train_key"], "device": ctx.device,
                **result})
    return 0


def cmd_report(args) -> int:
    from .report import write_report
    written = write_report(args.results)
    print(f"wrote {written['report']} and {len(written) - 1} plots")
    return 0


def _train_flags(args) -> dict:
    """The TrainConfig fields the training flags give (sim2real, fewshot)."""
    train = {d: getattr(args, d) for d in TRAIN_FLAGS if getattr(args, d, None) is not None}
    if "train_seed" in train:
        train["seed"] = train.pop("train_seed")
    if args.hflip is not None:
        train["hflip"] = args.hflip
    return train


def cmd_fewshot(args) -> int:
    return fewshot_command(args, _train_flags(args), _context(args, Path(args.out)).device)


def cmd_sim2real(args) -> int:
    from .sim2real import Sim2RealSpec, run_sim2real
    from .train import TrainConfig
    train = _train_flags(args)
    out = Path(args.out)
    ctx = _context(args, out)
    spec = Sim2RealSpec(tuple(map(Path, args.train)), Path(args.real), Path(args.real_labels),
                        out, tuple(args.map), Path(args.unlabelled) if args.unlabelled else
                        None, args.unlabelled_max, TrainConfig(**train), ctx.device,
                        args.progress, args.overwrite, args.score_threshold)
    r = run_sim2real(spec)
    for name, key in (("generated val", "synthetic_val"), ("real, as trained", "real_before"),
                      ("real, BatchNorm re-estimated", "real_after")):
        if r[key] is not None:
            m = r[key]["bands"]["all"]
            print(f"{name}: AP {m['AP']:.4f} AP50 {m['AP50']:.4f} AR100 {m['AR100']:.4f}")
    print(f"verdict: {r['verdict']['text']}")
    print(f"report: {out / 'report.md'}, picture: {out / 'detections.jpg'}")
    return 0


def _print_metrics(cell_id: str, test: dict, val: dict | None) -> None:
    m = test["metrics"]
    text = " ".join(f"{k} {v:.4f}" for k, v in m.items())
    print(f"{cell_id} on {test['test_set']}: {text}")
    if val is not None:
        print(f"{cell_id} on synthetic val: AP50 {val['metrics']['AP50']:.4f}")


COMMANDS = {"grid": cmd_grid, "train": cmd_train, "eval": cmd_eval, "report": cmd_report,
            "sim2real": cmd_sim2real, "fewshot": cmd_fewshot}


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    return COMMANDS[args.command](args)


if __name__ == "__main__":
    sys.exit(run_cli(main))
