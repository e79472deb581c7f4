"""Training, checkpoints and resume of the detector benchmark (tiny CPU runs)."""

from __future__ import annotations

import sys

import numpy as np
import pytest
import torch

from sdcomp.bench import require_torch
from sdcomp.bench.datasets import CacheOptions, DatasetPart, ensure_dataset, merged_split
from sdcomp.bench.detector import BACKBONES, build_detector, predict
from sdcomp.bench.train import TrainConfig, load_checkpoint, train, training_items
from sdcomp.errors import UserError

SIZE = 64
TINY = TrainConfig(backbone="mobilenet_v3-fpn", lr=0.01, max_iter=4, batch_size=2,
                   warmup_iters=1, checkpoint_every=2, proposals_train=40, proposals_test=20,
                   roi_batch=16)


pytestmark = pytest.mark.usefixtures("one_torch_thread")


@pytest.fixture(scope="module")
def items(tmp_path_factory, sprites_dir):
    cache = CacheOptions(tmp_path_factory.mktemp("cache"), sprites_dir, 1, False)
    part = DatasetPart("t", 10, "brown", 6, 0, SIZE, val_fraction=0.0)
    folder, _ = ensure_dataset(part.generator_config(), "t", cache)
    out = training_items(merged_split([folder], "train"))
    assert len(out) == 6 and sum(len(b) for _, b in out) >= 1
    return out


def test_training_items_are_corner_boxes_inside_the_image(items):
    for _path, boxes in items:
        assert boxes.dtype == np.float32 and boxes.shape[1] == 4
        assert np.all(boxes[:, 2] > boxes[:, 0]) and np.all(boxes[:, 3] > boxes[:, 1])
        assert np.all(boxes >= 0) and np.all(boxes <= SIZE)


def test_interrupted_training_resumes_to_the_uninterrupted_result(items, tmp_path):
    full_model, full = train(TINY, items, SIZE, tmp_path / "full.pt", "k1")
    assert len(full["losses"]) == 4 and full["resumed_from"] == 0
    assert all(len(row) == 5 and np.isfinite(row).all() for row in full["losses"])

    def stop(iteration, loss):
        if iteration == 2:
            raise KeyboardInterrupt

    ckpt = tmp_path / "cut.pt"
    with pytest.raises(KeyboardInterrupt):
        train(TINY, items, SIZE, ckpt, "k1", on_iteration=stop)
    saved = load_checkpoint(ckpt, "k1")
    assert saved["iteration"] == 3 and len(saved["losses"]) == 3
    model, resumed = train(TINY, items, SIZE, ckpt, "k1")
    assert resumed["resumed_from"] == 3
    np.testing.assert_allclose(resumed["losses"], full["losses"], rtol=1e-4, atol=1e-5)
    for (name, a), b in zip(full_model.state_dict().items(), model.state_dict().values(),
                            strict=True):
        if a.dtype.is_floating_point:
            torch.testing.assert_close(a, b, rtol=1e-3, atol=1e-4, msg=name)


def test_finished_training_is_not_repeated(items, tmp_path):
    ckpt = tmp_path / "c.pt"
    _, first = train(TINY, items, SIZE, ckpt, "k2")
    stamp = ckpt.stat().st_mtime_ns

    def never(iteration, loss):
        raise AssertionError("a finished training ran again")

    model, again = train(TINY, items, SIZE, ckpt, "k2", on_iteration=never)
    assert again["resumed_from"] == TINY.max_iter and again["losses"] == first["losses"]
    assert ckpt.stat().st_mtime_ns == stamp
    assert not model.training


def test_checkpoint_of_another_training_is_refused(items, tmp_path):
    ckpt = tmp_path / "c.pt"
    train(TrainConfig(**{**TINY.to_dict(), "max_iter": 1}), items, SIZE, ckpt, "aaa")
    with pytest.raises(UserError, match="other settings"):
        train(TINY, items, SIZE, ckpt, "bbb")


def test_multi_scale_training_scores_at_full_size():
    model = build_detector("mobilenet_v3-fpn", "none", 1, 64, 20, 10, 8, min_scale=0.5)
    image = [torch.rand(3, 64, 64)]
    model.train()
    seen = {model.transform(image)[0].image_sizes[0] for _ in range(40)}
    assert seen == {(32, 32), (40, 40), (48, 48), (56, 56), (64, 64)}
    model.eval()
    assert {model.transform(image)[0].image_sizes[0] for _ in range(5)} == {(64, 64)}


def test_predict_returns_boxes_scores_labels():
    torch.manual_seed(0)
    model = build_detector("mobilenet_v3-fpn", "none", 1, SIZE, 40, 20, 16)
    images = [np.zeros((SIZE, SIZE, 3), np.uint8), np.full((SIZE, SIZE, 3), 200, np.uint8)]
    out = predict(model, images, batch_size=1)
    assert len(out) == 2
    for boxes, scores, labels in out:
        assert boxes.shape == (len(scores), 4) and boxes.dtype == np.float32
        assert np.all((scores >= 0) & (scores <= 1)) and np.all(labels >= 1)


@pytest.mark.parametrize("backbone", BACKBONES)
def test_every_backbone_builds_without_downloading(backbone, monkeypatch):
    def no_download(*a, **k):
        raise AssertionError("tried to download weights")

    import torchvision.models._api as api

    monkeypatch.setattr(api, "load_state_dict_from_url", no_download)
    monkeypatch.setattr(torch.hub, "load_state_dict_from_url", no_download)
    model = build_detector(backbone, "none", 1, 96, 20, 10, 8)
    assert model.roi_heads.box_predictor.cls_score.out_features == 2
    model.eval()
    with torch.inference_mode():
        out = model([torch.rand(3, 96, 96)])
    assert out[0]["boxes"].shape[1] == 4


def test_default_weights_are_torchvisions_coco_detector(monkeypatch):
    """``--weights default`` for resnet50-fpn loads torchvision's COCO Faster R-CNN (served
    here from a freshly built torchvision model, so nothing downloads) and gets a new
    two-class box predictor; a failed download is a one-line error."""
    import torchvision.models._api as api
    from torchvision.models.detection import fasterrcnn_resnet50_fpn

    torch.manual_seed(2)
    coco = fasterrcnn_resnet50_fpn(weights=None, weights_backbone=None).state_dict()
    urls = []

    def serve(url, *a, **k):
        urls.append(url)
        return coco

    monkeypatch.setattr(api, "load_state_dict_from_url", serve)
    model = build_detector("resnet50-fpn", "default", 1, 64)
    assert len(urls) == 1 and "fasterrcnn_resnet50_fpn" in urls[0]
    assert model.roi_heads.box_predictor.cls_score.out_features == 2
    ours = model.state_dict()
    key = "backbone.body.layer1.0.conv1.weight"
    assert torch.equal(ours[key], coco[key])
    assert torch.equal(ours["rpn.head.cls_logits.weight"], coco["rpn.head.cls_logits.weight"])

    def offline(url, *a, **k):
        raise OSError("no network")

    monkeypatch.setattr(api, "load_state_dict_from_url", offline)
    for backbone in ("resnet50-fpn", "mobilenet_v3-fpn"):
        with pytest.raises(UserError, match="--weights default: could not get"):
            build_detector(backbone, "default", 1, 64)


def test_weights_file_loads_and_a_mismatch_is_a_user_error(tmp_path):
    torch.manual_seed(1)
    a = build_detector("mobilenet_v3-fpn", "none", 1, 64)
    path = tmp_path / "w.pt"
    torch.save({"model": a.state_dict()}, path)
    b = build_detector("mobilenet_v3-fpn", str(path), 1, 64)
    for x, y in zip(a.state_dict().values(), b.state_dict().values(), strict=True):
        assert torch.equal(x, y)
    with pytest.raises(UserError, match="does not fit this detector"):
        build_detector("resnet50-fpn", str(path), 1, 64)
    (tmp_path / "junk.pt").write_bytes(b"junk")
    with pytest.raises(UserError, match="not a readable torch state dict"):
        build_detector("mobilenet_v3-fpn", str(tmp_path / "junk.pt"), 1, 64)


def test_missing_torch_is_one_install_hint(monkeypatch):
    monkeypatch.setitem(sys.modules, "torch", None)
    with pytest.raises(UserError, match=r'pip install -e "\.\[bench\]"'):
        require_torch()
