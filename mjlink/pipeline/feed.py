"""``feed``: the fabric under the presser foot, fed by the head's dog through MuJoCo's contacts
(:mod:`mjlink.sim.feed`), at one speed or over a sweep of speeds, into ``OUT/NAME_feed/``.

What it reports per speed: the stitch length against the dog's geometric advance (its error),
its spread from stitch to stitch, the foot's separation from the fabric (how long, from where),
the presser spring's dynamic load factor and the fabric's slip on the dog's teeth; over a sweep,
the slowest speed whose stitch-length error exceeds :data:`ERROR_LIMIT`.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..errors import InputError
from ..files import write_json, write_table
from ..model.mechanism import Mechanism
from ..runtime import staging
from ..runtime.signals import uninterrupted
from ..runtime.workers import PlotJob, run_jobs
from ..sim import feed as _feed
from .results import Provenance, provenance

__all__ = ["ERROR_LIMIT", "FEED_STITCHES", "MAX_RPM", "MAX_STITCHES", "MIN_RPM", "SWEEP_RPM", "FeedResult", "feed"]

ERROR_LIMIT = 0.02  # the stitch-length error a sweep reports the first speed beyond (the 2 %)
SWEEP_RPM = tuple(range(500, 6001, 500))  # a sewing head's speeds, stitches/min
# Speeds the feed is run at, rpm: below 60 a stitch is over 100,000 steps of 10 us; above
# 10,000 no sewing head sews.
MIN_RPM, MAX_RPM = 60.0, 10_000.0
MIN_STITCHES, MAX_STITCHES = 2, 50  # the first starts from rest; a run's cost grows with its stitches
FEED_STITCHES = 6  # stitches a head's simulate feeds from rest: the advance settles within 2 to 3


@dataclass(frozen=True, kw_only=True)
class FeedResult:
    """The feed of ``mechanism`` (its name) over ``stitches`` stitches at each speed:
    ``sweep`` (:class:`mjlink.sim.feed.FeedSweep`, its runs in the order of the speeds), and
    ``first_over`` the slowest run whose stitch-length error exceeds ``limit`` (None: none);
    ``out_dir`` where it was written (None: nothing was), ``files`` the names there.
    :meth:`as_dict` is its ``report.json``."""

    mechanism: str
    stitches: int
    sweep: _feed.FeedSweep
    limit: float
    first_over: _feed.FeedRun | None
    out_dir: Path | None = None
    files: tuple[str, ...] = field(default=())
    provenance: Provenance | None = None

    def as_dict(self) -> dict[str, Any]:
        d: dict[str, Any] = {
            "mechanism": self.mechanism,
            "stitches": self.stitches,
            "error_limit": self.limit,
            "first_over_rpm": None if self.first_over is None else self.first_over.speed_rpm,
            "runs": [r.as_dict() for r in self.sweep.runs],
        }
        if self.provenance is not None:
            d["provenance"] = self.provenance.as_dict()
        return d


_ROWS = (  # feed_speeds.csv: a row per speed
    ("speed_rpm", lambda r: r.speed_rpm),
    ("stitch_mm", lambda r: r.stitch * 1e3),
    ("error_percent", lambda r: r.error * 100.0),
    ("spread_mm", lambda r: r.spread * 1e3),
    ("foot_off_deg", lambda r: r.separation[0]),
    ("largest_gap_mm", lambda r: float(r.lift.max()) * 1e3),
    ("load_factor", lambda r: r.load_factor),
    ("slip_mm", lambda r: r.slip * 1e3),
    ("foot_force_peak_N", lambda r: float(r.foot_force.max())),
    ("ply_shift_mm", lambda r: r.shift * 1e3),
)


def feed(
    mech: Mechanism,
    out_root: Path | str | None = None,
    *,
    speed_rpm: float | None = None,
    sweep: bool = False,
    stitches: int = 6,
    plots: bool = True,
    video: bool = False,
    force: bool = False,
    command: Sequence[str] = (),
) -> FeedResult:
    """The feed at ``speed_rpm`` (default the file's speed; its sign is the file's sense and is
    ignored), or with ``sweep`` at every speed of :data:`SWEEP_RPM`; into
    ``<out_root>/<name>_feed/`` unless ``out_root`` is None: ``report.json``
    (:meth:`FeedResult.as_dict`), ``feed_speeds.csv`` (a row per speed), ``feed.csv`` (the last
    stitch at the last speed) and, with ``plots``, ``feed.png`` (that stitch) and over a sweep
    ``feed_speed.png``, with ``video`` ``feed.mp4`` (that stitch close up,
    :func:`mjlink.sim.feed.feed_video`); its marker (kind ``feed``; a folder mjlink did not write for it is
    refused unless ``force``, :func:`mjlink.runtime.staging.staged_dir`).

    Raises:
      InputError: a head without a ``[timing]`` table naming its feed dog, a speed outside
        :data:`MIN_RPM` .. :data:`MAX_RPM`, stitches outside 2 .. :data:`MAX_STITCHES`, or
        ``--speed`` with ``--sweep``.
    """
    tm = mech.timing
    if tm is None or not tm.has("feed_dog"):
        raise InputError(f"{mech.name}: the feed needs a head whose [timing] table names the feed_dog")
    if not MIN_STITCHES <= stitches <= MAX_STITCHES:
        raise InputError(f"--stitches must be {MIN_STITCHES} to {MAX_STITCHES}, got {stitches}")
    if sweep and speed_rpm is not None:
        raise InputError("--speed and --sweep: give one (the sweep runs its own speeds)")
    if sweep:
        speeds = [float(w) for w in SWEEP_RPM]
    else:
        rpm = abs(speed_rpm) if speed_rpm is not None else abs(mech.speed) * 30.0 / math.pi
        # A speed given in rad/s or turned into rpm and back is not exactly its end: a rounding.
        if not MIN_RPM * (1.0 - 1e-12) <= rpm <= MAX_RPM * (1.0 + 1e-12):
            given = "--speed" if speed_rpm is not None else "the file's [input] speed (give --speed)"
            raise InputError(
                f"{given}: the feed runs at {MIN_RPM:g} to {MAX_RPM:g} rpm (a stitch in 10 us steps), got {rpm:.6g} rpm"
            )
        speeds = [rpm]
    if out_root is None:
        return _result(mech, stitches, _feed.sweep(mech, speeds, stitches=stitches), sweep)
    out_dir = Path(out_root) / f"{mech.name}_feed"
    options = {"speed_rpm": speed_rpm, "sweep": sweep, "stitches": stitches, "plots": plots, "video": video}
    if video:
        from ..sim import render  # here: OpenGL, for a video only

        render.check_backend(held=uninterrupted)  # a missing OpenGL is refused before any work
    with staging.staged_dir(out_dir, kind="feed", force=force, mechanism=mech.name, command=command) as stage:
        res = _result(mech, stitches, _feed.sweep(mech, speeds, stitches=stitches), sweep)
        res = dataclasses.replace(res, out_dir=out_dir, provenance=provenance(command, options))
        runs = res.sweep.runs
        write_table(stage / "feed_speeds.csv", [n for n, _ in _ROWS], [[f(r) for r in runs] for _, f in _ROWS])
        names, cols = runs[-1].columns()
        write_table(stage / "feed.csv", names, cols)
        if plots:
            from ..plotting import feed as feed_plot  # here: matplotlib, not for --no-plots

            jobs: list[PlotJob] = [functools.partial(feed_plot.feed_plot, mech, runs[-1], stage)]
            if sweep:
                jobs.append(functools.partial(feed_plot.feed_speed_plot, mech, runs, res.limit, stage))
            run_jobs(jobs)
        if video:
            _feed.feed_video(
                mech, stage / "feed.mp4", speed_rpm=runs[-1].speed_rpm, stitches=stitches, held=uninterrupted
            )
        write_json(stage / "report.json", res.as_dict())
        files = tuple(sorted(p.name for p in stage.iterdir() if not p.name.startswith(".")))
    return dataclasses.replace(res, files=files)


def _result(mech: Mechanism, stitches: int, runs: _feed.FeedSweep, sweep: bool) -> FeedResult:
    return FeedResult(
        mechanism=mech.name,
        stitches=stitches,
        sweep=runs,
        limit=ERROR_LIMIT,
        first_over=runs.first_over(ERROR_LIMIT) if sweep else None,
    )
