"""The local polish of an optimization: a CMA-ES started at the global search's best point.

Differential evolution finds the basin; it does not settle a point to many digits within it,
and several of mjlink's objectives are not smooth there (a largest deviation, a peak, a
nearest-point miss), which defeats gradient methods and slows a pattern search to a crawl in
curved valleys (measured on ``takeup_eyelets_demand``: a batched compass search stopped at
14.206..14.219 mm, Nelder-Mead reached 14.181 in 15,000 serial evaluations, this CMA-ES 14.152).
The covariance matrix adaptation evolution strategy (Hansen's (mu/mu_w, lambda)-CMA-ES, "The
CMA Evolution Strategy: A Tutorial", 2016) learns the valley's shape, needs no gradient,
and evaluates a generation of ``lambda`` candidates at once: one batch on the engine, as a
generation of the global search.

It works in the search box scaled to the unit cube. Candidates outside it are clipped into it
and ranked by their objective plus a penalty on the distance clipped; infeasible candidates
(feasibility or a bound violated) rank after every feasible one, by their violation (the
feasibility rules of the global search). It stops:

* converged, by **step**: the largest standard deviation of the search distribution is below
  ``xtol`` of the ranges (the point is settled to that resolution in every parameter);
* converged, by **values**: the best values of the last generations and every value of the
  latest one lie within ``ftol`` (relative to the best, plus the objective's ``atol``): the
  objective no longer changes where the search looks (flat directions: a parameter the
  objective does not depend on keeps the step from shrinking);
* not converged: at ``evaluations``, the budget.

The polish only ever returns a point at least as good as its start, feasible.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

# (S, P) candidates in the unit cube -> (objective (S,), violation (S,)); violation <= 0 is feasible.
Batch = Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]]

XTOL = 1e-9  # step at which the polish is converged, as a fraction of each parameter's range
FTOL = 1e-12  # relative change of the values below which it is converged by its values
PENALTY = 1e3  # objective per (fraction of the range)^2 outside the box, for ranking only


def batch_size(n: int) -> int:
    """Candidates of a polish generation over ``n`` parameters (lambda): Hansen's default
    4 + 3 ln n, at least 2 n."""
    return max(4 + int(3 * math.log(n)), 2 * n)


@dataclass(frozen=True, kw_only=True)
class Polished:
    """What the polish found: ``u`` (P,) in the unit cube and its objective ``f``, from ``f0``;
    ``evaluations``, ``generations``, the final ``step`` (fraction of the ranges), whether it
    ``converged`` and what stopped it (``stopped_by``: 'step', 'values' or 'evaluations')."""

    u: np.ndarray
    f: float
    f0: float
    evaluations: int
    generations: int
    step: float
    converged: bool
    stopped_by: str


def step_size(sigma: float, path_norm: float, cs: float, damps: float, chi_n: float) -> float:
    """CMA-ES's step-size update from the length of the conjugate evolution path, its factor
    capped at e per generation as Hansen's reference implementation caps it: a path lengthened
    by a nearly singular covariance would otherwise overflow the exponential (it did, on a
    head's take-up synthesis)."""
    return sigma * math.exp(min(1.0, (cs / damps) * (path_norm / chi_n - 1.0)))


def axes(d2: np.ndarray) -> np.ndarray:
    """The covariance's axis lengths (square roots of its eigenvalues ``d2``), floored at 1e-10
    of the longest: a direction the selection never moved along keeps a finite inverse, so that
    C^-1/2 (and the evolution path through it) stays bounded."""
    out: np.ndarray = np.sqrt(np.maximum(d2, 1e-20 * max(float(np.max(d2)), 1e-300)))
    return out


def polish(
    batch: Batch,
    u0: np.ndarray,
    f0: float,
    *,
    sigma0: float,
    evaluations: int,
    seed: int,
    xtol: float = XTOL,
    ftol: float = FTOL,
    atol: float = 0.0,
) -> Polished:
    """Minimize ``batch``'s objective from the feasible point ``u0`` (objective ``f0``).

    Args:
      batch: scores a batch of candidates of the unit cube (see :data:`Batch`).
      u0: (P,) the start, feasible.
      f0: its objective.
      sigma0: the initial step, a fraction of the ranges.
      evaluations: the budget.
      seed: the random stream's seed (the same seed gives the same polish).
      xtol, ftol, atol: the stopping tests (module docstring).
    """
    n = len(u0)
    rng = np.random.Generator(np.random.PCG64(seed))
    lam = batch_size(n)
    mu = lam // 2
    w = math.log(mu + 0.5) - np.log(np.arange(1, mu + 1))
    w /= w.sum()
    mueff = 1.0 / float((w**2).sum())
    cc = (4 + mueff / n) / (n + 4 + 2 * mueff / n)
    cs = (mueff + 2) / (n + mueff + 5)
    c1 = 2 / ((n + 1.3) ** 2 + mueff)
    cmu = min(1 - c1, 2 * (mueff - 2 + 1 / mueff) / ((n + 2) ** 2 + mueff))
    damps = 1 + 2 * max(0.0, math.sqrt((mueff - 1) / (n + 1)) - 1) + cs
    chi_n = math.sqrt(n) * (1 - 1 / (4 * n) + 1 / (21 * n * n))
    m = np.array(u0, dtype=float)
    sigma = float(sigma0)
    pc, ps = np.zeros(n), np.zeros(n)
    C, B, D = np.eye(n), np.eye(n), np.ones(n)
    inv_sqrt_c = np.eye(n)
    best_u, best_f = m.copy(), float(f0)
    history: list[float] = []  # best objective of each generation
    window = 10 + math.ceil(30 * n / lam)
    used = gen = decomposed = 0
    stopped = "evaluations"
    while used + lam <= evaluations:
        gen += 1
        y = rng.standard_normal((lam, n)) * D @ B.T
        X = m + sigma * y
        Xc = np.clip(X, 0.0, 1.0)
        f, viol = batch(Xc)
        used += lam
        out = ((X - Xc) ** 2).sum(axis=1)
        feasible = (viol <= 0) & np.isfinite(f)
        key = np.where(feasible, f + PENALTY * out, np.inf)
        # Feasible first by objective, then infeasible by violation: Lampinen's rules, as DE.
        order = np.lexsort((np.where(feasible, 0.0, viol), key))
        ok = feasible & (out == 0)
        if ok.any():
            j = int(np.flatnonzero(ok)[np.argmin(f[ok])])
            if f[j] < best_f:
                best_u, best_f = Xc[j].copy(), float(f[j])
        history.append(float(np.min(key)) if feasible.any() else math.inf)
        sel = y[order[:mu]]
        yw = w @ sel
        m = m + sigma * yw
        ps = (1 - cs) * ps + math.sqrt(cs * (2 - cs) * mueff) * (inv_sqrt_c @ yw)
        hsig = float(np.linalg.norm(ps) / math.sqrt(1 - (1 - cs) ** (2 * gen)) / chi_n < 1.4 + 2 / (n + 1))
        pc = (1 - cc) * pc + hsig * math.sqrt(cc * (2 - cc) * mueff) * yw
        C = (1 - c1 - cmu) * C + c1 * (np.outer(pc, pc) + (1 - hsig) * cc * (2 - cc) * C) + cmu * (sel.T * w) @ sel
        sigma = step_size(sigma, float(np.linalg.norm(ps)), cs, damps, chi_n)
        sigma = min(sigma, 0.5)
        if used - decomposed > lam / (c1 + cmu) / n / 10:
            decomposed = used
            C = np.triu(C) + np.triu(C, 1).T
            d2, B = np.linalg.eigh(C)
            D = axes(d2)
            inv_sqrt_c = (B / D) @ B.T
        step = sigma * float(D.max())
        if step < xtol:
            stopped = "step"
            break
        tol = ftol * max(abs(best_f), 1e-300) + atol
        recent = history[-window:]
        if len(history) >= window and feasible.all() and max(recent) - min(recent) <= tol and float(np.ptp(f)) <= tol:
            stopped = "values"
            break
    return Polished(
        u=best_u,
        f=best_f,
        f0=float(f0),
        evaluations=used,
        generations=gen,
        step=sigma * float(D.max()),
        converged=stopped != "evaluations",
        stopped_by=stopped,
    )
