"""A detector at the images' own resolution, and its BatchNorm statistics re-estimated on
unlabelled frames: the diagnostic of ``bench sim2real``.

**Native resolution** (:func:`native_resolution`): torchvision's detection transform scales
every image so that its sides fit ``min_size``/``max_size``; a 1920 x 1080 real frame scored
by a detector built for 416 px images would be shrunk 4.6 times, and its 20-pixel objects with
it. The transform is replaced by one that normalises and pads (to a multiple of 32) but never
resizes, in training and in scoring, so objects are seen at the size they have.

**BatchNorm re-estimation** (:func:`reestimate_batchnorm`, "AdaBN"): the weights stay; only
the per-channel means and variances that every BatchNorm layer normalises with are measured
again, on the user's unlabelled real frames (no labels, no training). A detector whose real
score rises with it was failing on the frames' global statistics (the water, light and
camera: the scene's look), not on the object's appearance. Frozen BatchNorm layers
(pretrained backbones) are made ordinary BatchNorm layers with the same affine weights first.
"""

from __future__ import annotations

import copy
from collections.abc import Iterable

import numpy as np

from . import require_torch

_TRANSFORM = None


def _native_transform_class():
    """``GeneralizedRCNNTransform`` whose ``resize`` leaves images and boxes as they are."""
    global _TRANSFORM
    if _TRANSFORM is None:
        from torchvision.models.detection.transform import GeneralizedRCNNTransform

        class NativeTransform(GeneralizedRCNNTransform):
            """Normalise and batch (zero-padded to a multiple of 32); never resize."""

            def resize(self, image, target=None):
                return image, target

        _TRANSFORM = NativeTransform
    return _TRANSFORM


def native_resolution(model):
    """``model`` (a torchvision Faster R-CNN) with its transform replaced by one that never
    resizes (same normalisation and padding); returns ``model``."""
    t = model.transform
    model.transform = _native_transform_class()(t.min_size, t.max_size, t.image_mean,
                                                t.image_std, t.size_divisible)
    return model


def _thawed(module):
    """``module`` with every ``FrozenBatchNorm2d`` replaced, in place, by a ``BatchNorm2d`` of
    the same weight, bias, statistics and eps."""
    torch, _ = require_torch()
    from torchvision.ops.misc import FrozenBatchNorm2d

    for name, child in list(module.named_children()):
        if isinstance(child, FrozenBatchNorm2d):
            bn = torch.nn.BatchNorm2d(child.weight.numel(), eps=child.eps)
            with torch.no_grad():
                bn.weight.copy_(child.weight)
                bn.bias.copy_(child.bias)
                bn.running_mean.copy_(child.running_mean)
                bn.running_var.copy_(child.running_var)
            setattr(module, name, bn.to(child.weight.device))
        else:
            _thawed(child)
    return module


def reestimate_batchnorm(model, frames: Iterable[np.ndarray], device: str = "cpu"):
    """A copy of ``model`` whose BatchNorm statistics are measured on ``frames`` (each an
    (H, W, 3) uint8 RGB array, fed one at a time through the model's own transform and
    backbone): every BatchNorm layer's running mean and variance become the average over the
    frames of each frame's per-channel statistics. ``model`` is not changed. Returns the
    copy in eval mode and the number of frames used (ValueError when there were none)."""
    torch, _ = require_torch()
    from .detector import to_tensor

    new = _thawed(copy.deepcopy(model)).to(device)
    new.eval()
    norms = [m for m in new.modules() if isinstance(m, torch.nn.modules.batchnorm._BatchNorm)]
    for m in norms:
        m.reset_running_stats()
        m.momentum = None  # cumulative average over the frames
        m.train()
    n = 0
    with torch.no_grad():  # (inference mode would not let BatchNorm update its buffers)
        for frame in frames:
            images, _ = new.transform([to_tensor(frame).to(device)])
            new.backbone(images.tensors)
            n += 1
    for m in norms:
        m.eval()
    if n == 0:
        raise ValueError("no frames to re-estimate BatchNorm statistics on")
    return new, n


def batchnorm_layers(model) -> int:
    """How many BatchNorm layers (ordinary or frozen) ``model`` has."""
    torch, _ = require_torch()
    from torchvision.ops.misc import FrozenBatchNorm2d

    return sum(isinstance(m, (torch.nn.modules.batchnorm._BatchNorm, FrozenBatchNorm2d))
               for m in model.modules())
