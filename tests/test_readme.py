"""The README's worked examples: the torchvision training block runs (with fewer steps),
the data.yaml shown is the one the generator writes."""

from __future__ import annotations

import contextlib
import io
import re
from pathlib import Path

import yaml

from sdcomp.io import yolo
from sdcomp.scene.config import GeneratorConfig

README = Path(__file__).resolve().parents[1] / "README.md"


def block_after(marker: str, lang: str) -> str:
    text = README.read_text()
    at = text.index(marker)
    m = re.compile(rf"```{lang}\n(.*?)```", re.S).search(text, at)
    assert m, f"no ```{lang} block after {marker!r}"
    return m.group(1)


def test_torchvision_example_trains(sprites_dir):
    code = block_after("<!-- tested: tests/test_readme.py -->", "python")
    for old, new in (("range(2000)", "range(3)"),
                     ('sprites_dir="sprites"', f'sprites_dir="{sprites_dir}"')):
        assert code.count(old) == 1, old
        code = code.replace(old, new)
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        exec(compile(code, "README.md", "exec"), {"__name__": "readme_example"})
    lines = out.getvalue().splitlines()
    assert len(lines) == 1 and lines[0].startswith("step 0: loss ")
    assert float(lines[0].split()[-1]) > 0


def test_readme_data_yaml_is_what_we_write():
    shown = yaml.safe_load(block_after("`rov/data.yaml` as written:", "yaml"))
    written = yaml.safe_load(yolo.data_yaml(GeneratorConfig().categories))
    assert shown == written
