"""``python -m sdcomp.merge`` (``sdcomp merge``): join the folders of ``--shard K/N`` runs
into one dataset (:mod:`sdcomp.run.merge`)."""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Sequence

from ..errors import run_cli
from ..run.merge import merge
from ..run.video_merge import is_video_folder, merge_video
from . import Parser, prog


def build_parser() -> argparse.ArgumentParser:
    p = Parser(
        prog=prog("merge"),
        description="Merge the folders of `sdcomp generate --shard K/N` (or `sdcomp video "
                    "--shard K/N`) runs into one dataset, byte-identical to a single run of "
                    "the same options.")
    p.add_argument("shards", nargs="+", metavar="DIR", help="the shard runs' --out folders")
    p.add_argument("--out", required=True, metavar="DIR",
                   help="the merged dataset's folder (required, no default)")
    p.add_argument("--overwrite", action="store_true",
                   help="replace a dataset already in --out (e.g. of a merge that was stopped; "
                        "default: off)")
    p.add_argument("--remove-shards", action="store_true",
                   help="delete the shard folders after a successful merge (default: off)")
    p.add_argument("--progress", action=argparse.BooleanOptionalAction, default=None,
                   help="progress line (default: only on a terminal)")
    return p


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    start = time.perf_counter()
    if is_video_folder(args.shards[0]):
        counts = merge_video(args.shards, args.out, overwrite=args.overwrite,
                             remove=args.remove_shards)
        print(f"merged {len(args.shards)} shards: {counts['sequences']} sequences, "
              f"{counts['frames']} frames, {counts['annotations']} boxes, to {args.out} in "
              f"{time.perf_counter() - start:.1f} s")
        return 0
    counts = merge(args.shards, args.out, overwrite=args.overwrite, remove=args.remove_shards,
                   progress=args.progress)
    print(f"merged {len(args.shards)} shards: {counts['images']} images ({counts['train']} "
          f"train, {counts['val']} val), {counts['annotations']} annotations, to {args.out} "
          f"in {time.perf_counter() - start:.1f} s")
    return 0


if __name__ == "__main__":
    sys.exit(run_cli(main))
