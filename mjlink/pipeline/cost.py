"""What a run will cost, estimated before it starts: samples, memory, CSV and video frames.

:func:`estimate` refuses the absurd (beyond ``mechanisms/README.md``'s Limits) with one line
naming the estimate and the option to change; a long run says so before it starts.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

from .. import compare
from ..errors import MjlinkError, SimulationError
from ..model.limits import (
    CSV_BYTES_PER_VALUE,
    LONG_RUN_SAMPLES,
    MAX_CSV_BYTES,
    MAX_CYCLES,
    MAX_FPS,
    MAX_TRACE_BYTES,
    MAX_VIDEO_FRAMES,
    TRACE_BYTES_PER_VALUE,
)
from ..model.mechanism import Mechanism
from ..runs import DYNAMIC, Case
from ..sim import simulate
from ..sim.steps import kinematic_clock
from ..units import RunKind
from .options import Options, check_duration, check_speed, has_masses


@dataclass(frozen=True)
class RunCost:
    """One MuJoCo run's size, estimated before it starts (:func:`estimate`).

    ``run`` what it is ('kinematic run' ...); ``samples`` it records (a float: it can be
    astronomically many) of ``values`` each; ``options`` what changes it, for messages.
    ``memory`` and ``csv`` are bytes (limits.TRACE_BYTES_PER_VALUE, CSV_BYTES_PER_VALUE).
    """

    run: str
    samples: float
    values: int
    options: str

    @property
    def memory(self) -> float:
        return self.samples * self.values * TRACE_BYTES_PER_VALUE

    @property
    def csv(self) -> float:
        return self.samples * self.values * CSV_BYTES_PER_VALUE

    def describe(self) -> str:
        """'the kinematic run records about 125,664 samples of 118 values: about 890 MB of
        memory and 341 MB of CSV'."""
        return (
            f"the {self.run} records about {self.samples:,.0f} samples of {self.values} values: about "
            f"{_bytes(self.memory)} of memory and {_bytes(self.csv)} of CSV"
        )


@dataclass(frozen=True)
class Estimate:
    """What a command will cost: its MuJoCo ``runs`` and the video's ``frames`` (0: no video)."""

    runs: tuple[RunCost, ...]
    frames: int = 0

    @property
    def long(self) -> RunCost | None:
        """The first run long enough to say so before it starts (limits.LONG_RUN_SAMPLES)."""
        return next((r for r in self.runs if r.samples > LONG_RUN_SAMPLES), None)


def _bytes(n: float) -> str:
    for unit, f in (("TB", 1e12), ("GB", 1e9), ("MB", 1e6), ("kB", 1e3)):
        if n >= f:
            return f"{n / f:.3g} {unit}"
    return f"{n:.0f} bytes"


def values_per_sample(mech: Mechanism) -> int:
    """Values a run records per sample: time and crank (4), position, velocity and acceleration
    of every point (9 each), per link its speeds, joint and loads (7 each), thread and gap (3)."""
    return 7 + 9 * len(mech.point_names) + 7 * len(mech.links)


def estimate(
    mech: Mechanism,
    opts: Options = Options(),
    *,
    kinematic: bool = True,
    cycles_option: str | None = "--cycles",
    names: Mapping[str, str] | None = None,
) -> Estimate:
    """What :func:`run` with ``opts`` will cost for ``mech`` (``kinematic=False``: without the
    kinematic run, as :func:`steady` does), estimated before anything starts. ``cycles_option``
    the option that sets the kinematic run's cycles, for messages (None: only the file's);
    ``names`` what the messages call the options ``--speed``, ``--cycles`` and ``--duration``
    where they come from elsewhere (the Python API's arguments).

    Samples of each run times the values it records give its memory and CSV; the video's frames
    are ``video_seconds`` x ``fps``. Raises MjlinkError, one line with the estimate and the
    option to change, beyond limits.MAX_TRACE_BYTES, MAX_CSV_BYTES, MAX_VIDEO_FRAMES or MAX_FPS
    (mechanisms/README.md, "Limits"), and for a speed, cycle count or duration outside its
    bounds.
    """

    def named(option: str) -> str:
        return (names or {}).get(option, option)

    values = values_per_sample(mech)
    runs = []
    if kinematic:
        w = mech.speed if opts.speed is None else opts.speed
        check_speed(named("--speed"), w)
        n = mech.cycles if opts.cycles is None else opts.cycles
        if not (math.isfinite(n) and 0 < n <= MAX_CYCLES):
            raise MjlinkError(
                f"{named('--cycles')} must be a positive number of crank periods, at most {MAX_CYCLES:g} "
                f"(mechanisms/README.md, Limits), got {n:g}"
            )
        clock = kinematic_clock(mech.period, w, n)
        # As a float (the clock's steps are an int): it may be astronomically many.
        samples = clock.duration / clock.settings.timestep + 1
        speed = named("--speed")
        hint = (
            f"lower {named(cycles_option)} or raise {speed}"
            if cycles_option
            else f"raise {speed} (or lower [input] cycles)"
        )
        runs.append(RunCost("kinematic run", samples, values, hint))
    if opts.dynamics and has_masses(mech):
        d = mech.dynamics.duration if opts.duration is None else opts.duration
        check_duration(d, named("--duration"))
        case = simulate.dynamic_case(mech, duration=d)
        runs.append(RunCost("dynamic run", float(case.samples), values, f"lower {named('--duration')}"))
    if opts.steady and mech.steady is not None:
        # Two runs (without and with the flywheel) of 3 periods sampled every step; the mean
        # speed stays below the no-load speed, so this is a lower bound.
        periods = 3 * 2 * math.pi / abs(mech.steady.motor.no_load_speed)
        runs.append(
            RunCost("steady-motion runs", 2 * (periods / DYNAMIC.timestep + 1), values, "raise --no-load-speed")
        )
    for r in runs:
        if r.memory > MAX_TRACE_BYTES or r.csv > MAX_CSV_BYTES:
            raise MjlinkError(
                f"{r.describe()}; at most {_bytes(MAX_TRACE_BYTES)} of memory and {_bytes(MAX_CSV_BYTES)} of CSV "
                f"(mechanisms/README.md, Limits): {r.options}"
            )
    frames = 0
    if opts.video:
        if not (math.isfinite(opts.fps) and 0 < opts.fps <= MAX_FPS):
            raise MjlinkError(f"--fps must be between 1 and {MAX_FPS} frames/s, got {opts.fps:g}")
        if not (math.isfinite(opts.video_seconds) and opts.video_seconds > 0):
            raise MjlinkError(f"--video-seconds must be a positive finite number, got {opts.video_seconds:g} s")
        wanted = opts.video_seconds * opts.fps
        if wanted > MAX_VIDEO_FRAMES:
            raise MjlinkError(
                f"the video would have {wanted:,.0f} frames ({opts.video_seconds:g} s at {opts.fps:g} fps); at most "
                f"{MAX_VIDEO_FRAMES:,} (mechanisms/README.md, Limits): lower --video-seconds or --fps"
            )
        frames = round(wanted)
        if frames < 1:
            raise MjlinkError(
                f"the video would have no frame ({opts.video_seconds:g} s at {opts.fps:g} fps): raise --video-seconds"
            )
    return Estimate(tuple(runs), frames)


def enough_samples(mech: Mechanism, case: Case, option: str) -> None:
    """Refuse a run too short to be compared with the reference (fewer than compare.MIN_SAMPLES
    samples), before it starts; the message names the option that lengthens it and how far."""
    if case.samples >= compare.MIN_SAMPLES:
        return
    need = (compare.MIN_SAMPLES - 1) * case.sample_every * case.settings.timestep  # s
    if case.kind == RunKind.KINEMATICS:
        least = f"{option} of at least {need * abs(case.omega0) / mech.period:.3g}"
    else:
        least = f"{option} of at least {need:.3g} s"
    raise SimulationError(
        f"the {'kinematic' if case.kind == RunKind.KINEMATICS else 'dynamic'} run would have only "
        f"{case.samples} sample{'s' if case.samples != 1 else ''} ({case.duration:.3g} s): at least "
        f"{compare.MIN_SAMPLES} are needed to compare it with the reference; give {least}"
    )
