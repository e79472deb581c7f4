"""The kill campaign over every kind of run (its tests are in :mod:`tests.test_faults`).

A trial starts a run of one kind as its own process group (2 workers), sends SIGINT, SIGTERM
or SIGKILL at a random moment to its main process or the whole group, checks that nothing is
corrupt, resumes it with ``--resume`` in this process, and asserts that the result has the
bytes of the kind's uninterrupted run and passes ``sdcomp check``. The kinds:

- ``still``: still images of the default scene (``sdcomp generate``);
- ``video``: ``sdcomp video`` sequences (with YOLO labels);
- ``seadronessee``: ``sdcomp generate --preset seadronessee`` at 64x48 px, its objects one
  variant of each of its five kinds (``--config``; the full preset loads 62 sprite atlases,
  1.4 GB and 15 s before its first image on this 2-core machine, and builds them in minutes);
- ``backgrounds``: generated over a folder of photos (``--backgrounds``, with YOLO labels);
- ``shard``: one shard (shard ``k`` of 3, in turn) of a sharded run: killed, resumed,
  merged with the other, uninterrupted, shards (``sdcomp merge``) and compared with the
  merge of the uninterrupted shards.

Each kind's uninterrupted run is made once per test module (:class:`Kinds`), as a process
timed like the trials' runs: signals land within the time it took, a third of them from the
process's start (Python's start-up, atlases, textures), the others after its first write.
"""

from __future__ import annotations

import json
import os
import random
import shutil
import signal
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np
import pytest

from sdcomp.cli.generate import main as generate_main
from sdcomp.cli.merge import main as merge_main
from sdcomp.cli.video import main as video_main
from sdcomp.scene.presets import SEADRONESSEE
from sdcomp.scene.settings import toml_value
from sdcomp.util import files

from .datasets import (
    CLI,
    VIDEO_CLI,
    assert_identical,
    check_intact,
    check_video_intact,
    cli,
    finish,
    live_processes,
    popen,
    sdcomp_check,
    wait_until,
)

pytestmark = pytest.mark.filterwarnings("ignore:__array__ implementation:DeprecationWarning")

# small frames, many images: a kill lands in the middle of a run of 2 workers
BASE = ["--n", "120", "--size", "48", "--clutter", "0", "--altitude", "3-6", "--count", "0-2",
        "--seed", "11"]
VIDEO = ["--sequences", "6", "--frames", "8", "--fps", "10", "--size", "48", "--clutter", "0",
         "--altitude", "12-20", "--count", "1-3", "--seed", "3", "--format", "coco,yolo"]
SDS = ["--preset", "seadronessee", "--width", "64", "--height", "48", "--n", "60",
       "--seed", "4"]
SHARDS = 3
KINDS = ("still", "video", "seadronessee", "backgrounds", "shard")
SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGKILL)
WORKERS = 2


@dataclass
class Kind:
    """A kind of run: how it is started (``code`` with ``flags``), resumed (``entry``),
    checked, and what it must end as (``reference``)."""

    name: str
    code: str  # the killed process's program (python -c)
    entry: Callable  # the command's main, for the resume in this process
    flags: list
    sprites: Path
    meta: str = "dataset.json"
    reference: Path = Path()  # the uninterrupted run's folder (shards: their merge)
    begins: float = 0.0  # s from the uninterrupted run's start to its first write
    seconds: float = 0.0  # s the uninterrupted run took, start-up included
    shards: list[Path] = field(default_factory=list)  # shard: the uninterrupted shards

    def argv(self, out: Path, nth: int) -> list:
        """The command line of the kind's ``nth`` trial (shard: which shard) into ``out``."""
        shard = ["--shard", f"{nth % SHARDS}/{SHARDS}"] if self.name == "shard" else []
        return [*self.flags, *shard, "--out", out, "--sprites", self.sprites, "--workers",
                WORKERS, "--no-progress"]

    def check(self, out: Path, allow_tmp: bool = False) -> None:
        """Nothing in ``out`` is corrupt."""
        if self.meta == "video.json":
            check_video_intact(out, allow_tmp=allow_tmp)
        else:
            check_intact(out, allow_tmp=allow_tmp)

    def result(self, out: Path, nth: int) -> Path:
        """The finished dataset of trial ``nth`` whose run is ``out``: ``out`` itself, or
        for a shard the merge of ``out`` (its own shard's bytes) with the other shards."""
        if self.name != "shard":
            return out
        k = nth % SHARDS
        assert_identical(self.shards[k], out)
        merged = out.with_name(f"{out.name}-merged")
        parts = [out if j == k else s for j, s in enumerate(self.shards)]
        rc, _, err = cli([*parts, "--out", merged, "--no-progress"], entry=merge_main)
        assert rc == 0, err
        return merged

    def delay(self, rng: random.Random) -> float:
        """A random moment of a run (s from its start): a third anywhere in it, start-up
        included, the others after its first write."""
        longest = max(self.begins + 0.3, 0.85 * self.seconds)
        low = 0.2 if rng.random() < 1 / 3 else self.begins
        return rng.uniform(low, longest)


def timed_run(kind: Kind, out: Path, nth: int = 0) -> tuple[float, float]:
    """Run trial ``nth``'s command uninterrupted as a process; (s to its first write, s in
    all)."""
    start = time.perf_counter()
    proc = popen(kind.code, kind.argv(out, nth))
    wait_until(lambda: (out / kind.meta).exists() or proc.poll() is not None,
               "the run's first write", timeout=300)
    begins = time.perf_counter() - start
    rc, _, err = finish(proc, timeout=300)
    assert rc == 0, err
    return begins, time.perf_counter() - start


def warm_up(kind: Kind, out: Path) -> None:
    """A one-image (one-frame) run of ``kind`` in this process: builds the sprite atlases
    it needs, which its timed run must not include."""
    one = ["--sequences", "1", "--frames", "1"] if kind.meta == "video.json" else ["--n", "1"]
    rc, _, err = cli([*kind.flags, *one, "--out", out, "--sprites", kind.sprites,
                      "--workers", 1, "--no-progress"], entry=kind.entry)
    assert rc == 0, err
    shutil.rmtree(out)


def write_photos(folder: Path) -> Path:
    """A few small JPEG photos of green-blue water for ``--backgrounds``."""
    folder.mkdir(parents=True)
    rng = np.random.default_rng(0)
    for k, (h, w) in enumerate([(90, 160), (120, 100), (64, 64)]):
        yy, xx = np.mgrid[0:h, 0:w]
        img = np.zeros((h, w, 3), np.float32)
        img[..., 0] = 90 + 40 * xx / w + 10 * k  # B
        img[..., 1] = 70 + 30 * yy / h  # G
        img[..., 2] = 30
        img += rng.normal(0, 6, img.shape)
        cv2.imwrite(str(folder / f"sea{k}.jpg"), np.clip(img, 0, 255).astype(np.uint8))
    return folder


def sds_config(path: Path) -> Path:
    """A config file of the seadronessee preset's objects, one variant of each kind
    (``-00``: its own atlas), everything else as the preset has it."""
    objects = [{**o, "mesh": f"{o['mesh']}-00"} for o in SEADRONESSEE["objects"]]
    path.write_text(f"objects = {toml_value(objects)}\n")
    return path


def make_kind(name: str, root: Path, sprites: Path, warm: bool = True) -> Kind:
    """The kind ``name`` with its uninterrupted run made in ``root`` (after a
    :func:`warm_up` if ``warm``)."""
    root.mkdir(parents=True)
    if name == "video":
        kind = Kind(name, VIDEO_CLI, video_main, VIDEO, sprites, meta="video.json")
    elif name == "seadronessee":
        kind = Kind(name, CLI, generate_main, [*SDS, "--config", sds_config(root / "sds.toml")],
                    sprites)
    elif name == "backgrounds":
        kind = Kind(name, CLI, generate_main, [*BASE, "--backgrounds",
                                               write_photos(root / "photos"), "--format",
                                               "coco,yolo"], sprites)
    else:
        kind = Kind(name, CLI, generate_main, BASE, sprites)
    if warm:
        warm_up(kind, root / "warm")
    kind.reference = root / "reference"
    if name != "shard":
        kind.begins, kind.seconds = timed_run(kind, kind.reference)
        return kind
    kind.shards = [root / f"shard{k}" for k in range(SHARDS)]
    kind.begins, kind.seconds = timed_run(kind, kind.shards[1], 1)
    for k in (0, 2):
        rc, _, err = cli(kind.argv(kind.shards[k], k), entry=generate_main)
        assert rc == 0, err
    rc, _, err = cli([*kind.shards, "--out", kind.reference, "--no-progress"],
                     entry=merge_main)
    assert rc == 0, err
    return kind


class Kinds:
    """The kinds of run under ``root``, each made (its uninterrupted run) on first use; a
    warm-up run for the first kind of each set of sprite atlases (the seadronessee kind's,
    the default object's)."""

    def __init__(self, root: Path, sprites: Path):
        self.root, self.sprites = root, sprites
        self.made: dict[str, Kind] = {}
        self.warmed: set[bool] = set()
        self.seconds = 0.0  # spent making them (atlases built included)

    def __getitem__(self, name: str) -> Kind:
        if name not in self.made:
            start = time.perf_counter()
            atlases = name == "seadronessee"
            self.made[name] = make_kind(name, self.root / name, self.sprites,
                                        warm=atlases not in self.warmed)
            self.warmed.add(atlases)
            self.seconds += time.perf_counter() - start
        return self.made[name]


# --------------------------------------------------------------------------- one trial

def kill_trial(kind: Kind, out: Path, nth: int, sig: int, delay: float, group: bool) -> dict:
    """Start trial ``nth`` of ``kind``, send ``sig`` after ``delay`` s to its main process
    (or its whole process group, as a terminal's Ctrl-C or the OOM killer would), check
    what is left. Returns {"fault": whether the run was still going when the signal came,
    "began": whether it had written its first file by then}."""
    proc = popen(kind.code, kind.argv(out, nth))
    # not a wait for a condition: the signal lands at a random moment of the run on purpose
    time.sleep(delay)
    fault = proc.poll() is None
    began = (out / kind.meta).exists()
    if fault:
        try:
            (os.killpg if group else os.kill)(proc.pid, sig)
        except ProcessLookupError:
            fault = False
    rc, _, err = finish(proc, timeout=120)
    if sig == signal.SIGKILL and not group:
        # orphaned workers notice at their next image and stop
        wait_until(lambda: not live_processes(proc.pid),
                   lambda: f"the orphaned workers to stop (still running: "
                           f"{live_processes(proc.pid)})")
    meta = out / kind.meta
    if not fault:
        assert rc == 0, err
    elif meta.exists() and sig != signal.SIGKILL:
        # the run had begun (a signal during Python's start-up may show a traceback): it
        # stopped cleanly, an "interrupted" run, no temporary files, no traceback
        assert "Traceback" not in err, err
        if rc == 130:
            status = json.loads(meta.read_text())["status"]
            assert status == "interrupted", status
    kind.check(out, allow_tmp=sig == signal.SIGKILL or not fault)
    return {"fault": fault, "began": fault and began}


def resume_and_compare(kind: Kind, out: Path, nth: int) -> None:
    """Finish ``out`` with ``--resume``: intact, complete, the uninterrupted run's bytes,
    and ``sdcomp check`` passes."""
    rc, _, err = cli([*kind.argv(out, nth), "--resume"], entry=kind.entry)
    assert rc == 0, err
    kind.check(out)
    assert json.loads((out / kind.meta).read_text())["status"] == "complete"
    result = kind.result(out, nth)
    assert_identical(kind.reference, result)
    sdcomp_check(result)


# --------------------------------------------------------------------------- the campaign

def _count(table: dict, key: str, r: dict) -> None:
    row = table.setdefault(key, {"trials": 0, "faults": 0, "after_first_write": 0})
    row["trials"] += 1
    row["faults"] += r["fault"]
    row["after_first_write"] += r["began"]


def campaign(kinds: Kinds, tmp: Path, trials: int, seed: int,
             names: tuple[str, ...] = KINDS) -> dict:
    """``trials`` kill trials, the kinds ``names`` in turn and the signals in turn (so each
    kind meets each signal), random delays and targets, each resumed and compared; returns
    the figures. A trial that breaks anything fails the test at once."""
    rng = random.Random(seed)
    stats: dict = {"trials": 0, "faults": 0, "after_first_write": 0, "corrupted": 0,
                   "by_signal": {}, "by_kind": {}}
    for t in range(trials):
        sig = SIGNALS[t % len(SIGNALS)]
        kind = kinds[names[t % len(names)]]
        nth = t // len(names)  # the kind's own trial (a shard's: which shard)
        folder = tmp / f"trial{t}"
        delay = kind.delay(rng)
        group = rng.random() < 0.5
        name = signal.Signals(sig).name
        try:
            r = kill_trial(kind, folder / "run", nth, sig, delay, group)
            resume_and_compare(kind, folder / "run", nth)
        except AssertionError:
            stats["corrupted"] += 1
            print(f"trial {t} ({kind.name}): {name} after {delay:.2f} s "
                  f"({'group' if group else 'main process'}) broke the run")
            raise
        stats["trials"] += 1
        stats["faults"] += r["fault"]
        stats["after_first_write"] += r["began"]
        _count(stats["by_signal"], name, r)
        _count(stats["by_kind"], kind.name, r)
        shutil.rmtree(folder)
    return stats


def figures(stats: dict, seconds: float, setup: float) -> str:
    """The campaign's figures as a few lines (``setup``: s of ``seconds`` spent making the
    kinds' uninterrupted runs)."""
    def rows(table: dict) -> str:
        return "; ".join(f"{k} {v['trials']} trials, {v['faults']} faults "
                         f"({v['after_first_write']} after the first write)"
                         for k, v in table.items())

    return (f"kill campaign: {stats['trials']} trials in {seconds:.0f} s ({setup:.0f} s of "
            f"it making the uninterrupted runs), {stats['faults']} "
            f"faults ({stats['after_first_write']} after the run's first write), "
            f"{stats['corrupted']} corrupted\n  by signal: {rows(stats['by_signal'])}\n"
            f"  by kind: {rows(stats['by_kind'])}")


# --------------------------------------------------------------------------- bugs found

def test_video_resume_removes_the_temporary_files_of_a_killed_write(tmp_path, sprites_dir):
    """SIGKILL while a video run writes video.json, data.yaml or its COCO-video file leaves
    that write's temporary file (``.NAME.*.tmp``); ``--resume`` removes it (it kept them, so
    the resumed folder was not the uninterrupted run's), as a still run's does."""
    small = [*VIDEO, "--sequences", "1", "--frames", "2", "--size", "32"]
    argv = [*small, "--sprites", sprites_dir, "--workers", 1, "--no-progress"]
    plain, killed = tmp_path / "plain", tmp_path / "killed"
    assert cli([*argv, "--out", plain], entry=video_main)[0] == 0
    shutil.copytree(plain, killed, symlinks=True)
    for name in ("video.json", "data.yaml", "annotations/instances_video.json"):
        path = killed / name
        path.with_name(f".{path.name}.k9x2.tmp").write_bytes(b'{"format": "sdc')
    rc, _, err = cli([*argv, "--out", killed, "--resume"], entry=video_main)
    assert rc == 0, err
    check_video_intact(killed)
    assert_identical(plain, killed)


def test_a_stopped_video_run_leaves_no_half_written_frame(tmp_path, sprites_dir, monkeypatch):
    """Found by the campaign (SIGTERM to a video run's process group): the workers end at
    SIGTERM, mid-write, and the stopped run kept their temporary frame files (a still run
    sweeps them). Here a frame's writer stops mid-write as such a worker does."""
    real = files.write_file

    def stopped(path, data):
        if path.name == "000002.jpg":
            path.with_name(f".{path.name}.{os.getpid()}.tmp").write_bytes(data[:100])
            raise KeyboardInterrupt  # its process ends: nothing removes the file
        return real(path, data)

    monkeypatch.setattr(files, "write_file", stopped)
    out = tmp_path / "stopped"
    rc, _, err = cli([*VIDEO, "--sequences", "1", "--frames", "3", "--size", "32", "--out", out,
                      "--sprites", sprites_dir, "--workers", 1, "--no-progress"],
                     entry=video_main)
    assert rc == 130, err
    assert json.loads((out / "video.json").read_text())["status"] == "interrupted"
    check_video_intact(out)
