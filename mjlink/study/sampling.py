"""The variants of a study: a full grid, a quasi-random design, or a tolerance sample.

* grid: every combination of the parameters' values, the first parameter slowest (so a
  two-parameter grid reshapes to (n_first, n_second)).
* random: a scrambled Sobol sequence or a Latin hypercube (``scipy.stats.qmc``) over the
  parameters' ranges, seeded.
* tolerance: nominal plus a deviation per parameter, drawn independently: uniform over
  +-tolerance, or normal with sigma = tolerance / 3 (the band then holds 99.73 % of parts,
  the usual reading of a drawing's tolerance). Seeded (numpy's PCG64).

Values are in the file's units; the same study file gives the same variants on any machine.
"""

from __future__ import annotations

import itertools
import warnings
from collections.abc import Sequence

import numpy as np

from .varied import Varied


def grid(varied: Sequence[Varied]) -> np.ndarray:
    """(V, P) every combination of the parameters' values, the first parameter slowest."""
    P = len(varied)
    return np.array(list(itertools.product(*(v.values for v in varied))), dtype=float).reshape(-1, P)


def quasi_random(varied: Sequence[Varied], samples: int, seed: int, sequence: str) -> np.ndarray:
    """(samples, P) a scrambled Sobol sequence (``sequence`` 'sobol') or a Latin hypercube
    ('lhs') over the parameters' ranges, seeded."""
    from scipy.stats import qmc  # here: scipy.stats, only for a random design

    P = len(varied)
    engine: qmc.QMCEngine
    if sequence == "sobol":
        engine = qmc.Sobol(P, scramble=True, seed=seed)
    else:
        engine = qmc.LatinHypercube(P, seed=seed)
    with np.errstate(all="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # Sobol warns for sample counts that are no power of 2
        u = engine.random(samples)
    lo = np.array([v.low for v in varied])
    hi = np.array([v.high for v in varied])
    return np.asarray(qmc.scale(u, lo, hi), dtype=float)


def deviations(varied: Sequence[Varied], samples: int, seed: int) -> np.ndarray:
    """(samples, P) deviations of the parameters from their values, file units: uniform over
    +-tolerance, or normal with sigma = tolerance / 3, drawn independently per parameter with
    numpy's PCG64 from ``seed`` (all the uniform draws first, then the normal ones)."""
    P = len(varied)
    rng = np.random.Generator(np.random.PCG64(seed))
    tol = np.array([v.tolerance for v in varied])
    uniform = np.array([v.distribution == "uniform" for v in varied])
    u = rng.uniform(-1.0, 1.0, size=(samples, P))
    z = rng.standard_normal(size=(samples, P))
    return np.asarray(np.where(uniform, u * tol, z * tol / 3.0))


def tolerance(varied: Sequence[Varied], samples: int, seed: int) -> np.ndarray:
    """(samples, P) a tolerance study's variants: nominal + :func:`deviations`."""
    nominal = np.array([v.param.nominal for v in varied])
    return nominal + deviations(varied, samples, seed)


def sample_std(x: np.ndarray) -> float:
    """The sample standard deviation (one degree of freedom less) of ``x`` (finite values; 0
    for fewer than two), scaled first: the squares of values beyond 1e154 (a margin to the
    breaking load over next to no tension) would overflow."""
    top = float(np.abs(x).max()) if x.size else 0.0
    return float(np.std(x / top, ddof=1) * top) if x.size > 1 and top > 0 else 0.0
