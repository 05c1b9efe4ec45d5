"""What a designer must know about an optimum before trusting it.

* **On a range bound**: a parameter within 1 % of its range's end (:data:`NEAR_BOUND`) is
  probably held there by the range, not by the design: widen the range to see.
* **Active constraints**: a [[bound]] whose value at the winner (its worst tolerance sample,
  robust) is within 1 % of its limit: the optimum is limited by it.
* **At the edge of feasibility**: a step of 1 % of a parameter's range makes the design fail to
  assemble or pass a dead-point limit: the optimum leans on the feasibility limit named.
* **Redundant parameters**: a parameter whose change by 1 % of its range, up and down, changes
  neither the objective (beyond :data:`FLAT` of it) nor the feasibility: the objective does not
  depend on it alone (it may still through a combination with others: warp_knitting's dwell
  depends on the crank settings' difference, not on phi01 alone), so its value is arbitrary
  and it can be dropped or fixed.
* **Seeds**: how far the optima of the runs from different seeds differ, in the objective and in
  the parameters (a fraction of their ranges).
* **At its own dimensions** (robust, with operating conditions): a [[bound]] the winner misses
  at its own dimensions under one of the samples' conditions. A sample judges each condition
  with that sample's deviations of the dimensions only, so a bound that binds at a corner of
  the conditions' box may hold there with the deviations and not without them.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from .spec import Study

if TYPE_CHECKING:
    from .search import Run

NEAR_BOUND = 0.01  # of the range
NEAR_LIMIT = 0.01  # of a bound's limit (its magnitude; absolute for a limit of 0)
PROBE = 0.01  # the step of the redundancy and edge probes, of the range
FLAT = 1e-9  # relative change of the objective below which a parameter is redundant
SAME_POINT = 1e-6  # seeds' optima this close (of every range) are one point, whatever their values


@dataclass(frozen=True)
class SeedSpread:
    """The optima of runs from different seeds: their ``seeds``, ``objectives`` (as minimized)
    and the largest difference of any parameter between them, a fraction of its range
    (``parameters``); ``agree``: the objectives within the study's ``ftol`` (plus ``atol``)."""

    seeds: tuple[int, ...]
    objectives: tuple[float, ...]
    parameters: float
    agree: bool
    sign: float = 1.0
    points: tuple[tuple[float, ...], ...] = ()  # each seed's optimum, file units

    @property
    def spread(self) -> float:
        return max(self.objectives) - min(self.objectives)

    def text(self) -> str:
        shown = sorted(self.sign * f for f in self.objectives)
        rel = self.spread / max(abs(min(self.objectives, key=abs)), 1e-300)
        return (
            f"the {len(self.seeds)} independent runs' optima {'agree' if self.agree else 'differ'}: objective "
            f"{shown[0]:.8g} .. {shown[-1]:.8g} (spread {self.spread:.3g}, {rel:.2g} of it), parameters apart by up to "
            f"{self.parameters:.2g} of their ranges"
        )


@dataclass(frozen=True)
class Caveats:
    """The caveats on a winner (see the module docstring), each a tuple of one-line texts."""

    at_bounds: tuple[str, ...] = ()
    active: tuple[str, ...] = ()
    edge: tuple[str, ...] = ()
    redundant: tuple[str, ...] = ()
    seeds: SeedSpread | None = None
    own: tuple[str, ...] = ()

    def lines(self) -> list[str]:
        out = [f"on a range bound: {t}" for t in self.at_bounds]
        out += [f"active constraint: {t}" for t in self.active]
        out += [f"at the edge of feasibility: {t}" for t in self.edge]
        out += [f"redundant: {t}" for t in self.redundant]
        out += [f"at its own dimensions: {t}" for t in self.own]
        if self.seeds is not None and not self.seeds.agree:
            out.append(f"runs: {self.seeds.text()}")
        return out

    def findings(self) -> list[str]:
        """What speaks for the winner rather than against it: the seeds' runs agreeing."""
        return [f"runs: {self.seeds.text()}"] if self.seeds is not None and self.seeds.agree else []

    def as_dict(self) -> dict[str, Any]:
        s = self.seeds
        return {
            "on_range_bound": list(self.at_bounds),
            "active_constraints": list(self.active),
            "edge_of_feasibility": list(self.edge),
            "redundant_parameters": list(self.redundant),
            "at_own_dimensions": list(self.own),
            "seeds": None
            if s is None
            else {
                "seeds": list(s.seeds),
                "objectives": [s.sign * f for f in s.objectives],
                "spread": s.spread,
                "parameters_apart_of_range": s.parameters,
                "agree": s.agree,
            },
        }


def seed_spread(study: Study, runs: list[Run]) -> SeedSpread:
    """How the feasible optima of ``runs`` (one per seed) differ."""
    opt = study.optimize
    assert opt is not None
    ok = [r for r in runs if np.all(np.isfinite(r.x))]
    span = np.array([v.high - v.low for v in study.varied])
    X = np.stack([r.x for r in ok])
    f = [r.f for r in ok]
    best = min(f)
    apart = float((np.ptp(X, axis=0) / span).max()) if len(ok) > 1 else 0.0
    agree = len(ok) == len(runs) and (max(f) - best <= opt.ftol * abs(best) + opt.atol or apart <= SAME_POINT)
    return SeedSpread(
        tuple(r.seed for r in ok),
        tuple(f),
        apart,
        agree,
        -1.0 if opt.sense == "max" and not opt.pareto else 1.0,
        tuple(tuple(float(v) for v in r.x) for r in ok),
    )


def caveats(
    study: Study,
    ev: Any,
    x: np.ndarray,
    objective: Callable[[Any], tuple[np.ndarray, np.ndarray]],
    seeds: SeedSpread | None = None,
) -> Caveats:
    """The caveats on the design ``x`` (P,) (file units), probed with the evaluator ``ev``
    (:class:`.optimize.Evaluator`) and the run's ``objective`` (scores -> minimized, violation)."""
    lo = np.array([v.low for v in study.varied])
    hi = np.array([v.high for v in study.varied])
    span = hi - lo
    at_bounds = []
    for v, xi, s in zip(study.varied, x, span, strict=True):
        unit = f" {v.param.unit}" if v.param.unit else ""
        for end, name in ((v.low, "low"), (v.high, "high")):
            if abs(xi - end) <= NEAR_BOUND * s:
                at_bounds.append(
                    f"{v.param.path} = {xi:.6g}{unit} is within {NEAR_BOUND:.0%} of its range's {name} end ({end:g}{unit})"
                )
    # Probes: each parameter 1 % of its range up and down (inside the box), with x itself.
    P = len(x)
    probes = [x]
    for j in range(P):
        for d in (+1.0, -1.0):
            y = x.copy()
            y[j] = min(max(x[j] + d * PROBE * span[j], lo[j]), hi[j])
            probes.append(y)
    X = np.stack(probes)
    sc = ev.score(X)
    f, viol = objective(sc)
    f0 = float(f[0])
    flat_tol = FLAT * max(abs(f0), 1e-300) + (study.optimize.atol if study.optimize else 0.0)
    redundant, edge = [], []
    for j, v in enumerate(study.varied):
        pair = [1 + 2 * j, 2 + 2 * j]
        moved = [k for k in pair if not np.array_equal(X[k], x)]
        if not moved:
            continue
        bad = [k for k in moved if viol[k] > 0]
        if bad:
            k = bad[0]
            why = sc.reason[k] or "a [[bound]] is exceeded"
            edge.append(f"{v.param.path} {'+' if X[k][j] > x[j] else '-'}{PROBE:.0%} of its range: {why}")
        elif all(abs(float(f[k]) - f0) <= flat_tol for k in moved):
            redundant.append(
                f"{v.param.path}: the objective does not change when it alone moves by {PROBE:.0%} of its range "
                "(drop it or fix it: its value is arbitrary)"
            )
    redundant += _non_unique(study, seeds)
    return Caveats(
        tuple(at_bounds), tuple(_active(study, ev, x)), tuple(edge), tuple(redundant), seeds, tuple(_own(study, ev, x))
    )


def _non_unique(study: Study, seeds: SeedSpread | None) -> list[str]:
    """Parameters in which the seeds' optima differ by more than PROBE of their ranges while
    their objectives agree: the objective depends on a combination of them, not on each."""
    if seeds is None or len(seeds.points) < 2:
        return []
    opt = study.optimize
    assert opt is not None
    f = seeds.objectives
    if max(f) - min(f) > opt.ftol * abs(min(f, key=abs)) + opt.atol:
        return []
    span = np.array([v.high - v.low for v in study.varied])
    apart = np.ptp(np.array(seeds.points), axis=0) / span
    moved = [(v.param.path, a) for v, a in zip(study.varied, apart, strict=True) if a > PROBE]
    if not moved:
        return []
    which = ", ".join(f"{p} by {a:.0%}" for p, a in moved)
    return [
        f"the {len(f)} independent runs' optima have the same objective but differ in {which} of the ranges: the objective "
        "depends on a combination of these, not on each (fix all but one of them)"
    ]


def _active(study: Study, ev: Any, x: np.ndarray) -> list[str]:
    """The [[bound]]s within NEAR_LIMIT of their limit at ``x`` (robust: its worst sample)."""
    if not study.bounds:
        return []
    rows = ev.rows(ev.samples(x[None]))  # the robust mode's deviations (one row of zeros without)
    out = []
    for b in study.bounds:
        a = rows.columns[b.column]
        near = []
        for limit, side, worst in ((b.low, "min", np.nanmin(a)), (b.high, "max", np.nanmax(a))):
            if limit is None or not math.isfinite(worst):
                continue
            if abs(worst - limit) <= NEAR_LIMIT * max(abs(limit), 1e-12) or (limit == 0 and abs(worst) <= 1e-9):
                near.append((abs(worst - limit), f"{b.text()}: {b.column} = {worst:.6g} at the winner, on its {side}"))
        if near:  # a band narrower than NEAR_LIMIT has both ends near: the winner is on the nearer
            out.append(min(near)[1])
    return out


def _own(study: Study, ev: Any, x: np.ndarray) -> list[str]:
    """The [[bound]]s ``x`` misses at its own dimensions under each distinct set of the
    conditions' values the robust samples hold (none without conditions)."""
    if not study.conditions or not study.bounds or study.robust is None:
        return []
    held = np.unique(ev.samples(x[None])[:, len(x) :], axis=0)
    rows = np.concatenate([np.broadcast_to(x, (len(held), len(x))), held], axis=1)
    got = ev.rows(rows)
    out = []
    for i, c in enumerate(held):
        at = ", ".join(
            f"{v.param.path} = {ci:.6g}{f' {v.param.unit}' if v.param.unit else ''}"
            for v, ci in zip(study.conditions, c, strict=True)
        )
        if not got.feasible[i]:
            out.append(f"with {at}: {got.reason[i] or 'infeasible'}")
            continue
        for b in study.bounds:
            a = got.columns[b.column][i : i + 1]
            if not b.holds(a)[0]:
                out.append(f"with {at}: misses {b.text()} ({b.column} = {float(a[0]):.6g})")
    return out
