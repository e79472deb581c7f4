"""The package reads as its data flow: a stage imports only earlier stages, nothing imports
another module's private name, modules stay short, and ruff and mypy are clean."""

from __future__ import annotations

import ast
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "sdcomp"
#: the stages in data-flow order; a module may import its own stage or an earlier one
STAGES = ("util", "assets", "atlas", "scene", "render", "annotate", "io", "run", "cli")
#: beside the flow: what each may import (besides util and errors)
BESIDE = {"pipeline": "annotate", "clips": "annotate", "torch_clips": "run",
          "report": "io", "torch_datasets": "run", "torch_real": "run", "bench": "cli",
          "fitting": "io"}
MAX_LINES = 400


def _modules() -> list[tuple[str, Path]]:
    out = []
    for path in sorted(PACKAGE.rglob("*.py")):
        parts = path.relative_to(ROOT).with_suffix("").parts
        name = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
        out.append((name, path))
    return out


def _imports(name: str, path: Path) -> list[tuple[str, list[str]]]:
    """(imported module, names imported from it) of every sdcomp import in the module,
    relative imports resolved."""
    package = name if path.name == "__init__.py" else name.rsplit(".", 1)[0]
    out = []
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[: len(package.split(".")) - node.level + 1]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            if target.startswith("sdcomp"):
                out.append((target, [a.name for a in node.names]))
        elif isinstance(node, ast.Import):
            out += [(a.name, []) for a in node.names if a.name.startswith("sdcomp")]
    return out


def _stage(module: str) -> str | None:
    """The stage (or beside-the-flow room) a module belongs to."""
    parts = module.split(".")
    if len(parts) < 2:
        return None
    return parts[1] if parts[1] in STAGES or parts[1] in BESIDE else None


def _rank(stage: str) -> int:
    return STAGES.index(BESIDE.get(stage, stage)) + (1 if stage in BESIDE else 0)


def test_stages_import_only_earlier_stages():
    bad = []
    for name, path in _modules():
        mine = _stage(name)
        if mine is None or name.endswith("__main__"):  # entry points run the command line
            continue
        for target, _ in _imports(name, path):
            theirs = _stage(target)
            if theirs is None or theirs == mine or theirs == "util":
                continue
            if _rank(theirs) > _rank(mine):
                bad.append(f"{name} imports {target} (stage {theirs} comes after {mine})")
    assert not bad, "\n".join(bad)


def test_nothing_imports_another_modules_private_name():
    bad = [f"{name} imports {n} from {target}" for name, path in _modules()
           for target, names in _imports(name, path) for n in names
           if n.startswith("_") and not n.startswith("__")]
    assert not bad, "\n".join(bad)


def test_modules_are_short():
    long = [f"{path.relative_to(ROOT)}: {n} lines" for _, path in _modules()
            if (n := len(path.read_text().splitlines())) > MAX_LINES]
    assert not long, "\n".join(long)


@pytest.mark.parametrize("tool,args", [("ruff", ["check", "sdcomp", "tests", "benchmarks"]),
                                       ("mypy", [])])
def test_linters_are_clean(tool, args):
    """ruff (style, complexity) and mypy (optional misuse, untyped defs: setup.cfg) pass."""
    exe = shutil.which(tool, path=str(Path(sys.executable).parent)) or shutil.which(tool)
    if exe is None:
        pytest.skip(f"{tool} is not installed (pip install -e '.[dev]' installs it)")
    proc = subprocess.run([exe, *args], cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stdout[-4000:] + proc.stderr[-2000:]


def test_a_new_engine_is_one_entry_for_stills_and_video(monkeypatch, tmp_path):
    """``--engine`` of generate and video come from one registry each, with the same
    names; an engine registered in both is what the commands run (no branch on a name)."""
    from sdcomp.cli.generate import main as generate_main
    from sdcomp.cli.video import main as video_main
    from sdcomp.run import engines

    assert set(engines.VIDEO_ENGINES) == set(engines.ENGINES)
    calls: list[str] = []

    def toy(kind):
        def run(config, options, scheduler=None):
            calls.append(kind)
            return dict.fromkeys(("images", "train", "val", "annotations", "objects_truncated",
                                  "objects_ignored", "objects_skipped", "objects_dropped",
                                  "sequences", "frames", "tracks"), 0)
        return run

    monkeypatch.setitem(engines.ENGINES, "toy", toy("stills"))
    monkeypatch.setitem(engines.VIDEO_ENGINES, "toy", toy("video"))
    video_main(["--engine", "toy", "--sequences", "1", "--frames", "2", "-q",
                "--out", str(tmp_path / "v")])
    assert calls == ["video"]
    assert generate_main(["--engine", "toy", "--n", "1", "-q", "--out",
                          str(tmp_path / "g")]) == 0
    assert calls == ["video", "stills"]
