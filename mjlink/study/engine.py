"""The study engine: variants in chunks, on Dask or in this process, resumable.

A study's variants are cut into chunks of a size that depends only on the number of variants
and the study's metrics (not on the workers), so a chunk's result is the same whatever runs it, and an interrupted
study, run again, finds its finished chunks in the cache and skips them. Chunks run:

* on a Dask cluster, through the client the caller gives: an existing cluster, whose workers
  must have mjlink installed, or a local one (the command line opens either with
  :func:`mjlink.runtime.cluster.client_for`);
* or in this process (no client): one chunk after the other; MuJoCo's rollout then uses a
  thread per core itself.

An optimization's generations, small batches one after the other, go to :class:`Pool`: the
study held by an actor on every worker, called straight from the client.

The reference is elementwise over variants, so its results are identical bit for bit whatever
the engine and the chunking, but for a metric that steps its variants together (the thread's
tension), whose arithmetic in another order agrees to rounding; MuJoCo's are within the
thresholds (a rollout does not depend on its batch either, but the engine does not promise more
than the thresholds).
"""

from __future__ import annotations

import functools
import os
import re
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import InputError, MjlinkError
from ..model.reader import shown
from .cache import Cache
from .spec import Study
from .tasks import Evaluated, StudyWorker, Verified, mujoco_chunk, reference_chunk

REFERENCE_CHUNK = (8, 256)  # variants per reference task: at least, at most
MUJOCO_CHUNK = (4, 128)  # variants per MuJoCo task (one rollout of that many models)
# Reference tasks at least of a study whose metric steps its variants together, and at least one
# a worker: a task's every step costs its own overhead whatever its size, so one a worker is
# cheapest (bench/bench_tension.py --study: 2 tasks of 500 heads took 0.75x the CPU of 4 of 250).
TOGETHER_PARTS = 2
# Blocks of consecutive variants each of those tasks draws from, spread over the study: its few
# large tasks then cost alike where the variants' costs follow a parameter (a head's thread
# settles slower at a higher tension), and neighbours (one head's geometry) stay together.
DEALT = 8
PROTOCOLS = ("tcp", "tls", "ws", "wss", "ucx", "inproc")  # Dask's address schemes


class EngineError(MjlinkError):
    """The Dask cluster cannot be reached or a task failed."""


class SchedulerError(EngineError, InputError):
    """A scheduler address that is not one, cannot be reached, or a cluster without workers:
    refused before any work (exit status 2)."""


def chunking(study: Study, lanes: int = 1) -> dict[str, list[int]]:
    """How variants are cut on ``lanes`` workers (the cache records it: another cut makes other
    chunks)."""
    together = max((m.together for m in study.metrics), default=1)
    cut = [*REFERENCE_CHUNK, together, DEALT] + ([_parts(lanes)] if together > 1 else [])
    return {"reference": cut, "mujoco": list(MUJOCO_CHUNK)}


def _parts(lanes: int) -> int:
    """The tasks at least of a study whose metric steps its variants together, on ``lanes``
    workers: :data:`TOGETHER_PARTS`, or one a worker."""
    return max(TOGETHER_PARTS, lanes)


ADDRESS = re.compile(
    r"(?:(?P<scheme>[A-Za-z][A-Za-z0-9+.-]*)://)?(?P<host>\[[0-9A-Fa-f:.]+\]|[A-Za-z0-9_.-]+)(?::(?P<port>[0-9]+))?/?"
)


def check_address(address: str) -> str:
    """A Dask scheduler address as given (``tcp://HOST:PORT``, ``HOST:PORT``, ``tls://...``), or
    a one-line SchedulerError saying how to write one. Nothing is contacted."""
    if isinstance(address, str) and address.strip().lower().startswith("inproc://") and address.strip()[9:]:
        return address.strip()  # an in-process scheduler's (tests, notebooks): HOST/PID/N
    m = ADDRESS.fullmatch(address.strip()) if isinstance(address, str) else None
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


def reference_chunks(study: Study, n: int, lanes: int = 1) -> list[tuple[int, int]]:
    """The reference's tasks over ``n`` variants of ``study`` on ``lanes`` workers: about 16
    within :data:`REFERENCE_CHUNK`, unless a metric steps its variants together
    (``Metric.together``), whose tasks then hold up to that many, one a worker and
    :data:`TOGETHER_PARTS` at least where the variants allow."""
    lo, hi = REFERENCE_CHUNK
    together = max((m.together for m in study.metrics), default=1)
    if together <= 1:
        return chunks(n, (lo, hi))
    return chunks(n, (int(min(together, max(lo, -(-n // _parts(lanes))))), together))


def reference_order(study: Study, n: int, lanes: int = 1) -> np.ndarray | None:
    """The order the reference's tasks take ``n`` variants of ``study`` in (:func:`reference_chunks`
    cuts it; None: the study's own). A study whose metric steps its variants together, in a few
    large tasks, deals them blocks of consecutive variants in turn, :data:`DEALT` blocks a
    task: each task holds a share of every part of the study."""
    cut = reference_chunks(study, n, lanes)
    if max((m.together for m in study.metrics), default=1) <= 1 or len(cut) < 2:
        return None
    block = -(-(cut[0][1] - cut[0][0]) // DEALT)
    i = np.arange(n)
    order: np.ndarray = np.lexsort((i, (i // block) % len(cut)))
    return order


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


@dataclass(frozen=True, kw_only=True)
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


# --------------------------------------------------------------------------------- running
Progress = Callable[[str, int, int], None]  # (stage, done, total) in variants


def run(
    study: Study,
    *,
    client: Any = None,
    what: str | None = None,
    cache_dir: Path | None = None,
    progress: Progress | None = None,
) -> Outcome:
    """Evaluate every variant of ``study`` with the reference, then verify the chosen ones in
    MuJoCo (the study's ``[verify]``).

    Args:
      study: the study.
      client: a ``distributed.Client`` to run on; None runs in this process, one chunk after
        the other (the command line opens the client: :mod:`mjlink.runtime.cluster`).
      what: the client as the summary names it (``"Dask LocalCluster (2 worker processes x 1
        thread)"``; default "in process", or "the given Dask client").
      cache_dir: where finished chunks are kept (None: no cache; :mod:`.cache`); the caller
        removes it (:meth:`.cache.Cache.remove`) once the study's outputs are safely written.
      progress: called with (stage, variants done, variants in the stage) as chunks finish.
    Returns:
      The :class:`Outcome`.
    """
    timing = Timing()
    with timing.stage("sampling"):
        values = study.values()
    lanes = workers_of(client)
    cache = Cache(cache_dir, study, len(values), chunking(study, lanes))
    if what is None:
        what = "in process" if client is None else "the given Dask client"
    return _run(study, values, client, lanes, what, cache, progress, timing)


def workers_of(client: Any) -> int:
    """The workers of a Dask ``client`` (1: None, this process)."""
    if client is None:
        return 1
    return max(1, len(client.scheduler_info().get("workers", {})))


def _run(
    study: Study,
    values: np.ndarray,
    client: Any,
    lanes: int,
    what: str,
    cache: Cache,
    progress: Progress | None,
    timing: Timing,
) -> Outcome:
    V = len(values)
    ref_chunks = reference_chunks(study, V, lanes)
    order = reference_order(study, V, lanes)
    dealt = values if order is None else values[order]
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
        _map(client, reference_chunk, study, dealt, todo, ref_done, {})
    back = np.arange(V) if order is None else np.argsort(order)  # the study's order again
    cols = {c.name: np.concatenate([results[k].columns[c.name] for k in ref_chunks])[back] for c in study.columns}
    feasible = np.concatenate([results[k].feasible for k in ref_chunks])[back]
    reasons = [r for k in ref_chunks for r in results[k].reason]
    reason = tuple(reasons[i] for i in back.tolist())

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
        study=study,
        values=values,
        columns=cols,
        feasible=feasible,
        reason=reason,
        verified=verified,
        mujoco=mj,
        mujoco_reason=tuple(mj_reason),
        engine=what,
        chunks=len(ref_chunks),
        resumed=resumed,
        timing=dict(timing.stages),
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
