"""The one orchestrator: every command's work, in order, as typed results.

Each layer lives in its own module: :mod:`.sim` (MuJoCo runs and video), :mod:`.reference`
(the vector-method analysis), :mod:`.compare` (agreement and every threshold), :mod:`.output`
(files), :mod:`.plotting` (figures). This module only orders and times them, and returns frozen
dataclasses; the command line (:mod:`mjlink.cli`) parses arguments, calls one function here and
prints what it returns.

=================  ===================  ==========================================
function           command              result, output
=================  ===================  ==========================================
:func:`run`        ``simulate``         :class:`SimulateResult`, folder ``OUT/NAME/``
:func:`loads`      ``torque``,          :class:`LoadsResult`, folder ``OUT/NAME_loads/``
                   ``reactions``
:func:`steady`     ``steady``           :class:`SteadyResult`, folder ``OUT/NAME_steady/``
:func:`build`      ``build``            :class:`BuildResult`, the MJCF (and a file)
:func:`synthesize` ``synth``            :class:`SynthResult`; :func:`write_design` its file
:func:`.study.run` ``study``            :class:`.study.StudyResult`, ``OUT/NAME-study/``
=================  ===================  ==========================================

Every output folder is all or nothing (:func:`output.staged_dir`), every single file too
(:func:`output.write_text`). Units SI (m, rad, s, kg, N, N*m, W) unless a name says otherwise
(``speed_rpm``). Errors are one-line :class:`MjlinkError` subclasses; where the value at fault
can come from a command-line option, the message names the option.
"""

from __future__ import annotations

import contextlib
import ctypes
import dataclasses
import functools
import gc
import math
import os
import pickle
import platform
import shlex
import signal
import sys
import threading
import time
import traceback
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .. import analysis, compare, output, reference, validation
from ..errors import MjlinkError, SimulationError
from ..model import catalogue, names
from ..model.limits import (
    CSV_BYTES_PER_VALUE,
    LONG_RUN_SAMPLES,
    MAX_CSV_BYTES,
    MAX_DURATION_S,
    MAX_FPS,
    MAX_LENGTH_MM,
    MAX_SPEED,
    MAX_SYNTH_PRESSURE_DEG,
    MAX_SYNTH_RATIO,
    MAX_TRACE_BYTES,
    MAX_VIDEO_FRAMES,
    MIN_BAR_MM,
    MIN_DURATION_S,
    MIN_SPEED,
    TRACE_BYTES_PER_VALUE,
)
from ..model.mechanism import Mechanism, Motor, SteadyCase, parse
from ..reference import synthesis
from ..runs import DYNAMIC, KINEMATIC, Case, Settings, Trace
from ..sim import builder, simulate
from ..units import DEG, MM, RunKind, to_rpm

STEADY_DEFINITION = "delta = (omega_max - omega_min) / omega_mean, omega_mean = time average over a period"
DEFAULT_TARGET_DELTA = SteadyCase.target_delta  # the file format's default coefficient of speed fluctuation
SYNTHESIS_PROBLEMS = ("crank_slider",)  # what synthesize knows how to solve

# A plot to draw later, with its arguments bound: picklable, so that a forked worker can draw it.
PlotJob = Callable[[], object]


# ============================================================================ options
@dataclass(frozen=True)
class Options:
    """What :func:`run` does (:func:`estimate` says what it will cost, and refuses the absurd).

    ``speed`` rad/s, signed, counter-clockwise positive about +Z as the file's ``[input]
    speed`` (a sign opposite to the file's turns the crank the other way), and ``cycles``
    crank periods of the kinematic run (None: the file's);
    ``duration`` s of the dynamic run (None: the file's); ``dynamics`` the forward-dynamics run
    (when the file has masses and a [dynamics] table); ``loads`` the driving torque and pair
    reactions (when it has masses); ``steady`` the steady-motion and flywheel study (needs a
    motor); ``plots`` the PNG figures; ``video`` the MP4, ``video_seconds`` s long at ``fps``
    frames/s, ``width`` x ``height`` pixels.
    """

    speed: float | None = None
    cycles: float | None = None
    duration: float | None = None
    dynamics: bool = True
    plots: bool = True
    video: bool = True
    video_seconds: float = 3.0
    fps: int = 30
    width: int = 640
    height: int = 480
    loads: bool = True
    steady: bool = False


@dataclass(frozen=True)
class Drive:
    """Drive, load and duration of the dynamic runs in place of the file's (None: the file's).

    ``moment`` constant driving moment on the crank, N*m; ``damping`` viscous damping on it,
    N*m*s; ``omega0`` initial crank speed of the dynamic run, rad/s; ``duration`` s;
    ``stall_torque`` N*m and ``no_load_speed`` rad/s, together, a linear motor characteristic;
    ``target_delta`` the coefficient of speed fluctuation the flywheel is sized for. Speeds and
    moments are signed as in the file: counter-clockwise positive about +Z.
    """

    moment: float | None = None
    damping: float | None = None
    omega0: float | None = None
    duration: float | None = None
    stall_torque: float | None = None
    no_load_speed: float | None = None
    target_delta: float | None = None


def has_masses(mech: Mechanism) -> bool:
    """Whether the file defines a forward-dynamics case: a [dynamics] table and masses."""
    return mech.has_dynamics and _has_mass(mech)


def _has_mass(mech: Mechanism) -> bool:
    """Whether any link has a mass: the loads need nothing more."""
    return any(l.mass > 0 for l in mech.links)


def speed_text(w: float) -> str:
    """A speed as errors show it, in both units the command line takes: '0 rad/s (0 rpm)'."""
    return f"{w:g} rad/s ({to_rpm(w):.4g} rpm)"


def check_speed(option: str, w: float | None, given: str | None = None) -> None:
    """Raise MjlinkError unless the crank speed ``w`` (rad/s, signed; None: not given) is within
    the range the simulation is made for; the message names ``option`` and the value as the
    user wrote it (``given``, e.g. '0 rpm'; default both units)."""
    if w is None:
        return
    if not (math.isfinite(w) and MIN_SPEED <= abs(w) <= MAX_SPEED):
        raise MjlinkError(
            f"{option} must be between {MIN_SPEED:g} and {MAX_SPEED:g} rad/s in magnitude "
            f"({to_rpm(MIN_SPEED):.3g} to {to_rpm(MAX_SPEED):.3g} rpm), got {given or speed_text(w)}"
        )


# ---------------------------------------------------------------------------- cost
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
    mech: Mechanism, opts: Options = Options(), *, kinematic: bool = True, cycles_option: str | None = "--cycles"
) -> Estimate:
    """What :func:`run` with ``opts`` will cost for ``mech`` (``kinematic=False``: without the
    kinematic run, as :func:`steady` does), estimated before anything starts. ``cycles_option``
    the option that sets the kinematic run's cycles, for messages (None: only the file's).

    Samples of each run times the values it records give its memory and CSV; the video's frames
    are ``video_seconds`` x ``fps``. Raises MjlinkError, one line with the estimate and the
    option to change, beyond limits.MAX_TRACE_BYTES, MAX_CSV_BYTES, MAX_VIDEO_FRAMES or MAX_FPS
    (mechanisms/README.md, "Limits"), and for a speed or duration outside its bounds.
    """
    values = values_per_sample(mech)
    runs = []
    if kinematic:
        w = mech.speed if opts.speed is None else opts.speed
        check_speed("--speed", w)
        n = mech.cycles if opts.cycles is None else opts.cycles
        if not (math.isfinite(n) and n > 0):
            raise MjlinkError(f"--cycles must be a positive finite number, got {n:g}")
        samples = n * mech.period / abs(w) / KINEMATIC.timestep + 1
        hint = f"lower {cycles_option} or raise --speed" if cycles_option else "raise --speed (or lower [input] cycles)"
        runs.append(RunCost("kinematic run", samples, values, hint))
    if opts.dynamics and has_masses(mech):
        d = mech.dynamics.duration if opts.duration is None else opts.duration
        _check_duration(d)
        case = simulate.dynamic_case(mech, duration=d)
        runs.append(RunCost("dynamic run", float(case.samples), values, "lower --duration"))
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


def _check_duration(d: float, option: str = "--duration") -> None:
    if not (math.isfinite(d) and MIN_DURATION_S <= d <= MAX_DURATION_S):
        raise MjlinkError(
            f"{option} must be between {MIN_DURATION_S:g} and {MAX_DURATION_S:g} s (mechanisms/README.md, "
            f"Limits), got {d:g} s"
        )


def with_drive(mech: Mechanism, drive: Drive, *, steady: bool = False) -> Mechanism:
    """``mech`` with the ``drive`` overrides applied, each validated (messages name the option).

    The motor characteristic becomes the file's [dynamics.motor] (unless ``steady``: then it
    drives only the steady-motion study) and, with ``target_delta``, its [steady] case. Raises
    MjlinkError for a non-finite value, a negative damping, a duration or speed outside its
    limits (mechanisms/README.md, "Limits"), half a motor characteristic or one of mixed signs,
    or a target delta outside (0, 2). Messages give values in the option's own unit.
    """
    dyn = mech.dynamics
    changes: dict[str, Any] = {}
    units = {"moment": "N*m", "damping": "N*m*s", "duration": "s"}
    for key in ("moment", "damping", "omega0", "duration"):
        v = getattr(drive, key)
        if v is None:
            continue
        if key == "omega0":
            if not (math.isfinite(v) and abs(v) <= MAX_SPEED):
                raise MjlinkError(
                    f"--omega0 must be at most {MAX_SPEED:g} rad/s ({to_rpm(MAX_SPEED):.3g} rpm) in magnitude, "
                    f"got {speed_text(v)}"
                )
        elif key == "duration":
            _check_duration(v)
        elif not math.isfinite(v) or (key == "damping" and v < 0):
            raise MjlinkError(
                f"--{key} must be a finite number{' >= 0' if key == 'damping' else ''}, got {v:g} {units[key]}"
            )
        changes[key] = v
    ts, w0 = drive.stall_torque, drive.no_load_speed
    motor = None
    if ts is None or w0 is None:
        if ts is not None or w0 is not None:
            raise MjlinkError("--stall-torque and --no-load-speed go together (a linear motor characteristic)")
    else:
        if not (math.isfinite(ts) and math.isfinite(w0)) or ts == 0 or w0 == 0 or (ts > 0) != (w0 > 0):
            raise MjlinkError(
                "--stall-torque and --no-load-speed must be finite, non-zero and of the same sign, got "
                f"{ts:g} N*m and {speed_text(w0)}"
            )
        check_speed("--no-load-speed", w0)
        motor = Motor(ts, w0)
        if not steady:
            changes["motor"] = motor
    if changes:
        mech = dataclasses.replace(
            mech, dynamics=dataclasses.replace(dyn, **changes), has_dynamics=mech.has_dynamics or bool(changes)
        )
    target = drive.target_delta
    if target is not None and not (0 < target < 2):
        raise MjlinkError(f"--target-delta must be between 0 and 2, got {target:g}")
    if motor is not None or target is not None:
        base = mech.steady or (SteadyCase(mech.dynamics.motor) if mech.dynamics.motor else None)
        m = motor or (base.motor if base else None)
        if m is not None:
            mech = dataclasses.replace(
                mech,
                steady=SteadyCase(
                    m, target if target is not None else (base.target_delta if base else DEFAULT_TARGET_DELTA)
                ),
            )
    return mech


# ============================================================================ results
def settings_dict(s: Settings) -> dict[str, Any]:
    """A model's numerical settings as the report records them (timestep s)."""
    return {
        "integrator": s.integrator,
        "timestep_s": s.timestep,
        "solref": list(s.solref),
        "solimp": list(s.solimp),
        "solver_tolerance": s.tolerance,
    }


@dataclass(frozen=True)
class KinematicsSummary:
    """The constant-speed MuJoCo run.

    ``speed`` crank speed, rad/s (signed, CCW positive); ``duration`` s; ``settings`` the
    model's numerical settings, whose ``flywheel`` (kg*m^2) is the armature that holds the
    speed (how well it held is the agreement's checked ``crank speed held``).
    """

    speed: float
    duration: float
    settings: Settings

    def as_dict(self) -> dict[str, Any]:
        """The report's ``kinematics`` entry."""
        return {
            "speed_rad_s": self.speed,
            "duration_s": self.duration,
            "settings": settings_dict(self.settings),
            "flywheel_armature_kg_m2": self.settings.flywheel,
        }


@dataclass(frozen=True)
class Rk4Comparison:
    """The paper's fixed-step RK4 (``steps`` steps over the file's duration, its
    ``[dynamics] paper_rk4_steps``) against the tight ODE solution.

    ``omega_final`` RK4's final crank speed, rad/s; ``omega_max_abs_diff`` the largest
    difference in crank speed, rad/s; ``omega_max_rel_diff`` that relative to the largest speed;
    ``omega_final_rel_diff`` the final speeds' difference relative to the tight final speed.
    """

    omega_final: float
    omega_max_abs_diff: float
    omega_max_rel_diff: float
    omega_final_rel_diff: float
    steps: int

    def as_dict(self) -> dict[str, Any]:
        return {
            "steps": self.steps,
            "omega_final_rad_s": self.omega_final,
            "omega_max_abs_diff_rad_s": self.omega_max_abs_diff,
            "omega_max_rel_diff": self.omega_max_rel_diff,
            "omega_final_rel_diff": self.omega_final_rel_diff,
        }


@dataclass(frozen=True)
class DynamicsSummary:
    """The forward-dynamics MuJoCo run and the reference's solution of the equation of motion.

    ``moment`` driving moment, N*m; ``damping`` N*m*s; ``duration`` s; ``settings`` the model's
    numerical settings; ``omega_final_mujoco`` and ``omega_final_reference`` the final crank
    speeds, rad/s; ``ode_rtol`` the reference ODE's relative tolerance (LSODA's, when it is
    the solver) and ``ode_method`` what solved it (:func:`mjlink.reference.forward_dynamics`); ``spectral_harmonics``
    and ``spectral_error`` the harmonics of the reduced inertia's series and its relative
    error; ``rk4`` the paper's method against it (None when the duration is not the file's).
    """

    moment: float
    damping: float
    duration: float
    settings: Settings
    omega_final_mujoco: float
    omega_final_reference: float
    ode_rtol: float
    spectral_harmonics: int
    spectral_error: float
    rk4: Rk4Comparison | None = None
    ode_method: str = "energy"

    def as_dict(self) -> dict[str, Any]:
        """The report's ``dynamics`` entry."""
        d: dict[str, Any] = {
            "moment_N_m": self.moment,
            "damping_N_m_s": self.damping,
            "duration_s": self.duration,
            "settings": settings_dict(self.settings),
            "omega_final_rad_s": {"mujoco": self.omega_final_mujoco, "reference": self.omega_final_reference},
            "reference_ode": {
                "method": self.ode_method,
                **(
                    {"newton_tol_rel": reference.energy.NEWTON_TOL, "panel_tail_rel": reference.energy.TAIL}
                    if self.ode_method == "energy"
                    else {"rtol": self.ode_rtol}
                ),
                "spectral_harmonics": self.spectral_harmonics,
                "spectral_error_rel": self.spectral_error,
            },
        }
        if self.rk4 is not None:
            d[f"paper_rk4_{self.rk4.steps}_steps"] = self.rk4.as_dict()
        return d


@dataclass(frozen=True)
class LoadsSummary:
    """Driving torque and pair reactions of the constant-speed run, MuJoCo against kinetostatics.

    ``speed`` crank speed, rad/s (the run's mean); ``torque_peak`` max |tau| and ``torque_rms``,
    N*m, and ``power_mean`` W, of the reference torque; ``torque_error`` max |tau_mj - tau_ref|
    relative to the reference torque's range; ``force_error`` the worst pair's force error
    relative to its largest force; ``pairs`` per pair label (``P3:lever-rocker``) its largest
    force (``max_force_N``, ``max_force_mujoco_N``), ``error_rel`` and, for a prismatic pair,
    ``max_moment_N_m`` and ``moment_error`` (see :class:`compare.Loads`); ``torque_threshold``
    and ``force_threshold`` the limits on the two errors; ``failures`` the limits missed.
    """

    speed: float
    torque_peak: float
    torque_rms: float
    power_mean: float
    torque_error: float
    force_error: float
    pairs: Mapping[str, Mapping[str, float]]
    torque_threshold: float
    force_threshold: float
    failures: tuple[str, ...] = ()
    shaking_force_error: float = 0.0
    shaking_moment_error: float | None = 0.0

    @property
    def speed_rpm(self) -> float:
        """Crank speed, rev/min (signed)."""
        return to_rpm(self.speed)

    def as_dict(self) -> dict[str, Any]:
        """The report's ``loads`` entry (the failures go to the report's own list)."""
        return {
            "speed_rad_s": self.speed,
            "speed_rpm": self.speed_rpm,
            "torque_peak_N_m": self.torque_peak,
            "torque_rms_N_m": self.torque_rms,
            "power_mean_W": self.power_mean,
            "torque_error_rel": self.torque_error,
            "force_error_rel": self.force_error,
            "pairs": self.pairs,
            # The frame's shaking force and moment, relative to the reference's range (the
            # moment of a geared mechanism is not compared: None).
            "shaking_force_error_rel": self.shaking_force_error,
            "shaking_moment_error_rel": self.shaking_moment_error,
            "thresholds": {
                "torque_rel": self.torque_threshold,
                "force_rel": self.force_threshold,
                "shaking_rel": compare.SHAKING_REL,
            },
        }


@dataclass(frozen=True)
class SteadySummary:
    """Steady motion under the motor characteristic, and the flywheel for the target.

    ``stall_torque`` N*m and ``no_load_speed`` rad/s of the motor; ``omega_mean`` the mean crank
    speed, rad/s; ``delta`` the reference's coefficient of speed fluctuation and
    ``delta_mujoco`` MuJoCo's on the same orbit; ``target_delta`` the one wanted; ``flywheel``
    the inertia on the crank that gives it, kg*m^2, with ``delta_with_flywheel`` (reference),
    ``delta_with_flywheel_mujoco`` and ``omega_mean_with_flywheel`` rad/s; ``failures`` where
    MuJoCo and the reference disagree (:func:`compare.steady_failures`).
    """

    stall_torque: float
    no_load_speed: float
    omega_mean: float
    delta: float
    delta_mujoco: float
    target_delta: float
    flywheel: float
    delta_with_flywheel: float
    delta_with_flywheel_mujoco: float
    omega_mean_with_flywheel: float
    failures: tuple[str, ...] = ()

    @property
    def n_mean_rpm(self) -> float:
        """Mean crank speed, rev/min (signed)."""
        return to_rpm(self.omega_mean)

    def as_dict(self) -> dict[str, Any]:
        """The report's ``steady`` entry, with its own ``failures``."""
        return {
            "motor": {"stall_torque_N_m": self.stall_torque, "no_load_speed_rad_s": self.no_load_speed},
            "omega_mean_rad_s": self.omega_mean,
            "n_mean_rpm": self.n_mean_rpm,
            "delta": self.delta,
            "delta_mujoco": self.delta_mujoco,
            "target_delta": self.target_delta,
            "flywheel_kg_m2": self.flywheel,
            "delta_with_flywheel": self.delta_with_flywheel,
            "delta_with_flywheel_mujoco": self.delta_with_flywheel_mujoco,
            "omega_mean_with_flywheel_rad_s": self.omega_mean_with_flywheel,
            "definition": STEADY_DEFINITION,
            "failures": list(self.failures),
        }


@dataclass(frozen=True)
class VideoSummary:
    """The MP4: ``file`` name in the output folder, ``frames``, ``fps`` frames/s, ``width`` x
    ``height`` pixels, the OpenGL ``backend`` and ``slowed_down_by`` (video seconds per
    simulated second)."""

    file: str
    frames: int
    fps: float
    width: int
    height: int
    backend: str
    slowed_down_by: float

    def as_dict(self) -> dict[str, Any]:
        return {
            "file": self.file,
            "frames": self.frames,
            "fps": self.fps,
            "size": [self.width, self.height],
            "backend": self.backend,
            "slowed_down_by": self.slowed_down_by,
        }


@dataclass(frozen=True)
class Timings:
    """Wall-clock seconds of each stage of :func:`run`, rounded to 0.1 ms; None for a stage that
    did not run. With both a video and plots, the plots are drawn in a forked worker while the
    video renders: ``video_and_plots`` is that time and ``plots_after_video`` the wait for the
    worker afterwards; otherwise ``plots`` (recorded even when there are none) and ``video``.
    Fields are in the order the stages run."""

    mujoco_kinematics: float
    reference_kinematics: float
    mujoco_dynamics: float | None = None
    reference_dynamics: float | None = None
    loads: float | None = None
    steady: float | None = None
    plots: float | None = None
    video: float | None = None
    video_and_plots: float | None = None
    plots_after_video: float | None = None
    total: float = 0.0

    def as_dict(self) -> dict[str, float]:
        """The report's ``timings``: ``NAME_s`` for every stage that ran."""
        return {f"{f.name}_s": v for f in dataclasses.fields(self) if (v := getattr(self, f.name)) is not None}


@dataclass(frozen=True)
class Provenance:
    """How an output was made: ``versions`` of mjlink, MuJoCo, Python and NumPy; ``command``
    the command line (empty when called from Python); ``options`` what the command asked for
    (units as in :class:`Options`). The numerical settings are recorded with each run."""

    versions: Mapping[str, str]
    command: tuple[str, ...] = ()
    options: Mapping[str, Any] = field(default_factory=dict)

    def as_dict(self) -> dict[str, Any]:
        return {
            "versions": dict(self.versions),
            "command": shlex.join(self.command) if self.command else None,
            "options": dict(self.options),
        }


def provenance(command: Sequence[str] = (), options: Mapping[str, Any] | None = None) -> Provenance:
    """The :class:`Provenance` of an output made now by ``command`` with ``options``."""
    from .. import __version__

    versions = {
        "mjlink": __version__,
        "mujoco": builder.mujoco_version(),
        "python": platform.python_version(),
        "numpy": np.__version__,
    }
    return Provenance(versions, tuple(command), dict(options or {}))


@dataclass(frozen=True)
class SimulateResult:
    """What :func:`run` did for one mechanism, all written under ``out_dir``.

    ``mechanism``, ``title`` and ``source`` from the file; ``mujoco_version``; ``kinematics``
    and, when run, ``dynamics``, ``loads``, ``steady`` and ``video``; ``agreements`` MuJoCo
    against the reference per run (kinematics, then dynamics) with ``thresholds`` their limits
    (:func:`compare.thresholds`); ``failures`` every limit missed (agreement, loads, steady);
    ``timings``; ``files`` the names in ``out_dir``. :meth:`as_dict` is ``report.json``.
    """

    mechanism: str
    title: str
    source: str
    mujoco_version: str
    out_dir: Path
    kinematics: KinematicsSummary
    agreements: tuple[compare.Agreement, ...]
    thresholds: Mapping[str, float]
    failures: tuple[str, ...]
    timings: Timings
    dynamics: DynamicsSummary | None = None
    loads: LoadsSummary | None = None
    steady: SteadySummary | None = None
    video: VideoSummary | None = None
    files: tuple[str, ...] = field(default=())
    provenance: Provenance | None = None

    def as_dict(self) -> dict[str, Any]:
        """The contents of ``report.json``."""
        d: dict[str, Any] = {
            "mechanism": self.mechanism,
            "title": self.title,
            "source": self.source,
            "mujoco_version": self.mujoco_version,
            "kinematics": self.kinematics.as_dict(),
        }
        if self.dynamics is not None:
            d["dynamics"] = self.dynamics.as_dict()
        if self.loads is not None:
            d["loads"] = self.loads.as_dict()
        if self.steady is not None:
            d["steady"] = self.steady.as_dict()
        d["agreement"] = {a.kind: a.as_dict() for a in self.agreements}
        d["thresholds"] = dict(self.thresholds)
        d["failures"] = list(self.failures)
        if self.video is not None:
            d["video"] = self.video.as_dict()
        d["timings"] = self.timings.as_dict()
        if self.provenance is not None:
            d["provenance"] = self.provenance.as_dict()
        return d


@dataclass(frozen=True)
class LoadsResult:
    """What :func:`loads` did: the ``loads`` of ``mechanism`` at constant speed, written to
    ``out_dir``. :meth:`as_dict` is its ``report.json``."""

    mechanism: str
    out_dir: Path
    loads: LoadsSummary
    provenance: Provenance | None = None

    @property
    def failures(self) -> tuple[str, ...]:
        return self.loads.failures

    def as_dict(self) -> dict[str, Any]:
        d = {"mechanism": self.mechanism, "loads": self.loads.as_dict(), "failures": list(self.failures)}
        if self.provenance is not None:
            d["provenance"] = self.provenance.as_dict()
        return d


@dataclass(frozen=True)
class SteadyResult:
    """What :func:`steady` did: the ``steady`` study of ``mechanism``, written to ``out_dir``.
    :meth:`as_dict` is its ``report.json``."""

    mechanism: str
    out_dir: Path
    steady: SteadySummary
    provenance: Provenance | None = None

    @property
    def failures(self) -> tuple[str, ...]:
        return self.steady.failures

    def as_dict(self) -> dict[str, Any]:
        d: dict[str, Any] = {"mechanism": self.mechanism, "steady": self.steady.as_dict()}
        if self.provenance is not None:
            d["provenance"] = self.provenance.as_dict()
        return d


@dataclass(frozen=True)
class BuildResult:
    """The MJCF of ``mechanism``: ``xml`` built with ``settings``, written to ``path`` (None: not
    written)."""

    mechanism: str
    settings: Settings
    xml: str
    path: Path | None = None


@dataclass(frozen=True)
class SynthResult:
    """Metric synthesis of the offset crank-slider (seed 002) for one requirement.

    ``stroke`` S and ``offset`` e, m; ``ratio`` lambda = r / l; ``max_pressure_angle`` the
    allowed [theta], rad; ``table`` every root of the quartic judged, as text; ``best`` the
    accepted root with the smallest pressure angle (None: none admissible); ``largest_ratio``
    the largest admissible lambda on a 0.01 grid (None: none), ``at_largest`` its best root and
    ``beyond_largest`` the first root at the next lambda (None when that root has no pressure
    angle). Lengths of a :class:`synthesis.Root` in m, angles rad.
    """

    stroke: float
    offset: float
    ratio: float
    max_pressure_angle: float
    table: str
    best: synthesis.Root | None
    largest_ratio: float | None
    at_largest: synthesis.Root | None
    beyond_largest: synthesis.Root | None


# ============================================================================ simulate
class _Clock:
    """Lap times of the stages, in s rounded to 0.1 ms."""

    def __init__(self) -> None:
        self.start = self.t = time.perf_counter()
        self.laps: dict[str, float] = {}

    def lap(self, stage: str) -> None:
        self.laps[stage] = round(time.perf_counter() - self.t, 4)
        self.t = time.perf_counter()

    def timings(self) -> Timings:
        return Timings(**self.laps, total=round(time.perf_counter() - self.start, 4))


@dataclass(frozen=True)
class _DynamicRun:
    """The forward-dynamics stage: its report entry and agreement, MuJoCo's and the reference's
    traces, and the paper's RK4 solution (None when not computed), for the plots."""

    summary: DynamicsSummary
    agreement: compare.Agreement
    mujoco_trace: Trace
    reference_trace: Trace
    rk4: reference.Motion | None
    model: builder.Built  # the run's model, built with the settings model.xml carries


def run(
    mech: Mechanism,
    out_root: Path | str,
    opts: Options = Options(),
    *,
    force: bool = False,
    command: Sequence[str] = (),
    progress: Callable[[str, float], None] | None = None,
) -> SimulateResult:
    """Run everything ``opts`` asks for ``mech`` and write ``<out_root>/<name>/``.

    The kinematic run, its reference and their agreement always; the forward-dynamics run, the
    loads, the steady-motion study, plots and video as ``opts`` says and the file allows. The
    folder holds the traces as CSV, ``report.json`` (:meth:`SimulateResult.as_dict`),
    ``model.xml`` (the dynamic model) and the figures and video, and its marker
    (:func:`output.staged_dir`, kind ``simulate``): it replaces the files an earlier ``simulate``
    wrote there and keeps any other file, or is not written at all if anything fails. A folder
    mjlink did not write for ``simulate`` of this mechanism is refused unless ``force``.

    Raises SimulationError if MuJoCo leaves the reference's assembly branch or diverges,
    OutputError if the folder cannot be written, RenderError if the video cannot be made.
    """
    estimate(mech, opts)  # the absurd is refused before anything starts, whoever calls
    clock = _Clock()
    out_dir = Path(out_root) / mech.name
    with output.staged_dir(out_dir, kind="simulate", force=force, mechanism=mech.name, command=command) as stage:
        kcase = simulate.kinematic_case(mech, speed=opts.speed, cycles=opts.cycles)
        _enough_samples(mech, kcase, "--cycles")
        kin_mj = simulate.run(mech, kcase, progress=_tell(progress, "kinematic run"))
        # The reference at MuJoCo's own crank angles, solved once: the branch watchdog's, the
        # agreement's, the residual panels' and the frame loads'.
        at_kin = compare.unchecked_at(mech, kin_mj.phi)
        _same_branch(mech, kin_mj, at_kin)
        clock.lap("mujoco_kinematics")
        kin_ref = reference.reference_trace(
            mech, reference.constant_speed(mech, kin_mj.time, kcase.omega0), RunKind.KINEMATICS
        )
        # The reference at MuJoCo's own crank state: the agreement's and the residual panels'.
        kin_at = compare.reference_at(mech, kin_mj, at_kin)
        agreements = [compare.agreement(mech, kin_mj, ref=kin_at)]
        clock.lap("reference_kinematics")
        output.write_csv(stage / "kinematics.csv", mech, kin_mj)
        output.write_csv(stage / "reference_kinematics.csv", mech, kin_ref)
        kinematics = KinematicsSummary(kcase.omega0, kcase.duration, kcase.settings)

        # Figures are drawn in forked workers while this process goes on (two cores): those of
        # the kinematic run at once, beside the dynamic run; those of the dynamics and loads
        # beside the loads and the video. Without fork they are drawn here, in order.
        workers: list[_Worker] = []
        pending: list[PlotJob] = []

        def draw(jobs: list[PlotJob], *, now: bool = True) -> None:
            worker = _start(jobs) if (jobs and now) else None
            if worker is not None:
                workers.append(worker)
            else:
                pending.extend(jobs)

        if opts.plots:
            from ..plotting import figures, style

            style.warm()  # once here, for every worker forked from this process
            # Residual panels subtract the reference at MuJoCo's own crank state, as the
            # agreement table does (the imposed speed holds to 1e-6, not exactly).
            draw([functools.partial(figures.kinematic_plots, mech, kin_mj, kin_at, stage)])

        dyn = None
        if opts.dynamics and has_masses(mech):
            dyn = _forward_dynamics(mech, opts.duration, stage, clock, progress)
            agreements.append(dyn.agreement)
            if opts.plots:
                from ..plotting import figures

                # The speed figures from the moment the dynamics are compared, beside the loads.
                draw(
                    [
                        functools.partial(
                            figures.speed_plots, mech, dyn.mujoco_trace, dyn.reference_trace, stage, dyn.rk4
                        )
                    ]
                )
        load_jobs: list[PlotJob] = []
        queue = load_jobs if opts.plots else None
        loads_summary = steady_summary = None
        if opts.loads and _has_mass(mech):
            loads_summary = _loads_study(mech, kin_mj, stage, queue, at_kin)
            clock.lap("loads")
        if opts.steady:
            steady_summary = _steady_study(mech, stage, queue)
            clock.lap("steady")
        failures = tuple(f for a in agreements for f in a.failures())
        failures += loads_summary.failures if loads_summary else ()
        failures += steady_summary.failures if steady_summary else ()

        # The loads' figures beside the video. Each group of figures is its own worker, started
        # as soon as its data exists: the two cores stay busy to the end rather than one
        # worker drawing the last figures alone while this process waits.
        draw(load_jobs)
        video = None
        if opts.video:
            video = _video(mech, kin_mj, kcase.settings, stage, opts, progress=not workers)
            clock.lap("video")
        run_jobs(pending)
        for w in workers:
            _finish(w)
        clock.lap("plots")
        result = SimulateResult(
            mechanism=mech.name,
            title=mech.title,
            source=mech.source,
            mujoco_version=builder.mujoco_version(),
            out_dir=out_dir,
            kinematics=kinematics,
            agreements=tuple(agreements),
            thresholds=compare.thresholds(),
            failures=failures,
            timings=clock.timings(),
            dynamics=dyn.summary if dyn else None,
            loads=loads_summary,
            steady=steady_summary,
            video=video,
            provenance=provenance(command, dataclasses.asdict(opts)),
        )
        output.write_json(stage / "report.json", result.as_dict())
        # The dynamic run's own model where it ran (its settings are DYNAMIC): not built again.
        xml = dyn.model.spec.to_xml() if dyn is not None else builder.to_xml(mech, DYNAMIC)
        output.write_text(stage / "model.xml", xml, in_stage=True)
        from ..plotting import page

        written = [p.name for p in stage.iterdir() if p.name != output.MARKER] + ["index.html"]
        output.write_text(stage / "index.html", page.index_html(result, written), in_stage=True)
        files = tuple(sorted(p.name for p in stage.iterdir() if p.name != output.MARKER))
    return dataclasses.replace(result, files=files)


def _tell(progress: Callable[[str, float], None] | None, what: str) -> Callable[[float], None] | None:
    """``progress`` for one run, named ``what``."""
    return None if progress is None else functools.partial(progress, what)


def _forward_dynamics(
    mech: Mechanism,
    duration: float | None,
    stage: Path,
    clock: _Clock,
    progress: Callable[[str, float], None] | None = None,
) -> _DynamicRun:
    """The dynamic run (``duration`` s, None: the file's), the reference's tight solution and,
    over the file's duration, the paper's RK4; their CSVs into ``stage``."""
    dcase = simulate.dynamic_case(mech, duration=duration)
    _enough_samples(mech, dcase, "--duration")
    built = builder.make(mech, dcase.settings)
    dyn_mj = simulate.run(mech, dcase, built, progress=_tell(progress, "dynamic run"))
    at_dyn = compare.unchecked_at(mech, dyn_mj.phi)
    _same_branch(mech, dyn_mj, at_dyn)
    clock.lap("mujoco_dynamics")
    sd = reference.SpectralDynamics(mech)
    motion = reference.forward_dynamics(mech, dyn_mj.time, sd=sd)
    dyn_ref = reference.reference_trace(mech, motion, RunKind.DYNAMICS)
    steps = mech.dynamics.paper_rk4_steps
    # Only a paper that integrated the equation of motion itself has an RK4 to show, and only
    # over its own interval (a shorter or longer run is not the paper's computation).
    rk4 = reference.rk4_dynamics(mech, steps, sd=sd) if steps and dcase.duration == mech.dynamics.duration else None
    agreement = compare.agreement(mech, dyn_mj, motion, ref=compare.reference_at(mech, dyn_mj, at_dyn))
    clock.lap("reference_dynamics")
    output.write_csv(stage / "dynamics.csv", mech, dyn_mj)
    output.write_csv(stage / "reference_dynamics.csv", mech, dyn_ref)
    paper = None
    if rk4 is not None:
        tight = _on_grid(motion, rk4.t) or reference.forward_dynamics(mech, rk4.t, sd=sd)
        d = np.abs(rk4.omega - tight.omega)
        paper = Rk4Comparison(
            float(rk4.omega[-1]),
            float(d.max()),
            float(d.max() / np.abs(tight.omega).max()),
            float(abs(rk4.omega[-1] - tight.omega[-1]) / abs(tight.omega[-1])),
            len(rk4.t) - 1,
        )
    summary = DynamicsSummary(
        mech.dynamics.moment,
        mech.dynamics.damping,
        dcase.duration,
        dcase.settings,
        float(dyn_mj.omega[-1]),
        float(motion.omega[-1]),
        reference.TIGHT_RTOL,
        sd.harmonics,
        sd.error,
        paper,
        motion.method,
    )
    return _DynamicRun(summary, agreement, dyn_mj, dyn_ref, rk4, built)


def _video(
    mech: Mechanism, kin_mj: Trace, settings: Settings, stage: Path, opts: Options, *, progress: bool
) -> VideoSummary:
    """The kinematic run as ``NAME.mp4`` in ``stage``."""
    from ..sim import render

    file = f"{mech.name}.mp4"
    info = render.render_video(
        mech,
        kin_mj,
        stage / file,
        seconds=opts.video_seconds,
        fps=opts.fps,
        width=opts.width,
        height=opts.height,
        settings=settings,
        progress=progress,
    )
    return VideoSummary(file, info.frames, info.fps, info.width, info.height, info.backend, info.time_scale)


def _enough_samples(mech: Mechanism, case: Case, option: str) -> None:
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


def _same_branch(mech: Mechanism, trace: Trace, at: reference.Kinematics | None = None) -> None:
    """Stop a run whose MuJoCo linkage snapped to the other assembly branch (near a dead point).
    ``at``: the reference at the run's own crank angles (:func:`compare.unchecked_at`)."""
    switched = compare.branch_switch(mech, trace, kin=at)
    if switched:
        raise SimulationError(switched)


def run_jobs(jobs: list[PlotJob]) -> None:
    """Draw the queued plots, in order."""
    for job in jobs:
        job()


class _Worker:
    """A forked process drawing plots into the stage: its ``pid``, the read end ``fd`` of the pipe
    its result comes through, and ``cancel``, which unregisters its stop hook from the stage."""

    def __init__(self, pid: int, fd: int) -> None:
        self.pid, self.fd = pid, fd
        self.reaped = False
        self.cancel: Callable[[], None] = lambda: None

    def stop(self) -> None:
        """Kill and reap the worker (the run failed or was interrupted); once only, so that a
        reaped PID, which the system may reuse, is never signalled."""
        if self.reaped:
            return
        self.reaped = True
        with contextlib.suppress(ProcessLookupError):
            os.kill(self.pid, signal.SIGKILL)
        with contextlib.suppress(ChildProcessError):
            os.waitpid(self.pid, 0)
        os.close(self.fd)


class _WorkerTraceback(Exception):
    """The plot worker's traceback, as the cause of the error it reported."""

    def __str__(self) -> str:
        return f"\n{self.args[0]}" if self.args else ""


def _start(jobs: list[PlotJob]) -> _Worker | None:
    """Draw ``jobs`` in a forked worker process while this one goes on (:func:`_finish` waits for
    it); None where fork is unavailable.

    The worker is part of the run and never outlives it. It ignores SIGINT and SIGTERM: the run
    decides, and a failing, interrupted or terminated run kills and reaps it before the stage is
    removed (its stop hook, :func:`output.on_discard`), so it cannot re-create the stage. It dies
    with this process when that is killed (Linux ``PR_SET_PDEATHSIG``; elsewhere it polls its
    parent). It reports through a pipe and ends with ``os._exit``, running none of the clean-ups
    it inherited (the stage's removal among them). Signals are held back across the fork, so that
    an interruption lands either before it or once the hook is registered.
    """
    if not hasattr(os, "fork"):
        return None
    parent = os.getpid()
    mask = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT, signal.SIGTERM})
    try:
        r, w = os.pipe()
        # Everything this process holds moved out of the collector's sight for the fork: the
        # worker's collections then never write to the inherited objects' headers, which would
        # copy page after page of the shared heap into the worker.
        gc.freeze()
        try:
            pid = os.fork()
        except OSError:
            gc.unfreeze()
            os.close(r)
            os.close(w)
            return None
        if pid == 0:
            code = 1
            try:
                os.close(r)
                code = _worker_main(jobs, w, parent, mask)
            finally:
                os._exit(code)
        gc.unfreeze()
        os.close(w)
        worker = _Worker(pid, r)
        worker.cancel = output.on_discard(worker.stop)
        return worker
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, mask)


def _worker_main(jobs: list[PlotJob], w: int, parent: int, mask: set[int | signal.Signals]) -> int:
    """The forked worker: draw ``jobs``, write nothing (success) or the pickled (error,
    traceback) to the pipe ``w``; returns the exit status."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_IGN)
    _die_with(parent)
    signal.pthread_sigmask(signal.SIG_SETMASK, mask)
    # No collections in this short-lived process: matplotlib's figures are cyclic garbage the
    # collector would chase through every few thousand allocations (0.3 s of CPU over the
    # take-up's figures); what they hold, some 50 MB in all, is freed when the worker exits.
    gc.disable()
    payload, code = b"", 0
    try:
        run_jobs(jobs)
    except BaseException as e:
        code, tb = 1, traceback.format_exc()
        try:
            payload = pickle.dumps((e, tb))
        except Exception:
            payload = pickle.dumps((MjlinkError(f"plot worker: {type(e).__name__}: {e}"), tb))
    view = memoryview(payload)
    while view:
        view = view[os.write(w, view) :]
    os.close(w)
    return code


def _die_with(parent: int) -> None:
    """Have this forked process killed when its parent ``parent`` dies."""
    armed = False
    if sys.platform.startswith("linux"):
        try:
            prctl = ctypes.CDLL(None, use_errno=True).prctl
            prctl.argtypes = [ctypes.c_int, ctypes.c_ulong, ctypes.c_ulong, ctypes.c_ulong, ctypes.c_ulong]
            prctl.restype = ctypes.c_int
            armed = prctl(1, signal.SIGKILL, 0, 0, 0) == 0  # PR_SET_PDEATHSIG
        except (OSError, AttributeError):
            pass
    if not armed:
        threading.Thread(target=_watch_parent, args=(parent,), daemon=True).start()
    if os.getppid() != parent:  # the parent died before the death signal was armed
        os._exit(1)


def _watch_parent(parent: int) -> None:
    while os.getppid() == parent:
        time.sleep(0.2)
    os._exit(1)


def _finish(worker: _Worker) -> None:
    """Wait for the worker, reap it and re-raise the error it reported (e.g. an unwritable plot's
    OutputError, with the worker's traceback as its cause). Interrupted while waiting, the
    exception goes on and the stage's stop hook kills the worker."""
    chunks = []
    while chunk := os.read(worker.fd, 1 << 16):
        chunks.append(chunk)
    with output.uninterrupted():
        _, status = os.waitpid(worker.pid, 0)
        worker.reaped = True
        worker.cancel()
        os.close(worker.fd)
    if chunks:
        try:
            err, tb = pickle.loads(b"".join(chunks))
        except Exception as e:
            raise MjlinkError(f"the plot worker failed and its error could not be read back: {e}") from None
        raise err from _WorkerTraceback(tb)
    code = os.waitstatus_to_exitcode(status)
    if code > 0:
        raise MjlinkError(f"the plot worker exited with status {code} before finishing the plots")
    if code < 0:
        try:
            how = signal.Signals(-code).name
        except ValueError:
            how = f"signal {-code}"
        raise MjlinkError(f"the plot worker was killed by {how} before finishing the plots")


def _on_grid(m: reference.Motion, t: np.ndarray) -> reference.Motion | None:
    """``m`` thinned to the times ``t`` if they are every k-th of its own, else None.

    ``m`` is solved at MuJoCo's sample times, which are ``data.time`` summed step by step and
    drift from the exact grid by rounding (1e-12 s after 20,000 steps, more in a longer run):
    a time within a millionth of the grid's step is the same instant here (the speed moves by
    |eps| x 1e-6 step, far below the RK4 error this is compared with), so a longer
    ``--duration`` does not solve the reference a second time."""
    k = (len(m.t) - 1) // max(len(t) - 1, 1)
    step = float(t[1] - t[0]) if len(t) > 1 else 0.0
    if k >= 1 and len(m.t[::k]) == len(t) and np.allclose(m.t[::k], t, rtol=0, atol=max(1e-12, 1e-6 * step)):
        return reference.Motion(m.t[::k], m.phi[::k], m.omega[::k], m.eps[::k], m.method)
    return None


# ============================================================================ loads and steady motion
def _loads_study(
    mech: Mechanism,
    kin_mj: Trace,
    stage: Path,
    plots: list[PlotJob] | None,
    at: reference.Kinematics | None = None,
) -> LoadsSummary:
    """Driving torque and pair reactions of the constant-speed run ``kin_mj`` (which recorded
    its loads): MuJoCo's and the reference's as CSV into ``stage``; their plots appended to
    ``plots`` (None: no plots)."""
    rx = reference.reactions(mech, kin_mj.phi, kin_mj.omega, kin_mj.eps)
    frames = compare.frame_reference(mech, kin_mj, at), compare.frame_mujoco(mech, kin_mj)
    cmp = compare.loads(mech, kin_mj, rx=rx, frames=frames)
    assert kin_mj.torque is not None  # compare.loads has refused a run without recorded loads
    output.write_loads_csv(stage / "loads.csv", kin_mj, kin_mj.torque, kin_mj.reactions, kin_mj.moments)
    output.write_loads_csv(stage / "reference_loads.csv", kin_mj, rx.torque, rx.forces, rx.moments)
    if plots is not None:
        from ..plotting import loads as loads_plots

        plots.append(functools.partial(loads_plots.torque_plot, mech, kin_mj, rx, stage))
        plots.append(functools.partial(loads_plots.reactions_plot, mech, kin_mj, rx, stage))
        plots.append(functools.partial(loads_plots.shaking_plot, mech, kin_mj, *frames, stage))
    # Statistics over exactly one period from the reference: the run's samples span a period
    # and its end, and counting that end twice biases means of large periodic torques.
    cycle = analysis.torque_cycle(mech, cmp.speed)
    return LoadsSummary(
        cmp.speed,
        cycle.peak,
        cycle.rms,
        cycle.power,
        cmp.torque_rel,
        cmp.force_rel,
        cmp.pairs,
        compare.TORQUE_REL,
        compare.FORCE_REL,
        tuple(cmp.failures()),
        cmp.shaking_force_rel,
        cmp.shaking_moment_rel,
    )


def _steady_study(mech: Mechanism, stage: Path, plots: list[PlotJob] | None) -> SteadySummary:
    """Steady motion under the motor characteristic, the flywheel for the target delta, and
    MuJoCo on both orbits: the orbits as CSV into ``stage``, their plot appended to ``plots``
    (None: no plot)."""
    mv = reference.steady_variant(mech)
    target = mech.steady.target_delta if mech.steady else DEFAULT_TARGET_DELTA
    plain = reference.steady_motion(mv)
    J_fly, fly = reference.flywheel_for(mv, target)
    runs = (simulate.steady_run(mv, plain), simulate.steady_run(mv, fly))
    output.write_steady_csv(stage / "reference_steady.csv", plain, fly)
    if plots is not None:
        from ..plotting import loads as loads_plots

        plots.append(functools.partial(loads_plots.steady_plot, mech, plain, fly, runs, stage))
    motor = mv.dynamics.motor
    assert motor is not None  # steady_variant drives the mechanism by its motor alone
    failures: list[str] = []
    for name, st, mj in (("without flywheel", plain, runs[0]), ("with flywheel", fly, runs[1])):
        failures += compare.steady_failures(name, mj.delta, st.delta)
    return SteadySummary(
        motor.stall_torque,
        motor.no_load_speed,
        plain.omega_mean,
        plain.delta,
        runs[0].delta,
        target,
        J_fly,
        fly.delta,
        runs[1].delta,
        fly.omega_mean,
        tuple(failures),
    )


def loads(
    mech: Mechanism,
    out_root: Path | str,
    *,
    speed: float | None = None,
    plots: bool = True,
    force: bool = False,
    command: Sequence[str] = (),
) -> LoadsResult:
    """Driving torque and pair reactions at constant crank speed, into ``<out_root>/<name>_loads/``.

    ``speed`` crank speed, rad/s, signed, counter-clockwise positive as the file's ``[input]
    speed`` (None: the file's speed). The folder holds ``loads.csv`` (MuJoCo), ``reference_loads.csv``
    (kinetostatics), ``report.json`` (:meth:`LoadsResult.as_dict`) and, with ``plots``,
    ``torque.png`` and ``reactions.png``, and its marker (kind ``loads``: torque and reactions
    share the folder; a folder mjlink did not write for them is refused unless ``force``, see
    :func:`output.staged_dir`). Raises MjlinkError if no link has a mass, the speed is out of
    range or the run would cost beyond the limits (:func:`estimate`).
    """
    if not _has_mass(mech):
        raise MjlinkError(f"{mech.name}: no masses in the file: give its links mass, inertia and com")
    check_speed("--speed", speed)
    estimate(mech, Options(speed=speed, dynamics=False, video=False), cycles_option=None)
    speed = mech.speed if speed is None else speed
    case = simulate.kinematic_case(mech, speed=speed)
    _enough_samples(mech, case, "[input] cycles")
    out_dir = Path(out_root) / f"{mech.name}_loads"
    with output.staged_dir(out_dir, kind="loads", force=force, mechanism=mech.name, command=command) as stage:
        kin = simulate.run(mech, case)
        jobs: list[PlotJob] = []
        result = LoadsResult(
            mech.name,
            out_dir,
            _loads_study(mech, kin, stage, jobs if plots else None),
            provenance(command, {"speed": speed, "plots": plots}),
        )
        run_jobs(jobs)
        output.write_json(stage / "report.json", result.as_dict())
    return result


def steady(
    mech: Mechanism,
    out_root: Path | str,
    *,
    drive: Drive = Drive(),
    plots: bool = True,
    force: bool = False,
    command: Sequence[str] = (),
) -> SteadyResult:
    """Steady motion under a motor characteristic, speed fluctuation and flywheel, into
    ``<out_root>/<name>_steady/``.

    ``drive`` overrides the file's motor, damping and target delta (:func:`with_drive`, the
    motor for this study only). The folder holds ``reference_steady.csv``, ``report.json``
    (:meth:`SteadyResult.as_dict`) and, with ``plots``, ``steady.png``, and its marker (kind
    ``steady``; a folder mjlink did not write for it is refused unless ``force``, see
    :func:`output.staged_dir`). Raises MjlinkError if there is no motor (neither in the file nor
    in ``drive``).
    """
    mech = with_drive(mech, drive, steady=True)
    if mech.steady is None:
        raise MjlinkError(
            f"{mech.name}: steady motion needs a motor: give [steady] or [dynamics.motor] in the file, "
            "or --stall-torque and --no-load-speed"
        )
    estimate(mech, Options(dynamics=False, video=False, steady=True), kinematic=False)
    out_dir = Path(out_root) / f"{mech.name}_steady"
    with output.staged_dir(out_dir, kind="steady", force=force, mechanism=mech.name, command=command) as stage:
        jobs: list[PlotJob] = []
        result = SteadyResult(
            mech.name,
            out_dir,
            _steady_study(mech, stage, jobs if plots else None),
            provenance(command, {**dataclasses.asdict(drive), "plots": plots}),
        )
        run_jobs(jobs)
        output.write_json(stage / "report.json", result.as_dict())
    return result


# ============================================================================ build and synthesis
def build(mech: Mechanism, *, kinematic: bool = False, path: Path | None = None) -> BuildResult:
    """The MJCF of ``mech``: the dynamic model, or with ``kinematic`` the kinematic run's (a
    flywheel on the crank); written to ``path`` whole if given. Raises MjlinkError for a
    ``path`` that names a folder (or nothing), before anything is built."""
    if path is not None:
        if not str(path) or path.is_dir():
            raise MjlinkError(f"-o {str(path)!r}: is a folder, not a file: give the MJCF file's name, e.g. model.xml")
        if not path.name:
            raise MjlinkError(f"-o {str(path)!r}: names no file: give the MJCF file's name, e.g. model.xml")
    settings = simulate.kinematic_case(mech).settings if kinematic else DYNAMIC
    xml = builder.to_xml(mech, settings)
    if path is not None:
        output.write_text(path, xml)
    return BuildResult(mech.name, settings, xml, path)


def synthesize(
    problem: str,
    *,
    stroke_mm: float | None = None,
    offset_mm: float | None = None,
    ratio: float | None = None,
    max_pressure_deg: float | None = None,
) -> SynthResult:
    """Metric synthesis of the offset crank-slider for a stroke (mm), guide offset (mm), lambda =
    r / l and allowed pressure angle (deg); each None takes ``crank_slider.toml``'s [synthesis]
    value. Raises MjlinkError for an unknown ``problem``, a value outside its limits
    (mechanisms/README.md, "Limits"; messages in the option's unit) or an impossible requirement."""
    if problem not in SYNTHESIS_PROBLEMS:
        raise MjlinkError(f"unknown synthesis problem {problem!r} (valid: {', '.join(SYNTHESIS_PROBLEMS)})")
    bounds = (
        ("--stroke", stroke_mm, MIN_BAR_MM, MAX_LENGTH_MM, " mm", False),
        ("--offset", offset_mm, 0.0, MAX_LENGTH_MM, " mm", False),
        ("--lambda", ratio, 0.0, MAX_SYNTH_RATIO, "", True),
        ("--max-pressure-angle", max_pressure_deg, 0.0, MAX_SYNTH_PRESSURE_DEG, " deg", True),
    )
    for option, v, lo, hi, unit, open_interval in bounds:
        if v is None:
            continue
        if not math.isfinite(v) or v < lo or v > hi or (open_interval and v in (lo, hi)):
            within = f"between {lo:g} and {hi:g}{unit}" + (" (both excluded)" if open_interval else "")
            raise MjlinkError(f"{option} must be {within}, got {v:g}{unit}")
    base = validation.get("crank_slider").synthesis
    assert base is not None  # crank_slider.toml carries the seed's [synthesis] requirement
    S = stroke_mm * MM if stroke_mm is not None else base.stroke
    e = offset_mm * MM if offset_mm is not None else base.offset
    lam = ratio if ratio is not None else base.ratio
    th = max_pressure_deg * DEG if max_pressure_deg is not None else base.max_pressure_angle
    table = synthesis.format_table(S, e, lam, th)
    best = synthesis.best(S, e, lam, th)
    top = synthesis.largest_ratio(S, e, th)
    at_top = beyond = None
    if top is not None:
        at_top = synthesis.best(S, e, top, th)
        nxt = synthesis.roots(S, e, round(top + 0.01, 10), th)[0]
        beyond = None if math.isnan(nxt.theta_max) else nxt
    return SynthResult(S, e, lam, th, table, best, top, at_top, beyond)


def write_design(result: SynthResult, path: Path) -> Path:
    """Save the accepted design of ``result`` as a mechanism file at ``path`` (whole or not at
    all), named after the file's stem, after validating it. Raises MjlinkError if the stem is
    not a valid mechanism name, no root is accepted or the design does not validate."""
    name = path.stem
    if not names.is_valid(name):
        raise MjlinkError(
            f"--write: the file name '{path.name}' must make a valid mechanism name "
            "(a letter, then letters, digits or _)"
        )
    base_text = catalogue.path_of("crank_slider").read_text(encoding="utf-8")
    text = synthesis.design_file(base_text, result.stroke, result.offset, result.ratio, result.max_pressure_angle, name)
    validation.validate(parse(text, path))
    return output.write_text(path, text)
