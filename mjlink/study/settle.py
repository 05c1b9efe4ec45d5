"""How long an optimization's runs take on a smooth bowl, and its first run rehearsed: the plan's
least likely cost and its best guess.

An optimization stops when its runs settle (:mod:`.search`), not at its budget, and how soon
depends on the objective, which is unknown before the work. Two cases bound it: the whole budget
(a run that never settles) and a smooth bowl of the study's own dimension, searched by the very
same code (the study's population, seeds, stopping rules and polish), which settles about as
soon as a search can. :mod:`.plan` takes the geometric mean of the two as its estimate: with only
the two bounds known, it is the guess whose worst ratio to the truth is least (the square root
of the bounds' ratio).

The bowl is ``1 + |u - u*|^2`` over the box scaled to the unit cube, its least point ``u*``
drawn from each run's seed within the middle of every range: its minimum equals its rise over a
unit of the scaled box, so scipy's spread test (relative to the objective's level) and the
stall and collapse tests all have their say, as on a metric whose best value is of the order of
its variation over the ranges.

Where the two bounds are more than 4x apart their geometric mean cannot promise 2x, and the
runs' length is the objective's own (an ill-conditioned fit whose polish runs to its budget,
a shallow problem that settles sooner than the bowl). The plan then rehearses the study's
first run (:func:`rehearse`): the very search, on the study's own objective, on a grid of
:data:`REHEARSAL_COARSER` times fewer crank angles (at least :data:`REHEARSAL_ANGLES`), for
at most :data:`REHEARSAL_SHARE` of the study's budget of candidates (or :data:`REHEARSAL_SECONDS`
of CPU, where they cost much). A run that ends within them gives its evaluations, which every
run is taken to need; one that does not gives those it has made, a lower bound on every run's.
Where that run had gone more generations than its stall test waits (``stall``) and was still
improving, the plan takes every run to its whole budget; where it had gone fewer, it cannot
tell, and takes the geometric mean of that bound and the budget (the shipped optimizations'
counts against their runs': bench/bench_study.py).
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..errors import MjlinkError
from .optimize import Evaluator, Scores, budget
from .search import search
from .spec import Study


@dataclass(frozen=True, kw_only=True)
class Settled:
    """Candidates an optimization's runs evaluate on the bowl: in the global ``search`` and in
    the ``polish``, summed over its runs (a candidate, not its tolerance samples); and
    ``batch_seconds``, the CPU seconds the runs' own work (scipy's and the polish's bookkeeping,
    the archive's records: everything but the objective) takes per batch on this machine, as
    measured on the bowl, whose objective costs next to nothing. Not ``complete``: the runs
    outgrew :data:`SECONDS` or their population :data:`POPULATION`; the counts then are of what
    was done, and the plan takes the whole budget."""

    search: int
    polish: int
    batch_seconds: float
    complete: bool = True


SECONDS = 2.0  # CPU seconds the runs on the bowl may take, at most
# Populations above this are not tried: scipy draws each candidate's donors from a permutation
# of the whole population, so a generation's own work grows with its square, and a huge
# population would hold the dry run in scipy before the objective is ever called.
POPULATION = 2000


class _Outgrown(Exception):
    pass


def on_bowl(study: Study) -> Settled:
    """The candidates ``study``'s runs evaluate on the bowl (module docstring): one run per seed,
    or per point of a Pareto front and its knee, each as a single objective from its own seed."""
    opt = study.optimize
    assert opt is not None
    lo = np.array([v.low for v in study.varied])
    span = np.array([v.high for v in study.varied]) - lo
    runs = opt.points + 1 if opt.pareto else opt.seeds
    found, polished, batches = 0, 0, 0
    if opt.population > POPULATION:
        return Settled(search=0, polish=0, batch_seconds=0.0, complete=False)
    import scipy.optimize  # imported before the clock starts: a one-off cost of any run
    import scipy.stats  # noqa: F401

    t = time.process_time()
    for k in range(runs):
        centre = np.random.default_rng(opt.seed + k).uniform(0.25, 0.75, len(lo))

        def score(X: np.ndarray, centre: np.ndarray = centre) -> np.ndarray:
            nonlocal batches
            batches += 1
            if time.process_time() - t > SECONDS:
                raise _Outgrown
            return 1.0 + (((np.asarray(X) - lo) / span - centre) ** 2).sum(axis=1)

        def objective(s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            return np.asarray(s, dtype=float), np.zeros(len(s))

        try:
            r = search(study, score, lambda *_: None, k, "bowl", objective, None, opt.seed + k, None)
        except _Outgrown:
            return Settled(search=found, polish=polished, batch_seconds=SECONDS / max(1, batches), complete=False)
        spent = r.polish.evaluations if r.polish is not None else 0
        found += r.evaluations - spent
        polished += spent
    return Settled(search=found, polish=polished, batch_seconds=(time.process_time() - t) / max(1, batches))


# A rehearsal stops after this share of the study's whole budget of candidates (a count, the
# same on every machine), or after REHEARSAL_SECONDS of CPU where its designs cost much.
REHEARSAL_SHARE = 0.25
REHEARSAL_SECONDS = 10.0
REHEARSAL_COARSER = 4  # the rehearsal's grid: this many times fewer crank angles than the study's
REHEARSAL_ANGLES = 24  # and at least this many (or the study's own, if fewer)
GENERATION_SECONDS = 1.0  # a generation costing more is not rehearsed: its first would overrun
WIDE = 4.0  # bounds further apart than this are narrowed by a rehearsal


@dataclass(frozen=True, kw_only=True)
class Rehearsed:
    """The study's first run rehearsed (module docstring): the candidates it evaluated in its
    global ``search`` and its ``polish`` (not their tolerance samples), on ``angles`` crank
    angles; ``complete`` whether the run ended by itself within :data:`REHEARSAL_SHARE` of the
    study's budget and :data:`REHEARSAL_SECONDS` (otherwise the counts are of what it had
    done)."""

    search: int
    polish: int
    angles: int
    complete: bool


def rehearse(study: Study, row_seconds: float) -> Rehearsed | None:
    """Rehearse ``study``'s first run (module docstring), its variant-angles costing about
    ``row_seconds`` each (the plan's calibration); None where a generation would take more than
    :data:`GENERATION_SECONDS`, or the coarse grid cannot be evaluated."""
    opt = study.optimize
    assert opt is not None
    angles = min(study.per_turn, max(REHEARSAL_ANGLES, study.per_turn // REHEARSAL_COARSER // 2 * 2))
    samples = study.robust.samples if study.robust else 1
    if opt.population * samples * angles * row_seconds > GENERATION_SECONDS:
        return None
    coarse = dataclasses.replace(study, per_turn=angles)
    most = REHEARSAL_SHARE * budget(study).candidates
    seen = {"search": 0, "polish": 0}
    t = time.process_time()

    def counted(key: str, ev: Evaluator) -> Callable[[np.ndarray], Scores]:
        def score(X: np.ndarray) -> Scores:
            out = ev.score(X)
            seen[key] += len(X)
            if seen["search"] + seen["polish"] >= most or time.process_time() - t > REHEARSAL_SECONDS:
                raise _Outgrown
            return out

        return score

    def objective(s: Scores) -> tuple[np.ndarray, np.ndarray]:
        if opt.pareto is None:
            return s.objective, s.violation
        return s.columns[opt.pareto[0]], s.violation

    with Evaluator(coarse, None, 1) as ev:
        try:
            r = search(
                coarse,
                counted("search", ev),
                lambda *_: None,
                0,
                "rehearsal",
                objective,
                None,
                opt.seed,
                None,
                polish_score=counted("polish", ev),
            )
        except _Outgrown:
            return Rehearsed(search=seen["search"], polish=seen["polish"], angles=angles, complete=False)
        except (MjlinkError, ValueError, ArithmeticError):
            return None
    polished = r.polish.evaluations if r.polish is not None else 0
    return Rehearsed(search=r.evaluations - polished, polish=polished, angles=angles, complete=True)
