"""``sdcomp check``: every file of a generated dataset against every other.

:func:`check_folder` checks a still dataset (:func:`check_dataset`) or a video run's folder
(:func:`check_video`) and returns one line per problem found, and the counts of its
summary. A still dataset, read through :func:`~sdcomp.io.layout.load_dataset`:

- each image and mask exists, decodes, and has the image record's width and height;
- an image's id is the number in its file name, and its file lies in its split's folder;
- the mask holds exactly the instance ids of the image's annotations, and each annotation's
  ``bbox`` and ``area`` are its mask pixels' extent and count;
- an image's ignore regions (``iscrowd`` entries) cover exactly its ignore mask, which
  touches no labelled pixel; no ignore regions without an ignore mask and none the other way;
- the image's meta accounts for every object placed: labelled + ignored + dropped + skipped;
- YOLO labels (where the folder has them): one line per labelled object, its class and box
  those of the COCO annotation (to the 6 decimals written);
- the splits are disjoint: no image id, file, or YOLO list line in two of them.

A video run (``video.json``, :mod:`sdcomp.io.clip_layout`), from its COCO-video file: the
same per frame (frame files, mask ids = the sequence's instance ids, boxes, areas, ignore
regions and masks, objects accounted for, YOLO lines), and each sequence's ``gt/gt.txt``
holds one flag-1 row per labelled object and one flag-0 row per ignore region of each frame,
with the same ids and boxes.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np

from ..annotate.rle import rle_to_mask
from ..errors import UserError
from ..io.clip_layout import ClipLayout
from ..io.layout import Entry, load_dataset
from ..io.mot import read_gt
from ..io.png import decode_ignore_png, decode_png16
from ..util.pool import imap_ordered

BOX_TOLERANCE = 1.5e-6  # YOLO boxes are written with 6 decimals (normalised)


@dataclass
class Report:
    """Problems found (one line each) and the summary's counts."""

    problems: list[str] = field(default_factory=list)
    images: int = 0
    labelled: int = 0
    truncated: int = 0
    ignored: int = 0

    def count(self, anns: list[dict], ignore: list[dict]) -> None:
        """Count one image with labelled objects ``anns`` and ignore regions ``ignore``."""
        self.images += 1
        self.labelled += len(anns)
        self.ignored += len(ignore)
        self.truncated += sum(bool(a.get("truncated")) for a in anns)

    def summary(self) -> str:
        return (f"{self.images} images: {self.labelled} objects labelled, {self.truncated} "
                f"truncated, {self.ignored} ignored; {len(self.problems)} problems")


CHUNK = 32  #: images per task of a worker process


def check_folder(folder: str | Path, workers: int = 2) -> Report:
    """Check ``folder``: a video run's (it has ``video.json``) or a still dataset; the
    images are read by ``workers`` processes (1: in this one)."""
    if ClipLayout(Path(folder)).meta.is_file():
        return check_video(folder, workers)
    return check_dataset(folder, workers)


def _chunks(items: list, size: int = CHUNK) -> list[list]:
    return [items[i:i + size] for i in range(0, len(items), size)]


def _per_image(func, tasks: list, workers: int) -> list[str]:
    """The problems ``func(task)`` finds for each task (a chunk of images), in order, in
    ``workers`` processes (in this one for 1 or a single task)."""
    if workers <= 1 or len(tasks) <= 1:
        return [line for t in tasks for line in func(t)]
    return [line for found in imap_ordered(func, tasks, workers, what="chunk")
            for line in found]


def _check_entries(task: tuple[Path, list[Entry]]) -> list[str]:
    root, entries = task
    return [line for e in entries for line in _check_entry(root, e)]


def check_dataset(folder: str | Path, workers: int = 2) -> Report:
    """Check the dataset ``folder`` (see the module docstring) with ``workers`` processes."""
    ds = load_dataset(folder, "all")
    root = Path(folder)
    report = Report()
    seen: dict[int, str] = {}
    for e in ds.entries:
        report.count(e.annotations, e.ignore)
        name = e.image["file_name"]
        if e.id in seen:
            report.problems.append(f"{name}: image id {e.id} is also in {seen[e.id]}")
        seen[e.id] = name
    report.problems += _per_image(_check_entries,
                                  [(root, c) for c in _chunks(list(ds.entries))], workers)
    report.problems += _check_lists(root)
    return report


def _check_entry(root: Path, e: Entry) -> list[str]:
    """The problems of one image (its files, masks, boxes, ignore regions, YOLO lines)."""
    im, name = e.image, e.image["file_name"]
    out: list[str] = []
    stem = Path(name).stem
    if not (stem.isdigit() and int(stem) == e.id):
        out.append(f"{name}: image id {e.id} is not the number in its file name")
    if not name.startswith(f"{e.split}/"):
        out.append(f"{name}: not in its split's folder {e.split}/")
    out += _check_frame(root / "images" / name, root / "masks", im, e.annotations, e.ignore)
    label = root / "labels" / Path(name).with_suffix(".txt")
    if (root / "labels").is_dir():
        out += _check_yolo(name, label, e.annotations, (im.get("height"), im.get("width")))
    return out


def _check_frame(image_file: Path, masks: Path, im: dict, anns: list[dict],
                 ignore: list[dict]) -> list[str]:
    """The problems of one image's files: the image and its mask (``mask_file`` under
    ``masks``) exist at the record's size, the mask against ``anns``, the ignore mask
    against ``ignore``, the meta's count of objects placed."""
    name = im["file_name"]
    image = cv2.imread(str(image_file), cv2.IMREAD_UNCHANGED)
    size = (im.get("height"), im.get("width"))
    if image is None:
        return [f"{name}: image missing or unreadable"]
    out = []
    if image.shape[:2] != size:
        out.append(f"{name}: image is {image.shape[1]}x{image.shape[0]}, its record says "
                   f"{size[1]}x{size[0]}")
    try:
        mask = decode_png16((masks / im["mask_file"]).read_bytes())
    except (OSError, ValueError, KeyError):
        return out + [f"{name}: mask missing or unreadable"]
    if mask.shape != size:
        return out + [f"{name}: mask is {mask.shape[1]}x{mask.shape[0]}, the image "
                      f"{size[1]}x{size[0]}"]
    out += _check_masks(name, mask, anns)
    out += _check_ignore(masks, name, im, mask, ignore)
    meta = im.get("meta", {})
    if "objects_placed" in meta:
        accounted = len(anns) + sum(int(meta.get(f"objects_{k}", 0))
                                    for k in ("ignored", "dropped", "skipped"))
        if accounted != meta["objects_placed"] or meta.get("objects_ignored", 0) != len(
                ignore):
            out.append(f"{name}: {meta['objects_placed']} objects placed, but "
                       f"{len(anns)} labelled, {len(ignore)} ignore regions, "
                       f"meta says {meta.get('objects_ignored', 0)} ignored, "
                       f"{meta.get('objects_dropped', 0)} dropped")
    return out


def _check_masks(name: str, mask: np.ndarray, anns: list[dict]) -> list[str]:
    """The mask's ids are the annotations' instance ids; boxes and areas are the masks'."""
    out = []
    ids = set(np.unique(mask).tolist()) - {0}
    want = {a.get("instance_id") for a in anns}
    if ids != want:
        out.append(f"{name}: mask ids {sorted(ids)} are not the annotations' "
                   f"{sorted(i for i in want if isinstance(i, int))}")
    for a in anns:
        ys, xs = np.nonzero(mask == a.get("instance_id"))
        if not len(xs):
            continue
        box = [float(xs.min()), float(ys.min()), float(xs.max() - xs.min() + 1),
               float(ys.max() - ys.min() + 1)]
        if [float(v) for v in a.get("bbox", ())] != box or a.get("area") != len(xs):
            out.append(f"{name}: instance {a.get('instance_id')}: bbox {a.get('bbox')} area "
                       f"{a.get('area')}, its mask's {box} area {len(xs)}")
    return out


def _check_ignore(masks: Path, name: str, im: dict, mask: np.ndarray, ignore: list[dict]
                  ) -> list[str]:
    """The ignore regions cover exactly the ignore mask (``ignore_file`` under ``masks``),
    apart from the labels."""
    file = im.get("ignore_file")
    if not isinstance(file, str):
        return [f"{name}: {len(ignore)} ignore regions but no ignore mask"] if ignore else []
    try:
        region = decode_ignore_png((masks / file).read_bytes())
    except (OSError, ValueError):
        return [f"{name}: ignore mask {file} missing or unreadable"]
    if region.shape != mask.shape:
        return [f"{name}: ignore mask {file} is not the image's size"]
    out = []
    if (region & (mask > 0)).any():
        out.append(f"{name}: ignore mask {file} covers labelled pixels")
    union = np.zeros(mask.shape, bool)
    for a in ignore:
        union |= rle_to_mask(a["segmentation"])
    if not np.array_equal(union, region):
        out.append(f"{name}: its {len(ignore)} ignore regions cover "
                   f"{int(union.sum())} pixels, its ignore mask {int(region.sum())}, not "
                   f"the same")
    return out


def _check_yolo(name: str, label: Path, anns: list[dict], size: tuple) -> list[str]:
    """One YOLO line per labelled object, class and box (or polygon's class) as in COCO."""
    try:
        lines = [ln.split() for ln in label.read_text().splitlines() if ln.strip()]
    except OSError:
        return [f"{name}: YOLO label file {label.name} missing"]
    if len(lines) != len(anns):
        return [f"{name}: {len(lines)} YOLO lines, {len(anns)} labelled objects"]
    h, w = size
    out = []
    for a, line in zip(sorted(anns, key=lambda a: a.get("instance_id", 0)), lines, strict=True):
        if int(line[0]) != int(a["category_id"]) - 1:
            out.append(f"{name}: YOLO class {line[0]} for category {a['category_id']}")
        elif len(line) == 5:
            x, y, bw, bh = (float(v) for v in a["bbox"])
            want = np.array([(x + bw / 2) / w, (y + bh / 2) / h, bw / w, bh / h])
            if np.abs(np.array(line[1:], float) - want).max() > BOX_TOLERANCE:
                out.append(f"{name}: YOLO box {' '.join(line[1:])} is not the COCO bbox "
                           f"{a['bbox']}")
    return out


def _check_lists(root: Path) -> list[str]:
    """train.txt and val.txt (where present) share no image."""
    lists = {s: set((root / f"{s}.txt").read_text().split())
             for s in ("train", "val") if (root / f"{s}.txt").is_file()}
    both = lists.get("train", set()) & lists.get("val", set())
    return [f"{p}: in both train.txt and val.txt" for p in sorted(both)]


def _sequence_frame(file_name: str) -> tuple[str, str]:
    """(sequence folder, frame file name) of a video frame's ``file_name``
    (``SEQ/img1/000001.jpg``)."""
    seq, _, frame = file_name.partition("/img1/")
    return seq, frame


def _check_frames(task: tuple[Path, list[tuple[dict, list[dict], list[dict]]]]
                  ) -> list[str]:
    """The problems of video frames: (image record, labelled, ignore regions) each."""
    root, frames = task
    out = []
    for im, anns, ignore in frames:
        out += _check_frame(root / im["file_name"], root, im, anns, ignore)
        seq, frame = _sequence_frame(im["file_name"])
        if (root / seq / "labels").is_dir():
            out += _check_yolo(im["file_name"],
                               root / seq / "labels" / Path(frame).with_suffix(".txt"), anns,
                               (im.get("height"), im.get("width")))
    return out


def check_video(folder: str | Path, workers: int = 2) -> Report:
    """Check the video run's folder ``folder`` (see the module docstring) with ``workers``
    processes."""
    layout = ClipLayout(Path(folder))
    try:
        coco = json.loads(layout.coco.read_text())
        images, annotations = coco["images"], coco["annotations"]
    except (OSError, ValueError, KeyError, TypeError):
        raise UserError(f"{layout.coco}: missing or not a COCO-video file; finish the run "
                        f"with `sdcomp video ... --resume`") from None
    labelled: dict[int, list[dict]] = {}
    crowd: dict[int, list[dict]] = {}
    for a in annotations:
        (crowd if a.get("iscrowd") else labelled).setdefault(a["image_id"], []).append(a)
    report = Report()
    frames: dict[str, dict[int, list[dict]]] = {}
    work = []
    for im in images:
        anns, ignore = labelled.get(im["id"], []), crowd.get(im["id"], [])
        report.count(anns, ignore)
        work.append((im, anns, ignore))
        seq, frame = _sequence_frame(im["file_name"])
        frames.setdefault(seq, {})[int(Path(frame).stem)] = anns + ignore
    report.problems += _per_image(_check_frames, [(layout.root, c) for c in _chunks(work)],
                                  workers)
    for seq, per_frame in frames.items():
        report.problems += _check_gt(layout.root / seq / "gt" / "gt.txt", per_frame)
    return report


def _check_gt(path: Path, per_frame: dict[int, list[dict]]) -> list[str]:
    """``gt.txt`` has a row per object of each frame (``per_frame``: frame number from 1 ->
    its COCO annotations, ignore regions with iscrowd 1): id, box and flag (1 labelled, 0
    ignore region) as in COCO."""
    try:
        rows = read_gt(path)
    except (OSError, ValueError):
        return [f"{path}: missing or unreadable"]
    got = {(int(r[0]), int(r[1]), int(r[6])): r[2:6] for r in rows}
    want = {(k, int(a["instance_id"]), 0 if a.get("iscrowd") else 1): a["bbox"]
            for k, anns in per_frame.items() for a in anns}
    out = [f"{path}: frame {k}, id {i}: {'ignore region' if f == 0 else 'object'} in COCO, "
           f"no gt row" for k, i, f in sorted(want.keys() - got.keys())]
    out += [f"{path}: frame {k}, id {i}: a gt row not in COCO"
            for k, i, _ in sorted(got.keys() - want.keys())]
    for key in sorted(want.keys() & got.keys()):
        x, y, w, h = (float(v) for v in want[key])
        if np.abs(np.asarray(got[key], float) - [x + 1, y + 1, w, h]).max() > 0.01:
            out.append(f"{path}: frame {key[0]}, id {key[1]}: box {list(got[key])} is not "
                       f"the COCO bbox {want[key]} (+1)")
    return out
