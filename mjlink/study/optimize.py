"""Optimal synthesis on the study engine: differential evolution over batches of variants.

An ``[optimize]`` study searches the [[parameter]] ranges for the design that minimizes (or
maximizes) a metric or a weighted sum of metric columns, subject to feasibility (assembly over
the whole period, the dead-point limits of ``check``) and the study's [[bound]]s; or, with
``pareto = [a, b]``, for a Pareto front of two metric columns (both minimized).

The optimizer is scipy's ``differential_evolution`` with ``vectorized=True`` and deferred
updating: each generation's candidates reach the evaluation as one (S, P) array, which the
engine cuts into chunks and runs on the Dask cluster (or in this process) exactly as a
sampled study's variants. Constraints go in as scipy's feasibility rules (Lampinen's: a
feasible candidate beats an infeasible one, two infeasible ones compare by their violation,
two feasible ones by the objective), so no penalty constant can let an infeasible design
win. Why DE: it needs no gradients (metrics such as a peak or a dwell are not smooth in the
parameters), it treats a whole generation as one batch, it is deterministic for a seed, and
scipy (already a dependency) keeps it well tested; CMA-ES would add a dependency and needs
more care with constraints, NSGA-II gives a front of approximate points.

Two objectives: the epsilon-constraint method on the same optimizer. One run minimizes each
column; ``points - 2`` more runs minimize the first column subject to the second staying
below levels spaced evenly between the two runs' values. Each front point is then a
constrained optimum in its own right (not a survivor of a population), and the spacing along
the second objective is even. The winner of a Pareto study is the front's knee: the point
nearest the ideal point (both columns at their front minimum) after scaling each column by
its range on the front.

Robust mode (``[robust]``): a candidate is evaluated on ``samples`` tolerance deviations of
its parameters (each [[parameter]]'s ``tolerance``: uniform over +-tolerance, or normal with
sigma = tolerance / 3), the same deviations for every candidate (common random numbers: the
objective is a deterministic, comparable function of the candidate). Each objective column
becomes its mean plus ``k`` standard deviations over the samples; the candidate is feasible
only if every sample is, and a bound must hold for every sample.

Reproducible: the seed fixes the initial population (scrambled Sobol or Latin hypercube) and
scipy's random stream; the reference is elementwise, so the result does not depend on the
engine, the workers or the chunking (tested).
"""

from __future__ import annotations

import math
import time
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..errors import MjlinkError
from .spec import Study
from .tasks import Evaluated, reference_chunk

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


@dataclass
class Run:
    """One differential-evolution run: its best feasible candidate ``x`` (P,) and objective
    ``f`` (what was minimized), generations and evaluations, whether scipy's convergence test
    stopped it, and ``history``: (generation, evaluations so far, best feasible objective so
    far, wall seconds since the run started) per generation (NaN until a feasible candidate
    appears)."""

    name: str
    x: np.ndarray
    f: float
    generations: int
    evaluations: int
    converged: bool
    history: list[tuple[int, int, float, float]] = field(default_factory=list)


@dataclass(frozen=True)
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


@dataclass(frozen=True)
class Result:
    """An optimization's outcome.

    ``winner`` (P,) parameter values (file units); ``objective`` its value (in the objective's
    unit, the sense as written); ``columns`` its metric columns (robust: mean + k std);
    ``nominal_columns`` the same design's columns without deviations; ``front`` (F, P) the
    Pareto designs with ``front_columns`` (F,) each (None for one objective), sorted by the
    first column; ``file_objective`` and ``file_columns`` the mechanism file's own design,
    scored the same way (NaN where it is infeasible or outside a bound); ``runs``; ``archive``; ``evaluations`` variants evaluated (a robust
    candidate counts its samples); ``engine``; ``timing`` wall seconds per stage.
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


Progress = Callable[[str, int, int, float], None]  # (run name, generation, generations, best so far)


def deviations(study: Study) -> np.ndarray:
    """(R, P) the robust mode's tolerance deviations (file units; one row of zeros without
    ``[robust]``), drawn once from the robust seed (numpy's PCG64)."""
    P = len(study.varied)
    rb = study.robust
    if rb is None:
        return np.zeros((1, P))
    rng = np.random.Generator(np.random.PCG64(rb.seed))
    tol = np.array([v.tolerance for v in study.varied])
    uniform = np.array([v.distribution == "uniform" for v in study.varied])
    u = rng.uniform(-1.0, 1.0, size=(rb.samples, P))
    z = rng.standard_normal(size=(rb.samples, P))
    return np.where(uniform, u * tol, z * tol / 3.0)


class Evaluator:
    """Scores batches of candidates on the engine (a Dask client, or this process).

    On a cluster the study is held by an actor on every worker (:class:`.engine.Pool`, made at
    the first batch): a generation is too small a batch to pay the scheduler's round trip.
    Use as a context manager, or call :meth:`close`, to release them.

    Args:
      study: an optimize study.
      client: a ``distributed.Client`` or None (this process).
      workers: how many chunks a batch is cut into at least (the cluster's workers).
    """

    def __init__(self, study: Study, client: Any = None, workers: int = 1):
        if study.optimize is None:
            raise OptimizeError(f"{study.name}: not an optimization (no [optimize] table)")
        self.study = study
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

    def rows(self, X: np.ndarray) -> Evaluated:
        """The reference's metrics of arbitrary rows (n, P), file units, on the engine."""
        n = len(X)
        # Equal chunks, a multiple of the workers in number, none above CHUNK_ROWS rows of
        # variants x angles (the reference's memory per task).
        cap = max(1, CHUNK_ROWS // self.study.per_turn)
        count = self.workers * max(1, -(-n // (self.workers * cap)))
        size = max(1, -(-n // count))
        parts = [(i, min(i + size, n)) for i in range(0, n, size)]
        got: dict[tuple[int, int], Evaluated] = {}
        t = time.perf_counter()
        from .engine import Pool, _map

        if self.client is None:
            _map(None, reference_chunk, self.study, X, parts, got.__setitem__, {})
        else:
            if self._pool is None:
                self._pool = Pool(self.client, self.study)
            self._pool.reference(X, parts, got.__setitem__)
        self.seconds += time.perf_counter() - t
        self.evaluations += n
        cols = {c.name: np.concatenate([got[k].columns[c.name] for k in parts]) for c in self.study.columns}
        return Evaluated(
            cols,
            np.concatenate([got[k].feasible for k in parts]),
            tuple(r for k in parts for r in got[k].reason),
        )

    def score(self, X: np.ndarray, robust: bool = True) -> Scores:
        """Scores of candidates X (S, P), file units (``robust=False``: at nominal dimensions
        even in robust mode)."""
        st = self.study
        opt = st.optimize
        assert opt is not None
        S, P = X.shape
        dev = self.dev if robust else np.zeros((1, P))
        R = len(dev)
        ev = self.rows((X[:, None, :] + dev[None]).reshape(S * R, P))
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


@dataclass
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
            cat(self.run) if self.run else np.zeros(0, int),
            cat(self.generation) if self.generation else np.zeros(0, int),
            cat(self.values) if self.values else np.zeros((0, P)),
            {c: cat([d[c] for d in self.columns]) if self.columns else np.zeros(0) for c in names},
            cat(self.objective) if self.objective else np.zeros(0),
            cat(self.violation) if self.violation else np.zeros(0),
            tuple(self.reason),
        )


Objective = Callable[[Scores], tuple[np.ndarray, np.ndarray]]  # -> (minimized value, violation)


def _de(
    ev: Evaluator,
    book: _Book,
    index: int,
    name: str,
    objective: Objective,
    init: np.ndarray | None,
    progress: Progress | None,
) -> Run:
    """One scipy differential-evolution run, every generation one batch on the engine."""
    from scipy.optimize import NonlinearConstraint, differential_evolution

    st = ev.study
    opt = st.optimize
    assert opt is not None
    lo = np.array([v.low for v in st.varied])
    hi = np.array([v.high for v in st.varied])
    P = len(lo)
    cache: dict[bytes, tuple[float, float]] = {}
    t0 = time.perf_counter()
    run = Run(name, np.full(P, np.nan), math.inf, 0, 0, False)
    gen = -1

    def evaluate(xT: np.ndarray) -> list[bytes]:
        nonlocal gen
        X = np.atleast_2d(np.asarray(xT, dtype=float).T if np.ndim(xT) == 2 else xT)
        keys = [x.tobytes() for x in X]
        todo = [i for i, k in enumerate(keys) if k not in cache]
        if todo:
            gen += 1
            Xn = X[todo]
            s = ev.score(Xn)
            f, viol = objective(s)
            book.add(index, gen, Xn, s, f, viol)
            run.evaluations += len(Xn)
            for i, fi, vi in zip(todo, f, viol, strict=True):
                cache[keys[i]] = (float(fi), float(vi))
            ok = np.flatnonzero(viol <= 0)
            if len(ok):
                j = ok[np.argmin(f[ok])]
                if f[j] < run.f:
                    run.f, run.x = float(f[j]), Xn[j].copy()
            best = run.f if math.isfinite(run.f) else math.nan
            run.history.append((gen, run.evaluations, best, time.perf_counter() - t0))
            run.generations = gen
            if progress:
                progress(name, gen, opt.generations, run.f)
        return keys

    def violation(xT: np.ndarray) -> np.ndarray:
        return np.array([[cache[k][1] for k in evaluate(xT)]])

    def func(xT: np.ndarray) -> np.ndarray:
        return np.array([cache[k][0] for k in evaluate(xT)])

    if init is None:
        from scipy.stats import qmc

        engine: qmc.QMCEngine = (
            qmc.Sobol(P, scramble=True, seed=opt.seed) if opt.init == "sobol" else qmc.LatinHypercube(P, seed=opt.seed)
        )
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)  # Sobol warns for counts that are no power of 2
            init = qmc.scale(engine.random(opt.population), lo, hi)
    with warnings.catch_warnings():
        # scipy warns when it cannot polish (we do not) or finds nothing feasible (we say so).
        warnings.simplefilter("ignore", UserWarning)
        res = differential_evolution(
            func,
            list(zip(lo, hi, strict=True)),
            maxiter=opt.generations,
            tol=opt.tol,
            atol=opt.atol,
            init=init,
            rng=np.random.default_rng(opt.seed + index),
            polish=False,
            vectorized=True,
            updating="deferred",
            constraints=NonlinearConstraint(violation, -np.inf, 0.0),
        )
    run.converged = bool(res.success)
    return run


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
    with Evaluator(study, client, workers) as ev:
        return _run(study, ev, engine, progress)


def _run(study: Study, ev: Evaluator, engine: str, progress: Progress | None) -> Result:
    opt = study.optimize
    assert opt is not None
    t0 = time.perf_counter()
    book = _Book()
    runs: list[Run] = []

    def weighted(s: Scores) -> tuple[np.ndarray, np.ndarray]:
        return s.objective, s.violation

    if opt.pareto is None:
        runs.append(_de(ev, book, 0, "optimum", weighted, None, progress))
        _feasible_or_fail(study, runs, book)
        winner = runs[0].x
        front = None
    else:
        c1, c2 = opt.pareto

        def single(c: str) -> Objective:
            return lambda s: (s.columns[c], s.violation)

        runs.append(_de(ev, book, 0, f"min {c1}", single(c1), None, progress))
        runs.append(_de(ev, book, 1, f"min {c2}", single(c2), None, progress))
        _feasible_or_fail(study, runs, book)
        ends = ev.score(np.stack([runs[0].x, runs[1].x]))
        hi2, lo2 = float(ends.columns[c2][0]), float(ends.columns[c2][1])
        span = max(hi2 - lo2, 1e-12 * max(abs(hi2), 1.0))
        warm = [runs[0].x, runs[1].x]
        for j, eps in enumerate(np.linspace(lo2, hi2, opt.points)[1:-1]):

            def capped(s: Scores, eps: float = float(eps)) -> tuple[np.ndarray, np.ndarray]:
                over = np.where(np.isfinite(s.columns[c2]), np.maximum(s.columns[c2] - eps, 0.0) / span, INFEASIBLE)
                return s.columns[c1], s.violation + over

            init = _warm_init(study, warm, j + 2)
            r = _de(ev, book, j + 2, f"min {c1} with {c2} <= {eps:.6g}", capped, init, progress)
            runs.append(r)
            if np.all(np.isfinite(r.x)):
                warm.append(r.x)
        cand = np.stack([r.x for r in runs if np.all(np.isfinite(r.x))])
        sc = ev.score(cand)
        keep = _nondominated(sc.columns[c1], sc.columns[c2]) & (sc.violation <= 0)
        front = cand[keep][np.argsort(sc.columns[c1][keep], kind="stable")]
        fc = ev.score(front)
        f1, f2 = fc.columns[c1], fc.columns[c2]
        n1 = (f1 - f1.min()) / max(np.ptp(f1), 1e-300)
        n2 = (f2 - f2.min()) / max(np.ptp(f2), 1e-300)
        winner = front[int(np.argmin(np.hypot(n1, n2)))]
    t_search = time.perf_counter() - t0
    final = ev.score(winner[None])
    nominal = ev.score(winner[None], robust=False)
    if final.violation[0] > 0:  # pragma: no cover - the winner was chosen among feasible candidates
        raise OptimizeError(f"{study.name}: the winner is infeasible: {final.reason[0]}")
    if opt.pareto is None:
        value = float(final.objective[0]) * (-1.0 if opt.sense == "max" else 1.0)
    else:
        value = math.nan
    file_values = np.array([[p.nominal for p in study.params]])
    fs0 = ev.score(file_values)
    file_value = math.nan
    if opt.pareto is None and fs0.violation[0] <= 0:
        file_value = float(fs0.objective[0]) * (-1.0 if opt.sense == "max" else 1.0)
    front_cols = None
    if front is not None:
        fs = ev.score(front)
        front_cols = {c: v.copy() for c, v in fs.columns.items()}
    return Result(
        study,
        winner,
        value,
        {c: float(v[0]) for c, v in final.columns.items()},
        {c: float(v[0]) for c, v in nominal.columns.items()},
        front,
        front_cols,
        file_value,
        {c: float(v[0]) for c, v in fs0.columns.items()},
        runs,
        book.archive(study),
        ev.evaluations,
        engine,
        {"search": t_search, "reference": ev.seconds, "total": time.perf_counter() - t0},
    )


def _warm_init(study: Study, warm: list[np.ndarray], index: int) -> np.ndarray:
    """An initial population for a front run: a fresh scrambled Sobol sample (seeded by the
    run) with the previous runs' optima in place of its first rows, so each run starts from
    the front found so far."""
    from scipy.stats import qmc

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


def _nondominated(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Which points of (a, b) no other point dominates (both minimized); duplicates keep one."""
    n = len(a)
    keep = np.ones(n, dtype=bool)
    for i in range(n):
        dom = (a <= a[i]) & (b <= b[i]) & ((a < a[i]) | (b < b[i]))
        same = (a == a[i]) & (b == b[i]) & (np.arange(n) < i)
        keep[i] = not dom.any() and not same.any()
    return keep


def _feasible_or_fail(study: Study, runs: list[Run], book: _Book) -> None:
    if all(np.all(np.isfinite(r.x)) for r in runs):
        return
    reasons = [r for r in book.reason if r]
    common = max(set(reasons), key=reasons.count) if reasons else "no candidate met the bounds"
    n = sum(len(v) for v in book.values)
    raise OptimizeError(
        f"{study.name}: no feasible design among {n} candidates (commonest reason: {common}); "
        "widen the [[parameter]] ranges or relax the [[bound]]s"
    )
