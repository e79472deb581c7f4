"""Real frames as a torch dataset, alone and mixed with synthetic images in a fixed ratio
(issue 49: what "synthetic plus K real frames" trains on)."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from sdcomp.errors import UserError
from sdcomp.torch_datasets import GeneratedCoco, MixedDetection, RealDetection, collate

from .user_inputs import H, W, coco_labels, frames_folder, generated, yolo_labels

__all__ = ["generated"]  # a fixture

pytestmark = pytest.mark.filterwarnings("ignore:__array__ implementation:DeprecationWarning")


def test_real_frames_in_the_torchvision_format(tmp_path):
    frames = frames_folder(tmp_path)

    def edit(c: dict) -> None:
        c["annotations"][1]["bbox"] = [150, 110, 40, 40]  # partly outside: clipped
        c["annotations"][2]["bbox"] = [500, 500, 10, 10]  # wholly outside: dropped
    real = RealDetection(frames, coco_labels(frames, tmp_path / "l.json", edit),
                         image_dtype=torch.uint8)
    assert len(real) == 3
    image, target = real[0]
    assert image.shape == (3, H, W) and image.dtype == torch.uint8
    assert target["boxes"].tolist() == [[20.0, 20.0, 41.0, 33.0]]
    assert target["labels"].tolist() == [1]
    assert target["masks"].shape == (1, H, W) and int(target["masks"].sum()) == 21 * 13
    assert float(target["area"][0]) == 21 * 13 and target["ignore"].shape == (H, W)
    assert real[1][1]["boxes"].tolist() == [[150.0, 110.0, W, H]]
    assert len(real[2][1]["boxes"]) == 0 and real[2][1]["masks"].shape == (0, H, W)
    floats, _ = RealDetection(frames, tmp_path / "l.json")[0]
    assert floats.dtype == torch.float32 and torch.allclose(floats * 255, image.float())


def test_real_categories_take_the_synthetic_ids_by_name(tmp_path):
    frames = frames_folder(tmp_path)
    labels = coco_labels(frames, tmp_path / "l.json")
    assert RealDetection(frames, labels, {"BlueROV2": 4})[0][1]["labels"].tolist() == [4]
    with pytest.raises(UserError, match="'bluerov2' is not among"):
        RealDetection(frames, labels, {"boat": 1})
    yolo = RealDetection(frames, yolo_labels(frames, tmp_path))
    assert yolo[0][1]["labels"].tolist() == [1]  # YOLO class 0 is category 1


@pytest.mark.parametrize("ratio", [0.0, 0.1, 0.25, 0.5, 1.0])
def test_mixed_stream_holds_the_ratio_in_every_prefix(ratio, tmp_path, generated):
    frames = frames_folder(tmp_path)
    real = RealDetection(frames, coco_labels(frames, tmp_path / "l.json"))
    synthetic = GeneratedCoco(generated, "all")
    mixed = MixedDetection(real, synthetic, ratio, length=40)
    kinds = [mixed.kind(i) for i in range(len(mixed))]
    for n in range(1, len(kinds) + 1):
        assert abs(kinds[:n].count("real") - ratio * n) < 1, (n, kinds[:n])
    # real items cycle the real frames in order, synthetic ones the synthetic images
    reals = [i for i, k in enumerate(kinds) if k == "real"]
    syns = [i for i, k in enumerate(kinds) if k == "synthetic"]
    if reals:
        shapes = {tuple(mixed[i][0].shape) for i in reals[:4]}
        assert shapes == {(3, H, W)}
        assert torch.equal(mixed[reals[0]][0], real[0][0])
        if len(reals) > 3:
            assert torch.equal(mixed[reals[3]][0], real[0][0])
    if syns:
        assert mixed[syns[0]][1]["image_id"] == synthetic[0][1]["image_id"]
        assert tuple(mixed[syns[0]][0].shape) == (3, 96, 96)
        assert "ignore" in mixed[syns[0]][1]
    images, targets = collate([mixed[i] for i in range(4)])
    assert len(images) == len(targets) == 4


def test_mixed_default_length_and_bad_ratios(tmp_path, generated):
    frames = frames_folder(tmp_path)
    real = RealDetection(frames, coco_labels(frames, tmp_path / "l.json"))
    synthetic = GeneratedCoco(generated, "all")
    assert len(MixedDetection(real, synthetic, 0.5)) == 2 * len(synthetic)
    assert len(MixedDetection(real, synthetic, 1.0)) == len(real)
    half = MixedDetection(real, synthetic, 0.5)
    assert sum(half.kind(i) == "synthetic" for i in range(len(half))) == len(synthetic)
    for bad in (-0.1, 1.5, float("nan"), "half"):
        with pytest.raises(UserError, match="ratio"):
            MixedDetection(real, synthetic, bad)  # type: ignore[arg-type]
    with pytest.raises(UserError, match="needs both kinds"):
        MixedDetection(real, torch.utils.data.TensorDataset(torch.zeros(0)), 0.5)
    with pytest.raises(IndexError):
        half[len(half)]
    assert np.isclose(half.ratio, 0.5)
