"""The mask rule: which pixels belong to which object, and which objects are annotated.

Each layer carries a *weight* per pixel: the fraction of that pixel's colour that comes from
the object itself (its coverage, times the water's transmittance to the visible surface, times
``1 - coverage`` of every layer composited in front of it; see :mod:`sdcomp.render.layers`). A
pixel belongs to an object's mask when the object's weight there is at least
:data:`MASK_THRESHOLD`: the object supplies at least half of the pixel's colour. So the mask
excludes what other objects hide, what murky water hides, and everything outside the frame; at
most one object can pass the rule for a pixel except in exact ties, which go to the nearer
object. The bbox and area of an annotation are those of its final mask (after the camera's
lens has moved it: :func:`measure`). Blur, noise and the camera's other stages come after and
do not change masks.

The labelling policy (:class:`AnnotationRule`, the same for stills and video frames): an
object of interest with visible pixels is *labelled* (its visible mask and box, whether the
frame's edge cuts it or not: *truncated*) when a detector can learn from them: at least
``min_visible_px`` pixels, a box of at least :data:`MIN_SIDE` pixels each way, and at least
``min_in_frame`` of its silhouette in the frame (0 by default: SeaDronesSee, COCO and
MOTChallenge label cut objects by what is visible). Every other object with visible pixels
is *ignored*: its pixels form the image's ignore region (COCO ``iscrowd`` entries, an ignore
mask), so nothing a detector sees is background by mistake. An object without a visible
pixel (out of the frame, hidden, in murky water) is *dropped*.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..render.layers import Layer
from ..scene.scene import Role, Scene

MASK_THRESHOLD = 0.5
#: pixels: a labelled object's box is at least this wide and high. A box 1 px across is a
#: line, not an object: Ultralytics' augmentation drops boxes of 2 px or less
#: (``box_candidates``) and an IoU of such a box moves by half with a one-pixel shift.
MIN_SIDE = 2
#: the rule as dataset.json states it
MASK_RULE = (f"a pixel belongs to an object when the object supplies at least "
             f"{MASK_THRESHOLD:g} of its colour (coverage x water transmittance x what is "
             f"not hidden by nearer objects), inside the frame")


@dataclass(frozen=True)
class AnnotationRule:
    """The labelling policy (see the module docstring): an object with visible pixels is
    labelled when it has at least ``min_visible_px`` of them, a box at least ``min_side``
    pixels wide and high and at least ``min_in_frame`` of its projected silhouette inside the
    frame; else it is ignored (its pixels an ignore region). With ``amodal``, labels also
    carry each object's whole projected silhouette."""

    min_visible_px: int = 4
    amodal: bool = False
    min_in_frame: float = 0.0
    min_side: int = MIN_SIDE

    def labelled(self, area: int, bbox: tuple[int, int, int, int], inside: float) -> bool:
        """Whether an object with ``area`` visible pixels, box ``bbox`` (x, y, w, h pixels)
        and the fraction ``inside`` of its silhouette in the frame is labelled (the caller
        has checked ``area > 0``; else it is dropped)."""
        return (area >= self.min_visible_px and min(bbox[2], bbox[3]) >= self.min_side
                and inside >= self.min_in_frame)


@dataclass
class Instance:
    """An annotated object in a rendered frame."""

    instance_id: int
    placement: int  # index into scene.placements
    category_id: int
    area: int
    bbox: tuple[int, int, int, int]  # x, y, w, h pixels
    amodal: np.ndarray | None = None  # (H, W) bool, only when asked for
    amodal_area: int = 0
    silhouette_area: int = 0  # pixels of the unoccluded in-frame silhouette (visibility)
    full_area: float = 0.0  # pixels of the whole silhouette, in the frame or out of it
    truncated: bool = False  # the frame's edge cuts its silhouette


@dataclass
class Measured:
    """What :func:`measure` finds in a label map: the labelled ``objects`` (ids 1..N), the
    ``ignored`` objects (``instance_id`` 0, their visible area and box), ``ignore`` (H, W)
    bool: the ignored objects' visible pixels (None when there are none), and ``dropped``:
    objects of interest with a layer but no visible pixel."""

    objects: list[Instance]
    ignored: list[Instance]
    ignore: np.ndarray | None
    dropped: int


@dataclass
class Frame:
    """A rendered and annotated image: ``image`` (H, W, 3) uint8 RGB, ``instances`` (H, W)
    uint16 ids (0 = none), the labelled ``objects`` and the count of objects of interest
    ``dropped`` (no visible pixel); ``scene`` is what it shows, ``camera`` what the camera
    stage did (its info dict: intrinsics ``K``, distortion ``dist``, ``zoom``, ``stages``;
    empty when none ran); ``ignored``: the objects of interest with visible pixels too few
    to label, whose pixels are ``ignore`` ((H, W) bool, None when there are none);
    ``skipped``: objects not drawn because they could not be labelled (``unlabelled``
    skip)."""

    image: np.ndarray
    instances: np.ndarray
    objects: list[Instance]
    dropped: int
    scene: Scene
    camera: dict = field(default_factory=dict)  # what the camera stage did (apply_camera)
    ignored: list[Instance] = field(default_factory=list)
    ignore: np.ndarray | None = None
    skipped: int = 0

    @property
    def truncated(self) -> int:
        """How many labelled objects the frame's edge cuts."""
        return sum(1 for o in self.objects if o.truncated)

    @property
    def gsd(self) -> float:
        """Metres per pixel (along x) at the image centre of the recorded image (the lens's
        zoom magnifies it)."""
        return self.scene.gsd / float(self.camera.get("zoom", 1.0))


def label_map(scene: Scene, layers: list[Layer]) -> tuple[np.ndarray, list[Layer]]:
    """(labels (H, W) uint16, the layers of the objects of interest in placement order):
    the k-th of them labels ``k + 1`` the pixels where it passes the mask rule
    (:data:`MASK_THRESHOLD`), nearer objects over farther ones (ties go to the nearer)."""
    model = scene.model
    labels = np.zeros((model.height, model.width), np.uint16)
    objs = sorted((lay for lay in layers if lay.role is Role.OBJECT),
                  key=lambda lay: lay.placement)
    ids = {lay.placement: k + 1 for k, lay in enumerate(objs)}
    for lay in layers:  # far to near
        if lay.role is Role.OBJECT:
            x0, y0, x1, y1 = lay.roi
            labels[y0:y1, x0:x1][lay.weight >= MASK_THRESHOLD] = ids[lay.placement]
    return labels, objs


def amodal_masks(shape: tuple[int, int], objs: list[Layer]) -> np.ndarray:
    """(N, H, W) bool: each object's whole projected silhouette in the frame (coverage at
    least :data:`MASK_THRESHOLD`, hidden or not)."""
    out = np.zeros((len(objs),) + tuple(shape), bool)
    for k, lay in enumerate(objs):
        x0, y0, x1, y1 = lay.roi
        out[k, y0:y1, x0:x1] = lay.alpha >= MASK_THRESHOLD
    return out


def truncated(layer: Layer, shape: tuple[int, int]) -> float:
    """The fraction of ``layer``'s projected silhouette (its coverage) inside a frame of
    ``shape`` (H, W); 1 for a layer that does not reach the frame's edge."""
    x0, y0, x1, y1 = layer.roi
    h, w = shape
    if x0 > 0 and y0 > 0 and x1 < w and y1 < h:
        return 1.0
    return min(float(layer.alpha.sum()) / max(layer.full_area, 1e-9), 1.0)


def measure(labels: np.ndarray, objs: list[Layer], rule: AnnotationRule,
            amodal: np.ndarray | None, moved: bool, zoom: float = 1.0) -> Measured:
    """The labelled and ignored objects of a label map (:func:`label_map`, possibly ``moved``
    by the camera's lens) with their boxes and areas by ``rule``
    (:meth:`AnnotationRule.labelled`), the ignore mask of the ignored ones' pixels, and how
    many had no visible pixel (dropped). ``labels`` is renumbered in place (labelled objects
    1..N in order, the others 0); ``amodal`` (K, H, W) bool, when given, goes with its
    objects (moved likewise). ``zoom``: the lens's magnification, which the silhouettes
    measured on the layers (before the lens) take to be compared with areas measured after
    it (visibility)."""
    stats = _label_stats(labels, objs, moved)
    out: list[Instance] = []
    ignored: list[Instance] = []
    relabel = np.zeros(len(objs) + 1, np.uint16)
    ignore_ids = np.zeros(len(objs) + 1, bool)
    dropped = 0
    for k, lay in enumerate(objs):
        area, bbox = stats[k]
        if area == 0:
            dropped += 1
            continue
        inside = truncated(lay, labels.shape)
        if not rule.labelled(area, bbox, inside):
            ignore_ids[k + 1] = True
            ignored.append(Instance(0, lay.placement, lay.category_id, area, bbox,
                                    truncated=inside < 1.0))
            continue
        relabel[k + 1] = len(out) + 1
        inst = Instance(len(out) + 1, lay.placement, lay.category_id, area, bbox,
                        truncated=inside < 1.0)
        inst.silhouette_area = (int(np.count_nonzero(amodal[k])) if amodal is not None else
                                round(np.count_nonzero(lay.alpha >= MASK_THRESHOLD)
                                      * (zoom * zoom if moved else 1.0)))
        inst.full_area = inst.silhouette_area / max(inside, 1e-9)
        if amodal is not None:
            inst.amodal = amodal[k]
            inst.amodal_area = int(amodal[k].sum())
        out.append(inst)
    ignore = _ignore_mask(labels, ignored, ignore_ids) if ignored else None
    if len(out) != len(objs):
        if moved:
            labels[:] = relabel[labels]
        else:
            _renumber(labels, objs, relabel)
    return Measured(out, ignored, ignore, dropped)


def _ignore_mask(labels: np.ndarray, ignored: list[Instance], ignore_ids: np.ndarray
                 ) -> np.ndarray:
    """(H, W) bool: the pixels of ``labels`` (ids before renumbering) whose id is flagged in
    ``ignore_ids`` ((K + 1,) bool), looked at only inside the ignored objects' boxes."""
    out = np.zeros(labels.shape, bool)
    for inst in ignored:
        x, y, w, h = inst.bbox
        win = labels[y:y + h, x:x + w]
        out[y:y + h, x:x + w] |= ignore_ids[win]
    return out


def _label_stats(labels: np.ndarray, objs: list[Layer], moved: bool
                 ) -> list[tuple[int, tuple[int, int, int, int]]]:
    """(area, bbox (x, y, w, h)) of labels 1..K: inside each object's drawn box when the
    labels have not ``moved`` (frames can be huge), else from all labelled pixels."""
    out: list[tuple[int, tuple[int, int, int, int]]] = []
    if moved:  # the rows holding labels first: a frame's objects fill few of its rows
        rows = np.flatnonzero(labels.any(axis=1))
        sub = labels[rows]
        yy, xs = np.nonzero(sub)
        ids, ys = sub[yy, xs], rows[yy]
        for k in range(1, len(objs) + 1):
            sel = ids == k
            out.append(_box(xs[sel], ys[sel], 0, 0))
        return out
    for k, lay in enumerate(objs):
        x0, y0, x1, y1 = lay.roi
        ys, xs = np.nonzero(labels[y0:y1, x0:x1] == k + 1)
        out.append(_box(xs, ys, x0, y0))
    return out


def _box(xs: np.ndarray, ys: np.ndarray, x0: int, y0: int
         ) -> tuple[int, tuple[int, int, int, int]]:
    if len(xs) == 0:
        return 0, (0, 0, 0, 0)
    return len(xs), (x0 + int(xs.min()), y0 + int(ys.min()), int(xs.max() - xs.min()) + 1,
                     int(ys.max() - ys.min()) + 1)


def _renumber(labels: np.ndarray, objs: list[Layer], relabel: np.ndarray) -> None:
    """Give the kept objects their new ids (dropped ones 0), inside each object's box only
    (frames can be huge), in increasing old id: new ids never exceed old ones, so a
    renumbered pixel is not matched again."""
    for k, lay in enumerate(objs):
        x0, y0, x1, y1 = lay.roi
        win = labels[y0:y1, x0:x1]
        win[win == k + 1] = relabel[k + 1]
