"""``python -m sdcomp.video`` (``sdcomp video``): sequences of a drone flying over moving
water with tracked objects, as MOTChallenge sequences and COCO-video ground truth.

Every generator flag means what it means for stills, drawn once per sequence unless it is
naturally per frame; the video flags (:class:`~sdcomp.scene.video.VideoConfig`) say how many
sequences, how long, and how the drone flies. ``--config FILE`` takes generator and video
keys in one table. See :mod:`sdcomp.io.clip_layout` for the output folder.
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Sequence

from ..errors import UserError, run_cli
from ..fitting.config_file import size_warning
from ..run.engines import VIDEO_ENGINES
from ..scene.config import GeneratorConfig, load_toml
from ..scene.params import Param
from ..scene.settings import setting_of, toml_value
from ..scene.video import VideoConfig
from ..util.log import setup_logging
from . import Parser, prog
from .generate import add_dataset_options, add_run_options, config_from_args, run_options

VIDEO_KEYS = tuple(f.name for f in VideoConfig.video_fields())


def build_parser() -> argparse.ArgumentParser:
    """The video parser: how to run, the video options, then the generator's options."""
    p = Parser(prog=prog("video"),
               description="Generate drone video sequences over moving water with tracked "
                           "objects: frames (MOTChallenge layout), 16-bit masks of track "
                           "ids, gt/gt.txt, seqinfo.ini, COCO-video JSON, flight metadata.",
               epilog="Random options take a value (30), a range (10-50, uniform) or a list "
                      "(10,20,30); per-image options are drawn once per sequence.")
    add_run_options(p.add_argument_group("run"))
    p.set_defaults(out="clips")
    group = p.add_argument_group("video options")
    defaults = VideoConfig()
    for f in VideoConfig.video_fields():
        spec = setting_of(f)
        default = getattr(defaults, f.name)
        flag = "--" + f.name.replace("_", "-")
        if isinstance(default, bool):
            group.add_argument(flag, dest=f.name, action=argparse.BooleanOptionalAction,
                               default=None, help=f"{spec.help} (default: {default})")
        elif isinstance(default, tuple):
            group.add_argument(flag, dest=f.name, nargs="+", default=None,
                               metavar=spec.metavar, help=f"{spec.help} (default: all)")
        else:
            shown = default.to_json() if isinstance(default, Param) else default
            group.add_argument(flag, dest=f.name, default=None, metavar=spec.metavar,
                               help=f"{spec.help} (default: {shown})")
    add_dataset_options(p.add_argument_group("image options (as for sdcomp generate)"))
    for action in p._actions:  # a video's size is --sequences x --frames, not --n
        if "--n" in action.option_strings:
            action.help = argparse.SUPPRESS
    return p


def video_from_args(args: argparse.Namespace) -> VideoConfig:
    """The video config of parsed arguments: defaults < config file < flags (the
    generator's part as :func:`config_from_args` reads it)."""
    table: dict = load_toml(args.config) if args.config else {}
    video_table = {k.replace("-", "_"): v for k, v in table.items()
                   if k.replace("-", "_") in VIDEO_KEYS}
    config_file = args.config
    if video_table:  # the generator reads the rest of the file
        rest = {k: v for k, v in table.items() if k.replace("-", "_") not in VIDEO_KEYS}
        args.config = None
        base = GeneratorConfig.from_mapping(rest, GeneratorConfig(), f"--config {config_file}")
        generator = _with_base(args, base)
    else:
        generator = config_from_args(args)
    given = {k: getattr(args, k) for k in VIDEO_KEYS if getattr(args, k, None) is not None}
    values = {**video_table, **given}
    try:
        return VideoConfig(generator, **values)
    except TypeError as e:
        raise UserError(f"--config {config_file}: {e}") from None


def _with_base(args: argparse.Namespace, base: GeneratorConfig) -> GeneratorConfig:
    """The generator config of ``args`` over ``base`` (a config file's, read here)."""
    config = config_from_args(args)
    defaults = GeneratorConfig().to_dict()
    flags = {k: v for k, v in config.to_dict().items() if v != defaults[k]}
    return GeneratorConfig.from_mapping(flags, base, "flags")


def dump(video: VideoConfig) -> str:
    """The whole video config as one TOML table (generator and video keys)."""
    lines = ["# sdcomp video config: every field, resolved",
             "# reproduce the run with: sdcomp video --config THIS_FILE --out DIR"]
    for key, value in video.generator.to_dict().items():
        if value is not None:
            lines.append(f"{key} = {toml_value(value)}")
    for key, value in video.to_dict().items():
        if key != "generator":
            lines.append(f"{key} = {toml_value(value)}")
    return "\n".join(lines) + "\n"


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    log = setup_logging(args.quiet, args.verbose)
    video = video_from_args(args)
    g = video.generator
    if args.config and (line := size_warning(args.config, g.width, g.height)):
        log.warning(line)
    if args.dump_config:
        sys.stdout.write(dump(video))
        return 0
    if args.quiet and args.progress is None:
        args.progress = False
    options = run_options(args)
    start = time.perf_counter()
    counts = VIDEO_ENGINES[args.engine](video, options, args.scheduler)
    secs = time.perf_counter() - start
    log.info(f"wrote {counts['sequences']} sequences, {counts['frames']} frames, "
             f"{counts['annotations']} boxes of {counts['tracks']} tracks to {options.out} "
             f"in {secs:.1f} s ({counts['frames'] / max(secs, 1e-9):.1f} frames/s)")
    return 0


if __name__ == "__main__":
    sys.exit(run_cli(main))
