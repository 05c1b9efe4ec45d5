"""The figures' worker: a process drawing plots into the stage while the run goes on.

A ``simulate`` run draws its figures in a worker process beside the MuJoCo runs and the video
(two cores). The worker is the standard library's :class:`multiprocessing.Process` with the
``fork`` start method: the traces the plots draw are inherited, not pickled through a pipe, and
the worker's result (nothing, or the error with its traceback) comes back through a
:func:`multiprocessing.Pipe`, with what an open :class:`mjlink.plotting.style.examine` found
on the figures the worker drew (the checks of the figures run where they are drawn).

The worker is part of the run and never outlives it: it ignores SIGINT and SIGTERM (the run
decides), a failing, interrupted or terminated run kills and reaps it before its stage is
removed (:func:`.staging.on_discard`), so it cannot re-create the stage, and a thread of
its own ends it within :data:`WATCH_S` of its parent's death (it polls ``os.getppid()``: a
killed run leaves no worker drawing). Where ``fork`` is unavailable the plots are drawn in this
process, in order.
"""

from __future__ import annotations

import contextlib
import gc
import multiprocessing
import os
import signal
import sys
import threading
import time
import traceback
from collections.abc import Callable
from multiprocessing.connection import Connection
from typing import Any

from ..errors import MjlinkError
from .signals import uninterrupted
from .staging import on_discard

# A plot to draw later, with its arguments bound.
PlotJob = Callable[[], object]

WATCH_S = 0.2  # how often a worker checks that its parent lives, s


def run_jobs(jobs: list[PlotJob]) -> None:
    """Draw the queued plots, in order."""
    for job in jobs:
        job()


class _WorkerTraceback(Exception):
    """The plot worker's traceback, as the cause of the error it reported."""

    def __str__(self) -> str:
        return f"\n{self.args[0]}" if self.args else ""


class PlotWorker:
    """A process drawing ``jobs`` (:func:`start` makes one): its ``pid``; :func:`finish` waits for
    it and re-raises its error; :meth:`stop` kills and reaps it (its stage's stop hook)."""

    def __init__(self, process: Any, result: Connection) -> None:
        self.process, self.result = process, result
        self.pid: int = process.pid
        self.reaped = False
        self.cancel: Callable[[], None] = lambda: None

    def stop(self) -> None:
        """Kill and reap the worker (the run failed or was interrupted); once only."""
        if self.reaped:
            return
        self.reaped = True
        self.process.kill()
        self.process.join()
        self.result.close()


def start(jobs: list[PlotJob]) -> PlotWorker | None:
    """Draw ``jobs`` in a worker process while this one goes on (:func:`finish` waits for it);
    None where ``fork`` is unavailable. SIGINT and SIGTERM are held back across the fork, so that
    an interruption lands either before it or once the worker's stop hook is registered."""
    try:
        ctx = multiprocessing.get_context("fork")
    except ValueError:
        return None
    parent = os.getpid()
    mask = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT, signal.SIGTERM})
    try:
        result, sink = ctx.Pipe(duplex=False)
        process = ctx.Process(target=_main, args=(jobs, sink, parent, mask), name="mjlink-plots")
        # Everything this process holds moved out of the collector's sight for the fork: the
        # worker's collections then never write to the inherited objects' headers, which would
        # copy page after page of the shared heap into the worker.
        gc.freeze()
        try:
            process.start()
        except OSError:
            result.close()
            sink.close()
            return None
        finally:
            gc.unfreeze()
        sink.close()
        worker = PlotWorker(process, result)
        worker.cancel = on_discard(worker.stop)
        return worker
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, mask)


def _examined() -> list[Any] | None:
    """The list an open :class:`mjlink.plotting.style.examine` gathers into here, if any: one
    is open only where the plotting module is loaded already (not imported for it)."""
    style = sys.modules.get("mjlink.plotting.style")
    return None if style is None else style.examined()


def _main(jobs: list[PlotJob], sink: Connection, parent: int, mask: set[Any]) -> None:
    """The worker: draw ``jobs``; send back (None, what an open examine found on the figures
    drawn) on success, ((error, traceback), []) on failure."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_IGN)
    threading.Thread(target=_watch_parent, args=(parent,), daemon=True).start()
    if os.getppid() != parent:  # the parent died before the watch began
        os._exit(1)
    signal.pthread_sigmask(signal.SIG_SETMASK, mask)
    # No collections in this short-lived process: matplotlib's figures are cyclic garbage the
    # collector would chase through every few thousand allocations for nothing; what they
    # hold, some 50 MB in all, is freed when the worker exits.
    gc.disable()
    report: Any = None
    found: list[Any] = []
    try:
        examined = _examined()
        before = len(examined) if examined is not None else 0  # inherited: the parent has them
        run_jobs(jobs)
        found = examined[before:] if examined is not None else []
    except BaseException as e:
        tb = traceback.format_exc()
        report = (e, tb)
    try:
        sink.send((report, found))
    except Exception as failed:  # the error itself does not pickle: its words do
        e, tb = report if report is not None else (failed, traceback.format_exc())
        with contextlib.suppress(Exception):
            sink.send(((MjlinkError(f"plot worker: {type(e).__name__}: {e}"), tb), []))
    sink.close()


def _watch_parent(parent: int) -> None:
    while os.getppid() == parent:
        time.sleep(WATCH_S)
    os._exit(1)


def finish(worker: PlotWorker) -> None:
    """Wait for the worker, reap it and re-raise the error it reported (e.g. an unwritable plot's
    OutputError, with the worker's traceback as its cause). Interrupted while waiting, the
    exception goes on and the stage's stop hook kills the worker."""
    try:
        report, found = worker.result.recv()
        got = True
    except EOFError:  # it ended without a word: killed, or exited
        report, found, got = None, [], False
    with uninterrupted():
        worker.process.join()
        worker.reaped = True
        worker.cancel()
        worker.result.close()
    if report is not None:
        err, tb = report
        raise err from _WorkerTraceback(tb)
    code = worker.process.exitcode
    if got and code == 0:
        examined = _examined()
        if examined is not None:
            examined.extend(found)
        return
    if code is not None and code > 0:
        raise MjlinkError(f"the plot worker exited with status {code} before finishing the plots")
    try:
        how = signal.Signals(-(code or 0)).name
    except ValueError:
        how = f"signal {-(code or 0)}"
    raise MjlinkError(f"the plot worker was killed by {how} before finishing the plots")
