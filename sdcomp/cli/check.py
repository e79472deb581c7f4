"""``sdcomp check`` (``python -m sdcomp.check``): check a generated dataset's files against
each other (:mod:`sdcomp.report.check`); one line per problem, a summary, exit 1 on any.

    sdcomp check DIR
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence

from ..errors import UserError, run_cli
from ..report.check import check_folder
from . import Parser, prog


def build_parser() -> argparse.ArgumentParser:
    p = Parser(
        prog=prog("check"),
        description="Check a dataset written by sdcomp generate or sdcomp video: image "
                    "and mask sizes, boxes and areas against the masks, image ids against "
                    "file names, ignore regions against the ignore masks, every object "
                    "placed labelled, ignored or not visible, YOLO lines against COCO, "
                    "splits disjoint, MOTChallenge gt.txt against COCO-video. Prints one "
                    "line per problem and a summary; exit status 1 when there is any "
                    "problem.")
    p.add_argument("folder", metavar="DIR", help="dataset folder (the --out of sdcomp "
                   "generate or sdcomp video)")
    p.add_argument("--workers", type=int, default=2, metavar="N",
                   help="processes reading the images (default: %(default)s)")
    return p


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    if args.workers < 1:
        raise UserError(f"--workers {args.workers}: use 1 or more")
    report = check_folder(args.folder, args.workers)
    for line in report.problems:
        print(line)
    print(report.summary())
    return 1 if report.problems else 0


if __name__ == "__main__":
    sys.exit(run_cli(main))
