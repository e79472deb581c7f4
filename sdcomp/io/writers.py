"""Label writers: one class per output format behind one interface, and their registry.

A run (:mod:`sdcomp.run`) and ``merge`` talk to the formats of ``--format`` only through
:class:`LabelWriter`: the folders a format needs, the files it writes per image (so a resumed
run or a merge can check they exist), the per-image write (before the image's journal line),
and the files made from the whole journal at the end, at checkpoints and after Ctrl-C.
Adding a format is adding a class here and its name to
:data:`sdcomp.scene.config.LABEL_FORMATS`.
"""

from __future__ import annotations

from pathlib import Path
from typing import Protocol

import numpy as np

from ..scene.config import LABEL_FORMATS, GeneratorConfig
from .coco import CocoWriter
from .layout import DatasetLayout
from .yolo import YoloWriter


class LabelWriter(Protocol):
    """What a label format does in a run (see the module docstring)."""

    def folders(self, layout: DatasetLayout) -> tuple[Path, ...]:
        """Folders the format writes into (made before the run, swept of temporary files)."""
        ...

    def image_files(self, layout: DatasetLayout, index: int, split: str) -> tuple[Path, ...]:
        """The files the format writes for image ``index`` of ``split`` (none for whole-run
        formats)."""
        ...

    def write_image(self, layout: DatasetLayout, index: int, split: str,
                    instances: np.ndarray, annotations: list[dict]) -> None:
        """Write image ``index``'s own label files (it is in ``split``): ``instances``
        (H, W) uint16 ids, its journal annotations (``instance_id``, ``category_id``,
        ``bbox``, ...)."""
        ...

    def finish(self, layout: DatasetLayout, offsets: dict[int, int], categories: list[dict],
               info: dict) -> dict[str, int]:
        """Write the files made from the journal (``offsets``: {index: byte offset} of the
        images to include); returns images per split where the format counts them."""
        ...

    def layout_entries(self) -> dict[str, str]:
        """dataset.json "layout" entries of the format's files."""
        ...


#: format name -> writer class (constructed with the run's config)
WRITERS: dict[str, type] = {"coco": CocoWriter, "yolo": YoloWriter}
assert tuple(WRITERS) == LABEL_FORMATS, "register every label format of the config"


def writers_for(config: GeneratorConfig) -> list[LabelWriter]:
    """The label writers of ``config.format``, in the config's (canonical) order."""
    return [WRITERS[name](config) for name in config.format]
