"""sdcomp.torch_clips: clips of on-the-fly video sequences as (video, targets) with track ids
that persist across frames and agree with the instance maps; deterministic in any process
and order; a 2-worker DataLoader; the transforms hook and collate."""

from __future__ import annotations

import copy
import pickle

import numpy as np
import pytest
import torch
from torchvision import tv_tensors
from torchvision.transforms import v2

from sdcomp.clips import ClipGenerator
from sdcomp.errors import UserError
from sdcomp.scene.config import GeneratorConfig
from sdcomp.scene.video import VideoConfig
from sdcomp.torch_clips import SyntheticClips, clip_starts, collate

# 128 px, low altitude: objects are tens of pixels; a few per frame
CONFIG = VideoConfig(GeneratorConfig(width=128, height=128, altitude="4-6", count="2-3",
                                     clutter=0.0, seed=3), sequences=2, frames=8)


@pytest.fixture(scope="module")
def dataset(sprites_dir) -> SyntheticClips:
    return SyntheticClips(CONFIG, 4, sprites_dir=sprites_dir)


def same(a: tuple, b: tuple) -> bool:
    (va, ta), (vb, tb) = a, b
    if not torch.equal(va, vb) or len(ta) != len(tb):
        return False
    for x, y in zip(ta, tb, strict=True):
        if set(x) != set(y):
            return False
        for k in x:
            if torch.is_tensor(x[k]):
                if not torch.equal(x[k], y[k]):
                    return False
            elif x[k] != y[k]:
                return False
    return True


def test_clip_starts():
    assert clip_starts(8, 4, 1) == [0, 4]
    assert clip_starts(12, 3, 2) == [0, 6]
    assert clip_starts(10, 4, 3) == [0]  # 12 > 10 frames, but one clip of span 10 fits
    assert clip_starts(10, 4, 1, 3) == [0, 3, 6]
    assert clip_starts(10, 4, 1, 1) == [0]
    with pytest.raises(UserError, match="spans 11 frames"):
        clip_starts(10, 3, 5)


def test_len_and_clip_frames(dataset):
    assert len(dataset) == 4 and dataset.clips_per_sequence == 2
    assert dataset.clip_frames(0) == (0, [0, 1, 2, 3])
    assert dataset.clip_frames(3) == (1, [4, 5, 6, 7])
    assert dataset.clip_frames(-1) == (1, [4, 5, 6, 7])
    with pytest.raises(IndexError):
        dataset[4]


def test_shapes_types_and_agreement_with_clip_generator(dataset, sprites_dir):
    gen = ClipGenerator(CONFIG, sprites_dir, progress=False)
    video, targets = dataset[1]
    assert type(video) is tv_tensors.Video
    assert video.shape == (4, 3, 128, 128) and video.dtype == torch.uint8
    assert len(targets) == 4
    for t, (k, target) in enumerate(zip([4, 5, 6, 7], targets, strict=True)):
        f = gen.frame(0, k)
        assert torch.equal(video[t].permute(1, 2, 0), torch.from_numpy(f.image))
        objs = sorted(f.objects, key=lambda o: o["track_id"])
        n = len(objs)
        assert target["sequence"] == 0 and target["frame"] == k
        assert type(target["boxes"]) is tv_tensors.BoundingBoxes
        assert target["boxes"].format == tv_tensors.BoundingBoxFormat.XYXY
        assert tuple(target["boxes"].canvas_size) == (128, 128)
        assert target["boxes"].shape == (n, 4) and target["boxes"].dtype == torch.float32
        assert target["labels"].dtype == torch.int64 and target["labels"].tolist() == [
            o["category_id"] for o in objs]
        assert target["track_ids"].dtype == torch.int64
        assert target["visibility"].dtype == torch.float32 and target["visibility"].shape == (n,)
        masks = target["masks"]
        assert type(masks) is tv_tensors.Mask and masks.dtype == torch.bool
        assert masks.shape == (n, 128, 128)
        for j, o in enumerate(objs):
            x, y, w, h = o["bbox"]
            assert target["boxes"][j].tolist() == [x, y, x + w, y + h]
            # the mask is where the instance map holds the object's track id
            assert torch.equal(masks[j], torch.from_numpy(f.instances == o["track_id"]))
            ys, xs = np.nonzero(masks[j].numpy())
            assert (xs.min(), ys.min(), xs.max() + 1, ys.max() + 1) == (x, y, x + w, y + h)


def test_track_ids_persist_across_frames(dataset):
    seen = 0
    for i in range(len(dataset)):
        video, targets = dataset[i]
        ids = [set(t["track_ids"].tolist()) for t in targets]
        # track ids are unique within a frame
        assert all(len(s) == len(t["track_ids"]) for s, t in zip(ids, targets, strict=True))
        # an object seen in two consecutive frames keeps its id and moves little
        for a, b in zip(targets, targets[1:], strict=False):
            for j, tid in enumerate(a["track_ids"].tolist()):
                if tid in b["track_ids"].tolist():
                    k = b["track_ids"].tolist().index(tid)
                    assert a["labels"][j] == b["labels"][k]
                    ca = a["boxes"][j].reshape(2, 2).mean(0)
                    cb = b["boxes"][k].reshape(2, 2).mean(0)
                    assert float((ca - cb).abs().max()) < 12
                    seen += 1
    assert seen >= 10


def test_deterministic_across_datasets_and_order(dataset, sprites_dir):
    other = SyntheticClips(CONFIG, 4, sprites_dir=sprites_dir)
    forward = [dataset[i] for i in range(len(dataset))]
    backward = [other[i] for i in reversed(range(len(other)))][::-1]
    assert all(same(a, b) for a, b in zip(forward, backward, strict=True))
    copy = pickle.loads(pickle.dumps(dataset))
    assert copy._clips is None and len(pickle.dumps(dataset)) < 50_000
    assert same(copy[2], forward[2])


def test_dataloader_two_workers_same_as_in_process(dataset):
    def batches(workers: int) -> list:
        loader = torch.utils.data.DataLoader(dataset, batch_size=2, num_workers=workers,
                                             collate_fn=collate)
        return list(loader)

    serial, parallel = batches(0), batches(2)
    assert len(serial) == len(parallel) == 2
    for (va, ta), (vb, tb) in zip(serial, parallel, strict=True):
        assert va.shape == (2, 4, 3, 128, 128) and va.dtype == torch.uint8
        assert torch.equal(va, vb)
        assert len(ta) == len(tb) == 2
        for clip_a, clip_b in zip(ta, tb, strict=True):
            assert same((va[:0], clip_a), (vb[:0], clip_b))
    assert torch.equal(serial[0][0][1], dataset[1][0])


def test_transforms_hook_moves_every_frame_alike(sprites_dir):
    plain = SyntheticClips(CONFIG, 3, clips_per_sequence=1, stride=2, sprites_dir=sprites_dir)
    flipped = copy.copy(plain)  # the same generator, with the hook
    flipped.transforms = v2.RandomHorizontalFlip(p=1.0)
    assert len(plain) == 2 and plain.clip_frames(1) == (1, [0, 2, 4])
    (va, ta), (vb, tb) = plain[1], flipped[1]
    assert type(vb) is tv_tensors.Video
    assert torch.equal(vb, va.flip(-1))
    for a, b in zip(ta, tb, strict=True):
        assert torch.equal(b["masks"], a["masks"].flip(-1))
        assert torch.equal(b["track_ids"], a["track_ids"])
        x1, y1, x2, y2 = a["boxes"].unbind(-1)
        assert torch.equal(b["boxes"], torch.stack([128 - x2, y1, 128 - x1, y2], -1))


def test_collate_and_bad_arguments(dataset, sprites_dir):
    videos, targets = collate([dataset[0], dataset[2]])
    assert videos.shape == (2, 4, 3, 128, 128) and len(targets) == 2 and len(targets[0]) == 4
    assert collate([]) == ((), ())
    with pytest.raises(UserError, match="clip_len"):
        SyntheticClips(CONFIG, 0, sprites_dir=sprites_dir)
    with pytest.raises(UserError, match="spans 9 frames"):
        SyntheticClips(CONFIG, 9, sprites_dir=sprites_dir)
    with pytest.raises(UserError, match="VideoConfig"):
        SyntheticClips("config", 2, sprites_dir=sprites_dir)  # type: ignore[arg-type]


def test_generator_config_gets_video_defaults(sprites_dir):
    ds = SyntheticClips(CONFIG.generator, 50, sprites_dir=sprites_dir)
    assert ds.config.frames == 150 and len(ds) == 4 * 3
