"""Design metrics: one number per variant, computed from the reference over a batch of variants.

A metric is one class (:class:`Metric`), registered by its ``kind`` (the name a study file
uses); it reads its options from the study file, names its columns with their units, and
computes them for every variant of a :class:`~mjlink.reference.batch.Batch` at once
(arrays of V variants x A crank angles, never a loop over variants). Each column's unit is in
its :class:`Column`; every definition is in the class's docstring (and the studies README).

Feasibility comes first (:func:`feasibility`): a variant that cannot be assembled at every
crank angle of its period, or that passes within the dead-point limits of ``check``
(transmission angle below 20 deg or above 160 deg, pressure angle above 60 deg), is infeasible
with the reason and the crank-angle range; its metrics are NaN, never a number.

Units of the columns: mm, um, deg, N, N*m, W or none, as each says; angles of a period are
sampled uniformly from phi0, the end excluded (a mean over them is the exact cycle mean).
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..errors import did_you_mean
from ..model.limits import MAX_PRESSURE_DEG, MIN_TRANSMISSION_DEG
from ..model.mechanism import Mechanism
from ..reference.batch import Batch
from ..reference.kinematics import angle_ranges
from . import kinematic_metrics, load_metrics, motion, tension_metric, timing
from .metric_base import AtSpeed, Column, Curve, Loads, Metric, MetricError, MetricLimitError

__all__ = [
    "AtSpeed",
    "Column",
    "Curve",
    "Feasibility",
    "Loads",
    "Metric",
    "MetricError",
    "MetricLimitError",
    "columns",
    "compute",
    "feasibility",
    "kinematic_metrics",
    "load_metrics",
    "motion",
    "read",
    "tension_metric",
    "timing",
]


# --------------------------------------------------------------------------- the study side
def read(mech: Mechanism, raw: Any, i: int) -> Metric:
    """The ``i``-th ``[[metric]]`` table of a study file, or a one-line MetricError."""
    where = f"[[metric]] #{i + 1}"
    if not isinstance(raw, dict):
        raise MetricError(f"{where}: must be a table")
    kind = raw.get("kind")
    if not isinstance(kind, str):
        raise MetricError(f"{where}: needs 'kind' (one of {', '.join(Metric.types)})")
    if kind not in Metric.types:
        # A point's own motion is one metric with options, not a kind per quantity: a near
        # name such as 'acceleration_peak' for 'velocity_peak' would mislead.
        motion = (
            "a point's position, velocity, acceleration or jerk, as a statistic or at an event, is "
            "kind = 'motion' with its quantity; "
        )
        low = kind.lower()
        if any(w in low for w in ("position", "velocity", "jerk", "motion")):
            hint = motion
        elif "acceleration" in low:
            hint = did_you_mean(kind, list(Metric.types)) + motion
        else:
            hint = did_you_mean(kind, list(Metric.types))
        raise MetricError(f"{where}: unknown metric '{kind}' ({hint}valid: {', '.join(Metric.types)})")
    return Metric.types[kind](mech, raw, f"{where} ({kind})")


@dataclass(frozen=True)
class Feasibility:
    """Per variant: ``feasible`` (V,) bool and ``reason`` ('' where feasible)."""

    feasible: np.ndarray
    reason: tuple[str, ...]


def feasibility(b: Batch) -> Feasibility:
    """Which variants assemble over the whole period and keep clear of dead points.

    A variant is infeasible where its values make no mechanism (``b.invalid``), where a block
    cannot close at some crank angle (reason names the block and the angle ranges, deg from
    the variant's phi0), or where a dyad's transmission angle leaves 20..160 deg or a slider's
    pressure angle exceeds 60 deg (the limits within which ``check`` accepts a mechanism).
    """
    V = b.variants
    reason = list(b.invalid)
    theta = b.theta
    steps = {s.point: s for s in b.mechanism.steps}
    for point, margin in b.kin.margins.items():
        bad = b.per_variant(~(margin >= 0.0))
        for i in np.flatnonzero(bad.any(axis=1)):
            if not reason[i]:
                reason[i] = f"{steps[point].named()} cannot close at {angle_ranges(theta, bad[i])} deg from phi0"
    P = b.kin.positions()
    for s in b.mechanism.steps:
        dp = s.dead_point(P)
        if dp is None:
            continue
        near = b.per_variant(~(dp.margin_deg >= dp.required_margin_deg))
        value = b.per_variant(dp.value_deg)
        for i in np.flatnonzero(near.any(axis=1)):
            if not reason[i]:
                j = int(np.argmax(np.where(near[i], 90.0 - b.per_variant(dp.margin_deg)[i], -np.inf)))
                limit = (
                    f"{MIN_TRANSMISSION_DEG:g}..{180 - MIN_TRANSMISSION_DEG:g} deg"
                    if dp.quantity == "transmission angle"
                    else f"{MAX_PRESSURE_DEG:g} deg"
                )
                reason[i] = (
                    f"{s.named()} passes a dead point: {dp.quantity} {value[i, j]:.1f} deg (limit {limit}) "
                    f"at {angle_ranges(theta, near[i])} deg from phi0"
                )
    feasible = np.array([not r for r in reason], dtype=bool)
    assert len(feasible) == V
    return Feasibility(feasible, tuple(reason))


def compute(metrics: Sequence[Metric], b: Batch, nominal: Batch) -> dict[str, np.ndarray]:
    """Every metric's columns for every variant of ``b`` ((V,) each); ``nominal`` is the
    nominal design's batch (one variant) at the same angles."""
    loads = Loads()
    out: dict[str, np.ndarray] = {}
    with np.errstate(all="ignore"):
        for m in metrics:
            out.update(m.compute(b, nominal, loads))
    return out


def columns(metrics: Sequence[Metric]) -> list[Column]:
    """Every metric's columns, in order; a name used twice is a MetricError."""
    cols = list(itertools.chain.from_iterable(m.columns() for m in metrics))
    owner = [m.where for m in metrics for _ in m.columns()]
    seen: dict[str, str] = {}
    for c, where in zip(cols, owner, strict=True):
        if c.name in seen:
            raise MetricError(
                f"[[metric]]: column '{c.name}' is computed twice ({seen[c.name]} and {where}): two identical "
                "metrics, or a motion metric's 'name' that another's column has"
                if seen[c.name] != where
                else f"{where}: column '{c.name}' is computed twice"
            )
        seen[c.name] = where
    return cols
