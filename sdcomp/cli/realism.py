"""``python -m sdcomp.realism`` (``sdcomp realism``): the realism report of a generated
dataset, against the targets and, given them, the user's real frames
(:mod:`sdcomp.report.realism`).

    sdcomp realism DIR [--real FRAMES [--real-labels F|DIR] [--real-gsd M | --real-fov DEG]]
                       [--out DIR/realism] [--max-images 500] [--match-gsd] [--cnn]
    sdcomp realism DIR --objects [--real FRAMES --real-labels F|DIR] [--min-size 15]
                       [--folds 5] [--no-cnn]
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

from ..errors import run_cli
from ..report.realism.markdown import row_text
from ..report.realism.object_classifier import summary_lines
from ..report.realism.object_report import fmt, objects_report
from ..report.realism.objects import MIN_SIZE
from ..report.realism.patches import METRICS
from ..report.realism.report import MAX_IMAGES, realism_report
from ..util.log import add_verbosity_flags, setup_logging
from . import prog


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog=prog("realism"),
        description="Realism report of a generated dataset: per-patch statistics of empty "
                    "water (saturation, luminance, high-pass std, glint) with PASS/FAIL per "
                    "target, luminance power spectra, histograms, crops of objects and water "
                    "at one ground sampling distance and, with real frames, a real-vs-"
                    "synthetic patch classifier whose cross-validated accuracy is the realism "
                    "number (0.5 = indistinguishable).",
        epilog="Writes OUT/report.md, report.json, spectrum.png, histograms.png, crops.png. "
               "With --objects instead (only the object part): OUT/objects.md, objects.json "
               "and object_crops.png. Definitions: docs/realism.md.")
    p.add_argument("dataset", metavar="DIR", help="generated dataset folder (generate --out)")
    p.add_argument("--real", metavar="FRAMES", help="real frames: a folder (or file) of photos "
                   "and videos, or a folder with an images/ subfolder (default: none: "
                   "statistics against the targets only)")
    p.add_argument("--real-labels", metavar="LABELS", help="COCO json file or YOLO labels "
                   "folder of the real frames: boxes kept out of empty water; a COCO file's "
                   "meta (altitude, gimbal pitch) gives the GSD with --real-fov (default: "
                   "none: every patch counts as water)")
    p.add_argument("--real-gsd", metavar="M", type=float, help="metres per pixel of every "
                   "real frame (default: from the COCO meta and --real-fov, else unknown)")
    p.add_argument("--real-fov", metavar="DEG", type=float, help="diagonal field of view of "
                   "the real frames as stored, degrees: with the COCO meta it gives each "
                   "frame's GSD and horizon (default: unknown)")
    p.add_argument("--match-gsd", action="store_true", help="resample real frames of known "
                   "GSD to the generated set's median GSD before measuring (default: each "
                   "frame at its own resolution)")
    p.add_argument("--out", metavar="DIR", help="output folder (default: DIR/realism)")
    p.add_argument("--max-images", metavar="N", type=int, default=MAX_IMAGES,
                   help="at most N images of each set, a seeded random choice (default: "
                        "%(default)s)")
    p.add_argument("--seed", metavar="S", type=int, default=0, help="seed of the image "
                   "choice, patch subsampling and folds (default: %(default)s)")
    p.add_argument("--folds", metavar="K", type=int, default=5, help="cross-validation folds, "
                   "split by image (default: %(default)s)")
    p.add_argument("--cnn", action="store_true", help="also a tiny CNN classifier (needs "
                   "torch; about a minute more) (default: off)")
    p.add_argument("--exclude-clutter", action="store_true", help="also keep the unannotated "
                   "floating clutter (boats, buoys, logs, foam) out of empty water (default: "
                   "off: only annotated objects are)")
    p.add_argument("--objects", action="store_true", help="instead of the water report, "
                   "per-object appearance: per labelled box its contrast against the water "
                   "around it, shares of dark and bright pixels, height / width, saturation "
                   "and size (image px, px at 1920 wide, metres where the GSD is known), "
                   "summarised per category, generated vs real (--real needs --real-labels "
                   "then), and with --real the object realism classifier: per category the "
                   "cross-validated accuracy of a CNN (and of a logistic regression on hand "
                   "features) telling real crops of the boxes from generated ones (0.5 = "
                   "indistinguishable); --match-gsd, --cnn and --exclude-clutter do not "
                   "apply; writes objects.md, objects.json, object_crops.png and "
                   "object_classifier.png (default: off)")
    p.add_argument("--no-cnn", action="store_true", help="with --objects --real: only the "
                   "logistic regression, not the CNN (faster; default: the CNN too, where "
                   "torch is installed)")
    p.add_argument("--min-size", metavar="PX", type=float, default=MIN_SIZE, help="with "
                   "--objects: leave out boxes with sqrt(w h) below PX image pixels "
                   "(default: %(default)g)")
    add_verbosity_flags(p)
    return p


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    log = setup_logging(args.quiet, args.verbose)
    if args.objects:
        return _objects(args, log)
    r = realism_report(args.dataset, args.real, args.out, args.real_labels, args.real_gsd,
                       args.real_fov, args.max_images, args.seed, args.folds, args.cnn,
                       args.exclude_clutter, args.match_gsd, log=log.debug)
    gs = r["summary"]["generated"]
    log.info("generated: " + "; ".join(f"{m} {row_text(gs[m])}" for m in METRICS))
    if r["summary"]["real"]:
        rs = r["summary"]["real"]
        log.info("real:      " + "; ".join(f"{m} {row_text(rs[m])}" for m in METRICS))
    c = r["classifier"]
    if c and "accuracy" in c:
        lo, hi = c["ci95_images"]
        log.info(f"real-vs-synthetic classifier accuracy {c['accuracy']:.3f} (image CI "
                 f"{lo:.3f}-{hi:.3f}; 0.5 = indistinguishable)")
    for t in r["targets"]:
        if t["ok"] is not None:
            log.info(f"{'PASS' if t['ok'] else 'FAIL'}  {t['target']}: {t['value']:.4g}")
    judged = [t for t in r["targets"] if t["ok"] is not None]
    out = Path(args.out) if args.out else Path(args.dataset) / "realism"
    log.info(f"targets: {sum(t['ok'] for t in judged)}/{len(judged)} pass; report: "
             f"{out / 'report.md'}")
    return 0


def _objects(args, log) -> int:
    """``--objects``: the per-object report, a line per category on the terminal."""
    r = objects_report(args.dataset, args.real, args.out, args.real_labels, args.real_gsd,
                       args.real_fov, args.max_images, args.seed, args.min_size,
                       folds=args.folds, cnn=not args.no_cnn, log=log.debug)
    for kind in ("generated", "real"):
        for cat, row in (r["categories"][kind] or {}).items():
            log.info(f"{kind} {cat} ({row['count']}): " + "; ".join(
                f"{m} {fmt(m, row[m])}" for m in ("contrast", "dark_share", "bright_share",
                                                   "aspect", "size_px", "size_m")))
    if r.get("classifier"):
        for line in summary_lines(r["classifier"]["categories"]):
            log.info("object classifier: " + line)
    out = Path(args.out) if args.out else Path(args.dataset) / "realism"
    log.info(f"report: {out / 'objects.md'}")
    return 0


if __name__ == "__main__":
    sys.exit(run_cli(main))
