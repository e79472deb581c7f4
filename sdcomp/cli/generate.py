"""``python -m sdcomp.generate`` (``sdcomp generate``): the generator's command line.

Every field of :class:`~sdcomp.scene.config.GeneratorConfig` is a flag; ``--preset`` and
``--config FILE`` (TOML, keys = field names) set many at once (flags win over the file, the
file over the preset). See :mod:`sdcomp.io.layout` for the output folder.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from collections.abc import Sequence
from dataclasses import fields
from pathlib import Path

from ..atlas.cache import sprites_folder
from ..errors import UserError, run_cli
from ..fitting.config_file import size_warning
from ..pipeline import DEFAULT_SPRITES
from ..run.engines import ENGINES
from ..run.options import RunOptions
from ..run.shards import parse_shard
from ..scene.config import RETIRED, GeneratorConfig, ObjectSpec, load_toml
from ..scene.presets import PRESETS, preset
from ..scene.settings import setting_of
from ..util.log import add_verbosity_flags, setup_logging
from . import Parser, prog


class _ObjectAction(argparse.Action):
    """``--object MESH`` appends an object; ``--category NAME`` names the last one and
    ``--weight W`` sets how often it is drawn."""

    def __call__(self, parser, namespace, value, option_string=None):
        objs = list(getattr(namespace, "objects", None) or [])
        if option_string in ("--category", "--weight"):
            if not objs:
                raise UserError(f"{option_string} must follow the --object it is for")
            last = objs[-1]
            objs[-1] = (ObjectSpec(last.mesh, value, last.weight) if option_string ==
                        "--category" else ObjectSpec(last.mesh, last.category, value))
        else:
            objs.append(ObjectSpec(value))
        namespace.objects = objs


def build_parser() -> argparse.ArgumentParser:
    """The generator's parser: how to run (:func:`add_run_options`), then a flag per
    config field (:func:`add_dataset_options`)."""
    p = Parser(
        prog=prog("generate"),
        description="Generate a synthetic drone-over-water detection dataset: images, "
                    "16-bit instance masks, COCO train/val annotations.",
        epilog="Random options take a value (30), a range (10-50, uniform) or a list "
               "(10,20,30). Presets: " + ", ".join(PRESETS) + ".")
    add_run_options(p.add_argument_group("run"))
    add_dataset_options(p.add_argument_group("dataset options"))
    return p


def add_run_options(run_g: argparse._ArgumentGroup) -> None:
    """Options that say how to run, never what the dataset holds."""
    run_g.add_argument("--out", default="dataset", metavar="DIR",
                       help="output folder (default: %(default)s)")
    run_g.add_argument("--workers", type=int, default=None, metavar="N",
                       help=f"worker processes (default: all cores, {cores()} here)")
    run_g.add_argument("--resume", action="store_true",
                       help="continue an interrupted run in --out (same options; default: off)")
    run_g.add_argument("--overwrite", action="store_true",
                       help="replace the dataset in a non-empty --out (default: off)")
    run_g.add_argument("--preset", metavar="NAME",
                       help="named settings: " + ", ".join(PRESETS) + " (default: none)")
    run_g.add_argument("--config", metavar="FILE", help="TOML file of options (keys as the "
                       "flags, with _ or -; default: none)")
    run_g.add_argument("--sprites", default=DEFAULT_SPRITES, metavar="DIR",
                       help="sprite atlas folder, built there if missing (default: "
                       "$SDCOMP_SPRITES, else the user's cache folder)")
    run_g.add_argument("--progress", action=argparse.BooleanOptionalAction, default=None,
                       help="progress line (default: only on a terminal)")
    run_g.add_argument("--shard", metavar="K/N", default=None,
                       help="render only shard K (0 to N-1) of N of the images, e.g. one task "
                            "of a job array; join the shard folders with `python -m "
                            "sdcomp.merge` (default: all images)")
    run_g.add_argument("--engine", choices=tuple(ENGINES), default="local",
                       help="local: worker processes on this machine; dask: shards as tasks "
                            "on a Dask cluster, needs `pip install 'sdcomp[dask]'` "
                            "(default: %(default)s)")
    run_g.add_argument("--scheduler", metavar="ADDRESS", default=None,
                       help="Dask scheduler of --engine dask, e.g. tcp://head:8786 (default: "
                            "a local cluster of --workers processes)")
    run_g.add_argument("--dump-config", action="store_true",
                       help="print the full resolved config as TOML (for --config) and exit, "
                            "writing nothing (default: off)")
    add_verbosity_flags(run_g)
    run_g.add_argument("--size", type=int, metavar="PX",
                       help="square output size, sets --width and --height (default: 416)")


def add_dataset_options(group: argparse._ArgumentGroup) -> None:
    """A flag per :class:`GeneratorConfig` field, with its metavar, help and default from
    the field's declaration (booleans get --no-..., lists take several values)."""
    defaults = GeneratorConfig()
    for f in fields(GeneratorConfig):
        spec = setting_of(f)
        metavar, text = spec.metavar, spec.help
        default = getattr(defaults, f.name)
        flag = "--" + f.name.replace("_", "-")
        if f.name == "objects":
            d = " ".join(o.mesh for o in default)
            group.add_argument("--object", dest="objects", action=_ObjectAction,
                               default=None, metavar=metavar, help=f"{text} (default: {d})")
            group.add_argument("--category", dest="objects", action=_ObjectAction,
                               metavar="NAME", help="COCO category of the preceding --object "
                               "(default: the mesh name)")
            group.add_argument("--weight", dest="objects", action=_ObjectAction,
                               metavar="W", help="how often the preceding --object is drawn, "
                               "relative to the other objects' weights (default: 1)")
        elif isinstance(default, bool):
            group.add_argument(flag, dest=f.name, action=argparse.BooleanOptionalAction,
                               default=None, help=f"{text} (default: {default})")
        elif isinstance(default, tuple) and f.name != "sensor_px":
            group.add_argument(flag, dest=f.name, nargs="+", default=None, metavar=metavar,
                               help=f"{text} (default: {' '.join(map(str, default)) or 'none'})")
        else:
            shown = default if default is not None else "none"
            group.add_argument(flag, dest=f.name, default=None, metavar=metavar or None,
                               help=f"{text} (default: {shown})")
    for name in RETIRED:  # earlier versions' flags: accepted with a warning, not listed
        group.add_argument("--" + name.replace("_", "-"), dest="retired_" + name,
                           default=None, help=argparse.SUPPRESS)


def cores() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:
        return os.cpu_count() or 1


def config_from_args(args: argparse.Namespace) -> GeneratorConfig:
    """The config of parsed arguments: defaults < preset < config file < flags."""
    config = GeneratorConfig()
    if args.preset:
        config = GeneratorConfig.from_mapping(preset(args.preset), config, "--preset")
    if args.config:
        config = GeneratorConfig.from_mapping(load_toml(args.config), config,
                                              f"--config {args.config}")
    given = {f.name: getattr(args, f.name) for f in fields(GeneratorConfig)
             if getattr(args, f.name, None) is not None}
    given.update({name: v for name in RETIRED
                  if (v := getattr(args, "retired_" + name, None)) is not None})
    if args.size is not None:
        if args.size < 1:
            raise UserError(f"--size {args.size} is out of range: use 1 to 32000 pixels")
        given.setdefault("width", args.size)
        given.setdefault("height", args.size)
    if given.get("camera", "custom") != "custom":
        # a camera named by flag replaces a preset's (or config file's) custom one: its
        # field of view and sensor, unless given too
        given.setdefault("fov", None)
        given.setdefault("sensor_px", None)
    return GeneratorConfig.from_mapping(given, config, "flags")


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    log = setup_logging(args.quiet, args.verbose)
    config = config_from_args(args)
    if args.config and (line := size_warning(args.config, config.width, config.height)):
        log.warning(line)
    if args.dump_config:
        sys.stdout.write(config.to_toml())
        return 0
    if args.quiet and args.progress is None:
        args.progress = False
    log.debug("config:\n%s", config.to_toml())
    options = run_options(args)
    start = time.perf_counter()
    counts = ENGINES[args.engine](config, options, args.scheduler)
    secs = time.perf_counter() - start
    log.info(f"wrote {counts['images']} images ({counts['train']} train, {counts['val']} "
             f"val), {counts['annotations']} objects labelled ({counts['objects_truncated']} "
             f"truncated by the frame's edge), {counts['objects_ignored']} ignored (too small "
             f"to label: ignore regions), {counts['objects_skipped']} skipped, "
             f"{counts['objects_dropped']} not visible, to {options.out} in {secs:.1f} s")
    warning = dropped_warning(counts, config)
    if warning:
        log.warning(warning)
    return 0


def run_options(args: argparse.Namespace) -> RunOptions:
    """The :class:`RunOptions` of parsed run options (:func:`add_run_options`): workers
    (default: all cores), shard, folders; UserError for a bad --workers, or --scheduler
    without --engine dask."""
    workers = args.workers if args.workers is not None else cores()
    if workers < 1:
        raise UserError(f"--workers {workers} is out of range: use 1 or more")
    shard = parse_shard(args.shard) if args.shard is not None else None
    if args.scheduler is not None and args.engine != "dask":
        raise UserError(f"--scheduler {args.scheduler} is for --engine dask: add --engine "
                        f"dask, or drop --scheduler")
    return RunOptions(Path(args.out), workers, args.resume, args.overwrite, args.progress,
                      sprites_folder(args.sprites), shard)


def dropped_warning(counts: dict, config: GeneratorConfig) -> str | None:
    """A warning when no object, or under half of those placed, could be labelled (not
    visible, or fewer than --min-visible-px visible pixels: too far, too small an image, or
    hidden)."""
    kept = counts["annotations"]
    dropped = sum(counts.get(f"objects_{k}", 0) for k in ("dropped", "ignored", "skipped"))
    if dropped == 0 or dropped < kept:
        return None
    share = "none" if kept == 0 else f"only {kept}"
    return (f"{share} of the {kept + dropped} objects placed could be labelled: the others had "
            f"fewer than --min-visible-px {config.min_visible_px} visible pixels at --altitude "
            f"{config.altitude.to_json()} and {config.width}x{config.height} px; lower "
            f"--altitude, raise --size, or lower --min-visible-px")


if __name__ == "__main__":
    sys.exit(run_cli(main))
