"""A process pool that notices dead workers: ordered results, one task per worker at a time.

:func:`imap_ordered` runs ``func(task)`` for every task in worker processes and yields the
results in task order. Unlike :class:`multiprocessing.pool.Pool`, which waits forever for the
result of a worker that was killed (out of memory, a segfault in native code, ``kill -9``),
it watches every worker's process sentinel next to its result pipe: a worker that ends without
answering stops the run with :class:`WorkerDied`, which names the item (the image index) the
worker was busy with. Workers record that item in shared memory with :func:`note`, so it is
known even when the worker dies without a word.

Workers are forked where the platform can (they inherit the caller's loaded state: textures,
sprite atlases), with SIGINT and SIGTERM blocked and OpenCV's threads paused while forking
(:func:`pause_opencv_threads_on_fork`); in a worker SIGINT is ignored
(the parent handles Ctrl-C and stops the workers) and SIGTERM ends it. A worker whose parent
has gone (the parent was killed with SIGKILL) stops at its next :func:`note`, or within
:data:`ORPHAN_SECONDS` when it is idle.
"""

from __future__ import annotations

import copy
import multiprocessing as mp
import os
import pickle
import signal
import threading
import traceback
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from multiprocessing.connection import wait
from typing import Any

import cv2

from ..errors import UserError

STOP_SECONDS = 5.0  # how long stopped workers get to end after SIGTERM before SIGKILL
ORPHAN_SECONDS = 1.0  # how often an idle worker checks that its parent is alive
_SIGNALS = {signal.SIGINT, signal.SIGTERM}

# in a worker: (slot, shared array of current items, parent pid)
_SELF: dict[str, Any] = {}


class WorkerDied(UserError):
    """A worker process ended (killed, crashed, exited) before finishing its task.

    Attributes: ``item`` (the item it was busy with, or None), ``pid``, ``exitcode``
    (negative: killed by that signal).
    """

    def __init__(self, message: str, item: int | None, pid: int, exitcode: int | None):
        super().__init__(message)
        self.item, self.pid, self.exitcode = item, pid, exitcode

    def __reduce__(self):
        return type(self), (self.args[0], self.item, self.pid, self.exitcode)


_fork_threads: list[int] = []  # OpenCV thread counts saved by forks in progress
_fork_handlers: list[bool] = []  # [True] once the handlers are installed


def _pause_opencv() -> None:
    _fork_threads.append(cv2.getNumThreads())
    cv2.setNumThreads(1)


def _resume_opencv() -> None:
    if _fork_threads:
        cv2.setNumThreads(_fork_threads.pop())


def _child_opencv() -> None:
    _fork_threads.clear()
    cv2.setNumThreads(1)


def pause_opencv_threads_on_fork() -> None:
    """Make every later ``os.fork`` of this process safe for OpenCV (idempotent).

    OpenCV's thread pool does not survive fork: a forked child can hang in its first
    parallel OpenCV call. The handlers installed here stop the pool (one thread) while the
    process forks, restore it in the parent afterwards and leave the child with one thread.
    Used by this pool's workers and by the DataLoader workers of :mod:`sdcomp.torch`.
    """
    if _fork_handlers or not hasattr(os, "register_at_fork"):
        return
    os.register_at_fork(before=_pause_opencv, after_in_parent=_resume_opencv,
                        after_in_child=_child_opencv)
    _fork_handlers.append(True)


def note(item: int) -> None:
    """In a worker: record that it now works on ``item`` (an int >= 0, e.g. an image index),
    which :class:`WorkerDied` reports should the worker die. Ends a worker whose parent is
    gone. A no-op outside a pool worker."""
    if not _SELF:
        return
    if os.getppid() != _SELF["parent"]:
        os._exit(1)  # orphaned: nobody reads our results
    _SELF["current"][_SELF["slot"]] = item


def _serve(slot: int, conn, current, parent: int, func: Callable, initializer, initargs) -> None:
    """A worker's main loop: receive (task number, task), answer ("ok"|"error", number, x)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    signal.pthread_sigmask(signal.SIG_UNBLOCK, _SIGNALS)
    _SELF.update(slot=slot, current=current, parent=parent)
    current[slot] = -1
    if initializer is not None:
        initializer(*initargs)
    while True:
        try:
            # no EOF tells an idle worker that its parent was killed: the workers hold
            # copies of the parent's ends of the pipes (forked after them)
            while not conn.poll(ORPHAN_SECONDS):
                if os.getppid() != parent:
                    return  # orphaned: nobody sends a task
            msg = conn.recv()
        except (EOFError, OSError):
            return  # the parent is gone
        if msg is None:
            return
        number, task = msg
        try:
            reply = ("ok", number, func(task))
        except Exception as exc:  # sent to the parent, which raises it
            reply = ("error", number, _portable(exc))
        current[slot] = -1
        try:
            conn.send(reply)
        except (BrokenPipeError, OSError):
            return


def _portable(exc: Exception) -> Exception:
    """``exc`` if it survives the pipe, with the worker's traceback as a note, else a
    RuntimeError. Surviving means it pickles and can be rebuilt from its reduction, which
    ``copy.copy`` does the way unpickling would (nothing is unpickled here)."""
    text = "".join(traceback.format_exception(exc)).rstrip()
    try:
        pickle.dumps(exc)
        copy.copy(exc)
    except Exception:
        exc = RuntimeError(f"{type(exc).__name__}: {exc}")
    if not isinstance(exc, (UserError, OSError)):
        exc.add_note(f"in the worker process:\n{text}")
    return exc


def _how(exitcode: int | None) -> str:
    if exitcode is None:
        return "still running, no longer answering"
    if exitcode < 0:
        try:
            return f"killed by {signal.Signals(-exitcode).name}"
        except ValueError:
            return f"killed by signal {-exitcode}"
    return f"exit status {exitcode}"


def imap_ordered(func: Callable[[Any], Any], tasks: Sequence, workers: int, *,
                 initializer: Callable | None = None, initargs: tuple = (),
                 what: str = "item", lookahead: int = 2) -> Iterator:
    """Yield ``func(task)`` for each of ``tasks``, in order, computed by ``workers`` processes.

    ``func``, ``initializer`` and their arguments must be picklable where fork is not
    available. At most ``lookahead * workers`` results wait for an earlier one. An exception
    raised by ``func`` is raised here (with the worker's traceback as a note); a worker that
    dies raises :class:`WorkerDied` naming the ``what`` it was busy with (see :func:`note`).
    Leaving the iteration early (an exception, Ctrl-C, ``close()``) stops the workers:
    SIGTERM, then SIGKILL after :data:`STOP_SECONDS`.
    """
    if not tasks:
        return
    workers = max(1, min(int(workers), len(tasks)))
    crew = _start_workers(workers, func, initializer, initargs, what)
    clean = False
    try:
        results: dict[int, Any] = {}  # task number: result, waiting for an earlier one
        sent = done = 0
        while done < len(tasks):
            sent = crew.send(tasks, sent, min(len(tasks), done + lookahead * workers))
            results.update(crew.receive())
            while done in results:
                yield results.pop(done)
                done += 1
        clean = True
    finally:
        _stop(crew.procs, crew.conns, clean)


class _Crew:
    """The worker processes of one :func:`imap_ordered` call, seen from the parent.

    Worker ``slot`` is ``procs[slot]``; the parent talks to it over ``conns[slot]`` (its end
    of a duplex pipe) and reads the item it works on from ``current[slot]`` (shared int64,
    -1: none). ``busy`` maps the slot of each worker with a task to that task's number (its
    index in ``tasks``); a worker gets its next task only once it has answered.
    """

    def __init__(self, procs: list, conns: list, current: Any, what: str):
        self.procs, self.conns, self.current, self.what = procs, conns, current, what
        self.busy: dict[int, int] = {}  # slot: task number

    def died(self, slot: int) -> WorkerDied:
        """The :class:`WorkerDied` of the worker in ``slot``."""
        return _died(self.procs[slot], int(self.current[slot]), self.what)

    def send(self, tasks: Sequence, sent: int, limit: int) -> int:
        """Give tasks ``sent``, ``sent + 1``, ... (below ``limit``) to the idle workers, in
        slot order; returns the number of the next task to send. A worker whose pipe is
        closed has died: raises :class:`WorkerDied`."""
        for slot, conn in enumerate(self.conns):
            if slot not in self.busy and sent < limit:
                try:
                    conn.send((sent, tasks[sent]))
                except OSError:  # its end of the pipe is closed: it died
                    raise self.died(slot) from None
                self.busy[slot] = sent
                sent += 1
        return sent

    def receive(self) -> dict[int, Any]:
        """Wait until at least one busy worker answers or ends; returns {task number:
        result} of the answers. Raises the exception a task raised, or :class:`WorkerDied`
        for a worker that ended without answering."""
        watch: dict[Any, int] = {}  # a busy worker's pipe or process sentinel: its slot
        for slot in self.busy:
            watch[self.conns[slot]] = slot
            watch[self.procs[slot].sentinel] = slot
        results: dict[int, Any] = {}
        for obj in wait(list(watch)):
            slot = watch[obj]
            if slot not in self.busy:
                continue  # its pipe and its sentinel were both ready
            number, value = self._answer(slot, obj)
            results[number] = value
            del self.busy[slot]
        return results

    def _answer(self, slot: int, ready: Any) -> tuple[int, Any]:
        """The (task number, result) the worker in ``slot`` sent, now that ``ready`` (its
        pipe or its sentinel) is ready; raises what :meth:`receive` raises."""
        conn, proc = self.conns[slot], self.procs[slot]
        reply = None
        if conn.poll():
            try:
                reply = conn.recv()
            except (EOFError, OSError):
                reply = None
        if reply is None:
            if proc.is_alive() and ready is not proc.sentinel:
                proc.join(STOP_SECONDS)  # pipe closed: it is ending
            raise self.died(slot)
        kind, number, value = reply
        if kind == "error":
            raise value
        return number, value


def _start_workers(workers: int, func: Callable, initializer: Callable | None,
                   initargs: tuple, what: str) -> _Crew:
    """Start ``workers`` processes running :func:`_serve` (forked where the platform can),
    with SIGINT and SIGTERM blocked and their handlers deferred while they start
    (:func:`_signals_deferred`), so that Ctrl-C never meets a half-started worker."""
    ctx: Any = mp.get_context("fork" if "fork" in mp.get_all_start_methods() else "spawn")
    current = ctx.RawArray("q", workers)
    procs, conns = [], []
    pause_opencv_threads_on_fork()  # children would hang in OpenCV's thread pool
    # keep Ctrl-C away from half-started workers (and from the fork handlers)
    with _signals_deferred():
        old_mask = signal.pthread_sigmask(signal.SIG_BLOCK, _SIGNALS)
        try:
            for slot in range(workers):
                mine, theirs = ctx.Pipe()
                p = ctx.Process(target=_serve, daemon=True, name=f"sdcomp-worker-{slot}",
                                args=(slot, theirs, current, os.getpid(), func, initializer,
                                      initargs))
                p.start()
                theirs.close()
                procs.append(p)
                conns.append(mine)
        finally:
            signal.pthread_sigmask(signal.SIG_SETMASK, old_mask)
    return _Crew(procs, conns, current, what)


@contextmanager
def _signals_deferred() -> Iterator[None]:
    """Hold SIGINT's and SIGTERM's Python handlers off for the block: a signal that comes
    meanwhile is noted, and raised again after the block with the handlers back.

    Blocking the signals (``pthread_sigmask``) is not enough: it blocks them in this thread
    only, another thread of the process (OpenCV's, a BLAS pool's) takes them, and Python then
    runs the handler in this thread's next bytecode, which may be a fork handler
    (:func:`_resume_opencv`), where the KeyboardInterrupt it raises is printed and dropped:
    the stop was lost. Outside the main thread (no handlers there) nothing is deferred."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    came: list[int] = []
    old = {s: h for s in _SIGNALS if (h := signal.getsignal(s)) is not None}
    for s in old:
        signal.signal(s, lambda signum, frame: came.append(signum))
    try:
        yield
    finally:
        for s, h in old.items():
            signal.signal(s, h)
        for signum in dict.fromkeys(came):
            signal.raise_signal(signum)


def _died(proc: Any, item: int, what: str) -> WorkerDied:
    """The :class:`WorkerDied` of ``proc``, which was on ``item`` (-1: none yet)."""
    proc.join(1.0)
    on = f"while on {what} {item}" if item >= 0 else "before its first " + what
    retry = (f"; if {what} {item} kills a worker again, run with --workers 1 to see the error"
             if item >= 0 else "")
    return WorkerDied(f"worker process {proc.pid} died ({_how(proc.exitcode)}) {on}; the "
                      f"run stopped, keeping what was finished: continue it with --resume"
                      f"{retry}", item if item >= 0 else None, proc.pid, proc.exitcode)


def _stop(procs: list, conns: list, clean: bool) -> None:
    """End the workers: ask politely after a clean run, else SIGTERM; SIGKILL stragglers."""
    for conn in conns:
        if clean:
            try:
                conn.send(None)
            except OSError:
                pass
        conn.close()
    if not clean:
        for p in procs:
            if p.is_alive():
                p.terminate()
    for p in procs:
        p.join(STOP_SECONDS)
        if p.is_alive():
            p.kill()
            p.join()
        p.close()
