"""Headless MuJoCo runs and the matching reference traces, as time series (SI units).

Two cases per mechanism:

* kinematic: the input crank turns at the file's constant ``speed``. The motion is imposed
  physically: a flywheel (armature on the crank joint, ``FLYWHEEL_RATIO`` times the largest
  reduced inertia of the mechanism) makes the mechanism's reaction on the crank negligible, as
  a machine's handwheel does; the crank speed that results is recorded, not assumed.
* dynamic: the file's ``[dynamics]`` case: driving moment by a motor, viscous damping on the
  crank joint, gravity, from (phi0, omega0).

Samples are taken after ``mj_forward`` on the current state and before ``mj_step`` (after a
step MuJoCo's derived quantities belong to the state before it). Point velocities are
``J_site qvel``, accelerations ``J_site qacc + Jdot_site qvel``.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable

import mujoco
import numpy as np

from .. import reference
from ..errors import SimulationError
from ..model.mechanism import Mechanism
from ..runs import DYNAMIC, KINEMATIC, Case, Settings, SteadyRun, Trace
from ..units import RunKind, Source
from . import builder

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
    """
    w = mech.speed if speed is None else speed
    n = mech.cycles if cycles is None else cycles
    base = settings or KINEMATIC
    phi = mech.phi0 + np.linspace(0, mech.period, 64, endpoint=False)
    jmax = float(reference.SpectralDynamics(mech, samples=128).evaluate(phi)[0].max())
    tau_max = float(np.abs(reference.driving_torque(mech, phi, w)).max())
    held = builder.SERVO_STEPS * base.timestep * tau_max / (abs(w) * SPEED_HOLD)
    fly = max(FLYWHEEL_RATIO * max(jmax, 1e-9), held)
    s = dataclasses.replace(base, flywheel=fly, imposed_speed=w)
    return Case(RunKind.KINEMATICS, n * mech.period / abs(w), w, s, 1, True)


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


class Probe:
    """Reads points, thread and loop gaps off a MuJoCo state, by the builder's element ids."""

    def __init__(self, mech: Mechanism, built: builder.Built):
        model = built.model
        self.model = model
        self.names = list(mech.point_names)
        self.site = built.sites
        self.moving = [n for n in self.names if n not in mech.ground]
        self.input_dof = built.input_dof
        self.qadr = built.input_qpos
        self.connects = [i for _, i in built.loops]
        self.thread = built.thread
        self._jp = np.zeros((3, model.nv))
        self._jd = np.zeros((3, model.nv))
        self._jr = np.zeros((3, model.nv))
        self._jrd = np.zeros((3, model.nv))
        self.links = [l.name for l in mech.links]
        self.body = built.bodies
        self.tree_pairs = [(p.label, p) for p, _ in built.tree]
        self.loop_eqs = [(p.label, i) for p, i in built.loops]
        self.mech = mech
        self.forces = [
            (f, self.site[f.point], int(model.site_bodyid[self.site[f.point]])) for f in mech.dynamics.forces
        ]
        self._jac = np.zeros((3, model.nv))
        # Moving points are read per body: each point's velocity and acceleration follow from
        # its body's origin motion by rigid-body kinematics (see body_state), so a sample costs
        # two Jacobians per body whatever the number of points on it.
        self.point_site = np.array([self.site[n] for n in self.moving], dtype=int)
        self.point_body = np.array([int(model.site_bodyid[self.site[n]]) for n in self.moving], dtype=int)
        self.bodies = sorted(set(self.point_body.tolist()) | {int(self.body[l]) for l in self.links})
        self.body_row = {b: i for i, b in enumerate(self.bodies)}

    def body_state(self, data: mujoco.MjData, out: np.ndarray) -> None:
        """Origin velocity, angular velocity, origin acceleration and angular acceleration of
        every body in :attr:`bodies` into ``out`` (bodies, 4, 3): m/s, rad/s, m/s^2, rad/s^2,
        world axes, from the Jacobians at the body origin and their time derivatives (exact,
        as the per-point Jacobians are)."""
        for i, b in enumerate(self.bodies):
            o = data.xpos[b]
            mujoco.mj_jac(self.model, data, self._jp, self._jr, o, b)
            mujoco.mj_jacDot(self.model, data, self._jd, self._jrd, o, b)
            out[i, 0] = self._jp @ data.qvel
            out[i, 1] = self._jr @ data.qvel
            out[i, 2] = self._jp @ data.qacc + self._jd @ data.qvel
            out[i, 3] = self._jr @ data.qacc + self._jrd @ data.qvel

    def apply_forces(self, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        """External point forces at the state whose positions ``data`` holds (``mj_kinematics``
        done), as body forces: at a sample's own state, or at a step's midpoint
        (:meth:`hold_forces`). Each goes into ``xfrc_applied`` (the force at the body's
        centre of mass with its moment) rather than ``qfrc_applied``, so that the body
        interaction forces of ``mj_rnePostConstraint`` count it.
        """
        phi = self.mech.phi0 + float(data.qpos[self.qadr])
        data.xfrc_applied[:] = 0.0
        for f, sid, body in self.forces:
            F = np.asarray(f.at_scalar(phi, self.mech.period))
            data.xfrc_applied[body, :3] += F
            data.xfrc_applied[body, 3:] += np.cross(data.site_xpos[sid] - data.xipos[body], F)

    def hold_forces(self, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        """Set the file's point forces for the coming step at its midpoint: the configuration
        half a step ahead (qpos + qvel dt / 2: every joint is a hinge or a slide) gives the
        crank angle for the force tables and the points' lever arms, and the force is held
        through the step's Runge-Kutta stages (second order in the step, like the midpoint
        rule), instead of a Python callback at every stage: that cost 255 us a step (5 s of
        a takeup_eyelets run); this costs 2 kinematics passes a step, and omega still agrees
        with the reference within 1.9e-5 of its range there (9.1e-6 with the per-stage
        callback; threshold 5e-4). Holding the force of the step's start instead missed the
        threshold (1.5e-3): the lever arm and the table lag by half a step."""
        q = data.qpos.copy()
        data.qpos[:] = q + 0.5 * model.opt.timestep * data.qvel
        mujoco.mj_kinematics(model, data)
        self.apply_forces(model, data)
        data.qpos[:] = q

    def applied(self, model: mujoco.MjModel, data: mujoco.MjData) -> np.ndarray:
        """Generalized force (nv,) of the external point forces in this state."""
        phi = self.mech.phi0 + float(data.qpos[self.qadr])
        total = np.zeros(model.nv)
        for f, sid, body in self.forces:
            mujoco.mj_jac(model, data, self._jac, None, data.site_xpos[sid], body)
            total += np.asarray(f.at_scalar(phi, self.mech.period)) @ self._jac
        return total

    def driving_torque(self, data: mujoco.MjData) -> float:
        """Torque (N*m) the drive supplies to the input crank in this state, the flywheel aside.

        The crank row of ``M qacc + bias = passive + constraint + applied + actuator`` with the
        flywheel's armature taken out of M: in the kinematic run this is the effort of the
        imposed motion, computed from ordinary-sized terms rather than as armature x a tiny
        acceleration.
        """
        c = self.input_dof
        mq = np.zeros(self.model.nv)
        mujoco.mj_mulM(self.model, data, mq, data.qacc)
        return float(
            mq[c]
            - self.model.dof_armature[c] * data.qacc[c]
            + data.qfrc_bias[c]
            - data.qfrc_passive[c]
            - data.qfrc_constraint[c]
            - self.applied(self.model, data)[c]
        )

    def pair_forces(self, data: mujoco.MjData) -> tuple[dict[str, np.ndarray], dict[str, float]]:
        """Force (N) on each pair's child from its parent, and prismatic pairs' moments (N*m).

        Tree pairs: the child body's interaction force with its parent (``cfrc_int`` after
        ``mj_rnePostConstraint``, which counts the loop equalities' forces); loop pairs: the
        connect equality's constraint force.
        """
        mujoco.mj_rnePostConstraint(self.model, data)
        forces, moments = {}, {}
        for label, pr in self.tree_pairs:
            b = self.body[pr.child]
            f = data.cfrc_int[b, 3:6].copy()
            if not pr.revolute:
                u = self.model.jnt_axis[self.model.body_jntadr[b]]
                u = data.xmat[b].reshape(3, 3) @ u
                n = np.array([-u[1], u[0], 0.0])
                forces[label] = (f @ n) * n
                c = data.subtree_com[self.model.body_rootid[b]]
                o = data.xpos[b]
                moments[label] = float(data.cfrc_int[b, 2] + np.cross(c - o, f)[2])
            else:
                forces[label] = f
        for label, i in self.loop_eqs:
            rows = np.nonzero(
                (data.efc_type[: data.nefc] == mujoco.mjtConstraint.mjCNSTR_EQUALITY) & (data.efc_id[: data.nefc] == i)
            )[0]
            forces[label] = data.efc_force[rows].copy()
        return forces, moments

    def loop_gaps(self, data: mujoco.MjData) -> np.ndarray:
        """Distance (m) between the two anchors of every loop-closing connect equality."""
        gaps = np.zeros(len(self.connects))
        for k, i in enumerate(self.connects):
            b1, b2 = self.model.eq_obj1id[i], self.model.eq_obj2id[i]
            a1, a2 = self.model.eq_data[i, 0:3], self.model.eq_data[i, 3:6]
            p1 = data.xpos[b1] + data.xmat[b1].reshape(3, 3) @ a1
            p2 = data.xpos[b2] + data.xmat[b2].reshape(3, 3) @ a2
            gaps[k] = np.linalg.norm(p1 - p2)
        return gaps


def _points_from_bodies(mech, probe: Probe, sites, origins, states, P, V, A, LW, LE) -> None:
    """Every point's position, velocity and acceleration and every link's angular rates from the
    recorded site positions and body states, all samples at once: for a point at ``r`` from its
    body's origin, ``v = v_o + w x r`` and ``a = a_o + alpha x r + w x (w x r)`` (rigid-body
    kinematics, exact). Ground points (sites on the world body) stand still."""
    k = len(sites)
    for n in probe.names:
        P[n][:k] = sites[:, probe.site[n]]
        if n not in probe.moving:
            V[n][:k] = 0.0
            A[n][:k] = 0.0
    for j, n in enumerate(probe.moving):
        b = int(probe.point_body[j])
        st = states[:, probe.body_row[b]]
        r = sites[:, probe.site[n]] - origins[:, b]
        w, al = st[:, 1], st[:, 3]
        V[n][:k] = st[:, 0] + np.cross(w, r)
        A[n][:k] = st[:, 2] + np.cross(al, r) + np.cross(w, np.cross(w, r))
    for n in probe.links:
        st = states[:, probe.body_row[int(probe.body[n])]]
        LW[n][:k] = st[:, 1, 2]
        LE[n][:k] = st[:, 3, 2]


def run(
    mech: Mechanism,
    case: Case,
    built: builder.Built | None = None,
    progress: Callable[[float], None] | None = None,
) -> Trace:
    """Simulate ``case`` in MuJoCo and sample it. Raises SimulationError if the run diverges.

    ``progress``, if given, is called with the fraction done (0..1) about every PROGRESS_EVERY
    seconds of a long run, and with 1 at its end."""
    built = built or builder.make(mech, case.settings)
    model = built.model
    data = mujoco.MjData(model)
    probe = Probe(mech, built)
    return _run(mech, case, model, data, probe, progress)


def _run(
    mech: Mechanism,
    case: Case,
    model: mujoco.MjModel,
    data: mujoco.MjData,
    probe: Probe,
    progress: Callable[[float], None] | None,
) -> Trace:
    data.qvel[:] = builder.consistent_velocity(model, data, probe.input_dof, case.omega0)
    nsteps, samples = case.steps, case.samples
    t = np.empty(samples)
    q = np.empty((samples, model.nq))
    w, e, gap = (np.empty(samples) for _ in range(3))
    th = np.empty(samples) if probe.thread >= 0 else None
    P = {n: np.empty((samples, 3)) for n in probe.names}
    V = {n: np.empty((samples, 3)) for n in probe.names}
    A = {n: np.empty((samples, 3)) for n in probe.names}
    LW = {n: np.empty(samples) for n in probe.links}
    LE = {n: np.empty(samples) for n in probe.links}
    sites = np.empty((samples, model.nsite, 3))
    origins = np.empty((samples, model.nbody, 3))
    states = np.empty((samples, len(probe.bodies), 4, 3))
    tau = np.empty(samples)
    RF: dict[str, np.ndarray] = {}
    RM: dict[str, np.ndarray] = {}
    k = 0
    shown = time.monotonic()
    for step in range(nsteps + 1):
        if progress is not None and step % 1000 == 0 and time.monotonic() - shown > PROGRESS_EVERY:
            progress(step / max(nsteps, 1))
            shown = time.monotonic()
        if step % case.sample_every == 0:
            if probe.forces:
                # The sample's loads see the forces of its own state, not the step's midpoint.
                mujoco.mj_kinematics(model, data)
                probe.apply_forces(model, data)
            mujoco.mj_forward(model, data)
            t[k] = data.time
            q[k] = data.qpos
            w[k] = data.qvel[probe.input_dof]
            e[k] = data.qacc[probe.input_dof]
            gaps = probe.loop_gaps(data)
            gap[k] = gaps.max(initial=0.0)
            if th is not None:
                th[k] = data.ten_length[probe.thread]
            sites[k] = data.site_xpos
            origins[k] = data.xpos
            probe.body_state(data, states[k])
            if case.loads:
                tau[k] = probe.driving_torque(data)
                f, m = probe.pair_forces(data)
                for lab, v in f.items():
                    RF.setdefault(lab, np.empty((samples, 3)))[k] = v
                for lab, v in m.items():
                    RM.setdefault(lab, np.empty(samples))[k] = v
            if not np.isfinite(data.qpos).all() or not np.isfinite(data.qacc).all():
                raise SimulationError(f"{mech.name}: MuJoCo diverged (non-finite state) at t = {data.time:.6g} s")
            if gap[k] > DIVERGED_LOOP:
                worst = probe.connects[int(np.argmax(gaps))]
                raise SimulationError(
                    f"{mech.name}: loop constraint {mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_EQUALITY, worst)} "
                    f"opened to {gap[k] * 1e3:.3g} mm at t = {data.time:.6g} s: the run diverged"
                )
            k += 1
        if step < nsteps:
            if probe.forces:
                probe.hold_forces(model, data)
            mujoco.mj_step(model, data)
    if progress is not None:
        progress(1.0)
    _points_from_bodies(mech, probe, sites[:k], origins[:k], states[:k], P, V, A, LW, LE)
    phi = mech.phi0 + q[:k, probe.qadr]
    return Trace(
        Source.MUJOCO,
        case.kind,
        t[:k],
        phi,
        w[:k],
        e[:k],
        {n: a[:k] for n, a in P.items()},
        {n: a[:k] for n, a in V.items()},
        {n: a[:k] for n, a in A.items()},
        None if th is None else th[:k],
        gap[:k],
        q[:k],
        {n: a[:k] for n, a in LW.items()},
        {n: a[:k] for n, a in LE.items()},
        tau[:k] if case.loads else None,
        {n: a[:k] for n, a in RF.items()},
        {n: a[:k] for n, a in RM.items()},
    )
