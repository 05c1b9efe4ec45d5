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


def nominal_values(study: Study) -> np.ndarray:
    """(1, P) the mechanism file's values of the varied parameters."""
    return np.array([[p.nominal for p in study.params]])


# The last few studies' nominal batches: (study, its content's digest, batch).
_NOMINAL: list[tuple[Study, bytes, _batch.Batch]] = []


def _nominal(study: Study) -> _batch.Batch:
    """The nominal design's batch, solved once per study in this process (an optimization
    evaluates many small generations of the same study). Found by identity first (in process
    and in an actor the same study comes every time, and pickling it to hash is a noticeable
    share of a small generation), then by content: a task on a cluster brings its own copy."""
    for s, _, b in _NOMINAL:
        if s is study:
            return b
    # What the batch depends on (not the whole study: a designer's metric may be a lambda).
    what = (study.mechanism, tuple(study.params), study.per_turn)
    key = hashlib.sha256(pickle.dumps(what, protocol=pickle.HIGHEST_PROTOCOL)).digest()
    same = [i for i, (_, k, _) in enumerate(_NOMINAL) if k == key]
    if same:
        b = _NOMINAL.pop(same[0])[2]  # back in front, with this copy of the study
    else:
        b = _batch.solve_batch(study.mechanism, study.params, nominal_values(study), study.per_turn)
    _NOMINAL.insert(0, (study, key, b))
    del _NOMINAL[4:]
    return b


def reference_chunk(study: Study, values: np.ndarray) -> Evaluated:
    """Feasibility and every metric of the variants ``values`` ((n, P), file units)."""
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


class StudyWorker:
    """One study held on a worker for many small batches of its variants: a Dask actor.

    An optimization evaluates a generation (a fraction of a second of work) at a time. As
    tasks, every generation pays the scheduler's round trip (scheduler, client and workers
    share the cores); an actor's method is called from the client straight to its worker, a
    few times cheaper, and the study travels once, not with every task."""

    def __init__(self, study: Study):
        self.study = study

    def reference(self, values: np.ndarray) -> Evaluated:
        """:func:`reference_chunk` of the held study."""
        return reference_chunk(self.study, values)


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
    from ..sim import batch as _sim_batch  # here: MuJoCo, not on reference-only workers

    mechs = [_batch.variant(study.mechanism, study.params, row) for row in values]
    res = _sim_batch.verify(mechs, threads=threads)
    return Verified(
        np.array([r.passed for r in res], dtype=bool),
        np.array([r.position_error for r in res]) * 1e6,
        np.array([r.loop_gap for r in res]) * 1e6,
        np.array([r.thread_error for r in res]) * 1e6,
        tuple(r.reason or "; ".join(r.failures) for r in res),
    )
