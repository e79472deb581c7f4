"""The labels of the user's footage: a COCO json file or a YOLO labels folder, by frame key
(see :mod:`sdcomp.render.footage`: a photo's file name without extension, a video frame's
``<video stem>_<frame:06d>``). YOLO class k is category k + 1 (as sdcomp writes them); its
names come from a ``data.yaml`` (``names:``) or ``classes.txt`` beside or inside the folder.
"""

from __future__ import annotations

import json
import math
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import UserError


@dataclass(frozen=True)
class FrameLabels:
    """The labelled objects of one frame: ``boxes`` (k, 4) float64 x, y, w, h and
    ``categories`` (k,) int64 category ids; ``size`` (width, height) the boxes' pixels
    refer to, or None when they are fractions of the frame (YOLO)."""

    boxes: np.ndarray
    categories: np.ndarray
    size: tuple[int, int] | None = None
    file_name: str = ""
    meta: dict = field(default_factory=dict)  # the COCO image's "meta" (altitude, pitch...)

    def pixels(self, width: int, height: int) -> np.ndarray:
        """(k, 4) float64 x, y, w, h in the pixels of a ``width`` x ``height`` frame (boxes
        of a frame labelled at another size are scaled)."""
        sx, sy = (width, height) if self.size is None else (width / self.size[0],
                                                            height / self.size[1])
        return self.boxes * np.array([sx, sy, sx, sy])


@dataclass
class Labels:
    """Labelled frames by key (see the module docstring), category names by id, the file or
    folder they were read from and its ``kind``: "coco" (a frame it does not list is
    unlabelled: its objects are unknown) or "yolo" (a frame without a label file has none).
    """

    frames: dict[str, FrameLabels] = field(default_factory=dict)
    categories: dict[int, str] = field(default_factory=dict)
    source: str = ""
    kind: str = "coco"

    def of(self, key: str) -> FrameLabels | None:
        return self.frames.get(key)


def read_labels(path: str | Path, what: str = "--background-labels") -> Labels:
    """The labels in a COCO json file or a YOLO labels folder (UserError naming ``what``
    and the file when they cannot be read)."""
    p = Path(path)
    if p.is_dir():
        return _yolo_labels(p, what)
    if not p.is_file():
        raise UserError(f"{what} {p}: no such file or folder; give a COCO json file or a "
                        f"YOLO labels folder")
    return _coco_labels(p, what)


def _coco_labels(path: Path, what: str) -> Labels:
    try:
        coco = json.loads(path.read_bytes())
    except OSError as e:
        raise UserError(f"{what} {path}: cannot read it ({e.strerror})") from None
    except (ValueError, UnicodeDecodeError) as e:
        first = str(e).splitlines()[0] if str(e) else type(e).__name__
        raise UserError(f"{what} {path}: not valid JSON ({first}); give a COCO file") from None
    if not (isinstance(coco, dict) and isinstance(coco.get("images"), list)
            and isinstance(coco.get("annotations", []), list)):
        raise UserError(f"{what} {path}: not a COCO file (needs an 'images' and an "
                        f"'annotations' list)")
    if not isinstance(coco.get("categories") or [], list):
        raise UserError(f"{what} {path}: 'categories' is not a list of {{id, name}} records")
    cats = {int(c["id"]): str(c.get("name", c["id"])) for c in coco.get("categories") or []
            if isinstance(c, dict) and _is_int(c.get("id"))}
    images = _coco_images(coco["images"], path, what)
    by_image: dict[int, list] = {}
    for k, a in enumerate(coco.get("annotations") or []):
        image_id, row = _coco_annotation(a, k, path, what)
        if image_id not in images:
            raise UserError(f"{what} {path}: {_name(a, k)} refers to image_id {image_id!r}, "
                            f"which no image record has; fix the ids or give the matching "
                            f"file")
        if cats and int(row[4]) not in cats:
            raise UserError(f"{what} {path}: {_name(a, k)} has category_id {int(row[4])}, "
                            f"which is not among its categories {sorted(cats)}")
        by_image.setdefault(image_id, []).append(row)
    out = Labels(categories=cats, source=str(path))
    for image_id, im in images.items():
        rows = np.asarray(by_image.get(image_id, []), np.float64).reshape(-1, 5)
        w, h = im.get("width"), im.get("height")
        size = ((int(w), int(h)) if isinstance(w, (int, float)) and isinstance(h, (int, float))
                and _is_int(w) and _is_int(h) and w > 0 and h > 0 else None)
        name = im["file_name"]
        key = Path(name.replace("\\", "/")).stem  # only the stem: a path in it is never opened
        meta: dict = im["meta"] if isinstance(im.get("meta"), dict) else {}
        out.frames[key] = FrameLabels(rows[:, :4], rows[:, 4].astype(np.int64), size, name,
                                      meta)
    return out


def _is_int(v: object) -> bool:
    """Whether ``v`` is a whole number (an int, or a float such as 3.0 some tools write)."""
    return (isinstance(v, int) and not isinstance(v, bool)) or (
        isinstance(v, float) and v.is_integer())


def _name(record: object, k: int) -> str:
    """How an error names the ``k``-th (0-based) annotation: by its id where it has one."""
    rid = record.get("id") if isinstance(record, dict) else None
    return f"annotation id {rid}" if _is_int(rid) else f"annotation #{k + 1}"


def _coco_images(records: list, path: Path, what: str) -> dict[int, dict]:
    """A COCO file's image records by id; UserError for a record without an integer ``id``
    or a ``file_name``, a repeated id, or two records whose file names share a stem (frames
    are matched by it)."""
    out: dict[int, dict] = {}
    stems: dict[str, str] = {}
    for k, im in enumerate(records):
        if not (isinstance(im, dict) and isinstance(im.get("file_name"), str)):
            raise UserError(f"{what} {path}: image record #{k + 1} has no 'file_name'")
        if not _is_int(im.get("id")):
            raise UserError(f"{what} {path}: image {im['file_name']!r} has no integer 'id'")
        im = {**im, "id": int(im["id"])}
        if im["id"] in out:
            raise UserError(f"{what} {path}: image id {im['id']} is used twice "
                            f"({out[im['id']]['file_name']!r}, {im['file_name']!r})")
        stem = Path(im["file_name"].replace("\\", "/")).stem
        if stem in stems:
            raise UserError(f"{what} {path}: images {stems[stem]!r} and {im['file_name']!r} "
                            f"share the name {stem!r}; frames are matched by file name "
                            f"without folder and extension: rename one")
        stems[stem] = im["file_name"]
        out[im["id"]] = im
    return out


def _coco_annotation(a: object, k: int, path: Path, what: str) -> tuple[int, list[float]]:
    """(image_id, [x, y, w, h, category_id]) of the ``k``-th annotation record; UserError
    naming it when a field is missing, not a number, not finite or a size is negative."""
    if not isinstance(a, dict):
        raise UserError(f"{what} {path}: annotation #{k + 1} is not a record ({a!r:.40})")
    box = a.get("bbox")
    if not (isinstance(box, (list, tuple)) and len(box) >= 4):
        raise UserError(f"{what} {path}: {_name(a, k)} has no 'bbox' [x, y, w, h]")
    for key in ("image_id", "category_id"):
        if not _is_int(a.get(key)):
            raise UserError(f"{what} {path}: {_name(a, k)} has no integer {key!r}")
    try:
        row = [float(v) for v in box[:4]] + [float(a["category_id"])]
    except (TypeError, ValueError):
        raise UserError(f"{what} {path}: a bbox is not numbers: {box!r}") from None
    if not all(map(math.isfinite, row)):
        raise UserError(f"{what} {path}: a bbox is not finite: {box!r}")
    if row[2] < 0 or row[3] < 0:
        raise UserError(f"{what} {path}: {_name(a, k)} has a negative size, bbox {box!r} "
                        f"(COCO boxes are [x, y, width, height])")
    return int(a["image_id"]), row


def _yolo_labels(folder: Path, what: str) -> Labels:
    files = sorted(folder.glob("*.txt"))
    files = [f for f in files if f.name != "classes.txt"]
    if not files and (folder / "labels").is_dir():
        folder = folder / "labels"
        files = sorted(f for f in folder.glob("*.txt") if f.name != "classes.txt")
    if not files:
        raise UserError(f"{what} {folder}: no YOLO label files (<frame>.txt) in it")
    out = Labels(categories=yolo_names(folder), source=str(folder), kind="yolo")
    for f in files:
        rows = []
        try:
            text = f.read_text(encoding="utf-8")
        except (OSError, UnicodeDecodeError) as e:
            raise UserError(f"{what}: cannot read {f} ({e})") from None
        for n, line in enumerate(text.splitlines(), 1):
            parts = line.split()
            if not parts:
                continue
            try:
                cls, vals = int(parts[0]), [float(v) for v in parts[1:]]
            except ValueError:
                cls, vals = -1, []
            if cls < 0 or len(vals) < 4 or (len(vals) > 4 and len(vals) % 2) or not all(
                    map(math.isfinite, vals)) or (len(vals) == 4 and min(vals[2:]) < 0):
                raise UserError(f"{what}: {f}:{n}: expected 'class cx cy w h' (normalised, "
                                f"sizes >= 0) "
                                f"or 'class x1 y1 x2 y2 ...', got {line.strip()[:60]!r}")
            if len(vals) == 4:
                cx, cy, bw, bh = vals
                rows.append([cx - bw / 2, cy - bh / 2, bw, bh, cls + 1])
            else:
                xs, ys = np.asarray(vals[0::2]), np.asarray(vals[1::2])
                rows.append([xs.min(), ys.min(), np.ptp(xs), np.ptp(ys), cls + 1])
        a = np.asarray(rows, np.float64).reshape(-1, 5)
        out.frames[f.stem] = FrameLabels(a[:, :4], a[:, 4].astype(np.int64), None, f.name)
    used = {int(c) for fl in out.frames.values() for c in fl.categories}
    for c in sorted(used - set(out.categories)):
        out.categories[c] = str(c - 1)  # no name given: the class number
    return out


def yolo_names(folder: Path) -> dict[int, str]:
    """Category names by id (YOLO class k = id k + 1) from the ``data.yaml`` (``names:`` as a
    list or a mapping) or ``classes.txt`` in ``folder`` or its parent; {} when none."""
    for d in (folder, folder.parent):
        classes = d / "classes.txt"
        if classes.is_file():
            names = [n.strip() for n in classes.read_text(errors="replace").splitlines()]
            return {k + 1: n for k, n in enumerate(names) if n}
        for name in ("data.yaml", "data.yml", "dataset.yaml"):
            if (d / name).is_file():
                return _yaml_names((d / name).read_text(errors="replace"))
    return {}


def _yaml_names(text: str) -> dict[int, str]:
    """``names`` of an Ultralytics data.yaml: ``names: [a, b]``, a block list ``- a`` or a
    block mapping ``0: a`` (the common forms; no YAML library needed)."""
    lines = text.splitlines()
    for i, line in enumerate(lines):
        m = re.match(r"^names\s*:\s*(.*)$", line)
        if not m:
            continue
        rest = m.group(1).split("#")[0].strip()
        if rest.startswith("["):
            items = [s.strip().strip("'\"") for s in rest.strip("[]").split(",")]
            return {k + 1: n for k, n in enumerate(items) if n}
        if rest.startswith("{"):
            pairs = [s.split(":", 1) for s in rest.strip("{}").split(",") if ":" in s]
            return {int(a.strip()) + 1: b.strip().strip("'\"") for a, b in pairs
                    if a.strip().isdigit()}
        out: dict[int, str] = {}
        k = 0
        for sub in lines[i + 1:]:
            if not sub.startswith((" ", "\t")) or not sub.strip():
                if sub.strip():
                    break
                continue
            s = sub.strip()
            if s.startswith("-"):
                out[k + 1] = s[1:].strip().strip("'\"")
                k += 1
            elif ":" in s and s.split(":", 1)[0].strip().isdigit():
                a, b = s.split(":", 1)
                out[int(a) + 1] = b.strip().strip("'\"")
        return out
    return {}
