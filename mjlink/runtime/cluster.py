"""The Dask cluster a study runs on: an existing one, or a local one started and stopped here.

:func:`client_for` connects to a scheduler (refusing in one line an address that is not one, a
scheduler that does not answer, a cluster without workers) or starts a ``LocalCluster`` of
single-threaded worker processes with the allocator settings of :mod:`.environment`, keeps it
out of the terminal's process group and its stderr out of the terminal, and closes it
quietly. The study engine (:mod:`mjlink.study.engine`) only uses the client it is given.
"""

from __future__ import annotations

import contextlib
import logging
import os
import socket
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

from ..notes import note
from ..study.engine import ADDRESS, EngineError, SchedulerError, check_address
from .environment import MALLOC_ENV

__all__ = ["CONNECT_TIMEOUT_S", "WORKERS_TIMEOUT_S", "check_reachable", "client_for", "local_workers"]

CONNECT_TIMEOUT_S = 10.0  # to an existing scheduler, before a one-line error
WORKERS_TIMEOUT_S = 10.0  # for a connected cluster's first worker, before a one-line error


def _connect(client_class: Any, address: str) -> Any:
    """A client of the scheduler at ``address``. distributed (2026.8) checks that its first
    read after registering holds the scheduler's stream-start alone, and fails with a bare
    AssertionError when the scheduler's batched sends put another message in the same read
    (a race seen once under load, with other clients on the scheduler): a second attempt
    registers anew."""
    try:
        return client_class(address, timeout=f"{CONNECT_TIMEOUT_S}s")
    except AssertionError:
        return client_class(address, timeout=f"{CONNECT_TIMEOUT_S}s")


def check_reachable(address: str, timeout: float | None = None) -> None:
    """Whether anything listens at a TCP scheduler address (a plain connection, no Dask): a
    scheduler that refuses or does not answer is a one-line SchedulerError at once, before the
    study is sized and planned. Other schemes are left to Dask's own connection."""
    m = ADDRESS.fullmatch(address.strip())
    if m is None or (m["scheme"] or "tcp").lower() not in ("tcp", "tls", "ws", "wss"):
        return
    host = m["host"].strip("[]")
    port = int(m["port"] or 8786)
    try:
        socket.create_connection((host, port), timeout=CONNECT_TIMEOUT_S if timeout is None else timeout).close()
    except OSError as e:
        why = "no answer" if isinstance(e, TimeoutError) else (e.strerror or type(e).__name__)
        raise SchedulerError(
            f"cannot reach the Dask scheduler at {address}: {why} (within {CONNECT_TIMEOUT_S:g} s); "
            "is it running, and is the address right?"
        ) from None


def _not_dask(e: BaseException) -> str:
    """What a failed connection to a scheduler says, in one line (a peer that answers in
    another protocol makes Dask's reader fail in odd ways: a huge allocation, a decode)."""
    if isinstance(e, MemoryError | ValueError | UnicodeError | EOFError):
        return "something answers there, but not as a Dask scheduler"
    return _one_line(e)


@contextmanager
def client_for(scheduler: str | None = None, workers: int | None = None) -> Iterator[tuple[Any, str]]:
    """A Dask client and a description of it (None and 'in process' for ``workers=0``).

    ``scheduler`` (or ``DASK_SCHEDULER_ADDRESS``) connects to an existing cluster: an address
    that is not one, a scheduler that does not answer within :data:`CONNECT_TIMEOUT_S` and a
    cluster that has no worker within :data:`WORKERS_TIMEOUT_S` are one-line SchedulerErrors.
    Otherwise a LocalCluster of ``workers`` single-threaded processes (default: one per core)
    is started and closed on exit. Its scheduler's HTTP server listens on a free port of
    localhost (never Dask's 8787: a second study at the same time finds it taken); its worker
    processes write to /dev/null, not to this terminal (``MJLINK_WORKER_LOGS=1`` keeps their
    stderr), and each leaves the terminal's process group once started, so that a Ctrl-C
    reaches this process alone, which stops them cleanly.
    """
    address = scheduler or os.environ.get("DASK_SCHEDULER_ADDRESS")
    if workers == 0 and not scheduler:
        yield None, "in process"
        return
    try:
        from distributed import Client, LocalCluster  # here: Dask, only for a cluster
    except ImportError as e:  # pragma: no cover - a dependency
        raise EngineError(f"Dask distributed is not installed ({e}): pip install 'dask[distributed]'") from None
    if address:
        address = check_address(address)
        try:
            client = _connect(Client, address)
        except Exception as e:
            raise SchedulerError(
                f"cannot reach the Dask scheduler at {address} within {CONNECT_TIMEOUT_S:g} s: {_not_dask(e)}"
            ) from None
        try:
            try:
                client.wait_for_workers(1, timeout=WORKERS_TIMEOUT_S)
            except Exception:
                raise SchedulerError(
                    f"the Dask cluster at {address} has no workers (none joined within {WORKERS_TIMEOUT_S:g} s): "
                    f"start some (dask worker {address}) or give another --scheduler"
                ) from None
            try:
                client.run(_warm)  # mjlink importable on every worker, its allocator settings made
            except Exception as e:
                raise EngineError(
                    f"the workers of the Dask cluster at {address} cannot run mjlink: {_one_line(e)}"
                ) from None
            n = len(client.scheduler_info()["workers"])
            yield client, f"Dask cluster at {address} ({n} workers)"
        finally:
            _close_quietly(client)
        return
    n = workers or os.cpu_count() or 1
    import dask  # here: Dask, only for a cluster

    # glibc reads these when a process starts (see .environment): the nanny's
    # pre-spawn environment is the only place to set them before a worker exists.
    # A worker never renders: it imports mujoco without probing OpenGL.
    environ = {**MALLOC_ENV, "MJLINK_NO_GL": "1"}
    # Dask's nanny sets its pre-spawn environment in this process too, before each worker it
    # spawns ("even if this means poisoning the process running the Nanny", its documentation):
    # the workers' allocator, BLAS, no-GL and hash-seed settings must not stay in a user's
    # process and reach every program it starts afterwards. Put back once started and once
    # closed (a lost worker's restart sets them again).
    before = dict(os.environ)
    try:
        with dask.config.set({"distributed.nanny.pre-spawn-environ": environ}), _workers_stderr():
            cluster = LocalCluster(
                n_workers=n,
                threads_per_worker=1,
                processes=True,
                dashboard_address=None,
                scheduler_kwargs={"dashboard_address": "127.0.0.1:0"},
                silence_logs=logging.ERROR,
            )
    finally:
        _restore(before)
    client = Client(cluster)
    try:
        client.run(_warm_local)  # imports on every worker now, not inside the first timed task
        yield client, f"Dask LocalCluster ({n} worker processes x 1 thread)"
    finally:
        _close_quietly(client, cluster)
        _restore(before)


def local_workers(workers: int | None) -> int:
    """The worker processes of a local cluster for ``--workers``: one per core by default; more
    than the cores is clamped to them, with a note (a study's tasks are CPU-bound: more
    processes than cores only share them)."""
    cores = os.cpu_count() or 1
    if workers is None:
        return cores
    if workers > cores:
        note(f"--workers {workers} is more than this machine's {cores} cores: using {cores}")
        return cores
    return workers


def _restore(before: dict[str, str]) -> None:
    """Set ``os.environ`` back to ``before``: what was added since is removed, what changed is
    set back."""
    for k in [k for k in os.environ if k not in before]:
        del os.environ[k]
    for k, v in before.items():
        if os.environ.get(k) != v:
            os.environ[k] = v


@contextmanager
def _workers_stderr() -> Iterator[None]:
    """While the body starts worker processes, their inherited stderr is /dev/null (unless
    ``MJLINK_WORKER_LOGS`` is set): a worker interrupted or stopped must not write Dask's
    tracebacks into the user's terminal. This process's stderr is back when the body ends."""
    if os.environ.get("MJLINK_WORKER_LOGS"):
        yield
        return
    sys.stderr.flush()
    saved = os.dup(2)
    devnull = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(devnull, 2)
        yield
    finally:
        os.dup2(saved, 2)
        os.close(saved)
        os.close(devnull)


def _close_quietly(client: Any, cluster: Any = None) -> None:
    """Close the client (and the local cluster) without Dask's log lines about connections
    closed under it (an interrupted run closes in the middle of its tasks)."""
    loggers = [logging.getLogger(n) for n in ("distributed", "tornado", "asyncio")]
    levels = [lg.level for lg in loggers]
    for lg in loggers:
        lg.setLevel(logging.CRITICAL + 1)
    try:
        with contextlib.suppress(Exception):
            client.close()
        if cluster is not None:
            with contextlib.suppress(Exception):
                cluster.close()
    finally:
        for lg, level in zip(loggers, levels, strict=True):
            lg.setLevel(level)


def _one_line(e: BaseException) -> str:
    text = " ".join(str(e).split()) or type(e).__name__
    return text if len(text) <= 200 else text[:197] + "..."


def _warm() -> None:
    """Run on every worker at start: its imports made now, not inside the first timed task."""
    import mjlink.sim.batch
    import mjlink.study.tasks  # noqa: F401


def _warm_local() -> None:
    """:func:`_warm`, and out of the terminal's process group: a worker of the local cluster is
    stopped by this process, not by the terminal's Ctrl-C (which would make it print)."""
    _warm()
    with contextlib.suppress(OSError):
        os.setpgrp()
