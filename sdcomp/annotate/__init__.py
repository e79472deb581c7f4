"""Stage 5, annotation: a rendered frame's instance masks (the mask rule), its annotated
objects, and their COCO-style records.

- :mod:`~sdcomp.annotate.masks`: the mask rule and the labelling policy: instance ids,
  boxes, what is labelled, ignored or dropped;
- :mod:`~sdcomp.annotate.records`: annotation dicts and image metadata of a frame;
- :mod:`~sdcomp.annotate.rle`: COCO run-length encoding.
"""

from .masks import (
    MASK_THRESHOLD,
    AnnotationRule,
    Frame,
    Instance,
    Measured,
    amodal_masks,
    label_map,
    measure,
)
from .records import (
    camera_record,
    coco_annotations,
    ignore_annotations,
    image_meta,
    object_annotations,
)

__all__ = ["MASK_THRESHOLD", "AnnotationRule", "Frame", "Instance", "Measured", "amodal_masks",
           "label_map", "measure", "object_annotations", "coco_annotations",
           "ignore_annotations", "image_meta", "camera_record"]
