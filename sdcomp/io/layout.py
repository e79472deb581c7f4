"""A dataset folder: where every file lives (:class:`DatasetLayout`) and the one checked reader.

Layout of a dataset folder ``root`` (format version 2), one sub-folder per split::

    images/train/000000.jpg      the images (or .png), sRGB; images/val/ likewise
    masks/train/000000.png       16-bit instance ids (0 = none; k = annotation with
                                 instance_id k of that image)
    masks/train/000000_ignore.png  8-bit ignore mask (255: pixels of objects of interest
                                 too small to label), only for images that have any; the
                                 COCO image's "ignore_file"
    annotations/instances_train.json, annotations/instances_val.json   COCO (--format coco):
                                 image id = the file's number (000017.jpg has id 17),
                                 file_name "train/000017.jpg" (relative to images/)
    labels/train/000000.txt      YOLO labels (--format yolo), beside images/train/
    train.txt, val.txt, data.yaml                                      YOLO lists (--format yolo)
    records.jsonl                one JSON line per finished image (the journal a resumed
                                 run continues from; the label files are made from it)
    dataset.json                 config, package version, seed, status and counts

Version 1 (no per-split folders) had flat images/, masks/, labels/ and COCO ids = number + 1;
:func:`check_format_version` refuses to continue such a folder.

:class:`DatasetLayout` is the only place that spells these names. :func:`load_dataset` is the
only reader of a finished (or interrupted) folder: contact sheets, statistics, the torch
datasets and the benchmark read through it. It reads the COCO files, or the journal where the
run wrote none (``--format yolo``).
"""

from __future__ import annotations

import json
import shlex
from dataclasses import dataclass, field
from pathlib import Path

from ..errors import UserError
from .journal import iter_records, read_journal

FORMAT = "sdcomp-dataset"
#: 2: per-split folders, COCO image id = file number, float boxes (1: flat folders, id + 1)
FORMAT_VERSION = 2
SPLITS = ("train", "val")
SPLIT_CHOICES = ("all", *SPLITS)
IMAGES, MASKS, ANNOTATIONS, LABELS = "images", "masks", "annotations", "labels"
JOURNAL, META = "records.jsonl", "dataset.json"
DATA_YAML = "data.yaml"
#: the ignore mask of image 000017 is masks/SPLIT/000017_ignore.png
IGNORE_SUFFIX = "_ignore.png"
#: the folders every run makes (the label writers add their own)
CORE_FOLDERS = (IMAGES, MASKS)
#: every top-level name a dataset folder may hold: what --overwrite replaces, nothing else
ENTRIES = (IMAGES, MASKS, ANNOTATIONS, JOURNAL, META, LABELS, *(f"{s}.txt" for s in SPLITS),
           DATA_YAML)
#: the order of the entries of dataset.json's "layout" (what each writer contributes)
LAYOUT_ORDER = ("images", "masks", "train", "val", "journal", "yolo_labels", "yolo_data",
                "yolo_train", "yolo_val")


def image_name(index: int, ext: str) -> str:
    """File name of image ``index`` with extension ``ext``: ``000017.jpg``."""
    return f"{index:06d}.{ext}"


def split_name(index: int, ext: str, split: str) -> str:
    """Name of image ``index``'s file relative to ``images/`` (or ``masks/``, ``labels/``):
    ``train/000017.jpg``; what the COCO ``file_name`` and ``mask_file`` hold."""
    return f"{split}/{image_name(index, ext)}"


def ignore_name(index: int, split: str) -> str:
    """Name of image ``index``'s ignore mask relative to ``masks/``: ``train/000017_ignore.png``
    (what the image record's ``ignore_file`` holds)."""
    return f"{split}/{index:06d}{IGNORE_SUFFIX}"


def check_format_version(meta: dict, root: Path, what: str) -> None:
    """UserError unless dataset.json ``meta`` (of the folder ``root``) is of this version's
    dataset format; ``what`` names the action refused (``--resume``, ``merge``)."""
    version = meta.get("format_version", 1)
    if version != FORMAT_VERSION:
        raise UserError(f"{what}: {root} was written by another sdcomp (dataset format "
                        f"{version}; this sdcomp writes format {FORMAT_VERSION}: per-split "
                        f"folders, COCO image id = file number): generate it afresh with "
                        f"--overwrite, or use the sdcomp that wrote it")


@dataclass(frozen=True)
class DatasetLayout:
    """The paths of the dataset folder ``root`` (see the module docstring)."""

    root: Path

    @property
    def images(self) -> Path:
        return self.root / IMAGES

    @property
    def masks(self) -> Path:
        return self.root / MASKS

    @property
    def annotations(self) -> Path:
        return self.root / ANNOTATIONS

    @property
    def labels(self) -> Path:
        return self.root / LABELS

    @property
    def journal(self) -> Path:
        return self.root / JOURNAL

    @property
    def meta(self) -> Path:
        return self.root / META

    @property
    def data_yaml(self) -> Path:
        return self.root / DATA_YAML

    def image_file(self, index: int, ext: str, split: str) -> Path:
        return self.images / split_name(index, ext, split)

    def mask_file(self, index: int, split: str) -> Path:
        return self.masks / split_name(index, "png", split)

    def ignore_file(self, index: int, split: str) -> Path:
        """The ignore mask of image ``index`` (written only when it has ignore pixels)."""
        return self.masks / ignore_name(index, split)

    def coco_file(self, split: str) -> Path:
        return self.annotations / f"instances_{split}.json"

    def label_file(self, index: int, split: str) -> Path:
        return self.labels / split_name(index, "txt", split)

    def split_folders(self, folder: Path) -> tuple[Path, ...]:
        """``folder``'s per-split sub-folders: ``folder/train``, ``folder/val``."""
        return tuple(folder / s for s in SPLITS)

    def list_file(self, split: str) -> Path:
        return self.root / f"{split}.txt"

    def resume_hint(self) -> str:
        """How to finish or repair the dataset: --resume redraws images and masks that are
        missing and rewrites the label files."""
        return (f"re-run `python -m sdcomp.generate --out {shlex.quote(str(self.root))} "
                f"--resume` with the run's options")

    def run_config(self) -> dict:
        """The run's config as dataset.json records it; empty when that cannot be read
        (missing, not JSON, no config mapping)."""
        try:
            config = json.loads(self.meta.read_bytes())["config"]
        except (OSError, ValueError, UnicodeDecodeError, KeyError, TypeError):
            return {}
        return config if isinstance(config, dict) else {}

    def written_without_coco(self) -> bool:
        """Whether dataset.json says the run wrote no COCO files (False when it cannot be
        read: the COCO files are the dataset)."""
        config = self.run_config()
        if "format" not in config:
            return False
        formats = config["format"]
        names = formats.split(",") if isinstance(formats, str) else formats
        return isinstance(names, list) and "coco" not in names


# --------------------------------------------------------------------------- reading

@dataclass(frozen=True)
class Entry:
    """One image of the dataset: its COCO record, its labelled objects' annotations, its
    split and its ignore regions (``iscrowd`` 1 entries: visible objects too small to
    label)."""

    image: dict
    annotations: list
    split: str
    ignore: list = field(default_factory=list)

    @property
    def id(self) -> int:
        return self.image["id"]


@dataclass(frozen=True)
class Dataset:
    """The images of a dataset folder (sorted by id) and its category names by id."""

    folder: Path
    entries: list[Entry]
    categories: dict[int, str]

    @property
    def layout(self) -> DatasetLayout:
        return DatasetLayout(self.folder)


def _read_coco(path: Path, how: str) -> dict:
    try:
        coco = json.loads(path.read_bytes())
    except OSError as exc:
        raise UserError(f"COCO file {str(path)!r} cannot be read ({exc.strerror}): "
                        f"{how}") from None
    except (ValueError, UnicodeDecodeError) as exc:
        msg = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise UserError(f"COCO file {str(path)!r} is not valid JSON ({msg}): {how} "
                        f"to rewrite it") from None
    if not (isinstance(coco, dict) and isinstance(coco.get("images"), list)
            and isinstance(coco.get("annotations", []), list)):
        raise UserError(f"{str(path)!r} is not a COCO file (no 'images' list): {how} "
                        f"to rewrite it")
    return coco


def _check_folder(folder: Path) -> None:
    if not folder.exists():
        raise UserError(f"dataset folder {str(folder)!r} does not exist: give the --out folder "
                        f"of `python -m sdcomp.generate`")
    if not folder.is_dir():
        raise UserError(f"{str(folder)!r} is a file, not a dataset folder: give the --out "
                        f"folder of `python -m sdcomp.generate`")


def load_dataset(folder: str | Path, split: str = "all") -> Dataset:
    """The images (sorted by id) with their annotations of ``split`` ("all", "train", "val").

    A folder written without COCO files (``--format yolo``, as its dataset.json says) is
    read from its journal, ``records.jsonl``: the records the COCO files would be made of.

    UserError for an unknown split, a folder that is missing or not a generated dataset,
    or a COCO file that is missing, not JSON or not COCO.
    """
    if split not in SPLIT_CHOICES:
        raise UserError(f"--split {split!r} is unknown: use {', '.join(SPLIT_CHOICES)}")
    layout = DatasetLayout(Path(folder))
    _check_folder(layout.root)
    how = layout.resume_hint()
    if layout.written_without_coco():
        if not layout.journal.is_file():
            raise UserError(f"{str(layout.root)!r} was written without COCO files and its "
                            f"journal records.jsonl is missing: {how} to rewrite it")
        return journal_dataset(layout.root, split)
    if not layout.annotations.is_dir():
        raise UserError(f"{str(layout.root)!r} is not a generated dataset (no annotations/ "
                        f"folder): give the --out folder of `python -m sdcomp.generate`")
    paths = {s: layout.coco_file(s) for s in SPLITS}
    wanted = SPLITS if split == "all" else (split,)
    present = [s for s in wanted if paths[s].is_file()]
    if not present:
        if split == "all":
            raise UserError(f"{str(layout.root)!r} is not a generated dataset (no "
                            f"annotations/instances_train.json or instances_val.json): "
                            f"{how} to write them")
        others = [s for s in SPLIT_CHOICES if s != split]
        raise UserError(f"--split {split}: {str(paths[split])!r} does not exist: use --split "
                        f"{' or '.join(others)}, or {how} to write it")
    entries: list[Entry] = []
    categories: dict[int, str] = {}
    for s in present:
        coco = _read_coco(paths[s], how)
        for cat in coco.get("categories") or []:
            if isinstance(cat, dict) and isinstance(cat.get("id"), int):
                categories[cat["id"]] = str(cat.get("name", cat["id"]))
        entries += _coco_entries(coco, s, paths[s], how)
    entries.sort(key=lambda e: (e.id, e.split))
    return Dataset(layout.root, entries, categories)


def _coco_entries(coco: dict, split: str, path: Path, how: str) -> list[Entry]:
    """The entries of one COCO file (its images with their annotations; ``iscrowd``
    entries are the images' ignore regions)."""
    by_image: dict = {}
    crowd: dict = {}
    for ann in coco.get("annotations", []):
        if isinstance(ann, dict):
            into = crowd if ann.get("iscrowd") else by_image
            into.setdefault(ann.get("image_id"), []).append(ann)
    entries = []
    for img in coco["images"]:
        if not (isinstance(img, dict) and isinstance(img.get("id"), int)
                and isinstance(img.get("file_name"), str)):
            raise UserError(f"{str(path)!r}: an image record lacks an integer 'id' or a "
                            f"'file_name': {how} to rewrite it")
        entries.append(Entry(img, by_image.get(img["id"], []), split,
                             crowd.get(img["id"], [])))
    return entries


def journal_dataset(folder: str | Path, split: str = "all") -> Dataset:
    """The images of ``split`` read from the run's journal, ``records.jsonl`` (the records
    the COCO files are made from), with the category names of its dataset.json (none when
    that cannot be read)."""
    layout = DatasetLayout(Path(folder))
    offsets = read_journal(layout.journal)
    wanted = None if split == "all" else split
    entries = [Entry(rec["image"], rec["annotations"], rec["split"], rec.get("ignore", []))
               for rec in iter_records(layout.journal, offsets, wanted)]
    entries.sort(key=lambda e: (e.id, e.split))
    try:
        categories = {i + 1: str(o["category"])
                      for i, o in enumerate(layout.run_config()["objects"])}
    except (KeyError, TypeError):
        categories = {}
    return Dataset(layout.root, entries, categories)
