"""One run of an optimization: differential evolution to settle the basin, then the polish.

:func:`search` is what every run of :mod:`.optimize` does (a single objective's seeds, each
end and level of a Pareto front, the front's knee): scipy's ``differential_evolution``
(vectorized, deferred updating: each generation one batch on the engine; the feasibility rules
for constraints) until it is **settled**, then the local polish (:mod:`.polish`) from its best
point until that is **converged**.

Settled: scipy's spread test holds (the population's objective values within ``tol`` /
``atol``), or the best feasible value has not improved by more than ``ftol`` of it (plus
``atol``) over the last ``stall`` generations, or the population has gathered within
:data:`COLLAPSED` of every range (an objective whose optimum is 0 keeps improving by relative
amounts for ever while its population closes in). A run that reaches its ``generations`` while
still improving is not settled: its result is reported as not converged, polish or not.
"""

from __future__ import annotations

import math
import time
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .polish import Polished, polish
from .spec import Study

# Scores of a batch -> (what the run minimizes (S,), violation (S,)).
Objective = Callable[[Any], tuple[np.ndarray, np.ndarray]]
# The archive's recorder: (run index, generation, values (S, P), scores, minimized, violation).
Record = Callable[[int, int, np.ndarray, Any, np.ndarray, np.ndarray], None]
Progress = Callable[[str, int, int, float], None]  # (run name, generation, generations, best so far)

COLLAPSED = 1e-4  # a population within this fraction of every range has settled on its basin
SIGMA0 = (1e-3, 0.05)  # the polish's first step, a fraction of the ranges: the population's spread, within


@dataclass(kw_only=True)
class Run:
    """One run: its best feasible candidate ``x`` (P,) and objective ``f`` (what was
    minimized), ``seed``, generations and evaluations (the polish's included), how the global
    search stopped (``stopped_by``: 'spread', 'stall', 'collapse' or 'generations'), the ``polish`` (None:
    none), whether the run ``converged`` (settled, then polished to its tolerance), and
    ``history``: (generation, evaluations so far, best feasible objective so far, wall seconds
    since the run started) per generation of the search and then of the polish (NaN until a
    feasible candidate appears)."""

    name: str
    x: np.ndarray
    f: float
    generations: int
    evaluations: int
    converged: bool
    history: list[tuple[int, int, float, float]] = field(default_factory=list)
    seed: int = 0
    stopped_by: str = "generations"
    polish: Polished | None = None
    search_generations: int = 0

    @property
    def settled(self) -> bool:
        return self.stopped_by in ("spread", "stall", "collapse")

    def why_not(self) -> str:
        """Why this run did not converge ('' if it did)."""
        if self.converged:
            return ""
        if not self.settled:
            return f"{self.name}: still improving at its last generation ({self.search_generations})"
        if self.polish is not None and not self.polish.converged:
            return (
                f"{self.name}: the polish used its {self.polish.evaluations:,} evaluations with its step at "
                f"{self.polish.step:.2g} of the ranges"
            )
        return f"{self.name}: not polished"


def search(
    study: Study,
    score: Callable[[np.ndarray], Any],
    record: Record,
    index: int,
    name: str,
    objective: Objective,
    init: np.ndarray | None,
    seed: int,
    progress: Progress | None,
    polish_score: Callable[[np.ndarray], Any] | None = None,
) -> Run:
    """One run (see the module docstring): ``score`` scores a batch (S, P) of candidates (file
    units) on the engine, ``polish_score`` the polish's smaller batches (default ``score``);
    every batch evaluated goes to ``record``; ``objective`` maps scores to what is minimized;
    ``init`` the first generation (None: a scrambled Sobol or Latin hypercube sample from
    ``seed``, as the study's ``init`` says)."""
    from scipy.optimize import (
        NonlinearConstraint,
        differential_evolution,
    )  # here: scipy.optimize, only for a search

    opt = study.optimize
    assert opt is not None
    lo = np.array([v.low for v in study.varied])
    hi = np.array([v.high for v in study.varied])
    P = len(lo)
    cache: dict[bytes, tuple[float, float]] = {}
    t0 = time.perf_counter()
    run = Run(name=name, x=np.full(P, np.nan), f=math.inf, generations=0, evaluations=0, converged=False, seed=seed)
    gen = -1
    improved_at = [0, math.inf]  # generation of the last improvement beyond ftol, and the value then

    def evaluate(xT: np.ndarray) -> list[bytes]:
        nonlocal gen
        X = np.atleast_2d(np.asarray(xT, dtype=float).T if np.ndim(xT) == 2 else xT)
        keys = [x.tobytes() for x in X]
        todo = [i for i, k in enumerate(keys) if k not in cache]
        if todo:
            gen += 1
            Xn = X[todo]
            s = score(Xn)
            f, viol = objective(s)
            record(index, gen, Xn, s, f, viol)
            run.evaluations += len(Xn)
            for i, fi, vi in zip(todo, f, viol, strict=True):
                cache[keys[i]] = (float(fi), float(vi))
            _better(run, Xn, f, viol)
            if run.f < improved_at[1] - (
                opt.ftol * abs(improved_at[1]) + opt.atol if math.isfinite(improved_at[1]) else 0
            ):
                improved_at[:] = [gen, run.f]
            run.history.append((gen, run.evaluations, _shown(run.f), time.perf_counter() - t0))
            run.generations = gen
            if progress:
                progress(name, gen, opt.generations, run.f)
        return keys

    def violation(xT: np.ndarray) -> np.ndarray:
        return np.array([[cache[k][1] for k in evaluate(xT)]])

    def func(xT: np.ndarray) -> np.ndarray:
        return np.array([cache[k][0] for k in evaluate(xT)])

    def stalled(intermediate_result: Any) -> bool:
        # Called after every generation: the best feasible value unchanged (within ftol) over
        # the last `stall` generations, or the population gathered within COLLAPSED of every
        # range, ends the run as settled.
        if not math.isfinite(run.f):
            return False
        if gen - improved_at[0] >= opt.stall:
            run.stopped_by = "stall"
            return True
        pop = getattr(intermediate_result, "population", None)
        if pop is not None and float((np.ptp(np.asarray(pop), axis=0) / (hi - lo)).max()) <= COLLAPSED:
            run.stopped_by = "collapse"
            return True
        return False

    if init is None:
        init = first_generation(study, seed, opt.population)
    # The file's design in place of the sample's first member (scipy's x0), where asked: a
    # search then holds at least the design it was asked to improve.
    x0 = np.array([v.param.nominal for v in study.varied]) if opt.start == "file" else None
    with warnings.catch_warnings():
        # scipy warns when it finds nothing feasible (we say so) or stops by the callback.
        warnings.simplefilter("ignore", UserWarning)
        res = differential_evolution(
            func,
            list(zip(lo, hi, strict=True)),
            maxiter=opt.generations,
            tol=opt.tol,
            atol=opt.atol,
            init=init,
            x0=x0,
            rng=np.random.default_rng(seed + index),
            polish=False,
            vectorized=True,
            updating="deferred",
            constraints=NonlinearConstraint(violation, -np.inf, 0.0),
            callback=stalled,
        )
    if run.stopped_by == "generations" and res.nit < opt.generations:
        run.stopped_by = "spread"  # scipy's own test ended it before its last generation
    run.search_generations = int(res.nit)  # scipy's generations after the first population
    if opt.polish_evaluations > 0 and math.isfinite(run.f):
        _polish(
            study, run, polish_score or score, record, index, objective, np.asarray(res.population), seed, t0, progress
        )
    run.converged = run.settled and (
        (run.polish is None and opt.polish_evaluations == 0) or bool(run.polish and run.polish.converged)
    )
    return run


def first_generation(study: Study, seed: int, count: int) -> np.ndarray:
    """(count, P) the first ``count`` candidates of a run's first generation drawn from ``seed``
    (file units): a scrambled Sobol or Latin hypercube sample of the ranges, as the study's
    ``init`` says."""
    from scipy.stats import qmc  # here: scipy.stats, only for a first generation

    opt = study.optimize
    assert opt is not None
    lo = np.array([v.low for v in study.varied])
    hi = np.array([v.high for v in study.varied])
    P = len(lo)
    engine: qmc.QMCEngine = (
        qmc.Sobol(P, scramble=True, seed=seed) if opt.init == "sobol" else qmc.LatinHypercube(P, seed=seed)
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # Sobol warns for counts that are no power of 2
        out: np.ndarray = qmc.scale(engine.random(count), lo, hi)
    return out


def _polish(
    study: Study,
    run: Run,
    score: Callable[[np.ndarray], Any],
    record: Record,
    index: int,
    objective: Objective,
    population: np.ndarray,
    seed: int,
    t0: float,
    progress: Progress | None,
) -> None:
    """Polish ``run``'s best point (:func:`.polish.polish`), recording every generation."""
    opt = study.optimize
    assert opt is not None
    lo = np.array([v.low for v in study.varied])
    span = np.array([v.high for v in study.varied]) - lo
    gen = [run.generations]

    def batch(U: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        X = lo + U * span
        s = score(X)
        f, viol = objective(s)
        gen[0] += 1
        record(index, gen[0], X, s, f, viol)
        run.evaluations += len(X)
        _better(run, X, f, viol)
        run.history.append((gen[0], run.evaluations, _shown(run.f), time.perf_counter() - t0))
        if progress:
            progress(run.name + " (polish)", gen[0], gen[0], run.f)
        return f, viol

    spread = float(np.median(np.std((population - lo) / span, axis=0))) if len(population) > 1 else SIGMA0[1]
    sigma0 = min(max(spread, SIGMA0[0]), SIGMA0[1])
    start = run.f
    run.polish = polish(
        batch,
        (run.x - lo) / span,
        start,
        sigma0=sigma0,
        evaluations=opt.polish_evaluations,
        seed=seed * 7919 + index + 1,
        xtol=opt.xtol,
        atol=opt.atol,
    )
    run.generations = gen[0]


def _better(run: Run, X: np.ndarray, f: np.ndarray, viol: np.ndarray) -> None:
    ok = np.flatnonzero((viol <= 0) & np.isfinite(f))
    if len(ok):
        j = ok[np.argmin(f[ok])]
        if f[j] < run.f:
            run.f, run.x = float(f[j]), X[j].copy()


def _shown(f: float) -> float:
    return f if math.isfinite(f) else math.nan
