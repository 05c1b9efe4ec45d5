"""The study engine: variants in chunks, on Dask or in this process, resumable.

A study's variants are cut into chunks of a size that depends only on the number of variants
(not on the workers), so a chunk's result is the same whatever runs it, and an interrupted
study, run again, finds its finished chunks in the cache and skips them. Chunks run:

* on a Dask cluster: an existing one (``scheduler='tcp://HOST:PORT'``, or the
  ``DASK_SCHEDULER_ADDRESS`` environment variable, Dask's own convention), whose workers must
  have mjlink installed; or, by default, a ``distributed.LocalCluster`` started here with one
  single-threaded worker process per core and closed at the end;
* or in this process (``workers=0``): one chunk after the other; MuJoCo's rollout then uses a
  thread per core itself.

An optimization's generations, small batches one after the other, go to :class:`Pool`: the
study held by an actor on every worker, called straight from the client.

The reference is elementwise over variants, so its results are identical bit for bit whatever
the engine and the chunking; MuJoCo's are within the thresholds (a rollout does not depend on
its batch either, but the engine does not promise more than the thresholds).
"""

from __future__ import annotations

import contextlib
import functools
import logging
import os
import re
import socket
import sys
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .. import memory
from ..errors import InputError, MjlinkError
from ..model.reader import shown
from ..notes import note
from .cache import Cache
from .spec import Study
from .tasks import Evaluated, StudyWorker, Verified, mujoco_chunk, reference_chunk

REFERENCE_CHUNK = (8, 256)  # variants per reference task: at least, at most
MUJOCO_CHUNK = (4, 128)  # variants per MuJoCo task (one rollout of that many models)
CONNECT_TIMEOUT_S = 10.0  # to an existing scheduler, before a one-line error
WORKERS_TIMEOUT_S = 10.0  # for a connected cluster's first worker, before a one-line error
PROTOCOLS = ("tcp", "tls", "ws", "wss", "ucx", "inproc")  # Dask's address schemes


class EngineError(MjlinkError):
    """The Dask cluster cannot be reached or a task failed."""


class SchedulerError(EngineError, InputError):
    """A scheduler address that is not one, cannot be reached, or a cluster without workers:
    refused before any work (exit status 2)."""


def chunking() -> dict[str, list[int]]:
    """How variants are cut (the cache records it: another cut makes other chunks)."""
    return {"reference": list(REFERENCE_CHUNK), "mujoco": list(MUJOCO_CHUNK)}


_ADDRESS = re.compile(
    r"(?:(?P<scheme>[A-Za-z][A-Za-z0-9+.-]*)://)?(?P<host>\[[0-9A-Fa-f:.]+\]|[A-Za-z0-9_.-]+)(?::(?P<port>[0-9]+))?/?"
)


def check_address(address: str) -> str:
    """A Dask scheduler address as given (``tcp://HOST:PORT``, ``HOST:PORT``, ``tls://...``), or
    a one-line SchedulerError saying how to write one. Nothing is contacted."""
    if isinstance(address, str) and address.strip().lower().startswith("inproc://") and address.strip()[9:]:
        return address.strip()  # an in-process scheduler's (tests, notebooks): HOST/PID/N
    m = _ADDRESS.fullmatch(address.strip()) if isinstance(address, str) else None
    scheme = (m["scheme"] or "tcp").lower() if m else ""
    port = int(m["port"]) if m and m["port"] and len(m["port"]) <= 5 else None
    if m is None or scheme not in PROTOCOLS or (m["port"] and (port is None or not 0 < port < 65536)):
        raise SchedulerError(
            f"{shown(address)} is not a Dask scheduler address: write tcp://HOST:PORT (e.g. tcp://10.0.0.5:8786; "
            f"schemes {', '.join(PROTOCOLS)}; ports 1..65535)"
        )
    return address.strip()


def chunks(n: int, bounds: tuple[int, int], parts: int = 16) -> list[tuple[int, int]]:
    """[start, stop) ranges cutting n items into about ``parts`` chunks within ``bounds``."""
    lo, hi = bounds
    size = int(min(hi, max(lo, -(-n // parts))))
    return [(i, min(i + size, n)) for i in range(0, n, size)]


@dataclass
class Timing:
    """Wall seconds of each stage; ``cpu`` this process's CPU seconds."""

    start: float = field(default_factory=time.perf_counter)
    stages: dict[str, float] = field(default_factory=dict)

    @contextmanager
    def stage(self, name: str) -> Iterator[None]:
        t = time.perf_counter()
        try:
            yield
        finally:
            self.stages[name] = self.stages.get(name, 0.0) + time.perf_counter() - t


@dataclass(frozen=True)
class Outcome:
    """Everything a study computed, per variant (V of them, in the study's order).

    ``values`` (V, P) parameter values, file units; ``columns`` metric -> (V,) in its unit
    (NaN where infeasible); ``feasible`` (V,) bool; ``reason`` why not; ``verified`` (V,) int8:
    -1 not run in MuJoCo, 0 missed a threshold (or could not run), 1 agreed; ``mujoco`` the
    MuJoCo figures of the verified variants (position error, loop gap, thread error: um),
    NaN elsewhere; ``mujoco_reason`` what missed. ``engine`` how it ran; ``resumed`` chunks
    taken from the cache.
    """

    study: Study
    values: np.ndarray
    columns: dict[str, np.ndarray]
    feasible: np.ndarray
    reason: tuple[str, ...]
    verified: np.ndarray
    mujoco: dict[str, np.ndarray]
    mujoco_reason: tuple[str, ...]
    engine: str
    chunks: int
    resumed: int
    timing: dict[str, float]


def _holds(keys: set[str], rows: int, z: dict[str, np.ndarray]) -> bool:
    """Whether a cached chunk's arrays are the ones expected, one value per variant each."""
    return set(z) == keys and all(a.shape == (rows,) for a in z.values())


def _pack_ref(e: Evaluated) -> dict[str, np.ndarray]:
    out = {f"col:{k}": v for k, v in e.columns.items()}
    out["feasible"] = e.feasible
    out["reason"] = np.array(e.reason, dtype=str)
    return out


def _unpack_ref(z: dict[str, np.ndarray]) -> Evaluated:
    cols = {k[4:]: z[k] for k in z if k.startswith("col:")}
    return Evaluated(cols, z["feasible"].astype(bool), tuple(str(r) for r in z["reason"]))


def _pack_mj(v: Verified) -> dict[str, np.ndarray]:
    return {
        "passed": v.passed,
        "position_error": v.position_error,
        "loop_gap": v.loop_gap,
        "thread_error": v.thread_error,
        "reason": np.array(v.reason, dtype=str),
    }


def _unpack_mj(z: dict[str, np.ndarray]) -> Verified:
    return Verified(
        z["passed"].astype(bool),
        z["position_error"],
        z["loop_gap"],
        z["thread_error"],
        tuple(str(r) for r in z["reason"]),
    )


# ------------------------------------------------------------------------------ clients
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
    m = _ADDRESS.fullmatch(address.strip())
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

    # glibc reads these when a process starts (see mjlink.memory): the nanny's
    # pre-spawn environment is the only place to set them before a worker exists.
    # A worker never renders: it imports mujoco without probing OpenGL.
    environ = {**memory.MALLOC_ENV, "MJLINK_NO_GL": "1"}
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


# --------------------------------------------------------------------------------- running
Progress = Callable[[str, int, int], None]  # (stage, done, total) in variants


def run(
    study: Study,
    *,
    client: Any = None,
    scheduler: str | None = None,
    workers: int | None = None,
    cache_dir: Path | None = None,
    progress: Progress | None = None,
) -> Outcome:
    """Evaluate every variant of ``study`` with the reference, then verify the chosen ones in
    MuJoCo (the study's ``[verify]``).

    Args:
      study: the study.
      client: a ``distributed.Client`` to run on (overrides ``scheduler``/``workers``).
      scheduler: address of an existing Dask scheduler.
      workers: worker processes of the local cluster (default one per core); 0 runs in this
        process without Dask.
      cache_dir: where finished chunks are kept (None: no cache; :mod:`.cache`); the caller
        removes it (:meth:`.cache.Cache.remove`) once the study's outputs are safely written.
      progress: called with (stage, variants done, variants in the stage) as chunks finish.
    Returns:
      The :class:`Outcome`.
    """
    timing = Timing()
    with timing.stage("sampling"):
        values = study.values()
    cache = Cache(cache_dir, study, len(values), chunking())
    if client is not None:
        out = _run(study, values, client, "the given Dask client", cache, progress, timing)
    else:
        t = time.perf_counter()
        with client_for(scheduler, workers) as (c, what):
            timing.stages["cluster start"] = time.perf_counter() - t
            out = _run(study, values, c, what, cache, progress, timing)
    return out


def _run(
    study: Study,
    values: np.ndarray,
    client: Any,
    what: str,
    cache: Cache,
    progress: Progress | None,
    timing: Timing,
) -> Outcome:
    V = len(values)
    ref_chunks = chunks(V, REFERENCE_CHUNK)
    resumed = 0
    results: dict[tuple[int, int], Evaluated] = {}
    todo = []
    ref_keys = {f"col:{c.name}" for c in study.columns} | {"feasible", "reason"}
    for a, b in ref_chunks:
        z = cache.load("ref", a, b, functools.partial(_holds, ref_keys, b - a))
        if z is not None:
            results[(a, b)] = _unpack_ref(z)
            resumed += 1
        else:
            todo.append((a, b))
    done = sum(b - a for a, b in results)
    if progress:
        progress("reference", done, V)

    def ref_done(key: tuple[int, int], e: Evaluated) -> None:
        nonlocal done
        results[key] = e
        cache.save("ref", *key, _pack_ref(e))
        done += key[1] - key[0]
        if progress:
            progress("reference", done, V)

    with timing.stage("reference"):
        _map(client, reference_chunk, study, values, todo, ref_done, {})
    cols = {c.name: np.concatenate([results[k].columns[c.name] for k in ref_chunks]) for c in study.columns}
    feasible = np.concatenate([results[k].feasible for k in ref_chunks])
    reason = tuple(r for k in ref_chunks for r in results[k].reason)

    chosen = select(study, cols, feasible)
    verified = np.full(V, -1, dtype=np.int8)
    mj = {k: np.full(V, np.nan) for k in ("position_error", "loop_gap", "thread_error")}
    mj_reason = [""] * V
    n_mj = 0
    if len(chosen):
        mj_chunks = chunks(len(chosen), MUJOCO_CHUNK, parts=8)
        got: dict[tuple[int, int], Verified] = {}
        todo = []
        mj_keys = {"passed", "position_error", "loop_gap", "thread_error", "reason"}
        for a, b in mj_chunks:
            z = cache.load("mujoco", a, b, functools.partial(_holds, mj_keys, b - a))
            if z is not None:
                got[(a, b)] = _unpack_mj(z)
                resumed += 1
            else:
                todo.append((a, b))
        n_mj = sum(b - a for a, b in got)
        if progress:
            progress("mujoco", n_mj, len(chosen))

        def mj_done(key: tuple[int, int], v: Verified) -> None:
            nonlocal n_mj
            got[key] = v
            cache.save("mujoco", *key, _pack_mj(v))
            n_mj += key[1] - key[0]
            if progress:
                progress("mujoco", n_mj, len(chosen))

        threads = 1 if client is not None else (os.cpu_count() or 1)
        with timing.stage("mujoco"):
            _map(client, mujoco_chunk, study, values[chosen], todo, mj_done, {"threads": threads})
        for a, b in mj_chunks:
            v, idx = got[(a, b)], chosen[a:b]
            verified[idx] = v.passed.astype(np.int8)
            mj["position_error"][idx] = v.position_error
            mj["loop_gap"][idx] = v.loop_gap
            mj["thread_error"][idx] = v.thread_error
            for i, r in zip(idx, v.reason, strict=True):
                mj_reason[i] = r
    timing.stages["total"] = time.perf_counter() - timing.start
    return Outcome(
        study,
        values,
        cols,
        feasible,
        reason,
        verified,
        mj,
        tuple(mj_reason),
        what,
        len(ref_chunks),
        resumed,
        dict(timing.stages),
    )


def _map(
    client: Any,
    fn: Callable[..., Any],
    study: Any,
    values: np.ndarray,
    todo: list[tuple[int, int]],
    done: Callable[[tuple[int, int], Any], None],
    kwargs: dict[str, Any],
) -> None:
    """Run ``fn(study, values[a:b], **kwargs)`` for every chunk, calling ``done`` as each ends.

    On a cluster the study travels with each task (a few kB pickled) rather than being
    scattered once: the scheduler's active memory manager drops a broadcast's extra replicas
    within a second or two (measured), so a scatter saves nothing, and tasks that depend on
    it may be sent to the one worker still holding it (seen once on a LocalCluster: 86 of
    the 91 tasks of an optimization on one of its two workers)."""
    if not todo:
        return
    if client is None:
        for a, b in todo:
            done((a, b), fn(study, values[a:b], **kwargs))
        return
    from distributed import as_completed  # here: Dask, only for a cluster

    futures = {client.submit(fn, study, values[a:b], pure=False, **kwargs): (a, b) for a, b in todo}
    try:
        # Results are fetched as the tasks end, in the background, not one request per task
        # after it is reported done: a round trip less per task, per generation of an
        # optimization.
        for fut, res in as_completed(futures, with_results=True, raise_errors=False):
            if fut.status == "error":
                try:
                    fut.result()
                except Exception as e:
                    raise _task_error(e) from None
            done(futures[fut], res)
    finally:
        for fut in futures:
            fut.cancel()


def _task_error(e: Exception) -> Exception:
    """What a failure on the cluster becomes: mjlink's own errors as they are, anything else a
    one-line EngineError."""
    if isinstance(e, MjlinkError):
        return e
    return EngineError(f"a study task failed on the cluster: {type(e).__name__}: {e}")


class Pool:
    """``study`` held by one :class:`~.tasks.StudyWorker` actor on every worker of ``client``,
    for many small batches (an optimization's generations; a sampled study's few large chunks
    go as tasks, :func:`run`, which the scheduler balances).

    Use as a context manager; the actors are released on exit. Chunks go to the actors in
    turn, so equal chunks in a multiple of the workers keep every worker equally busy. A lost
    worker takes its actor with it: the batch then runs once more on actors made anew on the
    workers left (a chunk's result does not depend on where it runs).
    """

    def __init__(self, client: Any, study: Study):
        self._client, self._study = client, study
        self._futures: list[Any] = []
        self._actors: list[Any] = []
        self._start()

    def _start(self) -> None:
        self.close()
        workers = list(self._client.scheduler_info()["workers"])
        if not workers:
            raise EngineError("the Dask cluster has no workers")
        # The futures keep the actors alive: an actor is released with its future. A worker
        # that has just left may still be listed: the actor then goes to another one.
        self._futures = [
            self._client.submit(StudyWorker, self._study, actor=True, workers=[w], allow_other_workers=True, pure=False)
            for w in workers
        ]
        try:
            self._actors = [f.result() for f in self._futures]
        except Exception as e:
            self.close()
            raise _task_error(e) from None

    def __enter__(self) -> Pool:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        for f in self._futures:
            f.release()
        self._futures, self._actors = [], []

    def reference(
        self, values: np.ndarray, todo: list[tuple[int, int]], done: Callable[[tuple[int, int], Evaluated], None]
    ) -> None:
        """:func:`~.tasks.reference_chunk` of ``values[a:b]`` for every chunk of ``todo``,
        calling ``done`` with each result."""
        for attempt in range(2):
            calls = [
                (key, self._actors[i % len(self._actors)].reference(values[key[0] : key[1]]))
                for i, key in enumerate(todo)
            ]
            try:
                results = [(key, call.result()) for key, call in calls]
            except OSError as e:  # the actor's worker cannot be reached (distributed's own words)
                if attempt:
                    raise _task_error(e) from None
                self._start()
                continue
            except Exception as e:
                raise _task_error(e) from None
            for key, r in results:
                done(key, r)
            return


def select(study: Study, columns: dict[str, np.ndarray], feasible: np.ndarray) -> np.ndarray:
    """Indices of the variants MuJoCo verifies: all feasible ones, none, or the ``count``
    feasible ones with the lowest ('best') or highest ('worst') value of column ``by``, in
    the study's order."""
    idx = np.flatnonzero(feasible)
    if study.verify == "none":
        return idx[:0]
    if study.verify == "all":
        return idx
    x = columns[study.by][idx]
    order = np.argsort(x if study.verify == "best" else -x, kind="stable")
    return np.sort(idx[order[: study.count]])
