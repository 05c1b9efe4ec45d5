"""The ``feed`` metric: a head's fabric fed under its presser foot through MuJoCo's contacts
(:func:`mjlink.sim.feed.run_feed`), per variant, at the metric's speeds.

It lives with the studies, not with the reference's metrics (:mod:`mjlink.analysis`): it runs
MuJoCo for each variant, where every other metric computes on the reference's traces. Its
variants share the file's linkage: a study with it may vary the speed, the ``[presser]`` and
``[fabric]`` numbers and ``timing.fabric`` (the dog's path is the file's; a variant whose feed
dog moves otherwise is refused, one line naming the metric).
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any, ClassVar

import numpy as np

from ..analysis.metric_base import Column, Loads, Metric, MetricError
from ..model.mechanism import Mechanism
from ..model.presser import FABRIC_DEFAULTS, PRESSER_DEFAULTS
from ..reference.batch import Batch

__all__ = ["FeedMetric"]

MIN_RPM, MAX_RPM = 60.0, 10_000.0  # as the feed command's
MOST_SPEEDS = 12
MIN_STITCHES, MAX_STITCHES = 2, 20
SAME_PATH = 1e-9  # m: a variant's feed dog within this of the file's moves as the file's does


def _of(x: Any, i: int, b: Batch) -> float:
    """Variant ``i``'s value of a number a study may vary: a (V*A,) row array or a scalar."""
    return float(np.asarray(x).reshape(-1)[i * b.angles]) if np.ndim(x) else float(x)


class FeedMetric(Metric):
    """The fabric fed under the presser foot (MuJoCo contacts), at each of ``speeds`` (rpm;
    default the variant's own speed), ``stitches`` (default 4) from rest: ``feed_error_max`` %
    the stitch's largest error in size against the dog's advance with its teeth up (signed) and
    ``feed_error_size`` % its size (what an optimization minimizes), ``feed_stitch`` mm the
    stitch at the fastest speed, ``feed_foot_off_max`` deg the most of a stitch the foot is off
    the fabric, ``feed_load_factor_max`` the presser spring's largest dynamic load factor,
    ``feed_foot_force_max`` N the foot's largest push on the fabric, ``feed_ply_shift_max`` mm
    the top ply's largest shift on the bottom one in a stitch (signed; 0 with one ply)."""

    kind = "feed"
    options = ("speeds", "stitches")

    COLUMNS: ClassVar[tuple[Column, ...]] = (
        Column("feed_error_max", "%", "the stitch's largest error against the dog's advance"),
        Column("feed_error_size", "%", "the size of the stitch's largest error against the dog's advance"),
        Column("feed_stitch", "mm", "stitch length with contact at the fastest speed"),
        Column("feed_foot_off_max", "deg", "most of a stitch the presser foot is off the fabric"),
        Column("feed_load_factor_max", "", "the presser spring's largest dynamic load factor"),
        Column("feed_foot_force_max", "N", "the presser foot's largest push on the fabric"),
        Column("feed_ply_shift_max", "mm", "the top ply's largest shift on the bottom one in a stitch"),
    )

    def read(self, raw: dict[str, Any]) -> None:
        tm = self.mech.timing
        if tm is None or not tm.has("feed_dog"):
            raise MetricError(f"{self.where}: {self.mech.name} is not a head whose [timing] table names the feed_dog")
        speeds = raw.get("speeds")
        if speeds is None:
            self.speeds: tuple[float, ...] | None = None
        else:
            ok = isinstance(speeds, list) and 1 <= len(speeds) <= MOST_SPEEDS
            ok = ok and all(not isinstance(w, bool) and isinstance(w, int | float) for w in speeds)
            ok = ok and all(math.isfinite(w) and MIN_RPM <= w <= MAX_RPM for w in speeds)
            if not ok:
                raise MetricError(
                    f"{self.where}: speeds must be a list of 1 to {MOST_SPEEDS} speeds in rpm, each {MIN_RPM:g} to "
                    f"{MAX_RPM:g}, got {speeds!r:.80}"
                )
            self.speeds = tuple(sorted(float(w) for w in speeds))
        n = raw.get("stitches", 4)
        if isinstance(n, bool) or not isinstance(n, int) or not MIN_STITCHES <= n <= MAX_STITCHES:
            raise MetricError(
                f"{self.where}: stitches must be a whole number {MIN_STITCHES} to {MAX_STITCHES}, got {n!r:.40}"
            )
        self.stitches = n

    def columns(self) -> list[Column]:
        return list(self.COLUMNS)

    def _own(self, b: Batch, i: int) -> Mechanism:
        """Variant ``i`` of the file: its speed, fabric thickness, [presser] and [fabric]."""
        m, tm = b.mechanism, self.mech.timing
        assert tm is not None and m.timing is not None
        presser, fabric = m.presser or PRESSER_DEFAULTS, m.fabric or FABRIC_DEFAULTS
        return dataclasses.replace(
            self.mech,
            speed=_of(m.speed, i, b),
            timing=dataclasses.replace(tm, fabric=_of(m.timing.fabric, i, b)),
            presser=dataclasses.replace(
                presser, **{f.name: _of(getattr(presser, f.name), i, b) for f in dataclasses.fields(presser)}
            ),
            fabric=dataclasses.replace(
                fabric,
                **{f.name: _of(getattr(fabric, f.name), i, b) for f in dataclasses.fields(fabric) if f.name != "plies"},
                plies=tuple(
                    dataclasses.replace(q, **{f.name: _of(getattr(q, f.name), i, b) for f in dataclasses.fields(q)})
                    for q in fabric.plies
                ),
            ),
        )

    def compute(self, b: Batch, nominal: Batch, loads: Loads) -> dict[str, np.ndarray]:
        from ..sim import feed as _feed  # here: MuJoCo, for a study that asks for the feed

        tm = self.mech.timing
        assert tm is not None
        dog = tm.roles["feed_dog"]
        path = b.per_variant(b.kin.points[dog].v)
        file_path = nominal.per_variant(nominal.kin.points[dog].v)[0]
        if path.shape[1] == file_path.shape[0] and np.abs(path - file_path).max(initial=0.0) > SAME_PATH:
            raise MetricError(
                f"{self.where}: the feed runs the file's linkage, so a study with it may vary the speed, [presser], "
                "[fabric] and timing.fabric, not what moves the feed dog"
            )
        out = np.full((b.variants, len(self.COLUMNS)), np.nan)
        for i in range(b.variants):
            own = self._own(b, i)
            speeds = self.speeds or (abs(own.speed) * 30.0 / math.pi,)
            if not MIN_RPM <= speeds[0] <= MAX_RPM:
                raise MetricError(
                    f"{self.where}: a variant at {speeds[0]:.6g} rpm: the feed runs at {MIN_RPM:g} to {MAX_RPM:g} "
                    "rpm (give the metric its speeds)"
                )
            runs = _feed.sweep(own, list(speeds), stitches=self.stitches).runs
            worst = max(runs, key=lambda r: abs(r.error))
            out[i] = [
                worst.error * 100.0,
                abs(worst.error) * 100.0,
                runs[-1].stitch * 1e3,
                max(r.separation[0] for r in runs),
                max(r.load_factor for r in runs),
                max(float(r.foot_force.max()) for r in runs),
                max((r.shift for r in runs), key=abs) * 1e3,
            ]
        return {c.name: out[:, j] for j, c in enumerate(self.COLUMNS)}
