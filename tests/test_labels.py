"""The labelling policy: every visible pixel of an object of interest is in a
label or in an ignore region; ignore regions are COCO ``iscrowd`` entries that COCOeval
ignores, 8-bit ignore masks beside the instance masks, SeaDronesSee's category 0 with
``--ignored-category``; ``--unlabelled skip`` draws nothing that cannot be labelled."""

from __future__ import annotations

import contextlib
import io
import json
from pathlib import Path

import cv2
import numpy as np
import pytest
from pycocotools.coco import COCO
from pycocotools.cocoeval import COCOeval

from sdcomp import Generator, GeneratorConfig
from sdcomp.annotate import AnnotationRule
from sdcomp.annotate.masks import MIN_SIDE
from sdcomp.io.coco import write_coco
from sdcomp.io.journal import Journal, read_journal

from .datasets import check_intact, generate

pytestmark = pytest.mark.filterwarnings("ignore:__array__ implementation:DeprecationWarning")

BASE = ["--size", "128", "--clutter", "0", "--count", "1-4", "--seed", "5", "--n", "8",
        "--format", "coco,yolo"]
CATEGORIES = [{"id": 1, "name": "boat", "supercategory": "boat"}]


def test_rule_labels_what_a_detector_can_learn_from():
    rule = AnnotationRule(min_visible_px=4)
    assert rule.labelled(4, (0, 0, 2, 2), 1.0)
    assert rule.labelled(40, (0, 0, 20, 2), 0.01)  # truncated to a hundredth: labelled
    assert not rule.labelled(3, (0, 0, 3, 1), 1.0)  # too few pixels
    assert not rule.labelled(30, (0, 0, 30, 1), 1.0)  # a line: a side under MIN_SIDE
    assert MIN_SIDE == 2
    strict = AnnotationRule(min_visible_px=4, min_in_frame=0.25)
    assert strict.labelled(40, (0, 0, 20, 2), 0.25) and not strict.labelled(40, (0, 0, 20, 2),
                                                                            0.24)


def test_every_visible_object_pixel_is_labelled_or_ignored(sprites_dir):
    """The default rule against one that labels every visible pixel: the same pixels, the
    labelled objects with their masks, the rest exactly the ignore mask."""
    gen = Generator(GeneratorConfig(seed=5, width=128, height=128, clutter=0,
                                    count="2-6"), sprites_dir)
    everything = AnnotationRule(1, min_side=1)
    ignored = 0
    for i in range(6):
        scene = gen.scene(i)
        f = gen.render_scene(scene)
        all_ = gen.render_scene(scene, everything)
        assert np.array_equal(f.image, all_.image)
        ignore = f.ignore if f.ignore is not None else np.zeros(f.instances.shape, bool)
        assert np.array_equal((f.instances > 0) | ignore, all_.instances > 0)
        assert not ((f.instances > 0) & ignore).any()
        by_placement = {o.placement: o for o in all_.objects}
        for o in f.objects:
            a = by_placement[o.placement]
            assert (o.area, o.bbox) == (a.area, a.bbox)
            assert np.array_equal(f.instances == o.instance_id, all_.instances == a.instance_id)
        assert sorted(o.placement for o in f.ignored) == sorted(
            set(by_placement) - {o.placement for o in f.objects})
        for o in f.ignored:
            assert o.area < gen.config.min_visible_px or min(o.bbox[2:]) < MIN_SIDE
        ignored += len(f.ignored)
    assert ignored > 0  # the frames test something


def test_ignored_category_writes_seadronessee_category_zero(tmp_path):
    """--ignored-category: ignore regions are annotations of category 0 'ignored' (listed
    first, as in SeaDronesSee's files), still iscrowd 1, with ids after the image's
    labelled objects'."""
    rle = {"size": [8, 8], "counts": "0"}
    rec = {"index": 3, "split": "train",
           "image": {"id": 3, "file_name": "train/000003.jpg", "width": 8, "height": 8},
           "annotations": [{"instance_id": 1, "category_id": 1, "bbox": [0.0, 0.0, 2.0, 2.0],
                            "area": 4, "segmentation": rle, "iscrowd": 0}],
           "ignore": [{"category_id": 1, "bbox": [5.0, 5.0, 1.0, 1.0], "area": 1,
                       "segmentation": rle, "iscrowd": 1}]}
    with Journal(tmp_path / "j.jsonl") as j:
        j.append([rec])
    offsets = read_journal(tmp_path / "j.jsonl")
    for flag, cat in ((False, 1), (True, 0)):
        out = tmp_path / f"c{flag}.json"
        counts = write_coco(out, tmp_path / "j.jsonl", offsets, "train", CATEGORIES, {}, flag)
        coco = json.loads(out.read_text())
        assert counts["annotations"] == 2
        crowd = [a for a in coco["annotations"] if a["iscrowd"]]
        assert [(a["id"], a["category_id"], a["instance_id"]) for a in crowd] == [
            (4002, cat, 2)]
        names = [c["name"] for c in coco["categories"]]
        assert names == (["ignored", "boat"] if flag else ["boat"])


@pytest.fixture(scope="module")
def drawn(tmp_path_factory, sprites_dir) -> Path:
    out = tmp_path_factory.mktemp("labels") / "draw"
    rc, _, err = generate(BASE, out, sprites_dir)
    assert rc == 0, err
    return out


@pytest.fixture(scope="module")
def skipped(tmp_path_factory, sprites_dir) -> Path:
    out = tmp_path_factory.mktemp("labels") / "skip"
    rc, _, err = generate(BASE, out, sprites_dir, "--unlabelled", "skip")
    assert rc == 0, err
    return out


def _coco(path: Path) -> COCO:
    with contextlib.redirect_stdout(io.StringIO()):
        return COCO(str(path))


def _evaluate(gt: COCO, dets: list[dict]) -> COCOeval:
    with contextlib.redirect_stdout(io.StringIO()):
        ev = COCOeval(gt, gt.loadRes(dets), "bbox")
        ev.evaluate()
        ev.accumulate()
        ev.summarize()
    return ev


def test_dataset_ignore_regions_agree_with_masks_and_counts(drawn):
    check_intact(drawn)  # crowd RLEs == ignore masks, apart from the labels
    meta = json.loads((drawn / "dataset.json").read_text())["counts"]
    crowd = 0
    for split in ("train", "val"):
        coco = json.loads((drawn / "annotations" / f"instances_{split}.json").read_text())
        crowd += sum(a["iscrowd"] for a in coco["annotations"])
        assert all(isinstance(a["segmentation"]["counts"], str) for a in coco["annotations"])
    assert meta["objects_ignored"] == crowd > 0
    records = [json.loads(ln) for ln in (drawn / "records.jsonl").read_text().splitlines()]
    assert sum(r["image"]["meta"]["objects_truncated"] for r in records) == meta[
        "objects_truncated"] == sum(a["truncated"] for r in records for a in r["annotations"])


def test_resume_redraws_a_lost_ignore_mask(drawn, tmp_path, sprites_dir):
    """An ignore mask deleted after the run is drawn again by --resume, the same bytes; the
    other images are kept (not drawn again)."""
    import shutil

    out = tmp_path / "copy"
    shutil.copytree(drawn, out)
    lost = sorted((out / "masks").glob("*/*_ignore.png"))[0]
    want = lost.read_bytes()
    kept = {p: p.stat().st_mtime_ns for p in (out / "images").glob("*/*")}
    lost.unlink()
    rc, _, err = generate(BASE, out, sprites_dir, "--resume")
    assert rc == 0, err
    assert lost.read_bytes() == want
    image = out / "images" / lost.parent.name / (lost.name.split("_")[0] + ".jpg")
    changed = [p for p, t in kept.items() if p.stat().st_mtime_ns != t]
    assert changed == [image], changed
    check_intact(out)


def test_cocoeval_ignores_detections_on_ignore_regions(drawn):
    """Ground truth against itself: AP 1.0; a detection on an ignore region, scored above
    every true one, is neither a true nor a false positive (AP stays 1.0, it is ignored)."""
    done = False
    for split in ("train", "val"):
        gt = _coco(drawn / "annotations" / f"instances_{split}.json")
        anns = gt.loadAnns(gt.getAnnIds())
        true = [a for a in anns if not a["iscrowd"]]
        crowd = [a for a in anns if a["iscrowd"]]
        if not (true and crowd):
            continue
        dets = [{"image_id": a["image_id"], "category_id": a["category_id"], "bbox": a["bbox"],
                 "score": 0.5} for a in true]
        assert _evaluate(gt, dets).stats[0] == pytest.approx(1.0)
        c = crowd[0]
        on_ignore = {"image_id": c["image_id"], "category_id": c["category_id"],
                     "bbox": c["bbox"], "score": 1.0}
        ev = _evaluate(gt, [*dets, on_ignore])
        assert ev.stats[0] == pytest.approx(1.0)
        # the same detection off the ignore region is a false positive
        off = dict(on_ignore, bbox=[c["bbox"][0] + 40.0, c["bbox"][1] + 40.0, *c["bbox"][2:]])
        if not any(a["image_id"] == c["image_id"] and abs(a["bbox"][0] - off["bbox"][0]) < 8
                   for a in anns):
            assert _evaluate(gt, [*dets, off]).stats[0] < 0.99
        done = True
    assert done


def test_unlabelled_skip_draws_only_what_is_labelled(drawn, skipped):
    """--unlabelled skip: no ignore region anywhere (YOLO, which has none, then has no
    unlabelled instance); images that had nothing to ignore are byte-identical, the others
    drawn without the objects that could not be labelled."""
    check_intact(skipped)
    d = json.loads((drawn / "dataset.json").read_text())["counts"]
    s = json.loads((skipped / "dataset.json").read_text())["counts"]
    assert s["objects_ignored"] == 0 and s["objects_skipped"] >= d["objects_ignored"] > 0
    assert not list((skipped / "masks").rglob("*_ignore.png"))
    changed = 0
    for rec in (json.loads(ln) for ln in (drawn / "records.jsonl").read_text().splitlines()):
        name = rec["image"]["file_name"]
        same = (drawn / "images" / name).read_bytes() == (skipped / "images" / name).read_bytes()
        assert same == ("ignore" not in rec), name
        changed += not same
        labels = (skipped / "labels" / name).with_suffix(".txt").read_text().splitlines()
        masks = cv2.imread(str(skipped / "masks" / rec["image"]["mask_file"]),
                           cv2.IMREAD_UNCHANGED)
        assert len(labels) == int(masks.max())
    assert changed > 0


def test_torch_datasets_carry_the_ignore_region(drawn, sprites_dir):
    """GeneratedCoco's target "ignore" is the image's ignore mask (zeros without one), as
    SyntheticDetection's is the rendered frame's; a v2 pipeline ending in
    SanitizeBoundingBoxes keeps it."""
    from torchvision.transforms import v2

    from sdcomp.torch_datasets import GeneratedCoco, SyntheticDetection

    sanitize = v2.Compose([v2.RandomHorizontalFlip(1.0), v2.SanitizeBoundingBoxes()])
    ds = GeneratedCoco(drawn, "all")
    flipped = GeneratedCoco(drawn, "all", transforms=sanitize)
    seen = 0
    for k, im in enumerate(ds.images):
        _, target = ds[k]
        ignore = target["ignore"].numpy().astype(bool)
        assert ignore.shape == (im["height"], im["width"])
        if "ignore_file" in im:
            want = cv2.imread(str(drawn / "masks" / im["ignore_file"]), cv2.IMREAD_UNCHANGED)
            assert np.array_equal(ignore, want > 0) and ignore.any()
            assert np.array_equal(flipped[k][1]["ignore"].numpy().astype(bool), ignore[:, ::-1])
            seen += 1
        else:
            assert not ignore.any()
    assert seen > 0
    config = GeneratorConfig.from_mapping(
        {"width": 128, "height": 128, "clutter": 0, "count": "1-4", "seed": 5})
    synth = SyntheticDetection(config, 8, sprites_dir)
    rec = next(json.loads(ln) for ln in (drawn / "records.jsonl").read_text().splitlines()
               if "ignore" in json.loads(ln))
    _, target = synth[rec["index"]]
    want = cv2.imread(str(drawn / "masks" / rec["image"]["ignore_file"]), cv2.IMREAD_UNCHANGED)
    assert np.array_equal(target["ignore"].numpy() > 0, want > 0)
