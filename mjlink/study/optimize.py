"""Optimal synthesis on the study engine: differential evolution, then a local polish.

An ``[optimize]`` study searches the [[parameter]] ranges for the design that minimizes (or
maximizes) a metric or a weighted sum of metric columns, subject to feasibility (assembly over
the whole period, the dead-point limits of ``check``) and the study's [[bound]]s; or, with
``pareto = [a, b]``, for a Pareto front of two metric columns (both minimized).

Each run (:mod:`.search`) is scipy's ``differential_evolution`` with ``vectorized=True`` and
deferred updating, each generation's candidates one (S, P) batch that the engine cuts into
chunks and runs on the Dask cluster (or in this process) as a sampled study's variants; then,
once the population has settled, a local CMA-ES polish from its best point (:mod:`.polish`), in
this process (its generations are small batches; the reference gives the same bits wherever it
runs). Constraints go in as the feasibility rules (Lampinen's: a feasible candidate beats an
infeasible one, two infeasible ones compare by their violation, two feasible ones by the
objective), so no penalty constant can let an infeasible design win. Why DE: it needs no
gradients (metrics such as a peak or a dwell are not smooth in the parameters), it treats a
whole generation as one batch, it is deterministic for a seed, and scipy keeps it well tested.

**Convergence.** A run is converged when its global search settled (scipy's spread test, or no
improvement of the best feasible value beyond ``ftol`` over ``stall`` generations) and its polish
then converged (its step below ``xtol`` of every range, or its values unchanging); a run that
used its generations or its polish budget first is not. A single objective is searched from
``seeds`` seeds (``seed``, ``seed + 1``, ...): the winner is the best, and the result is
converged only if every seed's run converged and their optima agree within ``ftol`` (relative,
plus ``atol``); how far they differ is reported either way (:class:`SeedSpread`).

Two objectives: the epsilon-constraint method. One run minimizes each column (the front's
ends); ``points - 2`` more minimize the first column subject to the second staying below levels
spaced evenly between the ends (each run's first generation holds the optima found so far).
Each front point is a constrained optimum in its own right. The winner is the front's **knee**,
defined on the front normalized by its ends: with each column scaled to 0 at its best end and 1
at its worst, the knee is the design nearest the ideal point (0, 0). It is found by a run of
its own, minimizing that distance over all feasible designs from the two ends, so it depends
on the ends alone, not on how many other front points were computed.

Robust mode (``[robust]``): a candidate is evaluated on ``samples`` tolerance deviations of
its parameters (each [[parameter]]'s ``tolerance``: uniform over +-tolerance, or normal with
sigma = tolerance / 3), the same deviations for every candidate (common random numbers: the
objective is a deterministic, comparable function of the candidate). A [[parameter]] with a
tolerance and no range is an operating condition (a needle tension the head is set to, a
thread): never searched, held at the file's value, deviated over the same samples, so the
design is judged over the conditions it will meet (Taguchi's noise factors); conditions given
``levels`` are crossed, every combination of their levels a sample (Taguchi's outer array),
so that the corners of their box, where bounds bind, are judged. Each objective column
becomes its mean plus ``k`` standard deviations over the samples; the candidate is feasible
only if every sample is, and a bound must hold for every sample.

Reproducible: the seeds fix the initial populations (scrambled Sobol or Latin hypercube),
scipy's random streams and the polish's; the reference is elementwise, so the result does not
depend on the engine, the workers or the chunking (tested).
"""

from __future__ import annotations

import dataclasses
import math
import time
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..errors import MjlinkError
from . import sampling
from .caveats import SAME_POINT, Caveats, SeedSpread, caveats, seed_spread
from .engine import Pool, _map
from .search import COLLAPSED, Progress, Run, search
from .spec import Study
from .tasks import Evaluated, reference_chunk

__all__ = ["Archive", "Evaluator", "OptimizeError", "Result", "Run", "Scores", "budget", "deviations", "run"]

INFEASIBLE = 1.0e6  # the violation of a candidate that does not assemble (bounds add relative excesses)
CHUNK_ROWS = 100_000  # variants x crank angles per reference task, at most


class OptimizeError(MjlinkError):
    """An optimization found no feasible design, or cannot run."""


@dataclass(frozen=True)
class Scores:
    """Scores of S candidates. ``objective`` (S,) what the run minimizes: the weighted sum,
    negated for 'max' (robust: its mean + k std over the tolerance samples); ``columns``
    metric -> (S,) (robust: the mean over the samples, but mean + k std for a Pareto study's
    two columns, which are what it minimizes); ``violation`` (S,) 0 where feasible and within
    bounds; ``reason`` why not."""

    objective: np.ndarray
    columns: dict[str, np.ndarray]
    violation: np.ndarray
    reason: tuple[str, ...]


@dataclass(frozen=True, kw_only=True)
class Archive:
    """Every candidate evaluated: ``run`` index, ``generation``, ``values`` (E, P) file
    units, ``columns`` metric -> (E,), ``objective`` (E,), ``violation`` (E,), ``reason``."""

    run: np.ndarray
    generation: np.ndarray
    values: np.ndarray
    columns: dict[str, np.ndarray]
    objective: np.ndarray
    violation: np.ndarray
    reason: tuple[str, ...]


@dataclass(frozen=True, kw_only=True)
class Result:
    """An optimization's outcome.

    ``winner`` (P,) parameter values (file units); ``objective`` its value (in the objective's
    unit, the sense as written); ``columns`` its metric columns (robust: mean + k std);
    ``nominal_columns`` the same design's columns without deviations; ``front`` (F, P) the
    Pareto designs with ``front_columns`` (F,) each (None for one objective), sorted by the
    first column; ``file_objective`` and ``file_columns`` the mechanism file's own design,
    scored the same way (NaN where it is infeasible or outside a bound); ``runs``; ``archive``;
    ``evaluations`` variants evaluated (a robust candidate counts its samples); ``engine``;
    ``timing`` wall seconds per stage; ``converged`` (see the module docstring) with
    ``criterion`` (the test, in words) and ``not_converged`` (why not, one line per run or the
    seeds' disagreement); ``caveats`` on the winner (:class:`.caveats.Caveats`).
    """

    study: Study
    winner: np.ndarray
    objective: float
    columns: dict[str, float]
    nominal_columns: dict[str, float]
    front: np.ndarray | None
    front_columns: dict[str, np.ndarray] | None
    file_objective: float
    file_columns: dict[str, float]
    runs: list[Run]
    archive: Archive
    evaluations: int
    engine: str
    timing: dict[str, float]
    converged: bool = False
    criterion: str = ""
    not_converged: tuple[str, ...] = ()
    caveats: Caveats = field(default_factory=Caveats)


def deviations(study: Study) -> np.ndarray:
    """(R, P + C) the robust mode's tolerance deviations of the P searched parameters and the
    C operating conditions (file units; one row of zeros without ``[robust]``), drawn once
    from the robust seed (:func:`.sampling.robust_deviations`): the same for every candidate."""
    rb = study.robust
    every = study.varied + study.conditions
    if rb is None:
        return np.zeros((1, len(every)))
    return sampling.robust_deviations(every, rb.samples, rb.seed)


def needed(study: Study) -> tuple[Any, ...]:
    """The study's metrics whose columns the search uses: the objective's (or the Pareto
    columns) and the [[bound]]s'."""
    opt = study.optimize
    assert opt is not None
    used = {c for c, _ in opt.objective} | set(opt.pareto or ()) | {b.column for b in study.bounds}
    return tuple(m for m in study.metrics if any(c.name in used for c in m.columns()))


class Evaluator:
    """Scores batches of candidates on the engine (a Dask client, or this process).

    On a cluster the study is held by an actor on every worker (:class:`.engine.Pool`, made at
    the first batch): a generation is too small a batch to pay the scheduler's round trip.
    Use as a context manager, or call :meth:`close`, to release them.

    The search computes only the metrics it needs (those of the objective or the Pareto
    columns and of the [[bound]]s, :func:`needed`); ``full=True`` computes every metric of the
    study (for the designs reported: the winner, the front, the file's design), in this process.
    A metric the search does not need is NaN in the search's scores.

    Args:
      study: an optimize study.
      client: a ``distributed.Client`` or None (this process).
      workers: how many chunks a batch is cut into at least (the cluster's workers).
    """

    def __init__(self, study: Study, client: Any = None, workers: int = 1):
        if study.optimize is None:
            raise OptimizeError(f"{study.name}: not an optimization (no [optimize] table)")
        self.study = study
        # What the reference evaluates: the searched parameters, then the conditions.
        self.every = dataclasses.replace(study, varied=study.varied + study.conditions, conditions=())
        self.search = dataclasses.replace(self.every, metrics=needed(study))
        self.held = np.array([v.param.nominal for v in study.conditions])
        self.client = client
        self.workers = max(1, workers)
        self.dev = deviations(study)
        self.evaluations = 0
        self.seconds = 0.0
        self._pool: Any = None

    def __enter__(self) -> Evaluator:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        """Release the cluster's actors (nothing in process)."""
        if self._pool is not None:
            self._pool.close()
            self._pool = None

    def samples(self, X: np.ndarray, robust: bool = True) -> np.ndarray:
        """(S * R, P + C) the rows that judge candidates X (S, P): each with the conditions at
        the file's values, plus each of the R deviations (``robust=False``: none)."""
        S = len(X)
        rows = np.concatenate([X, np.broadcast_to(self.held, (S, len(self.held)))], axis=1)
        dev = self.dev if robust else np.zeros((1, rows.shape[1]))
        out: np.ndarray = (rows[:, None, :] + dev[None]).reshape(S * len(dev), rows.shape[1])
        return out

    def rows(self, X: np.ndarray, full: bool = False) -> Evaluated:
        """The reference's metrics of arbitrary rows (n, P + C) (the searched parameters, then
        the conditions; file units), on the engine (those the search needs; ``full``: every
        metric, in this process)."""
        study = self.every if full else self.search
        n = len(X)
        # Equal chunks, a multiple of the workers in number, none above CHUNK_ROWS rows of
        # variants x angles (the reference's memory per task).
        cap = max(1, CHUNK_ROWS // self.study.per_turn)
        count = self.workers * max(1, -(-n // (self.workers * cap)))
        size = max(1, -(-n // count))
        parts = [(i, min(i + size, n)) for i in range(0, n, size)]
        got: dict[tuple[int, int], Evaluated] = {}
        t = time.perf_counter()
        if self.client is None or full:
            _map(None, reference_chunk, study, X, parts, got.__setitem__, {})
        else:
            if self._pool is None:
                self._pool = Pool(self.client, self.search)
            self._pool.reference(X, parts, got.__setitem__)
        self.seconds += time.perf_counter() - t
        self.evaluations += n
        computed = {c.name for c in study.columns}
        cols = {
            c.name: np.concatenate([got[k].columns[c.name] for k in parts])
            if c.name in computed
            else np.full(n, np.nan)
            for c in self.study.columns
        }
        return Evaluated(
            cols,
            np.concatenate([got[k].feasible for k in parts]),
            tuple(r for k in parts for r in got[k].reason),
        )

    def score(self, X: np.ndarray, robust: bool = True, full: bool = False) -> Scores:
        """Scores of candidates X (S, P), file units (``robust=False``: at nominal dimensions
        even in robust mode; ``full``: every metric, see :meth:`rows`)."""
        st = self.study
        opt = st.optimize
        assert opt is not None
        S = len(X)
        R = len(self.dev) if robust else 1
        ev = self.rows(self.samples(X, robust), full)
        feasible = ev.feasible.reshape(S, R).all(axis=1)
        k = st.robust.k if (st.robust is not None and robust) else 0.0

        def stat(a: np.ndarray) -> np.ndarray:  # (S, R) -> (S,): what is minimized
            return a[:, 0] if R == 1 else a.mean(axis=1) + k * a.std(axis=1, ddof=1)

        cols: dict[str, np.ndarray] = {}
        with np.errstate(all="ignore"):
            for c, a in ev.columns.items():
                a = a.reshape(S, R)
                cols[c] = stat(a) if (opt.pareto and c in opt.pareto) else a.mean(axis=1)
            violation = np.zeros(S)
            reason = [""] * S
            for b in st.bounds:
                a = ev.columns[b.column].reshape(S, R)
                scale = max(abs(b.low or 0.0), abs(b.high or 0.0), 1e-12)
                excess = np.zeros_like(a)
                if b.low is not None:
                    excess = np.maximum(excess, (b.low - a) / scale)
                if b.high is not None:
                    excess = np.maximum(excess, (a - b.high) / scale)
                excess = np.where(np.isfinite(a), excess, INFEASIBLE).max(axis=1)
                violation += excess
                for i in np.flatnonzero(excess > 0):
                    if not reason[i]:
                        reason[i] = f"outside {b.text()}"
            names = [c for c, _ in opt.objective] + list(opt.pareto or ())
            for c in names:
                bad = ~np.isfinite(cols[c])
                violation[bad] = np.maximum(violation[bad], INFEASIBLE)
            for i in np.flatnonzero(~feasible):
                j = int(np.argmin(ev.feasible[i * R : (i + 1) * R]))  # the first infeasible sample
                violation[i] = INFEASIBLE
                reason[i] = ev.reason[i * R + j] + (" (a tolerance sample)" if R > 1 else "")
            if opt.pareto:
                obj = np.zeros(S)
            else:
                per = sum((w * ev.columns[c].reshape(S, R) for c, w in opt.objective), np.zeros((S, R)))
                obj = stat(-per if opt.sense == "max" else per)
        return Scores(np.asarray(obj, dtype=float), cols, violation, tuple(reason))


@dataclass(kw_only=True)
class _Book:
    """What every run records: the archive's rows as they arrive."""

    run: list[np.ndarray] = field(default_factory=list)
    generation: list[np.ndarray] = field(default_factory=list)
    values: list[np.ndarray] = field(default_factory=list)
    columns: list[dict[str, np.ndarray]] = field(default_factory=list)
    objective: list[np.ndarray] = field(default_factory=list)
    violation: list[np.ndarray] = field(default_factory=list)
    reason: list[str] = field(default_factory=list)

    def add(self, run: int, gen: int, X: np.ndarray, s: Scores, objective: np.ndarray, violation: np.ndarray) -> None:
        self.run.append(np.full(len(X), run))
        self.generation.append(np.full(len(X), gen))
        self.values.append(X.copy())
        self.columns.append(s.columns)
        self.objective.append(objective)
        self.violation.append(violation)
        self.reason += list(s.reason)

    def archive(self, study: Study) -> Archive:
        P = len(study.varied)
        names = [c.name for c in study.columns]
        cat = np.concatenate
        return Archive(
            run=cat(self.run) if self.run else np.zeros(0, int),
            generation=cat(self.generation) if self.generation else np.zeros(0, int),
            values=cat(self.values) if self.values else np.zeros((0, P)),
            columns={c: cat([d[c] for d in self.columns]) if self.columns else np.zeros(0) for c in names},
            objective=cat(self.objective) if self.objective else np.zeros(0),
            violation=cat(self.violation) if self.violation else np.zeros(0),
            reason=tuple(self.reason),
        )


Objective = Callable[[Scores], tuple[np.ndarray, np.ndarray]]  # -> (minimized value, violation)


@dataclass(frozen=True)
class Budget:
    """An optimization's size at most: ``runs`` of at most ``generations`` generations of
    ``population`` candidates and a polish of ``polish`` evaluations each, every candidate
    evaluated at ``samples`` tolerance samples (1 without [robust]); ``verified`` designs
    checked in MuJoCo at the end."""

    runs: int
    population: int
    generations: int
    polish: int
    samples: int
    verified: int

    @property
    def candidates(self) -> int:
        return self.runs * (self.population * (self.generations + 1) + self.polish)

    @property
    def evaluations(self) -> int:
        """Variants evaluated by the reference at most (a candidate counts its samples)."""
        return self.candidates * self.samples

    @property
    def per_generation(self) -> int:
        """Variants of the largest batch (a generation's candidates x samples)."""
        return self.population * self.samples

    def describe(self) -> str:
        robust = f" x {self.samples} tolerance samples" if self.samples > 1 else ""
        polish = f" + a polish of {self.polish:,}" if self.polish else ""
        return (
            f"optimization of {self.runs} run(s) x (population {self.population} x at most {self.generations} "
            f"generations{polish}){robust}"
        )


def budget(study: Study) -> Budget:
    """What ``study``'s optimization costs at most (for the plan, :mod:`.plan`)."""
    opt = study.optimize
    assert opt is not None
    runs = opt.points + 1 if opt.pareto else opt.seeds
    R = study.robust.samples if study.robust else 1
    return Budget(
        runs, opt.population, opt.generations, opt.polish_evaluations, R, 1 + (opt.points + 1 if opt.pareto else 0)
    )


def run(
    study: Study,
    *,
    client: Any = None,
    workers: int = 1,
    engine: str = "in process",
    progress: Progress | None = None,
) -> Result:
    """Run an ``[optimize]`` study.

    Args:
      study: the study (its ``optimize`` set).
      client: a ``distributed.Client`` (None: this process).
      workers: the cluster's workers (a generation is cut into at least that many tasks).
      engine: a description of the engine, recorded.
      progress: called after each generation with (run, generation, generations, best).
    Returns:
      The :class:`Result`.
    Raises:
      OptimizeError: no feasible candidate was found (the message gives the commonest reason).
    """
    opt = study.optimize
    if opt is None:
        raise OptimizeError(f"{study.name}: not an optimization (no [optimize] table)")
    with Evaluator(study, client, workers) as ev, Evaluator(study, None, 1) as here:
        return _run(study, ev, here, engine, progress)


def _run(study: Study, ev: Evaluator, here: Evaluator, engine: str, progress: Progress | None) -> Result:
    opt = study.optimize
    assert opt is not None
    t0 = time.perf_counter()
    book = _Book()
    runs: list[Run] = []

    def one(index: int, name: str, objective: Objective, init: np.ndarray | None, seed: int) -> Run:
        r = search(study, ev.score, book.add, index, name, objective, init, seed, progress, polish_score=here.score)
        runs.append(r)
        return r

    def weighted(s: Scores) -> tuple[np.ndarray, np.ndarray]:
        return s.objective, s.violation

    spread: SeedSpread | None = None
    if opt.pareto is None:
        for k in range(opt.seeds):
            one(k, f"run {k + 1} of {opt.seeds}" if opt.seeds > 1 else "optimum", weighted, None, opt.seed + k)
        _feasible_or_fail(study, runs, book, every=False)
        best = min(runs, key=lambda r: r.f)
        winner = best.x
        front = None
        if opt.seeds > 1:
            spread = seed_spread(study, runs)
        objective: Objective = weighted
    else:
        c1, c2 = opt.pareto

        def single(c: str) -> Objective:
            return lambda s: (s.columns[c], s.violation)

        one(0, f"min {c1}", single(c1), None, opt.seed)
        one(1, f"min {c2}", single(c2), None, opt.seed)
        _feasible_or_fail(study, runs, book)
        ends = ev.score(np.stack([runs[0].x, runs[1].x]))
        hi2, lo2 = float(ends.columns[c2][0]), float(ends.columns[c2][1])
        hi1, lo1 = float(ends.columns[c1][1]), float(ends.columns[c1][0])
        span2 = max(hi2 - lo2, 1e-12 * max(abs(hi2), 1.0))
        span1 = max(hi1 - lo1, 1e-12 * max(abs(hi1), 1.0))
        anchors = [runs[0].x, runs[1].x]
        warm = list(anchors)
        for j, eps in enumerate(np.linspace(lo2, hi2, opt.points)[1:-1]):

            def capped(s: Scores, eps: float = float(eps)) -> tuple[np.ndarray, np.ndarray]:
                over = np.where(np.isfinite(s.columns[c2]), np.maximum(s.columns[c2] - eps, 0.0) / span2, INFEASIBLE)
                return s.columns[c1], s.violation + over

            r = one(j + 2, f"min {c1} with {c2} <= {eps:.6g}", capped, _warm_init(study, warm, j + 2), opt.seed)
            if np.all(np.isfinite(r.x)):
                warm.append(r.x)

        def knee(s: Scores) -> tuple[np.ndarray, np.ndarray]:
            n1 = (s.columns[c1] - lo1) / span1
            n2 = (s.columns[c2] - lo2) / span2
            d = np.hypot(np.maximum(n1, 0.0), np.maximum(n2, 0.0))
            return np.where(np.isfinite(d), d, np.inf), s.violation

        # From the two ends only: the knee depends on them, not on the points between.
        k = one(opt.points, "knee", knee, _warm_init(study, anchors, opt.points), opt.seed)
        objective = knee
        cand = np.stack([r.x for r in runs if np.all(np.isfinite(r.x))])
        sc = ev.score(cand)
        keep = _nondominated(sc.columns[c1], sc.columns[c2]) & (sc.violation <= 0)
        front = cand[keep][np.argsort(sc.columns[c1][keep], kind="stable")]
        winner = k.x if np.all(np.isfinite(k.x)) else front[len(front) // 2]
        if not any(np.array_equal(winner, x) for x in front):  # a knee a front point dominates (within rounding)
            winner = front[int(np.argmin([np.linalg.norm(x - winner) for x in front]))]
    t_search = time.perf_counter() - t0
    final = here.score(winner[None], full=True)
    nominal = here.score(winner[None], robust=False, full=True)
    if final.violation[0] > 0:  # pragma: no cover - the winner was chosen among feasible candidates
        raise OptimizeError(f"{study.name}: the winner is infeasible: {final.reason[0]}")
    value = float(final.objective[0]) * (-1.0 if opt.sense == "max" else 1.0) if opt.pareto is None else math.nan
    file_values = np.array([[p.nominal for p in study.params]])
    fs0 = here.score(file_values, full=True)
    file_value = math.nan
    if opt.pareto is None and fs0.violation[0] <= 0:
        file_value = float(fs0.objective[0]) * (-1.0 if opt.sense == "max" else 1.0)
    front_cols = None
    if front is not None:
        fs = here.score(front, full=True)
        front_cols = {c: v.copy() for c, v in fs.columns.items()}
    why = tuple(r.why_not() for r in runs if not r.converged)
    if spread is not None and not spread.agree:
        why += (spread.text(),)
    notes = caveats(study, here, winner, objective, spread)
    return Result(
        study=study,
        winner=winner,
        objective=value,
        columns={c: float(v[0]) for c, v in final.columns.items()},
        nominal_columns={c: float(v[0]) for c, v in nominal.columns.items()},
        front=front,
        front_columns=front_cols,
        file_objective=file_value,
        file_columns={c: float(v[0]) for c, v in fs0.columns.items()},
        runs=runs,
        archive=book.archive(study),
        evaluations=ev.evaluations + here.evaluations,
        engine=engine,
        timing={"search": t_search, "reference": ev.seconds + here.seconds, "total": time.perf_counter() - t0},
        converged=not why,
        criterion=criterion(study),
        not_converged=why,
        caveats=notes,
    )


def criterion(study: Study) -> str:
    """The convergence test of ``study``'s optimization, in words."""
    opt = study.optimize
    assert opt is not None
    settle = (
        f"each run's differential evolution settles (scipy's spread test, tol {opt.tol:g}, atol {opt.atol:g}; or "
        f"no improvement of the best feasible value by more than {opt.ftol:g} of it over {opt.stall} generations; or "
        f"its population within {COLLAPSED:g} of every range) "
        f"within {opt.generations} generations"
    )
    polish = (
        f", then a local CMA-ES polish from its best point reaches a step below {opt.xtol:g} of every range, or values "
        f"unchanged to 1e-12 of them, within {opt.polish_evaluations:,} evaluations"
        if opt.polish_evaluations
        else " (no polish)"
    )
    seeds = (
        f"; the {opt.seeds} independent runs' optima agree (objectives within {opt.ftol:g} of their value plus atol, or "
        f"parameters within {SAME_POINT:g} of every range)"
        if opt.pareto is None and opt.seeds > 1
        else ""
    )
    return settle + polish + seeds


def _warm_init(study: Study, warm: list[np.ndarray], index: int) -> np.ndarray:
    """An initial population for a front run: a fresh scrambled Sobol sample (seeded by the
    run) with the given optima in place of its first rows, so each run starts from them."""
    from scipy.stats import qmc  # here: scipy.stats, only for a search

    opt = study.optimize
    assert opt is not None
    lo = np.array([v.low for v in study.varied])
    hi = np.array([v.high for v in study.varied])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        pop = qmc.scale(qmc.Sobol(len(lo), scramble=True, seed=opt.seed + index).random(opt.population), lo, hi)
    k = min(len(warm), opt.population // 2)
    pop[:k] = np.clip(np.stack(warm[-k:]), lo, hi)
    return np.asarray(pop)


TIE = 1e-9  # of a column's largest magnitude: two values this close are one value


def _nondominated(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Which points of (a, b) no other point dominates (both minimized); duplicates keep one.
    Values within TIE count as equal: an objective that does not depend on a parameter still
    differs by rounding between designs, and must not make a worse design a front point."""
    n = len(a)
    ta = TIE * max(float(np.nanmax(np.abs(a), initial=0.0)), 1e-300)
    tb = TIE * max(float(np.nanmax(np.abs(b), initial=0.0)), 1e-300)
    keep = np.ones(n, dtype=bool)
    for i in range(n):
        dom = (a <= a[i] + ta) & (b <= b[i] + tb) & ((a < a[i] - ta) | (b < b[i] - tb))
        same = (np.abs(a - a[i]) <= ta) & (np.abs(b - b[i]) <= tb) & (np.arange(n) < i)
        keep[i] = not dom.any() and not same.any()
    return keep


def _feasible_or_fail(study: Study, runs: list[Run], book: _Book, *, every: bool = True) -> None:
    """Fail (one line) unless every run (``every``; else at least one) found a feasible design."""
    found = [bool(np.all(np.isfinite(r.x))) for r in runs]
    if all(found) if every else any(found):
        return
    reasons = [r for r in book.reason if r]
    common = max(set(reasons), key=reasons.count) if reasons else "no candidate met the bounds"
    n = sum(len(v) for v in book.values)
    raise OptimizeError(
        f"{study.name}: no feasible design among {n} candidates (commonest reason: {common}); "
        "widen the [[parameter]] ranges or relax the [[bound]]s"
    )
