"""COCO annotation helpers, the run's record journal, and a streaming, atomic COCO writer.

A run writes one *record* per image into a journal, ``records.jsonl`` (one compact JSON object
per line)::

    {"index": 17, "split": "train",
     "image": {"id": 18, "file_name": "000017.jpg", "width": 416, "height": 416,
               "mask_file": "000017.png", "meta": {...}},
     "annotations": [{"instance_id": 1, "category_id": 1, "bbox": [x, y, w, h], "area": 123,
                      "segmentation": {"size": [H, W], "counts": "..."}, "iscrowd": 0, ...}]}

COCO files are written from the journal (at the end, at checkpoints, after Ctrl-C) without
holding the records in memory: :func:`read_journal` keeps only ``{index: byte offset}``, and
:func:`write_coco` streams the images, then the annotations, in index order, through a temporary
file that is renamed into place (:func:`sdcomp.fileio.atomic_path`).

A crash can leave a partial last line; readers skip it and :func:`truncate_journal` (also run
when a :class:`Journal` opens an existing file) cuts it so appends start on a fresh line.
"""

from __future__ import annotations

import json
import os
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
from pycocotools import mask as mask_utils

from .errors import UserError
from .fileio import atomic_path

MAX_INSTANCES = 999  # instance ids per image: 1..999, see annotation_id


# --- annotation helpers ------------------------------------------------------------------------

def _mask2d(mask: np.ndarray) -> np.ndarray:
    mask = np.asarray(mask)
    if mask.ndim != 2:
        raise ValueError(f"mask must be 2-D (H, W), got shape {mask.shape}")
    return mask if mask.dtype == bool else mask != 0


def mask_to_rle(mask: np.ndarray) -> dict:
    """COCO compressed RLE of an (H, W) boolean mask: ``{"size": [H, W], "counts": str}``.

    ``counts`` is the pycocotools string (ASCII) so that ``json`` can write it; pycocotools
    reads it back as it is. A non-bool mask counts its non-zero pixels.
    """
    mask = _mask2d(mask)
    rle = mask_utils.encode(np.asfortranarray(mask, dtype=np.uint8))
    return {"size": [int(rle["size"][0]), int(rle["size"][1])],
            "counts": rle["counts"].decode("ascii")}


def crop_to_rle(crop: np.ndarray, x0: int, y0: int, height: int, width: int) -> dict:
    """COCO compressed RLE of a (height, width) mask that is zero outside ``crop`` (h, w)
    bool placed with its top-left pixel at (x0, y0): equal to :func:`mask_to_rle` of the
    full mask, without building it (runs are found in the crop's columns only)."""
    crop = _mask2d(crop)
    h, w = crop.shape
    if x0 < 0 or y0 < 0 or x0 + w > width or y0 + h > height:
        raise ValueError("the crop must lie inside the mask")
    # column-major: pixel (y, x) is at x * height + y; find where runs start and stop
    col = np.zeros((w, h + 2), np.int8)
    col[:, 1:-1] = crop.T
    change = np.diff(col, axis=1)  # +1 where a run starts, -1 after it ends
    xs, ys = np.nonzero(change)
    edges = (xs + x0) * height + (ys + y0)  # already in ascending order
    if h == height:  # a run through the bottom of one column into the next is one run
        edges, n = np.unique(edges, return_counts=True)
        edges = edges[n % 2 == 1]
    end = [] if len(edges) and edges[-1] == height * width else [height * width]
    bounds = np.concatenate([[0], edges, end])
    counts = np.diff(bounds).astype(np.uint32)
    rle = mask_utils.frPyObjects({"counts": counts.tolist(), "size": [height, width]},
                                 height, width)
    return {"size": [height, width], "counts": rle["counts"].decode("ascii")}


def bbox_of(mask: np.ndarray) -> list[int]:
    """``[x, y, w, h]`` in whole pixels: the extent of the mask's True pixels.

    Raises ValueError for a mask without any True pixel.
    """
    mask = _mask2d(mask)
    rows = np.flatnonzero(mask.any(axis=1))
    if rows.size == 0:
        raise ValueError("bbox_of: the mask is empty (no True pixel)")
    cols = np.flatnonzero(mask.any(axis=0))
    y0, y1, x0, x1 = int(rows[0]), int(rows[-1]), int(cols[0]), int(cols[-1])
    return [x0, y0, x1 - x0 + 1, y1 - y0 + 1]


def _is_int(v: Any) -> bool:
    return isinstance(v, (int, np.integer)) and not isinstance(v, (bool, np.bool_))


def annotation_id(image_index: int, instance_id: int) -> int:
    """The COCO annotation id of instance ``instance_id`` (1..999) in image ``image_index``.

    ``(image_index + 1) * 1000 + instance_id``: deterministic, unique over the run and the
    same whichever split the image is in.
    """
    if not _is_int(image_index) or image_index < 0:
        raise ValueError(f"image_index must be an integer >= 0, got {image_index!r}")
    if not _is_int(instance_id) or not 1 <= instance_id <= MAX_INSTANCES:
        raise ValueError(f"instance_id must be an integer in 1..{MAX_INSTANCES}, "
                         f"got {instance_id!r}")
    return (int(image_index) + 1) * 1000 + int(instance_id)


# --- the journal -------------------------------------------------------------------------------

def _json_default(obj: Any) -> Any:
    """Let records hold numpy scalars and arrays."""
    if isinstance(obj, np.bool_):
        return bool(obj)
    if isinstance(obj, np.integer):
        return int(obj)
    if isinstance(obj, np.floating):
        return float(obj)
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    raise TypeError(f"Object of type {type(obj).__name__} is not JSON serializable")


def _dumps(obj: Any) -> str:
    """Compact, one-line JSON; NaN and infinities are refused (not JSON, COCO tools choke)."""
    return json.dumps(obj, separators=(",", ":"), allow_nan=False, default=_json_default)


def _parse_record(line: bytes) -> dict | None:
    """The record on a journal line, or None when the line is not a whole record."""
    try:
        rec = json.loads(line)
    except ValueError:  # also UnicodeDecodeError
        return None
    if not isinstance(rec, dict) or not _is_int(rec.get("index")):
        return None
    return rec


class Journal:
    """Append-only JSON-lines file of records.

    ``Journal(path)`` opens the file for appending, creating it; an existing file first has a
    partial last line (a crash mid-write) cut, as :func:`truncate_journal` does. Use as a
    context manager or call :meth:`close`.
    """

    def __init__(self, path: str | Path):
        self.path = Path(path)
        if self.path.exists():
            truncate_journal(self.path)
        self._file = open(self.path, "ab")

    def append(self, records: Iterable[dict]) -> None:
        """Write the records, one line each, then flush and fsync once.

        All records are serialised before anything is written, so a record that cannot be
        (not a dict with an integer "index", not JSON-able, NaN) raises ValueError/TypeError
        and leaves the file as it was.
        """
        lines = []
        for rec in records:
            if not isinstance(rec, dict) or not _is_int(rec.get("index")):
                raise ValueError("a journal record must be a dict with an integer 'index'")
            lines.append(_dumps(rec))
        if not lines:
            return
        start = self._file.tell()
        try:
            self._file.write(("\n".join(lines) + "\n").encode("utf-8"))
            self._file.flush()
            os.fsync(self._file.fileno())
        except BaseException:  # disk full, Ctrl-C: leave no half record for the next append
            self._cut(start)
            raise

    def _cut(self, size: int) -> None:
        """Drop what a failed append wrote or still buffers: the file ends at ``size``."""
        try:
            self._file.close()  # may fail again flushing the buffer: the cut follows anyway
        except OSError:
            pass
        try:
            os.truncate(self.path, size)
        except OSError:
            pass  # a partial last line then remains, which readers skip and reopening cuts
        self._file = open(self.path, "ab")
        if self._file.tell() != size:
            truncate_journal(self.path)

    def close(self) -> None:
        self._file.close()

    @property
    def closed(self) -> bool:
        return self._file.closed

    def __enter__(self) -> Journal:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def read_journal(path: str | Path) -> dict[int, int]:
    """``{index: byte offset of its line}`` from one streaming pass over the journal.

    Blank lines are skipped, and so is a final line that is not a whole record (a crash
    mid-write). When an index appears more than once the later line wins. A damaged line
    anywhere else raises :class:`~sdcomp.errors.UserError`.
    """
    path = Path(path)
    offsets: dict[int, int] = {}
    bad: tuple[int, int] | None = None  # (line number, offset) of an unreadable line
    pos = 0
    with open(path, "rb") as f:
        for lineno, line in enumerate(f, 1):
            if bad is not None:  # an unreadable line that was not the last one
                break
            if line.strip():
                rec = _parse_record(line)
                if rec is None:
                    bad = (lineno, pos)
                else:
                    offsets[int(rec["index"])] = pos
            pos += len(line)
        else:
            return offsets  # at most the final line was unreadable: skipped
    raise UserError(f"{path}: line {bad[0]} (byte {bad[1]}) is not a journal record; the "
                    "journal is damaged: remove that line, or start the run afresh")


def truncate_journal(path: str | Path) -> None:
    """Make the journal end with a newline, so appends start on a fresh line.

    A trailing partial line (no newline at the end) is cut, unless it is a whole record that
    only misses its newline: then the newline is added, so the record :func:`read_journal`
    reports is kept.
    """
    with open(path, "r+b") as f:
        end = f.seek(0, os.SEEK_END)
        if end == 0:
            return
        f.seek(end - 1)
        if f.read(1) == b"\n":
            return
        start, block = end, 1 << 16  # find the last newline, reading backwards
        while start > 0:
            lo = max(0, start - block)
            f.seek(lo)
            chunk = f.read(start - lo)
            nl = chunk.rfind(b"\n")
            if nl >= 0:
                start = lo + nl + 1
                break
            start = lo
        f.seek(start)
        tail = f.read()
        if tail.strip() and _parse_record(tail) is not None:
            f.seek(end)
            f.write(b"\n")
        else:
            f.truncate(start)
        f.flush()
        os.fsync(f.fileno())


def iter_records(path: str | Path, offsets: dict[int, int],
                 split: str | None = None) -> Iterator[dict]:
    """Yield the records at ``offsets`` in ascending index order, only ``split`` if given.

    Lines appended after ``offsets`` was read do not disturb it (the offsets stay valid).
    """
    path = Path(path)
    with open(path, "rb") as f:
        for index in sorted(offsets):
            off = offsets[index]
            if f.tell() != off:
                f.seek(off)
            rec = _parse_record(f.readline())
            if rec is None or rec["index"] != index:
                raise UserError(f"{path}: no record for index {index} at byte {off}; the "
                                "journal changed since it was read")
            if split is None or rec.get("split") == split:
                yield rec


# --- COCO files --------------------------------------------------------------------------------

def _check_categories(categories: list[dict]) -> None:
    seen = set()
    for cat in categories:
        cid = cat.get("id") if isinstance(cat, dict) else None
        if not _is_int(cid) or cid < 1 or cid in seen or "name" not in cat:
            raise ValueError("categories must be dicts with a unique integer 'id' >= 1 and "
                             f"a 'name', got {cat!r}")
        seen.add(cid)


def write_coco(path: str | Path, journal_path: str | Path, offsets: dict[int, int],
               split: str | None, categories: list[dict], info: dict) -> dict:
    """Write the COCO JSON file of one split from the journal; return its counts.

    The file is ``{"info", "licenses": [], "categories", "images", "annotations"}``: the images
    of ``split`` (None: all records) in index order, then their annotations, each the record's
    annotation plus ``"id": annotation_id(index, instance_id)`` and ``"image_id"``. Two
    streaming passes over the journal, nothing held; written to a temporary file renamed onto
    ``path``, so a crash never leaves a half file. The output depends only on the records,
    not on their order in the journal. Returns ``{"images": n, "annotations": m}``.
    """
    _check_categories(categories)
    n_images = n_anns = 0
    with atomic_path(path) as tmp, open(tmp, "w", encoding="utf-8") as out:
        out.write(f'{{"info":{_dumps(info)},"licenses":[],"categories":{_dumps(categories)},'
                  '"images":[')
        for rec in iter_records(journal_path, offsets, split):
            out.write(("," if n_images else "") + _dumps(rec["image"]))
            n_images += 1
        out.write('],"annotations":[')
        for rec in iter_records(journal_path, offsets, split):
            image_id, seen = rec["image"]["id"], set()
            for ann in rec.get("annotations", ()):
                inst = ann.get("instance_id")
                if inst in seen:
                    raise UserError(f"{journal_path}: record {rec['index']} has instance_id "
                                    f"{inst} twice")
                seen.add(inst)
                full = {"id": annotation_id(rec["index"], inst), "image_id": image_id}
                full.update((k, v) for k, v in ann.items() if k not in full)
                out.write(("," if n_anns else "") + _dumps(full))
                n_anns += 1
        out.write("]}\n")
        out.flush()
        os.fsync(out.fileno())
    return {"images": n_images, "annotations": n_anns}
