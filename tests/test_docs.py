"""Every fenced command and Python block of README.md and docs/*.md runs, at tiny sizes.

Commands (``bash`` blocks) of ``sdcomp`` and ``python -m sdcomp.<job>`` run in this process
in a scratch folder per page (with a small ``dataset/`` in it), rewritten to a few images of
a few dozen pixels, one worker and the session's sprite atlases; Python blocks run there too.
What cannot run here is listed in :data:`NOT_RUN` and :data:`PY_NOT_RUN` with the reason;
blocks preceded by ``<!-- tested: FILE ... -->`` are run by that test file instead.

The figure check: a page quotes a figure of docs/figures.md as ``[N unit](figures.md#key)``;
the quoted number (each end of a range) must lie within the row's tolerance of its value.
"""

from __future__ import annotations

import importlib
import re
import shlex
import shutil
from pathlib import Path

import pytest

from sdcomp.cli import COMMANDS
from sdcomp.cli import main as sdcomp_main

from .datasets import cli

ROOT = Path(__file__).resolve().parents[1]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
FENCE = re.compile(r"^```(\w*)[ \t]*\n(.*?)^```[ \t]*$", re.S | re.M)
TESTED = re.compile(r"<!-- tested: (tests/\S+)[^>]*-->\s*$")

#: commands not run here: (regular expression searched in the command line, why)
NOT_RUN: list[tuple[str, str]] = [
    (r"pip install", "installs into a new virtual environment: .ci/run runs this line"),
    (r"^yolo ", "Ultralytics training downloads weights and takes minutes; "
               "tests/test_consumers.py trains one epoch on a generated folder"),
    (r"--backgrounds", "needs your own footage; tests/test_footage.py runs these flags on "
                       "generated frames and videos"),
    (r"--real ", "needs your real frames; tests/test_realism_report.py runs it on stand-ins"),
    (r"bench grid --preset (smoke|paper-table1 )", "trains 17 detectors (minutes); "
                                                  "tests/test_bench_smoke.py runs the smoke grid"),
    (r"--device cuda", "needs a GPU"),
    (r"bench train ", "trains a detector for 1500 iterations; tests/test_bench_train.py "
                      "trains one for a few"),
    (r"bench (eval|report) results/", "needs a trained results/ folder; "
                                      "tests/test_bench_cli.py runs both on one"),
    (r"bench sim2real", "a synopsis with your files; tests/test_bench_sim2real.py runs it"),
    (r"sdcomp fit my_site", "needs your footage; tests/test_fit.py fits generated stand-ins "
                            "with the same command"),
    (r"--config fitted\.toml", "reads what the fit line above writes; tests/test_fit.py "
                               "reads a fitted config through generate --config"),
    (r"\$SLURM|shards/\*", "a job-array script; tests/test_shards.py runs shards and merge"),
]
#: Python blocks not run here: (regular expression searched in the block, why)
PY_NOT_RUN: list[tuple[str, str]] = [
    (r"detectron2", "Detectron2 has no PyPI release (it installs from its source repository)"),
    (r"sdcomp.fit\(\"my_site", "needs your footage; tests/test_fit.py calls sdcomp.fit on "
                               "generated stand-ins"),
    (r"CocoDataset", "MMDetection needs mmcv's compiled operators from OpenMMLab's own index"),
    (r"apply_camera\(frame, labels", "an outline of the API, its arguments named, not made"),
    (r"view_water\(model, pose", "an outline of the API, its arguments named, not made"),
]
#: what a command's flags become: (flag, new value); flags not given are added
TINY = {"generate": [("--n", "3"), ("--width", "96"), ("--height", "64"), ("--workers", "1")],
        "video": [("--sequences", "1"), ("--frames", "3"), ("--width", "96"),
                  ("--height", "64"), ("--workers", "1")]}
#: flags dropped, with their value, before the tiny ones are added
DROP = {"--size", "--width", "--height", "--n", "--workers", "--sequences", "--frames"}


def blocks(page: Path) -> list[tuple[str, str, str | None]]:
    """The page's fenced blocks: (language, code, the test file named before it or None)."""
    text = page.read_text()
    found = []
    for m in FENCE.finditer(text):
        before = text[:m.start()].rstrip("\n").rsplit("\n", 1)[-1]
        tested = TESTED.search(before)
        found.append((m.group(1), m.group(2), tested.group(1) if tested else None))
    return found


def command_lines(code: str) -> list[str]:
    """The commands of a shell block: continuation lines joined, comments dropped."""
    lines = []
    for line in code.replace("\\\n", " ").splitlines():
        line = re.sub(r"(^|\s)#.*$", "", line).strip()
        if line:
            lines.append(line)
    return lines


def why_not_run(text: str, table: list[tuple[str, str]]) -> str | None:
    """The reason a command or block is not run, or None."""
    return next((why for pattern, why in table if re.search(pattern, text)), None)


def tiny(job: str, args: list[str], sprites: Path, here: Path) -> list[str]:
    """A command's arguments made small and pointed at the session's atlases."""
    out: list[str] = []
    it = iter(args)
    for a in it:
        if job in TINY and a in DROP:
            next(it, None)
            continue
        out.append(str(sprites / a[len("sprites/"):]) if a.startswith("sprites/") else a)
    for flag, value in TINY.get(job, []):
        out += [flag, value]
    if job in ("generate", "video"):
        out += ["--sprites", str(sprites), "--no-progress"]
        if "--out" not in out:
            out += ["--out", "out"]
        if (here / out[out.index("--out") + 1]).exists():
            out.append("--overwrite")
    if job == "atlas" and out[:1] == ["build"] and "--out" not in out:
        out += ["--out", str(sprites)]
    return out


def run_command(line: str, sprites: Path, here: Path) -> None:
    """Run one ``sdcomp ...`` or ``python -m sdcomp.<job> ...`` line in this process."""
    words = shlex.split(line)
    if words[0] == "sdcomp":
        job, args, entry = words[1], words[2:], sdcomp_main
        head = [job]
    elif words[:2] == ["python", "-m"] and words[2].startswith("sdcomp."):
        job, args, head = words[2].split(".", 1)[1], words[3:], []
        module, func = next(((m, f) for m, f, dash_m, _ in COMMANDS.values()
                             if dash_m == words[2]), (words[2], "main"))
        entry = getattr(importlib.import_module(module), func)
    else:
        raise AssertionError(f"not an sdcomp command and not in NOT_RUN: {line}")
    rc, _, err = cli([*head, *tiny(job, args, sprites, here)], entry)
    assert rc == 0, f"{line}\n{err[-2000:]}"


def run_python(code: str, sprites: Path) -> None:
    """Run a Python block with the session's atlases and no worker processes."""
    code = (code.replace('"sprites/', f'"{sprites}/').replace('sprites_dir="sprites"',
                                                                f'sprites_dir="{sprites}"')
            .replace("num_workers=2", "num_workers=0").replace("range(2000)", "range(2)"))
    exec(compile(code, "docs", "exec"), {"__name__": "docs_example"})


@pytest.fixture(scope="module")
def base(tmp_path_factory, sprites_dir) -> Path:
    """A scratch folder's starting contents: a small ``dataset/`` (COCO and YOLO, some
    images empty), a config file ``my.toml``, mesh files ``kayak.glb`` and ``boat.stl``."""
    import trimesh

    root = tmp_path_factory.mktemp("docs_base")
    rc, _, err = cli(["--n", "6", "--size", "96", "--altitude", "4-8", "--count", "0-2",
                      "--format", "coco,yolo", "--seed", "3", "--workers", "1",
                      "--no-progress", "--out", root / "dataset", "--sprites", sprites_dir])
    assert rc == 0, err
    (root / "my.toml").write_text('altitude = "5-20"\npitch = "60-90"\n')
    trimesh.creation.box(extents=(3.5, 0.8, 0.4)).export(root / "kayak.glb")
    trimesh.creation.box(extents=(4000, 1500, 600)).export(root / "boat.stl")
    return root


@pytest.mark.parametrize("page", PAGES, ids=lambda p: p.name)
def test_page_blocks_run(page, base, sprites_dir, tmp_path, monkeypatch, one_torch_thread):
    """Each command and Python block of the page runs (or is listed as not run, or named
    as tested elsewhere), in a scratch folder of its own."""
    here = tmp_path / "work"
    shutil.copytree(base, here, symlinks=True)
    monkeypatch.chdir(here)
    monkeypatch.setenv("SDCOMP_SPRITES", str(sprites_dir))
    monkeypatch.setenv("MPLBACKEND", "Agg")
    for lang, code, tested in blocks(page):
        if tested:
            assert (ROOT / tested).exists(), tested
        elif lang in ("bash", "sh", "shell"):
            for line in command_lines(code):
                if not why_not_run(line, NOT_RUN):
                    run_command(line, sprites_dir, here)
        elif lang == "python" and not why_not_run(code, PY_NOT_RUN):
            run_python(code, sprites_dir)


def test_not_run_lists_are_used():
    """Every entry of NOT_RUN and PY_NOT_RUN matches a block (no stale reasons)."""
    lines = [ln for p in PAGES for lang, code, _ in blocks(p) if lang in ("bash", "sh")
             for ln in command_lines(code)]
    codes = [code for p in PAGES for lang, code, _ in blocks(p) if lang == "python"]
    for pattern, why in NOT_RUN:
        assert any(re.search(pattern, ln) for ln in lines), (pattern, why)
    for pattern, why in PY_NOT_RUN:
        assert any(re.search(pattern, c) for c in codes), (pattern, why)


def test_example_config_parses():
    """docs/examples/*.toml are configs `sdcomp generate --config` accepts."""
    from sdcomp.cli.generate import build_parser, config_from_args

    examples = sorted((ROOT / "docs" / "examples").glob("*.toml"))
    assert examples
    for path in examples:
        config = config_from_args(build_parser().parse_args(["--config", str(path)]))
        assert config.objects, path


# --------------------------------------------------------------------------- figures

FIGURE_ROW = re.compile(r'^\| <a id="([\w-]+)"></a>`[\w-]+` \| [^|]+ \| ([\d.]+) \| [^|]+ \| '
                        r"([\d.]+) % \|", re.M)
QUOTE = re.compile(r"\[([^\]]*?)\]\((?:docs/)?figures\.md#([\w-]+)\)")
NUMBER = re.compile(r"\d+(?:\.\d+)?")


def figures() -> dict[str, tuple[float, float]]:
    """docs/figures.md's rows: key -> (value, tolerance as a fraction)."""
    text = (ROOT / "docs" / "figures.md").read_text()
    return {m.group(1): (float(m.group(2)), float(m.group(3)) / 100)
            for m in FIGURE_ROW.finditer(text)}


def test_figures_table_reads():
    table = figures()
    assert {"gen-416-ms", "gen-416-ips", "disk-1080-ips", "atlas-bluerov2-s"} <= set(table)


def test_quoted_figures_agree_with_the_table():
    """Every quoted figure names a row, and its numbers lie within the row's tolerance."""
    table = figures()
    quoted = 0
    for page in PAGES:
        for m in QUOTE.finditer(page.read_text()):
            text, key = m.groups()
            assert key in table, f"{page.name}: [{text}] names no figure {key!r}"
            value, tol = table[key]
            numbers = [float(n) for n in NUMBER.findall(text)]
            assert numbers, f"{page.name}: [{text}] quotes no number"
            for n in numbers:
                assert abs(n - value) <= tol * value, (
                    f"{page.name}: [{text}] differs from figures.md's {key} = {value} by "
                    f"more than {tol:.0%}")
            quoted += 1
    assert quoted >= 8


def test_figure_check_catches_a_wrong_number():
    """The check itself: a number off by more than the tolerance is caught."""
    value, tol = figures()["gen-416-ips"]
    wrong = value * (1 + 2 * tol)
    m = QUOTE.search(f"[{wrong:.0f} images/s](figures.md#gen-416-ips)")
    assert m and abs(float(NUMBER.findall(m.group(1))[0]) - value) > tol * value


# --------------------------------------------------------------------------- links

LINK = re.compile(r"\]\(([^)#\s]+\.(?:md|toml|jpg|png))(?:#[\w-]*)?\)")


def test_readme_is_a_page_and_links_every_docs_page():
    """README.md stays short and every page under docs/ is linked from it."""
    text = (ROOT / "README.md").read_text()
    assert len(text.splitlines()) <= 220
    linked = {(ROOT / target).resolve() for target in LINK.findall(text)}
    missing = [p.name for p in (ROOT / "docs").glob("*.md") if p.resolve() not in linked]
    assert not missing, f"docs pages not linked from README.md: {missing}"


def test_relative_links_name_existing_files():
    for page in PAGES:
        for target in LINK.findall(page.read_text()):
            if not target.startswith("http"):
                assert (page.parent / target).exists(), f"{page.name}: {target}"
