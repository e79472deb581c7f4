"""One image of a run: render it, write its files, return its journal record.

The record is ``{"index", "split", "image": {id, file_name, width, height, mask_file, camera,
meta}, "annotations": [...]}`` (see :mod:`sdcomp.io.journal`), and for an image with ignore
regions ``"ignore": [...]`` (iscrowd entries) and the image's ``ignore_file``; the image, its
16-bit mask, its ignore mask and the label writers' per-image files are written (each
atomically) before it is returned, so a journaled image always has its files. The image id
is the index, the number in the file name (``train/000017.jpg`` has id 17), as Ultralytics'
``save_json`` and most tools take it.
"""

from __future__ import annotations

from functools import lru_cache

import cv2
import numpy as np

from ..annotate import camera_record, coco_annotations, ignore_annotations, image_meta
from ..io.layout import DatasetLayout, ignore_name, split_name
from ..io.png import encode_ignore_png, encode_png16
from ..io.writers import LabelWriter
from ..pipeline import Generator
from ..util import files

SPLIT_BLOCK = 100  # val images are exactly round(f * 100) of every 100 consecutive ones


def split_of(seed: int, index: int, val_fraction: float) -> str:
    """``"val"`` or ``"train"`` for image ``index``: in every block of 100 consecutive
    images, exactly ``round(100 * val_fraction)`` chosen by a seeded permutation are val."""
    block, pos = divmod(int(index), SPLIT_BLOCK)
    k = int(round(val_fraction * SPLIT_BLOCK))
    if k <= 0:
        return "train"
    return "val" if _block_order(int(seed), block)[pos] < k else "train"


@lru_cache(maxsize=16)
def _block_order(seed: int, block: int) -> tuple[int, ...]:
    """The seeded permutation of a block of :data:`SPLIT_BLOCK` images (kept for the
    block's other images: drawing it costs more than writing an image's record)."""
    return tuple(np.random.default_rng([seed, block, 0x5B11]).permutation(SPLIT_BLOCK)
                 .tolist())


def encode_image(image: np.ndarray, image_format: str, jpeg_quality: int) -> bytes:
    """The (H, W, 3) uint8 RGB ``image`` as JPEG (of ``jpeg_quality``) or PNG file bytes.
    The image's channels are swapped to BGR in place (it is not used after)."""
    bgr = rgb_to_bgr_in_place(image)
    if image_format == "jpg":
        ok, data = cv2.imencode(".jpg", bgr, [cv2.IMWRITE_JPEG_QUALITY, jpeg_quality])
    else:
        ok, data = cv2.imencode(".png", bgr, [cv2.IMWRITE_PNG_COMPRESSION, 1])
    if not ok:
        raise RuntimeError(f"could not encode an image of shape {image.shape}")
    return data.tobytes()


def rgb_to_bgr_in_place(image: np.ndarray, band_bytes: int = 1 << 24) -> np.ndarray:
    """Swap an (H, W, 3) uint8 image to OpenCV's BGR order in place, in bands of rows (a
    30000 x 30000 frame is 2.7 GB: no room for a whole copy, which OpenCV makes even when
    asked to convert in place). Returns ``image``."""
    rows = max(1, band_bytes // max(1, image.shape[1] * 3))
    for y in range(0, image.shape[0], rows):
        band = image[y:y + rows]
        cv2.cvtColor(band, cv2.COLOR_RGB2BGR, dst=band)
    return image


def make_record(gen: Generator, index: int, layout: DatasetLayout,
                writers: list[LabelWriter]) -> dict:
    """Render image ``index``, write its image, mask and label files, return its journal
    record."""
    config = gen.config
    frame = gen.render(index)
    split = split_of(config.seed, index, config.val_fraction)
    name = split_name(index, config.image_format, split)
    mask_name = split_name(index, "png", split)
    data = encode_image(frame.image, config.image_format, frame.scene.jpeg_quality)
    files.write_file(layout.images / name, data)
    files.write_file(layout.masks / mask_name, encode_png16(frame.instances))
    anns = coco_annotations(frame)
    for writer in writers:  # before the record is returned (and journaled)
        writer.write_image(layout, index, split, frame.instances, anns)
    h, w = frame.instances.shape
    image = {"id": index, "file_name": name, "width": w, "height": h, "mask_file": mask_name,
             "camera": camera_record(frame, config.camera), "meta": image_meta(frame)}
    rec = {"index": index, "split": split, "image": image, "annotations": anns}
    if frame.ignore is not None:
        files.write_file(layout.ignore_file(index, split), encode_ignore_png(frame.ignore))
        image["ignore_file"] = ignore_name(index, split)
        rec["ignore"] = ignore_annotations(frame)
    return rec
