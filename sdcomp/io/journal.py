"""The run's journal, ``records.jsonl``: one compact JSON record per finished image.

A run writes one *record* per image (one line)::

    {"index": 17, "split": "train",
     "image": {"id": 18, "file_name": "000017.jpg", "width": 416, "height": 416,
               "mask_file": "000017.png", "meta": {...}},
     "annotations": [{"instance_id": 1, "category_id": 1, "bbox": [x, y, w, h], "area": 123,
                      "segmentation": {"size": [H, W], "counts": "..."}, "iscrowd": 0, ...}]}

The label files (:mod:`sdcomp.io.writers`) are made from the journal at the end, at
checkpoints and after Ctrl-C, without holding the records in memory: :func:`read_journal`
keeps only ``{index: byte offset}`` and :func:`iter_records` streams records in index order.

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

from ..errors import UserError


def is_int(v: Any) -> bool:
    """Whether ``v`` is an integer (Python or numpy), not a bool."""
    return isinstance(v, (int, np.integer)) and not isinstance(v, (bool, np.bool_))


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


def dumps_compact(obj: Any) -> str:
    """Compact, one-line JSON; NaN and infinities are refused (not JSON, COCO tools choke)."""
    return json.dumps(obj, separators=(",", ":"), allow_nan=False, default=_json_default)


def _parse_record(line: bytes) -> dict | None:
    """The record on a journal line, or None when the line is not a whole record."""
    try:
        rec = json.loads(line)
    except ValueError:  # also UnicodeDecodeError
        return None
    if not isinstance(rec, dict) or not is_int(rec.get("index")):
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
            if not isinstance(rec, dict) or not is_int(rec.get("index")):
                raise ValueError("a journal record must be a dict with an integer 'index'")
            lines.append(dumps_compact(rec))
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
