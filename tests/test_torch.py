"""sdcomp.torch: on-the-fly and folder datasets in the torchvision detection format,
determinism, pickling, a 2-worker DataLoader, and a few Faster R-CNN training steps."""

from __future__ import annotations

import contextlib
import io
import pickle
import sys

import numpy as np
import pytest
import torch
from torchvision import tv_tensors
from torchvision.transforms import v2

from sdcomp.cli.generate import main
from sdcomp.errors import UserError, run_cli
from sdcomp.pipeline import Generator
from sdcomp.scene.config import GeneratorConfig
from sdcomp.torch_datasets import GeneratedCoco, SyntheticDetection, collate

# 96 px, low altitude: the BlueROV2 is tens of pixels; 0-3 objects, so some images are empty
CONFIG = GeneratorConfig(width=96, height=96, clutter=0.0, altitude="3-6", count="0-3",
                         seed=5, image_format="png")


@pytest.fixture(scope="module")
def dataset(sprites_dir) -> SyntheticDetection:
    Generator(CONFIG, sprites_dir, progress=False)  # atlases built once, before any worker
    return SyntheticDetection(CONFIG, 30, sprites_dir=sprites_dir)


def same(a: tuple, b: tuple) -> bool:
    (ia, ta), (ib, tb) = a, b
    if not torch.equal(ia, ib) or set(ta) != set(tb):
        return False
    return all(torch.equal(ta[k], tb[k]) if torch.is_tensor(ta[k]) else ta[k] == tb[k]
               for k in ta)


def test_item_format_and_agreement_with_generator(dataset, sprites_dir):
    gen = Generator(CONFIG, sprites_dir, progress=False)
    n_objects = empty = 0
    for i in range(12):
        image, t = dataset[i]
        s = gen.sample(i)
        n = len(s.annotations)
        assert image.shape == (3, 96, 96) and image.dtype == torch.float32
        assert torch.equal((image * 255).round().to(torch.uint8).permute(1, 2, 0),
                           torch.from_numpy(s.image))
        assert 0.0 <= float(image.min()) and float(image.max()) <= 1.0
        assert t["boxes"].shape == (n, 4) and t["boxes"].dtype == torch.float32
        assert t["labels"].dtype == torch.int64 and t["labels"].tolist() == [
            a["category_id"] for a in s.annotations]
        assert t["masks"].shape == (n, 96, 96) and t["masks"].dtype == torch.uint8
        assert torch.equal(t["masks"].bool(), torch.from_numpy(s.masks))
        assert t["image_id"] == i  # the number in the file name, COCO's image id
        assert type(image) is tv_tensors.Image and type(t["masks"]) is tv_tensors.Mask
        assert type(t["boxes"]) is tv_tensors.BoundingBoxes
        assert t["boxes"].format.name == "XYXY" and tuple(t["boxes"].canvas_size) == (96, 96)
        assert t["area"].dtype == torch.float32
        assert t["area"].tolist() == [float(a["area"]) for a in s.annotations]
        assert t["iscrowd"].dtype == torch.int64 and t["iscrowd"].tolist() == [0] * n
        for box, a in zip(t["boxes"].tolist(), s.annotations, strict=True):
            x, y, w, h = a["bbox"]
            assert box == [x, y, x + w, y + h]
        for box, mask in zip(t["boxes"], t["masks"], strict=True):  # boxes = mask extents
            ys, xs = torch.nonzero(mask, as_tuple=True)
            assert box.tolist() == [xs.min(), ys.min(), xs.max() + 1, ys.max() + 1]
        n_objects += n
        empty += n == 0
    assert n_objects > 5 and empty > 0


def test_deterministic_and_small_when_pickled(dataset, sprites_dir):
    first = [dataset[i] for i in (3, 7)]
    assert same(dataset[7], first[1])  # any order
    other = SyntheticDetection(CONFIG, 30, sprites_dir=sprites_dir)
    assert same(other[3], first[0])
    assert same(dataset[-27], first[0])  # negative indices as in a list
    blob = pickle.dumps(dataset)  # after use: the generator is not carried
    assert len(blob) < 20_000
    assert same(pickle.loads(blob)[7], first[1])
    with pytest.raises(IndexError):
        dataset[30]
    assert len(dataset) == 30
    seeded = SyntheticDetection(GeneratorConfig.from_mapping({"seed": 6}, CONFIG), 30,
                                sprites_dir=sprites_dir)
    assert not torch.equal(seeded[3][0], first[0][0])
    with pytest.raises(UserError, match="length"):
        SyntheticDetection(CONFIG, -1)


def test_dataloader_two_workers(dataset):
    # busy OpenCV's thread pool in this process first: forked workers must not hang on it
    for i in range(3):
        dataset[i]
    loader = torch.utils.data.DataLoader(dataset, batch_size=4, num_workers=2,
                                         collate_fn=collate, timeout=300)
    seen = []
    for images, targets in loader:
        assert len(images) == len(targets) <= 4
        seen += list(zip(images, targets, strict=True))
    assert len(seen) == len(dataset)
    assert all(same(seen[i], dataset[i]) for i in (0, 13, 29))


def test_uint8_images_are_the_float_images_times_255(dataset, sprites_dir):
    """image_dtype=torch.uint8: the same images as 8-bit values (the float32 ones are them
    divided by 255, exactly), the same targets, through a 2-worker DataLoader and from a
    pickled copy (what a spawned worker gets); anything else is a UserError naming the
    value."""
    small = SyntheticDetection(CONFIG, 30, sprites_dir=sprites_dir, image_dtype=torch.uint8)
    loader = torch.utils.data.DataLoader(torch.utils.data.Subset(small, [0, 13, 29]),
                                         batch_size=2, num_workers=2, collate_fn=collate,
                                         timeout=300)
    seen = [item for images, targets in loader for item in zip(images, targets, strict=True)]
    seen.append(pickle.loads(pickle.dumps(small))[7])
    for (image, target), i in zip(seen, (0, 13, 29, 7), strict=True):
        image_f, target_f = dataset[i]
        assert image.dtype == torch.uint8 and image.shape == image_f.shape
        assert torch.equal(image.float().div_(255), image_f)
        assert same((image_f, target), (image_f, target_f))
    for bad in ("uint8", torch.float64, np.uint8, None):
        with pytest.raises(UserError, match=r"image_dtype .* torch\.uint8"):
            SyntheticDetection(CONFIG, 30, sprites_dir=sprites_dir, image_dtype=bad)


class Marked(torch.Tensor):
    """A tensor subclass (as torchvision's tv_tensors are)."""


def test_batch_pickles_its_tensors_as_one_buffer_per_dtype(dataset):
    """What a DataLoader worker sends: a collated batch arrives as a plain (images, targets)
    tuple with the same values, its plain tensors views of one shared buffer per dtype;
    tv_tensors come back as the same tv_tensors (their data in the shared buffers too); other
    tensor subclasses and tensors that need gradients travel as they are."""
    import io
    import pickle
    from multiprocessing.reduction import ForkingPickler

    import torch.multiprocessing  # noqa: F401  (torch's reductions for shared tensors)

    items = [dataset[i] for i in (0, 13, 29)]
    extra = {"marked": torch.ones(3).as_subclass(Marked),
             "grad": torch.ones(2, requires_grad=True)}
    items[1][1]["extra"] = extra
    batch = collate(items)
    buf = io.BytesIO()
    ForkingPickler(buf, pickle.HIGHEST_PROTOCOL).dump(batch)
    images, targets = out = pickle.loads(buf.getvalue())
    assert type(out) is tuple and type(images) is tuple and type(targets) is tuple
    def plain_target(t: dict) -> dict:
        return {k: v for k, v in t.items() if k != "extra"}

    assert all(same((gi, plain_target(gt)), (wi, plain_target(wt)))
               for gi, gt, (wi, wt) in zip(images, targets, items, strict=True))
    assert type(targets[1]["extra"]["marked"]) is Marked
    assert targets[1]["extra"]["grad"].requires_grad
    assert all(type(im) is tv_tensors.Image for im in images)
    assert all(type(t["boxes"]) is tv_tensors.BoundingBoxes and type(t["masks"]) is
               tv_tensors.Mask and tuple(t["boxes"].canvas_size) == (96, 96) for t in targets)
    packed = (torch.Tensor, tv_tensors.Image, tv_tensors.Mask, tv_tensors.BoundingBoxes)
    plain = [t for t in (*images, *(v for tg in targets for v in tg.values()))
             if type(t) in packed and not t.requires_grad]
    storages = {t.untyped_storage().data_ptr() for t in plain}
    assert len(storages) == len({t.dtype for t in plain}) < len(plain)


def test_dataloader_spawned_workers_get_a_small_pickle(dataset):
    # spawn: the dataset reaches the workers pickled (config only); they build generators
    subset = torch.utils.data.Subset(dataset, [2, 17, 23])
    loader = torch.utils.data.DataLoader(subset, batch_size=2, num_workers=2,
                                         collate_fn=collate, multiprocessing_context="spawn",
                                         timeout=300)
    seen = [item for images, targets in loader for item in zip(images, targets, strict=True)]
    assert [t["image_id"] for _, t in seen] == [2, 17, 23]
    assert all(same(item, dataset[i]) for item, i in zip(seen, (2, 17, 23), strict=True))


def test_transforms_hook(sprites_dir):
    calls = []

    def flip(image, target):
        calls.append(target["image_id"])
        w = image.shape[-1]
        target = dict(target, boxes=target["boxes"][:, [2, 1, 0, 3]] * torch.tensor(
            [-1.0, 1.0, -1.0, 1.0]) + torch.tensor([w, 0.0, w, 0.0]),
            masks=target["masks"].flip(-1))
        return image.flip(-1), target

    plain = SyntheticDetection(CONFIG, 30, sprites_dir=sprites_dir)
    flipped = SyntheticDetection(CONFIG, 30, sprites_dir=sprites_dir, transforms=flip)
    (a, ta), (b, tb) = plain[4], flipped[4]
    assert calls == [4]
    assert torch.equal(b, a.flip(-1)) and torch.equal(tb["masks"], ta["masks"].flip(-1))


@pytest.mark.parametrize("fmt", ["coco", "yolo"])
def test_generated_coco_matches_on_the_fly(tmp_path, dataset, sprites_dir, fmt):
    """A written folder reads back as the on-the-fly dataset; one written with --format yolo
    (no COCO files) is read from its journal."""
    out = tmp_path / "ds"
    err = io.StringIO()
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(err):
        rc = run_cli(main, ["--config", str(_toml(tmp_path)), "--n", "20", "--out", str(out),
                            "--sprites", str(sprites_dir), "--workers", "1", "--no-progress",
                            "--format", fmt])
    assert rc == 0, err.getvalue()
    assert (out / "annotations" / "instances_train.json").exists() == (fmt == "coco")
    both = {}
    for split in ("train", "val"):
        ds = GeneratedCoco(out, split)
        assert len(ds) > 0
        for k in range(len(ds)):
            image, t = ds[k]
            both[t["image_id"]] = (image, t)
    assert sorted(both) == list(range(20))
    for image_id, item in both.items():
        assert same(item, dataset[image_id])  # PNG images: bit-exact
    assert len(GeneratedCoco(out, "all")) == 20
    image8, t8 = GeneratedCoco(out, "all", image_dtype=torch.uint8)[5]
    image_f, tf = GeneratedCoco(out, "all")[5]
    assert image8.dtype == torch.uint8 and torch.equal(image8.float().div_(255), image_f)
    assert same((image_f, t8), (image_f, tf))
    with pytest.raises(UserError, match="image_dtype"):
        GeneratedCoco(out, "all", image_dtype=torch.int32)
    with pytest.raises(UserError, match="does not exist"):
        GeneratedCoco(tmp_path / "nothing", "train")


def _toml(tmp_path):
    path = tmp_path / "c.toml"
    path.write_text(CONFIG.to_toml())
    return path


def test_faster_rcnn_trains(dataset):
    """A few torchvision Faster R-CNN steps on SyntheticDetection: the loss goes down."""
    from torchvision.models.detection import fasterrcnn_mobilenet_v3_large_fpn

    torch.manual_seed(0)
    model = fasterrcnn_mobilenet_v3_large_fpn(weights=None, weights_backbone=None,
                                              num_classes=2, min_size=96, max_size=96)
    model.train()
    ids = [i for i in range(len(dataset)) if len(dataset[i][1]["boxes"])][:4]
    images, targets = collate([dataset[i] for i in ids])
    targets = [{k: v for k, v in t.items() if k != "masks"} for t in targets]
    opt = torch.optim.SGD(model.parameters(), lr=0.01, momentum=0.9)
    losses = []
    for _ in range(8):
        loss = sum(model(list(images), targets).values())
        opt.zero_grad()
        loss.backward()
        opt.step()
        losses.append(float(loss.detach()))
    print("\nFaster R-CNN losses:", " ".join(f"{v:.3f}" for v in losses), file=sys.stderr)
    assert all(np.isfinite(losses))
    assert np.mean(losses[-3:]) < 0.8 * np.mean(losses[:3])


V2 = {"flip": (v2.RandomHorizontalFlip(p=1.0), 0.0),
      "vflip": (v2.RandomVerticalFlip(p=1.0), 0.0),
      "rotate90": (v2.RandomAffine(degrees=(90.0, 90.0)), 0.0),
      "affine": (v2.RandomAffine(degrees=0.0, translate=(0.2, 0.2), scale=(0.8, 1.3)), 1.5),
      "resize": (v2.Resize((150, 130)), 150 / 96),
      "crop": (v2.RandomCrop(64), None)}  # None: a cut object's box is clamped, not shrunk


@pytest.mark.parametrize("name", list(V2))
def test_v2_transforms_move_boxes_and_masks_with_the_image(sprites_dir, name):
    """torchvision v2 geometric transforms given as ``transforms``: boxes still equal their
    masks' extents afterwards (to within the transform's resampling of the mask); a crop, or
    an affine move that pushes an object over the frame's edge, clamps the box of an object
    it cuts, which then still contains the mask's extent."""
    transform, tol = V2[name]
    pipeline = v2.Compose([transform, v2.SanitizeBoundingBoxes(min_size=1)])
    torch.manual_seed(0)
    plain = SyntheticDetection(CONFIG, 30, sprites_dir=sprites_dir)
    moved = SyntheticDetection(CONFIG, 30, sprites_dir=sprites_dir, transforms=pipeline)
    checked = 0
    for i in range(12):
        image, t = moved[i]
        assert type(image) is tv_tensors.Image and t["boxes"].dtype == torch.float32
        assert tuple(t["boxes"].canvas_size) == tuple(image.shape[-2:]) == tuple(
            t["masks"].shape[-2:])
        assert len(t["boxes"]) == len(t["masks"]) == len(t["labels"])
        for box, mask in zip(t["boxes"], t["masks"], strict=True):
            ys, xs = torch.nonzero(mask, as_tuple=True)
            if len(xs) == 0:
                continue
            extent = torch.tensor([xs.min(), ys.min(), xs.max() + 1, ys.max() + 1]).float()
            h, w = image.shape[-2:]
            cut = bool(box[0] <= 0 or box[1] <= 0 or box[2] >= w or box[3] >= h)
            if tol is None:
                assert (box[:2] <= extent[:2]).all() and (box[2:] >= extent[2:]).all()
                assert (box >= 0).all() and (box[2:] <= 64).all()
            elif cut:  # the clamped box of the whole moved object: it holds the visible part
                assert (box[:2] <= extent[:2] + tol).all(), (i, box, extent)
                assert (box[2:] >= extent[2:] - tol).all(), (i, box, extent)
            else:
                assert torch.allclose(box, extent, atol=tol + 1e-4), (i, box, extent)
            checked += 1
        if name == "flip":
            assert torch.equal(image, plain[i][0].flip(-1))
    assert checked > 5


def test_resize_keeps_fractional_boxes(tmp_path, sprites_dir):
    """COCO boxes are written as floats, so a v2 resize of a read-back box is not truncated
    to whole pixels."""
    out = tmp_path / "ds"
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
        rc = run_cli(main, ["--config", str(_toml(tmp_path)), "--n", "6", "--out", str(out),
                            "--sprites", str(sprites_dir), "--workers", "1"])
    assert rc == 0
    ds = GeneratedCoco(out, "all", transforms=v2.Resize((97, 97)))
    raw = GeneratedCoco(out, "all")
    n = 0
    for k in range(len(ds)):
        (_, t), (_, r) = ds[k], raw[k]
        assert t["boxes"].dtype == torch.float32
        assert torch.allclose(t["boxes"], r["boxes"] * 97 / 96, atol=1e-4)
        n += len(r["boxes"])
    assert n > 0
