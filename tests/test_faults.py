"""Faults injected into generator runs: kill signals at random moments, a full disk, no
permission, a journal write cut short, a worker process that dies. After each: nothing
corrupt (:func:`tests.datasets.check_intact`), a one-line error where the run reports one,
and ``--resume`` finishes a dataset byte-identical to an uninterrupted run.

The kill trials cover every kind of run (:mod:`tests.test_faults_kinds`: still images,
video, the seadronessee preset, footage backgrounds, a shard before its merge). The CI runs
one trial of each kind; ``pytest -m slow tests/test_faults.py`` runs the campaign (20 trials
of every signal, the kinds in turn) and prints its figures.
"""

from __future__ import annotations

import errno
import json
import os
import signal
import subprocess
import time
from pathlib import Path

import pytest

from sdcomp.io import coco
from sdcomp.io.journal import Journal, read_journal
from sdcomp.util import files

from .datasets import (
    CLI,
    assert_identical,
    check_intact,
    finish,
    generate,
    live_processes,
    one_line_error,
    popen,
    wait_until,
)
from .test_faults_kinds import BASE, KINDS, Kinds, campaign, figures

pytestmark = pytest.mark.filterwarnings("ignore:__array__ implementation:DeprecationWarning")

TRIALS = 60  # the slow campaign's: 20 of each signal, 12 of each kind


def gen(out: Path, sprites: Path, *extra, workers: int = 2) -> tuple[int, str, str]:
    return generate(BASE, out, sprites, *extra, workers=workers)


@pytest.fixture(scope="module")
def reference(tmp_path_factory, sprites_dir) -> Path:
    """BASE, one worker, uninterrupted."""
    out = tmp_path_factory.mktemp("faults") / "reference"
    rc, _, err = gen(out, sprites_dir, workers=1)
    assert rc == 0, err
    return out


def resume_and_compare(out: Path, sprites: Path, reference: Path) -> None:
    rc, _, err = gen(out, sprites, "--resume")
    assert rc == 0, err
    check_intact(out)
    assert json.loads((out / "dataset.json").read_text())["status"] == "complete"
    assert_identical(reference, out)


# --------------------------------------------------------------------------- kill signals

@pytest.fixture(scope="module")
def kinds(tmp_path_factory, sprites_dir) -> Kinds:
    """Every kind of run (:mod:`tests.test_faults_kinds`), each uninterrupted run made once."""
    return Kinds(tmp_path_factory.mktemp("kinds"), sprites_dir)


def test_kill_signals_at_random_moments(tmp_path, kinds):
    """One trial of each kind of run (the signals in turn)."""
    stats = campaign(kinds, tmp_path, trials=len(KINDS), seed=1)
    assert stats["corrupted"] == 0 and set(stats["by_kind"]) == set(KINDS)
    assert stats["faults"] >= 1  # at least one signal hit a running run


@pytest.mark.slow
def test_kill_campaign(tmp_path, kinds):
    """60 trials: 20 of each signal, 12 of each kind (each kind meets each signal 4
    times); the figures are printed (``-s``)."""
    start = time.perf_counter()
    stats = campaign(kinds, tmp_path, trials=TRIALS, seed=2026)
    print(f"\n{figures(stats, time.perf_counter() - start, kinds.seconds)}")
    assert stats["trials"] == TRIALS and stats["corrupted"] == 0
    assert all(row["trials"] >= 20 for row in stats["by_signal"].values())
    assert stats["faults"] >= 0.75 * TRIALS and stats["after_first_write"] >= 0.4 * TRIALS


def test_sigterm_stops_workers_and_leaves_no_temporary_file(tmp_path, sprites_dir,
                                                            reference):
    out = tmp_path / "term"
    # a run long enough that the signal surely comes while images are being written
    argv = [*BASE, "--n", "2000", "--out", out, "--sprites", sprites_dir, "--workers", 2,
            "--no-progress"]
    proc = popen(CLI, argv)
    try:
        wait_until(lambda: has_image(out, proc), "the run's first image in images/")
    except AssertionError:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)  # leave no run behind
            proc.communicate()
        raise
    os.kill(proc.pid, signal.SIGTERM)
    rc, _, err = finish(proc, timeout=30)
    assert rc == 130, err
    assert "--resume" in err and "Traceback" not in err
    assert json.loads((out / "dataset.json").read_text())["status"] == "interrupted"
    check_intact(out)
    # the workers are gone: nothing of this run changes the folder any more
    before = files_and_sizes(out)
    wait_until(lambda: not live_processes(proc.pid),
               lambda: f"the workers to end (still running: {live_processes(proc.pid)})")
    assert files_and_sizes(out) == before


def has_image(out: Path, proc: subprocess.Popen) -> bool:
    """Whether the run ``proc`` has written an image into ``out``; AssertionError if it
    ended without one."""
    assert proc.poll() is None, f"the run ended (exit status {proc.returncode}) before an image"
    return (out / "images").exists() and bool(list((out / "images").glob("*/*.jpg")))


def files_and_sizes(root: Path) -> dict:
    return {p.as_posix(): p.stat().st_size for p in root.rglob("*") if p.is_file()}


# --------------------------------------------------------------------------- the pool's workers

# a SIGTERM taken by another thread while the pool forks its first worker (any thread of a
# run, its OpenCV threads too, may take a signal sent to the process)
SIGNAL_WHILE_FORKING = """
import os, signal, threading
from sdcomp.util.pool import imap_ordered

def stop(signum, frame):
    raise KeyboardInterrupt

signal.signal(signal.SIGTERM, stop)
go, sent = threading.Event(), threading.Event()

def sender():
    go.wait()
    os.kill(os.getpid(), signal.SIGTERM)
    sent.set()

def after_fork():
    if not go.is_set():
        go.set()
        sent.wait(10)

threading.Thread(target=sender, daemon=True).start()
os.register_at_fork(after_in_parent=after_fork)
try:
    print(sum(imap_ordered(abs, [-1, -2, -3, -4], 2)))
except KeyboardInterrupt:
    print("stopped")
"""


def test_a_signal_while_the_workers_start_stops_the_run():
    """Found by the campaign (a still run, SIGTERM to its main process): the signal came
    while the pool forked its workers, its handler ran in the fork handler that restores
    OpenCV's threads, and the KeyboardInterrupt it raised there was printed and dropped: the
    run went on to the end, deaf to a second SIGTERM. Now the pool defers the handlers while
    it starts its workers, and the run stops."""
    proc = popen(SIGNAL_WHILE_FORKING, [])
    rc, out, err = finish(proc, timeout=60)
    assert rc == 0 and out == "stopped\n", out + err
    assert "Traceback" not in err, err


# the run is killed (SIGKILL) when its workers have answered and wait for a task
KILLED_WHILE_IDLE = """
import os, signal
from sdcomp.util.pool import imap_ordered

results = imap_ordered(abs, [-1, -2, -3, -4], 2)
print([next(results) for _ in range(4)], flush=True)  # all in: the workers are idle
os.kill(os.getpid(), signal.SIGKILL)
"""


def test_idle_workers_of_a_killed_run_end():
    """Found by the campaign (SIGKILL to a run's main process near its end): its idle
    workers waited for a task for ever (each holds copies of the parent's ends of the
    pipes, so none sees an end of file), holding the run's output pipes open. Now an idle
    worker checks every second that its parent is alive."""
    proc = popen(KILLED_WHILE_IDLE, [])
    rc, out, err = finish(proc, timeout=20)  # the orphans hold its pipes until they end
    assert rc == -signal.SIGKILL and out == "[1, 2, 3, 4]\n", out + err
    wait_until(lambda: not live_processes(proc.pid), "the orphaned workers to end", 10)


# --------------------------------------------------------------------------- a worker dies

DIE = ("import os, signal, sys\n"
       "from sdcomp.run import local as writer\n"
       "MODE = sys.argv.pop(1)\n"
       "real = writer.make_record\n"
       "def fatal(gen, index, *rest):\n"
       "    if index == 77:\n"
       "        if MODE == 'kill':\n"
       "            os.kill(os.getpid(), signal.SIGKILL)\n"
       "        os._exit(3)\n"
       "    return real(gen, index, *rest)\n"
       "writer.make_record = fatal\n" + CLI)


@pytest.mark.parametrize("how", ["kill", "exit"])
def test_dead_worker_is_named_with_its_image_and_the_run_stops(how, tmp_path, sprites_dir,
                                                                reference):
    out = tmp_path / how
    proc = popen(DIE, [how, *BASE, "--out", out, "--sprites", sprites_dir, "--workers", 2,
                       "--no-progress"])
    rc, _, err = finish(proc, timeout=60)  # multiprocessing.Pool would hang here
    assert rc == 2, err
    one_line_error(err)
    assert "image 77" in err and "died" in err and "--resume" in err
    assert ("SIGKILL" if how == "kill" else "exit status 3") in err
    assert json.loads((out / "dataset.json").read_text())["status"] == "failed"
    listed = check_intact(out)
    assert 0 < listed < 120
    resume_and_compare(out, sprites_dir, reference)


# --------------------------------------------------------------------------- disk full, permissions

def _fail_writes(monkeypatch, after: int, err: int, match: str = "") -> None:
    """Image/mask writes whose path contains ``match`` fail with errno ``err`` once
    ``after`` of them succeeded (in each worker process: they inherit the patch)."""
    real = files.write_file
    count = [0]

    def flaky(path, data):
        if match in str(path):
            if count[0] >= after:
                tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
                with open(tmp, "wb") as fh:  # a partial temporary file, as a full disk leaves
                    fh.write(data[: len(data) // 2])
                raise OSError(err, os.strerror(err), str(tmp))
            count[0] += 1
        return real(path, data)

    monkeypatch.setattr(files, "write_file", flaky)


@pytest.mark.parametrize("err,workers,match", [(errno.ENOSPC, 2, "images"),
                                               (errno.EACCES, 1, "masks")])
def test_write_error_is_one_line_and_resume_completes(err, workers, match, tmp_path,
                                                      sprites_dir, reference, monkeypatch):
    out = tmp_path / "full"
    _fail_writes(monkeypatch, 50, err, match)
    rc, _, stderr = gen(out, sprites_dir, workers=workers)
    assert rc == 2, stderr
    one_line_error(stderr)
    assert os.strerror(err) in stderr and "--resume" in stderr
    assert ("free some disk space" if err == errno.ENOSPC else "writable") in stderr
    assert f"/{match}/" in stderr  # names the file
    meta = json.loads((out / "dataset.json").read_text())
    assert meta["status"] == "failed"
    assert f"{meta['counts']['images']} of 120 images are saved" in stderr
    check_intact(out)
    monkeypatch.undo()  # space is back
    resume_and_compare(out, sprites_dir, reference)


def test_real_write_removes_its_temporary_file_on_error(tmp_path, monkeypatch):
    target = tmp_path / "x.jpg"

    def no_replace(a, b):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(a))

    monkeypatch.setattr(files.os, "replace", no_replace)
    with pytest.raises(OSError):
        files.write_file(target, b"data")
    assert list(tmp_path.iterdir()) == []


def test_annotation_files_that_cannot_be_written(tmp_path, sprites_dir, reference,
                                                 monkeypatch):
    """The final COCO write fails: one line, the last checkpoint's files stay whole."""
    out = tmp_path / "coco_full"
    real = coco.write_coco
    calls = [0]

    def flaky(path, *a, **k):
        calls[0] += 1
        if calls[0] > 2:  # the two splits of the first, "running", write succeed
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(path))
        return real(path, *a, **k)

    monkeypatch.setattr(coco, "write_coco", flaky)
    rc, _, stderr = gen(out, sprites_dir)
    assert rc == 2, stderr
    one_line_error(stderr)
    assert "instances_" in stderr and "No space left" in stderr
    assert json.loads((out / "dataset.json").read_text())["status"] == "running"
    check_intact(out)
    monkeypatch.undo()
    resume_and_compare(out, sprites_dir, reference)


class _CutFile:
    """A file whose writes store half the bytes, then fail like a full disk."""

    def __init__(self, fh):
        self.fh = fh

    def write(self, data):
        self.fh.write(data[: len(data) // 2])
        self.fh.flush()
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    def __getattr__(self, name):
        return getattr(self.fh, name)


def test_journal_append_cut_short_leaves_no_half_record(tmp_path):
    path = tmp_path / "records.jsonl"
    with Journal(path) as j:
        j.append([{"index": 0, "x": "a" * 100}])
        before = path.read_bytes()
        real = j._file
        j._file = _CutFile(real)
        with pytest.raises(OSError):
            j.append([{"index": 1, "x": "b" * 100}, {"index": 2}])
        assert path.read_bytes() == before
        j.append([{"index": 3}])  # space is back: appends go on, on a fresh line
    assert sorted(read_journal(path)) == [0, 3]
    assert read_journal(path)  # no damaged line


@pytest.fixture
def tiny_disk(tmp_path):
    """A 320 kB tmpfs (needs root and mount; skipped elsewhere); yields (folder, regrow)."""
    mnt = tmp_path / "disk"
    mnt.mkdir()
    if subprocess.run(["mount", "-t", "tmpfs", "-o", "size=320k", "tmpfs", str(mnt)],
                      capture_output=True).returncode != 0:
        pytest.skip("cannot mount a tmpfs here (needs root): the monkeypatched tests cover it")

    def regrow():
        subprocess.run(["mount", "-o", "remount,size=64m", str(mnt)], check=True)

    try:
        yield mnt, regrow
    finally:
        subprocess.run(["umount", "-l", str(mnt)], capture_output=True)


def test_real_full_disk(tiny_disk, sprites_dir, reference):
    mnt, regrow = tiny_disk
    out = mnt / "dataset"
    rc, _, err = gen(out, sprites_dir)
    assert rc == 2, err
    one_line_error(err)
    assert "No space left on device" in err and "--resume" in err
    check_intact(out)
    regrow()
    resume_and_compare(out, sprites_dir, reference)


def test_resume_after_a_kill_before_dataset_json(tmp_path, sprites_dir, reference):
    """Killed between creating the folders and writing dataset.json (found by the kill
    campaign): --resume starts afresh instead of refusing the folder."""
    out = tmp_path / "early"
    for sub in ("images", "masks", "annotations"):
        (out / sub).mkdir(parents=True)
    (out / "annotations" / ".instances_train.json.x1y2.tmp").write_bytes(b'{"info":')
    resume_and_compare(out, sprites_dir, reference)
    # but a folder with someone else's files is still refused
    other = tmp_path / "other"
    (other / "images").mkdir(parents=True)
    (other / "images" / "photo.jpg").write_bytes(b"\xff\xd8\xff")
    rc, _, err = gen(other, sprites_dir, "--resume")
    assert rc == 2 and "not an sdcomp dataset" in err
