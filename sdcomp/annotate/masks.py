"""The mask rule: which pixels belong to which object, and which objects are annotated.

Each layer carries a *weight* per pixel: the fraction of that pixel's colour that comes from
the object itself (its coverage, times the water's transmittance to the visible surface, times
``1 - coverage`` of every layer composited in front of it; see :mod:`sdcomp.render.layers`). A
pixel belongs to an object's mask when the object's weight there is at least
:data:`MASK_THRESHOLD`: the object supplies at least half of the pixel's colour. So the mask
excludes what other objects hide, what murky water hides, and everything outside the frame; at
most one object can pass the rule for a pixel except in exact ties, which go to the nearer
object. The bbox and area of an annotation are those of its final mask; an object of interest
with fewer than ``min_visible_px`` mask pixels is not annotated and is counted as dropped.
Blur and noise come after and do not change masks.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..render.layers import Layer
from ..scene.scene import Role, Scene

MASK_THRESHOLD = 0.5
#: the rule as dataset.json states it
MASK_RULE = (f"a pixel belongs to an object when the object supplies at least "
             f"{MASK_THRESHOLD:g} of its colour (coverage x water transmittance x what is "
             f"not hidden by nearer objects), inside the frame")


@dataclass(frozen=True)
class AnnotationRule:
    """What is annotated: objects with at least ``min_visible_px`` mask pixels; with
    ``amodal``, also each object's whole projected silhouette."""

    min_visible_px: int = 4
    amodal: bool = False


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


@dataclass
class Frame:
    """A rendered and annotated image: ``image`` (H, W, 3) uint8 RGB, ``instances`` (H, W)
    uint16 ids (0 = none), the annotated ``objects`` and the count of objects of interest
    ``dropped`` for having too few visible pixels; ``scene`` is what it shows."""

    image: np.ndarray
    instances: np.ndarray
    objects: list[Instance]
    dropped: int
    scene: Scene

    @property
    def gsd(self) -> float:
        """Metres per pixel (along x) at the image centre."""
        return self.scene.gsd


def instance_map(scene: Scene, layers: list[Layer], rule: AnnotationRule
                 ) -> tuple[np.ndarray, list[Instance], int]:
    """(instances (H, W) uint16, the annotated objects in placement order with ids 1..N,
    the number of objects of interest dropped) of the composited ``layers`` (far to near,
    final weights) of ``scene``."""
    model = scene.model
    instances = np.zeros((model.height, model.width), np.uint16)
    objs = [lay for lay in layers if lay.role is Role.OBJECT]
    ids = {lay.placement: k + 1 for k, lay in
           enumerate(sorted(objs, key=lambda lay: lay.placement))}
    for lay in objs:  # far to near: ties go to the nearer object
        x0, y0, x1, y1 = lay.roi
        sel = lay.weight >= MASK_THRESHOLD
        instances[y0:y1, x0:x1][sel] = ids[lay.placement]
    out = []
    next_id = 0
    relabel = np.zeros(len(objs) + 1, np.uint16)
    for lay in sorted(objs, key=lambda lay: lay.placement):
        old = ids[lay.placement]
        x0, y0, x1, y1 = lay.roi
        region = instances[y0:y1, x0:x1] == old
        area = int(region.sum())
        if area < rule.min_visible_px:
            continue
        next_id += 1
        relabel[old] = next_id
        ys, xs = np.nonzero(region)
        bbox = (x0 + int(xs.min()), y0 + int(ys.min()), int(xs.max() - xs.min()) + 1,
                int(ys.max() - ys.min()) + 1)
        inst = Instance(next_id, lay.placement, lay.category_id, area, bbox)
        inst.silhouette_area = int(np.count_nonzero(lay.alpha >= MASK_THRESHOLD))
        if rule.amodal:
            full = np.zeros_like(instances, dtype=bool)
            full[y0:y1, x0:x1] = lay.alpha >= MASK_THRESHOLD
            inst.amodal = full
            inst.amodal_area = int(full.sum())
        out.append(inst)
    if len(out) != len(objs):
        _renumber(instances, objs, ids, relabel)
    return instances, out, scene.count(Role.OBJECT) - len(out)


def _renumber(instances: np.ndarray, objs: list[Layer], ids: dict[int, int],
              relabel: np.ndarray) -> None:
    """Give the kept objects their new ids (dropped ones 0), inside each object's box only
    (frames can be huge), in increasing old id: new ids never exceed old ones, so a
    renumbered pixel is not matched again."""
    for lay in sorted(objs, key=lambda lay: ids[lay.placement]):
        old = ids[lay.placement]
        x0, y0, x1, y1 = lay.roi
        win = instances[y0:y1, x0:x1]
        win[win == old] = relabel[old]
