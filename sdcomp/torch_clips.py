"""A PyTorch dataset of video clips rendered on the fly, for trackers and video models.

Item ``i`` of :class:`SyntheticClips` is a clip: ``clip_len`` frames of one sequence of
:class:`~sdcomp.clips.ClipGenerator`, every ``stride``-th, as ``(video, targets)``::

    video    tv_tensors.Video (T, 3, H, W) uint8 RGB in 0..255
    targets  a list of T dicts, one per frame, objects sorted by track id:
             {"boxes":      tv_tensors.BoundingBoxes (N, 4) float32 XYXY, canvas_size (H, W)
                            (pixel edges: COCO's [x, y, w, h] is x1 = x, x2 = x + w),
              "labels":     (N,) int64 COCO category ids (from 1),
              "track_ids":  (N,) int64 track ids: one object keeps its id across frames,
                            and its mask is where the frame's instance map equals it,
              "masks":      tv_tensors.Mask (N, H, W) bool,
              "visibility": (N,) float32 visible fraction of the object's silhouette (0-1),
              "ignore":     tv_tensors.Mask (H, W) bool: the frame's ignore region (objects
                            with too few visible pixels to label; all False when none),
              "sequence":   int, the sequence index,
              "frame":      int, the frame index in the sequence (0-based)}

Frame ``k`` of sequence ``s`` depends only on (config, s, k), so item ``i`` is the same
tensors in every process, in any order, on every run. The dataset builds its generator (and
any missing sprite atlas) when it is made; forked DataLoader workers inherit it and a pickled
copy (``multiprocessing_context="spawn"``) carries only the config and builds its own on
first use. As in :mod:`sdcomp.torch_datasets`, OpenCV's threads pause while a process forks.

``transforms(video, targets) -> (video, targets)`` is applied last: one call per clip, so a
``torchvision.transforms.v2`` transform draws its random parameters once and moves every
frame, box and mask alike (``v2.RandomHorizontalFlip()`` flips the whole clip).

Use :func:`collate` as the DataLoader's ``collate_fn``: ``(videos, targets)`` with videos
stacked (B, T, 3, H, W) and targets a tuple of B lists of T dicts.

Torch and torchvision are optional dependencies of sdcomp: only this module (and
:mod:`sdcomp.torch_datasets`, :mod:`sdcomp.bench`) imports them.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import torch

from .clips import ClipGenerator, VideoFrame
from .errors import UserError

try:
    from torchvision import tv_tensors
except ImportError:  # pragma: no cover - torchvision comes with the dev and bench extras
    raise ImportError("sdcomp.torch_clips needs torchvision (pip install torchvision, or "
                      "pip install 'sdcomp[bench]')") from None
from .atlas.cache import sprites_folder
from .pipeline import DEFAULT_SPRITES, Generator
from .scene.config import GeneratorConfig
from .scene.video import VideoConfig, sequence_split
from .util.pool import pause_opencv_threads_on_fork

Target = dict[str, Any]
ClipTransforms = Callable[[torch.Tensor, list[Target]], tuple[torch.Tensor, list[Target]]]

pause_opencv_threads_on_fork()  # DataLoader workers are forked on Linux


def _whole(value: Any, name: str, low: int) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < low:
        raise UserError(f"{name} {value!r} must be a whole number >= {low}")
    return int(value)


def clip_starts(frames: int, clip_len: int, stride: int,
                clips_per_sequence: int | None = None) -> list[int]:
    """The first frame of each clip of a sequence of ``frames`` frames.

    A clip spans ``(clip_len - 1) * stride + 1`` frames. By default the clips follow one
    another without overlap (``frames // (clip_len * stride)`` of them, at least one when a
    clip fits); with ``clips_per_sequence`` = n they are spread evenly from frame 0 to the
    last start that fits (overlapping where n is large)."""
    span = (clip_len - 1) * stride + 1
    if span > frames:
        raise UserError(f"a clip of {clip_len} frames every {stride} spans {span} frames, "
                        f"more than the {frames} of a sequence: lower clip_len or stride, "
                        f"or raise the config's frames")
    if clips_per_sequence is None:
        return [j * clip_len * stride for j in range(max(1, frames // (clip_len * stride)))]
    n, last = clips_per_sequence, frames - span
    if n == 1:
        return [0]
    return [int(np.floor(j * last / (n - 1) + 0.5)) for j in range(n)]


def frame_target(frame: VideoFrame) -> Target:
    """The target dict of one frame (see the module docstring)."""
    h, w = frame.instances.shape
    objs = sorted(frame.objects, key=lambda o: o["track_id"])
    n = len(objs)
    ids = np.array([o["track_id"] for o in objs], np.int64).reshape(n)
    masks = frame.instances[None] == ids.astype(np.uint16).reshape(n, 1, 1)  # (N, H, W)
    boxes = np.array([[x, y, x + bw, y + bh] for x, y, bw, bh in (o["bbox"] for o in objs)],
                     np.float32).reshape(n, 4)
    return {"boxes": tv_tensors.BoundingBoxes(torch.from_numpy(boxes), format="XYXY",
                                              canvas_size=(h, w)),
            "labels": torch.from_numpy(np.array([o["category_id"] for o in objs],
                                                np.int64).reshape(n)),
            "track_ids": torch.from_numpy(ids),
            "masks": tv_tensors.Mask(torch.from_numpy(masks)),
            "visibility": torch.from_numpy(np.array([o["visibility"] for o in objs],
                                                    np.float32).reshape(n)),
            "ignore": tv_tensors.Mask(torch.from_numpy(
                np.zeros((h, w), bool) if frame.ignore is None else frame.ignore)),
            "sequence": int(frame.sequence), "frame": int(frame.frame)}


class SyntheticClips(torch.utils.data.Dataset):
    """Clips of the sequences of ``config`` rendered on demand (see the module docstring).

    Args:
        config: a :class:`VideoConfig` (its ``sequences`` and ``frames`` set the dataset's
            size), or a :class:`GeneratorConfig` for the video defaults around it.
        clip_len: frames per clip (T).
        clips_per_sequence: clips drawn from each sequence, spread evenly (see
            :func:`clip_starts`); default: as many as follow one another without overlap.
        stride: take every ``stride``-th frame (1: consecutive frames).
        sprites_dir: sprite atlas folder (built there on first use when missing).
        transforms: optional ``transforms(video, targets) -> (video, targets)``, applied
            last, once per clip.
        split: "all", or the sequences of "train" or "val" only (whole sequences, as
            ``sdcomp video`` splits them by the config's ``val_fraction``:
            :func:`~sdcomp.scene.video.sequence_split`).

    ``len(dataset)`` = sequences (of the split) x clips per sequence; item ``i`` is clip
    ``i % clips_per_sequence`` of the split's sequence ``i // clips_per_sequence``.
    """

    def __init__(self, config: VideoConfig | GeneratorConfig, clip_len: int,
                 clips_per_sequence: int | None = None, stride: int = 1,
                 sprites_dir: str | Path | None = DEFAULT_SPRITES,
                 transforms: ClipTransforms | None = None, split: str = "all"):
        if isinstance(config, GeneratorConfig):
            config = VideoConfig(config)
        if not isinstance(config, VideoConfig):
            raise UserError(f"config must be a VideoConfig or GeneratorConfig, not "
                            f"{type(config).__name__}")
        self.config = config
        if split not in ("all", "train", "val"):
            raise UserError(f"split {split!r} is unknown: use all, train or val")
        self.sequences = [s for s in range(config.sequences) if split == "all"
                          or sequence_split(s, config.generator.val_fraction) == split]
        self.clip_len = _whole(clip_len, "clip_len", 1)
        self.stride = _whole(stride, "stride", 1)
        if clips_per_sequence is not None:
            clips_per_sequence = _whole(clips_per_sequence, "clips_per_sequence", 1)
        self.starts = clip_starts(config.frames, self.clip_len, self.stride,
                                  clips_per_sequence)
        self.clips_per_sequence = len(self.starts)
        self.sprites_dir = str(sprites_folder(sprites_dir))
        self.transforms = transforms
        # built here, once: atlases are built (or a bad mesh reported) before any worker
        # starts; forked workers inherit it, pickled copies (spawn) rebuild it on first use
        self._clips: ClipGenerator | None = ClipGenerator(config, self.sprites_dir,
                                                          progress=False)
        self._clips.warm()

    @property
    def clips(self) -> ClipGenerator:
        """This process's clip generator (built on first use in a process that got a
        pickled copy of the dataset)."""
        if self._clips is None:
            # build_workers=1: a DataLoader worker is daemonic and may not start processes
            gen = Generator(self.config.generator, self.sprites_dir, progress=False,
                            build_workers=1)
            self._clips = ClipGenerator(self.config, self.sprites_dir, generator=gen)
        return self._clips

    def __len__(self) -> int:
        return len(self.sequences) * self.clips_per_sequence

    def clip_frames(self, i: int) -> tuple[int, list[int]]:
        """(sequence, frame indices) of item ``i``."""
        n = len(self)
        index = int(i) + (n if int(i) < 0 else 0)
        if not 0 <= index < n:
            raise IndexError(f"clip index {i} is out of range for a dataset of {n}")
        k, j = divmod(index, self.clips_per_sequence)
        start = self.starts[j]
        return self.sequences[k], [start + t * self.stride for t in range(self.clip_len)]

    def __getitem__(self, i: int) -> tuple[torch.Tensor, list[Target]]:
        s, ks = self.clip_frames(i)
        frames = [self.clips.frame(s, k) for k in ks]
        video = np.stack([np.ascontiguousarray(f.image.transpose(2, 0, 1)) for f in frames])
        out: torch.Tensor = tv_tensors.Video(torch.from_numpy(video))
        targets = [frame_target(f) for f in frames]
        if self.transforms is not None:
            out, targets = self.transforms(out, targets)
        return out, targets

    def __getstate__(self) -> dict:
        state = self.__dict__.copy()
        state["_clips"] = None  # textures and sprites are rebuilt in the other process
        return state


def collate(batch: Sequence[tuple[torch.Tensor, list[Target]]]
            ) -> tuple[torch.Tensor | tuple[torch.Tensor, ...], tuple[list[Target], ...]]:
    """DataLoader ``collate_fn`` for clips: ``(videos, targets)``, videos stacked into one
    (B, T, 3, H, W) tensor (a tuple of videos where transforms left them different sizes),
    targets a tuple of B lists of T dicts (frames differ in their number of objects)."""
    if not batch:
        return (), ()
    videos, targets = zip(*batch, strict=True)
    if len({tuple(v.shape) for v in videos}) == 1:
        return torch.stack([v.as_subclass(torch.Tensor) for v in videos]), tuple(targets)
    return tuple(videos), tuple(targets)


__all__ = ["SyntheticClips", "clip_starts", "collate", "frame_target"]
