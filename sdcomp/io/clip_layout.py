"""The folder of a video run (``sdcomp video --out clips``)::

    clips/
      video.json                        what was made: format, config, status, counts
      annotations/instances_video.json  COCO-video ground truth of every finished sequence
      data.yaml                         Ultralytics dataset file (with --format yolo)
      sdcomp-0000/                      one MOTChallenge sequence
        img1/000001.jpg ...             frames (MOTChallenge: from 1)
        masks/000001.png ...            16-bit instance masks, values = track ids
        masks/000001_ignore.png ...     8-bit ignore masks (frames that have ignore regions)
        labels/000001.txt ...           YOLO labels (with --format yolo); images/ -> img1
        gt/gt.txt                       MOTChallenge ground truth
        flight.json                     per-frame flight metadata (SeaDronesSee's keys)
        sequence.json                   the sequence's COCO-video part
        sdcomp-0000.mp4                 with --mp4
        seqinfo.ini                     written last: the sequence is complete

Every file is written whole or not at all (temporary name, then rename).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from .layout import IGNORE_SUFFIX

VIDEO_FORMAT = "sdcomp-video"
VIDEO_FORMAT_VERSION = 1
SEQ_PREFIX = "sdcomp"


@dataclass(frozen=True)
class ClipLayout:
    """Paths of a video run's folder ``root`` (see the module docstring)."""

    root: Path

    @property
    def meta(self) -> Path:
        return self.root / "video.json"

    @property
    def coco(self) -> Path:
        return self.root / "annotations" / "instances_video.json"

    @property
    def data_yaml(self) -> Path:
        return self.root / "data.yaml"

    def name(self, s: int) -> str:
        """The folder name of sequence ``s``."""
        return f"{SEQ_PREFIX}-{s:04d}"

    def seq(self, s: int) -> Path:
        return self.root / self.name(s)

    def image(self, s: int, k: int, ext: str) -> Path:
        """Frame ``k`` (0-based) of sequence ``s``."""
        return self.seq(s) / "img1" / f"{k + 1:06d}.{ext}"

    def mask(self, s: int, k: int) -> Path:
        return self.seq(s) / "masks" / f"{k + 1:06d}.png"

    def ignore_mask(self, s: int, k: int) -> Path:
        """Frame ``k``'s ignore mask (written only when it has ignore pixels)."""
        return self.seq(s) / "masks" / f"{k + 1:06d}{IGNORE_SUFFIX}"

    def label(self, s: int, k: int) -> Path:
        return self.seq(s) / "labels" / f"{k + 1:06d}.txt"

    def gt(self, s: int) -> Path:
        return self.seq(s) / "gt" / "gt.txt"

    def seqinfo(self, s: int) -> Path:
        return self.seq(s) / "seqinfo.ini"

    def part(self, s: int) -> Path:
        return self.seq(s) / "sequence.json"

    def flight(self, s: int) -> Path:
        return self.seq(s) / "flight.json"

    def mp4(self, s: int) -> Path:
        return self.seq(s) / f"{self.name(s)}.mp4"

    def complete(self, s: int) -> bool:
        """Whether sequence ``s`` was finished (its seqinfo.ini is written last)."""
        return self.seqinfo(s).exists() and self.part(s).exists()

    def sequences(self) -> list[int]:
        """Indices of the sequence folders present (complete or not), sorted."""
        out = []
        for p in self.root.glob(f"{SEQ_PREFIX}-*"):
            tail = p.name[len(SEQ_PREFIX) + 1:]
            if p.is_dir() and tail.isdigit():
                out.append(int(tail))
        return sorted(out)
