"""Strips and animated previews of a video run's folder (``sdcomp video --out clips``).

A strip is a grid: one row per sequence, frames evenly spaced along it (first and last
included), each tile the frame with the boxes of its ``gt/gt.txt`` in one colour per track
id (:func:`track_colour`: the same colour for an id on every tile, in every run) labelled
with the id, and the frame number (from 1, as in MOTChallenge) at its bottom left; the first
tile of a row also names the sequence. A preview is one sequence's frames with the same
drawing, as an animated GIF (Pillow) or an MP4 (OpenCV's mp4v writer).

The command line is ``sdcomp show clips --out strip.png [--preview seq.gif]``
(:mod:`sdcomp.cli.show`). Python::

    from sdcomp.report.video_sheet import load_video, strip
    rgb, shown = strip(load_video("clips/"), sequences=2, frames_per_row=6)
"""

from __future__ import annotations

import colorsys
import json
import os
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from ..errors import UserError
from ..io.clip_layout import VIDEO_FORMAT, ClipLayout
from ..io.mot import read_gt, read_seqinfo
from ..util.files import atomic_path
from .sheet import BACKGROUND, FONT, MIN_CELL, TEXT_RGB, select_indices

GAP = 2  # background pixels between tiles
PREVIEW_EXTENSIONS = (".gif", ".mp4")
GOLDEN = 0.618033988749895  # hue step between consecutive track ids: well spread colours
HUE0 = 0.462  # hue offset: id 1 orange, 2 violet, 3 green, 4 magenta, 5 cyan, 6 yellow


def track_colour(track_id: int) -> tuple[int, int, int]:
    """The RGB colour of ``track_id``'s boxes: a bright hue fixed by the id alone."""
    hue = (HUE0 + int(track_id) * GOLDEN) % 1.0
    r, g, b = colorsys.hsv_to_rgb(hue, 0.85, 1.0)
    return round(r * 255), round(g * 255), round(b * 255)


@dataclass(frozen=True)
class VideoSequence:
    """One finished sequence of a video folder: its frames and its gt.txt rows."""

    index: int
    name: str
    folder: Path
    length: int
    width: int
    height: int
    fps: float
    image_dir: str
    image_ext: str
    gt: np.ndarray  # (N, 9) rows of io.mot.GT_COLUMNS

    def image_path(self, k: int) -> Path:
        """Frame ``k`` (0-based)."""
        return self.folder / self.image_dir / f"{k + 1:06d}{self.image_ext}"

    def rows(self, k: int) -> np.ndarray:
        """The gt.txt rows of frame ``k`` (0-based)."""
        return self.gt[self.gt[:, 0].astype(np.int64) == k + 1]

    def read(self, k: int) -> np.ndarray:
        """Frame ``k`` as (H, W, 3) uint8 RGB."""
        path = self.image_path(k)
        bgr = cv2.imread(str(path), cv2.IMREAD_COLOR)
        if bgr is None:
            raise UserError(f"{path}: missing or unreadable frame; re-run sdcomp video with "
                            f"--resume to redraw it")
        return cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB)


def is_video_folder(folder: str | Path) -> bool:
    """Whether ``folder`` holds a ``video.json`` of format ``sdcomp-video``."""
    meta = Path(folder) / "video.json"
    if not meta.is_file():
        return False
    try:
        data = json.loads(meta.read_text())
    except (OSError, ValueError):
        raise UserError(f"{meta}: unreadable or not JSON; re-run sdcomp video with --resume "
                        f"to rewrite it") from None
    return isinstance(data, dict) and data.get("format") == VIDEO_FORMAT


def load_video(folder: str | Path) -> list[VideoSequence]:
    """The finished sequences of the video folder ``folder``, in order (UserError when it
    is not one or has none)."""
    root = Path(folder)
    if not is_video_folder(root):
        raise UserError(f"{str(root)!r} is not a video folder (no video.json of format "
                        f"{VIDEO_FORMAT!r}): give the --out folder of sdcomp video")
    layout = ClipLayout(root)
    out = []
    for s in layout.sequences():
        if not layout.complete(s):
            continue
        try:
            info = read_seqinfo(layout.seqinfo(s))
            gt = read_gt(layout.gt(s)).reshape(-1, 9)
            seq = VideoSequence(s, info.get("name", layout.name(s)), layout.seq(s),
                                int(info["seqLength"]), int(info["imWidth"]),
                                int(info["imHeight"]), float(info.get("frameRate", 30)),
                                info.get("imDir", "img1"), info.get("imExt", ".jpg"), gt)
        except (OSError, ValueError, KeyError):
            raise UserError(f"{layout.seq(s)}: unreadable seqinfo.ini or gt/gt.txt; re-run "
                            f"sdcomp video with --resume to rewrite it") from None
        if seq.length < 1 or seq.width < 1 or seq.height < 1:
            raise UserError(f"{layout.seqinfo(s)}: no frames or no size")
        out.append(seq)
    if not out:
        raise UserError(f"{str(root)!r} has no finished sequence yet: run sdcomp video with "
                        f"--resume to finish them")
    return out


def find_sequence(seqs: list[VideoSequence], index: int) -> VideoSequence:
    """The sequence numbered ``index`` (as in its folder name, sdcomp-0003 = 3)."""
    for seq in seqs:
        if seq.index == index:
            return seq
    have = ", ".join(str(s.index) for s in seqs[:20]) + (", ..." if len(seqs) > 20 else "")
    raise UserError(f"--sequence {index}: no finished sequence {index} in the folder "
                    f"(it has {have})")


# --------------------------------------------------------------------------- drawing

def _font_scale(width: int) -> float:
    return max(0.3, width / 640)


def _text(img: np.ndarray, text: str, org: tuple[int, int], scale: float,
          colour: tuple[int, int, int]) -> None:
    """``text`` at ``org`` (baseline left) with a dark outline, readable on any water."""
    cv2.putText(img, text, org, FONT, scale, (0, 0, 0), 3, cv2.LINE_AA)
    cv2.putText(img, text, org, FONT, scale, colour, 1, cv2.LINE_AA)


def draw_tracks(img: np.ndarray, rows: np.ndarray, scale: float = 1.0) -> np.ndarray:
    """Draw the gt.txt ``rows`` of one frame into ``img`` (RGB, in place; the frame
    resized by ``scale``): each box (MOTChallenge's 1-based left/top) as a one-pixel
    rectangle on its outermost pixels, in :func:`track_colour`, its id above it (inside
    the frame where the box touches the top)."""
    h, w = img.shape[:2]
    fs = _font_scale(w) * 0.9
    for row in rows:
        tid = int(row[1])
        x, y, bw, bh = float(row[2]) - 1, float(row[3]) - 1, float(row[4]), float(row[5])
        x0, y0 = round(x * scale), round(y * scale)
        x1 = max(x0, round((x + bw) * scale) - 1)
        y1 = max(y0, round((y + bh) * scale) - 1)
        colour = track_colour(tid)
        cv2.rectangle(img, (x0, y0), (x1, y1), colour, 1, cv2.LINE_8)
        (tw, th), base = cv2.getTextSize(str(tid), FONT, fs, 1)
        ty = y0 - 3 if y0 - 3 - th >= 0 else min(h - 2, y1 + th + 3)
        _text(img, str(tid), (min(max(0, x0), max(0, w - tw)), ty), fs, colour)
    return img


def frame_tile(seq: VideoSequence, k: int, width: int, label: str | None = None
               ) -> np.ndarray:
    """Frame ``k`` of ``seq`` resized to ``width`` (height by its aspect), its boxes drawn
    and ``label`` (default ``#<frame from 1>``) at its bottom left."""
    img = seq.read(k)
    scale = width / img.shape[1]
    height = max(1, round(img.shape[0] * scale))
    if (width, height) != (img.shape[1], img.shape[0]):
        interp = cv2.INTER_AREA if scale < 1 else cv2.INTER_LINEAR
        img = cv2.resize(img, (width, height), interpolation=interp)
    draw_tracks(img, seq.rows(k), scale)
    _text(img, label if label is not None else f"#{k + 1}", (3, height - 4),
          _font_scale(width), TEXT_RGB)
    return img


def strip_frames(seq: VideoSequence, frames_per_row: int) -> list[int]:
    """The frames (0-based) of ``seq`` on its row: evenly spaced, first and last included."""
    return select_indices(seq.length, frames_per_row, "spread")


def check_strip(sequences: int, frames_per_row: int, cell: int) -> None:
    if sequences < 1:
        raise UserError(f"--sequences {sequences} must be at least 1")
    if frames_per_row < 1:
        raise UserError(f"--frames-per-row {frames_per_row} must be at least 1")
    if cell < MIN_CELL:
        raise UserError(f"--cell {cell} is too small: use at least {MIN_CELL} pixels")


def strip(seqs: list[VideoSequence], sequences: int = 4, frames_per_row: int = 6,
          cell: int = 256) -> tuple[np.ndarray, list[tuple[VideoSequence, list[int]]]]:
    """(H, W, 3) uint8 RGB strip of the first ``sequences`` sequences (rows) at
    ``frames_per_row`` evenly spaced frames (columns), tiles ``cell`` pixels wide with
    :data:`GAP` pixels between them; and what it shows, (sequence, frames) per row. The
    tile of row r, column c starts at (x, y) = (c * (cell + GAP), sum of the heights of
    the rows above + r * GAP)."""
    check_strip(sequences, frames_per_row, cell)
    rows = [(seq, strip_frames(seq, frames_per_row)) for seq in seqs[:sequences]]
    heights = [max(1, round(seq.height * cell / seq.width)) for seq, _ in rows]
    cols = max(len(ks) for _, ks in rows)
    sheet = np.empty((sum(heights) + GAP * (len(rows) - 1),
                      cols * cell + GAP * (cols - 1), 3), np.uint8)
    sheet[:] = BACKGROUND
    top = 0
    for (seq, ks), h in zip(rows, heights, strict=True):
        for c, k in enumerate(ks):
            label = f"{seq.name} #{k + 1}" if c == 0 else None
            tile = frame_tile(seq, k, cell, label)
            x = c * (cell + GAP)
            sheet[top:top + h, x:x + cell] = tile[:h]
        top += h + GAP
    return sheet, rows


def preview_frames(seq: VideoSequence, max_width: int = 640) -> Iterator[np.ndarray]:
    """The frames of ``seq`` (RGB) with boxes and ids, at most ``max_width`` wide."""
    width = min(seq.width, max_width)
    for k in range(seq.length):
        yield frame_tile(seq, k, width)


def check_preview(path: Path) -> None:
    """UserError unless ``path`` ends in .gif or .mp4 and its folder exists."""
    if path.suffix.lower() not in PREVIEW_EXTENSIONS:
        raise UserError(f"--preview {str(path)!r} must end in .gif or .mp4")
    if path.is_dir() or not path.parent.is_dir():
        raise UserError(f"--preview {str(path)!r}: not a file name in an existing folder")
    if not os.access(path.parent, os.W_OK | os.X_OK):
        raise UserError(f"--preview {str(path)!r}: folder {str(path.parent)!r} is not "
                        f"writable")


def write_preview(seq: VideoSequence, path: str | Path, max_width: int = 640) -> int:
    """Write the animated preview of ``seq`` to ``path`` (.gif or .mp4), atomically, at
    the sequence's frame rate; returns the number of frames."""
    path = Path(path)
    check_preview(path)
    frames = preview_frames(seq, max_width)
    if path.suffix.lower() == ".gif":
        from PIL import Image  # Pillow comes with matplotlib

        images = [Image.fromarray(f) for f in frames]
        with atomic_path(path) as tmp:
            images[0].save(tmp, format="GIF", save_all=True, append_images=images[1:],
                           duration=max(20, round(1000 / seq.fps)), loop=0)
        return len(images)
    tmp = path.with_name(f".{path.stem}.{os.getpid()}.tmp.mp4")  # OpenCV picks by suffix
    first = next(frames)
    h, w = first.shape[:2]
    fourcc = cv2.VideoWriter.fourcc(*"mp4v")
    writer = cv2.VideoWriter(str(tmp), fourcc, float(seq.fps), (w, h))
    if not writer.isOpened():
        raise UserError(f"--preview {str(path)!r}: OpenCV cannot write MP4 here; use .gif")
    n = 0
    try:
        for f in (first, *frames):
            writer.write(cv2.cvtColor(f, cv2.COLOR_RGB2BGR))
            n += 1
    except BaseException:
        writer.release()
        tmp.unlink(missing_ok=True)
        raise
    writer.release()
    tmp.replace(path)
    return n
