"""The ``tension`` metric of a study: each variant's needle thread under tension
(:mod:`.tension`), its heads stepped together (:mod:`.tension_many`)."""

from __future__ import annotations

import dataclasses
from typing import Any, ClassVar

import numpy as np

from ..model.timing import StitchType
from ..reference.batch import Batch
from .metric_base import Column, Curve, Loads, MetricError, probed
from .tension import NeedleTension, prepare
from .timing import HeadTiming, TimingChecks

__all__ = ["TensionMetric"]


class TensionMetric(TimingChecks):
    """A lockstitch head's needle thread under tension, per variant (:func:`needle_tension` at
    the variant's speed and [tension] numbers, on the study's crank angles): ``tension_peak``
    N, ``tension_margin`` (the breaking load over the peak), ``tension_per_stitch`` mm (drawn
    through the discs), ``tension_slack`` deg (of the stitch with the thread below the eye
    slack: a loop), ``tension_spring`` mm (the check spring's largest travel),
    ``tension_periodic`` (1 where the stitch reached its periodic state) and ``tension_period``
    (1; 2 where the stitches alternate, more where the check spring striking its stop repeats
    its motion only every few; 0 without a periodic state)."""

    kind = "tension"
    options = ()
    together = 512  # stepped at once (:mod:`.tension_many`): a task of this many costs least per variant

    @classmethod
    def share(cls, n: int) -> float:
        from .tension_many import share  # the array step's cost

        return share(n)

    def read(self, raw: dict[str, Any]) -> None:
        tm, bal = self.mech.timing, self.mech.balance
        if tm is None or bal is None or not self.mech.thread or tm.stitch is not StitchType.LOCKSTITCH:
            raise MetricError(
                f"{self.where}: {self.mech.name} is not a lockstitch head with [timing], [thread] and [balance] "
                "tables (docs/head.md, The thread under tension)"
            )
        self.maker, self.tag = tm.target, ""

    COLUMNS: ClassVar[tuple[Column, ...]] = (
        Column("tension_peak", "N", "the needle thread's largest tension over the stitch"),
        Column("tension_margin", "", "the thread's breaking load over its peak tension"),
        Column("tension_per_stitch", "mm", "needle thread drawn through the discs per stitch"),
        Column("tension_slack", "deg", "of the stitch the thread below the eye is slack (a loop)"),
        Column("tension_spring", "mm", "the check spring's largest travel"),
        Column("tension_periodic", "", "1 if the stitch reached its periodic state"),
        Column("tension_period", "", "stitches after which the thread's state repeats (2: alternating; 0: none)"),
        Column(
            "tension_drawn_up",
            "",
            "pull on the stitch as set, over the bobbin tension",
        ),
    )

    def columns(self) -> list[Column]:
        return list(self.COLUMNS)

    def _tensions(self, b: Batch) -> list[tuple[HeadTiming, NeedleTension]]:
        from .tension_many import step_many  # it steps this module's problems

        heads, problems = [], []
        for head, bal, _, own in self.variants(b):
            whole = dataclasses.replace(head, balance=bal)
            heads.append(whole)
            problems.append(prepare(own, whole, samples=len(head.theta)))
        # Probed for memory (a study's calibration): one stitch holds what eight do.
        return list(zip(heads, step_many(problems, cycles=1 if probed() else None), strict=True))

    def compute(self, b: Batch, nominal: Batch, loads: Loads) -> dict[str, np.ndarray]:
        rows = []
        for _, t in self._tensions(b):
            rows.append(
                [
                    t.peak,
                    t.margin,
                    t.per_stitch * 1e3,
                    float(t.slack.mean()) * 360.0,
                    float(t.spring.max()) * 1e3,
                    float(t.converged),
                    float(t.period),
                    t.drawn_up,
                ]
            )
        out = np.array(rows, dtype=float).reshape(b.variants, len(self.COLUMNS))
        return {c.name: out[:, j] for j, c in enumerate(self.columns())}

    def curve(self, b: Batch, loads: Loads) -> Curve | None:
        """The largest tension of any stretch over the stitch, N."""
        values = np.full((b.variants, b.angles), np.nan)
        for i, (head, t) in enumerate(self._tensions(b)):
            assert head.order is not None
            values[i, head.order] = t.tension.max(axis=0)
        return Curve("needle thread: largest tension", "N", values)
