"""A sheet of object crops from several sets, side by side at one pixel scale: real frames
(with labels) and generated datasets, as the object realism classifier sees them (each whole
box and its water, a window twice the box's longer side; ``sdcomp realism --objects``).

    python tools/crop_sheet.py --category swimmer --out docs/sar/swimmer_crops.jpg \\
        --real ../shared/reference/realframes tests/data/realframes_objects.json real \\
        --set before/sds "before (2026-11-28)" --set after/sds "after"

One row of ``--n`` crops per set (random boxes, seeded, distinct frames first), each crop
enlarged to ``--px`` pixels (the classifier's 64 px crops drawn bigger), a caption per row.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import cv2
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from sdcomp.report.realism.crops import Crop, montage  # noqa: E402
from sdcomp.report.realism.object_crops import collect_crops  # noqa: E402
from sdcomp.report.realism.object_report import table_rows  # noqa: E402
from sdcomp.report.realism.object_sets import measure_objects  # noqa: E402
from sdcomp.report.realism.sources import load_generated, load_real  # noqa: E402


def rows_of(frames, category: str, n: int, seed: int, px: int, rows: int) -> list[Crop]:
    """Up to ``n * rows`` crops of ``category`` from a set, random, distinct frames first."""
    table = measure_objects(frames)
    picks = [r for r in table_rows(table) if r[2] == category]
    rng = np.random.default_rng(seed)
    order = rng.permutation(len(picks))
    first, rest, seen = [], [], set()
    for j in order:
        f = picks[int(j)][0]
        (rest if f in seen else first).append(picks[int(j)])
        seen.add(f)
    crops = collect_crops(frames, (first + rest)[:3 * n * rows], out_px=px)
    return [Crop(c, "", True) for c in crops.crops[:n * rows]]


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--category", required=True)
    p.add_argument("--out", required=True)
    p.add_argument("--real", nargs=3, action="append", default=[],
                   metavar=("FRAMES", "LABELS", "CAPTION"))
    p.add_argument("--set", nargs=2, action="append", default=[],
                   metavar=("DATASET", "CAPTION"))
    p.add_argument("--n", type=int, default=10, help="crops per row")
    p.add_argument("--rows", type=int, default=1, help="rows per set")
    p.add_argument("--px", type=int, default=96, help="side of a crop in the sheet")
    p.add_argument("--seed", type=int, default=0)
    args = p.parse_args(argv)
    lines: list[tuple[str, list[Crop]]] = []
    for frames, labels, caption in args.real:
        crops = rows_of(load_real(frames, labels), args.category, args.n, args.seed, args.px,
                        args.rows)
        lines += [(caption if i == 0 else "", crops[i * args.n:(i + 1) * args.n])
                  for i in range(args.rows)]
    for folder, caption in args.set:
        crops = rows_of(load_generated(folder), args.category, args.n, args.seed, args.px,
                        args.rows)
        lines += [(caption if i == 0 else "", crops[i * args.n:(i + 1) * args.n])
                  for i in range(args.rows)]
    title = (f"{args.category}: each whole box and its water, a window twice the box's "
             f"longer side, as the object realism classifier sees it")
    img = montage(lines, title, args.n, args.px)
    cv2.imwrite(args.out, cv2.cvtColor(img, cv2.COLOR_RGB2BGR), [cv2.IMWRITE_JPEG_QUALITY, 88])
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
