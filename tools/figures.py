"""Measure sdcomp's headline figures and write them to docs/figures.md.

    python tools/figures.py [--images 40] [--sprites DIR] [--out docs/figures.md] [--dry-run]

The rows marked ``measured`` are timed here, on this machine (one process unless the row
says otherwise); the other rows of the existing table are carried over as they are. Pages
quote a row as ``[64 images/s](figures.md#gen-416-ips)``, and tests/test_docs.py checks
every quote against the table within the row's tolerance: after measuring, fix the quotes
the test names.
"""

from __future__ import annotations

import argparse
import os
import platform
import re
import sys
import time
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

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
    if not path.exists():
        return {}
    return {m.group(1): Figure(m.group(1), m.group(2), float(m.group(3)), m.group(4),
                               float(m.group(5)), m.group(6))
            for m in ROW.finditer(path.read_text())}


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
    p.add_argument("--images", type=int, default=40, help="images timed per 416 px figure")
    p.add_argument("--sprites", default=None, help="sprite atlas folder (default: the cache)")
    p.add_argument("--out", default=str(ROOT / "docs" / "figures.md"))
    p.add_argument("--dry-run", action="store_true", help="print the table, write nothing")
    args = p.parse_args()
    out = Path(args.out)
    if (warning := busy()) is not None:
        print(f"warning: {warning}", file=sys.stderr)
    figures = read_table(out)
    for f in measure(args.images, sprites_folder(args.sprites)):
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
