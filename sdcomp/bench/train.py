"""Training one detector: the paper's schedule by default, checkpointed and resumable.

The paper (Detectron2): SGD, learning rate 0.001, at most 1500 iterations, 416 x 416 images.
Defaults here: SGD with momentum 0.9 and weight decay 1e-4 (Detectron2's), 2 images per batch
(the Detectron2 tutorial's), a linear warm-up over the first 100 iterations, then a constant
rate, horizontal flips; ``min_scale`` < 1 adds multi-scale training (off by default). Every
value is a :class:`TrainConfig` field (and a flag).

Batches are a deterministic function of (seed, iteration): epoch ``e`` visits the training
images in the order of a permutation seeded with (seed, e). A checkpoint (model, optimiser,
torch RNG state, losses) is written atomically every ``checkpoint_every`` iterations, at the
end, and on Ctrl-C; :func:`train` continues from it, so an interrupted run ends where an
uninterrupted one would. A checkpoint at ``max_iter`` means the training is done.
"""

from __future__ import annotations

import hashlib
import json
import math
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass
from pathlib import Path

import cv2
import numpy as np

from ..errors import UserError
from ..util.files import atomic_path
from ..util.progress import Progress
from . import require_torch
from .detector import BACKBONES, build_detector, check_weights

OPTIMIZERS = ("sgd", "adamw")
LOSS_NAMES = ("loss_classifier", "loss_box_reg", "loss_objectness", "loss_rpn_box_reg")


@dataclass(frozen=True)
class TrainConfig:
    """How a cell's detector is trained. Learning rates per iteration, iterations of
    ``batch_size`` images; ``weights``: none, default, backbone or a state-dict file."""

    backbone: str = "resnext101_32x8d-fpn"
    weights: str = "none"
    optimizer: str = "sgd"
    lr: float = 0.001
    momentum: float = 0.9
    weight_decay: float = 1e-4
    max_iter: int = 1500
    batch_size: int = 2
    warmup_iters: int = 100
    hflip: bool = True
    proposals_train: int = 2000
    proposals_test: int = 1000
    roi_batch: int = 512
    min_scale: float = 1.0
    checkpoint_every: int = 100
    seed: int = 0

    def __post_init__(self) -> None:
        if self.backbone not in BACKBONES:
            raise UserError(f"--backbone {self.backbone!r} is unknown; use one of "
                            f"{', '.join(BACKBONES)}")
        if not isinstance(self.weights, str):
            raise UserError("--weights must be none, default, backbone or a file")
        check_weights(self.weights)
        if self.optimizer not in OPTIMIZERS:
            raise UserError(f"--optimizer {self.optimizer!r} is unknown; use "
                            f"{' or '.join(OPTIMIZERS)}")
        for name, lo, hi in (("lr", 1e-8, 10.0), ("momentum", 0.0, 0.999),
                             ("weight_decay", 0.0, 1.0), ("min_scale", 0.1, 1.0)):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not (
                    math.isfinite(v) and lo <= v <= hi):
                raise UserError(f"--{name.replace('_', '-')} {v!r} is out of range: use "
                                f"{lo:g} to {hi:g}")
            object.__setattr__(self, name, float(v))
        for name, lo, hi in (("max_iter", 1, 10_000_000), ("batch_size", 1, 1024),
                             ("warmup_iters", 0, 10_000_000), ("checkpoint_every", 1, 10**9),
                             ("proposals_train", 1, 100_000), ("proposals_test", 1, 100_000),
                             ("roi_batch", 1, 100_000),
                             ("seed", 0, 2**63 - 1)):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int) or not lo <= v <= hi:
                raise UserError(f"--{name.replace('_', '-')} {v!r} is out of range: use "
                                f"{lo} to {hi}")
        if not isinstance(self.hflip, bool):
            raise UserError("--hflip must be true or false")

    def to_dict(self) -> dict:
        return asdict(self)

    def lr_at(self, iteration: int) -> float:
        """Learning rate of (0-based) ``iteration``: linear warm-up from lr/1000, then lr."""
        if iteration < self.warmup_iters:
            f = (iteration + 1) / self.warmup_iters
            return self.lr * (0.001 + (1 - 0.001) * f)
        return self.lr


def train_key(config: TrainConfig, dataset_keys: list[str], image_size: int) -> str:
    """12 hex digits identifying a training: its config, datasets and image size (the
    checkpoint_every interval does not change the result and is left out)."""
    d = config.to_dict()
    d.pop("checkpoint_every")
    text = json.dumps({"train": d, "datasets": dataset_keys, "size": image_size},
                      sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()[:12]


# --------------------------------------------------------------------------- data


def read_image(path: str | Path) -> np.ndarray:
    """An image file as (H, W, 3) uint8 RGB."""
    bgr = cv2.imread(str(path), cv2.IMREAD_COLOR)
    if bgr is None:
        raise UserError(f"{path}: not a readable image")
    return cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB)


def training_items(coco: dict, category_id: int = 1) -> list[tuple[str, np.ndarray]]:
    """(image path, boxes (K, 4) float32 x0, y0, x1, y1 px) per image of a merged COCO dict
    (:func:`~.datasets.merged_split`); images without boxes are kept (background only).
    Ignore regions (``iscrowd`` entries) are no positives: torchvision's detectors have no
    ignore loss, so their few pixels (objects too small to label) train as background."""
    boxes: dict[int, list] = {im["id"]: [] for im in coco["images"]}
    for a in coco["annotations"]:
        if a["category_id"] == category_id and not a.get("iscrowd", 0):
            x, y, w, h = a["bbox"]
            if w > 0 and h > 0:
                boxes[a["image_id"]].append([x, y, x + w, y + h])
    return [(im["path"], np.asarray(boxes[im["id"]], np.float32).reshape(-1, 4))
            for im in coco["images"]]


def batch_indices(n: int, batch_size: int, seed: int, iteration: int) -> list[int]:
    """Indices into ``n`` training images of batch ``iteration``: consecutive slices of
    per-epoch permutations seeded with (seed, epoch)."""
    start = iteration * batch_size
    out = []
    for pos in range(start, start + batch_size):
        epoch, k = divmod(pos, n)
        out.append(int(np.random.default_rng([seed, epoch, 0xB0]).permutation(n)[k]))
    return out


def _batch(items, config: TrainConfig, iteration: int, device):
    torch, _ = require_torch()
    from .detector import to_tensor
    images, targets = [], []
    for j, idx in enumerate(batch_indices(len(items), config.batch_size, config.seed,
                                          iteration)):
        path, boxes, *classes = items[idx]  # (path, boxes) or (path, boxes, labels)
        labels = classes[0] if classes else np.ones(len(boxes), np.int64)
        image = read_image(path)
        boxes = boxes.copy()
        if config.hflip and np.random.default_rng([config.seed, iteration, j, 0xF1]
                                                  ).random() < 0.5:
            image = np.ascontiguousarray(image[:, ::-1])
            w = image.shape[1]
            boxes[:, [0, 2]] = w - boxes[:, [2, 0]]
        images.append(to_tensor(image).to(device))
        targets.append({"boxes": torch.from_numpy(boxes).to(device),
                        "labels": torch.as_tensor(labels, dtype=torch.int64, device=device)})
    return images, targets


# --------------------------------------------------------------------------- loop


def resolve_device(device: str) -> str:
    """``auto`` -> ``cuda`` where available, else ``cpu``; checks an explicit choice."""
    torch, _ = require_torch()
    if device == "auto":
        return "cuda" if torch.cuda.is_available() else "cpu"
    if device.startswith("cuda") and not torch.cuda.is_available():
        raise UserError(f"--device {device}: no CUDA device here; use cpu or auto")
    if device != "cpu" and not device.startswith("cuda"):
        raise UserError(f"--device {device!r} is unknown; use auto, cpu or cuda")
    return device


def make_detector(config: TrainConfig, image_size: int, weights: str | None = None,
                  num_classes: int = 1, native: bool = False):
    """The detector ``config`` trains (``num_classes`` classes), with ``weights`` (default:
    the config's); ``native``: it never resizes images (:func:`.adapt.native_resolution`)."""
    model = build_detector(config.backbone, config.weights if weights is None else weights,
                           num_classes, image_size, config.proposals_train,
                           config.proposals_test, config.roi_batch, config.min_scale)
    if native:
        from .adapt import native_resolution
        native_resolution(model)
    return model


def _optimizer(model, config: TrainConfig):
    torch, _ = require_torch()
    params = [p for p in model.parameters() if p.requires_grad]
    if config.optimizer == "adamw":
        return torch.optim.AdamW(params, lr=config.lr, weight_decay=config.weight_decay)
    return torch.optim.SGD(params, lr=config.lr, momentum=config.momentum,
                           weight_decay=config.weight_decay)


def load_checkpoint(path: Path, key: str | None = None) -> dict | None:
    """The checkpoint at ``path`` (None if absent); a UserError if it belongs to another
    training than ``key``."""
    torch, _ = require_torch()
    if not path.exists():
        return None
    try:
        ckpt = torch.load(path, map_location="cpu", weights_only=True)
    except Exception as e:  # noqa: BLE001 - a damaged file is reported, not raised
        raise UserError(f"{path}: unreadable checkpoint ({e}); delete it to retrain") from None
    if key is not None and ckpt.get("key") != key:
        raise UserError(f"{path} was trained with other settings (key {ckpt.get('key')}, "
                        f"now {key}); use another --out, or --overwrite")
    return ckpt


def _start_training(config: TrainConfig, image_size: int, ckpt: dict | None, device: str,
                    num_classes: int = 1, native: bool = False):
    """The detector and its optimizer, seeded with ``config.seed``, on ``device``, resumed
    from the checkpoint ``ckpt`` (:func:`load_checkpoint`) where there is one (the torch
    RNG state too). Returns ``(model, optimizer, start, losses, wall)``: the first iteration
    to run, the loss rows so far and the seconds of training so far (0, [], 0.0 afresh).
    """
    torch, _ = require_torch()
    torch.manual_seed(config.seed)
    model = make_detector(config, image_size, "none" if ckpt else config.weights,
                          num_classes, native)
    model.to(device)
    opt = _optimizer(model, config)
    start, losses, wall = 0, [], 0.0
    if ckpt is not None:
        model.load_state_dict(ckpt["model"])
        opt.load_state_dict(ckpt["optimizer"])
        start, losses, wall = int(ckpt["iteration"]), list(ckpt["losses"]), ckpt["wall_s"]
        torch.set_rng_state(ckpt["rng"])
    return model, opt, start, losses, wall


def train(config: TrainConfig, items: list, image_size: int, checkpoint: Path, key: str,
          device: str = "cpu", progress: bool | None = None,
          on_iteration: Callable[[int, float], None] | None = None, num_classes: int = 1,
          native: bool = False):
    """Train (or finish training) a detector on ``items`` (:func:`training_items`: (path,
    boxes) pairs, or (path, boxes, labels) with labels (K,) int64 classes from 1 of
    ``num_classes``); ``native``: at the images' own size (:func:`.adapt.native_resolution`).

    Returns ``(model, history)``: the model in eval mode on ``device``, and a dict with
    ``losses`` (per iteration: the total and each of :data:`LOSS_NAMES`, floats),
    ``resumed_from`` (first iteration run now; ``max_iter`` if nothing was left),
    ``wall_s`` (seconds of training, summed over interrupted runs).
    ``on_iteration(iteration, loss)`` is called after each step (tests stop runs with it).

    Over 50 lines: the training loop reads best whole. Its state (``losses``, the RNG state
    to checkpoint, whether the model and ``losses`` agree) changes step by step in an order
    that a Ctrl-C at any point relies on, and ``save`` checkpoints that state; the set-up
    (model, optimizer, resuming a checkpoint) is :func:`_start_training`.
    """
    torch, _ = require_torch()
    check_weights(config.weights)
    if not items:
        raise UserError("the cell's training split has no images; raise the image count")
    ckpt = load_checkpoint(checkpoint, key)
    model, opt, start, losses, wall = _start_training(config, image_size, ckpt, device,
                                                      num_classes, native)
    model.train()
    progress_line = Progress(config.max_iter - start, "train", progress, unit="it")
    t0 = time.perf_counter()
    rng = torch.get_rng_state()  # at the start of the next iteration to run
    consistent = True  # False while the model holds a step that ``losses`` does not show

    def save(iteration: int) -> None:
        state = {"key": key, "iteration": iteration, "model": model.state_dict(),
                 "optimizer": opt.state_dict(), "losses": losses, "rng": rng,
                 "wall_s": wall + time.perf_counter() - t0, "config": config.to_dict()}
        checkpoint.parent.mkdir(parents=True, exist_ok=True)
        with atomic_path(checkpoint) as tmp:
            torch.save(state, tmp)

    try:
        for it in range(start, config.max_iter):
            for g in opt.param_groups:
                g["lr"] = config.lr_at(it)
            images, targets = _batch(items, config, it, device)
            parts = model(images, targets)
            loss = sum(parts.values())
            value = float(loss.detach())
            if not math.isfinite(value):
                raise UserError(f"training diverged at iteration {it} (loss {value}); lower "
                                f"--lr or raise --warmup-iters")
            opt.zero_grad(set_to_none=True)
            loss.backward()
            row = [round(value, 6)] + [round(float(parts[n].detach()), 6) for n in LOSS_NAMES]
            consistent = False
            opt.step()
            losses.append(row)
            consistent = True
            rng = torch.get_rng_state()
            progress_line.update()
            if on_iteration is not None:
                on_iteration(it, value)
            if (it + 1) % config.checkpoint_every == 0 and it + 1 < config.max_iter:
                save(it + 1)
        if start < config.max_iter or ckpt is None:
            save(config.max_iter)
    except KeyboardInterrupt:
        if consistent and len(losses) > start:
            save(len(losses))  # the iterations finished so far
        raise
    finally:
        progress_line.close()
    model.eval()
    return model, {"losses": losses, "resumed_from": start,
                   "wall_s": round(wall + time.perf_counter() - t0, 3)}
