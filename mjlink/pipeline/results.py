"""What each command gives back: typed results, each with its report entry (``as_dict``).

The summaries of a ``simulate`` run's stages (kinematics, dynamics, loads, steady motion,
video, timings, provenance) and the results of every command: :class:`SimulateResult` (its
``as_dict`` is ``report.json``), :class:`LoadsResult`, :class:`SteadyResult`,
:class:`BuildResult`, :class:`SynthResult`. Units SI unless a key says otherwise.
"""

from __future__ import annotations

import dataclasses
import platform
import shlex
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .. import compare, reference
from ..analysis.summary import Summary
from ..analysis.tension import NeedleTension
from ..analysis.timing import HeadTiming
from ..model import synthesis
from ..runs import Settings
from ..sim import builder
from ..sim.feed import FeedRun
from ..units import to_rpm
from ..version import __version__

STEADY_DEFINITION = "delta = (omega_max - omega_min) / omega_mean, omega_mean = time average over a period"


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


@dataclass(frozen=True, kw_only=True)
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


@dataclass(frozen=True, kw_only=True)
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
            # The frame's shaking force and moment, relative to the reference's range (None: a
            # geared mechanism's moment in a run without its gear couplings' torques).
            "shaking_force_error_rel": self.shaking_force_error,
            "shaking_moment_error_rel": self.shaking_moment_error,
            "thresholds": {
                "torque_rel": self.torque_threshold,
                "force_rel": self.force_threshold,
                "shaking_rel": compare.SHAKING_REL,
            },
        }


@dataclass(frozen=True, kw_only=True)
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


@dataclass(frozen=True, kw_only=True)
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


@dataclass(frozen=True, kw_only=True)
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
    feed: float | None = None
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

    versions = {
        "mjlink": __version__,
        "mujoco": builder.mujoco_version(),
        "python": platform.python_version(),
        "numpy": np.__version__,
    }
    return Provenance(versions, tuple(command), dict(options or {}))


@dataclass(frozen=True, kw_only=True)
class SimulateResult:
    """What :func:`run` did for one mechanism, all written under ``out_dir``.

    ``mechanism``, ``title`` and ``source`` from the file; ``mujoco_version``; ``kinematics``
    and, when run, ``dynamics``, ``loads``, ``steady`` and ``video``; ``agreements`` MuJoCo
    against the reference per run (kinematics, then dynamics) with ``thresholds`` their limits
    (:func:`compare.thresholds`); ``failures`` every limit missed (agreement, loads, steady);
    ``timings``; ``files`` the names in ``out_dir``; ``timing`` a head's timing checks (their
    misses are among ``failures``); ``tension`` a lockstitch head's needle thread over a stitch
    (:func:`mjlink.analysis.tension.needle_tension`); ``feed`` a head's fabric fed under its
    presser foot (:func:`mjlink.sim.feed.run_feed`); ``design`` the design at a glance (headline numbers, strokes,
    dimensions: :class:`mjlink.analysis.summary.Summary`). :meth:`as_dict` is ``report.json``.
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
    timing: HeadTiming | None = None  # a sewing head's timing checks ([timing] table)
    design: Summary | None = None  # the design at a glance: the page's first screen
    tension: NeedleTension | None = None  # a lockstitch head's needle thread under tension
    feed: FeedRun | None = None  # a head's fabric under its presser foot at this speed (MuJoCo contacts)

    def as_dict(self) -> dict[str, Any]:
        """The contents of ``report.json``."""
        d: dict[str, Any] = {
            "mechanism": self.mechanism,
            "title": self.title,
            "source": self.source,
            "mujoco_version": self.mujoco_version,
            "kinematics": self.kinematics.as_dict(),
        }
        if self.design is not None:
            d["design"] = self.design.as_dict()
        if self.dynamics is not None:
            d["dynamics"] = self.dynamics.as_dict()
        if self.loads is not None:
            d["loads"] = self.loads.as_dict()
        if self.steady is not None:
            d["steady"] = self.steady.as_dict()
        if self.timing is not None:
            d["timing"] = self.timing.as_dict()
        if self.tension is not None:
            d["tension"] = self.tension.as_dict()
        if self.feed is not None:
            d["feed"] = self.feed.as_dict()
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


@dataclass(frozen=True, kw_only=True)
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
