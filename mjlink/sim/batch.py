"""MuJoCo's check of many variants at once: one ``mujoco.rollout`` over all their models.

A design study evaluates thousands of variants of one mechanism (same points, blocks and
links; other numbers). Each variant verified here gets its own model, built from ``MjSpec``
by :func:`mjlink.sim.builder.make_batch` with the settings of ``simulate``'s kinematic run
(:func:`mjlink.sim.simulate.kinematic_case`: RK4 at 50 us, the flywheel and speed servo sized
for that variant): :func:`~mjlink.sim.builder.make`'s bodies, joints, equalities, drive,
sensors and keyframe ``initial``, plus a site on each side of every loop pin with its
position sensor. The variants' models must have one size signature; their initial states
come from their keyframes, and one call of ``mujoco.rollout`` steps them all together on its
C++ thread pool for one period of the input at the file's speed (variants at other speeds
take other numbers of steps: one call per number). No Python runs per step: the traces come
back through the sensors alone.

Which sample a row is: ``mj_step`` computes the sensors in its forward pass, before it
integrates (the Runge-Kutta stages skip them), and rollout copies ``sensordata`` after each
step, so row k of rollout's sensordata holds the sensors of the state before step k+1, at
t = k dt. ``n + 1`` rollout steps give the samples t = 0, dt, ..., n dt of an n-step run, as
``simulate`` records them (mujoco's ``python/mujoco/rollout.cc``, ``_unsafe_rollout``; the
equality with a plain ``mj_step`` loop is tested). Rollout stops stepping a trajectory at
MuJoCo's first warning (after a non-finite state MuJoCo resets the data to ``qpos0``) and
repeats its last sensor values to the end; such a run is recognized by its crank angle no
longer advancing and is reported as diverged.

External forces at points (``[[dynamics.force]]``), which ``simulate`` applies through
MuJoCo's control callback at every Runge-Kutta stage, are applied here as rollout's open-loop
``xfrc_applied``: per step, the force and its moment about the body's centre of mass on the
reference's motion at mid-step. On ``takeup_eyelets`` the errors then agree with
``simulate``'s to within 1e-15 m.

Each variant is compared with the reference at MuJoCo's own crank angles and speeds, with
the definitions of :mod:`mjlink.compare` and its thresholds: point positions, point
velocities (relative to their range), loop gaps, thread length, the held crank speed and the
least number of samples. Point accelerations, which ``simulate`` also checks, are not: no
sensor of the model reports them.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from .. import compare, reference
from ..errors import MjlinkError
from ..model import names
from ..model.jet import norms
from ..model.mechanism import Mechanism
from ..runs import Settings
from ..units import RunKind
from . import builder, simulate, steps
from ._mujoco import mujoco

_RUN = str(RunKind.KINEMATICS)
_FULL = mujoco.mjtState.mjSTATE_FULLPHYSICS
# Errors a variant's numbers can cause while its model is built: the reference cannot
# assemble it (MjlinkError), MuJoCo refuses to compile it or numpy's algebra fails (ValueError).
_BUILD_ERRORS = (MjlinkError, ValueError, ArithmeticError)


@dataclass(frozen=True, kw_only=True)
class Verification:
    """One variant's batched MuJoCo run against the reference (maxima over the run).

    ``position_error`` m, the largest distance of any moving point from the reference;
    ``velocity_error`` the largest velocity error of any moving point relative to the largest
    speed that point reaches; ``loop_gap`` m, the largest gap of any loop pin; ``thread_error``
    m, the largest thread-length difference (NaN without a thread); ``speed_error`` the crank
    speed's largest deviation from its initial value, relative to it; ``samples`` the run's
    samples; ``passed`` every threshold of :mod:`mjlink.compare` held; ``failures`` the
    thresholds missed, one line each; ``reason`` '' if the variant ran, else why it has no
    result (its model could not be built, or MuJoCo diverged), its errors then NaN.
    """

    position_error: float
    velocity_error: float
    loop_gap: float
    thread_error: float
    speed_error: float
    samples: int
    passed: bool
    failures: tuple[str, ...] = ()
    reason: str = ""


@dataclass(kw_only=True)
class Timing:
    """Wall-clock seconds of :func:`verify_timed` per stage, summed over the variants.

    ``settings`` the kinematic case of each variant (its flywheel and servo sized from the
    reference); ``spec`` building the MjSpec; ``compile`` compiling it; ``keyframe`` the
    joint speeds consistent with the crank speed and the initial states; ``forces`` the open-loop
    external forces (only mechanisms with ``[[dynamics.force]]`` have any); ``rollout`` the
    rollout; ``compare`` the reference and the comparison. ``steps`` MuJoCo steps taken in all,
    ``threads`` rollout's threads.
    """

    settings: float = 0.0
    spec: float = 0.0
    compile: float = 0.0
    keyframe: float = 0.0
    forces: float = 0.0
    rollout: float = 0.0
    compare: float = 0.0
    steps: int = 0
    threads: int = 1

    @property
    def total(self) -> float:
        """Seconds of all stages."""
        return self.settings + self.spec + self.compile + self.keyframe + self.forces + self.rollout + self.compare


@dataclass(frozen=True)
class _Variant:
    """A variant ready to run: its model and initial state (nstate,), its rollout steps (one
    period and the initial sample: :func:`mjlink.sim.steps.verify_steps`)."""

    index: int
    mech: Mechanism
    built: builder.Built
    state: np.ndarray
    steps: int


def signature(model: mujoco.MjModel) -> tuple[int, ...]:
    """The sizes that must be equal across the models of one rollout (and more, so that a
    variant of another topology is recognized as one): nq, nv, nu, na, nbody, njnt, neq,
    nsite, ntendon, nsensor, nsensordata and the full physics state's size."""
    return (
        model.nq,
        model.nv,
        model.nu,
        model.na,
        model.nbody,
        model.njnt,
        model.neq,
        model.nsite,
        model.ntendon,
        model.nsensor,
        model.nsensordata,
        mujoco.mj_stateSize(model, _FULL),
    )


_SIGNATURE = "nq nv nu na nbody njnt neq nsite ntendon nsensor nsensordata nstate".split()


def verify(mechs: Sequence[Mechanism], *, threads: int = 1, settings: Settings | None = None) -> list[Verification]:
    """Build every variant, step them all in one rollout, compare each with the reference.

    Args:
      mechs: the variants: one mechanism with other numbers (same points, blocks, links).
        Each is run for one period of its input at its file's speed (``mech.speed``), from
        its file's initial angle, as ``simulate``'s kinematic run.
      threads: rollout's threads (1: on the calling thread).
      settings: the numerical settings the kinematic case starts from (timestep, solver,
        loop stiffness); None: ``simulate``'s (:data:`mjlink.runs.KINEMATIC`).
    Returns:
      One :class:`Verification` per variant, in order. A variant that misses a threshold
      is flagged (``passed`` False, ``failures``); one whose model cannot be built or whose
      run diverges has its ``reason``. None is left out.
    Raises:
      MjlinkError: a variant's model differs in size from the first one's (it is not a
        variant of the same mechanism), or ``threads`` < 1.
    """
    return verify_timed(mechs, threads=threads, settings=settings)[0]


def verify_timed(
    mechs: Sequence[Mechanism], *, threads: int = 1, settings: Settings | None = None
) -> tuple[list[Verification], Timing]:
    """:func:`verify`, with the seconds each stage took (:class:`Timing`)."""
    if threads < 1:
        raise MjlinkError(f"threads must be at least 1, got {threads}")
    timing = Timing(threads=threads)
    times: dict[str, float] = {}
    out: list[Verification | None] = [None] * len(mechs)
    ready: list[_Variant] = []
    data: mujoco.MjData | None = None
    for i, mech in enumerate(mechs):
        try:
            t0 = time.perf_counter()
            case = simulate.kinematic_case(mech, cycles=1.0, settings=settings)
            timing.settings += time.perf_counter() - t0
            built = builder.make_batch(mech, case.settings, times)
        except _BUILD_ERRORS as e:
            out[i] = _no_result(f"model not built: {_one_line(e)}")
            continue
        if ready:
            _same_size(ready[0], i, mech, built.physics)
        t0 = time.perf_counter()
        # One scratch MjData serves every model: they have one size signature, as rollout's
        # per-thread MjData serve them all too.
        if data is None:
            data = mujoco.MjData(built.physics)
        mujoco.mj_resetDataKeyframe(
            built.physics, data, mujoco.mj_name2id(built.physics, mujoco.mjtObj.mjOBJ_KEY, names.INITIAL)
        )
        state = np.empty(mujoco.mj_stateSize(built.physics, _FULL))
        mujoco.mj_getState(built.physics, data, state, _FULL)
        times["keyframe"] = times.get("keyframe", 0.0) + time.perf_counter() - t0
        ready.append(_Variant(i, mech, built, state, steps.verify_steps(mech.period, mech.speed, settings)))
    for k in ("spec", "compile", "keyframe"):
        setattr(timing, k, times.get(k, 0.0))

    # Variants at other speeds take other numbers of steps: each step count is one rollout
    # (a design study that keeps the speed has one).
    for nstep in sorted({v.steps for v in ready}):
        group = [v for v in ready if v.steps == nstep]
        t0 = time.perf_counter()
        control = None
        if any(v.mech.dynamics.forces for v in group):
            control = np.zeros((len(group), nstep, 6 * group[0].built.physics.nbody))
            for j, v in enumerate(group):
                control[j] = external_forces(v.mech, v.built, nstep)
        timing.forces += time.perf_counter() - t0
        t0 = time.perf_counter()
        models, states = [v.built.physics for v in group], np.array([v.state for v in group])
        sd = rollout(models, states, nstep, control=control, threads=threads)
        del control
        timing.rollout += time.perf_counter() - t0
        timing.steps += len(group) * nstep
        t0 = time.perf_counter()
        for v, rows in zip(group, sd, strict=True):
            out[v.index] = judge(v.mech, v.built, rows)
        del sd
        timing.compare += time.perf_counter() - t0
    return [v if v is not None else _no_result("not run") for v in out], timing


def rollout(
    models: Sequence[mujoco.MjModel],
    states: np.ndarray,
    nstep: int,
    *,
    control: np.ndarray | None = None,
    threads: int = 1,
) -> np.ndarray:
    """Step every model from its initial state in one rollout; return the sensor traces.

    Args:
      models: B models of one size signature.
      states: (B, nstate) their initial full physics states (``mjSTATE_FULLPHYSICS``).
      nstep: steps of each trajectory.
      control: (B, nstep, 6 nbody) ``xfrc_applied`` during each step (N, N*m; world frame, at
        the bodies' centres of mass), or None for none.
      threads: rollout's threads (1: on the calling thread, no pool).
    Returns:
      (B, nstep, nsensordata) sensor values; row k of a trajectory is its state at t = k dt
      (the state before step k+1).
    Raises:
      MjlinkError: the models differ in size.
    """
    models = list(models)
    sizes = signature(models[0])
    if any(signature(m) != sizes for m in models[1:]):
        raise MjlinkError("rollout: the models differ in size; one rollout steps models of one size signature only")
    nsd = models[0].nsensordata
    sensordata = np.empty((len(models), nstep, nsd))
    states = np.ascontiguousarray(states, dtype=np.float64)
    datas = [mujoco.MjData(models[0]) for _ in range(threads)]
    # skip_checks: the wrapper would otherwise allocate and fill the states of every step
    # too (nstep x nstate per variant), which nothing here reads; the sizes are checked
    # above (signature) and by rollout's C++ side (array sizes).
    with mujoco.rollout.Rollout(nthread=threads if threads > 1 else 0) as pool:
        pool.rollout(
            models,
            datas,
            states,
            None if control is None else np.ascontiguousarray(control, dtype=np.float64),
            skip_checks=True,
            nstep=nstep,
            control_spec=(
                mujoco.mjtState.mjSTATE_CTRL if control is None else mujoco.mjtState.mjSTATE_XFRC_APPLIED
            ).value,
            sensordata=sensordata,
            # One variant per job: a job is a whole trajectory (milliseconds), so scheduling
            # costs nothing, and no thread idles at the end while the other finishes a chunk.
            chunk_size=1,
        )
    return sensordata


def external_forces(mech: Mechanism, built: builder.Built, nstep: int) -> np.ndarray:
    """The file's external point forces as rollout's open-loop ``xfrc_applied``.

    Args:
      mech: the variant, run at its constant speed ``mech.speed`` from ``mech.phi0``.
      built: its model.
      nstep: steps of the run.
    Returns:
      (nstep, 6 nbody): row k the force (N) and its moment (N*m) about each body's centre of
      mass during step k+1, evaluated on the reference's motion at mid-step, t = (k + 1/2) dt,
      as :meth:`mjlink.sim.simulate.Forces.hold` evaluates them on MuJoCo's state half
      a step ahead and holds them through the step.
    """
    model = built.physics
    out = np.zeros((nstep, model.nbody, 6))
    if not mech.dynamics.forces:
        return out.reshape(nstep, -1)
    phi = mech.phi0 + mech.speed * (np.arange(nstep) + 0.5) * float(model.opt.timestep)
    kin = reference.solve(mech, np.concatenate([[mech.phi0], phi]), check=False)
    for f in mech.dynamics.forces:
        site = built.sites[f.point]
        body = int(model.site_bodyid[site])
        if body == 0:  # a force on the frame moves nothing
            continue
        # Every body frame is aligned with the world at phi0, so the arm from the centre of
        # mass to the point turns with the link's angle from there.
        angle = kin.angles[mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, body)].v
        turn = angle[1:] - angle[0]
        r = model.site_pos[site] - model.body_ipos[body]
        c, s = np.cos(turn), np.sin(turn)
        arm = np.column_stack([c * r[0] - s * r[1], s * r[0] + c * r[1], np.full(nstep, r[2])])
        force = f.at(phi, mech.period)
        out[:, body, :3] += force
        out[:, body, 3:] += np.cross(arm, force)
    return out.reshape(nstep, -1)


def judge(mech: Mechanism, built: builder.Built, rows: np.ndarray) -> Verification:
    """One variant's sensor traces against the reference at its own crank angles.

    Args:
      mech: the variant.
      built: its model (:func:`mjlink.sim.builder.make_batch`).
      rows: (n, nsensordata) its sensor values at t = 0, dt, ..., (n-1) dt.
    Returns:
      Its :class:`Verification`.
    """
    model = built.physics

    def col(key: tuple[str, str], dim: int = 1) -> np.ndarray:  # by the builder's sensor addresses
        a = built.sensors[key]
        return rows[:, a] if dim == 1 else rows[:, a : a + dim]

    n, dt = len(rows), float(model.opt.timestep)
    angle = col(("angle", "input"))
    omega = col(("speed", "input"))
    if not np.isfinite(rows).all():
        k = int(np.argmin(np.isfinite(rows).all(axis=1)))
        return _no_result(f"MuJoCo diverged: non-finite sensor values at t = {k * dt:.6g} s")
    # The crank is held at its speed: each step turns it by omega dt. A run that stopped
    # (MuJoCo reset a non-finite state, rollout then repeats the last values) does not.
    turn = np.abs(np.diff(angle) - omega[0] * dt) > 0.5 * abs(omega[0]) * dt
    if turn.any():
        k = int(np.argmax(turn)) + 1
        return _no_result(f"MuJoCo diverged at t = {k * dt:.6g} s: its state went non-finite or huge, the run stopped")
    gap = simulate.loop_gaps(built, rows).max(axis=1, initial=0.0)
    if gap.max(initial=0.0) > simulate.DIVERGED_LOOP:
        k = int(np.argmax(gap > simulate.DIVERGED_LOOP))
        return _no_result(f"MuJoCo diverged: a loop opened to {gap[k] * 1e3:.3g} mm at t = {k * dt:.6g} s")

    try:
        kin = reference.solve(mech, mech.phi0 + angle)
    except MjlinkError as e:
        return _no_result(f"reference: {_one_line(e)}")
    pos = vel = 0.0
    for p in mech.moving_points:
        pos = max(pos, float(norms(col(("pos", p), 3) - kin.position(p)).max()))
        v_ref = kin.velocity(p, omega)
        scale = float(norms(v_ref).max())
        if scale > 0:  # compare's rule: a point that never moves has no velocity error
            err = norms(col(("vel", p), 3) - v_ref).max()
            vel = max(vel, float(err) / scale)
    thread = math.nan
    lf = kin.thread_length()
    if built.thread >= 0 and lf is not None:
        thread = float(np.abs(col(("length", names.THREAD)) - lf.v).max())
    speed = float(np.abs(omega - omega[0]).max() / abs(omega[0]))
    checks = [
        compare.Check(_RUN, "samples", float(n), "", float(compare.MIN_SAMPLES), at_least=True),
        compare.Check(_RUN, "point position", pos * 1e6, "um", compare.POSITION_UM),
        compare.Check(_RUN, "loop gap", float(gap.max(initial=0.0)) * 1e6, "um", compare.LOOP_UM),
        compare.Check(_RUN, "point velocity", vel, "of range", compare.VELOCITY_REL),
        compare.Check(_RUN, "crank speed held", speed, "relative", compare.SPEED_REL),
    ]
    if not math.isnan(thread):
        checks.append(compare.Check(_RUN, "thread length", thread * 1e6, "um", compare.THREAD_UM))
    failures = tuple(_failure(c) for c in checks if c.passed is False)
    return Verification(
        position_error=pos,
        velocity_error=vel,
        loop_gap=float(gap.max(initial=0.0)),
        thread_error=thread,
        speed_error=speed,
        samples=n,
        passed=not failures,
        failures=failures,
    )


def _failure(c: compare.Check) -> str:
    """A missed check as one line, worded as :meth:`mjlink.compare.Agreement.failures`."""
    if c.at_least:
        return f"{c.run}: only {c.value:.0f} samples: at least {c.limit:g} are needed to judge a run"
    return f"{c.run}: {c.quantity} error {c.value:.3g} {c.unit} exceeds {c.limit:g}"


def _same_size(first: _Variant, i: int, mech: Mechanism, model: mujoco.MjModel) -> None:
    """Refuse a variant whose model differs in size from the first variant's."""
    a, b = signature(first.built.physics), signature(model)
    if a != b:
        diff = ", ".join(f"{k} {x} against {y}" for k, x, y in zip(_SIGNATURE, b, a, strict=True) if x != y)
        raise MjlinkError(
            f"variant {i} ({mech.name}) is not a variant of variant {first.index} ({first.mech.name}): their models "
            f"differ in size ({diff}); verify variants of one mechanism (same points, blocks and links) together"
        )


def _no_result(reason: str) -> Verification:
    nan = math.nan
    return Verification(
        position_error=nan,
        velocity_error=nan,
        loop_gap=nan,
        thread_error=nan,
        speed_error=nan,
        samples=0,
        passed=False,
        failures=(),
        reason=reason,
    )


def _one_line(e: BaseException) -> str:
    return "; ".join(line.strip() for line in str(e).splitlines() if line.strip())
