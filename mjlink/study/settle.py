"""How long an optimization's runs take on a smooth bowl: the plan's least likely cost.

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
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

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
