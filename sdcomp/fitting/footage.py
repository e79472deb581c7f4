"""Reading the user's footage for ``sdcomp fit``: frames at one working size, their water
statistics (:mod:`.stats`, objects of the optional labels and painted-out regions,
:mod:`sdcomp.report.realism.painted`, kept out) and their geometry
(``--altitude`` / ``--pitch``, else the labels' SeaDronesSee ``meta``, else the flight logs
of :mod:`.flightlog`: a photo's DJI XMP, a video's SRT subtitle file)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np

from ..errors import UserError
from ..report.realism.painted import shrink_valid
from ..report.realism.patches import PATCH, empty_water
from ..report.realism.sea import ALTITUDE_KEY, PITCH_KEY, num
from ..report.realism.sources import Frame, load_frame, load_real, sky_mask
from ..scene.camera import ALTITUDE_RANGE, PITCH_RANGE, CameraModel
from .flightlog import dji_meta, photo_fov, srt_meta
from .grade import water_patches
from .stats import image_stats as measure_image
from .stats import stack, summary

MAX_SIDE = 512  #: frames larger than this (long side, px) are measured resized to it


@dataclass
class Footage:
    """What ``sdcomp fit`` knows of the footage.

    ``per_image`` {statistic: (n,) float64} over the frames read (n frames with water),
    ``summary`` {statistic: (p10, p50, p90)}, ``width`` x ``height`` the working size
    (pixels) frames were measured at, ``altitude`` / ``pitch`` (m, degrees) per frame where
    known (empty: not known), ``crops`` a few (h, w, 3) uint8 RGB frames at the working
    size for the report's picture, ``notes`` one-line facts for the report,
    ``sky_masked`` whether the sky of some frames was kept out (so the rendered frames'
    is too), ``fov`` the frames' diagonal field of view (degrees: ``--fov``, else the
    median of the photos' EXIF ones; None: unknown), ``patches`` (k, 64, 64, 3) uint8 some
    empty-water patches of the frames (the site grade's sample), ``patch_frames`` (k,) the
    frame each is of."""

    per_image: dict[str, np.ndarray]
    summary: dict[str, tuple[float, float, float]]
    width: int
    height: int
    altitude: list[float] = field(default_factory=list)
    pitch: list[float] = field(default_factory=list)
    crops: list[np.ndarray] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    frames: int = 0
    sky_masked: bool = False
    fov: float | None = None
    patches: np.ndarray = field(default_factory=lambda: np.zeros((0, PATCH, PATCH, 3), np.uint8))
    patch_frames: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))


def working_size(width: int, height: int, size: int | None) -> tuple[int, int]:
    """(w, h) pixels to measure a width x height frame at: its own size, or resized so its
    long side is ``size`` (default: at most :data:`MAX_SIDE`), aspect kept, at least one
    patch (64 px) each way."""
    long_side = max(width, height)
    target = size if size is not None else min(long_side, MAX_SIDE)
    f = target / long_side
    return max(PATCH, round(width * f)), max(PATCH, round(height * f))


def read_footage(path: str | Path, labels: str | Path | None = None, size: int | None = None,
                 max_frames: int = 200, altitude: float | None = None,
                 pitch: float | None = None, seed: int = 0, *,
                 fov: float | None = None) -> Footage:
    """Measure the frames at ``path`` (a folder or file of photos and videos; at most
    ``max_frames``, a seeded choice). ``labels``: a COCO json or YOLO folder whose boxes are
    kept out of the statistics (and whose ``meta`` gives altitude and pitch); ``altitude``
    / ``pitch`` override the meta; ``fov``: the frames' diagonal field of view (degrees;
    default: a photo's EXIF one, :func:`~.flightlog.photo_fov`), with which the sky of a
    frame of known pitch is kept out of the water
    (:func:`~sdcomp.report.realism.sources.sky_mask`). UserError when nothing can be read or
    measured."""
    _check_options(size, max_frames, fov)
    fs = load_real(path, labels, max_images=max_frames, seed=seed,
                   option_names=("FRAMES", "--labels"))
    if not fs.frames:
        raise UserError(f"{path}: no photos or videos found")
    s0 = fs.frames[0].source
    w, h = working_size(s0.width, s0.height, size)
    rows: list[dict[str, float] | None] = []
    crops: list[np.ndarray] = []
    alts, pitches, logs, skies, painted = [], [], 0, 0, 0
    fovs: list[float] = []
    patches: list[np.ndarray] = []
    rng = np.random.default_rng([int(seed), 0x9A7])
    for frame in fs.frames:
        loaded = load_frame(frame)  # a frame it cannot read stops the fit, naming it
        assert loaded is not None  # (None is only for a generated set's missing images)
        meta, logged = _frame_meta(frame)
        logs += logged
        alts.append(num(meta, ALTITUDE_KEY))
        pitches.append(num(meta, PITCH_KEY))
        exif = None if fov is not None else _exif_fov(frame)
        fovs += [exif] if exif is not None else []
        valid = _below_horizon(w, h, fov if fov is not None else exif,
                               pitch if pitch is not None else pitches[-1])
        skies += valid is not None and not valid.all()
        rgb, boxes = _resize(loaded.rgb, frame.boxes, w, h)
        scene = None if loaded.painted is None else shrink_valid(~loaded.painted, w, h)
        painted += scene is not None
        if scene is not None:
            valid = scene if valid is None else valid & scene
        keep = empty_water((h, w), None, boxes, valid)
        rows.append(measure_image(rgb, keep, scene))
        patches.append(water_patches(rgb, keep, rng))
        if len(crops) < 4:
            crops.append(rgb)
    per = stack(rows)
    if per["luminance"].size == 0:
        raise UserError(f"{path}: none of the {len(fs.frames)} frames has a 64 x 64 patch of "
                        f"water free of labelled objects to measure")
    out = Footage(per, summary(per), w, h, crops=crops, frames=per["luminance"].size,
                  patches=np.concatenate(patches),
                  patch_frames=np.repeat(np.arange(len(patches)), [len(p) for p in patches]))
    out.altitude = _geometry(altitude, alts, ALTITUDE_RANGE, "altitude")
    out.pitch = _geometry(pitch, pitches, PITCH_RANGE, "pitch")
    out.sky_masked = skies > 0
    out.fov = fov if fov is not None else (
        round(float(np.median(fovs)), 1) if fovs else None)
    out.notes = [*fs.notes, f"measured at {w} x {h} px"] + [note for n, note in (
        (logs, f"altitude or pitch of {logs} frames from flight logs (DJI XMP, SRT)"),
        (len(fovs), f"field of view of {len(fovs)} photos from their EXIF (35 mm equivalent "
                    f"focal length): {out.fov} degrees diagonally"),
        (skies, f"sky kept out of {skies} frames (their pitch and field of view)"),
        (painted, f"painted-out (black) regions kept out of {painted} frames")) if n]
    return out


def _check_options(size: int | None, max_frames: int, fov: float | None) -> None:
    """UserError naming a bad ``--size``, ``--max-frames`` or ``--fov``."""
    if size is not None and not PATCH <= size <= 4096:
        raise UserError(f"--size {size} is out of range: use {PATCH} to 4096 pixels")
    if max_frames < 1:
        raise UserError(f"--max-frames {max_frames} must be at least 1")
    if fov is not None and not 1 < fov < 170:
        raise UserError(f"--fov {fov} is out of range: use 1 to 170 degrees (the frames' "
                        f"diagonal field of view)")


def _frame_meta(frame: Frame) -> tuple[dict, bool]:
    """A frame's meta (its labels'), completed from its flight log (:mod:`.flightlog`: a
    photo's DJI XMP, a video's SRT) where altitude or pitch is missing; and whether the log
    gave anything."""
    meta = frame.meta
    if frame.source is None or (num(meta, ALTITUDE_KEY) is not None
                                and num(meta, PITCH_KEY) is not None):
        return meta, False
    k = frame.source.frame
    logged = dji_meta(frame.path) if k is None else srt_meta(frame.path, k)
    return {**logged, **meta}, bool(logged)


def _exif_fov(frame: Frame) -> float | None:
    """A photo's diagonal field of view from its EXIF (:func:`~.flightlog.photo_fov`); None
    for a video frame or a photo without one."""
    s = frame.source
    return None if s is None or s.frame is not None else photo_fov(frame.path)


def _below_horizon(w: int, h: int, fov: float | None, pitch: float | None
                   ) -> np.ndarray | None:
    """(h, w) bool, False on the sky (:func:`~sdcomp.report.realism.sources.sky_mask`) of a
    w x h frame of diagonal field of view ``fov`` at ``pitch`` degrees; None when either is
    unknown or the frame looks straight down."""
    if fov is None or pitch is None or not 0 < pitch < 90:
        return None
    return sky_mask(CameraModel(w, h, fov, w, h), pitch)


def _resize(rgb: np.ndarray, boxes: list | None, w: int, h: int
            ) -> tuple[np.ndarray, list | None]:
    """``rgb`` (H, W, 3) uint8 resized to w x h (area filter down, cubic up) and its (x, y,
    w, h) pixel boxes scaled with it."""
    ih, iw = rgb.shape[:2]
    if (iw, ih) == (w, h):
        return rgb, boxes
    interp = cv2.INTER_AREA if w < iw else cv2.INTER_CUBIC
    out = cv2.resize(rgb, (w, h), interpolation=interp)
    if boxes is not None:
        fx, fy = w / iw, h / ih
        boxes = [[b[0] * fx, b[1] * fy, b[2] * fx, b[3] * fy] for b in boxes]
    return out, boxes


def _geometry(given: float | None, meta: list, bounds: tuple[float, float], name: str
              ) -> list[float]:
    """The values of ``name`` (altitude or pitch): ``given`` (checked against ``bounds``),
    else the frames' meta values within bounds, else []."""
    lo, hi = bounds
    if given is not None:
        if not (math.isfinite(given) and lo <= given <= hi):
            raise UserError(f"--{name} {given} is out of range: use {lo:g} to {hi:g}")
        return [float(given)]
    return [float(v) for v in meta if v is not None and lo <= v <= hi]
