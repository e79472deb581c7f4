"""MOTChallenge files of a sequence: ``gt/gt.txt`` and ``seqinfo.ini``, as TrackEval and
py-motmetrics read them, and reading them back.

``gt.txt``: one line per annotated object per frame, sorted by frame then id:
``frame, id, left, top, width, height, conf, class, visibility`` with frames from 1, boxes
in MOTChallenge's pixel convention (the top-left pixel is (1, 1): ``left = x + 1``), ``conf``
(MOTChallenge's flag) 1 for a labelled object and 0 for an ignore region (an object whose
visible pixels are too few to label: TrackEval and py-motmetrics' ``min_confidence=1`` leave
it out, matching nothing to it), ``class`` the COCO category id and ``visibility`` the
visible fraction of the object's whole projected silhouette (0-1).
"""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path

import numpy as np

GT_COLUMNS = ("frame", "id", "left", "top", "width", "height", "conf", "class", "visibility")


def gt_lines(frames: Iterable[tuple[int, list[dict]]]) -> str:
    """The text of ``gt.txt`` from (frame number from 1, objects) pairs; each object has
    ``track_id``, ``bbox`` [x, y, w, h] (0-based pixels), ``category_id``, ``visibility``
    and, for an ignore region, ``iscrowd`` 1 (its flag is 0)."""
    rows = []
    for k, objects in frames:
        for o in objects:
            x, y, w, h = (float(v) for v in o["bbox"])
            rows.append((int(k), int(o["track_id"]), x + 1, y + 1, w, h,
                         0 if o.get("iscrowd") else 1, int(o["category_id"]),
                         float(o["visibility"])))
    rows.sort(key=lambda r: (r[0], r[1]))
    return "".join(f"{f},{i},{_n(x)},{_n(y)},{_n(w)},{_n(h)},{flag},{c},{v:.4f}\n"
                   for f, i, x, y, w, h, flag, c, v in rows)


def _n(v: float) -> str:
    return str(int(v)) if float(v).is_integer() else f"{v:.2f}"


def seqinfo_text(name: str, fps: float, length: int, width: int, height: int,
                 ext: str = ".jpg", im_dir: str = "img1") -> str:
    """The ``seqinfo.ini`` of a sequence (frame rate written as a whole number when it is
    one, as MOTChallenge's are)."""
    rate = str(int(fps)) if float(fps).is_integer() else f"{fps:g}"
    return (f"[Sequence]\nname={name}\nimDir={im_dir}\nframeRate={rate}\nseqLength={length}\n"
            f"imWidth={width}\nimHeight={height}\nimExt={ext}\n")


def read_gt(path: str | Path) -> np.ndarray:
    """``gt.txt`` as an (N, 9) float64 array of :data:`GT_COLUMNS` ((0, 9) when empty)."""
    text = Path(path).read_text()
    if not text.strip():
        return np.zeros((0, 9))
    return np.loadtxt(path, delimiter=",", ndmin=2)


def read_seqinfo(path: str | Path) -> dict[str, str]:
    """The ``[Sequence]`` keys of a ``seqinfo.ini``."""
    out = {}
    for line in Path(path).read_text().splitlines():
        if "=" in line:
            k, v = line.split("=", 1)
            out[k.strip()] = v.strip()
    return out
