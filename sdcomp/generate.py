"""Command line of the generator: ``python -m sdcomp.generate --n 2500 --out dataset``.

Every field of :class:`~sdcomp.config.GeneratorConfig` is a flag; ``--preset`` and
``--config FILE`` (TOML, keys = field names) set many at once (flags win over the file, the
file over the preset). See :mod:`sdcomp.writer` for the output folder.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from collections.abc import Sequence
from dataclasses import fields
from pathlib import Path

from .cli import prog
from .config import CLUTTER_KINDS, PRESETS, GeneratorConfig, ObjectSpec, load_toml, preset
from .errors import UserError, run_cli
from .generator import DEFAULT_SPRITES
from .log import add_verbosity_flags, setup_logging
from .shards import parse_shard
from .writer import RunOptions, run

# field: (metavar, help). Defaults are appended from GeneratorConfig.
HELP: dict[str, tuple[str, str]] = {
    "n": ("N", "number of images"),
    "seed": ("S", "random seed: image i depends only on (seed, i, options)"),
    "val_fraction": ("F", "fraction of images in the val split (exact per 100 images)"),
    "image_format": ("jpg|png", "image file format"),
    "jpeg_quality": ("Q", "JPEG quality, 1-100 (a value, range lo-hi or list)"),
    "min_visible_px": ("PX", "objects with fewer visible pixels are not annotated "
                             "(counted as dropped)"),
    "amodal": ("", "also store amodal masks (the whole projected object, ignoring "
                   "occlusion and water)"),
    "format": ("coco,yolo", "annotation formats: coco (JSON), yolo (Ultralytics label files, "
                            "data.yaml) or both; never changes the images"),
    "yolo_seg": ("", "YOLO labels are polygons traced from the masks instead of boxes"),
    "camera": ("NAME", "drone camera: mavic2pro (77 deg diagonal FOV), phantom4pro "
                       "(84 deg), or custom with --fov and --sensor-px"),
    "fov": ("DEG", "diagonal field of view, degrees (overrides the camera's)"),
    "sensor_px": ("W,H", "sensor resolution, pixels (sets the aspect the FOV refers to)"),
    "width": ("PX", "output image width, pixels"),
    "height": ("PX", "output image height, pixels"),
    "altitude": ("M", "camera altitude, metres: value, range lo-hi or list a,b,c"),
    "pitch": ("DEG", "gimbal pitch below the horizon, degrees: 90 straight down, down to 15"),
    "heading": ("DEG", "camera heading, degrees"),
    "water": ("COLOR", "water colours, one per image at random: brown, blue, green or R,G,B "
                       "(several allowed)"),
    "turbidity": ("T", "turbidity 0 (clear, 0.05/m) to 1 (murky, 5/m attenuation)"),
    "wind": ("M/S", "wind speed, m/s: wave roughness, glint spread, whitecaps above 5"),
    "floor_depth": ("M", "sea-floor depth, metres (seen through clear water)"),
    "whitecaps": ("X", "whitecap amount at a given wind (0 = none)"),
    "backgrounds": ("DIR", "composite onto your own empty-water photos in DIR instead of "
                           "procedural water"),
    "sun_elevation": ("DEG", "sun elevation above the horizon, degrees"),
    "sun_azimuth": ("DEG", "sun azimuth, degrees"),
    "ambient": ("L", "ambient sky light (linear, sun = 2.2)"),
    "shadows": ("", "draw object shadows on the water and sea floor"),
    "objects": ("MESH", "object of interest: bluerov2, bluerov2-heavy or a mesh file "
                        "(repeat for several; each its own COCO category)"),
    "count": ("K", "objects of interest per image (0 allowed: empty images)"),
    "draft": ("M", "how far objects sink below their natural waterline, metres "
                   "(large = fully submerged)"),
    "tilt": ("DEG", "largest wave tilt (roll and pitch) of objects, degrees"),
    "clutter": ("K", "mean number of floating clutter objects per image (0 = none)"),
    "clutter_kinds": ("KIND", f"clutter kinds to use: {', '.join(CLUTTER_KINDS)}"),
    "rocks": ("F", "fraction of the sea floor covered by rocks and debris (0 = none)"),
    "shore": ("P", "probability of a shoreline with land at a frame edge"),
    "hills": ("P", "probability of hills on the horizon when the horizon is in view"),
    "exposure": ("STOPS", "exposure jitter, stops"),
    "white_balance": ("A", "white-balance jitter: red and blue gains within 1 +- A"),
    "noise": ("SIGMA", "sensor noise standard deviation, 8-bit levels"),
    "motion_blur": ("P", "probability of motion blur"),
    "defocus_blur": ("P", "probability of defocus blur"),
    "vignetting": ("V", "brightness fall-off at the image corners (fraction)"),
}


class _ObjectAction(argparse.Action):
    """``--object MESH`` appends an object; ``--category NAME`` names the last one."""

    def __call__(self, parser, namespace, value, option_string=None):
        objs = list(getattr(namespace, "objects", None) or [])
        if option_string == "--category":
            if not objs:
                raise UserError("--category must follow the --object it names")
            objs[-1] = ObjectSpec(objs[-1].mesh, value)
        else:
            objs.append(ObjectSpec(value))
        namespace.objects = objs


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog=prog("generate"),
        description="Generate a synthetic drone-over-water detection dataset: images, "
                    "16-bit instance masks, COCO train/val annotations.",
        epilog="Random options take a value (30), a range (10-50, uniform) or a list "
               "(10,20,30). Presets: " + ", ".join(PRESETS) + ".")
    run_g = p.add_argument_group("run")
    run_g.add_argument("--out", default="dataset", metavar="DIR",
                       help="output folder (default: %(default)s)")
    run_g.add_argument("--workers", type=int, default=None, metavar="N",
                       help=f"worker processes (default: all cores, {_cores()} here)")
    run_g.add_argument("--resume", action="store_true",
                       help="continue an interrupted run in --out (same options; default: off)")
    run_g.add_argument("--overwrite", action="store_true",
                       help="replace the dataset in a non-empty --out (default: off)")
    run_g.add_argument("--preset", metavar="NAME",
                       help="named settings: " + ", ".join(PRESETS) + " (default: none)")
    run_g.add_argument("--config", metavar="FILE", help="TOML file of options (keys as the "
                       "flags, with _ or -; default: none)")
    run_g.add_argument("--sprites", default=DEFAULT_SPRITES, metavar="DIR",
                       help="sprite atlas folder, built there if missing (default: %(default)s)")
    run_g.add_argument("--progress", action=argparse.BooleanOptionalAction, default=None,
                       help="progress line (default: only on a terminal)")
    run_g.add_argument("--shard", metavar="K/N", default=None,
                       help="render only shard K (0 to N-1) of N of the images, e.g. one task "
                            "of a job array; join the shard folders with `python -m "
                            "sdcomp.merge` (default: all images)")
    run_g.add_argument("--engine", choices=("local", "dask"), default="local",
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
    defaults = GeneratorConfig()
    group = p.add_argument_group("dataset options")
    for f in fields(GeneratorConfig):
        metavar, text = HELP[f.name]
        default = getattr(defaults, f.name)
        flag = "--" + f.name.replace("_", "-")
        if f.name == "objects":
            d = " ".join(o.mesh for o in default)
            group.add_argument("--object", dest="objects", action=_ObjectAction,
                               default=None, metavar=metavar, help=f"{text} (default: {d})")
            group.add_argument("--category", dest="objects", action=_ObjectAction,
                               metavar="NAME", help="COCO category of the preceding --object "
                               "(default: the mesh name)")
            continue
        if isinstance(default, bool):
            group.add_argument(flag, dest=f.name, action=argparse.BooleanOptionalAction,
                               default=None, help=f"{text} (default: {default})")
            continue
        if isinstance(default, tuple) and f.name != "sensor_px":
            group.add_argument(flag, dest=f.name, nargs="+", default=None, metavar=metavar,
                               help=f"{text} (default: {' '.join(map(str, default))})")
            continue
        shown = default if default is not None else "none"
        group.add_argument(flag, dest=f.name, default=None, metavar=metavar or None,
                           help=f"{text} (default: {shown})")
    return p


def _cores() -> int:
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
    if args.size is not None:
        if args.size < 1:
            raise UserError(f"--size {args.size} is out of range: use 1 to 32000 pixels")
        given.setdefault("width", args.size)
        given.setdefault("height", args.size)
    return GeneratorConfig.from_mapping(given, config, "flags")


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    log = setup_logging(args.quiet, args.verbose)
    config = config_from_args(args)
    if args.dump_config:
        sys.stdout.write(config.to_toml())
        return 0
    if args.quiet and args.progress is None:
        args.progress = False
    log.debug("config:\n%s", config.to_toml())
    workers = args.workers if args.workers is not None else _cores()
    if workers < 1:
        raise UserError(f"--workers {workers} is out of range: use 1 or more")
    shard = parse_shard(args.shard) if args.shard is not None else None
    options = RunOptions(Path(args.out), workers, args.resume, args.overwrite, args.progress,
                         Path(args.sprites), shard)
    start = time.perf_counter()
    if args.engine == "dask":
        from .engine_dask import run_dask  # dask is optional: imported only here

        counts = run_dask(config, options, args.scheduler)
    elif args.scheduler is not None:
        raise UserError(f"--scheduler {args.scheduler} is for --engine dask: add --engine "
                        f"dask, or drop --scheduler")
    else:
        counts = run(config, options)
    secs = time.perf_counter() - start
    log.info(f"wrote {counts['images']} images ({counts['train']} train, {counts['val']} "
             f"val), {counts['annotations']} annotations, {counts['objects_dropped']} objects "
             f"too hidden to annotate, to {options.out} in {secs:.1f} s")
    return 0


if __name__ == "__main__":
    sys.exit(run_cli(main))
