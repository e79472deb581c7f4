"""The user's own footage: still photos, video files, and the labelled objects in them.

A *source* is one frame a background can be cut from: a still photo, or frame ``k`` of a
video file (read with OpenCV's ``VideoCapture``, frame-accurate seeking). :func:`list_sources`
lists a folder (or one file) of them, checking every file before anything is written.

Labels (:func:`read_labels`) are a COCO json file or a YOLO labels folder. A frame is
matched to its labels by its *key*: a still's file name without the extension
(``DJI_0042.jpg`` -> ``DJI_0042``), a video frame's ``<video stem>_<frame, 6 digits from 0>``
(``flight.mp4`` frame 120 -> ``flight_000120``, the name ``ffmpeg -i flight.mp4
-start_number 0 flight_%06d.png`` gives it). YOLO names a frame's label file ``<key>.txt``
(``class cx cy w h`` normalised, or ``class x1 y1 x2 y2 ...`` polygons); its class names come
from a ``data.yaml`` (``names:``) or ``classes.txt`` beside or inside the folder. The
renderer (:mod:`sdcomp.render.photos`), the realism report and ``bench sim2real`` all read the
user's frames through this module.
"""

from __future__ import annotations

import json
import math
import re
from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np

from ..errors import UserError

IMAGE_EXTENSIONS = (".jpg", ".jpeg", ".png", ".bmp", ".tif", ".tiff", ".webp")
VIDEO_EXTENSIONS = (".mp4", ".mov", ".avi", ".mkv", ".m4v", ".mts", ".ts", ".webm", ".mpg")
#: largest frame accepted, pixels (a 150 MP photo is 450 MB decoded; a header claiming more
#: is most likely a decompression bomb, or at least not worth decoding for a background)
MAX_PIXELS = 150_000_000


@dataclass(frozen=True)
class Source:
    """One frame of the user's footage: ``path`` (a photo, or a video when ``frame`` is its
    0-based frame index), ``key`` (how labels name it, see the module docstring) and its
    ``width`` x ``height`` in pixels."""

    path: Path
    frame: int | None
    key: str
    width: int
    height: int


def frame_key(path: Path, frame: int | None) -> str:
    """The label key of a photo (its stem) or of a video's frame (``<stem>_<frame:06d>``)."""
    return path.stem if frame is None else f"{path.stem}_{frame:06d}"


def is_video(path: Path) -> bool:
    return path.suffix.lower() in VIDEO_EXTENSIONS


def check_photo(path: Path, what: str = "--backgrounds") -> tuple[int, int]:
    """(width, height) from the header of the photo at ``path``, read without decoding the
    pixels; UserError naming the file when it is not a readable image or is larger than
    :data:`MAX_PIXELS` (e.g. a decompression bomb: a small file claiming a huge image)."""
    import warnings

    from PIL import Image  # Pillow comes with matplotlib

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", Image.DecompressionBombWarning)
            with Image.open(path) as im:  # reads the header only
                w, h = im.size
    except Image.DecompressionBombError:
        w = h = -1  # larger than Pillow will even open
    except (OSError, ValueError, SyntaxError, Image.DecompressionBombWarning):
        raise UserError(f"{what}: cannot read {path} as an image; remove or replace "
                        f"it") from None
    if w < 0 or w * h > MAX_PIXELS:
        size = f"{w} x {h} pixels" if w >= 0 else "over Pillow's bomb limit"
        raise UserError(f"{what}: {path} claims {size}, more than "
                        f"{MAX_PIXELS // 1_000_000} megapixels (a decompression bomb?); "
                        f"downscale or remove it")
    if not cv2.haveImageReader(str(path)):
        raise UserError(f"{what}: cannot read {path} as an image; remove or replace it")
    return w, h


def video_info(path: Path, what: str = "--backgrounds") -> tuple[int, int, int]:
    """(frame count, width, height) of a video file; UserError naming the file when OpenCV
    cannot open it, count its frames or decode its first frame."""
    cap = cv2.VideoCapture(str(path))
    try:
        if not cap.isOpened():
            raise UserError(f"{what}: cannot open {path} as a video (OpenCV's FFmpeg reader); "
                            f"convert it, e.g. ffmpeg -i {path.name} -c:v libx264 out.mp4")
        n = int(cap.get(cv2.CAP_PROP_FRAME_COUNT))
        w, h = int(cap.get(cv2.CAP_PROP_FRAME_WIDTH)), int(cap.get(cv2.CAP_PROP_FRAME_HEIGHT))
        ok, first = cap.read()
        if n <= 0 or not ok or first is None:
            raise UserError(f"{what}: {path} has no frames OpenCV can count and decode; "
                            f"re-mux it, e.g. ffmpeg -i {path.name} -c copy out.mp4")
        if w * h > MAX_PIXELS:
            raise UserError(f"{what}: {path} has {w} x {h} pixel frames, more than "
                            f"{MAX_PIXELS // 1_000_000} megapixels; downscale it")
        return n, first.shape[1], first.shape[0]
    finally:
        cap.release()


def media_files(path: Path, what: str, videos: bool = True) -> list[Path]:
    """The photos (and videos) of a folder, sorted (its ``images/`` subfolder when it has
    none itself), or ``[path]`` for one such file; UserError when there are none."""
    kinds = IMAGE_EXTENSIONS + (VIDEO_EXTENSIONS if videos else ())
    names = ", ".join(kinds)
    if path.is_file():
        if path.suffix.lower() not in kinds:
            raise UserError(f"{what} {path}: not a photo or video file ({names})")
        return [path]
    if not path.is_dir():
        raise UserError(f"{what} {path}: no such file or folder")

    def listing(d: Path) -> list[Path]:
        try:
            return sorted(p for p in d.iterdir() if p.suffix.lower() in kinds and p.is_file())
        except OSError as e:
            raise UserError(f"{what} {d}: cannot read the folder ({e.strerror})") from None

    files = listing(path)
    if not files and (path / "images").is_dir():
        files = listing(path / "images")
    if not files:
        raise UserError(f"{what} {path}: no {'photos or videos' if videos else 'images'} in "
                        f"it; put frames ({names}) there")
    return files


def list_sources(path: str | Path, what: str = "--backgrounds") -> list[Source]:
    """Every frame of a folder (or file) of photos and videos, in a fixed order: files
    sorted by name, a video's frames in order. Every file is checked first (headers,
    video frame counts): a bad one is a UserError naming it."""
    out: list[Source] = []
    for p in media_files(Path(path), what):
        if is_video(p):
            n, w, h = video_info(p, what)
            out += [Source(p, k, frame_key(p, k), w, h) for k in range(n)]
        else:
            w, h = check_photo(p, what)
            out.append(Source(p, None, frame_key(p, None), w, h))
    return out


def _truncated(data: bytes) -> bool:
    """Whether a JPEG or PNG file stops before its end marker (an interrupted copy)."""
    if data[:3] == b"\xff\xd8\xff":
        return b"\xff\xd9" not in data[-4096:]
    if data[:8] == b"\x89PNG\r\n\x1a\n":
        return b"IEND" not in data[-4096:]
    return False


def read_photo(path: Path, what: str = "--backgrounds") -> np.ndarray:
    """(H, W, 3) uint8 RGB of a photo; UserError naming it when it cannot be read, is
    truncated or does not decode."""
    try:
        raw = path.read_bytes()
    except OSError as e:
        raise UserError(f"{what}: cannot read {path} ({e.strerror}); remove or replace "
                        f"it") from None
    if _truncated(raw):
        raise UserError(f"{what}: {path} is truncated (the file ends before the image "
                        f"does); remove or replace it")
    data = cv2.imdecode(np.frombuffer(raw, np.uint8), cv2.IMREAD_COLOR)
    if data is None:
        raise UserError(f"{what}: cannot read {path} as an image; remove or replace it")
    return cv2.cvtColor(data, cv2.COLOR_BGR2RGB)


class VideoReader:
    """Frames of video files by index, one ``VideoCapture`` per file and process (a capture
    inherited through ``fork`` would share its file offset with the parent's)."""

    def __init__(self, what: str = "--backgrounds"):
        self.what = what
        self._open: dict[Path, cv2.VideoCapture] = {}
        self._pid = 0

    def __getstate__(self) -> dict:
        return {"what": self.what}

    def __setstate__(self, state: dict) -> None:
        self.__init__(state["what"])  # type: ignore[misc]

    def frame(self, path: Path, k: int) -> np.ndarray:
        """(H, W, 3) uint8 RGB frame ``k`` (0-based) of the video at ``path``."""
        import os

        if self._pid != os.getpid():  # a forked child: never reuse the parent's captures
            self._open, self._pid = {}, os.getpid()
        cap = self._open.get(path)
        if cap is None:
            cap = self._open[path] = cv2.VideoCapture(str(path))
        if int(cap.get(cv2.CAP_PROP_POS_FRAMES)) != k:
            cap.set(cv2.CAP_PROP_POS_FRAMES, k)
        ok, bgr = cap.read()
        if not ok or bgr is None:
            raise UserError(f"{self.what}: cannot decode frame {k} of {path}; re-encode it, "
                            f"e.g. ffmpeg -i {path.name} -c:v libx264 out.mp4")
        return cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB)


def read_source(src: Source, videos: VideoReader, what: str = "--backgrounds") -> np.ndarray:
    """(H, W, 3) uint8 RGB pixels of a :class:`Source`."""
    if src.frame is None:
        return read_photo(src.path, what)
    return videos.frame(src.path, src.frame)


# --------------------------------------------------------------------------- labels


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
    cats = {int(c["id"]): str(c.get("name", c["id"])) for c in coco.get("categories") or []
            if isinstance(c, dict) and isinstance(c.get("id"), int)}
    by_image: dict[object, list] = {}
    for a in coco.get("annotations") or []:
        box = a.get("bbox") if isinstance(a, dict) else None
        if not (isinstance(box, (list, tuple)) and len(box) >= 4):
            raise UserError(f"{what} {path}: an annotation has no 'bbox' [x, y, w, h]")
        try:
            row = [float(v) for v in box[:4]] + [float(a.get("category_id", 0))]
        except (TypeError, ValueError):
            raise UserError(f"{what} {path}: a bbox is not numbers: {box!r}") from None
        if not all(map(math.isfinite, row)):
            raise UserError(f"{what} {path}: a bbox is not finite: {box!r}")
        by_image.setdefault(a.get("image_id"), []).append(row)
    out = Labels(categories=cats, source=str(path))
    for im in coco["images"]:
        if not (isinstance(im, dict) and isinstance(im.get("file_name"), str)):
            raise UserError(f"{what} {path}: an image record has no 'file_name'")
        rows = np.asarray(by_image.get(im.get("id"), []), np.float64).reshape(-1, 5)
        w, h = im.get("width"), im.get("height")
        size = (int(w), int(h)) if isinstance(w, int) and isinstance(h, int) and w > 0 and h > 0 \
            else None
        name = im["file_name"]
        key = Path(name.replace("\\", "/")).stem
        meta: dict = im["meta"] if isinstance(im.get("meta"), dict) else {}
        out.frames[key] = FrameLabels(rows[:, :4], rows[:, 4].astype(np.int64), size, name,
                                      meta)
    return out


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
                    map(math.isfinite, vals)):
                raise UserError(f"{what}: {f}:{n}: expected 'class cx cy w h' (normalised) "
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
