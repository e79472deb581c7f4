"""Measure sdcomp's headline figures and write them to docs/figures.md.

    pytest benchmarks --benchmark-json bench.json
    python tools/figures.py [--benchmarks bench.json ...] [--images 200] [--sprites DIR]
                            [--out docs/figures.md] [--dry-run]

The rows marked ``measured`` are timed here, on this machine (one process unless the row
says otherwise; the per-stage costs on one OpenCV thread, as a run's worker renders, by
tools/profile_stages.py); the rows marked ``benchmark`` are read from a pytest-benchmark
JSON file (:data:`BENCH_ROWS`: the benchmarks' ``extra_info``) when one is given; the other
rows of the existing table are carried over as they are. Pages quote a row as
``[64 images/s](figures.md#gen-416-ips)``, and tests/test_docs.py checks every quote against
the table within the row's tolerance: after measuring, fix the quotes the test names.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import re
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import cv2

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tools"))

from profile_stages import profile  # noqa: E402

from sdcomp import Generator, GeneratorConfig  # noqa: E402
from sdcomp.assets import bluerov2  # noqa: E402
from sdcomp.atlas import build_atlas  # noqa: E402
from sdcomp.atlas.builtin import object_atlas  # noqa: E402
from sdcomp.atlas.cache import sprites_folder  # noqa: E402

HEADER = """# Figures

The headline figures, in one place. `python tools/figures.py` measures the rows marked
*measured* on the machine it runs on and rewrites this table (the others it carries over:
they take too long to measure each time). Pages quote a figure as a link,
`[64 images/s](figures.md#gen-416-ips)`; `tests/test_docs.py` fails when a quoted number (or
either end of a quoted range) differs from the value here by more than the row's tolerance.
"""
ROW = re.compile(r'^\| <a id="([\w-]+)"></a>`[\w-]+` \| (.+?) \| ([\d.]+) \| (.+?) \| '
                 r"([\d.]+) % \| (.+?) \|$", re.M)


@dataclass
class Figure:
    """One row of the table."""

    key: str
    what: str
    value: float
    unit: str
    tolerance: float  # percent
    source: str

    def row(self) -> str:
        value = f"{self.value:.3g}" if self.value < 100 else f"{self.value:.0f}"
        return (f'| <a id="{self.key}"></a>`{self.key}` | {self.what} | {value} | '
                f"{self.unit} | {self.tolerance:g} % | {self.source} |")


def read_table(path: Path) -> dict[str, Figure]:
    """The rows of an existing figures page (empty when there is none)."""
    return read_table_text(path.read_text()) if path.exists() else {}


def read_table_text(text: str) -> dict[str, Figure]:
    """The rows of a figures page's text, by key."""
    return {m.group(1): Figure(m.group(1), m.group(2), float(m.group(3)), m.group(4),
                               float(m.group(5)), m.group(6))
            for m in ROW.finditer(text)}


def ms_per_image(config: GeneratorConfig, sprites: Path, n: int) -> float:
    """Milliseconds an image of ``config`` takes in memory, one process (after a warm-up)."""
    gen = Generator(config, sprites, progress=False)
    gen.warm()
    gen.render(0)
    start = time.perf_counter()
    for i in range(1, n + 1):
        gen.render(i)
    return (time.perf_counter() - start) / n * 1000


def atlas_seconds() -> float:
    """Seconds to build the BlueROV2's atlas with 2 processes (not saved)."""
    mesh = bluerov2.build()
    start = time.perf_counter()
    build_atlas(mesh, object_atlas(mesh, None), workers=2, progress=False)
    return time.perf_counter() - start


def measure(n: int, sprites: Path) -> list[Figure]:
    """The measured rows."""
    base = {"seed": 0, "width": 416, "height": 416}
    ms = ms_per_image(GeneratorConfig.from_mapping(base), sprites, n)
    clean = ms_per_image(GeneratorConfig.from_mapping(
        {**base, "look": "clean", "glitter": False}), sprites, n)
    hd = ms_per_image(GeneratorConfig.from_mapping(
        {"seed": 0, "camera": "mavic2pro-video", "width": 1920, "height": 1080}), sprites,
        max(2, n // 10))
    return [
        Figure("gen-416-ms", "generator in memory, 416x416, defaults, one process: time an "
               "image", ms, "ms", 40, "measured"),
        Figure("gen-416-ips", "the same, images per second", 1000 / ms, "images/s", 40,
               "measured"),
        Figure("gen-416-clean-ms", "the same with `--look clean --no-glitter`", clean, "ms",
               40, "measured"),
        Figure("gen-1080-ms", "generator in memory, 1920x1080 (`mavic2pro-video`), "
               "defaults, one process: time an image", hd, "ms", 50, "measured"),
        Figure("atlas-bluerov2-s", "build the BlueROV2 atlas (188 poses), 2 processes",
               atlas_seconds(), "s", 50, "measured"),
    ]


@dataclass(frozen=True)
class BenchRow:
    """A figure read from ``pytest benchmarks --benchmark-json FILE``: ``extra_info[field]``
    of the benchmark named ``test`` (its parameter ids included, as pytest names it)."""

    key: str
    test: str
    field: str
    what: str
    unit: str
    tolerance: float


BENCH_ROWS = (
    BenchRow("disk-416-ips", "test_bench_disk_416_two_workers", "images_per_s",
             "`sdcomp generate` to disk, 416x416 JPEG + masks + COCO, 2 workers (1000 "
             "images)", "images/s", 50),
    BenchRow("disk-1080-ips", "test_bench_disk_1080_two_workers[default]", "images_per_s",
             "`sdcomp generate` to disk, 1920x1080 JPEG + masks + COCO, 2 workers (40 "
             "images)", "images/s", 50),
    BenchRow("disk-1080-fast-ips",
             "test_bench_disk_1080_two_workers[camera-off-compression-no-glitter]",
             "images_per_s", "the same with `--camera-off compression --no-glitter`",
             "images/s", 50),
    BenchRow("disk-20mp-ips", "test_bench_disk_full_resolution", "images_per_s",
             "`sdcomp generate` to disk, 5472x3648 JPEG + masks + COCO, 2 workers (12 "
             "images)", "images/s", 50),
    BenchRow("loader-416-ips", "test_bench_dataloader_416_two_workers[float32]",
             "images_per_s", "`SyntheticDetection` through a 2-worker DataLoader, 416x416, "
             "float CHW images and masks", "images/s", 50),
    BenchRow("loader-416-uint8-ips", "test_bench_dataloader_416_two_workers[uint8]",
             "images_per_s", "the same with `image_dtype=torch.uint8`", "images/s", 50),
    BenchRow("video-416-fps", "test_bench_video_to_disk[416]", "video_frames_per_s",
             "`sdcomp video` to disk, 416x416, 2 workers (4 sequences of 30 frames)",
             "frames/s", 50),
    BenchRow("video-416-still-ratio", "test_bench_video_to_disk[416]",
             "video_over_still", "the same, frames a second over stills a second (1: a "
             "frame costs a still)", "x", 25),
    BenchRow("huge-frame-s", "test_bench_huge_frame", "seconds", "one 30000x30000 frame "
             "with mask and COCO (limit 120 s)", "s", 50),
)


def from_benchmarks(path: Path) -> list[Figure]:
    """The :data:`BENCH_ROWS` found in a pytest-benchmark JSON file (those it lacks are
    left out: a run of some of the benchmarks updates only their rows)."""
    data = json.loads(path.read_text())
    runs = {b["name"]: b for b in data.get("benchmarks", [])}
    day = str(data.get("datetime", ""))[:10]
    out = []
    for row in BENCH_ROWS:
        found = runs.get(row.test, {}).get("extra_info", {}).get(row.field)
        if found is not None:
            out.append(Figure(row.key, row.what, float(found), row.unit, row.tolerance,
                              f"benchmark: `{row.test}` ({day})"))
    return out


#: per-stage rows: (key part, what, steps summed: a profile step name, or a prefix ending
#: in ':' for all the steps that start with it)
STAGE_ROWS = (
    ("water", "the water (view and draw)", ("water (view and draw)",)),
    ("glitter", "of it, the sun's glitter", ("  water: glitter",)),
    ("objects", "the objects' layers, foam, shadows and compositing", ("objects:",)),
    ("camera", "the camera (every stage, the labels' remap)", ("camera:",)),
    ("lens", "of it, the lens (remap, maps, labels)", ("camera: lens", "camera: lens_maps",
                                                     "camera: labels")),
    ("compression", "of it, the 4K recording's compression", ("camera: compression",)),
)


def _step_in(step: str, names: tuple[str, ...]) -> bool:
    """Whether a profile step is one of ``names`` (a name ending in ':' is a prefix)."""
    return any(step == m or (m.endswith(":") and step.startswith(m)) for m in names)


def stage_figures(sizes: tuple[tuple[int, int], ...], n: int, sprites: Path) -> list[Figure]:
    """Milliseconds an image per stage (:data:`STAGE_ROWS`) at each ``(w, h)`` of
    ``sizes``, default config, warm, on one OpenCV thread (tools/profile_stages.py)."""
    threads = cv2.getNumThreads()
    cv2.setNumThreads(1)
    out = []
    try:
        for w, h in sizes:
            steps, _ = profile(GeneratorConfig(width=w, height=h), n if w * h < 1e6
                               else max(2, n // 5), str(sprites))
            tag = "1080" if (w, h) == (1920, 1080) else f"{w}"
            whole = sum(v for k, v in steps.items() if not k.startswith("  "))
            parts = [("whole", "the whole image", whole)]
            parts += [(part, what, sum(v for k, v in steps.items() if _step_in(k, names)))
                      for part, what, names in STAGE_ROWS]
            out += [Figure(f"stage-{tag}-{part}-ms", f"{w}x{h}, one worker: {what}",
                           1000 * sec, "ms", 50, "measured: tools/profile_stages.py")
                    for part, what, sec in parts]
    finally:
        cv2.setNumThreads(threads)
    return out


def busy() -> str | None:
    """A warning when the machine is busy (other work makes every figure slower)."""
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else 0.0
    cpus = os.cpu_count() or 1
    if load > 0.5 * cpus:
        return f"the machine is busy (load {load:.1f} on {cpus} CPUs): figures will be slow"
    return None


def machine() -> str:
    """One line naming the machine and the date."""
    return (f"Measured on: {platform.machine()}, {os.cpu_count()} CPUs, "
            f"{platform.python_implementation()} {platform.python_version()}, "
            f"{time.strftime('%Y-%m-%d', time.gmtime())}. A shared machine's speed drifts "
            f"by up to a third.")


def page_text(figures: dict[str, Figure]) -> str:
    """The figures page of ``figures``."""
    lines = [HEADER, machine(), "", "| key | what | value | unit | tolerance | source |",
             "|---|---|---|---|---|---|", *(f.row() for f in figures.values())]
    return "\n".join(lines) + "\n"


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--images", type=int, default=200, help="images timed per 416 px figure")
    p.add_argument("--sprites", default=None, help="sprite atlas folder (default: the cache)")
    p.add_argument("--out", default=str(ROOT / "docs" / "figures.md"))
    p.add_argument("--dry-run", action="store_true", help="print the table, write nothing")
    p.add_argument("--benchmarks", nargs="+", default=[], metavar="JSON",
                   help="pytest-benchmark JSON files (pytest benchmarks --benchmark-json "
                   "FILE) to read the benchmarks' rows from (a later file's rows win)")
    p.add_argument("--no-measure", action="store_true",
                   help="only read --benchmarks; time nothing here")
    args = p.parse_args()
    out = Path(args.out)
    figures = read_table(out)
    found = [f for path in args.benchmarks for f in from_benchmarks(Path(path))]
    if not args.no_measure:
        if (warning := busy()) is not None:
            print(f"warning: {warning}", file=sys.stderr)
        sprites = sprites_folder(args.sprites)
        found += measure(args.images, sprites)
        found += stage_figures(((416, 416), (1920, 1080)), args.images, sprites)
    for f in found:
        figures[f.key] = f
    text = page_text(figures)
    if args.dry_run:
        print(text)
    else:
        out.write_text(text)
        print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
