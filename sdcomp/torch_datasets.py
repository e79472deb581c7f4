"""PyTorch datasets: images generated on the fly, or read from a generated folder.

Both return ``(image, target)`` in the torchvision detection format, so the models of
``torchvision.models.detection`` train on them directly, as torchvision's ``tv_tensors`` so
that every ``torchvision.transforms.v2`` transform moves the image, boxes and masks together::

    image   tv_tensors.Image (3, H, W) float32 RGB in [0, 1] (or, with
            ``image_dtype=torch.uint8``, uint8 RGB in 0..255)
    target  {"boxes":    tv_tensors.BoundingBoxes (N, 4) float32, format XYXY, canvas_size
                         (H, W): x1, y1, x2, y2 in pixels (pixel edges: a box [x, y, w, h]
                         of COCO is x1 = x, x2 = x + w),
             "labels":   (N,) int64 COCO category ids (from 1; 0 is torchvision's background),
             "masks":    tv_tensors.Mask (N, H, W) uint8 0/1 instance masks,
             "image_id": int, COCO image id (the image's index, the number in its file name),
             "area":     (N,) float32 mask pixel counts (of the untransformed mask),
             "iscrowd":  (N,) int64 zeros,
             "ignore":   tv_tensors.Mask (H, W) uint8 0/1: the ignore region, pixels of
                         objects of interest too small to label (all 0 when none)}

The ignore region is what a detector should neither learn nor be scored on there (COCO's
``iscrowd`` entries). It is one (H, W) mask, not (1, H, W): ``v2.SanitizeBoundingBoxes``
passes masks whose first dimension is not the number of boxes through unchanged.

A v2 transform that drops or crops objects leaves boxes that may be empty: end the pipeline
with ``v2.SanitizeBoundingBoxes()`` (it removes them with their labels and masks).

Use :func:`collate` as the DataLoader's ``collate_fn`` (images differ in their number of
objects): a batch is a tuple of images and a tuple of targets.

``image_dtype=torch.uint8`` hands the images over as the 8-bit values they are: a quarter of
the bytes a DataLoader worker copies into shared memory for the main process (a 416x416
image: 0.5 MB instead of 2 MB), which on a small machine is where a worker spends most of
its time after rendering. The model's device then divides by 255
(``[im.to(device).float().div_(255) for im in images]``): exactly the float32 images.

:class:`SyntheticDetection` renders image ``i`` from (config, i) when asked for it: a dataset
of any length that needs no disk, identical in every process and on every run. It is safe
with ``DataLoader(num_workers > 0)``: the dataset builds its
:class:`~sdcomp.generator.Generator` (and any missing sprite atlas) when it is made; forked
workers inherit it, and pickling carries only the config (a few kB): a worker that receives a
pickled copy (``multiprocessing_context="spawn"``) builds its own generator on first use.

OpenCV's thread pool does not survive ``fork`` (a forked child can hang in its first parallel
OpenCV call), and DataLoader workers are forked on Linux. Importing this module therefore
installs :func:`sdcomp.pool.pause_opencv_threads_on_fork`: OpenCV's threads pause while any
process forks and the child keeps one (a DataLoader worker is one of several processes).

:func:`fill_empty_target` is the guard torchvision's own ``CocoDetection`` (wrapped for v2)
needs on images without objects, whose targets lack ``boxes`` and ``labels``.

This module (with :mod:`sdcomp.bench`) is the only one in sdcomp that imports torch and
torchvision.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import torch

from .errors import UserError

try:
    from torchvision import tv_tensors
except ImportError:  # pragma: no cover - torchvision comes with the dev and bench extras
    raise ImportError("sdcomp.torch_datasets needs torchvision (pip install torchvision, or "
                      "pip install 'sdcomp[bench]')") from None
from .atlas.cache import sprites_folder
from .io.png import decode_ignore_png, decode_png16
from .pipeline import DEFAULT_SPRITES, Generator
from .scene.config import GeneratorConfig
from .util.pool import pause_opencv_threads_on_fork

Target = dict[str, Any]
Transforms = Callable[[torch.Tensor, Target], tuple[torch.Tensor, Target]]

pause_opencv_threads_on_fork()  # DataLoader workers are forked on Linux


IMAGE_DTYPES = (torch.float32, torch.uint8)


def check_image_dtype(image_dtype: Any) -> torch.dtype:
    """``image_dtype`` if it is one of :data:`IMAGE_DTYPES`, else a :class:`UserError`."""
    if not any(image_dtype is d for d in IMAGE_DTYPES):
        raise UserError(f"image_dtype {image_dtype!r} is not supported: use torch.float32 "
                        f"(RGB in [0, 1], the default) or torch.uint8 (RGB in 0..255)")
    return image_dtype


def to_sample(image: np.ndarray, instances: np.ndarray, instance_ids: Sequence[int],
              category_ids: Sequence[int], bboxes: Sequence[Sequence[float]],
              image_id: int, image_dtype: torch.dtype = torch.float32,
              ignore: np.ndarray | None = None) -> tuple[torch.Tensor, Target]:
    """The torchvision form of one image: ``image`` (H, W, 3) uint8 RGB, ``instances``
    (H, W) uint16 instance ids; per object its instance id, category id (from 1) and COCO
    bbox [x, y, w, h] in pixels; ``ignore`` (H, W) bool, the ignore region (None: none).
    The image comes back as (3, H, W) ``image_dtype``: float32 in [0, 1] or uint8 in
    0..255. See the module docstring for the target."""
    # numpy, then torch.from_numpy: no torch kernels (slow for small tensors on few cores)
    h, w = instances.shape
    chw: np.ndarray = np.stack(cv2.split(np.ascontiguousarray(image)))
    if check_image_dtype(image_dtype) is torch.float32:
        chw = chw.astype(np.float32)
        np.divide(chw, np.float32(255.0), out=chw)
    n = len(instance_ids)
    ids = np.asarray(instance_ids, np.uint16).reshape(n, 1, 1)
    masks = (instances[None] == ids).view(np.uint8)  # (N, H, W), also for N = 0
    boxes = np.array([[x, y, x + bw, y + bh] for x, y, bw, bh in bboxes],
                     np.float32).reshape(n, 4)
    target = {"boxes": tv_tensors.BoundingBoxes(torch.from_numpy(boxes), format="XYXY",
                                                canvas_size=(h, w)),
              "labels": torch.from_numpy(np.asarray(category_ids, np.int64).reshape(n)),
              "masks": tv_tensors.Mask(torch.from_numpy(masks)),
              "image_id": int(image_id),
              "area": torch.from_numpy(masks.reshape(n, h * w).sum(1, dtype=np.int64)
                                       .astype(np.float32)),
              "iscrowd": torch.from_numpy(np.zeros(n, np.int64)),
              "ignore": tv_tensors.Mask(torch.from_numpy(
                  np.zeros((h, w), np.uint8) if ignore is None
                  else np.ascontiguousarray(ignore, bool).view(np.uint8)))}
    img = tv_tensors.Image(torch.from_numpy(chw))
    return img, target


def fill_empty_target(image: Any, target: Target) -> tuple[Any, Target]:
    """A v2 ``transforms(image, target)`` for torchvision's ``CocoDetection`` wrapped with
    ``wrap_dataset_for_transforms_v2``: an image without objects comes with a target of
    only ``image_id``, on which detection models raise ``KeyError: 'boxes'``; this adds
    empty ``boxes`` (0, 4) XYXY, ``labels`` (0,) int64 and ``masks`` (0, H, W) uint8.
    Other targets pass unchanged."""
    if "boxes" not in target:
        h, w = image.shape[-2:] if isinstance(image, torch.Tensor) else image.size[::-1]
        target = {**target,
                  "boxes": tv_tensors.BoundingBoxes(torch.zeros((0, 4)), format="XYXY",
                                                    canvas_size=(h, w)),
                  "labels": torch.zeros(0, dtype=torch.int64),
                  "masks": tv_tensors.Mask(torch.zeros((0, h, w), dtype=torch.uint8))}
    return image, target


def collate(batch: Sequence[tuple[torch.Tensor, Target]]) -> tuple[tuple, tuple]:
    """DataLoader ``collate_fn`` for detection: ``(images, targets)`` as two tuples.

    The result is a :class:`Batch`: sent from a DataLoader worker, all its tensors travel
    in one shared buffer per dtype instead of one each."""
    images, targets = zip(*batch, strict=True) if batch else ((), ())
    return Batch((tuple(images), tuple(targets)))


class Batch(tuple):
    """A collated ``(images, targets)`` that pickles its plain tensors packed: one 1-D
    tensor per dtype, so a worker shares 3-4 buffers per batch with the main process instead
    of about 6 per image (each costs the main process a socket round trip for its file
    descriptor: about 2 ms of its CPU per image, which it takes from the workers on a small
    machine). Unpickled it is a plain tuple whose tensors are views of those buffers, the
    tv_tensors (images, boxes, masks) wrapped again as they were. Other objects (numbers,
    other tensor subclasses) are pickled as they are."""

    def __reduce__(self):
        groups: dict[str, list[torch.Tensor]] = {}
        sizes: dict[str, int] = {}

        def hollow(obj: Any) -> Any:  # a plain tensor or tv_tensor -> a _Slot into `groups`
            wrap = _wrap_spec(obj)
            if wrap is None or obj.requires_grad:
                return obj
            key = str(obj.dtype)
            groups.setdefault(key, []).append(obj.as_subclass(torch.Tensor))
            offset = sizes.get(key, 0)
            sizes[key] = offset + obj.numel()
            return _Slot((key, offset, tuple(obj.shape), wrap))

        skeleton = _walk(tuple(self), hollow)
        buffers = {key: torch.cat([t.reshape(-1) for t in ts]) for key, ts in groups.items()}
        return _fill_batch, (skeleton, buffers)


class _Slot(tuple):
    """Where a packed tensor goes: (dtype key, offset, shape, its tv_tensor wrapping)."""


def _wrap_spec(obj: Any) -> tuple | None:
    """How to wrap a packed tensor again: ``()`` for a plain tensor, ``("image",)``,
    ``("mask",)``, ``("boxes", format, canvas_size, clamping_mode)``; None for objects that
    are not packed."""
    kind = type(obj)
    if kind is torch.Tensor:
        return ()
    if kind is tv_tensors.Image:
        return ("image",)
    if kind is tv_tensors.Mask:
        return ("mask",)
    if kind is tv_tensors.BoundingBoxes:
        return ("boxes", obj.format.name, tuple(obj.canvas_size),
                getattr(obj, "clamping_mode", None))
    return None


def _wrapped(tensor: torch.Tensor, wrap: tuple) -> torch.Tensor:
    """``tensor`` wrapped as :func:`_wrap_spec` recorded (no copy)."""
    if not wrap:
        return tensor
    if wrap[0] == "image":
        return tv_tensors.Image(tensor)
    if wrap[0] == "mask":
        return tv_tensors.Mask(tensor)
    _, fmt, canvas, clamping = wrap
    extra = {} if clamping is None else {"clamping_mode": clamping}
    return tv_tensors.BoundingBoxes(tensor, format=fmt, canvas_size=canvas, **extra)


def _walk(obj: Any, leaf: Callable[[Any], Any]) -> Any:
    """``obj`` rebuilt through its tuples, lists and dicts (exact types) with ``leaf``
    applied to everything else."""
    if type(obj) in (tuple, list):
        return type(obj)(_walk(o, leaf) for o in obj)
    if type(obj) is dict:
        return {k: _walk(v, leaf) for k, v in obj.items()}
    return leaf(obj)


def _fill_batch(skeleton: tuple, buffers: dict[str, torch.Tensor]) -> tuple:
    """The unpickled :class:`Batch`: a plain ``(images, targets)`` of views of ``buffers``."""
    def fill(obj: Any) -> Any:
        if type(obj) is not _Slot:
            return obj
        key, offset, shape, wrap = obj
        return _wrapped(buffers[key][offset:offset + math.prod(shape)].view(shape), wrap)

    return _walk(skeleton, fill)


def _check_length(length: int) -> int:
    if isinstance(length, bool) or not isinstance(length, (int, np.integer)) or length < 0:
        raise UserError(f"length {length!r} must be a whole number >= 0 (images in the "
                        f"dataset)")
    return int(length)


def _index(i: int, length: int) -> int:
    i = int(i)
    if i < 0:
        i += length
    if not 0 <= i < length:
        raise IndexError(f"image index {i} is out of range for a dataset of {length}")
    return i


class SyntheticDetection(torch.utils.data.Dataset):
    """``length`` images of ``config`` rendered on demand: item ``i`` is image ``i`` of the
    generator (the same pixels as ``images/{i:06d}`` of ``sdcomp generate`` with this config,
    before JPEG compression), as ``(image, target)`` (see the module docstring).

    Args:
        config: the generator's config (``config.n`` is not used; ``length`` is).
        length: number of images (indices 0 .. length - 1).
        sprites_dir: sprite atlas folder (built there on first use when missing).
        transforms: optional ``transforms(image, target) -> (image, target)``, applied last:
            a ``torchvision.transforms.v2`` pipeline moves image, boxes and masks together
            (end it with ``v2.SanitizeBoundingBoxes()`` where objects can leave the frame).
        image_dtype: ``torch.float32`` (RGB in [0, 1]) or ``torch.uint8`` (RGB in 0..255,
            a quarter of the bytes through a DataLoader; see the module docstring).
    """

    def __init__(self, config: GeneratorConfig, length: int,
                 sprites_dir: str | Path | None = DEFAULT_SPRITES,
                 transforms: Transforms | None = None,
                 image_dtype: torch.dtype = torch.float32):
        if not isinstance(config, GeneratorConfig):
            raise UserError(f"config must be a GeneratorConfig, not {type(config).__name__}")
        self.config = config
        self.length = _check_length(length)
        self.sprites_dir = str(sprites_folder(sprites_dir))
        self.transforms = transforms
        self.image_dtype = check_image_dtype(image_dtype)
        # built here, once: atlases are built (or a bad mesh reported) before any worker
        # starts; forked workers inherit it, pickled copies (spawn) rebuild it on first use
        self._gen: Generator | None = Generator(config, self.sprites_dir, progress=False)
        self._gen.warm()  # sprites prepared once, here, instead of in every worker

    @property
    def generator(self) -> Generator:
        """This process's generator (built on first use in a process that got a pickled
        copy of the dataset)."""
        if self._gen is None:
            # build_workers=1: a DataLoader worker is daemonic and may not start processes
            self._gen = Generator(self.config, self.sprites_dir, progress=False,
                                  build_workers=1)
        return self._gen

    def __len__(self) -> int:
        return self.length

    def __getitem__(self, i: int) -> tuple[torch.Tensor, Target]:
        index = _index(i, self.length)
        frame = self.generator.render(index)
        objs = frame.objects
        image, target = to_sample(frame.image, frame.instances,
                                  [o.instance_id for o in objs], [o.category_id for o in objs],
                                  [o.bbox for o in objs], index, self.image_dtype,
                                  frame.ignore)
        if self.transforms is not None:
            image, target = self.transforms(image, target)
        return image, target

    def __getstate__(self) -> dict:
        state = self.__dict__.copy()
        state["_gen"] = None  # textures and sprites are rebuilt in the other process
        return state


class GeneratedCoco(torch.utils.data.Dataset):
    """The images of one split of a folder written by ``sdcomp generate``, in index order, as
    ``(image, target)`` (see the module docstring). Masks come from ``masks/`` (16-bit
    instance ids, and the 8-bit ignore masks of images that have one), boxes and labels
    from ``annotations/instances_{split}.json`` (or, in a folder written with ``--format
    yolo``, from the run's journal ``records.jsonl``).

    Args:
        folder: the dataset folder (the generator's ``--out``).
        split: "train", "val" or "all".
        transforms: optional ``transforms(image, target) -> (image, target)``.
        image_dtype: ``torch.float32`` (RGB in [0, 1]) or ``torch.uint8`` (RGB in 0..255).
    """

    def __init__(self, folder: str | Path, split: str = "train",
                 transforms: Transforms | None = None,
                 image_dtype: torch.dtype = torch.float32):
        from .io.layout import load_dataset  # the one checked dataset reader

        self.image_dtype = check_image_dtype(image_dtype)
        ds = load_dataset(folder, split)
        self.folder = Path(folder)
        self.split = split
        self.categories: dict[int, str] = dict(ds.categories)
        self.images: list[dict] = [e.image for e in ds.entries]
        self.annotations: list[list[dict]] = [
            sorted(e.annotations, key=lambda a: a.get("instance_id", 0)) for e in ds.entries]
        self.transforms = transforms

    def __len__(self) -> int:
        return len(self.images)

    def __getitem__(self, i: int) -> tuple[torch.Tensor, Target]:
        k = _index(i, len(self.images))
        im, anns = self.images[k], self.annotations[k]
        path = self.folder / "images" / im["file_name"]
        bgr = cv2.imread(str(path), cv2.IMREAD_COLOR)
        if bgr is None:
            raise UserError(f"{path}: missing or unreadable image; re-run sdcomp generate "
                            f"with --resume to redraw it")
        mask_path = self.folder / "masks" / im.get("mask_file", Path(im["file_name"]).stem +
                                                   ".png")
        try:
            instances = decode_png16(mask_path.read_bytes())
        except (OSError, ValueError):
            raise UserError(f"{mask_path}: missing or unreadable mask; re-run sdcomp generate "
                            f"with --resume to redraw it") from None
        image, target = to_sample(cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB), instances,
                                  [a["instance_id"] for a in anns],
                                  [a["category_id"] for a in anns],
                                  [a["bbox"] for a in anns], im["id"], self.image_dtype,
                                  self._ignore(im))
        if self.transforms is not None:
            image, target = self.transforms(image, target)
        return image, target


    def _ignore(self, im: dict) -> np.ndarray | None:
        """(H, W) bool: image ``im``'s ignore mask (its ``ignore_file``), None without one."""
        name = im.get("ignore_file")
        if not isinstance(name, str):
            return None
        path = self.folder / "masks" / name
        try:
            return decode_ignore_png(path.read_bytes())
        except (OSError, ValueError):
            raise UserError(f"{path}: missing or unreadable ignore mask; re-run sdcomp "
                            f"generate with --resume to redraw it") from None


def __getattr__(name: str) -> Any:  # RealDetection, MixedDetection: sdcomp.torch_real
    if name in ("RealDetection", "MixedDetection"):
        from . import torch_real
        return getattr(torch_real, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


__all__ = ["SyntheticDetection", "GeneratedCoco", "Batch", "collate", "to_sample",
           "fill_empty_target"]
