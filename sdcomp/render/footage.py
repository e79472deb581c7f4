"""The user's own footage: still photos, video files, and the labelled objects in them.

A *source* is one frame a background can be cut from: a still photo, or frame ``k`` of a
video file (read with OpenCV's ``VideoCapture``, frame-accurate seeking). :func:`list_sources`
lists a folder (or one file) of them, checking every file before anything is written.

Labels (:func:`sdcomp.render.footage_labels.read_labels`) are a COCO json file or a YOLO
labels folder. A frame is
matched to its labels by its *key*: a still's file name without the extension
(``DJI_0042.jpg`` -> ``DJI_0042``), a video frame's ``<video stem>_<frame, 6 digits from 0>``
(``flight.mp4`` frame 120 -> ``flight_000120``, the name ``ffmpeg -i flight.mp4
-start_number 0 flight_%06d.png`` gives it). YOLO names a frame's label file ``<key>.txt``
(``class cx cy w h`` normalised, or ``class x1 y1 x2 y2 ...`` polygons); its class names come
from a ``data.yaml`` (``names:``) or ``classes.txt`` beside or inside the folder. The
renderer (:mod:`sdcomp.render.photos`), the realism report, ``fit`` and ``bench sim2real``
all read the user's frames through these two modules.

One rule for a frame that cannot be read, in every command: the command stops before it
writes anything, with one line naming the file and what is wrong (a UserError). The checks
of :func:`list_sources` find what a header can tell (not an image, empty, truncated, too
large, a video whose last frame does not decode); a frame that fails to decode later (its
middle damaged) stops the command the same way. Photos are read as the viewer shows them:
EXIF orientation applied, grey and 16-bit images as 8-bit RGB, CMYK converted.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from ..errors import UserError
from ..util.memory import check_fits

# FFmpeg (inside OpenCV's video reader) prints its complaints about a damaged file to stderr
# itself; sdcomp reports a bad file in one line of its own (a user's setting wins)
os.environ.setdefault("OPENCV_FFMPEG_LOGLEVEL", "-8")

IMAGE_EXTENSIONS = (".jpg", ".jpeg", ".png", ".bmp", ".tif", ".tiff", ".webp")
VIDEO_EXTENSIONS = (".mp4", ".mov", ".avi", ".mkv", ".m4v", ".mts", ".ts", ".webm", ".mpg")
#: largest frame accepted, pixels (a 150 MP photo is 450 MB decoded; a header claiming more
#: is most likely a decompression bomb, or at least not worth decoding for a background)
MAX_PIXELS = 150_000_000
#: peak bytes per pixel of reading one frame: the file's decode (3), its RGB copy (3), a
#: crop or resize of it and the float32 working copies the commands make of that (~10)
BYTES_PER_FRAME_PX = 16


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
    """(width, height) of the photo at ``path`` as it is displayed (EXIF orientation
    applied, as :func:`read_photo` decodes it), read from its header without decoding the
    pixels; UserError naming the file when it is not a readable image, is truncated (a JPEG
    or PNG that ends before its end marker) or is larger than :data:`MAX_PIXELS` (e.g. a
    decompression bomb: a small file claiming a huge image)."""
    import warnings

    from PIL import Image  # Pillow comes with matplotlib

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", Image.DecompressionBombWarning)
            with Image.open(path) as im:  # reads the header only
                w, h = im.size
                if _orientation(im) in (5, 6, 7, 8):  # turned by a quarter: shown h x w
                    w, h = h, w
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
    check_fits(w * h * BYTES_PER_FRAME_PX, f"{what}: {path} ({w} x {h} pixels)",
               "downscale it")
    if _truncated(_ends(path), path):
        raise UserError(_truncated_message(path, what))
    return w, h


def _orientation(im) -> int:
    """The EXIF orientation tag (1-8) of an open Pillow image; 1 where it has none."""
    try:
        value = im.getexif().get(0x0112, 1)
    except Exception:  # noqa: BLE001 - a damaged EXIF block: the pixels as stored
        return 1
    return int(value) if isinstance(value, int) else 1


def _ends(path: Path, n: int = 4096) -> bytes:
    """The first 8 and the last ``n`` bytes of a file (all of it when it is short)."""
    with open(path, "rb") as f:
        head = f.read(8)
        size = f.seek(0, os.SEEK_END)
        f.seek(max(8, size - n))
        return head + f.read()


def _truncated_message(path: Path, what: str) -> str:
    return (f"{what}: {path} is truncated (the file ends before the image does, e.g. an "
            f"interrupted copy); remove or replace it")


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
        if w * h > MAX_PIXELS:
            raise UserError(f"{what}: {path} has {w} x {h} pixel frames, more than "
                            f"{MAX_PIXELS // 1_000_000} megapixels; downscale it")
        check_fits(w * h * BYTES_PER_FRAME_PX, f"{what}: {path} ({w} x {h} pixel frames)",
                   f"downscale it, e.g. ffmpeg -i {path.name} -vf scale=iw/2:-2 out.mp4")
        ok, first = cap.read()
        if n <= 0 or not ok or first is None:
            raise UserError(f"{what}: {path} has no frames OpenCV can count and decode; "
                            f"re-mux it, e.g. ffmpeg -i {path.name} -c copy out.mp4")
        if n > 1:  # a file cut short still claims its frames: the last one must decode
            cap.set(cv2.CAP_PROP_POS_FRAMES, n - 1)
            ok, last = cap.read()
            if not ok or last is None:
                raise UserError(f"{what}: {path} claims {n} frames but its last one does not "
                                f"decode (truncated or damaged); re-encode it, e.g. ffmpeg -i "
                                f"{path.name} -c:v libx264 out.mp4")
        return n, first.shape[1], first.shape[0]
    finally:
        cap.release()


def media_files(path: Path, what: str, videos: bool = True) -> list[Path]:
    """The photos (and videos) of a folder, sorted (else those of its ``images/`` subfolder,
    else of that one's subfolders: a dataset's split folders), or ``[path]`` for one such
    file; UserError when there are none."""
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
    if not files:
        base = path / "images" if (path / "images").is_dir() else path
        files = listing(base) or [f for d in sorted(base.iterdir()) if d.is_dir()
                                  for f in listing(d)]
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


def _truncated(ends: bytes, path: Path) -> bool:
    """Whether the JPEG or PNG file at ``path`` stops before its image does (an interrupted
    copy). ``ends``: its first 8 and last 4096 bytes (:func:`_ends`). Where they hold no end
    marker, Pillow decodes the file to tell a cut-off image from one followed by other data
    (a phone's motion photo, a vendor's trailer)."""
    if ends[:3] == b"\xff\xd8\xff":
        marked = b"\xff\xd9" in ends[-4096:]
    elif ends[:8] == b"\x89PNG\r\n\x1a\n":
        marked = b"IEND" in ends[-4096:]
    else:
        return False
    if marked:
        return False
    from PIL import Image

    try:
        with Image.open(path) as im:
            im.load()  # raises on a truncated file (Pillow's LOAD_TRUNCATED_IMAGES is off)
    except (OSError, ValueError, SyntaxError):
        return True
    return False


def read_photo(path: Path, what: str = "--backgrounds") -> np.ndarray:
    """(H, W, 3) uint8 RGB of a photo; UserError naming it when it cannot be read, is
    truncated or does not decode."""
    try:
        raw = path.read_bytes()
    except OSError as e:
        raise UserError(f"{what}: cannot read {path} ({e.strerror}); remove or replace "
                        f"it") from None
    if _truncated(raw[:8] + raw[-4096:], path):
        raise UserError(_truncated_message(path, what))
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

    def frame(self, path: Path, k: int, what: str | None = None) -> np.ndarray:
        """(H, W, 3) uint8 RGB frame ``k`` (0-based) of the video at ``path``; UserError
        naming it (as ``what``, else the reader's) when that frame does not decode."""
        if self._pid != os.getpid():  # a forked child: never reuse the parent's captures
            self._open, self._pid = {}, os.getpid()
        cap = self._open.get(path)
        if cap is None:
            cap = self._open[path] = cv2.VideoCapture(str(path))
        if int(cap.get(cv2.CAP_PROP_POS_FRAMES)) != k:
            cap.set(cv2.CAP_PROP_POS_FRAMES, k)
        ok, bgr = cap.read()
        if not ok or bgr is None:
            raise UserError(f"{what or self.what}: cannot decode frame {k} of {path}; "
                            f"re-encode it, e.g. ffmpeg -i {path.name} -c:v libx264 out.mp4")
        return cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB)


def read_source(src: Source, videos: VideoReader, what: str = "--backgrounds") -> np.ndarray:
    """(H, W, 3) uint8 RGB pixels of a :class:`Source`; UserError naming it (as ``what``)
    when they cannot be read."""
    if src.frame is None:
        return read_photo(src.path, what)
    return videos.frame(src.path, src.frame, what)
