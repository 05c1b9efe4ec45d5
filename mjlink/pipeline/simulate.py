"""The ``simulate`` run: the kinematic run and its reference and agreement; then, as the
options say and the file allows, the forward dynamics, the loads, the steady motion, the
figures (drawn in a worker process beside the runs, :mod:`mjlink.runtime.workers`) and the video, into one
output folder published whole (:func:`mjlink.staging.staged_dir`).
"""

from __future__ import annotations

import dataclasses
import functools
import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .. import compare, notes, reference
from ..analysis import summary, tension
from ..analysis.timing import head_timing
from ..errors import SimulationError
from ..files import write_csv, write_json, write_table, write_text
from ..model.mechanism import Mechanism
from ..pages import design, index
from ..runs import DYNAMIC, Settings, Trace
from ..runtime import staging, workers
from ..runtime.markers import MARKER
from ..runtime.signals import uninterrupted
from ..runtime.workers import PlotJob, run_jobs
from ..sim import builder, simulate
from ..sim.feed import FeedRun, run_feed
from ..units import RunKind
from .cost import enough_samples, estimate
from .feed import FEED_STITCHES, MAX_RPM, MIN_RPM
from .loads import loads_stage, steady_stage
from .options import Options, has_mass, has_masses
from .results import (
    DynamicsSummary,
    KinematicsSummary,
    Rk4Comparison,
    SimulateResult,
    Timings,
    VideoSummary,
    provenance,
)


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
    (:func:`mjlink.runtime.staging.staged_dir`, kind ``simulate``): it replaces the files an earlier ``simulate``
    wrote there and keeps any other file, or is not written at all if anything fails. A folder
    mjlink did not write for ``simulate`` of this mechanism is refused unless ``force``.

    Raises SimulationError if MuJoCo leaves the reference's assembly branch or diverges,
    OutputError if the folder cannot be written, RenderError if the video cannot be made.
    """
    estimate(mech, opts)  # the absurd is refused before anything starts, whoever calls
    clock = _Clock()
    out_dir = Path(out_root) / mech.name
    with staging.staged_dir(out_dir, kind="simulate", force=force, mechanism=mech.name, command=command) as stage:
        kcase = simulate.kinematic_case(mech, speed=opts.speed, cycles=opts.cycles)
        enough_samples(mech, kcase, "--cycles")
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
        write_csv(stage / "kinematics.csv", mech, kin_mj)
        write_csv(stage / "reference_kinematics.csv", mech, kin_ref)
        kinematics = KinematicsSummary(kcase.omega0, kcase.duration, kcase.settings)

        # Figures are drawn in forked workers while this process goes on (two cores): those of
        # the kinematic run at once, beside the dynamic run; those of the dynamics and loads
        # beside the loads and the video. Without fork they are drawn here, in order.
        drawing: list[workers.PlotWorker] = []
        pending: list[PlotJob] = []

        def draw(jobs: list[PlotJob], *, now: bool = True) -> None:
            worker = workers.start(jobs) if (jobs and now) else None
            if worker is not None:
                drawing.append(worker)
            else:
                pending.extend(jobs)

        if opts.plots:
            from ..plotting import figures, style  # here: matplotlib, not for --no-plots

            style.warm()  # once here, for every worker forked from this process
            # Residual panels subtract the reference at MuJoCo's own crank state, as the
            # agreement table does (the imposed speed holds to 1e-6, not exactly).
            draw([functools.partial(figures.kinematic_plots, mech, kin_mj, kin_at, stage)])

        dyn = None
        if opts.dynamics and has_masses(mech):
            dyn = _forward_dynamics(mech, opts.duration, stage, clock, progress)
            agreements.append(dyn.agreement)
            if opts.plots:
                from ..plotting import figures  # here: matplotlib, not for --no-plots

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
        if opts.loads and has_mass(mech):
            loads_summary = loads_stage(mech, kin_mj, stage, queue, at_kin)
            clock.lap("loads")
        if opts.steady:
            steady_summary = steady_stage(mech, stage, queue)
            clock.lap("steady")
        head = head_timing(mech) if mech.timing is not None else None
        thread = tension.of_head(mech, head) if head is not None else None
        if thread is not None:
            names, cols = thread.columns()
            write_table(stage / "tension.csv", names, cols)
        fed = _feed(mech, opts.speed, stage)
        if fed is not None:
            clock.lap("feed")
        if head is not None and opts.plots:
            from ..plotting import timing as timing_plot  # here: matplotlib, not for --no-plots

            jobs: list[PlotJob] = [functools.partial(timing_plot.cyclogram_plot, mech, head, stage)]
            if head.balance is not None:
                jobs.append(functools.partial(timing_plot.balance_plot, mech, head, stage))
            if thread is not None:
                jobs.append(functools.partial(timing_plot.tension_plot, mech, head, thread, stage))
            if fed is not None:
                from ..plotting import feed as feed_plot

                jobs.append(functools.partial(feed_plot.feed_plot, mech, fed, stage))
            draw(jobs)
        failures = tuple(f for a in agreements for f in a.failures())
        failures += head.failures() if head else ()
        failures += thread.failures() if thread else ()
        failures += loads_summary.failures if loads_summary else ()
        failures += steady_summary.failures if steady_summary else ()

        # The loads' figures beside the video. Each group of figures is its own worker, started
        # as soon as its data exists: the two cores stay busy to the end rather than one
        # worker drawing the last figures alone while this process waits.
        draw(load_jobs)
        video = None
        if opts.video:
            video = _video(mech, kin_mj, kcase.settings, stage, opts, progress=not drawing)
            clock.lap("video")
        run_jobs(pending)
        for w in drawing:
            workers.finish(w)
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
            timing=head,
            design=summary.summarize(mech, thread, fed),
            tension=thread,
            feed=fed,
        )
        write_json(stage / "report.json", result.as_dict())
        # The dynamic run's own model where it ran (its settings are DYNAMIC): not built again.
        xml = dyn.model.spec.to_xml() if dyn is not None else builder.to_xml(mech, DYNAMIC)
        write_text(stage / "model.xml", xml, in_stage=True)
        if mech.text is not None:  # drag-to-design edits the file as it was read for this run
            write_text(stage / "design.html", design.design_html(mech, mech.text), in_stage=True)
        written = [p.name for p in stage.iterdir() if p.name != MARKER] + ["index.html"]
        write_text(stage / "index.html", index.index_html(result, written), in_stage=True)
        files = tuple(sorted(p.name for p in stage.iterdir() if p.name != MARKER))
    return dataclasses.replace(result, files=files)


def _feed(mech: Mechanism, speed: float | None, stage: Path) -> FeedRun | None:
    """A head's fabric fed under its presser foot at the run's ``speed`` (rad/s; None: the
    file's), :data:`FEED_STITCHES` stitches from rest, its last into ``feed.csv``; None for a
    mechanism without a feed dog, or at a speed the feed is not run at (a note says so)."""
    tm = mech.timing
    if tm is None or not tm.has("feed_dog"):
        return None
    rpm = abs(mech.speed if speed is None else speed) * 30.0 / math.pi
    if not MIN_RPM <= rpm <= MAX_RPM:
        notes.note(f"the feed with contact runs at {MIN_RPM:g} to {MAX_RPM:g} rpm: not run at {rpm:.6g} rpm")
        return None
    run = run_feed(mech, speed_rpm=rpm, stitches=FEED_STITCHES)
    names, cols = run.columns()
    write_table(stage / "feed.csv", names, cols)
    return run


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
    enough_samples(mech, dcase, "--duration")
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
    write_csv(stage / "dynamics.csv", mech, dyn_mj)
    write_csv(stage / "reference_dynamics.csv", mech, dyn_ref)
    paper = None
    if rk4 is not None:
        tight = on_grid(motion, rk4.t) or reference.forward_dynamics(mech, rk4.t, sd=sd)
        d = np.abs(rk4.omega - tight.omega)
        paper = Rk4Comparison(
            float(rk4.omega[-1]),
            float(d.max()),
            float(d.max() / np.abs(tight.omega).max()),
            float(abs(rk4.omega[-1] - tight.omega[-1]) / abs(tight.omega[-1])),
            len(rk4.t) - 1,
        )
    summary = DynamicsSummary(
        moment=mech.dynamics.moment,
        damping=mech.dynamics.damping,
        duration=dcase.duration,
        settings=dcase.settings,
        omega_final_mujoco=float(dyn_mj.omega[-1]),
        omega_final_reference=float(motion.omega[-1]),
        ode_rtol=reference.TIGHT_RTOL,
        spectral_harmonics=sd.harmonics,
        spectral_error=sd.error,
        rk4=paper,
        ode_method=motion.method,
    )
    return _DynamicRun(summary, agreement, dyn_mj, dyn_ref, rk4, built)


def _video(
    mech: Mechanism, kin_mj: Trace, settings: Settings, stage: Path, opts: Options, *, progress: bool
) -> VideoSummary:
    """The kinematic run as ``NAME.mp4`` in ``stage``."""
    from ..sim import render  # here: Pillow, imageio, OpenGL, only for a video

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
        held=uninterrupted,
    )
    return VideoSummary(
        file=file,
        frames=info.frames,
        fps=info.fps,
        width=info.width,
        height=info.height,
        backend=info.backend,
        slowed_down_by=info.time_scale,
    )


def _same_branch(mech: Mechanism, trace: Trace, at: reference.Kinematics | None = None) -> None:
    """Stop a run whose MuJoCo linkage snapped to the other assembly branch (near a dead point).
    ``at``: the reference at the run's own crank angles (:func:`compare.unchecked_at`)."""
    switched = compare.branch_switch(mech, trace, kin=at)
    if switched:
        raise SimulationError(switched)


def on_grid(m: reference.Motion, t: np.ndarray) -> reference.Motion | None:
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
