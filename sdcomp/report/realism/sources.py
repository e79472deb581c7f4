"""The two kinds of image sets the realism report reads: a generated dataset and real frames.

A generated dataset is read through :func:`sdcomp.io.layout.load_dataset` (the one reader):
images, 16-bit instance masks, boxes and each image's ``meta`` (its GSD, altitude and gimbal
pitch). Sky and land are kept out of "empty water" by :class:`SeaOracle`.

Real frames are the user's footage (:mod:`sdcomp.render.footage`): a folder (or file) of
photos and videos, every video frame a candidate, optionally with labels (a COCO json file or
a YOLO labels folder) whose boxes are kept out of empty water. A frame a COCO file does not
list is skipped (its objects are unknown); a frame without a YOLO label file has none. Their
painted-out regions (:mod:`.painted`: SeaDronesSee's black paint over what it does not
label) are not water either.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np

from ...errors import UserError
from ...io.layout import load_dataset
from ...render.footage import Source, VideoReader, list_sources, read_source
from ...render.footage_labels import Labels, read_labels
from ...scene.camera import CameraModel, camera_basis, horizon_row
from .painted import painted_mask
from .sea import ALTITUDE_KEY, GSD_KEY, PITCH_KEY, SeaOracle, num

REAL_SKY_MARGIN = 0.05  #: fraction of the height kept clear below a real frame's horizon
PAINT_HOW = "painted-out (black) regions excluded"  #: a real frame's valid mask, painted


@dataclass
class Frame:
    """One image of a set, not yet read.

    Attributes:
        path: the image (or video) file; ``source`` the real frame it is (None: generated).
        group: index of the image within its set (cross-validation folds split by it).
        boxes: (x, y, w, h) pixel boxes to keep clear (objects), or None when unknown.
        categories: the category name of each box (parallel to ``boxes``), or None.
        mask_path: the 16-bit instance-id PNG (generated sets), or None.
        meta: the image's metadata (COCO ``meta``), possibly empty.
        camera: the image's COCO ``camera`` record (intrinsics ``K`` with the lens's zoom,
            ``dist_coeffs``, pose ``R_w2c``, ``t_w2c``), possibly empty; for a real frame
            whose meta and ``--real-fov`` give its pose, a pinhole record of that pose
            (:func:`pinhole_record`).
        gsd: metres per pixel at the image centre, or None when unknown.
        gsd_source: where ``gsd`` comes from: "meta", "camera", "user" or "unknown".
        valid: callable (H, W) -> ((H, W) bool valid-pixel mask or None for all, how) or None.
        what: how the command names the real frames in its errors (``--real``, ``FRAMES``).
    """

    path: Path
    group: int
    boxes: list | None = None
    mask_path: Path | None = None
    meta: dict = field(default_factory=dict)
    gsd: float | None = None
    gsd_source: str = "unknown"
    valid: Callable | None = None
    source: Source | None = None
    camera: dict = field(default_factory=dict)
    categories: list | None = None
    what: str = "--real"


@dataclass
class FrameSet:
    """The frames of a set, its kind ("generated" or "real"), its folder and notes (one-line
    facts about how it was read, for the report)."""

    kind: str
    folder: Path
    frames: list
    notes: list = field(default_factory=list)


@dataclass
class Loaded:
    """A frame read into memory: ``rgb`` (H, W, 3) uint8, ``instances`` (H, W) uint16 or None,
    ``valid`` (H, W) bool or None (all valid), ``valid_how`` how that mask was made,
    ``painted`` (H, W) bool, True on a real frame's painted-out regions (already False in
    ``valid``), or None where there are none."""

    rgb: np.ndarray
    instances: np.ndarray | None
    valid: np.ndarray | None
    valid_how: str
    painted: np.ndarray | None = None


_VIDEOS = VideoReader("--real")


def read_rgb(path: Path) -> np.ndarray | None:
    """(H, W, 3) uint8 RGB of an image file (grey and alpha are converted), None if unreadable."""
    data = np.fromfile(str(path), np.uint8) if path.is_file() else None
    if data is None or data.size == 0:
        return None
    bgr = cv2.imdecode(data, cv2.IMREAD_COLOR)
    return None if bgr is None else cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB)


def read_mask(path: Path) -> np.ndarray | None:
    """(H, W) uint16 instance ids of a 16-bit PNG, None if missing or unreadable."""
    m = cv2.imread(str(path), cv2.IMREAD_UNCHANGED) if path.is_file() else None
    if m is None:
        return None
    return (m[..., 0] if m.ndim == 3 else m).astype(np.uint16, copy=False)


def frame_rgb(frame: Frame) -> np.ndarray | None:
    """(H, W, 3) uint8 RGB of a :class:`Frame`; None when a generated frame's image cannot be
    read (skipped and counted). A real frame that cannot be read is a UserError naming it,
    the rule of every command for the user's frames (:mod:`sdcomp.render.footage`). Only the
    pixels: :func:`load_frame` also reads the mask and valid pixels."""
    if frame.source is not None:
        return read_source(frame.source, _VIDEOS, frame.what)
    return read_rgb(frame.path)


def load_frame(frame: Frame) -> Loaded | None:
    """Read a :class:`Frame`; None when a generated frame's image cannot be read (a real
    frame's is a UserError, :func:`frame_rgb`). A real frame's
    painted-out regions (:func:`~.painted.painted_mask`) are invalid pixels."""
    rgb = frame_rgb(frame)
    if rgb is None:
        return None
    inst = read_mask(frame.mask_path) if frame.mask_path is not None else None
    if inst is not None and inst.shape != rgb.shape[:2]:
        inst = None
    valid, how = (None, "unknown: all pixels accepted")
    if frame.valid is not None:
        valid, how = frame.valid(rgb.shape[:2])
    painted = frame_painted(frame, rgb)
    if painted is not None:
        valid = ~painted if valid is None else valid & ~painted
        how = PAINT_HOW if frame.valid is None else f"{how}; {PAINT_HOW}"
    return Loaded(rgb, inst, valid, how, painted)


def frame_painted(frame: Frame, rgb: np.ndarray) -> np.ndarray | None:
    """The painted-out regions (:func:`~.painted.painted_mask`) of a real frame's pixels
    ``rgb``; None for a generated frame (sdcomp paints nothing) or where there are none."""
    return painted_mask(rgb) if frame.source is not None else None


def subsample(frames: list, max_images: int | None, seed: int) -> list:
    """At most ``max_images`` of ``frames`` (a seeded random choice, kept in order), each
    numbered by its position (:attr:`Frame.group`)."""
    if max_images is not None and len(frames) > max_images:
        pick = np.sort(np.random.default_rng(seed).choice(len(frames), max_images,
                                                           replace=False))
        frames = [frames[i] for i in pick]
    for i, f in enumerate(frames):
        f.group = i
    return frames


# --------------------------------------------------------------------------- generated sets

def load_generated(folder: str | Path, max_images: int | None = None, seed: int = 0,
                   exclude_clutter: bool = False) -> FrameSet:
    """The frames of a generated dataset folder (at most ``max_images``, a seeded choice).

    UserError for a missing folder, a folder that is not a dataset, unreadable COCO files,
    or no images."""
    data = load_dataset(folder)
    layout = data.layout
    oracle = SeaOracle(layout.run_config(), exclude_clutter)
    frames = []
    for e in data.entries:
        img = e.image
        path = layout.images / img["file_name"]
        if not path.is_file():
            continue
        meta: dict = img["meta"] if isinstance(img.get("meta"), dict) else {}
        mask = img.get("mask_file") or str(Path(img["file_name"]).with_suffix(".png"))
        anns = [a for a in e.annotations if isinstance(a.get("bbox"), (list, tuple))]
        boxes = [a["bbox"] for a in anns]
        names = [data.categories.get(a.get("category_id"), str(a.get("category_id")))
                 for a in anns]
        gsd = num(meta, GSD_KEY)
        camera: dict = img["camera"] if isinstance(img.get("camera"), dict) else {}
        index = int(img["id"])  # format 2: the image id is its index
        frames.append(Frame(path, 0, boxes, layout.masks / mask, meta, gsd,
                            "meta" if gsd else "unknown", oracle.bind(index, meta, camera),
                            camera=camera, categories=names))
    if not frames:
        raise UserError(f"{str(layout.root)!r} has no readable images listed in its "
                        f"annotations; give the --out folder of a finished `sdcomp generate`")
    n = len(frames)
    frames = subsample(frames, max_images, seed)
    notes = [f"{n} images listed, {len(frames)} used"]
    if oracle.config is None:
        notes.append("the run's config could not be read: land and clutter are not excluded "
                     "from empty water, nor sky")
    return FrameSet("generated", layout.root, frames, notes)


# --------------------------------------------------------------------------- real frames

def load_real(path: str | Path, labels: str | Path | None = None, gsd: float | None = None,
              fov: float | None = None, max_images: int | None = None, seed: int = 0,
              option_names: tuple[str, str] = ("--real", "--real-labels")
              ) -> FrameSet:
    """The real frames at ``path`` (photos and videos; at most ``max_images``, a seeded
    choice).

    Args:
        labels: a COCO json file or YOLO labels folder: boxes kept clear; a COCO file's
            ``meta`` (altitude, gimbal pitch) gives the GSD with ``fov``.
        gsd: metres per pixel of every frame (overrides the meta).
        fov: diagonal field of view of the frames as stored, degrees (for the GSD from meta
            and the horizon of oblique frames).
        option_names: how the command calls the frames and the labels in its errors (``sdcomp
            realism``: ``--real``, ``--real-labels``; ``sdcomp fit``: ``FRAMES``,
            ``--labels``).
    UserError for a missing path, no frames, unreadable labels or bad values."""
    if gsd is not None and not (math.isfinite(gsd) and 0 < gsd < 1000):
        raise UserError(f"--real-gsd {gsd} is out of range: use metres per pixel > 0")
    if fov is not None and not 1 < fov < 170:
        raise UserError(f"--real-fov {fov} is out of range: use 1 to 170 degrees")
    sources = list_sources(path, option_names[0])
    lab: Labels | None = (read_labels(labels, option_names[1]) if labels is not None
                          else None)
    frames, unlisted = [], 0
    for s in sources:
        fl = lab.of(s.key) if lab is not None else None
        if lab is not None and lab.kind == "coco" and fl is None:
            unlisted += 1
            continue
        boxes = fl.pixels(s.width, s.height).tolist() if fl is not None else (
            [] if lab is not None else None)
        names = ([lab.categories.get(int(c), str(c)) for c in fl.categories]
                 if fl is not None and lab is not None else ([] if lab is not None else None))
        frames.append(Frame(s.path, 0, boxes, None, dict(fl.meta) if fl else {}, source=s,
                            categories=names, what=option_names[0]))
    if lab is not None and not frames:
        raise UserError(f"{option_names[1]} {labels}: none of the {len(sources)} frames of "
                        f"{path} is listed in it (matched by file name without extension; "
                        f"video frames: <video name>_<frame:06d>)")
    frames = subsample(frames, max_images, seed)
    for f in frames:
        _real_geometry(f, gsd, fov)
    notes = []
    if unlisted:
        notes.append(f"{unlisted} frames not listed in the COCO file were skipped")
    if lab is None:
        notes.append("no labels: every patch of the real frames counts as empty water")
    notes.append(f"{len(frames)} frames used of {len(sources) - unlisted}; GSD known for "
                 f"{sum(f.gsd is not None for f in frames)}")
    return FrameSet("real", Path(path), frames, notes)


def _real_geometry(frame: Frame, gsd: float | None, fov: float | None) -> None:
    """Set a real frame's GSD (``gsd``, else its meta with a camera of ``fov``) and, for an
    oblique frame of known pitch and ``fov``, its sky mask; with a known altitude too, its
    camera record (:func:`pinhole_record`)."""
    s = frame.source
    assert s is not None
    alt, pitch = num(frame.meta, ALTITUDE_KEY), num(frame.meta, PITCH_KEY)
    if gsd is not None:
        frame.gsd, frame.gsd_source = float(gsd), "user"
    if fov is None or pitch is None or not 0 < pitch <= 90:
        return
    model = CameraModel(s.width, s.height, fov, s.width, s.height)
    if alt is not None and alt > 0:
        frame.camera = pinhole_record(model, alt, pitch)
    if gsd is None and alt:
        frame.gsd = alt / math.sin(math.radians(pitch)) / model.fx
        frame.gsd_source = "camera"
    if pitch < 90:
        frame.valid = _real_sky(fov, pitch)


def pinhole_record(model: CameraModel, altitude: float, pitch: float) -> dict:
    """A COCO ``camera`` record as sdcomp writes one (``K`` in OpenCV's convention, no
    distortion, ``R_w2c`` rows right / down / forward in world axes, ``t_w2c`` metres) of a
    pinhole ``model`` at ``altitude`` metres above the sea, ``pitch`` degrees below the
    horizon, heading 0."""
    rot = camera_basis(pitch, 0.0)
    t = -rot @ np.array([0.0, 0.0, float(altitude)])
    return {"K": [[model.fx, 0.0, model.width / 2 - 0.5], [0.0, model.fy, model.height / 2 - 0.5],
                  [0.0, 0.0, 1.0]], "dist_coeffs": [0.0] * 5, "width": model.width,
            "height": model.height, "R_w2c": rot.tolist(), "t_w2c": t.tolist()}


def sky_mask(model: CameraModel, pitch: float) -> np.ndarray:
    """(H, W) bool, False on the sky of a frame of camera ``model`` looking ``pitch`` degrees
    below the horizon: the rows above its horizon and :data:`REAL_SKY_MARGIN` of the height
    below it (haze, hills, shores)."""
    h, w = int(model.height), int(model.width)
    top = horizon_row(model, pitch) + REAL_SKY_MARGIN * h
    return np.repeat((np.arange(h) >= top)[:, None], w, axis=1)


def _real_sky(fov: float, pitch: float) -> Callable:
    def valid(shape: tuple[int, int]):
        h, w = shape
        return (sky_mask(CameraModel(w, h, fov, w, h), pitch),
                "sky excluded (from pitch and --real-fov, 5 % margin)")
    return valid
