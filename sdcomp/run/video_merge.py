"""Joining the folders of ``sdcomp video --shard K/N`` runs into one video folder, the same
bytes as one run of all the sequences (the sequence folders carry their global indices;
video.json and the COCO-video file are rewritten from them in sequence order)."""

from __future__ import annotations

import json
import shutil
from collections.abc import Sequence
from pathlib import Path

from ..errors import UserError
from ..io.clip_layout import VIDEO_FORMAT, ClipLayout
from ..scene.config import GeneratorConfig
from ..scene.video import VideoConfig
from .merge import place_file
from .output import os_error_message
from .video import sequence_indices, write_video_meta


def is_video_folder(folder: str | Path) -> bool:
    """Whether ``folder`` holds a video run (its video.json)."""
    return (Path(folder) / "video.json").exists()


def video_config(meta: dict) -> VideoConfig:
    """The :class:`VideoConfig` a video.json records."""
    d = dict(meta["config"])
    generator = GeneratorConfig.from_mapping(d.pop("generator"), GeneratorConfig(), "video.json")
    return VideoConfig(generator, **d)


def _read(folder: Path) -> tuple[dict, VideoConfig, tuple[int, int]]:
    try:
        meta = json.loads((folder / "video.json").read_text())
        if meta.get("format") != VIDEO_FORMAT:
            raise ValueError
    except (OSError, ValueError):
        raise UserError(f"{folder} is not an sdcomp video folder (no valid video.json)"
                        ) from None
    shard = meta.get("shard")
    if not shard:
        raise UserError(f"{folder} was not made with --shard: nothing to merge")
    if meta.get("status") != "complete":
        raise UserError(f"{folder} is not finished (status {meta.get('status')!r}): continue "
                        f"it with --resume first")
    k, n = (int(x) for x in shard.split("/"))
    return meta, video_config(meta), (k, n)


def merge_video(folders: Sequence[str | Path], out: str | Path, *, overwrite: bool = False,
                remove: bool = False) -> dict:
    """Merge the shard ``folders`` of one video run into ``out``; returns its counts."""
    out = Path(out)
    shards = sorted((_read(Path(f)) + (Path(f),) for f in folders), key=lambda s: s[2][0])
    video = _check_shards(shards, out)
    n = shards[0][2][1]
    layout = ClipLayout(out)
    if out.exists() and any(out.iterdir()) and not overwrite:
        raise UserError(f"--out {out} is not empty: add --overwrite to replace it, or "
                        f"choose another --out")
    try:
        if overwrite and out.exists():
            for s in layout.sequences():
                shutil.rmtree(layout.seq(s))
        (out / "annotations").mkdir(parents=True, exist_ok=True)
        for _, v, (k, _n), folder in shards:
            src = ClipLayout(folder)
            for s in sequence_indices(v, (k, n)):
                _copy_tree(src.seq(s), layout.seq(s))
        counts = write_video_meta(video, layout, "complete", None,
                                  list(range(video.sequences)))
        if remove:
            for *_, folder in shards:
                shutil.rmtree(folder)
    except OSError as e:
        raise UserError(os_error_message(e, out).replace(
            "continue with the same command and --resume", "merge again with --overwrite")
        ) from None
    return counts


def _check_shards(shards: list, out: Path) -> VideoConfig:
    """The common config of ``shards`` ((meta, config, (k, n), folder), sorted by k) once
    they are checked to be all n shards of one run, none of them ``out``."""
    video, n = shards[0][1], shards[0][2][1]
    for _, v, (_, nn), folder in shards:
        if nn != n or v.to_dict() != video.to_dict():
            raise UserError(f"{folder} is a shard of another run (its --shard or options "
                            f"differ from {shards[0][3]}'s)")
        if out.resolve() == folder.resolve():
            raise UserError(f"--out {out} is the shard folder {folder}: merge into another "
                            f"folder")
    have = [s[2][0] for s in shards]
    if have != list(range(n)):
        missing = sorted(set(range(n)) - set(have))
        raise UserError(f"shards {have} given of {n}: "
                        + (f"shard {missing[0]}/{n} is missing" if missing else
                           "a shard is given twice"))
    return video


def _copy_tree(src: Path, dst: Path) -> None:
    """A sequence folder's files hard-linked (else copied) into ``dst``; links kept."""
    for p in sorted(src.rglob("*")):
        target = dst / p.relative_to(src)
        if p.is_symlink():
            target.parent.mkdir(parents=True, exist_ok=True)
            if not target.is_symlink():
                target.symlink_to(p.readlink(), target_is_directory=True)
        elif p.is_dir():
            target.mkdir(parents=True, exist_ok=True)
        else:
            target.parent.mkdir(parents=True, exist_ok=True)
            place_file(p, target)
