"""COCO-video ground truth (the TAO / CocoVID style that mmtracking and TAO's tools read):
``videos``, ``images`` with ``video_id`` and ``frame_id`` (0-based), ``annotations`` with
``track_id`` (unique over the file), ``instance_id`` (the sequence's own id: gt.txt's id and
the mask value), ``video_id``, per-frame RLE ``segmentation``, ``visibility``, and ``tracks``.

A run writes one ``sequence.json`` per finished sequence (:func:`sequence_part`) and joins
them in sequence order (:func:`join_parts`), so the file never depends on which worker
made which sequence.
"""

from __future__ import annotations

from collections.abc import Iterable

TRACK_STRIDE = 100_000  # global track id = sequence index x TRACK_STRIDE + the sequence's id
FRAME_STRIDE = 1_000_000  # image id = sequence index x FRAME_STRIDE + frame number (from 1)


def sequence_part(s: int, video: dict, frames: Iterable[tuple[int, dict, list[dict]]]
                  ) -> dict:
    """The COCO-video part of sequence ``s``: ``video`` (its entry: name, width, height,
    fps, length, ...) and (frame from 0, image entry, objects) for each frame; objects as
    :class:`~sdcomp.clips.VideoFrame` gives them (its ignore regions among them, with
    ``iscrowd`` 1)."""
    images: list[dict] = []
    anns: list[dict] = []
    tracks: dict[int, int] = {}
    for k, image, objects in frames:
        image_id = s * FRAME_STRIDE + k + 1
        images.append(dict(image, id=image_id, video_id=s + 1, frame_id=k))
        for o in objects:
            tid = s * TRACK_STRIDE + int(o["track_id"])
            tracks.setdefault(tid, int(o["category_id"]))
            anns.append({"image_id": image_id, "video_id": s + 1, "track_id": tid,
                         "instance_id": int(o["track_id"]), "category_id": o["category_id"],
                         "bbox": o["bbox"], "area": o["area"],
                         "segmentation": o["segmentation"], "iscrowd": o.get("iscrowd", 0),
                         "visibility": o["visibility"], "state": o.get("state", {})})
    return {"video": dict(video, id=s + 1), "images": images, "annotations": anns,
            "tracks": [{"id": t, "category_id": c, "video_id": s + 1}
                       for t, c in sorted(tracks.items())]}


def join_parts(parts: Iterable[dict], categories: list[dict], info: dict) -> dict:
    """One COCO-video dict from sequence parts (in order); annotation ids 1, 2, ..."""
    out: dict = {"info": info, "categories": categories, "videos": [], "images": [],
                 "annotations": [], "tracks": []}
    for part in parts:
        out["videos"].append(part["video"])
        out["images"] += part["images"]
        out["tracks"] += part["tracks"]
        for a in part["annotations"]:
            out["annotations"].append(dict(a, id=len(out["annotations"]) + 1))
    return out
