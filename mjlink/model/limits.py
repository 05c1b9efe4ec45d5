"""Plausibility and faithfulness limits (mechanisms/README.md, "Limits" and "Dead points").

One home for every bound a mechanism, a command-line value or a check is held to. Lengths in
the file's mm where the name says so; everything else SI unless named.
"""

from __future__ import annotations

from dataclasses import dataclass

# Bounds are compared with this relative tolerance: a value written in another unit is converted
# with a rounding in its last bits ("100 um" is 0.09999999999999999 mm), which must not refuse a
# value that meets its bound as written. 1e-9 is far above that rounding (about 1e-16) and far
# below anything a bound tells apart; a value truly beyond a bound is refused.
BOUND_RTOL = 1e-9


def above(v: float, hi: float) -> bool:
    """``v`` is beyond the upper bound ``hi`` (by more than :data:`BOUND_RTOL` of it)."""
    return v > hi + BOUND_RTOL * abs(hi)


def below(v: float, lo: float) -> bool:
    """``v`` is short of the lower bound ``lo`` (by more than :data:`BOUND_RTOL` of it)."""
    return v < lo - BOUND_RTOL * abs(lo)


# Lengths and coordinates, mm: beyond a metre the agreement thresholds, which are absolute
# (0.1 um), are no longer met at machine speeds (errors grow with size); bars below 0.1 mm are
# not machine parts, and far below it MuJoCo's fixed tolerances dominate (a 2 um crank-slider
# missed the thresholds).
MAX_LENGTH_MM = 1000.0
MIN_BAR_MM = 0.1
# [input] speed, rad/s: below 1 rad/s a kinematic run of one turn needs > 125 000 steps;
# above 1e4 rad/s a turn is shorter than 13 steps. [input] cycles at most MAX_CYCLES.
MIN_SPEED, MAX_SPEED = 1.0, 1e4
MAX_CYCLES = 100.0
# Durations of the dynamic run, s ([dynamics] duration, --duration). It is sampled every
# 0.25 ms and needs 100 samples to be compared with the reference (compare.MIN_SAMPLES), so a
# run under 25 ms cannot be judged; at dt = 50 us a 100 s run is 2 million steps, far beyond
# any study of a machine's run-up (the papers' take-up settles within 1 s of simulated time).
MIN_DURATION_S, MAX_DURATION_S = 0.025, 100.0
MAX_GEAR_RATIO = 64.0
# Angles in files (phi0, phase, attached angle): beyond a turn or two they only lose precision
# (phi0 = 1e300 deg leaves no digits for the crank's motion).
MAX_ANGLE_DEG = 720.0
# A link's mass (g) and moment of inertia (kg*m^2): a tonne and 1000 kg*m^2 are far beyond any
# machine part; absurd values would only overflow the reduced inertia or MuJoCo's mass matrix.
MAX_MASS_G, MAX_INERTIA = 1e6, 1e3

# Dead points, measured with the kinematic run (dt 50 us) on four-bars and crank-sliders whose
# links carry bar-like masses: four-bars miss the velocity threshold (2e-5 of range) from 8-12
# deg from the dead point at 100-150 rad/s and the position threshold (0.1 um) at 20 deg with a
# 40 mm crank at 150 rad/s; crank-sliders (20 mm crank) miss 0.1 um once the pressure angle
# passes 75-80 deg (100 rad/s) or 70-75 deg (150 rad/s). Errors grow with speed and, for
# positions, with crank length x speed^2. Within the envelope below the limits keep every run
# measured within the thresholds.
MIN_TRANSMISSION_DEG = 20.0  # a dyad's transmission angle stays within [20, 160] deg
MAX_PRESSURE_DEG = 60.0  # a slider's pressure angle stays at most 60 deg
# The envelope over which the thresholds are verified (test_property.py generates inside it):
# crank speed up to 150 rad/s, crank-pin acceleration r omega^2 between 10 m/s^2 (below it
# gravity's load on the soft loop closures dominates the acceleration error) and 500 m/s^2
# (errors grow with it), links with comparable, bar-like masses. Outside it a run is reported,
# not refused: the agreement table shows how close it came and --strict fails on a miss.
VERIFIED_SPEED = 150.0  # rad/s
VERIFIED_CRANK_ACCELERATION = (10.0, 500.0)  # m/s^2, crank length x speed^2
MIN_DIRECTION_M = 1e-6  # points that define a direction (attached, guide) stay this far apart
# Points of one link are one point or at least this far apart: MuJoCo's compiler takes a site or
# centre of mass within 1e-7 m of its body's frame for the frame itself (measured: a centre of
# mass 1e-4 mm from its crank's pivot was simulated on the pivot, a 0.1 um position error).
MIN_DISTINCT_M = 1e-6
SAMPLES_PER_TURN = 3600  # input-angle samples per crank turn for every check over a cycle

# What one command may cost, estimated before it starts (pipeline.estimate): a run records
# 7 + 9 per point + 7 per link values per sample (118 for the take-up), and each costs about
# 60 bytes of memory and 23 bytes of CSV, MuJoCo's trace and the reference's together
# (measured: the take-up's kinematic run at 1 rad/s, 125 664 samples, peaked at 1.0 GB and wrote
# 338 MB of CSV; over 100 turns it would need ~90 GB and 34 GB). Refused beyond these, naming
# the estimate and the option to change.
TRACE_BYTES_PER_VALUE, CSV_BYTES_PER_VALUE = 60.0, 23.0
MAX_TRACE_BYTES = 2e9  # memory for the traces of one run, bytes
MAX_CSV_BYTES = 1e9  # CSV written by one run, bytes
LONG_RUN_SAMPLES = 100_000  # above this a run says on stderr that it will take a while
# The video: frames are rendered and encoded one by one, so a run's cost grows with its frames
# (10 000 frames are a 5.5-minute video at 30 fps, far more than a cycle needs); beyond 240 fps
# no player shows the difference. What a video costs: docs/performance.md.
MAX_VIDEO_FRAMES = 10_000
MAX_FPS = 240
# Text a file shows in every listing, plot title and report: one line, a title not an essay
# (a 1 MB title was written into every figure and report).
MAX_TITLE_CHARS = 200
# A mechanism or study file is a few kB: above this it is refused by its size, before it is read.
MAX_FILE_BYTES = 1 << 20
# Points in one file (ground and built): every check over a cycle solves each point at
# SAMPLES_PER_TURN input angles per turn of the period, so its cost is points x samples, and
# 200 points are far more than a machine's linkage names. The product is bounded too, for
# geared files whose period spans many turns: 200 points over 4 turns.
MAX_POINTS = 200
MAX_CHECK_POINT_SAMPLES = MAX_POINTS * SAMPLES_PER_TURN * 4
# Synthesis of the offset crank-slider (synth): stroke and offset are lengths like any bar's
# (MIN_BAR_MM .. MAX_LENGTH_MM); lambda = r / l below 1 (a crank longer than its rod cannot
# turn); the allowed pressure angle within 0 .. 90 deg (at 90 the slider locks).
MAX_SYNTH_RATIO = 1.0
MAX_SYNTH_PRESSURE_DEG = 90.0

# External forces and moments ([[dynamics.force]], [dynamics] moment, motor stall_torque): a
# meganewton, a hundred-tonne press's, is far beyond the loads of a machine's linkage, and a
# meganewton-metre is that force on the longest lever a file may hold (MAX_LENGTH_MM). Beyond,
# a number is no load of a machine (1e300 kN passed check).
MAX_FORCE_N = 1e6
MAX_TORQUE_NM = 1e6
# Viscous damping of the crank, N*m*s: the largest moment at the slowest speed a run makes.
MAX_DAMPING = MAX_TORQUE_NM / MIN_SPEED
# Gravity, m/s^2 along -Y: ten times the Earth's covers any test rig; beyond, it is no gravity.
MAX_GRAVITY = 100.0


@dataclass(frozen=True)
class Bound:
    """A key's physical range in the file's ``unit``: ``lo`` .. ``hi`` (None: open-ended), an
    end excluded where ``*_open``; ``why`` says where the range comes from."""

    lo: float | None
    hi: float | None
    unit: str
    why: str
    lo_open: bool = False
    hi_open: bool = False

    def refuses(self, v: float) -> str | None:
        """Why ``v`` (finite, file units) is out of range, or None. A closed end is compared
        with BOUND_RTOL; an open end strictly (what it excludes is the end itself)."""
        lo_bad = self.lo is not None and (v <= self.lo if self.lo_open else below(v, self.lo))
        hi_bad = self.hi is not None and (v >= self.hi if self.hi_open else above(v, self.hi))
        if not (lo_bad or hi_bad):
            return None
        u = f" {self.unit}" if self.unit else ""
        if self.lo is not None and self.hi is not None:
            ends = f"{'above' if self.lo_open else 'at least'} {self.lo:g} and {'below' if self.hi_open else 'at most'} {self.hi:g}"
        elif self.lo is not None:
            ends = f"{'above' if self.lo_open else 'at least'} {self.lo:g}"
        else:
            assert self.hi is not None
            ends = f"{'below' if self.hi_open else 'at most'} {self.hi:g}"
        return f"must be {ends}{u} ({self.why}), got {v:g}{u}"


# A sewing head's [timing] and [balance] numbers (mjlink.model.timing; docs/head.md), in the
# file's units. Heights are the head's coordinates; the rest are what a head sews.
MAX_STITCH_MM = 50.0
HEAD: dict[str, Bound] = {
    "timing.plate": Bound(-MAX_LENGTH_MM, MAX_LENGTH_MM, "mm", "a height of the head, as its [ground] coordinates"),
    "timing.fabric": Bound(
        0.0,
        20.0,
        "mm",
        "the fabric passes under the raised presser foot, which sewing heads lift some 20 mm at most",
    ),
    "timing.loop_release": Bound(
        0.0,
        360.0,
        "deg",
        "a turn of the hook (looper) from the pick-up: the loop leaves it within that turn",
        lo_open=True,
        hi_open=True,
    ),
    "timing.feed_in_fabric": Bound(0.0, MAX_STITCH_MM, "mm", "feed of one stitch at most, as [balance] stitch_length"),
    # A maker's window [lo, hi] on a height or a rise of the head's points.
    "timing.window": Bound(
        -MAX_LENGTH_MM, MAX_LENGTH_MM, "mm", "a height of the head's points, as its [ground] coordinates"
    ),
    "balance.stitch_length": Bound(
        0.1,
        MAX_STITCH_MM,
        "mm",
        "a stitch no shorter than a sewing thread is thick, and far beyond the DDL-8700's 5 mm at most",
    ),
    "balance.loop_body": Bound(
        0.0, 200.0, "mm", "across what the loop is drawn round: the shipped bobbin case is 21 mm", lo_open=True
    ),
    "balance.bobbin_case_width": Bound(
        0.0,
        100.0,
        "mm",
        "across the bobbin case's faces, which the loop passes over: 10 mm on the shipped head",
        lo_open=True,
    ),
    "balance.check_spring_travel": Bound(
        0.0, 100.0, "mm", "a check spring's stroke, 6-8 mm on the shipped head's class"
    ),
    "balance.stretch": Bound(
        0.0, 0.2, "", "a fraction: at its working tension a thread stretches a few %, and it breaks at some 15-30 %"
    ),
}
"""Every number of a head's ``[timing]`` and ``[balance]`` tables, by ``table.key``, with its
range, unit and reason (``timing.window``: each end of a maker's window; ``balance.loop_body``:
the ``bobbin_case`` or ``looper`` diameter)."""


# [steady] target_delta and --target-delta, the coefficient of speed fluctuation
# (w_max - w_min) / w_mean: above 0, and below 2 for any motion that keeps its sense.
TARGET_DELTA = Bound(
    0.0,
    2.0,
    "",
    "a coefficient of speed fluctuation, below 2 while the crank keeps turning",
    lo_open=True,
    hi_open=True,
)
