"""A contact sheet of a generated dataset: images with mask outlines, boxes and captions.

Reads the folder that the generator wrote::

    DIR/images/000000.jpg            photos (file_name in the COCO files)
    DIR/masks/000000.png             16-bit instance ids (mask_file in the COCO files)
    DIR/annotations/instances_train.json, instances_val.json
    DIR/records.jsonl                the run's journal: read instead of the COCO files in a
                                     folder written with --format yolo (which has none)

and draws, per chosen image, the photo letterboxed into a square cell, the outline of each
instance (traced in the full-resolution mask, then scaled), its COCO box, both in one bright
colour per category, and a one-line caption (file stem, altitude, gimbal pitch, water colour,
turbidity, number of annotations) on a dark band at the bottom of the cell.

Command line::

    python -m sdcomp.show DIR [--out DIR/sheet.png] [--n 24] [--split all|train|val]
                              [--columns 6] [--cell 256] [--select spread|first|random]
                              [--seed 0] [--no-labels]

Python::

    from sdcomp.show import contact_sheet
    rgb = contact_sheet("dataset/", n=12, split="val")     # (H, W, 3) uint8 RGB
"""

from __future__ import annotations

import argparse
import json
import math
import os
import shlex
import sys
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from .cli import prog
from .coco import iter_records, read_journal
from .errors import UserError, run_cli
from .fileio import atomic_write_bytes
from .pngio import decode_png16

SPLITS = ("train", "val")
SPLIT_CHOICES = ("all", *SPLITS)
SELECT_CHOICES = ("spread", "first", "random")
MIN_CELL = 32
BACKGROUND = (40, 40, 40)  # sRGB around the letterboxed images
PAD = 1  # pixels kept free on each side of a cell's image, so neighbours do not touch
TEXT_RGB = (235, 235, 235)
BAND_DARKEN = 0.3  # caption band = pixels x this
FONT = cv2.FONT_HERSHEY_SIMPLEX
# bright, mutually distinct colours (sRGB) for category ids 1, 2, ... (then repeating)
PALETTE = (
    ("red", (255, 60, 60)), ("green", (60, 255, 60)), ("blue", (70, 150, 255)),
    ("yellow", (255, 230, 0)), ("magenta", (255, 60, 255)), ("cyan", (0, 255, 255)),
    ("orange", (255, 150, 0)), ("violet", (170, 110, 255)),
)


def _resume(folder: Path) -> str:
    """How to finish or repair the dataset in ``folder``: --resume redraws images and masks
    that are missing and rewrites the COCO files."""
    return (f"re-run `python -m sdcomp.generate --out {shlex.quote(str(folder))} --resume` "
            f"with the run's options")


def category_colour(category_id: int) -> tuple[int, int, int]:
    """The RGB colour outlines and boxes of ``category_id`` are drawn in."""
    return PALETTE[(int(category_id) - 1) % len(PALETTE)][1]


def category_colour_name(category_id: int) -> str:
    return PALETTE[(int(category_id) - 1) % len(PALETTE)][0]


# --------------------------------------------------------------------------- reading

@dataclass(frozen=True)
class Entry:
    """One image of the dataset: its COCO record, its annotations and its split."""

    image: dict
    annotations: list
    split: str

    @property
    def id(self) -> int:
        return self.image["id"]


@dataclass(frozen=True)
class Dataset:
    folder: Path
    entries: list  # of Entry, sorted by image id
    categories: dict  # category id -> name


def _read_coco(path: Path, how: str) -> dict:
    try:
        coco = json.loads(path.read_bytes())
    except OSError as exc:
        raise UserError(f"COCO file {str(path)!r} cannot be read ({exc.strerror}): "
                        f"{how}") from None
    except (ValueError, UnicodeDecodeError) as exc:
        msg = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise UserError(f"COCO file {str(path)!r} is not valid JSON ({msg}): {how} "
                        f"to rewrite it") from None
    if not (isinstance(coco, dict) and isinstance(coco.get("images"), list)
            and isinstance(coco.get("annotations", []), list)):
        raise UserError(f"{str(path)!r} is not a COCO file (no 'images' list): {how} "
                        f"to rewrite it")
    return coco


def load_dataset(folder: str | Path, split: str = "all") -> Dataset:
    """The images (sorted by id) with their annotations of ``split`` ("all", "train", "val").

    A folder written without COCO files (``--format yolo``, as its dataset.json says) is
    read from its journal, ``records.jsonl``: the records the COCO files would be made of.

    UserError for an unknown split, a folder that is missing or not a generated dataset,
    or a COCO file that is missing, not JSON or not COCO.
    """
    if split not in SPLIT_CHOICES:
        raise UserError(f"--split {split!r} is unknown: use {', '.join(SPLIT_CHOICES)}")
    folder = Path(folder)
    if not folder.exists():
        raise UserError(f"dataset folder {str(folder)!r} does not exist: give the --out folder "
                        f"of `python -m sdcomp.generate`")
    if not folder.is_dir():
        raise UserError(f"{str(folder)!r} is a file, not a dataset folder: give the --out "
                        f"folder of `python -m sdcomp.generate`")
    if _written_without_coco(folder):
        if not (folder / "records.jsonl").is_file():
            raise UserError(f"{str(folder)!r} was written without COCO files and its journal "
                            f"records.jsonl is missing: {_resume(folder)} to rewrite it")
        return journal_dataset(folder, split)
    ann_dir = folder / "annotations"
    if not ann_dir.is_dir():
        raise UserError(f"{str(folder)!r} is not a generated dataset (no annotations/ folder): "
                        f"give the --out folder of `python -m sdcomp.generate`")
    paths = {s: ann_dir / f"instances_{s}.json" for s in SPLITS}
    wanted = SPLITS if split == "all" else (split,)
    present = [s for s in wanted if paths[s].is_file()]
    if not present:
        if split == "all":
            raise UserError(f"{str(folder)!r} is not a generated dataset (no "
                            f"annotations/instances_train.json or instances_val.json): "
                            f"{_resume(folder)} to write them")
        others = [s for s in SPLIT_CHOICES if s != split]
        raise UserError(f"--split {split}: {str(paths[split])!r} does not exist: use --split "
                        f"{' or '.join(others)}, or {_resume(folder)} to write it")
    entries: list[Entry] = []
    categories: dict[int, str] = {}
    for s in present:
        coco = _read_coco(paths[s], _resume(folder))
        for cat in coco.get("categories") or []:
            if isinstance(cat, dict) and isinstance(cat.get("id"), int):
                categories[cat["id"]] = str(cat.get("name", cat["id"]))
        by_image: dict = {}
        for ann in coco.get("annotations", []):
            if isinstance(ann, dict):
                by_image.setdefault(ann.get("image_id"), []).append(ann)
        for img in coco["images"]:
            if not (isinstance(img, dict) and isinstance(img.get("id"), int)
                    and isinstance(img.get("file_name"), str)):
                raise UserError(f"{str(paths[s])!r}: an image record lacks an integer 'id' or "
                                f"a 'file_name': {_resume(folder)} to rewrite it")
            entries.append(Entry(img, by_image.get(img["id"], []), s))
    entries.sort(key=lambda e: (e.id, e.split))
    return Dataset(folder, entries, categories)


def _run_config(folder: Path) -> dict:
    """The run's config as the dataset.json of ``folder`` records it; empty when that
    cannot be read (missing, not JSON, no config mapping)."""
    try:
        config = json.loads((folder / "dataset.json").read_bytes())["config"]
    except (OSError, ValueError, UnicodeDecodeError, KeyError, TypeError):
        return {}
    return config if isinstance(config, dict) else {}


def _written_without_coco(folder: Path) -> bool:
    """Whether the dataset.json of ``folder`` says its run wrote no COCO files (False when
    it cannot be read: the COCO files are the dataset)."""
    config = _run_config(folder)
    return "format" in config and "coco" not in str(config["format"]).split(",")


def journal_dataset(folder: str | Path, split: str = "all") -> Dataset:
    """The images of ``split`` read from the run's journal, ``records.jsonl`` (the records
    the COCO files are made from), with the category names of its dataset.json (none when
    that cannot be read)."""
    folder = Path(folder)
    journal = folder / "records.jsonl"
    offsets = read_journal(journal)
    wanted = None if split == "all" else split
    entries = [Entry(rec["image"], rec["annotations"], rec["split"])
               for rec in iter_records(journal, offsets, wanted)]
    entries.sort(key=lambda e: (e.id, e.split))
    try:
        categories = {i + 1: str(o["category"])
                      for i, o in enumerate(_run_config(folder)["objects"])}
    except (KeyError, TypeError):
        categories = {}
    return Dataset(folder, entries, categories)


def select_indices(count: int, n: int, select: str = "spread", seed: int = 0) -> list[int]:
    """Which of ``count`` images (indices, ascending) to show, at most ``n``.

    ``first``: the first n; ``spread``: n evenly over the range, first and last included;
    ``random``: n distinct ones drawn with ``seed``.
    """
    if select not in SELECT_CHOICES:
        raise UserError(f"--select {select!r} is unknown: use {', '.join(SELECT_CHOICES)}")
    if n < 1:
        raise UserError(f"--n {n} must be at least 1")
    if n >= count:
        return list(range(count))
    if select == "first":
        return list(range(n))
    if select == "random":
        return sorted(int(i) for i in np.random.default_rng(seed).choice(count, n, replace=False))
    if n == 1:
        return [0]
    # step (count-1)/(n-1) >= 1, so flooring x + 0.5 keeps the picks distinct
    return [int(math.floor(i * (count - 1) / (n - 1) + 0.5)) for i in range(n)]


# --------------------------------------------------------------------------- drawing

def band_height(cell: int) -> int:
    """Rows at the bottom of a cell that the caption band covers."""
    (_, th), base = cv2.getTextSize("Ag0", FONT, _font_scale(cell), 1)
    return min(cell, th + base + 4)


def _font_scale(cell: int) -> float:
    return max(0.3, cell / 640)


def _fit_text(text: str, cell: int) -> tuple[str, float]:
    """The caption (cut if need be) and a font scale at which it fits the cell's width."""
    scale, room = _font_scale(cell), cell - 4
    (w, _), _ = cv2.getTextSize(text, FONT, scale, 1)
    if w > room:
        scale = max(0.25, scale * room / w)
    while text and cv2.getTextSize(text, FONT, scale, 1)[0][0] > room:
        text = text[:-1]
    return text.rstrip(), scale


def _num(meta: dict, key: str) -> float | None:
    try:
        v = float(meta[key])
    except (KeyError, TypeError, ValueError):
        return None
    return v if math.isfinite(v) else None


def caption(entry: Entry) -> str:
    """E.g. ``000123 alt 23m pitch 90 brown t0.40 n=2``; metadata that is absent is left out."""
    meta = entry.image.get("meta")
    meta = meta if isinstance(meta, dict) else {}
    parts = [Path(entry.image["file_name"]).stem]
    if (alt := _num(meta, "height_above_takeoff(meter)")) is not None:
        parts.append(f"alt {alt:.0f}m")
    if (pitch := _num(meta, "gimbal_pitch(degrees)")) is not None:
        parts.append(f"pitch {pitch:.0f}")
    if meta.get("water_color"):
        parts.append(str(meta["water_color"]))
    if (turb := _num(meta, "turbidity")) is not None:
        parts.append(f"t{turb:.2f}")
    parts.append(f"n={len(entry.annotations)}")
    return " ".join(parts)


def _read_image(path: Path, target_scale: float, listed: tuple[int, int] | None,
                how: str) -> tuple[np.ndarray, tuple[int, int]]:
    """The RGB image and its full size (w, h).

    Decoded at 1/2, 1/4 or 1/8 size where that is still at least ``target_scale`` of the
    ``listed`` size and the file agrees with that size; otherwise decoded whole.
    """
    if not path.is_file():
        raise UserError(f"image {str(path)!r} is listed in the COCO file but missing: "
                        f"{how}")
    factor = 1
    while listed is not None and factor < 8 and target_scale * factor * 2 <= 1.0:
        factor *= 2
    flags = {1: cv2.IMREAD_COLOR, 2: cv2.IMREAD_REDUCED_COLOR_2,
             4: cv2.IMREAD_REDUCED_COLOR_4, 8: cv2.IMREAD_REDUCED_COLOR_8}
    img = cv2.imread(str(path), flags[factor])
    if img is not None and factor > 1:
        assert listed is not None
        if (abs(img.shape[1] * factor - listed[0]) < factor
                and abs(img.shape[0] * factor - listed[1]) < factor):
            return cv2.cvtColor(img, cv2.COLOR_BGR2RGB), listed
        img = cv2.imread(str(path), cv2.IMREAD_COLOR)  # the listed size is wrong: use the file's
    if img is None:
        raise UserError(f"image {str(path)!r} cannot be decoded (corrupt or truncated): "
                        f"{how}")
    return cv2.cvtColor(img, cv2.COLOR_BGR2RGB), (img.shape[1], img.shape[0])


def _read_mask(path: Path, shape: tuple[int, int], how: str) -> np.ndarray:
    if not path.is_file():
        raise UserError(f"mask {str(path)!r} is listed in the COCO file but missing: "
                        f"{how}")
    try:
        mask = decode_png16(path.read_bytes())
    except (OSError, ValueError) as exc:
        raise UserError(f"mask {str(path)!r} is unreadable ({exc}): {how}") from None
    if mask.shape != shape:
        raise UserError(f"mask {str(path)!r} is {mask.shape[1]}x{mask.shape[0]} but its image "
                        f"is {shape[1]}x{shape[0]}: {how}")
    return mask


def _contours(mask: np.ndarray, instance_ids: set[int]) -> dict[int, list[np.ndarray]]:
    """Outer contours (full-resolution pixel coordinates) of each instance id in ``mask``."""
    ys, xs = np.nonzero(mask)
    vals = mask[ys, xs]
    out: dict[int, list[np.ndarray]] = {}
    for iid in instance_ids:
        sel = vals == iid
        if not sel.any():
            continue
        y0, y1, x0, x1 = ys[sel].min(), ys[sel].max(), xs[sel].min(), xs[sel].max()
        crop = (mask[y0:y1 + 1, x0:x1 + 1] == iid).astype(np.uint8)
        found, _ = cv2.findContours(crop, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE,
                                    offset=(int(x0), int(y0)))
        out[iid] = list(found)
    return out


def render_cell(folder: str | Path, entry: Entry, cell: int = 256,
                labels: bool = True) -> np.ndarray:
    """(cell, cell, 3) uint8 RGB: the image letterboxed, outlines, boxes and caption."""
    folder = Path(folder)
    tile = np.empty((cell, cell, 3), np.uint8)
    tile[:] = BACKGROUND
    rec = entry.image
    w, h = rec.get("width"), rec.get("height")
    listed = (w, h) if isinstance(w, int) and isinstance(h, int) and w > 0 and h > 0 else None
    room = cell - 2 * PAD
    scale_hint = min(room / listed[0], room / listed[1]) if listed else 1.0
    img, (w, h) = _read_image(folder / "images" / rec["file_name"], scale_hint, listed,
                              _resume(folder))
    s = min(room / w, room / h)
    dw, dh = max(1, round(w * s)), max(1, round(h * s))
    ox, oy = (cell - dw) // 2, (cell - dh) // 2
    interp = cv2.INTER_AREA if dw < img.shape[1] else cv2.INTER_LINEAR
    tile[oy:oy + dh, ox:ox + dw] = cv2.resize(img, (dw, dh), interpolation=interp)
    sx, sy = dw / w, dh / h

    anns = entry.annotations
    contours: dict[int, list[np.ndarray]] = {}
    iids = {a["instance_id"] for a in anns if isinstance(a.get("instance_id"), int)}
    if iids and isinstance(rec.get("mask_file"), str):
        mask = _read_mask(folder / "masks" / rec["mask_file"], (h, w), _resume(folder))
        contours = _contours(mask, iids)
    for ann in anns:
        cid = ann.get("category_id")
        colour = category_colour(cid if isinstance(cid, int) else 1)
        bbox = ann.get("bbox")
        if (isinstance(bbox, list) and len(bbox) == 4
                and all(isinstance(v, (int, float)) and math.isfinite(v) for v in bbox)):
            x, y, bw, bh = (float(v) for v in bbox)
            p0 = (ox + round(x * sx), oy + round(y * sy))
            p1 = (ox + max(round(x * sx), round((x + bw) * sx) - 1),
                  oy + max(round(y * sy), round((y + bh) * sy) - 1))
            cv2.rectangle(tile, p0, p1, colour, 1, cv2.LINE_8)
        for c in contours.get(ann.get("instance_id"), []):
            # pixel centres to cell coordinates, 4 fractional bits for sub-pixel placement
            pts = (c[:, 0, :] + 0.5) * (sx, sy) - 0.5 + (ox, oy)
            cv2.polylines(tile, [np.round(pts * 16).astype(np.int32)], True, colour, 1,
                          cv2.LINE_8, shift=4)
    if labels:
        bh_ = band_height(cell)
        band = tile[cell - bh_:]
        band[:] = (band * BAND_DARKEN).astype(np.uint8)
        text, fs = _fit_text(caption(entry), cell)
        (_, th), base = cv2.getTextSize("Ag0", FONT, fs, 1)
        cv2.putText(tile, text, (2, cell - 2 - base), FONT, fs, TEXT_RGB, 1, cv2.LINE_AA)
    return tile


def _check_params(n: int, columns: int, cell: int) -> None:
    if n < 1:
        raise UserError(f"--n {n} must be at least 1")
    if columns < 1:
        raise UserError(f"--columns {columns} must be at least 1")
    if cell < MIN_CELL:
        raise UserError(f"--cell {cell} is too small: use at least {MIN_CELL} pixels")


def _check_choices(split: str, select: str) -> None:
    if split not in SPLIT_CHOICES:
        raise UserError(f"--split {split!r} is unknown: use {', '.join(SPLIT_CHOICES)}")
    if select not in SELECT_CHOICES:
        raise UserError(f"--select {select!r} is unknown: use {', '.join(SELECT_CHOICES)}")


def _sheet(ds: Dataset, split: str, n: int, columns: int, cell: int, select: str, seed: int,
           labels: bool) -> tuple[np.ndarray, list[Entry]]:
    if not ds.entries:
        raise UserError(f"{str(ds.folder)!r} has no images in split {split!r}: choose another "
                        f"--split, or {_resume(ds.folder)}")
    shown = [ds.entries[i] for i in select_indices(len(ds.entries), n, select, seed)]
    cols = min(columns, len(shown))
    rows = math.ceil(len(shown) / cols)
    sheet = np.empty((rows * cell, cols * cell, 3), np.uint8)
    sheet[:] = BACKGROUND
    for k, entry in enumerate(shown):
        r, c = divmod(k, cols)
        sheet[r * cell:(r + 1) * cell, c * cell:(c + 1) * cell] = render_cell(
            ds.folder, entry, cell, labels)
    return sheet, shown


def contact_sheet(folder: str | Path, n: int = 24, split: str = "all", columns: int = 6,
                  cell: int = 256, select: str = "spread", seed: int = 0,
                  labels: bool = True) -> np.ndarray:
    """(H, W, 3) uint8 RGB contact sheet of up to ``n`` images of the dataset in ``folder``.

    The images of ``split`` are sorted by id and ``select``-ed (see :func:`select_indices`);
    they fill ``min(columns, shown)`` columns of ``cell`` x ``cell`` cells, row by row, so
    the sheet is ``ceil(shown / min(columns, shown)) * cell`` high. Raises UserError for bad
    arguments or a missing or broken dataset.
    """
    _check_params(n, columns, cell)
    _check_choices(split, select)
    return _sheet(load_dataset(folder, split), split, n, columns, cell, select, seed,
                  labels)[0]


def write_sheet(sheet: np.ndarray, path: str | Path) -> Path:
    """Write an RGB sheet as a PNG, atomically."""
    path = Path(path)
    ok, buf = cv2.imencode(".png", cv2.cvtColor(sheet, cv2.COLOR_RGB2BGR))
    if not ok:
        raise OSError(f"could not encode {path}")
    atomic_write_bytes(path, buf.tobytes())
    return path


# --------------------------------------------------------------------------- command line

def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog=prog("show"),
        description="Draw a contact sheet of a generated dataset: images with mask outlines, "
                    "boxes (one colour per category) and captions.",
        formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    p.add_argument("folder", metavar="DIR", help="dataset folder (the generator's --out)")
    p.add_argument("--out", default=None, metavar="PNG", help="sheet file (default: DIR/sheet.png)")
    p.add_argument("--n", type=int, default=24, help="images to show at most")
    p.add_argument("--split", default="all", metavar="|".join(SPLIT_CHOICES),
                   help="which COCO file's images")
    p.add_argument("--columns", type=int, default=6, help="cells per row at most")
    p.add_argument("--cell", type=int, default=256, metavar="PX", help="cell side, pixels")
    p.add_argument("--select", default="spread", metavar="|".join(SELECT_CHOICES),
                   help="spread: evenly over the images; first: the first n; random: n drawn "
                        "with --seed")
    p.add_argument("--seed", type=int, default=0, help="seed of --select random")
    p.add_argument("--no-labels", dest="labels", action="store_false",
                   help="no caption band")
    return p


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


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    _check_params(args.n, args.columns, args.cell)
    _check_choices(args.split, args.select)
    ds = load_dataset(args.folder, args.split)
    out = Path(args.out) if args.out is not None else ds.folder / "sheet.png"
    _check_out(out)
    sheet, shown = _sheet(ds, args.split, args.n, args.columns, args.cell, args.select,
                          args.seed, args.labels)
    write_sheet(sheet, out)
    used = sorted({a.get("category_id", 1) for e in shown for a in e.annotations
                   if isinstance(a.get("category_id", 1), int)})
    legend = ", ".join(f"{ds.categories.get(c, c)} {category_colour_name(c)}" for c in used)
    print(f"{out}: {len(shown)} of {len(ds.entries)} images ({args.split}, {args.select}), "
          f"{sheet.shape[1]}x{sheet.shape[0]} px" + (f"; colours: {legend}" if legend else ""))
    return 0


if __name__ == "__main__":
    sys.exit(run_cli(main))
