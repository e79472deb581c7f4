"""``python -m sdcomp.fitting`` (``sdcomp fit``): the generator settings that make generated
images look like the user's own unlabelled footage (:mod:`sdcomp.fitting`).

    sdcomp fit FRAMES [--out fitted.toml] [--labels COCO|YOLO] [--altitude M] [--pitch DEG]
                      [--fov DEG] [--size PX] [--max-frames 200] [--renders 16] [--passes 2]
                      [--sprites DIR] [--report DIR]
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path

from ..errors import UserError, run_cli
from ..fitting.api import fit_footage
from ..fitting.config_file import HEADER, config_text, write_config
from ..fitting.report import write_report
from ..fitting.search import CANDIDATES
from ..pipeline import DEFAULT_SPRITES
from ..render.camera.grade import save_grade
from ..scene.presets import PRESETS
from ..util.log import add_verbosity_flags, setup_logging
from . import Parser, prog


def build_parser() -> argparse.ArgumentParser:
    p = Parser(
        prog=prog("fit"),
        description="Fit the generator's scene to your footage: measure the frames' water "
                    "statistics (colour, brightness, texture, glitter) and the camera's "
                    "(noise, sharpness, JPEG blockiness, vignetting), then choose water "
                    "types and turbidity (by inverting the water colour), sky, sun "
                    "elevation, wind, the camera look, recording, JPEG quality and blur (by "
                    "a coordinate search on small rendered frames) so that generated images "
                    "match them. Writes a commented config for `sdcomp generate --config` "
                    "and `sdcomp video --config`, and a report.",
        epilog="Writes OUT (the config), with --grade OUT's name + .grade.json, and "
               "beside them, fit_report.md, fit_report.json and fit_crops.png (or into "
               "--report DIR). Runs in a few minutes on 2 cores for 50-200 frames. Recipe "
               "and figures: docs/fit.md.")
    p.add_argument("frames", metavar="FRAMES", help="your footage: a folder (or file) of "
                   "photos and videos (every video frame is a candidate)")
    p.add_argument("--out", metavar="FILE", default="fitted.toml", help="the config to write "
                   "(default: %(default)s)")
    p.add_argument("--report", metavar="DIR", help="folder of the report (default: the "
                   "config's folder)")
    p.add_argument("--labels", metavar="LABELS", help="COCO json file or YOLO labels folder "
                   "of the frames: labelled objects are kept out of the water statistics; "
                   "a COCO file's SeaDronesSee meta (height_above_takeoff(meter), "
                   "gimbal_pitch(degrees)) gives the geometry (default: none)")
    p.add_argument("--altitude", metavar="M", type=float, help="camera altitude of the "
                   "footage, metres (default: from the labels' meta, else DJI flight logs: "
                   "a photo's XMP, a video's SRT file beside it; else not fitted)")
    p.add_argument("--pitch", metavar="DEG", type=float, help="gimbal pitch below the "
                   "horizon, degrees, 90 = straight down (default: from the labels' meta, "
                   "else DJI flight logs (XMP, SRT), else not fitted)")
    p.add_argument("--fov", metavar="DEG", type=float, help="diagonal field of view of the "
                   "frames as stored, degrees (e.g. 72.8 for a Mavic 2 Pro's 4K video): "
                   "with a known pitch, the sky of oblique frames is kept out of the water "
                   "statistics (default: a photo's EXIF 35 mm focal length, else "
                   "unknown: sky counts as water)")
    p.add_argument("--size", metavar="PX", type=int, help="long side of the frames as "
                   "measured and generated, pixels (default: the frames' own, at most 512)")
    p.add_argument("--max-frames", metavar="N", type=int, default=200, help="at most N "
                   "frames, a seeded random choice")
    p.add_argument("--renders", metavar="N", type=int, default=16, help="frames rendered per "
                   "candidate setting (more: slower, less noisy)")
    p.add_argument("--passes", metavar="N", type=int, default=2, help="rounds of the "
                   "coordinate search")
    p.add_argument("--search", metavar="GROUPS", default=",".join(CANDIDATES),
                   help="settings searched, comma-separated, in order (default: all: "
                        "%(default)s)")
    p.add_argument("--sprites", metavar="DIR", default=DEFAULT_SPRITES, help="sprite atlas "
                   "folder, built there when missing (default: $SDCOMP_SPRITES, else the "
                   "user's cache folder)")
    p.add_argument("--seed", metavar="S", type=int, default=0, help="seed of the frame choice "
                   "and the rendered frames")
    p.add_argument("--preset", metavar="NAME", help="fit under this generate preset's scene "
                   "(its altitudes, pitches and camera; the objects do not matter), to "
                   f"generate with `--preset NAME --config OUT` ({', '.join(PRESETS)}; "
                   "default: none, the generator's defaults)")
    p.add_argument("--grade", action=argparse.BooleanOptionalAction, default=False,
                   help="also fit the site grade (the camera's last stage: the water's "
                        "colour and detail mapped to the footage's, chosen by the realism "
                        "classifier), written beside the config as OUT's name + .grade.json "
                        "and named in it (default: off: on the real frames measured so far it "
                        "lowers the classifier at the fit but not on the generated set, "
                        "docs/fit.md; none when no grade helps)")
    add_verbosity_flags(p)
    return p


def _check(args: argparse.Namespace) -> tuple[str, ...]:
    """The searched groups; UserError for a bad option value."""
    groups = tuple(g.strip() for g in args.search.split(",") if g.strip())
    bad = [g for g in groups if g not in CANDIDATES]
    if bad:
        raise UserError(f"--search {bad[0]!r} is unknown; use some of {', '.join(CANDIDATES)}")
    if not 1 <= args.renders <= 1000:
        raise UserError(f"--renders {args.renders} is out of range: use 1 to 1000")
    if not 0 <= args.passes <= 10:
        raise UserError(f"--passes {args.passes} is out of range: use 0 to 10")
    if not Path(args.frames).exists():
        raise UserError(f"{args.frames}: no such file or folder")
    if Path(args.out).suffix.lower() != ".toml":
        raise UserError(f"--out {args.out}: the config must be a .toml file")
    return groups


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    log = setup_logging(args.quiet, args.verbose)
    groups = _check(args)
    result = fit_footage(args.frames, args.labels, args.altitude, args.pitch, args.size,
                         args.max_frames, args.renders, args.sprites, groups, args.passes,
                         args.seed, log=log.info, fov=args.fov, grade=args.grade,
                         preset_name=args.preset)
    fitted = "altitude" if "not fitted" not in result.geometry else ""
    out = Path(args.out)
    chosen = result.config
    if result.grade is not None and not result.grade.identity:
        grade_file = out.with_name(out.stem + ".grade.json")
        grade_file.parent.mkdir(parents=True, exist_ok=True)
        save_grade(result.grade, grade_file)
        chosen = replace(chosen, grade=grade_file.name)
    header = [f"{HEADER}{args.frames}: {result.footage.frames} frames, "
              f"{result.search.seconds:.0f} s", result.geometry,
              f"use: sdcomp generate {f'--preset {args.preset} ' if args.preset else ''}"
              f"--config THIS_FILE --out DIR (flags after it override it)"]
    config = write_config(args.out, config_text(chosen, header, bool(fitted)))
    md = write_report(result, args.report or out.parent, out.name if args.report is None
                      else str(out))
    log.info(f"config: {out} ({config.width} x {config.height} px, water "
             f"{','.join(config.water)}); report: {md}")
    return 0


if __name__ == "__main__":
    sys.exit(run_cli(main))
