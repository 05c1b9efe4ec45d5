"""``simulate``: the whole job for one mechanism, as one all-or-nothing output folder.

Kinematic and dynamic MuJoCo runs, the reference's traces, the agreement report, CSV files,
plots and video, written under ``<out>/<name>/``. Each layer lives in its own module; this
one only orders them and times them.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

from . import compare, output, reference
from .model.mechanism import Mechanism
from .runs import DYNAMIC, Settings, Trace
from .sim import builder, simulate


@dataclass(frozen=True)
class Options:
    """What ``simulate`` does: ``speed`` rad/s and ``cycles`` of the kinematic run (None: the
    file's), ``duration`` s of the dynamic run (None: the file's), plots and video settings
    (``video_seconds`` s of video for the kinematic run, ``fps``, pixels)."""

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
class Result:
    """Outcome of ``simulate``: the output folder, the agreement per run, the report dict."""

    mechanism: str
    out_dir: Path
    agreements: tuple[compare.Agreement, ...]
    report: dict
    files: tuple[str, ...] = field(default=())

    @property
    def failures(self) -> list[str]:
        return list(self.report.get("failures", []))


def has_masses(mech: Mechanism) -> bool:
    """Whether the file defines a forward-dynamics case: a [dynamics] table and masses."""
    return mech.has_dynamics and any(l.mass > 0 for l in mech.links)


def run(mech: Mechanism, out_root: Path, opts: Options = Options(),
        log: Callable[[str], None] = print) -> Result:
    """Run everything for ``mech`` and write ``<out_root>/<name>/``. Returns the Result."""
    t_start = time.perf_counter()
    timings: dict[str, float] = {}

    def lap(name: str, t0: float) -> float:
        timings[name] = round(time.perf_counter() - t0, 4)
        return time.perf_counter()

    with output.staged_dir(Path(out_root) / mech.name) as stage:
        t = time.perf_counter()
        kcase = simulate.kinematic_case(mech, speed=opts.speed, cycles=opts.cycles)
        kin_mj = simulate.run(mech, kcase)
        _same_branch(mech, kin_mj)
        t = lap("mujoco_kinematics_s", t)
        kin_ref = reference.reference_trace(
            mech, reference.constant_speed(mech, kin_mj.time, kcase.omega0), "kinematics")
        agreements = [compare.agreement(mech, kin_mj)]
        t = lap("reference_kinematics_s", t)
        output.write_csv(stage / "kinematics.csv", mech, kin_mj)
        output.write_csv(stage / "reference_kinematics.csv", mech, kin_ref)

        report: dict = {
            "mechanism": mech.name, "title": mech.title, "source": mech.source,
            "mujoco_version": builder.mujoco_version(),
            "kinematics": {"speed_rad_s": kcase.omega0, "duration_s": kcase.duration,
                           "settings": _settings(kcase.settings),
                           "flywheel_armature_kg_m2": kcase.settings.flywheel,
                           "omega_spread_rel": float(np.ptp(kin_mj.omega) / abs(kcase.omega0))},
        }
        dyn_mj = dyn_ref = rk4 = None
        if opts.dynamics and has_masses(mech):
            dcase = simulate.dynamic_case(mech, duration=opts.duration)
            dyn_mj = simulate.run(mech, dcase)
            _same_branch(mech, dyn_mj)
            t = lap("mujoco_dynamics_s", t)
            sd = reference.SpectralDynamics(mech)
            motion = reference.forward_dynamics(mech, dyn_mj.time, sd=sd)
            dyn_ref = reference.reference_trace(mech, motion, "dynamics")
            rk4 = reference.rk4_dynamics(mech, 1000, sd=sd) if dcase.duration == mech.dynamics.duration else None
            agreements.append(compare.agreement(mech, dyn_mj, motion))
            t = lap("reference_dynamics_s", t)
            output.write_csv(stage / "dynamics.csv", mech, dyn_mj)
            output.write_csv(stage / "reference_dynamics.csv", mech, dyn_ref)
            report["dynamics"] = {
                "moment_N_m": mech.dynamics.moment, "damping_N_m_s": mech.dynamics.damping,
                "duration_s": dcase.duration, "settings": _settings(dcase.settings),
                "omega_final_rad_s": {"mujoco": float(dyn_mj.omega[-1]), "reference": float(motion.omega[-1])},
                "reference_ode": {"method": "DOP853", "rtol": reference.TIGHT_RTOL, "spectral_harmonics": sd.harmonics,
                                  "spectral_error_rel": sd.error},
            }
            if rk4 is not None:
                tight = _on_grid(motion, rk4.t) or reference.forward_dynamics(mech, rk4.t, sd=sd)
                d = np.abs(rk4.omega - tight.omega)
                report["dynamics"]["paper_rk4_1000_steps"] = {
                    "omega_final_rad_s": float(rk4.omega[-1]),
                    "omega_max_abs_diff_rad_s": float(d.max()),
                    "omega_max_rel_diff": float(d.max() / np.abs(tight.omega).max()),
                    "omega_final_rel_diff": float(abs(rk4.omega[-1] - tight.omega[-1]) / abs(tight.omega[-1])),
                }
        load_failures: list[str] = []
        jobs: list = []  # plots to draw: (function, args, kwargs)
        if opts.loads and any(l.mass > 0 for l in mech.links):
            report["loads"], load_failures = loads_outputs(mech, kin_mj, stage, jobs if opts.plots else None)
            t = lap("loads_s", t)
        if opts.steady:
            report["steady"] = steady_outputs(mech, stage, jobs if opts.plots else None)
            load_failures += report["steady"]["failures"]
            t = lap("steady_s", t)
        report["agreement"] = {a.kind: a.as_dict() for a in agreements}
        report["thresholds"] = compare.thresholds()
        report["failures"] = [f for a in agreements for f in a.failures()] + load_failures

        if opts.plots:
            from .plotting import figures

            jobs.append((figures.all_plots, (mech, kin_mj, kin_ref, dyn_mj, dyn_ref, stage), {"rk4": rk4}))
        # Plots and video are independent and each takes seconds: on a machine with two cores
        # the plots are drawn in a forked worker while this process renders.
        worker = _start(jobs) if (opts.video and jobs) else None
        if worker is None:
            run_jobs(jobs)
            t = lap("plots_s", t)
        if opts.video:
            from .sim import render

            info = render.render_video(mech, kin_mj, stage / f"{mech.name}.mp4", seconds=opts.video_seconds,
                                       fps=opts.fps, width=opts.width, height=opts.height,
                                       settings=kcase.settings, progress=worker is None)
            report["video"] = {"file": f"{mech.name}.mp4", "frames": info.frames, "fps": info.fps,
                               "size": [info.width, info.height], "backend": info.backend,
                               "slowed_down_by": info.time_scale}
            t = lap("video_s" if worker is None else "video_and_plots_s", t)
        if worker is not None:
            _finish(worker)
            t = lap("plots_after_video_s", t)
        timings["total_s"] = round(time.perf_counter() - t_start, 4)
        report["timings"] = timings
        output.write_json(stage / "report.json", report)
        (stage / "model.xml").write_text(builder.to_xml(mech, DYNAMIC), encoding="utf-8")
        files = tuple(sorted(p.name for p in stage.iterdir()))
    return Result(mech.name, Path(out_root) / mech.name, tuple(agreements), report, files)


def _same_branch(mech: Mechanism, trace: Trace) -> None:
    """Stop a run whose MuJoCo linkage snapped to the other assembly branch (near a dead point)."""
    from .errors import SimulationError

    switched = compare.branch_switch(mech, trace)
    if switched:
        raise SimulationError(switched)


def run_jobs(jobs: list) -> None:
    """Draw the queued plots: (function, args, kwargs) triples."""
    for f, args, kwargs in jobs:
        f(*args, **kwargs)


def _start(jobs: list):
    """Run ``jobs`` in a forked worker process; None where fork is unavailable."""
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    if "fork" not in multiprocessing.get_all_start_methods():
        return None
    pool = ProcessPoolExecutor(max_workers=1, mp_context=multiprocessing.get_context("fork"))
    return pool, pool.submit(run_jobs, jobs)


def _finish(worker) -> None:
    pool, future = worker
    try:
        future.result()  # re-raises the worker's MjlinkError (e.g. an unwritable plot)
    finally:
        pool.shutdown()


def loads_outputs(mech: Mechanism, kin_mj: Trace, stage: Path, jobs: list | None = None
                  ) -> tuple[dict, list[str]]:
    """Driving torque and pair reactions of a constant-speed run: CSV, report entry; the plots
    are appended to ``jobs`` (None: no plots)."""
    loads = compare.loads(mech, kin_mj)
    rx = reference.reactions(mech, kin_mj.phi, kin_mj.omega, kin_mj.eps)
    output.write_loads_csv(stage / "loads.csv", kin_mj, kin_mj.torque, kin_mj.reactions, kin_mj.moments)
    output.write_loads_csv(stage / "reference_loads.csv", kin_mj, rx.torque, rx.forces, rx.moments)
    if jobs is not None:
        from .plotting import loads as plots_loads

        jobs.append((plots_loads.torque_plot, (mech, kin_mj, rx, stage), {}))
        jobs.append((plots_loads.reactions_plot, (mech, kin_mj, rx, stage), {}))
    entry = {"speed_rad_s": loads.speed, "speed_rpm": loads.speed * 30 / np.pi,
             "torque_peak_N_m": loads.torque_peak, "torque_rms_N_m": loads.torque_rms,
             "power_mean_W": loads.power_mean, "torque_error_rel": loads.torque_rel,
             "force_error_rel": loads.force_rel, "pairs": loads.pairs,
             "thresholds": {"torque_rel": compare.TORQUE_REL, "force_rel": compare.FORCE_REL}}
    return entry, loads.failures()


def steady_outputs(mech: Mechanism, stage: Path, jobs: list | None = None, *, target: float | None = None) -> dict:
    """Steady motion under the motor characteristic, the flywheel for the target delta, and
    MuJoCo on both orbits: CSV, report entry (with its own ``failures``); the plot is
    appended to ``jobs`` (None: no plot)."""
    mv = reference.steady_variant(mech)
    target = target if target is not None else (mech.steady.target_delta if mech.steady else 0.02)
    plain = reference.steady_motion(mv)
    J_fly, fly = reference.flywheel_for(mv, target)
    runs = (simulate.steady_run(mv, plain), simulate.steady_run(mv, fly))
    lines = ["phi1_deg,omega_rad_s,t_s,omega_flywheel_rad_s,t_flywheel_s"]
    lines += [",".join(map(repr, r)) for r in np.column_stack(
        [np.degrees(plain.phi), plain.omega, plain.t, fly.omega, fly.t]).tolist()]
    (stage / "reference_steady.csv").write_text("\n".join(lines) + "\n", encoding="utf-8")
    if jobs is not None:
        from .plotting import loads as plots_loads

        jobs.append((plots_loads.steady_plot, (mech, plain, fly, runs, stage), {}))
    motor = mv.dynamics.motor
    failures = []
    for name, st, run in (("without flywheel", plain, runs[0]), ("with flywheel", fly, runs[1])):
        failures += compare.steady_failures(name, run.delta, st.delta)
    return {"motor": {"stall_torque_N_m": motor.stall_torque, "no_load_speed_rad_s": motor.no_load_speed},
            "omega_mean_rad_s": plain.omega_mean, "n_mean_rpm": plain.omega_mean * 30 / np.pi,
            "delta": plain.delta, "delta_mujoco": runs[0].delta, "target_delta": target,
            "flywheel_kg_m2": J_fly, "delta_with_flywheel": fly.delta,
            "delta_with_flywheel_mujoco": runs[1].delta,
            "omega_mean_with_flywheel_rad_s": fly.omega_mean,
            "definition": "delta = (omega_max - omega_min) / omega_mean, omega_mean = time average over a period",
            "failures": failures}


def _on_grid(m: reference.Motion, t: np.ndarray) -> reference.Motion | None:
    """``m`` thinned to the times ``t`` if they are every k-th of its own, else None."""
    k = (len(m.t) - 1) // max(len(t) - 1, 1)
    if k >= 1 and len(m.t[::k]) == len(t) and np.allclose(m.t[::k], t, rtol=0, atol=1e-12):
        return reference.Motion(m.t[::k], m.phi[::k], m.omega[::k], m.eps[::k])
    return None


def _settings(s: Settings) -> dict:
    return {"integrator": s.integrator, "timestep_s": s.timestep, "solref": list(s.solref),
            "solimp": list(s.solimp), "solver_tolerance": s.tolerance}
