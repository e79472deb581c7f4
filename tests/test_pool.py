"""The worker pool of the generator (:mod:`sdcomp.pool`): ordered results, errors raised
in the parent, dead workers reported with their item instead of a hang, workers stopped
when the caller leaves early."""

from __future__ import annotations

import os
import signal
import time

import pytest

from sdcomp.errors import UserError
from sdcomp.util import pool
from sdcomp.util.pool import WorkerDied, imap_ordered, note

from .datasets import wait_until


def square(task):
    note(task)
    if task % 3 == 0:
        time.sleep(0.01)  # models a slower task (finish out of order), not a wait
    return task * task, os.getpid()


def fails_on_5(task):
    note(task)
    if task == 5:
        raise ValueError("bad task 5")
    if task == 6:
        raise UserError("user task 6")
    return task


def dies_on_4(task):
    note(task)
    if task == 4:
        os.kill(os.getpid(), signal.SIGKILL)
    return task


def dies_at_once(task):
    os._exit(7)


def slow(task):
    note(task)
    time.sleep(0.2)  # models a task that takes a while, not a wait for a condition
    return os.getpid()


def ended(pid: int) -> bool:
    """Whether process ``pid`` has ended and been reaped (a zombie still exists)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return True
    return False


def test_results_come_in_order_from_several_processes():
    out = list(imap_ordered(square, list(range(40)), 3))
    assert [r for r, _ in out] == [i * i for i in range(40)]
    assert len({pid for _, pid in out}) > 1 and os.getpid() not in {pid for _, pid in out}


def test_errors_are_raised_in_the_parent_with_the_worker_traceback():
    with pytest.raises(ValueError, match="bad task 5") as exc:
        list(imap_ordered(fails_on_5, [1, 2, 3, 4, 5], 2))
    assert any("in the worker process" in n for n in getattr(exc.value, "__notes__", []))
    with pytest.raises(UserError, match="user task 6"):
        list(imap_ordered(fails_on_5, [6], 1))


def test_a_dead_worker_is_reported_with_its_item_not_a_hang():
    t = time.monotonic()
    with pytest.raises(WorkerDied) as exc:
        list(imap_ordered(dies_on_4, list(range(10)), 2, what="image"))
    assert time.monotonic() - t < 20
    e = exc.value
    assert e.item == 4 and e.exitcode == -signal.SIGKILL
    assert "image 4" in str(e) and "SIGKILL" in str(e) and "\n" not in str(e)
    with pytest.raises(WorkerDied, match="exit status 7.*before its first item"):
        list(imap_ordered(dies_at_once, [1, 2], 2))


def test_leaving_early_stops_the_workers():
    it = imap_ordered(slow, list(range(20)), 2)
    pid = next(it)
    it.close()
    # ended and reaped (no zombie either)
    wait_until(lambda: ended(pid), f"worker {pid} to end and be reaped after close()")


def test_note_outside_a_worker_does_nothing(monkeypatch):
    exits: list = []
    monkeypatch.setattr(os, "_exit", exits.append)  # note() must not end this process
    before = dict(pool._SELF)
    assert before == {}  # this process is no pool worker
    assert note(3) is None
    assert pool._SELF == before  # no slot, no shared array, no parent recorded
    assert exits == []
