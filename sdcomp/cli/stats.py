"""``python -m sdcomp.stats`` (``sdcomp stats``): statistics of a generated dataset as tables
and a figure (:mod:`sdcomp.report.stats`).

    sdcomp stats DIR [--out DIR/stats.png] [--bins 10]
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

from ..errors import UserError, run_cli
from ..report.stats import dataset_stats, format_table, plot_stats
from ..util.log import add_verbosity_flags, setup_logging
from . import Parser, prog


def build_parser() -> argparse.ArgumentParser:
    p = Parser(
        prog=prog("stats"),
        description="Statistics of a generated dataset: counts per category and split, "
                    "object sizes against the COCO small/medium/large bounds, altitude, "
                    "pitch, turbidity and water colour histograms, images with no objects. "
                    "Printed as tables and drawn as a PNG figure.")
    p.add_argument("folder", metavar="DIR", help="dataset folder (the generator's --out)")
    p.add_argument("--out", default=None, metavar="PNG",
                   help="figure file (default: DIR/stats.png; '-' for none)")
    p.add_argument("--bins", type=int, default=10, metavar="N",
                   help="histogram bins")
    add_verbosity_flags(p)
    return p


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    log = setup_logging(args.quiet, args.verbose)
    stats = dataset_stats(args.folder, args.bins)
    out = None if args.out == "-" else Path(args.out) if args.out else \
        Path(args.folder) / "stats.png"
    if out is not None:
        if out.suffix.lower() != ".png":
            raise UserError(f"--out {str(out)!r} must end in .png: the figure is written as "
                            f"PNG (or give --out - for none)")
        if not out.parent.is_dir():
            raise UserError(f"--out {str(out)!r}: folder {str(out.parent)!r} does not exist: "
                            f"create it first or choose another path")
    log.info(format_table(stats).rstrip("\n"))
    if out is not None:
        plot_stats(stats, out)
        log.info(f"figure: {out}")
    return 0


if __name__ == "__main__":
    sys.exit(run_cli(main))
