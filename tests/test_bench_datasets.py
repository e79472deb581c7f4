"""Cell datasets cached by config hash, test sets and their checks (no torch)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from sdcomp.bench.datasets import (
    CacheOptions,
    DatasetPart,
    config_key,
    ensure_dataset,
    merged_split,
    real_test,
)
from sdcomp.errors import UserError


def _part(**kw) -> DatasetPart:
    args = {"name": "alt10-brown", "altitude": 10, "water": "brown", "n": 3, "seed": 0,
            "size": 64}
    return DatasetPart(**{**args, **kw})


@pytest.fixture()
def cache(tmp_path, sprites_dir) -> CacheOptions:
    return CacheOptions(tmp_path / "cache", sprites_dir, 1, False)


def test_same_config_is_reused_changed_config_regenerated(cache):
    config = _part().generator_config()
    folder, reused = ensure_dataset(config, "alt10-brown", cache)
    assert not reused and folder.name == f"alt10-brown-{config_key(config)}"
    meta = json.loads((folder / "dataset.json").read_text())
    assert meta["status"] == "complete" and meta["counts"]["images"] == 3
    stamp = {p: p.stat().st_mtime_ns for p in folder.rglob("*") if p.is_file()}
    again, reused = ensure_dataset(_part().generator_config(), "alt10-brown", cache)
    assert reused and again == folder
    assert {p: p.stat().st_mtime_ns for p in folder.rglob("*") if p.is_file()} == stamp
    # another image count or water colour: another key and folder, generated anew
    for changed in (_part(n=4), _part(water="green"), _part(seed=5), _part(size=48)):
        c = changed.generator_config()
        assert config_key(c) != config_key(config)
        other, reused = ensure_dataset(c, "alt10-brown", cache)
        assert not reused and other != folder
        assert json.loads((other / "dataset.json").read_text())["config"] == c.to_dict()


def test_interrupted_generation_is_completed(cache):
    config = _part(n=4, seed=9).generator_config()
    folder, _ = ensure_dataset(config, "x", cache)
    lost = next((folder / "images").glob("*/000002.jpg"))
    first = lost.read_bytes()
    meta = json.loads((folder / "dataset.json").read_text())
    meta["status"] = "interrupted"
    (folder / "dataset.json").write_text(json.dumps(meta))
    lost.unlink()
    again, reused = ensure_dataset(config, "x", cache)
    assert again == folder and not reused
    assert lost.read_bytes() == first
    assert json.loads((folder / "dataset.json").read_text())["status"] == "complete"


def test_parts_merge_with_new_ids_and_absolute_paths(cache):
    a, _ = ensure_dataset(_part(n=5).generator_config(), "a", cache)
    b, _ = ensure_dataset(_part(n=5, water="green", seed=1).generator_config(), "b", cache)
    merged = merged_split([a, b], "train")
    parts = [json.loads((f / "annotations" / "instances_train.json").read_text())
             for f in (a, b)]
    assert len(merged["images"]) == sum(len(p["images"]) for p in parts)
    assert len(merged["annotations"]) == sum(len(p["annotations"]) for p in parts)
    assert [im["id"] for im in merged["images"]] == list(range(1, len(merged["images"]) + 1))
    assert all(Path(im["path"]).is_absolute() and Path(im["path"]).is_file()
               for im in merged["images"])
    ids = {im["id"] for im in merged["images"]}
    assert all(an["image_id"] in ids for an in merged["annotations"])


def _real(tmp_path: Path, categories=None, files=("f1.jpg",)) -> tuple[Path, Path]:
    images = tmp_path / "frames"
    images.mkdir(exist_ok=True)
    for f in files:
        (images / f).write_bytes(b"x")
    coco = {"images": [{"id": 1, "file_name": "f1.jpg", "width": 64, "height": 64}],
            "annotations": [{"id": 1, "image_id": 1, "category_id": 5, "bbox": [1, 1, 9, 9]}],
            "categories": categories if categories is not None else
            [{"id": 5, "name": "BlueROV2"}]}
    path = tmp_path / "real.json"
    path.write_text(json.dumps(coco))
    return path, images


def test_real_test_set_maps_the_category_and_labels_itself(tmp_path):
    coco, images = _real(tmp_path)
    test = real_test(coco, images)
    assert test.category_id == 5 and test.kind == "real"
    assert test.label.startswith("real (real.json, 1 images")
    assert test.image_path(test.coco["images"][0]) == images / "f1.jpg"


def test_real_test_set_errors(tmp_path):
    with pytest.raises(UserError, match="--test-coco .*no such file"):
        real_test(tmp_path / "none.json", tmp_path)
    (tmp_path / "bad.json").write_text("{not json")
    with pytest.raises(UserError, match="not a readable JSON"):
        real_test(tmp_path / "bad.json", tmp_path)
    (tmp_path / "list.json").write_text("[]")
    with pytest.raises(UserError, match="not a COCO file"):
        real_test(tmp_path / "list.json", tmp_path)
    coco, images = _real(tmp_path, categories=[{"id": 5, "name": "boat"}])
    with pytest.raises(UserError, match="no category named 'bluerov2' .found: boat"):
        real_test(coco, images)
    (tmp_path / "other").mkdir()
    coco, images = _real(tmp_path / "other", files=())
    with pytest.raises(UserError, match="'f1.jpg' of --test-coco is missing"):
        real_test(coco, images)
    with pytest.raises(UserError, match="--test-images .*no such folder"):
        real_test(coco, tmp_path / "nowhere")
