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
import math
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


def deviations(varied: Sequence[Varied], samples: int, seed: int, stream: int = 0) -> np.ndarray:
    """(samples, P) deviations of the parameters from their values, file units: uniform over
    +-tolerance, normal with sigma = tolerance / 3, or even (``samples`` values evenly spaced
    over +-tolerance, both ends included, in a random order: a band every part of which must
    be met, such as the needle tensions a head is set to), drawn independently per parameter
    with numpy's PCG64 from ``seed`` (all the uniform draws first, then the normal ones, then
    each even parameter's order); a ``stream`` other than 0 draws from a stream of its own,
    independent of stream 0's."""
    P = len(varied)
    rng = np.random.Generator(np.random.PCG64(np.random.SeedSequence([seed, stream]) if stream else seed))
    tol = np.array([v.tolerance for v in varied])
    uniform = np.array([v.distribution == "uniform" for v in varied])
    u = rng.uniform(-1.0, 1.0, size=(samples, P))
    z = rng.standard_normal(size=(samples, P))
    out = np.where(uniform, u * tol, z * tol / 3.0)
    spaced = np.linspace(-1.0, 1.0, samples) if samples > 1 else np.zeros(1)
    for j, v in enumerate(varied):
        if v.distribution == "even":
            out[:, j] = rng.permutation(spaced) * tol[j]
    return np.asarray(out)


def crossed(conditions: Sequence[Varied], samples: int) -> np.ndarray:
    """(samples, C) the deviations of operating conditions given ``levels``: each condition's
    levels evenly over +-tolerance, ends included, every combination of them once (the first
    condition slowest, as :func:`grid`), repeated whole to ``samples`` rows (a multiple of the
    combinations). Taguchi's crossed outer array: every corner of the conditions' box is a
    sample, which random pairings of two even conditions miss."""
    axes = [np.linspace(-v.tolerance, v.tolerance, v.levels) for v in conditions]
    combos = np.array(list(itertools.product(*axes)), dtype=float).reshape(-1, len(conditions))
    return np.tile(combos, (samples // len(combos), 1))


def robust_deviations(varied: Sequence[Varied], samples: int, seed: int) -> np.ndarray:
    """(samples, P) a robust optimization's deviations, the parameters in ``varied``'s order:
    those searched (with a range) drawn by :func:`deviations` from ``seed``, the operating
    conditions (no range: held at the file's value) from a stream of their own, so that adding
    a condition leaves the searched parameters' samples as they were, or, given ``levels``,
    crossed (:func:`crossed`, nothing drawn)."""
    cond = np.array([math.isnan(v.low) for v in varied], dtype=bool)
    out = np.zeros((samples, len(varied)))
    out[:, ~cond] = deviations([v for v, c in zip(varied, cond, strict=True) if not c], samples, seed)
    held = [v for v, c in zip(varied, cond, strict=True) if c]
    if held and all(v.levels for v in held):
        out[:, cond] = crossed(held, samples)
    elif held:
        out[:, cond] = deviations(held, samples, seed, stream=1)
    return out


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
