"""``bench fewshot``'s command line: its parser, the training flags it shares with
``sim2real``'s (:func:`native_training_flags`) and the command (:mod:`sdcomp.bench.fewshot`)."""

from __future__ import annotations

import argparse
from pathlib import Path

from ..errors import UserError


def fewshot_parser(sub, train_flags: dict) -> None:
    """Add the ``fewshot`` subcommand to ``sub``, with the training flags ``train_flags``
    (flag dest: (type, metavar, help))."""
    s = sub.add_parser("fewshot", help="how many real frames sdcomp saves: real only, "
                       "synthetic only, synthetic fine-tuned on K and mixed, scored on "
                       "held-out real frames")
    s.add_argument("--train", action="append", required=True, metavar="DIR",
                   help="generated dataset folder (repeat for several)")
    s.add_argument("--real", required=True, metavar="FRAMES",
                   help="your labelled real photos: a folder (or file)")
    s.add_argument("--real-labels", required=True, metavar="LABELS",
                   help="their labels: a COCO json file or a YOLO labels folder")
    s.add_argument("--k", default="0,10,25,50,all", metavar="LIST",
                   help="real training frames per run, comma-separated; 'all' = the whole "
                        "pool (default: %(default)s)")
    s.add_argument("--seeds", default="0,1", metavar="LIST",
                   help="training seeds, comma-separated (default: %(default)s)")
    s.add_argument("--test-share", type=float, default=0.3, metavar="F",
                   help="share of the source photos and videos held out for testing "
                        "(default: %(default)s)")
    s.add_argument("--ratio", type=float, default=0.25, metavar="F",
                   help="share of real images in the mixed arm (default: %(default)s)")
    s.add_argument("--finetune-iter", type=int, metavar="N",
                   help="fine-tuning iterations (default: half of --max-iter)")
    s.add_argument("--map", action="append", default=[], metavar="GEN=REAL",
                   help="generated category GEN is real category REAL (repeatable)")
    s.add_argument("--out", required=True, metavar="DIR", help="results folder (resumable)")
    native_training_flags(s, "training (as sim2real)", train_flags)


def native_training_flags(s: argparse.ArgumentParser, title: str, train_flags: dict) -> None:
    """The flags of a training at the frames' own size (``sim2real``, ``fewshot``): device,
    threads, progress, and the ``train_flags`` but ``min_scale`` (images are never resized)
    in a group ``title``, with ``--hflip``."""
    s.add_argument("--device", default="auto", metavar="DEV", help="auto, cpu or cuda[:N]")
    s.add_argument("--threads", type=int, metavar="N", help="torch CPU threads")
    s.add_argument("--progress", action=argparse.BooleanOptionalAction, default=None,
                   help="progress line (default: only on a terminal)")
    g = s.add_argument_group(title)
    for dest, (typ, metavar, text) in train_flags.items():
        if dest != "min_scale":
            g.add_argument("--" + dest.replace("_", "-"), dest=dest, type=typ,
                           metavar=metavar, help=text)
    g.add_argument("--hflip", action=argparse.BooleanOptionalAction, default=None,
                   help="random horizontal flips")


def _ints(text: str, flag: str, allow_all: bool = False) -> tuple:
    out: list = []
    for part in text.split(","):
        part = part.strip().lower()
        if allow_all and part == "all":
            out.append(None)
            continue
        try:
            out.append(int(part))
        except ValueError:
            raise UserError(f"{flag} {text!r}: {part!r} is not a whole number"
                            + (" or 'all'" if allow_all else "")) from None
    return tuple(out)


def cmd_fewshot(args, train: dict, device: str) -> int:
    """Run ``bench fewshot`` from the parsed ``args``, the training flags given ``train``
    and the resolved ``device``; prints the AP50 table's path."""
    from .fewshot import FewshotSpec, run_fewshot
    from .train import TrainConfig
    spec = FewshotSpec(tuple(map(Path, args.train)), Path(args.real), Path(args.real_labels),
                       Path(args.out), _ints(args.k, "--k", True), _ints(args.seeds, "--seeds"),
                       args.test_share, args.ratio, args.finetune_iter, tuple(args.map),
                       TrainConfig(**train), device, args.progress)
    run_fewshot(spec)
    print(f"report: {Path(args.out) / 'report.md'}, plot: {Path(args.out) / 'fewshot.png'}")
    return 0
