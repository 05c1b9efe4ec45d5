"""Headless MuJoCo runs and the matching reference traces, as time series (SI units).

Two cases per mechanism:

* kinematic: the input crank turns at the file's constant ``speed``. The motion is imposed
  physically: a flywheel (armature on the crank joint, ``FLYWHEEL_RATIO`` times the largest
  reduced inertia of the mechanism) makes the mechanism's reaction on the crank negligible, as
  a machine's handwheel does; the crank speed that results is recorded, not assumed.
* dynamic: the file's ``[dynamics]`` case: driving moment by a motor, viscous damping on the
  crank joint, gravity, from (phi0, omega0).

Every quantity is read from the model's own sensors (:func:`builder._add_sensors`), the
same a user of the written MJCF reads: point positions, velocities and accelerations (frame
sensors: MuJoCo's exact rigid-body kinematics), the thread's length, the crank's angle and
speed, the links' angular rates, the drive's torque and each tree pair's reaction (force and
torque sensors on MuJoCo's body interaction forces). The loop pairs' forces, which no sensor
reports, follow from the same sensors by Newton's law per link (:func:`_loop_forces`). A
sample is the state at its time: after a step MuJoCo's derived quantities belong to the
state before it, and so do the sensors rollout records.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from .. import reference
from ..errors import SimulationError
from ..model import names
from ..model.jet import norms
from ..model.mechanism import Mechanism
from ..runs import DYNAMIC, Case, Settings, SteadyRun, Trace
from ..units import RunKind, Source
from . import builder
from ._mujoco import mujoco, rollout
from .steps import kinematic_clock

FLYWHEEL_RATIO = 1e9
PROGRESS_EVERY = 0.5  # s between progress reports of a long run
SPEED_HOLD = 1e-9  # relative speed error the kinematic drive's servo is sized for
DIVERGED_LOOP = 1e-3  # m: a loop gap this large means the run has failed, not just drifted


def kinematic_case(
    mech: Mechanism, *, speed: float | None = None, cycles: float | None = None, settings: Settings | None = None
) -> Case:
    """The constant-speed case: ``cycles`` periods of the mechanism at ``speed`` rad/s.

    The flywheel is sized twice over: ``FLYWHEEL_RATIO`` times the largest reduced inertia,
    so that the mechanism's inertia barely moves it, and large enough that its speed servo
    (see :mod:`mjlink.sim.builder`) holds the speed within ``SPEED_HOLD`` of nominal against
    the largest torque the motion needs (inertia, gravity, damping and the file's forces).

    Above ``VERIFIED_SPEED`` (a sewing head at its production speed) the default settings'
    timestep and loop time constant shrink by ``VERIFIED_SPEED / |speed|``: the run is then the
    verified one on a faster clock (the same crank angle per step and per time constant), where
    at the fixed timestep the loops' error would grow with the speed squared. Given
    ``settings`` are used as they are.
    """
    w = mech.speed if speed is None else speed
    clock = kinematic_clock(mech.period, w, mech.cycles if cycles is None else cycles, settings)
    base = clock.settings
    phi = mech.phi0 + np.linspace(0, mech.period, 64, endpoint=False)
    jmax = float(reference.SpectralDynamics(mech, samples=128).evaluate(phi)[0].max())
    tau_max = float(np.abs(reference.driving_torque(mech, phi, w)).max())
    held = builder.SERVO_STEPS * base.timestep * tau_max / (abs(w) * SPEED_HOLD)
    fly = max(FLYWHEEL_RATIO * max(jmax, 1e-9), held)
    return dataclasses.replace(clock, settings=dataclasses.replace(base, flywheel=fly, imposed_speed=w))


def dynamic_case(
    mech: Mechanism,
    *,
    duration: float | None = None,
    settings: Settings | None = None,
    sample_dt: float = 2.5e-4,
    omega0: float | None = None,
) -> Case:
    """The file's forward-dynamics case, sampled every ``sample_dt`` s (duration s, omega0 rad/s)."""
    s = settings or DYNAMIC
    every = max(1, round(sample_dt / s.timestep))
    return Case(
        RunKind.DYNAMICS,
        mech.dynamics.duration if duration is None else duration,
        mech.dynamics.omega0 if omega0 is None else omega0,
        s,
        every,
    )


def steady_run(mech: Mechanism, steady: reference.Steady, periods: int = 3) -> SteadyRun:
    """Simulate ``mech`` (a :func:`reference.steady_variant`) from the steady orbit's start,
    with the steady case's flywheel as armature on the crank, and measure the fluctuation."""
    T = float(abs(steady.t[-1]))
    base = DYNAMIC
    s = dataclasses.replace(base, flywheel=steady.extra_inertia)
    case = dynamic_case(mech, duration=periods * T, settings=s, sample_dt=base.timestep, omega0=float(steady.omega[0]))
    tr = run(mech, case)
    last = tr.time >= tr.time[-1] - T
    w = tr.omega[last]
    mean = (tr.phi[last][-1] - tr.phi[last][0]) / (tr.time[last][-1] - tr.time[last][0])
    return SteadyRun(float((w.max() - w.min()) / abs(mean)), float(mean), tr)


class Forces:
    """The file's external point forces on a MuJoCo state, as body forces (``xfrc_applied``).

    They go into ``xfrc_applied`` (the force at the body's centre of mass with its moment)
    rather than ``qfrc_applied``, so that the body interaction forces of
    ``mj_rnePostConstraint``, which the load sensors read, count them.
    """

    def __init__(self, mech: Mechanism, built: builder.Built):
        model = built.physics
        self.mech = mech
        self.qadr = built.input_qpos
        self.items = [
            (f, built.sites[f.point], int(model.site_bodyid[built.sites[f.point]])) for f in mech.dynamics.forces
        ]
        self.period = mech.period

    def apply(self, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        """The forces at the state whose positions ``data`` holds (``mj_kinematics`` done):
        at a sample's own state, or at a step's midpoint (:meth:`hold`). Scalar arithmetic:
        this runs every step, where numpy's small-array calls cost more than the step."""
        phi = self.mech.phi0 + float(data.qpos[self.qadr])
        xfrc = data.xfrc_applied
        xfrc[:] = 0.0
        for f, sid, body in self.items:
            fx, fy, fz = f.at_scalar(phi, self.period)
            px, py, pz = data.site_xpos[sid]
            cx, cy, cz = data.xipos[body]
            rx, ry, rz = px - cx, py - cy, pz - cz
            xfrc[body] += (fx, fy, fz, ry * fz - rz * fy, rz * fx - rx * fz, rx * fy - ry * fx)

    def hold(self, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        """Set the forces for the coming step at its midpoint: the configuration half a step
        ahead (qpos + qvel dt / 2: every joint is a hinge or a slide) gives the crank angle
        for the force tables and the points' lever arms, and the force is held through the
        step's Runge-Kutta stages (second order in the step, like the midpoint rule), instead
        of a Python callback at every stage, which dominated a takeup_eyelets run; this costs
        2 kinematics passes a step, and omega still agrees with the reference within 1.9e-5
        of its range there (9.1e-6 with the per-stage callback; threshold 5e-4). Holding the force of the step's start instead missed the
        threshold (1.5e-3): the lever arm and the table lag by half a step. MuJoCo has no
        native element for a force that is a table of the crank angle (an actuator's gain and
        bias are affine in its own length and speed), and rollout's open-loop controls would
        need the angle before the run has found it."""
        q = data.qpos.copy()
        data.qpos[:] = q + 0.5 * model.opt.timestep * data.qvel
        mujoco.mj_kinematics(model, data)
        self.apply(model, data)
        data.qpos[:] = q


@dataclass(frozen=True)
class Record:
    """A run's raw samples: ``time`` (n,) s, ``qpos`` (n, nq), ``qvel`` (n, nv), ``rows`` (n,
    nsensordata) the model's sensors, ``xfrc`` (n, nbody, 3) N the external point forces in
    effect at each sample (None: the file has none)."""

    time: np.ndarray
    qpos: np.ndarray
    qvel: np.ndarray
    rows: np.ndarray
    xfrc: np.ndarray | None


CHUNK_STEPS = 4096  # steps per rollout call: progress, Ctrl-C and the divergence check between them
CHECK_EVERY = 256  # samples of a Python-stepped run between divergence checks


def _record_rollout(
    case: Case, built: builder.Built, data: mujoco.MjData, progress: Callable[[float], None] | None
) -> Record:
    """Step the run in compiled chunks (``mujoco.rollout``) and keep every ``sample_every``-th
    row of sensors with its state.

    Rollout copies ``sensordata`` after each ``mj_step``, whose forward pass computes the
    sensors before it integrates (the Runge-Kutta stages skip them): row j holds the sensors of
    the state before step j+1, at t = j dt, which is the state rollout returned for step j
    (the initial state for j = 0). ``steps + 1`` steps give the samples up to the run's end.
    """

    model = built.physics
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    ns = mujoco.mj_stateSize(model, spec)
    state0 = np.empty(ns)
    mujoco.mj_getState(model, data, state0, spec)
    total, every = case.steps + 1, case.sample_every
    chunk = max(every, CHUNK_STEPS // every * every)
    keep_t, keep_q, keep_v, keep_r = [], [], [], []
    warm = data.qacc_warmstart.copy()
    shown = time.monotonic()
    done = 0
    before = state0
    while done < total:
        if progress is not None and time.monotonic() - shown >= PROGRESS_EVERY:
            progress(done / total)
            shown = time.monotonic()
        n = min(chunk, total - done)
        st, sd = rollout.rollout(model, data, before, nstep=n, initial_warmstart=warm)
        st, sd = st[0], sd[0]
        # The state at each row's time: the one before its step.
        at = np.concatenate([before[None], st[:-1]])
        idx = np.arange(0, n, every) if done % every == 0 else np.arange(every - done % every, n, every)
        keep_t.append(at[idx, 0])
        keep_q.append(at[idx, 1 : 1 + model.nq])
        keep_v.append(at[idx, 1 + model.nq : 1 + model.nq + model.nv])
        keep_r.append(sd[idx])
        _check(built, keep_t[-1], keep_r[-1], keep_q[-1])
        _check_reset(built, data, at[:, 0])
        before = st[-1].copy()
        warm = data.qacc_warmstart.copy()
        done += n
    return Record(np.concatenate(keep_t), np.concatenate(keep_q), np.concatenate(keep_v), np.concatenate(keep_r), None)


def _record_stepped(
    mech: Mechanism,
    case: Case,
    built: builder.Built,
    data: mujoco.MjData,
    progress: Callable[[float], None] | None,
) -> Record:
    """Step the run in Python, once per step, for a file with point forces (set per step by
    :meth:`Forces.hold`); at each sample the forces of the sample's own state are applied and
    the sensors read after ``mj_forward``."""
    model = built.physics
    forces = Forces(mech, built)
    n = case.samples
    t = np.empty(n)
    q = np.empty((n, model.nq))
    v = np.empty((n, model.nv))
    rows = np.empty((n, model.nsensordata))
    xfrc = np.empty((n, model.nbody, 3))
    k = checked = 0
    shown = time.monotonic()
    for step in range(case.steps + 1):
        if progress is not None and step % 1000 == 0 and time.monotonic() - shown > PROGRESS_EVERY:
            progress(step / max(case.steps, 1))
            shown = time.monotonic()
        if step % case.sample_every == 0:
            # The sample's loads see the forces of its own state, not the step's midpoint.
            mujoco.mj_kinematics(model, data)
            forces.apply(model, data)
            mujoco.mj_forward(model, data)
            t[k] = data.time
            q[k] = data.qpos
            v[k] = data.qvel
            rows[k] = data.sensordata
            xfrc[k] = data.xfrc_applied[:, :3]
            k += 1
            if k - checked == CHECK_EVERY or step == case.steps:
                _check(built, t[checked:k], rows[checked:k], q[checked:k])
                _check_reset(built, data, t[checked:k])
                checked = k
        if step < case.steps:
            forces.hold(model, data)
            mujoco.mj_step(model, data)
    return Record(t[:k], q[:k], v[:k], rows[:k], xfrc[:k])


_UNSTABLE = (mujoco.mjtWarning.mjWARN_BADQPOS, mujoco.mjtWarning.mjWARN_BADQVEL, mujoco.mjtWarning.mjWARN_BADQACC)


def _check_reset(built: builder.Built, data: mujoco.MjData, times: np.ndarray) -> None:
    """Raise SimulationError if MuJoCo found the state non-finite or huge and reset it (it
    warns and goes on from the initial state): at the last time ``times`` (s, the rows'
    times) reached before the reset."""
    if any(data.warning[w].number for w in _UNSTABLE):
        back = np.nonzero(np.diff(times) <= 0)[0]
        t = times[back[0]] if len(back) else times[-1]
        raise SimulationError(f"{built.spec.modelname}: MuJoCo diverged (non-finite or huge state) at t = {t:.6g} s")


def loop_gaps(built: builder.Built, rows: np.ndarray) -> np.ndarray:
    """(n, loops) distance (m) between the two anchors of every loop pin."""
    S = built.sensors
    out = np.zeros((len(rows), len(built.loops)))
    for i, (pr, _) in enumerate(built.loops):
        a, b = (S[("pos", names.loop_anchor(pr.pin, link))] for link in (pr.child, pr.parent))
        out[:, i] = norms(rows[:, a : a + 3] - rows[:, b : b + 3])
    return out


def _check(built: builder.Built, t: np.ndarray, rows: np.ndarray, qpos: np.ndarray) -> None:
    """Raise SimulationError at the first sample that is not finite or whose loop opened."""
    model = built.physics
    bad = ~(np.isfinite(rows).all(axis=1) & np.isfinite(qpos).all(axis=1))
    if bad.any():
        k = int(np.argmax(bad))
        raise SimulationError(f"{built.spec.modelname}: MuJoCo diverged (non-finite state) at t = {t[k]:.6g} s")
    if not built.loops:
        return
    gaps = loop_gaps(built, rows)
    worst = gaps.max(axis=1)
    if (worst > DIVERGED_LOOP).any():
        k = int(np.argmax(worst > DIVERGED_LOOP))
        eq = built.loops[int(np.argmax(gaps[k]))][1]
        raise SimulationError(
            f"{built.spec.modelname}: loop constraint {mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_EQUALITY, eq)} "
            f"opened to {worst[k] * 1e3:.3g} mm at t = {t[k]:.6g} s: the run diverged"
        )


def _rotate(quat: np.ndarray, v: np.ndarray) -> np.ndarray:
    """(n, 3) vectors ``v`` turned by the unit quaternions ``quat`` (n, 4), w first."""
    w, u = quat[:, :1], quat[:, 1:]
    t = 2.0 * np.cross(u, v)
    return v + w * t + np.cross(u, t)


def _loop_forces(
    mech: Mechanism, built: builder.Built, rec: Record, tree_force: dict[str, np.ndarray]
) -> dict[str, np.ndarray]:
    """Force (N, world) on each loop pair's child from its connect equality, per sample, from
    Newton's law for every link: MuJoCo's body interaction forces (the load sensors) count
    every force on a body, the loops' included, so m (a - g) minus the pair forces from the
    parent and to the children, minus the point forces, is what the loops put on the body.
    Solved for all loops and samples at once (least squares, exact when each loop's force
    shows in some body's balance; raises SimulationError if the loops' forces cannot be told
    apart, as when two loops join the same two links)."""
    model = built.physics
    S = built.sensors
    rows = rec.rows
    links = [l.name for l in mech.links]
    row_of = {l: i for i, l in enumerate(links)}
    inc = np.zeros((len(links), len(built.loops)))
    for e, (pr, _) in enumerate(built.loops):
        inc[row_of[pr.child], e] += 1.0
        if pr.parent is not None:
            inc[row_of[pr.parent], e] -= 1.0
    # numpy < 2 cannot take the rank of an empty matrix: no loops, nothing to tell apart.
    if inc.size and np.linalg.matrix_rank(inc) < len(built.loops):
        raise SimulationError(f"{mech.name}: the loops' forces cannot be told apart from the links' balances")
    rhs = np.empty((len(links), len(rows), 3))
    for l in links:
        b = built.bodies[l]
        a = S[("comacc", l)]
        r = float(model.body_mass[b]) * rows[:, a : a + 3] - tree_force[l]
        for pr, _ in built.tree:
            if pr.parent == l:
                r = r + tree_force[pr.child]
        if rec.xfrc is not None:
            r = r - rec.xfrc[:, b]
        rhs[row_of[l]] = r
    sol = np.linalg.pinv(inc) @ rhs.reshape(len(links), -1)
    return {pr.label: sol[e].reshape(len(rows), 3) for e, (pr, _) in enumerate(built.loops)}


def decode(mech: Mechanism, case: Case, built: builder.Built, rec: Record) -> Trace:
    """The trace of a run from its raw samples: every quantity from the model's sensors
    (:func:`builder._add_sensors`), vectorized over the samples."""
    model = built.physics
    S = built.sensors
    rows = rec.rows
    n = len(rows)
    g = np.asarray(model.opt.gravity)

    def col(key: tuple[str, str], dim: int = 3) -> np.ndarray:
        return rows[:, S[key] : S[key] + dim]

    P, V, A = {}, {}, {}
    for name in mech.point_names:
        if name in mech.ground:
            P[name] = np.broadcast_to(model.site_pos[built.sites[name]], (n, 3)).copy()
            V[name] = np.zeros((n, 3))
            A[name] = np.zeros((n, 3))
        else:
            P[name], V[name] = col(("pos", name)).copy(), col(("vel", name)).copy()
            A[name] = col(("acc", name)) + g  # the sensor reads a - g
    LW = {l.name: col(("angvel", l.name))[:, 2].copy() for l in mech.links}
    LE = {l.name: col(("angacc", l.name))[:, 2].copy() for l in mech.links}
    # The input crank turns on the frame about Z: its angular acceleration is the crank's.
    eps = LE[mech.input_link.name].copy()
    gaps = loop_gaps(built, rows)
    tau = None
    RF: dict[str, np.ndarray] = {}
    RM: dict[str, np.ndarray] = {}
    GT: dict[str, np.ndarray] = {}
    if case.loads:
        # The drive's torque on the crank minus what turns the flywheel: the effort of the
        # imposed motion from ordinary-sized terms.
        tau = col(("output", names.DRIVE), 1)[:, 0] - model.dof_armature[built.input_dof] * eps
        full: dict[str, np.ndarray] = {}
        geared = {mech.carrier(c).name for c in mech.geared}
        for pr, j in built.tree:
            quat = col(("quat", pr.child), 4)
            f = _rotate(quat, col(("force", pr.child)))
            full[pr.child] = f
            if pr.revolute:
                RF[pr.label] = f
            else:
                u = _rotate(quat, np.broadcast_to(model.jnt_axis[j], (n, 3)))
                nrm = np.column_stack([-u[:, 1], u[:, 0], np.zeros(n)])
                RF[pr.label] = np.einsum("ij,ij->i", f, nrm)[:, None] * nrm
                RM[pr.label] = _rotate(quat, col(("torque", pr.child)))[:, 2]
            if pr.parent is None and pr.revolute and pr.child in geared:
                # A geared shaft's joint carries the gear equality's torque, which no pair's
                # force shows: the frame's share of the coupling (compare.frame_mujoco).
                GT[pr.label] = _rotate(quat, col(("torque", pr.child)))[:, 2]
        RF.update(_loop_forces(mech, built, rec, full))
    return Trace(
        source=Source.MUJOCO,
        kind=case.kind,
        time=rec.time,
        phi=mech.phi0 + col(("angle", "input"), 1)[:, 0],
        omega=col(("speed", "input"), 1)[:, 0].copy(),
        eps=eps,
        points=P,
        velocities=V,
        accelerations=A,
        thread_length=col(("length", names.THREAD), 1)[:, 0].copy() if mech.thread else None,
        loop_gap=gaps.max(axis=1, initial=0.0),
        qpos=rec.qpos,
        link_omega=LW,
        link_eps=LE,
        torque=tau,
        reactions=RF,
        moments=RM,
        gear_torques=GT,
    )


def run(
    mech: Mechanism,
    case: Case,
    built: builder.Built | None = None,
    progress: Callable[[float], None] | None = None,
) -> Trace:
    """Simulate ``case`` in MuJoCo and sample it through the model's sensors. Raises
    SimulationError if the run diverges.

    A file without point forces is stepped in compiled chunks (:func:`_record_rollout`); one
    with them in Python, once per step (:func:`_record_stepped`). ``progress``, if given, is
    called with the fraction done (0..1) about every PROGRESS_EVERY seconds of a long run, and
    with 1 at its end."""
    built = built or builder.make(mech, case.settings)
    data = mujoco.MjData(built.physics)
    data.qvel[:] = builder.consistent_velocity(built.physics, data, built.input_dof, case.omega0)
    if mech.dynamics.forces:
        rec = _record_stepped(mech, case, built, data, progress)
    else:
        rec = _record_rollout(case, built, data, progress)
    if progress is not None:
        progress(1.0)
    return decode(mech, case, built, rec)
