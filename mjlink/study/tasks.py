"""One chunk of a study: the reference metrics of a batch of variants, and their MuJoCo check.

These are the tasks the engine (:mod:`.engine`) hands to Dask workers or runs in process:
plain functions of a :class:`~.spec.Study` and an array of variants, returning plain data,
so that the same chunk gives the same result (bit for bit for the reference) wherever it runs.
"""

from __future__ import annotations

import hashlib
import pickle
from dataclasses import dataclass

import numpy as np

from .. import memory
from ..analysis import metrics as _metrics
from ..reference import batch as _batch
from .spec import Study


@dataclass(frozen=True)
class Evaluated:
    """Reference results of n variants: ``columns`` metric name -> (n,) (NaN where
    infeasible), ``feasible`` (n,) bool, ``reason`` n strings ('' where feasible)."""

    columns: dict[str, np.ndarray]
    feasible: np.ndarray
    reason: tuple[str, ...]


def _keep_freed_memory() -> None:
    """This process's allocator keeps what it frees (:mod:`mjlink.memory`), with one arena: a
    study task runs in a worker thread, one at a time. Runs when a worker starts (the engine's
    warm-up), before the worker's task thread exists, and at every task (a no-op then)."""
    memory.keep_freed_memory()
    memory.one_arena()


def nominal_values(study: Study) -> np.ndarray:
    """(1, P) the mechanism file's values of the varied parameters."""
    return np.array([[p.nominal for p in study.params]])


_NOMINAL: list[tuple[bytes, _batch.Batch]] = []  # the last few studies' nominal batches, by content


def _nominal(study: Study) -> _batch.Batch:
    """The nominal design's batch, solved once per study in this process (an optimization
    evaluates many small generations of the same study). Found by the study's content: on a
    cluster every task brings its own copy of the study."""
    key = hashlib.sha256(pickle.dumps(study, protocol=pickle.HIGHEST_PROTOCOL)).digest()
    for k, b in _NOMINAL:
        if k == key:
            return b
    b = _batch.solve_batch(study.mechanism, study.params, nominal_values(study), study.per_turn)
    _NOMINAL.insert(0, (key, b))
    del _NOMINAL[4:]
    return b


def reference_chunk(study: Study, values: np.ndarray) -> Evaluated:
    """Feasibility and every metric of the variants ``values`` ((n, P), file units)."""
    _keep_freed_memory()
    params = study.params
    nominal = _nominal(study)
    b = _batch.solve_batch(study.mechanism, params, values, study.per_turn)
    f = _metrics.feasibility(b)
    if not f.feasible.all() and any(m.needs_loads for m in study.metrics):
        # Loads on a geometry that does not close can be singular: infeasible variants are
        # evaluated as the nominal design and their columns blanked.
        safe = np.where(f.feasible[:, None], values, nominal_values(study))
        b = _batch.solve_batch(study.mechanism, params, safe, study.per_turn)
    cols = _metrics.compute(study.metrics, b, nominal)
    for v in cols.values():
        v[~f.feasible] = np.nan
    return Evaluated(cols, f.feasible, f.reason)


@dataclass(frozen=True)
class Verified:
    """MuJoCo's check of n variants: ``passed`` (n,) bool; ``position_error``,
    ``loop_gap``, ``thread_error`` (n,) um (NaN where not applicable); ``reason`` n strings
    (what missed a threshold, or why the model could not run; '' where it passed)."""

    passed: np.ndarray
    position_error: np.ndarray
    loop_gap: np.ndarray
    thread_error: np.ndarray
    reason: tuple[str, ...]


def mujoco_chunk(study: Study, values: np.ndarray, threads: int = 1) -> Verified:
    """Every variant of ``values`` ((n, P), file units) built in MuJoCo and run over one
    period at constant speed in one batched rollout, compared with the reference."""
    from ..sim import batch as _sim_batch

    _keep_freed_memory()

    mechs = [_batch.variant(study.mechanism, study.params, row) for row in values]
    res = _sim_batch.verify(mechs, threads=threads)
    return Verified(
        np.array([r.passed for r in res], dtype=bool),
        np.array([r.position_error for r in res]) * 1e6,
        np.array([r.loop_gap for r in res]) * 1e6,
        np.array([r.thread_error for r in res]) * 1e6,
        tuple(r.reason or "; ".join(r.failures) for r in res),
    )
