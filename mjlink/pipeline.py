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
=================  ===================  ==========================================

Every output folder is all or nothing (:func:`output.staged_dir`), every single file too
(:func:`output.write_text`). Units SI (m, rad, s, kg, N, N*m, W) unless a name says otherwise
(``speed_rpm``). Errors are one-line :class:`MjlinkError` subclasses; where the value at fault
can come from a command-line option, the message names the option.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from . import analysis, compare, output, reference, validation
from .errors import MjlinkError, SimulationError
from .model import catalogue, names
from .model.limits import MAX_SPEED, MIN_SPEED
from .model.mechanism import Mechanism, Motor, SteadyCase, parse
from .reference import synthesis
from .runs import DYNAMIC, Case, Settings, Trace
from .sim import builder, simulate
from .units import DEG, MM, RunKind, from_rpm, to_rpm

PAPER_RK4_STEPS = 1000  # the paper integrates the equation of motion by fixed-step RK4 in this many steps
REFERENCE_ODE_METHOD = "DOP853"  # what reference.forward_dynamics solves the equation of motion with
STEADY_DEFINITION = "delta = (omega_max - omega_min) / omega_mean, omega_mean = time average over a period"
DEFAULT_TARGET_DELTA = SteadyCase.target_delta  # the file format's default coefficient of speed fluctuation
SYNTHESIS_PROBLEMS = ("crank_slider",)  # what synthesize knows how to solve

# A plot to draw later, with its arguments bound: picklable, so that a forked worker can draw it.
PlotJob = Callable[[], object]


# ============================================================================ options
@dataclass(frozen=True)
class Options:
    """What :func:`run` does.

    ``speed`` rad/s and ``cycles`` crank periods of the kinematic run (None: the file's);
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
    ``stall_torque`` N*m and ``no_load_speed`` rad/s, together, a linear motor characteristic
    (signed in the crank's sense); ``target_delta`` the coefficient of speed fluctuation the
    flywheel is sized for.
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


def check_speed(option: str, w: float | None) -> None:
    """Raise MjlinkError unless the crank speed ``w`` (rad/s; None: not given) is within the
    range the simulation is made for; the message names ``option``."""
    if w is None:
        return
    if not (MIN_SPEED <= abs(w) <= MAX_SPEED):
        raise MjlinkError(
            f"{option} must be between {MIN_SPEED:g} and {MAX_SPEED:g} rad/s in magnitude "
            f"({to_rpm(MIN_SPEED):.3g} to {to_rpm(MAX_SPEED):.3g} rpm), got {w:g} rad/s"
        )


def with_drive(mech: Mechanism, drive: Drive, *, steady: bool = False) -> Mechanism:
    """``mech`` with the ``drive`` overrides applied, each validated (messages name the option).

    The motor characteristic becomes the file's [dynamics.motor] (unless ``steady``: then it
    drives only the steady-motion study) and, with ``target_delta``, its [steady] case. Raises
    MjlinkError for a non-finite value, a negative damping, a non-positive duration, half a
    motor characteristic or one of mixed signs, or a target delta outside (0, 2).
    """
    dyn = mech.dynamics
    changes: dict[str, Any] = {}
    for key in ("moment", "damping", "omega0", "duration"):
        v = getattr(drive, key)
        if v is None:
            continue
        if not math.isfinite(v) or (key == "damping" and v < 0) or (key == "duration" and v <= 0):
            raise MjlinkError(
                f"--{key} must be a finite number{' >= 0' if key == 'damping' else ''}"
                f"{' > 0' if key == 'duration' else ''}, got {v}"
            )
        changes[key] = v
    ts, w0 = drive.stall_torque, drive.no_load_speed
    motor = None
    if ts is None or w0 is None:
        if ts is not None or w0 is not None:
            raise MjlinkError("--stall-torque and --no-load-speed go together (a linear motor characteristic)")
    else:
        if not (math.isfinite(ts) and math.isfinite(w0)) or ts == 0 or w0 == 0 or (ts > 0) != (w0 > 0):
            raise MjlinkError("--stall-torque and --no-load-speed must be finite, non-zero and of the same sign")
        motor = Motor(ts, w0)
        if not steady:
            changes["motor"] = motor
    if changes:
        mech = dataclasses.replace(
            mech, dynamics=dataclasses.replace(dyn, **changes), has_dynamics=mech.has_dynamics or bool(changes)
        )
    target = drive.target_delta
    if target is not None and not (0 < target < 2):
        raise MjlinkError(f"--target-delta must be between 0 and 2, got {target}")
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
    """The paper's fixed-step RK4 (:data:`PAPER_RK4_STEPS` steps) against the tight ODE solution.

    ``omega_final`` RK4's final crank speed, rad/s; ``omega_max_abs_diff`` the largest
    difference in crank speed, rad/s; ``omega_max_rel_diff`` that relative to the largest speed;
    ``omega_final_rel_diff`` the final speeds' difference relative to the tight final speed.
    """

    omega_final: float
    omega_max_abs_diff: float
    omega_max_rel_diff: float
    omega_final_rel_diff: float

    def as_dict(self) -> dict[str, Any]:
        return {
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
    speeds, rad/s; ``ode_rtol`` the reference ODE's relative tolerance; ``spectral_harmonics``
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

    def as_dict(self) -> dict[str, Any]:
        """The report's ``dynamics`` entry."""
        d: dict[str, Any] = {
            "moment_N_m": self.moment,
            "damping_N_m_s": self.damping,
            "duration_s": self.duration,
            "settings": settings_dict(self.settings),
            "omega_final_rad_s": {"mujoco": self.omega_final_mujoco, "reference": self.omega_final_reference},
            "reference_ode": {
                "method": REFERENCE_ODE_METHOD,
                "rtol": self.ode_rtol,
                "spectral_harmonics": self.spectral_harmonics,
                "spectral_error_rel": self.spectral_error,
            },
        }
        if self.rk4 is not None:
            d[f"paper_rk4_{PAPER_RK4_STEPS}_steps"] = self.rk4.as_dict()
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
            "thresholds": {"torque_rel": self.torque_threshold, "force_rel": self.force_threshold},
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
        return d


@dataclass(frozen=True)
class LoadsResult:
    """What :func:`loads` did: the ``loads`` of ``mechanism`` at constant speed, written to
    ``out_dir``. :meth:`as_dict` is its ``report.json``."""

    mechanism: str
    out_dir: Path
    loads: LoadsSummary

    @property
    def failures(self) -> tuple[str, ...]:
        return self.loads.failures

    def as_dict(self) -> dict[str, Any]:
        return {"mechanism": self.mechanism, "loads": self.loads.as_dict(), "failures": list(self.failures)}


@dataclass(frozen=True)
class SteadyResult:
    """What :func:`steady` did: the ``steady`` study of ``mechanism``, written to ``out_dir``.
    :meth:`as_dict` is its ``report.json``."""

    mechanism: str
    out_dir: Path
    steady: SteadySummary

    @property
    def failures(self) -> tuple[str, ...]:
        return self.steady.failures

    def as_dict(self) -> dict[str, Any]:
        return {"mechanism": self.mechanism, "steady": self.steady.as_dict()}


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


def run(mech: Mechanism, out_root: Path | str, opts: Options = Options()) -> SimulateResult:
    """Run everything ``opts`` asks for ``mech`` and write ``<out_root>/<name>/``.

    The kinematic run, its reference and their agreement always; the forward-dynamics run, the
    loads, the steady-motion study, plots and video as ``opts`` says and the file allows. The
    folder holds the traces as CSV, ``report.json`` (:meth:`SimulateResult.as_dict`),
    ``model.xml`` (the dynamic model) and the figures and video; it replaces an earlier one
    whole, or is not written at all if anything fails.

    Raises SimulationError if MuJoCo leaves the reference's assembly branch or diverges,
    OutputError if the folder cannot be written, RenderError if the video cannot be made.
    """
    clock = _Clock()
    out_dir = Path(out_root) / mech.name
    with output.staged_dir(out_dir) as stage:
        kcase = simulate.kinematic_case(mech, speed=opts.speed, cycles=opts.cycles)
        _enough_samples(mech, kcase, "--cycles")
        kin_mj = simulate.run(mech, kcase)
        _same_branch(mech, kin_mj)
        clock.lap("mujoco_kinematics")
        kin_ref = reference.reference_trace(
            mech, reference.constant_speed(mech, kin_mj.time, kcase.omega0), RunKind.KINEMATICS
        )
        agreements = [compare.agreement(mech, kin_mj)]
        clock.lap("reference_kinematics")
        output.write_csv(stage / "kinematics.csv", mech, kin_mj)
        output.write_csv(stage / "reference_kinematics.csv", mech, kin_ref)
        kinematics = KinematicsSummary(kcase.omega0, kcase.duration, kcase.settings)

        dyn = None
        if opts.dynamics and has_masses(mech):
            dyn = _forward_dynamics(mech, opts.duration, stage, clock)
            agreements.append(dyn.agreement)
        jobs: list[PlotJob] = []
        queue = jobs if opts.plots else None
        loads_summary = steady_summary = None
        if opts.loads and _has_mass(mech):
            loads_summary = _loads_study(mech, kin_mj, stage, queue)
            clock.lap("loads")
        if opts.steady:
            steady_summary = _steady_study(mech, stage, queue)
            clock.lap("steady")
        failures = tuple(f for a in agreements for f in a.failures())
        failures += loads_summary.failures if loads_summary else ()
        failures += steady_summary.failures if steady_summary else ()

        if opts.plots:
            from .plotting import figures

            jobs.append(
                functools.partial(
                    figures.all_plots,
                    mech,
                    kin_mj,
                    kin_ref,
                    dyn.mujoco_trace if dyn else None,
                    dyn.reference_trace if dyn else None,
                    stage,
                    rk4=dyn.rk4 if dyn else None,
                )
            )
        # Plots and video are independent and each takes seconds: on a machine with two cores
        # the plots are drawn in a forked worker while this process renders.
        worker = _start(jobs) if (opts.video and jobs) else None
        if worker is None:
            run_jobs(jobs)
            clock.lap("plots")
        video = None
        if opts.video:
            video = _video(mech, kin_mj, kcase.settings, stage, opts, progress=worker is None)
            clock.lap("video" if worker is None else "video_and_plots")
        if worker is not None:
            _finish(worker)
            clock.lap("plots_after_video")
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
        )
        output.write_json(stage / "report.json", result.as_dict())
        output.write_text(stage / "model.xml", builder.to_xml(mech, DYNAMIC), in_stage=True)
        files = tuple(sorted(p.name for p in stage.iterdir()))
    return dataclasses.replace(result, files=files)


def _forward_dynamics(mech: Mechanism, duration: float | None, stage: Path, clock: _Clock) -> _DynamicRun:
    """The dynamic run (``duration`` s, None: the file's), the reference's tight solution and,
    over the file's duration, the paper's RK4; their CSVs into ``stage``."""
    dcase = simulate.dynamic_case(mech, duration=duration)
    _enough_samples(mech, dcase, "--duration")
    dyn_mj = simulate.run(mech, dcase)
    _same_branch(mech, dyn_mj)
    clock.lap("mujoco_dynamics")
    sd = reference.SpectralDynamics(mech)
    motion = reference.forward_dynamics(mech, dyn_mj.time, sd=sd)
    dyn_ref = reference.reference_trace(mech, motion, RunKind.DYNAMICS)
    rk4 = reference.rk4_dynamics(mech, PAPER_RK4_STEPS, sd=sd) if dcase.duration == mech.dynamics.duration else None
    agreement = compare.agreement(mech, dyn_mj, motion)
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
    )
    return _DynamicRun(summary, agreement, dyn_mj, dyn_ref, rk4)


def _video(
    mech: Mechanism, kin_mj: Trace, settings: Settings, stage: Path, opts: Options, *, progress: bool
) -> VideoSummary:
    """The kinematic run as ``NAME.mp4`` in ``stage``."""
    from .sim import render

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


def _same_branch(mech: Mechanism, trace: Trace) -> None:
    """Stop a run whose MuJoCo linkage snapped to the other assembly branch (near a dead point)."""
    switched = compare.branch_switch(mech, trace)
    if switched:
        raise SimulationError(switched)


def run_jobs(jobs: list[PlotJob]) -> None:
    """Draw the queued plots, in order."""
    for job in jobs:
        job()


def _start(jobs: list[PlotJob]) -> tuple[Any, Any] | None:
    """Run ``jobs`` in a forked worker process: (pool, future); None where fork is unavailable."""
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    if "fork" not in multiprocessing.get_all_start_methods():
        return None
    pool = ProcessPoolExecutor(max_workers=1, mp_context=multiprocessing.get_context("fork"))
    return pool, pool.submit(run_jobs, jobs)


def _finish(worker: tuple[Any, Any]) -> None:
    pool, future = worker
    try:
        future.result()  # re-raises the worker's MjlinkError (e.g. an unwritable plot)
    finally:
        pool.shutdown()


def _on_grid(m: reference.Motion, t: np.ndarray) -> reference.Motion | None:
    """``m`` thinned to the times ``t`` if they are every k-th of its own, else None."""
    k = (len(m.t) - 1) // max(len(t) - 1, 1)
    if k >= 1 and len(m.t[::k]) == len(t) and np.allclose(m.t[::k], t, rtol=0, atol=1e-12):
        return reference.Motion(m.t[::k], m.phi[::k], m.omega[::k], m.eps[::k])
    return None


# ============================================================================ loads and steady motion
def _loads_study(mech: Mechanism, kin_mj: Trace, stage: Path, plots: list[PlotJob] | None) -> LoadsSummary:
    """Driving torque and pair reactions of the constant-speed run ``kin_mj`` (which recorded
    its loads): MuJoCo's and the reference's as CSV into ``stage``; their plots appended to
    ``plots`` (None: no plots)."""
    cmp = compare.loads(mech, kin_mj)
    rx = reference.reactions(mech, kin_mj.phi, kin_mj.omega, kin_mj.eps)
    assert kin_mj.torque is not None  # compare.loads has refused a run without recorded loads
    output.write_loads_csv(stage / "loads.csv", kin_mj, kin_mj.torque, kin_mj.reactions, kin_mj.moments)
    output.write_loads_csv(stage / "reference_loads.csv", kin_mj, rx.torque, rx.forces, rx.moments)
    if plots is not None:
        from .plotting import loads as loads_plots

        plots.append(functools.partial(loads_plots.torque_plot, mech, kin_mj, rx, stage))
        plots.append(functools.partial(loads_plots.reactions_plot, mech, kin_mj, rx, stage))
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
        from .plotting import loads as loads_plots

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


def loads(mech: Mechanism, out_root: Path | str, *, rpm: float | None = None, plots: bool = True) -> LoadsResult:
    """Driving torque and pair reactions at constant crank speed, into ``<out_root>/<name>_loads/``.

    ``rpm`` crank speed, rev/min, in the file's sense of rotation (negative reverses it; None:
    the file's speed). The folder holds ``loads.csv`` (MuJoCo), ``reference_loads.csv``
    (kinetostatics), ``report.json`` (:meth:`LoadsResult.as_dict`) and, with ``plots``,
    ``torque.png`` and ``reactions.png``. Raises MjlinkError if no link has a mass or the
    speed is zero, not finite or out of range.
    """
    if not _has_mass(mech):
        raise MjlinkError(f"{mech.name}: no masses in the file: give its links mass, inertia and com")
    speed = mech.speed
    if rpm is not None:
        if not math.isfinite(rpm) or rpm == 0:
            raise MjlinkError(f"--speed must be a non-zero finite number of rev/min, got {rpm}")
        speed = math.copysign(1.0, mech.speed) * from_rpm(rpm)
        check_speed("--speed", speed)
    case = simulate.kinematic_case(mech, speed=speed)
    _enough_samples(mech, case, "[input] cycles")
    kin = simulate.run(mech, case)
    out_dir = Path(out_root) / f"{mech.name}_loads"
    with output.staged_dir(out_dir) as stage:
        jobs: list[PlotJob] = []
        result = LoadsResult(mech.name, out_dir, _loads_study(mech, kin, stage, jobs if plots else None))
        run_jobs(jobs)
        output.write_json(stage / "report.json", result.as_dict())
    return result


def steady(mech: Mechanism, out_root: Path | str, *, drive: Drive = Drive(), plots: bool = True) -> SteadyResult:
    """Steady motion under a motor characteristic, speed fluctuation and flywheel, into
    ``<out_root>/<name>_steady/``.

    ``drive`` overrides the file's motor, damping and target delta (:func:`with_drive`, the
    motor for this study only). The folder holds ``reference_steady.csv``, ``report.json``
    (:meth:`SteadyResult.as_dict`) and, with ``plots``, ``steady.png``. Raises MjlinkError if
    there is no motor (neither in the file nor in ``drive``).
    """
    mech = with_drive(mech, drive, steady=True)
    if mech.steady is None:
        raise MjlinkError(
            f"{mech.name}: steady motion needs a motor: give [steady] or [dynamics.motor] in the file, "
            "or --stall-torque and --no-load-speed"
        )
    out_dir = Path(out_root) / f"{mech.name}_steady"
    with output.staged_dir(out_dir) as stage:
        jobs: list[PlotJob] = []
        result = SteadyResult(mech.name, out_dir, _steady_study(mech, stage, jobs if plots else None))
        run_jobs(jobs)
        output.write_json(stage / "report.json", result.as_dict())
    return result


# ============================================================================ build and synthesis
def build(mech: Mechanism, *, kinematic: bool = False, path: Path | None = None) -> BuildResult:
    """The MJCF of ``mech``: the dynamic model, or with ``kinematic`` the kinematic run's (a
    flywheel on the crank); written to ``path`` whole if given."""
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
    value. Raises MjlinkError for an unknown ``problem`` or an impossible requirement."""
    if problem not in SYNTHESIS_PROBLEMS:
        raise MjlinkError(f"unknown synthesis problem '{problem}' (valid: {', '.join(SYNTHESIS_PROBLEMS)})")
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
