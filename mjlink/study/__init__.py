"""Design studies: many variants of one mechanism, evaluated by the reference and checked in MuJoCo.

The Python API (the ``study`` command is a thin layer over it)::

    import numpy as np
    from mjlink import study

    mech = study.mechanism("takeup")                          # a registered name or a file
    v = study.override(mech, {"construct.P3.length_a": 22.01})  # one variant, a Mechanism
    res = study.evaluate(mech, {"construct.P3.length_a": np.linspace(21.9, 22.1, 201)},
                         metrics=[{"kind": "thread_range"}, {"kind": "torque_peak"}])
    res.columns["thread_range"]                               # (201,) mm, NaN where infeasible
    checks = study.verify([v, mech])                          # MuJoCo, one batched rollout

    from mjlink.study import optimize                         # optimal synthesis ([optimize])
    res = optimize.run(study.load("crank_slider_pareto"))     # no files: res.winner, res.front

A whole study file run and written (its folder, table, summary, figures; an optimization's
winner file): :func:`mjlink.run_study`.

Parameter paths and their units: :mod:`mjlink.model.paths`; metrics:
:mod:`mjlink.analysis.metrics`; the study file: ``studies/README.md``.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..analysis import metrics as _metrics
from ..model import paths as _paths
from ..model.mechanism import Mechanism
from ..reference import batch as _batch
from ..validation import get
from .spec import Study, StudyFileError, Varied, load, parse
from .tasks import Evaluated, Verified, reference_chunk

if TYPE_CHECKING:
    from ..sim.batch import Verification

__all__ = [
    "Evaluated",
    "Study",
    "StudyFileError",
    "Verified",
    "evaluate",
    "load",
    "mechanism",
    "override",
    "parse",
    "verify",
]


def mechanism(name_or_path: str | Path) -> Mechanism:
    """A validated mechanism: a registered name (``takeup``) or a file's path."""

    return get(name_or_path)


def override(mech: Mechanism, values: Mapping[str, float]) -> Mechanism:
    """One variant of ``mech``: parameter path -> value in the file's units (mm, deg, g ...).

    Raises a one-line error for an unknown path (naming the nearest valid one)."""
    params = [_paths.resolve(mech, p) for p in values]
    return _batch.variant(mech, params, [float(v) for v in values.values()])


def evaluate(
    mech: Mechanism,
    values: Mapping[str, Sequence[float] | np.ndarray],
    metrics: Sequence[Mapping[str, Any]],
    *,
    per_turn: int = 360,
) -> Evaluated:
    """The reference's metrics for a batch of variants, all at once (no loop over variants).

    Args:
      mech: the nominal mechanism.
      values: parameter path -> (V,) values, file units (every path the same length).
      metrics: metric tables as in a study file, e.g. ``{"kind": "stroke", "point": "P5"}``.
      per_turn: crank angles per input turn (even).
    Returns:
      :class:`Evaluated`: ``columns`` metric column -> (V,), ``feasible`` (V,), ``reason``.
    """
    params = [_paths.resolve(mech, p) for p in values]
    table = np.column_stack([np.asarray(v, dtype=float).ravel() for v in values.values()])
    mets = tuple(_metrics.read(mech, dict(m), i) for i, m in enumerate(metrics))
    _metrics.columns(mets)
    st = Study(
        name="api",
        title="",
        path=None,
        mechanism=mech,
        method="grid",
        varied=tuple(Varied(param=p) for p in params),
        samples=len(table),
        seed=0,
        sequence="sobol",
        metrics=mets,
        bounds=(),
        per_turn=per_turn,
        verify="none",
        count=0,
        by="",
        digest="",
    )
    return reference_chunk(st, table)


def verify(mechs: Sequence[Mechanism], *, threads: int | None = None) -> list[Verification]:
    """MuJoCo's check of variants of one mechanism (same topology), stepped together in one
    ``mujoco.rollout`` over one period at constant speed and compared with the reference with
    the thresholds of ``simulate``. ``threads`` default: one per core."""

    from ..sim import batch as _sim  # here: MuJoCo, only to verify

    return _sim.verify(list(mechs), threads=threads or os.cpu_count() or 1)
