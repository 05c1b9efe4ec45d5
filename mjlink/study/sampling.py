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
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from .spec import Study, Varied


def sample(study: Study) -> np.ndarray:
    """(V, P) parameter values of every variant, file units."""
    P = len(study.varied)
    if study.method == "optimize":
        raise ValueError(f"{study.name}: an optimization draws its candidates itself (mjlink.study.optimize)")
    if study.method == "grid":
        return np.array(list(itertools.product(*(v.values for v in study.varied))), dtype=float).reshape(-1, P)
    if study.method == "random":
        from scipy.stats import qmc

        engine: qmc.QMCEngine
        if study.sequence == "sobol":
            engine = qmc.Sobol(P, scramble=True, seed=study.seed)
        else:
            engine = qmc.LatinHypercube(P, seed=study.seed)
        with np.errstate(all="ignore"):
            import warnings

            with warnings.catch_warnings():  # Sobol warns for sample counts that are no power of 2
                warnings.simplefilter("ignore", UserWarning)
                u = engine.random(study.samples)
        lo = np.array([v.low for v in study.varied])
        hi = np.array([v.high for v in study.varied])
        return np.asarray(qmc.scale(u, lo, hi), dtype=float)
    return tolerance(study.varied, study.samples, study.seed)


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


def robust_deviations(study: Study) -> np.ndarray:
    """(R, P) a robust optimization's tolerance deviations (file units; one row of zeros without
    ``[robust]``), drawn once from the robust seed: the same for every candidate."""
    rb = study.robust
    if rb is None:
        return np.zeros((1, len(study.varied)))
    return deviations(study.varied, rb.samples, rb.seed)
