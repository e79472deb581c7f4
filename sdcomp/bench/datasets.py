"""Cell datasets and test sets: generated through sdcomp, cached by config hash.

A cell trains on one or more :class:`DatasetPart` (the paper's "+G" cells add a part of 137
green-water images). Each part is a :class:`~sdcomp.config.GeneratorConfig` built on the
``paper-alt10`` preset (one BlueROV2 per square image) with the part's altitude, water, image
count, size and seed, written by :func:`sdcomp.writer.run` into ``CACHE/<name>-<hash>/``
where ``hash`` covers the whole config and the sdcomp version: a re-run finds the folder
complete (``dataset.json`` status ``complete``) and reuses it, an interrupted generation
resumes, a changed config gets a new folder.

Test sets (:class:`EvalSet`, every output names its ``label``):

- the user's real labelled frames: ``--test-coco FILE --test-images DIR`` (:func:`real_test`),
  and Table 6's real training frames, ``--real-train FILE --real-train-images DIR``
  (:func:`real_train`, kept apart from the test set's by :func:`check_disjoint`),
- otherwise a held-out synthetic "field" set (:class:`FieldSpec`): a separate seed, mixed
  altitudes, water colours and gimbal pitches (:func:`field_test`),
- the synthetic val split of a cell (:func:`val_set`), the paper's validation AP.
"""

from __future__ import annotations

import hashlib
import json
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .. import __version__
from ..errors import UserError
from ..io.coco import IGNORED_CATEGORY
from ..run.local import RunOptions, run
from ..scene.config import GeneratorConfig, preset
from .train import training_items

CATEGORY = "bluerov2"
IGNORED_ID = IGNORED_CATEGORY["id"]  # SeaDronesSee's "ignored": an ignore region of any class
CACHE_VERSION = 1
FIELD_SEED = 1000
MIXED = ("brown", "blue", "green")  # the colours of water "mixed"


@dataclass(frozen=True)
class DatasetPart:
    """One generated dataset: ``n`` images of one BlueROV2 at ``altitude`` metres over
    ``water`` (brown, blue, green, or mixed: one of the three per image), ``size`` x ``size``
    px, generator seed ``seed``."""

    name: str
    altitude: float
    water: str
    n: int
    seed: int
    size: int = 416
    val_fraction: float = 0.2

    def generator_config(self) -> GeneratorConfig:
        base = GeneratorConfig.from_mapping(preset("paper-alt10"), source="bench")
        water = list(MIXED) if self.water == "mixed" else [self.water]
        return GeneratorConfig.from_mapping(
            {"altitude": self.altitude, "water": water, "n": self.n, "seed": self.seed,
             "width": self.size, "height": self.size, "val_fraction": self.val_fraction},
            base, "bench")


@dataclass(frozen=True)
class FieldSpec:
    """The held-out synthetic "field" test set: ``n`` images from seed ``seed`` (never a
    training seed), altitudes ``altitude`` m, gimbal pitch ``pitch`` degrees below the
    horizon, water colours ``water`` (one per image), one BlueROV2 each."""

    n: int = 200
    seed: int = FIELD_SEED
    altitude: str = "10-20"
    pitch: str = "60-90"
    water: tuple[str, ...] = ("brown", "blue", "green")

    def __post_init__(self) -> None:
        if not isinstance(self.n, int) or not 1 <= self.n <= 1_000_000:
            raise UserError(f"--field-n {self.n!r} is out of range: use 1 to 1000000 images")
        if not isinstance(self.seed, int) or self.seed < 0:
            raise UserError(f"--field-seed {self.seed!r} must be a whole number >= 0")
        object.__setattr__(self, "water", tuple(self.water))
        self.generator_config(416)  # the generator checks altitude, pitch, water

    def generator_config(self, size: int) -> GeneratorConfig:
        base = GeneratorConfig.from_mapping(preset("paper-alt10"), source="bench")
        return GeneratorConfig.from_mapping(
            {"altitude": self.altitude, "pitch": self.pitch, "water": list(self.water),
             "n": self.n, "seed": self.seed, "width": size, "height": size,
             "val_fraction": 0.0}, base, "field test set")

    def describe(self) -> str:
        return (f"synthetic-field (seed {self.seed}, {self.n} images, altitude "
                f"{self.altitude} m, pitch {self.pitch} deg, water {'/'.join(self.water)})")


def config_key(config: GeneratorConfig) -> str:
    """12 hex digits of SHA-256 over the config, the sdcomp version and the cache version."""
    text = json.dumps({"cache": CACHE_VERSION, "sdcomp": __version__,
                       "config": config.to_dict()}, sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()[:12]


@dataclass(frozen=True)
class CacheOptions:
    """Where and how datasets are generated (none of it changes their content)."""

    cache_dir: Path
    sprites_dir: Path = Path("sprites")
    workers: int = 1
    progress: bool | None = None


def ensure_dataset(config: GeneratorConfig, name: str, options: CacheOptions
                   ) -> tuple[Path, bool]:
    """The folder of ``config``'s dataset, generated unless a complete one is cached.

    Returns ``(folder, reused)``; ``reused`` is True when nothing had to be generated.
    """
    folder = Path(options.cache_dir) / f"{name}-{config_key(config)}"
    if _complete(folder):
        return folder, True
    try:
        folder.parent.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise UserError(f"--cache {options.cache_dir}: cannot create it ({e.strerror})") from None
    workers = options.workers if config.n >= 64 else 1
    run(config, RunOptions(folder, workers, resume=True, progress=options.progress,
                           sprites_dir=Path(options.sprites_dir)))
    return folder, False


def _complete(folder: Path) -> bool:
    try:
        meta = json.loads((folder / "dataset.json").read_text())
    except (OSError, ValueError):
        return False
    return meta.get("status") == "complete"


# --------------------------------------------------------------------------- sets


@dataclass
class EvalSet:
    """A COCO ground truth with its images: ``coco`` (dict), images under ``images_dir`` (or
    each image's ``path``), scored for category ``category_id``; ``label`` names it."""

    label: str
    kind: str  # "real", "synthetic-field" or "synthetic-val"
    coco: dict
    images_dir: Path
    category_id: int = 1
    files: list[str] = field(default_factory=list)  # the source annotation files

    def image_path(self, image: dict) -> Path:
        return Path(image["path"]) if "path" in image else self.images_dir / image["file_name"]

    def coco_for_category(self) -> dict:
        """The ground truth restricted to the scored category, with its ignore regions
        (``iscrowd`` entries of that category, or of category 0, SeaDronesSee's
        ``ignored``, which stands for any category) as that category's: COCOeval counts a
        detection on one neither as a true nor as a false positive."""
        anns: list[dict] = []
        for a in self.coco["annotations"]:
            crowd = a.get("iscrowd", 0)
            if a.get("category_id") != self.category_id and not (
                    crowd and a.get("category_id") == IGNORED_ID):
                continue
            w, h = a["bbox"][2], a["bbox"][3]  # COCOeval needs id, area and iscrowd
            anns.append({**a, "id": len(anns) + 1, "area": a.get("area", w * h),
                         "iscrowd": crowd, "category_id": self.category_id})
        cats = [c for c in self.coco["categories"] if c["id"] == self.category_id]
        return {"images": self.coco["images"], "categories": cats, "annotations": anns}


def read_coco(path: Path, what: str) -> dict:
    """A COCO file's dict, or a one-line UserError naming ``what`` (the flag)."""
    try:
        data = json.loads(Path(path).read_text())
    except FileNotFoundError:
        raise UserError(f"{what} {path}: no such file") from None
    except (OSError, ValueError, UnicodeDecodeError) as e:
        raise UserError(f"{what} {path}: not a readable JSON file ({e})") from None
    if not isinstance(data, dict) or not all(
            isinstance(data.get(k), list) for k in ("images", "annotations", "categories")):
        raise UserError(f"{what} {path}: not a COCO file (needs images, annotations and "
                        f"categories lists)")
    return data


def merged_split(folders: list[Path], split: str) -> dict:
    """One COCO dict of ``split`` ("train" or "val") over several dataset folders; image ids
    are renumbered from 1 and each image gets its absolute ``path``."""
    images: list[dict] = []
    anns: list[dict] = []
    cats = None
    for folder in folders:
        data = read_coco(folder / "annotations" / f"instances_{split}.json", "dataset")
        cats = cats or data["categories"]
        new_id = {}
        for im in data["images"]:
            new_id[im["id"]] = len(images) + 1
            images.append({**im, "id": len(images) + 1,
                           "path": str((folder / "images" / im["file_name"]).resolve())})
        for a in data["annotations"]:
            anns.append({**a, "id": len(anns) + 1, "image_id": new_id[a["image_id"]]})
    return {"images": images, "annotations": anns, "categories": cats or [
        {"id": 1, "name": CATEGORY, "supercategory": "object"}]}


def val_set(folders: list[Path]) -> EvalSet:
    """The synthetic val split of a cell's datasets."""
    return EvalSet("synthetic-val", "synthetic-val", merged_split(folders, "val"),
                   Path("."), 1, [str(f) for f in folders])


def field_test(spec: FieldSpec, size: int, options: CacheOptions) -> EvalSet:
    """The held-out synthetic field set (generated or taken from the cache)."""
    folder, _ = ensure_dataset(spec.generator_config(size), f"field{size}", options)
    return EvalSet(spec.describe(), "synthetic-field", merged_split([folder], "train"),
                   Path("."), 1, [str(folder)])


def real_test(coco_file: str | Path, images_dir: str | Path) -> EvalSet:
    """The user's labelled frames: a COCO file with a ``bluerov2`` category (any case) and
    the folder its ``file_name`` entries are relative to. Checks every image file exists."""
    data, category = _labelled_frames(coco_file, images_dir, "--test-coco", "--test-images")
    label = f"real ({os.path.basename(coco_file)}, {len(data['images'])} images)"
    return EvalSet(label, "real", data, Path(images_dir), category, [str(coco_file)])


@dataclass(frozen=True)
class RealTrain:
    """The user's real labelled training frames of Table 6 (``--real-train``): ``items``
    (absolute image path, boxes (K, 4) float32 x0, y0, x1, y1 px) in the file's order,
    ``key`` a hash of their names and boxes (a cell's training key), ``label`` names them."""

    label: str
    items: tuple[tuple[str, np.ndarray], ...]
    key: str
    files: tuple[str, ...] = ()

    def pick(self, n: int, seed: int) -> list[tuple[str, np.ndarray]]:
        """The first ``n`` frames of one order seeded by ``seed`` (a larger ``n`` keeps a
        smaller one's frames, as the paper's 500, 1000 and 1500 grow); UserError when
        there are fewer than ``n``."""
        if n > len(self.items):
            raise UserError(f"--real-train {self.files[0] if self.files else self.label}: "
                            f"Table 6 asks {n} frames, it has {len(self.items)}; lower "
                            f"--size-scale (the paper's 500/1000/1500 are multiplied by it)")
        order = np.random.default_rng([seed, 0x7AB6]).permutation(len(self.items))
        return [self.items[i] for i in order[:n]]


def real_train(coco_file: str | Path, images_dir: str | Path) -> RealTrain:
    """The user's labelled training frames (``--real-train FILE --real-train-images DIR``),
    checked as :func:`real_test` checks a test set's; frames without boxes train as water."""
    data, category = _labelled_frames(coco_file, images_dir, "--real-train",
                                      "--real-train-images")
    images = [{**im, "path": str((Path(images_dir) / str(im["file_name"])).resolve())}
              for im in data["images"]]
    items = training_items({**data, "images": images}, category)
    digest = hashlib.sha256()
    for im, (_, boxes) in zip(images, items, strict=True):
        digest.update(str(im["file_name"]).encode() + b"\0" + boxes.tobytes())
    return RealTrain(f"real ({os.path.basename(coco_file)}, {len(items)} images)",
                     tuple(items), digest.hexdigest()[:12], (str(coco_file),))


def check_disjoint(real: RealTrain, test: EvalSet) -> None:
    """UserError when the real training frames include frames of the test set."""
    if test.kind != "real":
        return
    tested = {test.image_path(im).resolve() for im in test.coco["images"]}
    shared = sorted(p for p, _ in real.items if Path(p) in tested)
    if shared:
        raise UserError(f"--real-train holds {len(shared)} of the --test-coco frames (e.g. "
                        f"{Path(shared[0]).name}); train and test on different frames")


def _labelled_frames(coco_file: str | Path, images_dir: str | Path, coco_flag: str,
                     images_flag: str) -> tuple[dict, int]:
    """(COCO dict, id of its ``bluerov2`` category) of the user's labelled frames, every
    image file checked; UserErrors name the flags."""
    coco_file, images_dir = Path(coco_file), Path(images_dir)
    data = read_coco(coco_file, coco_flag)
    if not images_dir.is_dir():
        raise UserError(f"{images_flag} {images_dir}: no such folder")
    names = {str(c.get("name", "")).lower(): c.get("id") for c in data["categories"]}
    if CATEGORY not in names:
        found = ", ".join(sorted(names)) or "none"
        raise UserError(f"{coco_flag} {coco_file}: no category named {CATEGORY!r} (found: "
                        f"{found}); rename the BlueROV2 category to {CATEGORY}")
    if not data["images"]:
        raise UserError(f"{coco_flag} {coco_file}: lists no images")
    for im in data["images"]:
        p = images_dir / str(im.get("file_name", ""))
        if not p.is_file():
            raise UserError(f"{images_flag} {images_dir}: {im.get('file_name')!r} of "
                            f"{coco_flag} is missing")
    return data, int(names[CATEGORY])
