"""``feed``: the fabric under the presser foot, fed by the head's dog through MuJoCo's contacts
(:mod:`mjlink.sim.feed`), at one speed or over a sweep of speeds; nothing is written.

What it reports per speed: the stitch length against the dog's geometric advance (its error),
its spread from stitch to stitch, the foot's separation from the fabric (how long, from where),
the presser spring's dynamic load factor and the fabric's slip on the dog's teeth; over a sweep,
the slowest speed whose stitch-length error exceeds :data:`ERROR_LIMIT`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from ..errors import InputError
from ..model.mechanism import Mechanism
from ..sim import feed as _feed

__all__ = ["ERROR_LIMIT", "FEED_STITCHES", "MAX_RPM", "MAX_STITCHES", "MIN_RPM", "SWEEP_RPM", "FeedResult", "feed"]

ERROR_LIMIT = 0.02  # the stitch-length error a sweep reports the first speed beyond (the 2 %)
SWEEP_RPM = tuple(range(500, 6001, 500))  # a sewing head's speeds, stitches/min
# Speeds the feed is run at, rpm: below 60 a stitch is over 100,000 steps of 10 us; above
# 10,000 no sewing head sews.
MIN_RPM, MAX_RPM = 60.0, 10_000.0
MIN_STITCHES, MAX_STITCHES = 2, 50  # the first starts from rest; 50 stitches take some 10 s at 6,000 rpm
FEED_STITCHES = 6  # stitches a head's simulate feeds from rest: the advance settles within 2 to 3


@dataclass(frozen=True, kw_only=True)
class FeedResult:
    """The feed of ``mechanism`` (its name) over ``stitches`` stitches at each speed:
    ``sweep`` (:class:`mjlink.sim.feed.FeedSweep`, its runs in the order of the speeds), and
    ``first_over`` the slowest run whose stitch-length error exceeds ``limit`` (None: none)."""

    mechanism: str
    stitches: int
    sweep: _feed.FeedSweep
    limit: float
    first_over: _feed.FeedRun | None


def feed(mech: Mechanism, *, speed_rpm: float | None = None, sweep: bool = False, stitches: int = 6) -> FeedResult:
    """The feed at ``speed_rpm`` (default the file's speed; its sign is the file's sense and is
    ignored), or with ``sweep`` at every speed of :data:`SWEEP_RPM`.

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
        if not MIN_RPM <= rpm <= MAX_RPM:
            given = "--speed" if speed_rpm is not None else "the file's [input] speed (give --speed)"
            raise InputError(
                f"{given}: the feed runs at {MIN_RPM:g} to {MAX_RPM:g} rpm (a stitch in 10 us steps), got {rpm:.6g} rpm"
            )
        speeds = [rpm]
    runs = _feed.sweep(mech, speeds, stitches=stitches)
    return FeedResult(
        mechanism=mech.name,
        stitches=stitches,
        sweep=runs,
        limit=ERROR_LIMIT,
        first_over=runs.first_over(ERROR_LIMIT) if sweep else None,
    )
