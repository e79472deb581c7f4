"""Flight logs beside the user's footage, for ``sdcomp fit``'s geometry: the height above
take-off and the gimbal pitch of a frame, as SeaDronesSee-style meta
(``height_above_takeoff(meter)``, ``gimbal_pitch(degrees)``: degrees below the horizon).

- A DJI photo carries them in its XMP (``drone-dji:RelativeAltitude``,
  ``drone-dji:GimbalPitchDegree``): :func:`dji_meta`.
- A DJI video is recorded with a subtitle file beside it (``DJI_0042.MP4`` and
  ``DJI_0042.SRT``): one entry per frame (newer models) or per second (older ones), each a
  time span and a line of flight data: the height above take-off as ``rel_alt: 36.200``
  (older models: ``H 36.2m``) and, on some models, the gimbal as ``gb_pitch: -36.1``
  (negative below the horizon, as in the XMP). :func:`srt_meta` gives a video frame the
  entry whose span holds the frame's middle (frame ``k`` at ``(k + 0.5) / fps`` seconds).
  The absolute ``altitude:`` / ``abs_alt:`` (above sea level, by GPS) is not read.
- A photo's field of view comes from its EXIF 35 mm equivalent focal length
  (``FocalLengthIn35mmFilm``, which DJI and most cameras write): :func:`photo_fov`.
"""

from __future__ import annotations

import functools
import math
import re
from pathlib import Path

import cv2
import numpy as np

from ..report.realism.sea import ALTITUDE_KEY, PITCH_KEY

XMP_HEAD = 1 << 17  #: bytes of a photo searched for DJI's XMP attributes
#: DJI XMP attributes (drone-dji namespace) -> (meta key, sign): DJI's gimbal pitch is
#: negative below the horizon (-90 straight down), sdcomp's positive
DJI_XMP = {"RelativeAltitude": (ALTITUDE_KEY, 1.0), "GimbalPitchDegree": (PITCH_KEY, -1.0)}
_XMP_VALUE = re.compile(rb'drone-dji:(RelativeAltitude|GimbalPitchDegree)\s*=\s*"([^"]*)"|'
                        rb'<drone-dji:(RelativeAltitude|GimbalPitchDegree)>([^<]*)<')
EXIF_IFD, FOCAL_35MM = 0x8769, 0xA405  #: EXIF sub-IFD and its FocalLengthIn35mmFilm tag
FULL_FRAME_DIAGONAL = 43.267  #: mm: the diagonal of a 36 x 24 mm frame
MAX_SRT_BYTES = 64 << 20  #: larger subtitle files are not read (an hour at 30 fps: ~30 MB)
_NUMBER = r"([-+]?\d+(?:\.\d+)?)"
_TIME = r"(\d+):(\d\d):(\d\d)[,.](\d{1,3})"
_SRT_SPAN = re.compile(_TIME + r"\s*-->\s*" + _TIME)
#: SRT flight data -> (meta key, sign)
_SRT_FIELDS = (
    (re.compile(r"rel_alt\s*:\s*" + _NUMBER + r"(?![\w.])"), ALTITUDE_KEY, 1.0),
    (re.compile(r"(?<![\w.])H\s*:?\s*" + _NUMBER + r"\s*m\b"), ALTITUDE_KEY, 1.0),
    (re.compile(r"gb_pitch\s*:\s*" + _NUMBER + r"(?![\w.])"), PITCH_KEY, -1.0),
)


def dji_meta(path: Path) -> dict[str, float]:
    """The meta of a photo from its DJI XMP (``drone-dji:RelativeAltitude``,
    ``GimbalPitchDegree``, as attributes or elements in its first :data:`XMP_HEAD` bytes);
    {} when it has none or the file cannot be read."""
    try:
        with open(path, "rb") as fh:
            head = fh.read(XMP_HEAD)
    except OSError:
        return {}
    out = {}
    for m in _XMP_VALUE.finditer(head):
        name = (m.group(1) or m.group(3)).decode()
        text = (m.group(2) if m.group(1) else m.group(4)).decode("ascii", "replace")
        try:
            value = float(text.strip())
        except ValueError:
            continue
        key, sign = DJI_XMP[name]
        if math.isfinite(value):
            out[key] = sign * value
    return out


def photo_fov(path: Path) -> float | None:
    """The diagonal field of view (degrees) of the photo at ``path`` from its EXIF 35 mm
    equivalent focal length ``f``: ``2 atan(43.27 / (2 f))``; None when it has none (or the
    file cannot be read)."""
    from PIL import Image  # Pillow comes with matplotlib

    try:
        with Image.open(path) as im:
            tag = im.getexif().get_ifd(EXIF_IFD).get(FOCAL_35MM)
    except (OSError, ValueError, SyntaxError):
        return None
    try:
        f = float(tag) if tag is not None else 0.0
    except (TypeError, ValueError):
        return None
    if not 1.0 <= f <= 5000.0:  # 0: unknown, as EXIF writes it
        return None
    return math.degrees(2.0 * math.atan(FULL_FRAME_DIAGONAL / (2.0 * f)))


def srt_path(video: Path) -> Path | None:
    """The subtitle file recorded beside ``video`` (its stem with ``.SRT`` or ``.srt``, in
    any case), None when there is none."""
    for suffix in (".SRT", ".srt"):
        candidate = video.with_suffix(suffix)
        if candidate.is_file():
            return candidate
    try:
        return next((p for p in video.parent.iterdir() if p.stem == video.stem
                     and p.suffix.lower() == ".srt" and p.is_file()), None)
    except OSError:
        return None


def parse_srt(text: str) -> tuple[np.ndarray, np.ndarray, list[dict[str, float]]]:
    """The entries of a DJI subtitle file: (starts, ends) (n,) float64 seconds and each
    entry's meta (see the module docstring; {} for an entry without flight data). Blocks
    without a time span are skipped; a malformed number is left out of its entry."""
    starts, ends, metas = [], [], []
    for block in re.split(r"\r?\n\s*\r?\n", text):
        span = _SRT_SPAN.search(block)
        if span is None:
            continue
        g = [int(x) for x in span.groups()]
        starts.append(g[0] * 3600 + g[1] * 60 + g[2] + g[3] / 10 ** len(span.group(4)))
        ends.append(g[4] * 3600 + g[5] * 60 + g[6] + g[7] / 10 ** len(span.group(8)))
        data = block[span.end():]
        meta: dict[str, float] = {}
        for pattern, key, sign in _SRT_FIELDS:
            m = pattern.search(data)
            if m is not None and key not in meta:
                value = float(m.group(1))
                if math.isfinite(value):
                    meta[key] = sign * value
        metas.append(meta)
    return np.array(starts, np.float64), np.array(ends, np.float64), metas


@functools.lru_cache(maxsize=32)
def _entries(path: str, stamp: tuple[int, int]
             ) -> tuple[np.ndarray, np.ndarray, list[dict[str, float]]] | None:
    """:func:`parse_srt` of the file at ``path`` (``stamp``: its size and modification time,
    so that a changed file is read again); None when it cannot be read or is too large."""
    if stamp[0] > MAX_SRT_BYTES:
        return None
    try:
        return parse_srt(Path(path).read_text(encoding="utf-8", errors="replace"))
    except OSError:
        return None


@functools.lru_cache(maxsize=32)
def video_fps(path: str) -> float | None:
    """Frames per second of the video at ``path`` (OpenCV's reading of its header), None
    when unknown."""
    cap = cv2.VideoCapture(path)
    try:
        fps = float(cap.get(cv2.CAP_PROP_FPS)) if cap.isOpened() else 0.0
    finally:
        cap.release()
    return fps if math.isfinite(fps) and 0.5 <= fps <= 1000 else None


def srt_meta(video: Path, frame: int) -> dict[str, float]:
    """The meta of frame ``frame`` (0-based) of ``video`` from the subtitle file beside it:
    the entry whose span holds the frame's middle, else the last one that starts before it;
    {} without a subtitle file, a frame rate or such an entry."""
    srt = srt_path(video)
    if srt is None:
        return {}
    try:
        st = srt.stat()
    except OSError:
        return {}
    entries = _entries(str(srt), (st.st_size, st.st_mtime_ns))
    fps = video_fps(str(video))
    if entries is None or fps is None or len(entries[0]) == 0:
        return {}
    starts, ends, metas = entries
    t = (frame + 0.5) / fps
    inside = np.flatnonzero((starts <= t) & (t < ends))
    if len(inside):
        return dict(metas[int(inside[0])])
    before = np.flatnonzero(starts <= t)
    return dict(metas[int(before[np.argmax(starts[before])])]) if len(before) else {}
