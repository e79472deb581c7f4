"""COCO label files: the two split files written from the journal, streaming and atomic.

:func:`write_coco` streams the images, then the annotations, of one split in index order from
the journal (:mod:`sdcomp.io.journal`) through a temporary file that is renamed into place
(:func:`sdcomp.util.files.atomic_path`). :class:`CocoWriter` is the ``coco`` label writer of
:mod:`sdcomp.io.writers`.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from ..errors import UserError
from ..scene.config import MAX_INSTANCES, GeneratorConfig
from ..util.files import atomic_path
from .journal import dumps_compact, is_int, iter_records
from .layout import SPLITS, DatasetLayout

#: dataset.json "layout" entries of the COCO files
LAYOUT = {"train": "annotations/instances_train.json", "val": "annotations/instances_val.json"}


def annotation_id(image_index: int, instance_id: int) -> int:
    """The COCO annotation id of instance ``instance_id`` (1..999) in image ``image_index``.

    ``(image_index + 1) * 1000 + instance_id``: deterministic, unique over the run and the
    same whichever split the image is in.
    """
    if not is_int(image_index) or image_index < 0:
        raise ValueError(f"image_index must be an integer >= 0, got {image_index!r}")
    if not is_int(instance_id) or not 1 <= instance_id <= MAX_INSTANCES:
        raise ValueError(f"instance_id must be an integer in 1..{MAX_INSTANCES}, "
                         f"got {instance_id!r}")
    return (int(image_index) + 1) * 1000 + int(instance_id)


def _check_categories(categories: list[dict]) -> None:
    seen = set()
    for cat in categories:
        cid = cat.get("id") if isinstance(cat, dict) else None
        if not isinstance(cid, int) or not is_int(cid) or cid < 1 or cid in seen \
                or "name" not in cat:
            raise ValueError("categories must be dicts with a unique integer 'id' >= 1 and "
                             f"a 'name', got {cat!r}")
        seen.add(cid)


#: SeaDronesSee's category of what it does not label (``--ignored-category``)
IGNORED_CATEGORY = {"supercategory": "ignored", "id": 0, "name": "ignored"}


def ignore_entries(rec: dict, ignored_category: bool) -> list[dict]:
    """The COCO annotations of record ``rec``'s ignore regions (its ``"ignore"`` list), with
    instance ids after its labelled objects' and, with ``ignored_category``, category 0."""
    first = len(rec.get("annotations", ())) + 1
    out = []
    for j, ign in enumerate(rec.get("ignore", ())):
        full = dict(ign, instance_id=first + j)
        if ignored_category:
            full["category_id"] = IGNORED_CATEGORY["id"]
        out.append(full)
    return out


def write_coco(path: str | Path, journal_path: str | Path, offsets: dict[int, int],
               split: str | None, categories: list[dict], info: dict,
               ignored_category: bool = False) -> dict:
    """Write the COCO JSON file of one split from the journal; return its counts.

    The file is ``{"info", "licenses": [], "categories", "images", "annotations"}``: the images
    of ``split`` (None: all records) in index order, then their annotations, each the record's
    annotation plus ``"id": annotation_id(index, instance_id)`` and ``"image_id"``. Two
    streaming passes over the journal, nothing held; written to a temporary file renamed onto
    ``path``, so a crash never leaves a half file. The output depends only on the records,
    not on their order in the journal. A record's ignore regions follow its annotations
    (:func:`ignore_entries`: ``iscrowd`` 1; with ``ignored_category`` of category 0,
    SeaDronesSee's ``ignored``, listed first). Returns ``{"images": n, "annotations": m}``
    (ignore entries included).
    """
    _check_categories(categories)
    if ignored_category:
        categories = [IGNORED_CATEGORY, *categories]
    n_images = n_anns = 0
    with atomic_path(path) as tmp, open(tmp, "w", encoding="utf-8") as out:
        out.write(f'{{"info":{dumps_compact(info)},"licenses":[],'
                  f'"categories":{dumps_compact(categories)},"images":[')
        for rec in iter_records(journal_path, offsets, split):
            out.write(("," if n_images else "") + dumps_compact(rec["image"]))
            n_images += 1
        out.write('],"annotations":[')
        for rec in iter_records(journal_path, offsets, split):
            image_id, seen = rec["image"]["id"], set()
            for ann in [*rec.get("annotations", ()), *ignore_entries(rec, ignored_category)]:
                inst = ann.get("instance_id")
                if inst in seen:
                    raise UserError(f"{journal_path}: record {rec['index']} has instance_id "
                                    f"{inst} twice")
                seen.add(inst)
                full = {"id": annotation_id(rec["index"], inst), "image_id": image_id}
                full.update((k, v) for k, v in ann.items() if k not in full)
                out.write(("," if n_anns else "") + dumps_compact(full))
                n_anns += 1
        out.write("]}\n")
        out.flush()
        os.fsync(out.fileno())
    return {"images": n_images, "annotations": n_anns}


class CocoWriter:
    """The ``coco`` label format: ``annotations/instances_{train,val}.json`` made from the
    journal (nothing per image). See :class:`sdcomp.io.writers.LabelWriter`."""

    def __init__(self, config: GeneratorConfig):
        self.ignored_category = config.ignored_category

    def folders(self, layout: DatasetLayout) -> tuple[Path, ...]:
        return (layout.annotations,)

    def image_files(self, layout: DatasetLayout, index: int, split: str) -> tuple[Path, ...]:
        return ()

    def write_image(self, layout: DatasetLayout, index: int, split: str,
                    instances: np.ndarray, annotations: list[dict]) -> None:
        return None

    def finish(self, layout: DatasetLayout, offsets: dict[int, int], categories: list[dict],
               info: dict) -> dict[str, int]:
        return {split: write_coco(layout.coco_file(split), layout.journal, offsets, split,
                                  categories, info, self.ignored_category)["images"]
                for split in SPLITS}

    def layout_entries(self) -> dict[str, str]:
        return dict(LAYOUT)
