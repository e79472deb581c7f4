"""The detector: torchvision Faster R-CNN with a selectable backbone and starting weights.

Backbones (:data:`BACKBONES`):

- ``resnext101_32x8d-fpn``: the paper's X101-FPN (Detectron2), ResNeXt-101 32x8d + FPN on
  strides 4-32 (+ a max-pooled level).
- ``resnet50-fpn``: torchvision's ``fasterrcnn_resnet50_fpn`` layout (COCO weights exist).
- ``mobilenet_v3-fpn``: MobileNetV3-Large + FPN on strides 8, 16, 32 (+ pooled level): the
  CPU choice. torchvision's own mobilenet detector only uses stride 32, where a 15-pixel
  BlueROV2 (10 m, 416 px) is half a feature cell, so we return the stride-8 and -16 stages.

Anchors are one size per level, 16 to 256 px (torchvision's are 32-512, for COCO's larger
objects), three aspect ratios, so the number of anchors per location is torchvision's and
its COCO detector weights load. Images are not resized: ``min_size = max_size = image_size``.

Weights (``--weights``): ``none`` (default) trains from scratch with trainable BatchNorm;
``default`` takes the best that torchvision's weights API offers, downloading it where the
machine can: COCO detector weights for ``resnet50-fpn`` (box predictor replaced for our
classes), ImageNet backbone weights for the others; ``backbone`` takes ImageNet backbone
weights only; a file path loads a state dict (a detector's, or a checkpoint of ours).
"""

from __future__ import annotations

from pathlib import Path

from ..errors import UserError
from . import require_torch

BACKBONES = ("resnext101_32x8d-fpn", "resnet50-fpn", "mobilenet_v3-fpn")
WEIGHT_CHOICES = ("none", "default", "backbone")
ANCHOR_SIZES = (16, 32, 64, 128, 256)  # pixels, one per pyramid level (fewer levels: prefix)
ASPECT_RATIOS = (0.5, 1.0, 2.0)
MOBILENET_STAGES = [2, 3, 5]  # MobileNetV3-Large stages at strides 8, 16, 32


def check_weights(weights: str) -> str:
    """``weights`` if it is a known choice or an existing file, else a UserError."""
    if weights in WEIGHT_CHOICES:
        return weights
    if not Path(weights).is_file():
        raise UserError(f"--weights {weights!r}: not one of {', '.join(WEIGHT_CHOICES)} and "
                        f"no such file")
    return weights


def _backbone_weights(backbone: str):
    from torchvision.models import (
        MobileNet_V3_Large_Weights,
        ResNet50_Weights,
        ResNeXt101_32X8D_Weights,
    )
    return {"resnext101_32x8d-fpn": ResNeXt101_32X8D_Weights.DEFAULT,
            "resnet50-fpn": ResNet50_Weights.DEFAULT,
            "mobilenet_v3-fpn": MobileNet_V3_Large_Weights.DEFAULT}[backbone]


def build_detector(backbone: str = "mobilenet_v3-fpn", weights: str = "none",
                   num_classes: int = 1, image_size: int = 416, proposals_train: int = 2000,
                   proposals_test: int = 1000, roi_batch: int = 512, min_scale: float = 1.0):
    """A ``torchvision.models.detection.FasterRCNN`` for ``num_classes`` object classes
    (+ background), taking ``image_size`` px images unresized.

    ``proposals_train``/``proposals_test``: RPN proposals kept per image (before and after
    NMS; torchvision's defaults 2000/1000), ``roi_batch``: proposals sampled per image to
    train the box head (Detectron2's 512). Fewer make small CPU runs much faster.
    ``min_scale`` < 1: multi-scale training (as Detectron2's default resize), each training
    batch scaled to one of five sizes from ``min_scale * image_size`` to ``image_size`` px;
    scoring always at ``image_size``.

    The model maps a list of (3, H, W) float32 tensors in [0, 1] to, per image, ``boxes``
    (K, 4) float32 x0, y0, x1, y1 pixels, ``labels`` (K,) int64 (1 = first class) and
    ``scores`` (K,) float32; in train mode, with targets, to a dict of scalar losses.
    """
    require_torch()
    if backbone not in BACKBONES:
        raise UserError(f"--backbone {backbone!r} is unknown; use one of {', '.join(BACKBONES)}")
    weights = check_weights(weights)
    pretrained = weights in ("default", "backbone")
    try:
        return _build(backbone, weights, pretrained, num_classes, image_size, proposals_train,
                      proposals_test, roi_batch, min_scale)
    except OSError as e:  # URLError, no network, a full disk: the download failed
        raise UserError(f"--weights {weights}: could not get torchvision's weights ({e}); "
                        f"use --weights none, or a file you downloaded") from None


def _build(backbone, weights, pretrained, num_classes, image_size, proposals_train,
           proposals_test, roi_batch, min_scale):
    from torch import nn
    from torchvision.models.detection import FasterRCNN
    from torchvision.models.detection.anchor_utils import AnchorGenerator
    from torchvision.models.detection.backbone_utils import (
        mobilenet_backbone,
        resnet_fpn_backbone,
    )
    from torchvision.models.detection.faster_rcnn import FastRCNNPredictor
    from torchvision.ops.misc import FrozenBatchNorm2d

    coco = weights == "default" and backbone == "resnet50-fpn"  # the whole detector's
    bw = _backbone_weights(backbone) if pretrained and not coco else None
    # from scratch: BatchNorm learns (all layers trainable); pretrained: torchvision's
    # frozen statistics and its default number of trainable stages
    norm = FrozenBatchNorm2d if pretrained else nn.BatchNorm2d
    if backbone == "mobilenet_v3-fpn":
        body = mobilenet_backbone(backbone_name="mobilenet_v3_large", weights=bw, fpn=True,
                                  norm_layer=norm, trainable_layers=3 if pretrained else 6,
                                  returned_layers=MOBILENET_STAGES)
        levels = len(MOBILENET_STAGES) + 1
    else:
        name = "resnext101_32x8d" if backbone.startswith("resnext") else "resnet50"
        body = resnet_fpn_backbone(backbone_name=name, weights=bw, norm_layer=norm,
                                   trainable_layers=3 if pretrained else 5)
        levels = 5
    anchors = AnchorGenerator(tuple((s,) for s in ANCHOR_SIZES[:levels]),
                              (ASPECT_RATIOS,) * levels)
    model = FasterRCNN(body, num_classes=91 if coco else num_classes + 1,
                       min_size=train_sizes(image_size, min_scale), max_size=image_size,
                       rpn_anchor_generator=anchors,
                       rpn_pre_nms_top_n_train=proposals_train,
                       rpn_post_nms_top_n_train=proposals_train,
                       rpn_pre_nms_top_n_test=proposals_test,
                       rpn_post_nms_top_n_test=proposals_test,
                       box_batch_size_per_image=roi_batch)
    if coco:
        from torchvision.models.detection import FasterRCNN_ResNet50_FPN_Weights
        state = FasterRCNN_ResNet50_FPN_Weights.DEFAULT.get_state_dict(progress=False,
                                                                      check_hash=True)
        model.load_state_dict(state)
        box = model.roi_heads.box_predictor.cls_score.in_features
        model.roi_heads.box_predictor = FastRCNNPredictor(box, num_classes + 1)
    elif weights not in WEIGHT_CHOICES:
        load_weights_file(model, Path(weights))
    return model


def train_sizes(image_size: int, min_scale: float = 1.0) -> tuple[int, ...]:
    """Training image sizes (px), ascending, ending at ``image_size`` (the scoring size)."""
    steps = [min_scale + (1.0 - min_scale) * k / 4 for k in range(5)]
    return tuple(sorted({max(16, int(round(image_size * f))) for f in steps}))


def load_weights_file(model, path: Path) -> None:
    """Load a state dict (or a checkpoint dict with a ``model`` entry) into ``model``."""
    torch, _ = require_torch()
    try:
        state = torch.load(path, map_location="cpu", weights_only=True)
    except Exception as e:  # noqa: BLE001 - any unreadable file is the user's to fix
        raise UserError(f"--weights {path}: not a readable torch state dict ({e})") from None
    if isinstance(state, dict) and "model" in state and isinstance(state["model"], dict):
        state = state["model"]
    try:
        model.load_state_dict(state)
    except (RuntimeError, TypeError, AttributeError) as e:
        first = str(e).strip().splitlines()[0] if str(e).strip() else type(e).__name__
        raise UserError(f"--weights {path}: does not fit this detector ({first}); pass the "
                        f"--backbone it was trained with") from None


def predict(model, images: list, device: str = "cpu", batch_size: int = 4) -> list:
    """Detections of ``model`` (eval mode) on ``images``, each (H, W, 3) uint8 RGB.

    Returns, per image, ``(boxes, scores, labels)`` NumPy arrays: (K, 4) float32 x0, y0, x1,
    y1 pixels, (K,) float32 in [0, 1], (K,) int64 class ids from 1.
    """
    torch, _ = require_torch()
    model.eval()
    out = []
    with torch.inference_mode():
        for k in range(0, len(images), batch_size):
            batch = [to_tensor(im).to(device) for im in images[k:k + batch_size]]
            for r in model(batch):
                out.append((r["boxes"].float().cpu().numpy(), r["scores"].float().cpu().numpy(),
                            r["labels"].cpu().numpy()))
    return out


def to_tensor(image):
    """(H, W, 3) uint8 RGB -> (3, H, W) float32 tensor in [0, 1]."""
    torch, _ = require_torch()
    return torch.from_numpy(image).permute(2, 0, 1).float().div_(255.0)
