"""``python -m sdcomp.show`` (``sdcomp show``): a contact sheet of a generated dataset
(:mod:`sdcomp.report.sheet`), or a strip and an animated preview of a video run's folder
(:mod:`sdcomp.report.video_sheet`; a folder with a ``video.json`` of format sdcomp-video).

    python -m sdcomp.show DIR [--out DIR/sheet.png] [--n 24] [--split all|train|val]
                              [--columns 6] [--cell 256] [--select spread|first|random]
                              [--seed 0] [--no-labels] [--zoom [--context 3]]
    python -m sdcomp.show CLIPS [--out CLIPS/strip.png] [--sequences 4]
                                [--frames-per-row 6] [--cell 256]
                                [--preview seq.gif|seq.mp4 [--sequence S]]
"""

from __future__ import annotations

import argparse
import os
import sys
from collections.abc import Sequence
from pathlib import Path

from ..errors import UserError, run_cli
from ..io.layout import SPLIT_CHOICES, Dataset, load_dataset
from ..report.sheet import (
    SELECT_CHOICES,
    category_colour_name,
    check_choices,
    check_params,
    sheet_of,
    write_sheet,
)
from ..report.video_sheet import find_sequence, is_video_folder, load_video, strip, write_preview
from ..report.zoom import CONTEXT, SMALL_IN_CELL, median_side_in_cell, zoom_sheet
from . import Parser, prog


def build_parser() -> argparse.ArgumentParser:
    p = Parser(
        prog=prog("show"),
        description="Draw a contact sheet of a generated dataset: images with mask outlines, "
                    "boxes (one colour per category) and captions.")
    p.add_argument("folder", metavar="DIR", help="dataset folder (the generator's --out), or "
                   "a video folder (sdcomp video's --out)")
    p.add_argument("--out", default=None, metavar="PNG",
                   help="sheet file (default: DIR/sheet.png; for a video folder DIR/strip.png, "
                        "none with only --preview)")
    p.add_argument("--n", type=int, default=24, help="images to show at most")
    p.add_argument("--split", default="all", metavar="|".join(SPLIT_CHOICES),
                   help="which COCO file's images")
    p.add_argument("--columns", type=int, default=6, help="cells per row at most")
    p.add_argument("--cell", type=int, default=256, metavar="PX", help="cell side, pixels")
    p.add_argument("--select", default="spread", metavar="|".join(SELECT_CHOICES),
                   help="spread: evenly over the images; first: the first n; random: n drawn "
                        "with --seed")
    p.add_argument("--seed", type=int, default=0, help="seed of --select random")
    p.add_argument("--zoom", action=argparse.BooleanOptionalAction, default=None,
                   help="one cell per object: a crop around it, magnified (--n counts "
                        "objects); --no-zoom: whole images (default: zoom when the objects "
                        f"would be under {SMALL_IN_CELL:g} px across in a whole-image cell)")
    p.add_argument("--context", type=float, default=CONTEXT, metavar="X",
                   help="with --zoom: crop side as a multiple of the object's box side")
    p.add_argument("--no-labels", dest="labels", action="store_false",
                   help="no caption band (default: captions under each image)")
    v = p.add_argument_group("video folders")
    v.add_argument("--sequences", type=int, default=None, metavar="N",
                   help="strip rows: the first N sequences (default: 4)")
    v.add_argument("--frames-per-row", type=int, default=None, metavar="N",
                   help="strip columns: N frames evenly spaced over each sequence (default: 6)")
    v.add_argument("--preview", default=None, metavar="GIF|MP4",
                   help="also write an animated preview of one sequence (.gif or .mp4; default: "
                        "none)")
    v.add_argument("--sequence", type=int, default=None, metavar="S",
                   help="the sequence of --preview, by its folder number (default: the first)")
    return p


VIDEO_ONLY = ("sequences", "frames_per_row", "preview", "sequence")


def _check_out(out: Path) -> None:
    if out.is_dir():
        raise UserError(f"--out {str(out)!r} is a folder: give a file name such as "
                        f"{str(out / 'sheet.png')!r}")
    if out.suffix.lower() != ".png":
        raise UserError(f"--out {str(out)!r} must end in .png: the sheet is written as PNG")
    parent = out.parent
    if not parent.is_dir():
        raise UserError(f"--out {str(out)!r}: folder {str(parent)!r} does not exist: create it "
                        f"first or choose another path")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise UserError(f"--out {str(out)!r}: folder {str(parent)!r} is not writable")


def _small_objects(ds: Dataset, cell: int) -> bool:
    """Whether the objects would be specks in whole-image cells (said in one line)."""
    side = median_side_in_cell(ds, cell)
    if side is None or side >= SMALL_IN_CELL:
        return False
    print(f"objects are small (median {side:.1f} px across in a {cell} px cell): one "
          f"magnified cell per object (--no-zoom: whole images)")
    return True


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    if is_video_folder(args.folder):
        return _show_video(args)
    for name in VIDEO_ONLY:
        if getattr(args, name) is not None:
            raise UserError(f"--{name.replace('_', '-')} is for video folders (sdcomp video's "
                            f"--out); {args.folder!r} is a dataset folder")
    check_params(args.n, args.columns, args.cell)
    check_choices(args.split, args.select)
    ds = load_dataset(args.folder, args.split)
    out = Path(args.out) if args.out is not None else ds.folder / "sheet.png"
    _check_out(out)
    if args.zoom is None:
        args.zoom = _small_objects(ds, args.cell)
    if args.zoom:
        if not 1.0 <= args.context <= 50.0:
            raise UserError(f"--context {args.context:g} is out of range: use 1 to 50 (times "
                            f"the object's box side)")
        sheet, objects = zoom_sheet(ds, args.n, args.columns, args.cell, args.select,
                                    args.seed, args.labels, args.context)
        anns = [a for _, a in objects]
        what = f"{len(objects)} objects"
    else:
        sheet, shown = sheet_of(ds, args.split, args.n, args.columns, args.cell,
                                args.select, args.seed, args.labels)
        anns = [a for e in shown for a in e.annotations]
        what = f"{len(shown)} of {len(ds.entries)} images"
    write_sheet(sheet, out)
    used = sorted({a.get("category_id", 1) for a in anns
                   if isinstance(a.get("category_id", 1), int)})
    legend = ", ".join(f"{ds.categories.get(c, c)} {category_colour_name(c)}" for c in used)
    print(f"{out}: {what} ({args.split}, {args.select}), "
          f"{sheet.shape[1]}x{sheet.shape[0]} px" + (f"; colours: {legend}" if legend else ""))
    return 0


def _show_video(args: argparse.Namespace) -> int:
    """``sdcomp show`` of a video folder: the strip and/or the preview."""
    if args.zoom:
        raise UserError("--zoom is for dataset folders; a video folder is shown as a strip")
    folder = Path(args.folder)
    seqs = load_video(folder)
    preview = Path(args.preview) if args.preview is not None else None
    seq = find_sequence(seqs, args.sequence if args.sequence is not None else seqs[0].index)
    if args.sequence is not None and preview is None:
        raise UserError("--sequence chooses the sequence of --preview: add --preview seq.gif")
    out = (Path(args.out) if args.out is not None
           else None if preview is not None else folder / "strip.png")
    if out is not None:
        _check_out(out)
        sheet, rows = strip(seqs, 4 if args.sequences is None else args.sequences,
                            6 if args.frames_per_row is None else args.frames_per_row,
                            args.cell)
        write_sheet(sheet, out)
        tracks = sum(len(set(sq.gt[:, 1].astype(int).tolist())) for sq, _ in rows)
        print(f"{out}: {len(rows)} of {len(seqs)} sequences x {len(rows[0][1])} frames, "
              f"{tracks} tracks, {sheet.shape[1]}x{sheet.shape[0]} px")
    if preview is not None:
        n = write_preview(seq, preview)
        print(f"{preview}: {seq.name}, {n} frames at {seq.fps:g} fps")
    return 0


if __name__ == "__main__":
    sys.exit(run_cli(main))
