"""COCO helpers, the record journal, and the streaming COCO writer."""

from __future__ import annotations

import contextlib
import io
import json
import random
import tracemalloc

import numpy as np
import pytest
from pycocotools import mask as mask_utils
from pycocotools.coco import COCO
from pycocotools.cocoeval import COCOeval

from sdcomp.annotate.rle import mask_to_rle
from sdcomp.errors import UserError
from sdcomp.io.coco import annotation_id, write_coco
from sdcomp.io.journal import Journal, iter_records, read_journal, truncate_journal

CATEGORIES = [{"id": 1, "name": "bluerov2", "supercategory": "rov"},
              {"id": 2, "name": "buoy", "supercategory": "object"}]
# pycocotools' own decode under numpy 2 warns about __array__(copy=...); not ours
pytestmark = pytest.mark.filterwarnings("ignore:__array__ implementation:DeprecationWarning")

INFO = {"description": "sdcomp test", "version": "1", "year": 2025}


# --- helpers -----------------------------------------------------------------------------------

def test_mask_to_rle_round_trip():
    rng = np.random.default_rng(0)
    for shape in [(1, 1), (1, 9), (7, 1), (13, 17), (64, 48)]:
        for p in (0.0, 0.05, 0.5, 1.0):
            mask = rng.random(shape) < p
            rle = mask_to_rle(mask)
            assert rle["size"] == list(shape) and isinstance(rle["counts"], str)
            json.dumps(rle)  # JSON-able as it is
            back = mask_utils.decode({"size": rle["size"], "counts": rle["counts"].encode()})
            np.testing.assert_array_equal(back.astype(bool), mask)
            area = int(mask_utils.area({"size": rle["size"], "counts": rle["counts"]}))
            assert area == int(mask.sum())


def test_mask_to_rle_accepts_non_bool_and_rejects_non_2d():
    m = np.zeros((5, 6), np.uint8)
    m[1:3, 2:5] = 7
    assert mask_to_rle(m) == mask_to_rle(m != 0)
    with pytest.raises(ValueError):
        mask_to_rle(np.zeros((3, 4, 1), bool))


def test_annotation_id():
    ids = {annotation_id(i, k) for i in range(300) for k in (1, 2, 3, 500, 999)}
    assert len(ids) == 300 * 5
    assert annotation_id(17, 1) == 18001 and annotation_id(0, 999) == 1999
    assert annotation_id(np.int64(3), np.int32(2)) == 4002
    for bad in (0, 1000, -1, 1.0, True, None):
        with pytest.raises(ValueError):
            annotation_id(5, bad)
    with pytest.raises(ValueError):
        annotation_id(-1, 1)


# --- records as the generator makes them ------------------------------------------------------

def make_record(index: int, split: str, rng: np.random.Generator, h: int = 40, w: int = 56,
                max_instances: int = 4) -> dict:
    ids = np.zeros((h, w), np.uint16)
    for inst in range(1, int(rng.integers(0, max_instances + 1)) + 1):
        y, x = int(rng.integers(0, h - 2)), int(rng.integers(0, w - 2))
        ids[y:y + int(rng.integers(2, h // 2)), x:x + int(rng.integers(2, w // 2))] = inst
    anns = []
    for inst in np.unique(ids[ids > 0]).tolist():
        m = ids == inst
        rle = mask_to_rle(m)
        bbox = mask_utils.toBbox({**rle, "counts": rle["counts"].encode()}).astype(int).tolist()
        anns.append({"instance_id": inst, "category_id": 1 + inst % 2, "bbox": bbox,
                     "area": int(m.sum()), "segmentation": rle, "iscrowd": 0,
                     "pose": {"yaw": float(rng.random()), "range_m": 12.5}})
    return {"index": index, "split": split,
            "image": {"id": index + 1, "file_name": f"{index:06d}.jpg", "width": w, "height": h,
                      "mask_file": f"{index:06d}.png",
                      "meta": {"seed": index * 7, "sea_state": [1, 2.5]}},
            "annotations": anns}


def make_records(n: int, seed: int = 0) -> list[dict]:
    rng = np.random.default_rng(seed)
    return [make_record(i, "val" if i % 5 == 4 else "train", rng) for i in range(n)]


# --- journal -----------------------------------------------------------------------------------

def test_journal_append_and_read(tmp_path):
    recs = make_records(12)
    path = tmp_path / "records.jsonl"
    with Journal(path) as j:
        j.append(recs[:5])
        j.append([])
        j.append(recs[5:])
    assert j.closed
    offsets = read_journal(path)
    assert sorted(offsets) == list(range(12))
    assert list(iter_records(path, offsets)) == recs
    assert [r["index"] for r in iter_records(path, offsets, "val")] == [4, 9]
    assert len(path.read_text().splitlines()) == 12
    # numpy values are written as plain JSON numbers
    with Journal(path) as j:
        j.append([{"index": np.int64(20), "split": "train", "x": np.float32(0.5),
                   "a": np.arange(3)}])
    rec = next(iter_records(path, {20: read_journal(path)[20]}))
    assert rec == {"index": 20, "split": "train", "x": 0.5, "a": [0, 1, 2]}


def test_journal_rejects_bad_records_without_writing(tmp_path):
    path = tmp_path / "records.jsonl"
    with Journal(path) as j:
        j.append(make_records(2))
        size = path.stat().st_size
        for bad in ([{"split": "train"}], [{"index": "3"}], [make_records(1)[0], 5],
                    [{"index": 3, "x": float("nan")}], [{"index": 3, "x": object()}]):
            with pytest.raises((ValueError, TypeError)):
                j.append(bad)
        assert path.stat().st_size == size


def test_truncated_last_line_skipped_and_repaired(tmp_path):
    recs = make_records(6)
    path = tmp_path / "records.jsonl"
    with Journal(path) as j:
        j.append(recs[:5])
    line = json.dumps(recs[5], separators=(",", ":"))
    with open(path, "a") as f:  # a crash in the middle of writing record 5
        f.write(line[: len(line) // 2])
    assert sorted(read_journal(path)) == [0, 1, 2, 3, 4]
    truncate_journal(path)
    assert path.read_bytes().endswith(b"\n")
    assert sorted(read_journal(path)) == [0, 1, 2, 3, 4]
    with Journal(path) as j:
        j.append([recs[5]])
    offsets = read_journal(path)
    assert list(iter_records(path, offsets)) == recs


def test_journal_open_repairs_partial_line(tmp_path):
    recs = make_records(3)
    path = tmp_path / "records.jsonl"
    with Journal(path) as j:
        j.append(recs[:2])
    with open(path, "a") as f:
        f.write('{"index":2,"spl')
    with Journal(path) as j:  # no explicit truncate_journal: opening cuts the partial line
        j.append([recs[2]])
    assert list(iter_records(path, read_journal(path))) == recs


def test_truncate_keeps_whole_record_missing_newline(tmp_path):
    recs = make_records(3)
    path = tmp_path / "records.jsonl"
    path.write_text("\n".join(json.dumps(r) for r in recs))  # no final newline
    assert sorted(read_journal(path)) == [0, 1, 2]
    truncate_journal(path)
    assert path.read_text().endswith("\n")
    assert list(iter_records(path, read_journal(path))) == recs


def test_truncate_edge_cases(tmp_path):
    path = tmp_path / "j.jsonl"
    path.write_bytes(b"")
    truncate_journal(path)
    assert path.read_bytes() == b""
    path.write_bytes(b'{"index":1,"sp')  # only a partial line
    truncate_journal(path)
    assert path.read_bytes() == b""
    long_partial = b'{"index":1,"x":"' + b"a" * 200_000  # longer than one read-back block
    path.write_bytes(b'{"index":0}\n' + long_partial)
    truncate_journal(path)
    assert path.read_bytes() == b'{"index":0}\n'


def test_blank_lines_duplicates_and_damage(tmp_path):
    recs = make_records(4)
    path = tmp_path / "records.jsonl"
    newer = dict(recs[1], split="val")
    with Journal(path) as j:
        j.append(recs[:3])
    with open(path, "a") as f:
        f.write("\n  \n")
    with Journal(path) as j:
        j.append([newer, recs[3]])
    offsets = read_journal(path)
    assert sorted(offsets) == [0, 1, 2, 3]
    assert [r["split"] for r in iter_records(path, offsets)] == ["train", "val", "train",
                                                                   "train"]
    # a damaged line that is not the last one is an error, not silently dropped
    lines = path.read_text().splitlines(keepends=True)
    lines.insert(1, '{"index":9,"spl\n')
    path.write_text("".join(lines))
    with pytest.raises(UserError, match="line 2"):
        read_journal(path)


def test_iter_records_detects_stale_offsets(tmp_path):
    path = tmp_path / "records.jsonl"
    with Journal(path) as j:
        j.append(make_records(3))
    offsets = read_journal(path)
    offsets[2] += 1
    with pytest.raises(UserError):
        list(iter_records(path, offsets))


# --- COCO files --------------------------------------------------------------------------------

def write_journal(path, recs, order=None, batch=7):
    order = list(range(len(recs))) if order is None else order
    with Journal(path) as j:
        for i in range(0, len(order), batch):
            j.append([recs[k] for k in order[i:i + batch]])


def quiet(fn, *args):
    with contextlib.redirect_stdout(io.StringIO()):
        return fn(*args)


def test_write_coco_loads_and_is_consistent(tmp_path):
    recs = make_records(40, seed=3)
    recs[7]["annotations"] = []  # an image with nothing in it is kept
    jpath = tmp_path / "records.jsonl"
    write_journal(jpath, recs)
    offsets = read_journal(jpath)
    total = {"images": 0, "annotations": 0}
    for split in ("train", "val"):
        out = tmp_path / f"{split}.json"
        counts = write_coco(out, jpath, offsets, split, CATEGORIES, INFO)
        mine = [r for r in recs if r["split"] == split]
        assert counts == {"images": len(mine),
                          "annotations": sum(len(r["annotations"]) for r in mine)}
        total = {k: total[k] + counts[k] for k in total}
        coco = quiet(COCO, str(out))
        data = json.loads(out.read_text())
        assert list(data) == ["info", "licenses", "categories", "images", "annotations"]
        assert data["info"] == INFO and data["licenses"] == []
        assert sorted(coco.getCatIds()) == [1, 2]
        assert [im["id"] for im in data["images"]] == [r["image"]["id"] for r in mine]
        assert len(set(coco.getImgIds())) == len(mine)
        ann_ids = [a["id"] for a in data["annotations"]]
        assert len(set(ann_ids)) == len(ann_ids) == counts["annotations"]
        for a in data["annotations"]:
            assert isinstance(a["area"], int) and a["area"] > 0
            assert a["iscrowd"] == 0 and isinstance(a["segmentation"]["counts"], str)
            assert a["image_id"] in coco.imgs
            assert a["id"] == annotation_id(a["image_id"] - 1, a["instance_id"])
            m = coco.annToMask(a)
            ys, xs = np.nonzero(m)
            extent = [xs.min(), ys.min(), xs.max() - xs.min() + 1, ys.max() - ys.min() + 1]
            assert int(m.sum()) == a["area"] and extent == a["bbox"]
        if split == "train":
            assert 8 in coco.imgs and coco.getAnnIds(imgIds=[8]) == []
    assert total["images"] == 40
    assert not [p.name for p in tmp_path.iterdir() if p.name.endswith(".tmp")]


@pytest.mark.parametrize("iou_type", ["bbox", "segm"])
def test_cocoeval_of_ground_truth_against_itself(tmp_path, iou_type):
    recs = make_records(30, seed=5)
    jpath = tmp_path / "records.jsonl"
    write_journal(jpath, recs)
    out = tmp_path / "train.json"
    write_coco(out, jpath, read_journal(jpath), "train", CATEGORIES, INFO)
    gt = quiet(COCO, str(out))
    key = "bbox" if iou_type == "bbox" else "segmentation"
    dets = [{"image_id": a["image_id"], "category_id": a["category_id"], key: a[key],
             "score": 1.0} for a in gt.dataset["annotations"]]
    assert dets
    dt = quiet(gt.loadRes, dets)
    ev = COCOeval(gt, dt, iou_type)
    quiet(ev.evaluate)
    quiet(ev.accumulate)
    quiet(ev.summarize)
    assert ev.stats[0] == pytest.approx(1.0)


def test_write_coco_independent_of_journal_order(tmp_path):
    recs = make_records(50, seed=8)
    order = list(range(50))
    random.Random(1).shuffle(order)
    a, b = tmp_path / "a.jsonl", tmp_path / "b.jsonl"
    write_journal(a, recs)
    write_journal(b, recs, order, batch=3)
    assert a.read_bytes() != b.read_bytes()
    for split in ("train", "val", None):
        write_coco(tmp_path / "a.json", a, read_journal(a), split, CATEGORIES, INFO)
        write_coco(tmp_path / "b.json", b, read_journal(b), split, CATEGORIES, INFO)
        assert (tmp_path / "a.json").read_bytes() == (tmp_path / "b.json").read_bytes()


def test_write_coco_is_atomic_on_error(tmp_path):
    recs = make_records(10, seed=2)
    recs[6]["annotations"] = [dict(recs[6]["annotations"][0], instance_id=1000)] \
        if recs[6]["annotations"] else [{"instance_id": 0}]
    jpath = tmp_path / "records.jsonl"
    write_journal(jpath, recs)
    out = tmp_path / "train.json"
    out.write_text("old")
    with pytest.raises(ValueError):
        write_coco(out, jpath, read_journal(jpath), None, CATEGORIES, INFO)
    assert out.read_text() == "old"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["records.jsonl", "train.json"]


def test_write_coco_checks_categories_and_duplicate_instances(tmp_path):
    recs = make_records(3, seed=4)
    jpath = tmp_path / "records.jsonl"
    write_journal(jpath, recs)
    offsets = read_journal(jpath)
    for cats in ([{"id": 0, "name": "x"}], [{"id": 1, "name": "a"}, {"id": 1, "name": "b"}],
                 [{"id": 1}]):
        with pytest.raises(ValueError):
            write_coco(tmp_path / "c.json", jpath, offsets, None, cats, INFO)
    ann = {"instance_id": 1, "category_id": 1, "bbox": [0, 0, 1, 1], "area": 1, "iscrowd": 0,
           "segmentation": mask_to_rle(np.ones((1, 1), bool))}
    with Journal(jpath) as j:
        j.append([dict(recs[0], annotations=[ann, ann])])
    with pytest.raises(UserError, match="twice"):
        write_coco(tmp_path / "c.json", jpath, read_journal(jpath), None, CATEGORIES, INFO)
    assert not (tmp_path / "c.json").exists()


def test_write_coco_memory_stays_flat(tmp_path):
    """20,000 records: write_coco's peak is a small fraction of holding them all."""
    rng = np.random.default_rng(11)
    templates = [make_record(i, "train", rng, h=120, w=160, max_instances=3) for i in range(50)]
    jpath = tmp_path / "records.jsonl"
    n = 20_000
    with Journal(jpath) as j:
        for start in range(0, n, 2000):
            batch = []
            for i in range(start, start + 2000):
                t = templates[i % len(templates)]
                batch.append({"index": i, "split": "val" if i % 10 == 0 else "train",
                              "image": dict(t["image"], id=i + 1, file_name=f"{i:06d}.jpg"),
                              "annotations": t["annotations"]})
            j.append(batch)
    offsets = read_journal(jpath)
    assert len(offsets) == n

    tracemalloc.start()  # what holding 1,000 of the records takes
    held = list(iter_records(jpath, dict(list(offsets.items())[:1000])))
    per_1000 = tracemalloc.get_traced_memory()[0]
    del held
    tracemalloc.stop()

    tracemalloc.start()
    try:
        counts = write_coco(tmp_path / "train.json", jpath, offsets, "train", CATEGORIES, INFO)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert counts["images"] == n - n // 10
    all_records = per_1000 * n / 1000
    assert all_records > 20e6  # the check means something
    assert peak < 5e6 and peak < all_records / 10, (peak, all_records)
