"""The ``torque``, ``reactions`` and ``steady`` commands, and the loads and steady-motion stages
``simulate`` shares with them.
"""

from __future__ import annotations

import dataclasses
import functools
from collections.abc import Sequence
from pathlib import Path

from .. import analysis, compare, reference
from ..errors import MjlinkError
from ..files import write_json, write_loads_csv, write_steady_csv
from ..model.mechanism import Mechanism
from ..runs import Trace
from ..runtime import staging
from ..runtime.workers import PlotJob, run_jobs
from ..sim import simulate
from .cost import enough_samples, estimate
from .options import DEFAULT_TARGET_DELTA, Drive, Options, check_speed, has_mass, with_drive
from .results import LoadsResult, LoadsSummary, SteadyResult, SteadySummary, provenance


# ============================================================================ loads and steady motion
def loads_stage(
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
    write_loads_csv(stage / "loads.csv", kin_mj, kin_mj.torque, kin_mj.reactions, kin_mj.moments)
    write_loads_csv(stage / "reference_loads.csv", kin_mj, rx.torque, rx.forces, rx.moments)
    if plots is not None:
        from ..plotting import loads as loads_plots  # here: matplotlib, not for --no-plots

        plots.append(functools.partial(loads_plots.torque_plot, mech, kin_mj, rx, stage))
        plots.append(functools.partial(loads_plots.reactions_plot, mech, kin_mj, rx, stage))
        plots.append(functools.partial(loads_plots.shaking_plot, mech, kin_mj, *frames, stage))
    # Statistics over exactly one period from the reference: the run's samples span a period
    # and its end, and counting that end twice biases means of large periodic torques.
    cycle = analysis.torque_cycle(mech, cmp.speed)
    return LoadsSummary(
        speed=cmp.speed,
        torque_peak=cycle.peak,
        torque_rms=cycle.rms,
        power_mean=cycle.power,
        torque_error=cmp.torque_rel,
        force_error=cmp.force_rel,
        pairs=cmp.pairs,
        torque_threshold=compare.TORQUE_REL,
        force_threshold=compare.FORCE_REL,
        failures=tuple(cmp.failures()),
        shaking_force_error=cmp.shaking_force_rel,
        shaking_moment_error=cmp.shaking_moment_rel,
    )


def steady_stage(mech: Mechanism, stage: Path, plots: list[PlotJob] | None) -> SteadySummary:
    """Steady motion under the motor characteristic, the flywheel for the target delta, and
    MuJoCo on both orbits: the orbits as CSV into ``stage``, their plot appended to ``plots``
    (None: no plot)."""
    mv = reference.steady_variant(mech)
    target = mech.steady.target_delta if mech.steady else DEFAULT_TARGET_DELTA
    plain = reference.steady_motion(mv)
    J_fly, fly = reference.flywheel_for(mv, target)
    runs = (simulate.steady_run(mv, plain), simulate.steady_run(mv, fly))
    write_steady_csv(stage / "reference_steady.csv", plain, fly)
    if plots is not None:
        from ..plotting import loads as loads_plots  # here: matplotlib, not for --no-plots

        plots.append(functools.partial(loads_plots.steady_plot, mech, plain, fly, runs, stage))
    motor = mv.dynamics.motor
    assert motor is not None  # steady_variant drives the mechanism by its motor alone
    failures: list[str] = []
    for name, st, mj in (("without flywheel", plain, runs[0]), ("with flywheel", fly, runs[1])):
        failures += compare.steady_failures(name, mj.delta, st.delta)
    return SteadySummary(
        stall_torque=motor.stall_torque,
        no_load_speed=motor.no_load_speed,
        omega_mean=plain.omega_mean,
        delta=plain.delta,
        delta_mujoco=runs[0].delta,
        target_delta=target,
        flywheel=J_fly,
        delta_with_flywheel=fly.delta,
        delta_with_flywheel_mujoco=runs[1].delta,
        omega_mean_with_flywheel=fly.omega_mean,
        failures=tuple(failures),
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
    :func:`mjlink.runtime.staging.staged_dir`). Raises MjlinkError if no link has a mass, the speed is out of
    range or the run would cost beyond the limits (:func:`estimate`).
    """
    if not has_mass(mech):
        raise MjlinkError(f"{mech.name}: no masses in the file: give its links mass, inertia and com")
    check_speed("--speed", speed)
    estimate(mech, Options(speed=speed, dynamics=False, video=False), cycles_option=None)
    speed = mech.speed if speed is None else speed
    case = simulate.kinematic_case(mech, speed=speed)
    enough_samples(mech, case, "[input] cycles")
    out_dir = Path(out_root) / f"{mech.name}_loads"
    with staging.staged_dir(out_dir, kind="loads", force=force, mechanism=mech.name, command=command) as stage:
        kin = simulate.run(mech, case)
        jobs: list[PlotJob] = []
        result = LoadsResult(
            mech.name,
            out_dir,
            loads_stage(mech, kin, stage, jobs if plots else None),
            provenance(command, {"speed": speed, "plots": plots}),
        )
        run_jobs(jobs)
        write_json(stage / "report.json", result.as_dict())
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
    :func:`mjlink.runtime.staging.staged_dir`). Raises MjlinkError if there is no motor (neither in the file nor
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
    with staging.staged_dir(out_dir, kind="steady", force=force, mechanism=mech.name, command=command) as stage:
        jobs: list[PlotJob] = []
        result = SteadyResult(
            mech.name,
            out_dir,
            steady_stage(mech, stage, jobs if plots else None),
            provenance(command, {**dataclasses.asdict(drive), "plots": plots}),
        )
        run_jobs(jobs)
        write_json(stage / "report.json", result.as_dict())
    return result
