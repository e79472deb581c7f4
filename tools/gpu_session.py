"""One GPU lease's worth of benchmark runs, as many at once as the card takes, within a
deadline: the paper's grid cells at paper scale and the fit experiment of docs/fit.md.

A single Faster R-CNN training at 2 images of 416 px keeps a big GPU mostly idle (the time
goes to kernel launches and Python), so several trainings share the card: the grid's cells
and the X101 sim2real runs in one pool (``--big-jobs`` at a time, in the order given), the
MobileNetV3 sim2real runs of the fit experiment in another (``--small-jobs``). Every run gets
the time left to the deadline; what has not finished by then is stopped and left out, what
has is kept, and a stopped training leaves its checkpoint: the same command again on the
same (warm) machine continues it. Before the pools: the cells' datasets (``bench grid
--datasets-only``, so that parallel ``train`` runs find them made) and each fit pair's two
training sets.

    python3 tools/gpu_session.py RESULTS --sprites DIR --deadline 520 \\
        --cells alt10-brown-n626 alt30-brown-n626 --pairs PAIRS --pair-seeds 7:11 8:12

``PAIRS/p{S}/`` holds what ``tools/fit_sim2real.py`` made on a CPU for stand-in seed S:
``footage/`` (the tinted frames and ``labels.json``) and ``fitted.toml``. Writes under
RESULTS: ``grid/`` (cells, report), ``fit/p{S}/s2r_*`` (sim2real.json each), ``log/`` and
``summary.json`` (every run: command, exit status, seconds).

Measured on one H200 (2026-11-28, 16 cores): five X101 trainings and four MobileNetV3 ones at
once kept the GPU 97-100 % busy: the X101 trainings ran at 2.9 iterations/s each, and at
4.3 each with five X101 alone (21 together, about twice one cell alone on an H100, 10); the
MobileNetV3 sim2real runs took 170 s of training each. That was too many at once for a
520 s deadline: only four MobileNetV3 runs ended in it; three cells and the two X101 sim2real
runs ended in a second, 235 s call that resumed them. Plan on 1500 / 4.3 = 350 s for each
wave of five X101 cells run alone, and the small runs after them, not beside them.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import threading
import time
from pathlib import Path

from fit_sim2real import train_geometry  # this folder: the same training sets as the CPU's

SDCOMP = [sys.executable, "-m", "sdcomp"]
MOBILENET = ["--backbone", "mobilenet_v3-fpn", "--weights", "none", "--optimizer", "sgd",
             "--lr", "0.01", "--max-iter", "400", "--batch-size", "4", "--threads", "1"]
X101 = ["--backbone", "resnext101_32x8d-fpn", "--weights", "none", "--threads", "2",
        "--checkpoint-every", "500"]  # the paper's schedule otherwise


class Session:
    """Runs commands before a deadline and records how each ended."""

    def __init__(self, results: Path, deadline_s: float) -> None:
        self.results, self.end = results, time.monotonic() + deadline_s
        self.records: list[dict] = []
        self.lock = threading.Lock()
        (results / "log").mkdir(parents=True, exist_ok=True)

    def left(self) -> float:
        return self.end - time.monotonic()

    def run(self, name: str, cmd: list[str]) -> int:
        """Run ``cmd`` (its output to log/NAME.log) until it ends or the deadline; -9 when
        stopped by the deadline, -1 when there was no time to start it."""
        t0 = time.monotonic()
        if self.left() < 5:
            rc = -1
        else:
            with open(self.results / "log" / f"{name}.log", "w") as log:
                p = subprocess.Popen(cmd, stdout=log, stderr=subprocess.STDOUT)
                try:
                    rc = p.wait(timeout=max(self.left(), 1))
                except subprocess.TimeoutExpired:
                    p.kill()
                    p.wait()
                    rc = -9
        with self.lock:
            self.records.append({"name": name, "rc": rc, "seconds": round(time.monotonic()
                                                                           - t0, 1),
                                 "cmd": cmd})
            self.save()
        print(f"[{time.strftime('%H:%M:%S')}] {name}: rc {rc}, "
              f"{time.monotonic() - t0:.0f} s", flush=True)
        return rc

    def pool(self, jobs: list[tuple[str, list[str]]], width: int) -> list[threading.Thread]:
        """Run ``jobs`` in order, ``width`` at a time, in the background; returns the
        pool's threads (joined, it is done)."""
        queue = list(jobs)

        def worker() -> None:
            while True:
                with self.lock:
                    if not queue:
                        return
                    name, cmd = queue.pop(0)
                self.run(name, cmd)

        threads = [threading.Thread(target=worker) for _ in range(width)]
        for t in threads:
            t.start()
        return threads

    def save(self) -> None:
        (self.results / "summary.json").write_text(json.dumps(self.records, indent=1))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("results", type=Path)
    ap.add_argument("--sprites", required=True)
    ap.add_argument("--deadline", type=float, default=520.0, help="seconds from the start")
    ap.add_argument("--cells", nargs="*", default=[],
                    help="paper grid cells of Tables 1-2 (their datasets are made first), "
                    "in order")
    ap.add_argument("--pairs", type=Path, help="folder of p{S}/footage and p{S}/fitted.toml")
    ap.add_argument("--pair-seeds", nargs="*", default=[],
                    help="STANDIN:TRAIN seed pairs of the fit experiment")
    ap.add_argument("--train-seeds", nargs="*", type=int, default=[0],
                    help="detector seeds per arm (MobileNetV3)")
    ap.add_argument("--x101-pairs", nargs="*", default=[],
                    help="stand-in seeds whose two arms also train X101 (big pool, first)")
    ap.add_argument("--big-jobs", type=int, default=5)
    ap.add_argument("--small-jobs", type=int, default=3)
    ap.add_argument("--workers", type=int, default=14)
    ap.add_argument("--device", default="cuda")
    ap.add_argument("--max-iter", type=int, help="every training's iterations (a dry run)")
    ap.add_argument("--size-scale", type=float, help="the grid's image counts x F (a dry run)")
    a = ap.parse_args()
    iters = ["--max-iter", str(a.max_iter)] if a.max_iter else []
    scale = ["--size-scale", str(a.size_scale)] if a.size_scale else []
    r: Path = a.results
    s = Session(r, a.deadline)
    common = ["--sprites", a.sprites, "--device", a.device, "--no-progress"]
    grid = ["--preset", "paper", "--out", str(r / "grid"), "--cache", str(r / "cache"),
            *common]
    for table in ("paper-table1", "paper-table2") if a.cells else ():
        s.run(f"datasets-{table}", [*SDCOMP, "bench", "grid", "--datasets-only", "--preset",
                                    table, "--out", str(r / "grid"), "--cache",
                                    str(r / "cache"), "--sprites", a.sprites, "--workers",
                                    str(a.workers), "--device", "cpu", "--no-progress",
                                    *scale])
    pairs = [tuple(int(x) for x in p.split(":")) for p in a.pair_seeds]
    for standin, train_seed in pairs:
        w = r / "fit" / f"p{standin}"
        gen = [*SDCOMP, "generate", *train_geometry(), "--seed", str(train_seed),
               "--sprites", a.sprites, "--workers", str(a.workers), "--no-progress", "-q"]
        config = ["--config", str(a.pairs / f"p{standin}" / "fitted.toml")]
        for arm, extra in (("defaults", []), ("fitted", config)):
            if not (w / arm / "dataset.json").exists():  # made by an earlier call
                s.run(f"gen-p{standin}-{arm}", [*gen, *extra, "--out", str(w / arm)])

    def s2r(standin: int, arm: str, tag: str, detector: list[str]) -> tuple[str, list[str]]:
        w, p = r / "fit" / f"p{standin}", a.pairs / f"p{standin}"
        return (f"s2r-p{standin}-{arm}-{tag}",
                [*SDCOMP, "bench", "sim2real", "--train", str(w / arm), "--real",
                 str(p / "footage"), "--real-labels", str(p / "footage" / "labels.json"),
                 "--out", str(w / f"s2r_{arm}_{tag}"), "--device", a.device, "--no-progress",
                 *detector, *iters])

    big = [s2r(int(p), arm, "x101", X101) for p in a.x101_pairs for arm in ("defaults",
                                                                           "fitted")]
    big += [(f"cell-{c}", [*SDCOMP, "bench", "train", "--cell", c, *grid, *X101, *iters, *scale])
            for c in a.cells]
    small = [s2r(standin, arm, f"mnv3-seed{seed}", [*MOBILENET, "--train-seed", str(seed)])
             for seed in a.train_seeds for standin, _ in pairs for arm in ("defaults",
                                                                             "fitted")]
    for t in s.pool(big, a.big_jobs) + s.pool(small, a.small_jobs):
        t.join()
    if a.cells:
        s.run("report", [*SDCOMP, "bench", "report", str(r / "grid")])
    print(f"done, {s.left():.0f} s before the deadline", flush=True)


if __name__ == "__main__":
    main()
