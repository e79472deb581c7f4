"""The Python API of video: render frame ``k`` of sequence ``s`` to arrays with track ids.

    >>> from sdcomp import GeneratorConfig
    >>> from sdcomp.clips import ClipGenerator
    >>> from sdcomp.scene.video import VideoConfig
    >>> clips = ClipGenerator(VideoConfig(GeneratorConfig(seed=1), frames=60))
    >>> f = clips.frame(0, 12)     # sequence 0, frame 12 (0-based)
    >>> f.image.shape, f.tracks, f.objects[0]["track_id"]

A :class:`ClipGenerator` wraps a still :class:`~sdcomp.pipeline.Generator` (the same
assets, renderer and annotation rule) and the sequences of :mod:`sdcomp.scene.sequence`:
a frame is the still pipeline run on the frame's scene; its instance map is renumbered
with track ids. Frame ``k`` of sequence ``s`` depends only on (config, s, k).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .annotate import Frame, coco_annotations, ignore_annotations, image_meta
from .annotate.records import dji_heading
from .pipeline import DEFAULT_SPRITES, Generator
from .scene.sequence import Sequence, frame_scene, sample_sequence
from .scene.video import VideoConfig

EARTH_RADIUS = 6_371_000.0  # m: for the GPS-like positions of the flight metadata


@dataclass
class VideoFrame:
    """One frame of a sequence as arrays.

    Attributes:
        sequence, frame: indices (0-based).
        image: (H, W, 3) uint8 RGB.
        instances: (H, W) uint16 track ids (0 = no object of interest).
        objects: per annotated object: track_id, category_id, bbox [x, y, w, h] px (of
            its visible pixels), area px, segmentation (COCO RLE), visibility (visible
            pixels over its whole projected silhouette, in frame or not, 0-1), pose, and
            state (world x_m, y_m, vx/vy m/s, heading_deg).
        tracks: track id of every object of interest in the scene (annotated or not).
        ignored: per visible object too small to label (the labelling policy of
            :class:`~sdcomp.annotate.AnnotationRule`): its ignore region as a COCO ``iscrowd``
            entry with ``track_id``: tracks stay accounted for to their last visible pixel.
        ignore: (H, W) bool, the frame's ignore region (None when it has none).
        meta: the frame's metadata: the still's (water, sun, camera...) and the flight's
            with SeaDronesSee's key names.
        frame_info: the still pipeline's :class:`~sdcomp.annotate.Frame`.
    """

    sequence: int
    frame: int
    image: np.ndarray
    instances: np.ndarray
    objects: list[dict]
    tracks: tuple[int, ...]
    meta: dict
    frame_info: Frame
    ignored: list[dict] = field(default_factory=list)
    ignore: np.ndarray | None = None


class ClipGenerator:
    """Renders the sequences of ``video`` (sprites from ``sprites_dir``, built there first
    when missing, as :class:`~sdcomp.pipeline.Generator` does). Keeps the sequences it has
    drawn (a few kB each)."""

    def __init__(self, video: VideoConfig, sprites_dir: str | Path | None = DEFAULT_SPRITES,
                 progress: bool | None = None, generator: Generator | None = None):
        self.video = video
        self.gen = generator or Generator(video.generator, sprites_dir, progress=progress)
        self._sequences: dict[int, Sequence] = {}

    def warm(self) -> None:
        """Prepare textures and sprites before forking workers (:meth:`Generator.warm`)."""
        self.gen.warm()

    def sequence(self, s: int) -> Sequence:
        """Sequence ``s`` (drawn on first use)."""
        seq = self._sequences.get(s)
        if seq is None:
            if len(self._sequences) > 64:
                self._sequences.clear()
            seq = self._sequences[s] = sample_sequence(self.video, s, self.gen.model)
        return seq

    def frame(self, s: int, k: int) -> VideoFrame:
        """Frame ``k`` (0-based) of sequence ``s``."""
        seq = self.sequence(s)
        scene, ids = frame_scene(seq, k)
        info = self.gen.render_scene(scene)
        lut = np.zeros(len(info.objects) + 1, np.uint16)
        for inst in info.objects:
            lut[inst.instance_id] = ids[inst.placement]
        instances = lut[info.instances]
        t = seq.time(k)
        objects = []
        for inst, ann in zip(info.objects, coco_annotations(info), strict=True):
            track = ids[inst.placement]
            tr = next(tr for tr in seq.tracks if tr.track_id == track)
            x, y = tr.position(t)
            vx, vy = tr.velocity(t)
            ann = dict(ann, track_id=track, instance_id=track,
                       visibility=_visibility(inst.area, inst.full_area),
                       state={"x_m": round(float(x), 3), "y_m": round(float(y), 3),
                              "vx_mps": round(float(vx), 4), "vy_mps": round(float(vy), 4),
                              "heading_deg": round(float(tr.heading(t)), 3),
                              "speed_through_water_mps": round(tr.placement.speed, 4)})
            objects.append(ann)
        ignored = [dict(ann, track_id=ids[inst.placement], instance_id=ids[inst.placement],
                        visibility=_visibility(inst.area, inst.full_area))
                   for inst, ann in zip(info.ignored, ignore_annotations(info), strict=True)]
        info.instances = instances
        tracks = tuple(i for i in ids if i > 0)
        return VideoFrame(s, k, info.image, instances, objects, tracks,
                          self.frame_meta(seq, k, info), info, ignored, info.ignore)

    def frame_meta(self, seq: Sequence, k: int, info: Frame) -> dict:
        """The metadata of frame ``k``: the still's (:func:`image_meta`) with the flight's
        under SeaDronesSee's key names (speeds m/s, DJI headings: degrees clockwise from
        north), a GPS-like position (the flight's offset from the config's latitude and
        longitude, by default Lake Constance, where a third of SeaDronesSee was filmed) and the
        timestamp (ms)."""
        st = seq.camera(k)
        meta = image_meta(info)
        lat0, lon0 = self.video.latitude, self.video.longitude
        lat = lat0 + math.degrees(float(st.y) / EARTH_RADIUS)
        lon = lon0 + math.degrees(float(st.x) / (EARTH_RADIUS * math.cos(math.radians(lat0))))
        course = math.degrees(math.atan2(float(st.vy), float(st.vx))) if float(
            st.speed) > 1e-6 else float(st.heading)
        meta.update({
            "frame": k + 1, "time(s)": round(seq.time(k), 6),
            "timestamp": int(round(seq.time(k) * 1000)),
            "latitude": round(lat, 8), "longitude": round(lon, 8),
            "x(m)": round(float(st.x), 4), "y(m)": round(float(st.y), 4),
            "altitude(meter)": round(float(st.altitude), 4),
            "speed(m/s)": round(float(st.speed), 4),
            "xspeed(m/s)": round(float(st.vy), 4),  # north, as DJI's velocity_x
            "yspeed(m/s)": round(float(st.vx), 4),  # east
            "zspeed(m/s)": round(float(st.vz), 4),
            "compass_heading(degrees)": round(dji_heading(course), 4),
            "flight": seq.flight.kind,
        })
        return meta


def _visibility(area: int, full_area: float) -> float:
    """Visible pixels over the whole projected silhouette (0-1; 1 when unknown)."""
    if full_area <= 0:
        return 1.0
    return round(min(area / full_area, 1.0), 4)
