"""The peer side of ``bench_optimize.py``: a four-bar path-generation problem and pylinkage.

The problem (mm; angles in degrees in the design vector):

* ground: the crank pivot A = (0, 0), the rocker pivot D = (48, 0);
* crank AB of length a, B = a (cos phi, sin phi);
* joint C with |BC| = b and |DC| = c, on mjlink's dyad branch sign = +1:
  L = |B - D|, u = (B - D) / L, cos U = (L^2 + c^2 - b^2) / (2 L c), C = D + c R(+U) u;
* coupler point P = B + e R(alpha) (C - B) / |C - B| (polar from B against B -> C);
* design x = (a, b, c, e, alpha_deg) in the box BOUNDS; the target design X_STAR;
* precision points: P of X_STAR at phi = 0, 60, ..., 300 deg (no prescribed timing);
* objective: the RMS over the six targets of the distance to the nearest of the coupler
  point's positions at SAMPLES = 72 crank angles (every 5 deg), mm; a design that cannot
  assemble at some sampled angle is infeasible.

The rocker pivot is fixed because pylinkage's optimizers vary a linkage's constraints
(lengths and angles) only, not its ground points.

pylinkage (``pip install pylinkage==1.3.0``) is imported inside the functions that need it:
this bench only, not a dependency of mjlink.
"""

from __future__ import annotations

import math
import time
from typing import Any

import numpy as np

X_STAR = (12.0, 40.0, 38.0, 25.0, 45.0)  # a, b, c, e (mm), alpha (deg)
D_X = 48.0  # mm, the rocker pivot
BOUNDS = ((5.0, 20.0), (20.0, 60.0), (15.0, 50.0), (5.0, 40.0), (-90.0, 90.0))
SAMPLES = 72
PRECISION_ANGLES_DEG = (0.0, 60.0, 120.0, 180.0, 240.0, 300.0)
THRESHOLD = 0.05  # mm: the objective value both optimizers are timed to
METHODS = ("differential evolution", "particle swarm")


def coupler_curve(x: Any, phi: np.ndarray) -> np.ndarray:
    """(len(phi), 2) positions of P, mm (NaN where the loop cannot close)."""
    a, b, c, e, alpha = (float(v) for v in x)
    B = a * np.stack([np.cos(phi), np.sin(phi)], axis=1)
    D = np.array([D_X, 0.0])
    d = B - D
    L = np.hypot(d[:, 0], d[:, 1])
    u = d / L[:, None]
    cos_u = (L * L + c * c - b * b) / (2 * L * c)
    with np.errstate(invalid="ignore"):
        U = np.arccos(np.where(np.abs(cos_u) <= 1.0, cos_u, np.nan))
    cu, su = np.cos(U), np.sin(U)
    C = D + c * np.stack([cu * u[:, 0] - su * u[:, 1], su * u[:, 0] + cu * u[:, 1]], axis=1)
    w = (C - B) / np.hypot(*(C - B).T)[:, None]
    ca, sa = math.cos(math.radians(alpha)), math.sin(math.radians(alpha))
    return B + e * np.stack([ca * w[:, 0] - sa * w[:, 1], sa * w[:, 0] + ca * w[:, 1]], axis=1)


def targets() -> np.ndarray:
    """(6, 2) the precision points, mm."""
    return coupler_curve(X_STAR, np.radians(PRECISION_ANGLES_DEG))


def _rms_miss(path: np.ndarray, t: np.ndarray) -> float:
    d2 = ((path[None, :, :] - t[:, None, :]) ** 2).sum(axis=2).min(axis=1)
    return float(np.sqrt(d2.mean()))


def objective_numpy(x: Any) -> float:
    """The objective, mm (inf where infeasible): the problem's plain definition."""
    path = coupler_curve(x, np.radians(np.arange(SAMPLES) * 360.0 / SAMPLES))
    if not np.all(np.isfinite(path)):
        return math.inf
    return _rms_miss(path, targets())


def build(x: Any = X_STAR) -> Any:
    """A pylinkage Linkage of design x, its joint C on the sign = +1 branch at phi = 0 (pylinkage
    then keeps the intersection nearest the previous position), 5 deg per step."""
    import pylinkage as pl

    a, b, c, e, alpha = (float(v) for v in x)
    A = pl.Ground(0.0, 0.0, name="A")
    D = pl.Ground(D_X, 0.0, name="D")
    crank = pl.Crank(anchor=A, radius=a, angular_velocity=2 * math.pi / SAMPLES, name="B")
    # C's starting position on the branch (from the closed form at phi = 0).
    Bx, By = a, 0.0
    d = np.array([Bx - D_X, By])
    L = float(np.hypot(*d))
    u = d / L
    U = math.acos(max(-1.0, min(1.0, (L * L + c * c - b * b) / (2 * L * c))))
    cx = D_X + c * (math.cos(U) * u[0] - math.sin(U) * u[1])
    cy = c * (math.sin(U) * u[0] + math.cos(U) * u[1])
    C = pl.RRRDyad(crank.output, D, distance1=b, distance2=c, x=cx, y=cy, name="C")
    P = pl.FixedDyad(crank.output, C, distance=e, angle=math.radians(alpha), name="P")
    return pl.Linkage([A, D, crank, C, P], name="fourbar")


def _fitness() -> Any:
    """The fitness a pylinkage user writes: its kinematic run (one full cycle, at least 96
    frames, +inf when unbuildable), then the RMS miss of the coupler point's locus."""
    import pylinkage as pl

    t = targets()

    @pl.kinematic_minimization
    def fitness(loci: Any, **_: Any) -> float:
        path = np.array([frame[4] for frame in loci], dtype=float)
        return _rms_miss(path, t)

    return fitness


def _pl_params(x: Any) -> list[float]:
    a, b, c, e, alpha = (float(v) for v in x)
    return [a, b, c, e, math.radians(alpha)]


def fitness_pylinkage(x: Any) -> float:
    """The objective computed through pylinkage's own simulation, mm."""
    linkage = build(X_STAR)
    init = tuple(linkage.get_coords())
    return float(_fitness()(linkage, _pl_params(x), init))


def check(n: int = 200, seed: int = 0) -> tuple[int, float]:
    """(designs both call feasible, largest difference mm) of pylinkage's fitness against the
    NumPy definition at random designs; raises if they disagree on feasibility more than
    rarely (pylinkage keeps the branch nearest the previous position, which can differ from
    the sign convention near a dead point)."""
    rng = np.random.default_rng(seed)
    lo, hi = np.array(BOUNDS).T
    X = lo + (hi - lo) * rng.random((n, len(lo)))
    linkage = build(X_STAR)
    init = tuple(linkage.get_coords())
    fit = _fitness()
    worst, both, disagree = 0.0, 0, 0
    for x in X:
        f_np = objective_numpy(x)
        f_pl = float(fit(linkage, _pl_params(x), init))
        if math.isfinite(f_np) and math.isfinite(f_pl):
            both += 1
            worst = max(worst, abs(f_np - f_pl))
        elif math.isfinite(f_np) != math.isfinite(f_pl):
            disagree += 1
    if disagree > n // 20:
        raise AssertionError(f"pylinkage and the definition disagree on feasibility for {disagree} of {n} designs")
    return both, worst


def run(method: str, *, seed: int, budget: int, threshold: float = THRESHOLD) -> dict[str, Any]:
    """pylinkage's optimizer on the problem, from scratch, about ``budget`` evaluations.

    Returns evaluations, wall_s, cpu_s, evals_per_s, best (mm), best_x, evals_to_threshold and
    wall_to_threshold_s (None if never reached) and the history (evaluation, wall s, best)."""
    import pylinkage as pl
    from pylinkage.optimization import differential_evolution_optimization, particle_swarm_optimization

    np.random.seed(seed)
    linkage = build(X_STAR)
    fit = _fitness()
    count, best = 0, math.inf
    hist: list[tuple[int, float, float]] = []
    hit: tuple[int, float] | None = None
    t0 = time.perf_counter()

    def counted(lk: Any, params: Any, init: Any) -> float:
        nonlocal count, best, hit
        f = float(fit(lk, params, init))
        count += 1
        if f < best:
            best = f
            hist.append((count, time.perf_counter() - t0, best))
            if hit is None and best <= threshold:
                hit = (count, time.perf_counter() - t0)
        return f

    lo = [b[0] for b in BOUNDS[:4]] + [math.radians(BOUNDS[4][0])]
    hi = [b[1] for b in BOUNDS[:4]] + [math.radians(BOUNDS[4][1])]
    c0 = time.process_time()
    if method == "differential evolution":
        pop = 12  # per parameter: 60 candidates per generation, as mjlink's run
        res = differential_evolution_optimization(
            counted,
            linkage,
            bounds=(lo, hi),
            order_relation=min,
            maxiter=max(1, budget // (pop * 5) - 1),
            popsize=pop,
            tol=0.0,
            seed=seed,
            verbose=False,
            polish=False,
        )
    elif method == "particle swarm":
        n = 60
        res = particle_swarm_optimization(
            counted,
            linkage,
            dimensions=5,
            n_particles=n,
            iterations=max(1, budget // n),
            bounds=(lo, hi),
            order_relation=min,
            verbose=False,
        )
    else:
        raise ValueError(f"unknown method {method!r} (one of {', '.join(METHODS)})")
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    member = res[0] if isinstance(res, pl.Ensemble | list | tuple) or hasattr(res, "__getitem__") else res
    x = list(getattr(member, "dimensions", []))
    return {
        "evaluations": count,
        "wall_s": wall,
        "cpu_s": cpu,
        "evals_per_s": count / wall,
        "best": best,
        "best_x": x,
        "evals_to_threshold": hit[0] if hit else None,
        "wall_to_threshold_s": hit[1] if hit else None,
        "history": hist,
    }


if __name__ == "__main__":
    k, d = check()
    print(f"pylinkage vs the NumPy definition: {k} feasible designs, largest difference {d:.2e} mm")
    for m in METHODS:
        r = run(m, seed=1, budget=20000)
        print(m, {k: v for k, v in r.items() if k not in ("history", "best_x")})
