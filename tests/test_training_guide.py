"""The training guide's worked examples (docs/training.md): the torchvision training block
runs (with fewer steps), the data.yaml shown is the one the generator writes, the
CocoDetection and supervision blocks read a generated folder."""

from __future__ import annotations

import contextlib
import io
import json
import re
from pathlib import Path

import pytest
import torch
import yaml

from sdcomp.io import yolo
from sdcomp.scene.config import GeneratorConfig

from .datasets import cli

GUIDE = Path(__file__).resolve().parents[1] / "docs" / "training.md"


def block_after(marker: str, lang: str) -> str:
    text = GUIDE.read_text()
    at = text.index(marker)
    m = re.compile(rf"```{lang}\n(.*?)```", re.S).search(text, at)
    assert m, f"no ```{lang} block after {marker!r}"
    return m.group(1)


def test_torchvision_example_trains(sprites_dir):
    code = block_after("<!-- tested: tests/test_training_guide.py -->", "python")
    for old, new in (("range(2000)", "range(3)"),
                     ('sprites_dir="sprites"', f'sprites_dir="{sprites_dir}"')):
        assert code.count(old) == 1, old
        code = code.replace(old, new)
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        exec(compile(code, "docs/training.md", "exec"), {"__name__": "readme_example"})
    lines = out.getvalue().splitlines()
    assert len(lines) == 1 and lines[0].startswith("step 0: loss ")
    assert float(lines[0].split()[-1]) > 0


def test_readme_data_yaml_is_what_we_write():
    shown = yaml.safe_load(block_after("`rov/data.yaml` as written:", "yaml"))
    written = yaml.safe_load(yolo.data_yaml(GeneratorConfig().categories))
    assert shown == written


@pytest.fixture(scope="module")
def rov(tmp_path_factory, sprites_dir) -> Path:
    """A small "rov" folder as the guide's snippets expect, with images without objects."""
    root = tmp_path_factory.mktemp("readme")
    rc, _, err = cli(["--n", "12", "--size", "160", "--count", "0-1", "--clutter", "0",
                      "--val-fraction", "0.5",
                      "--format", "coco,yolo", "--yolo-seg", "--seed", "2", "--workers", "1",
                      "--no-progress", "--out", root / "rov", "--sprites", sprites_dir])
    assert rc == 0, err
    return root


def test_coco_detection_example_trains_on_empty_images(rov, monkeypatch, one_torch_thread):
    """torchvision's CocoDetection wrapped for v2, with fill_empty_target: a Faster R-CNN
    step on a batch of images without objects (KeyError: 'boxes' without the guard)."""
    coco = json.loads((rov / "rov/annotations/instances_train.json").read_text())
    assert any(not [a for a in coco["annotations"] if a["image_id"] == im["id"]]
               for im in coco["images"])
    code = block_after("<!-- tested: tests/test_training_guide.py CocoDetection -->", "python")
    monkeypatch.chdir(rov)
    scope: dict = {"__name__": "readme_example"}
    exec(compile(code, "docs/training.md", "exec"), scope)
    loss = scope["loss"].detach()
    assert torch.isfinite(loss) and float(loss) > 0
    assert all(t["boxes"].dtype == torch.float32 for t in scope["targets"])
    # the guard is what makes it work: without it an empty image's target has no boxes
    bare = code.replace(", fill_empty_target])", "])")
    assert bare != code
    scope = {"__name__": "readme_example"}
    with pytest.raises(KeyError, match="boxes"):
        torch.manual_seed(0)
        exec(compile(bare.replace("shuffle=True", "shuffle=False"), "docs/training.md", "exec"),
             scope)


def test_supervision_example(rov, monkeypatch):
    code = block_after("<!-- tested: tests/test_training_guide.py supervision -->", "python")
    monkeypatch.chdir(rov)
    scope: dict = {"__name__": "readme_example"}
    exec(compile(code, "docs/training.md", "exec"), scope)
    n_val = len(list((rov / "rov/images/val").iterdir()))
    assert n_val and len(scope["val"]) == len(scope["val_coco"]) == n_val
