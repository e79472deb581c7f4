"""``sdcomp check``: every file of a generated still dataset against every other.

:func:`check_dataset` reads a folder through :func:`~sdcomp.io.layout.load_dataset` and
returns one line per problem found, and the counts of its summary:

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
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np

from ..annotate.rle import rle_to_mask
from ..io.layout import Entry, load_dataset
from ..io.png import decode_ignore_png, decode_png16

BOX_TOLERANCE = 1.5e-6  # YOLO boxes are written with 6 decimals (normalised)


@dataclass
class Report:
    """Problems found (one line each) and the summary's counts."""

    problems: list[str] = field(default_factory=list)
    images: int = 0
    labelled: int = 0
    truncated: int = 0
    ignored: int = 0

    def summary(self) -> str:
        return (f"{self.images} images: {self.labelled} objects labelled, {self.truncated} "
                f"truncated, {self.ignored} ignored; {len(self.problems)} problems")


def check_dataset(folder: str | Path) -> Report:
    """Check the dataset ``folder`` (see the module docstring)."""
    ds = load_dataset(folder, "all")
    root = Path(folder)
    report = Report()
    seen: dict[int, str] = {}
    for e in ds.entries:
        report.images += 1
        name = e.image["file_name"]
        if e.id in seen:
            report.problems.append(f"{name}: image id {e.id} is also in {seen[e.id]}")
        seen[e.id] = name
        report.labelled += len(e.annotations)
        report.ignored += len(e.ignore)
        report.truncated += sum(bool(a.get("truncated")) for a in e.annotations)
        report.problems += _check_entry(root, e)
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
    image = cv2.imread(str(root / "images" / name), cv2.IMREAD_UNCHANGED)
    size = (im.get("height"), im.get("width"))
    if image is None:
        return out + [f"{name}: image missing or unreadable"]
    if image.shape[:2] != size:
        out.append(f"{name}: image is {image.shape[1]}x{image.shape[0]}, its record says "
                   f"{size[1]}x{size[0]}")
    try:
        mask = decode_png16((root / "masks" / im["mask_file"]).read_bytes())
    except (OSError, ValueError, KeyError):
        return out + [f"{name}: mask missing or unreadable"]
    if mask.shape != size:
        return out + [f"{name}: mask is {mask.shape[1]}x{mask.shape[0]}, the image "
                      f"{size[1]}x{size[0]}"]
    out += _check_masks(name, mask, e.annotations)
    out += _check_ignore(root, name, im, mask, e.ignore)
    meta = im.get("meta", {})
    if "objects_placed" in meta:
        accounted = len(e.annotations) + sum(int(meta.get(f"objects_{k}", 0))
                                             for k in ("ignored", "dropped", "skipped"))
        if accounted != meta["objects_placed"] or meta.get("objects_ignored", 0) != len(
                e.ignore):
            out.append(f"{name}: {meta['objects_placed']} objects placed, but "
                       f"{len(e.annotations)} labelled, {len(e.ignore)} ignore regions, "
                       f"meta says {meta.get('objects_ignored', 0)} ignored, "
                       f"{meta.get('objects_dropped', 0)} dropped")
    label = root / "labels" / Path(name).with_suffix(".txt")
    if (root / "labels").is_dir():
        out += _check_yolo(name, label, e.annotations, size)
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


def _check_ignore(root: Path, name: str, im: dict, mask: np.ndarray, ignore: list[dict]
                  ) -> list[str]:
    """The ignore regions cover exactly the ignore mask, apart from the labels."""
    file = im.get("ignore_file")
    if not isinstance(file, str):
        return [f"{name}: {len(ignore)} ignore regions but no ignore mask"] if ignore else []
    try:
        region = decode_ignore_png((root / "masks" / file).read_bytes())
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
