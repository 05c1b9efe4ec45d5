"""Agreement between a MuJoCo trace and the vector-method reference.

The reference is a function of the crank state, so MuJoCo's points are compared with the
reference evaluated at MuJoCo's own crank angle, speed and acceleration at each sample: what
remains is the error of the simulated linkage (soft loop closure, integration), not a phase
drift of the input. For the dynamic run the crank motion itself is compared in time with the
reference's equation-of-motion solution.

Definitions (all maxima over the run):

* position error: ``max |P_mj - P_ref|`` per point, um;
* velocity and acceleration errors: ``max |v_mj - v_ref| / max |v_ref|`` per moving point,
  i.e. relative to the largest magnitude the point reaches (its range);
* loop gap: largest distance between the two anchors of a loop-closing equality, um;
* thread error: ``max |l_mj - l_ref|``, um;
* omega error (dynamics): ``max |omega_mj(t) - omega_ref(t)|`` in rad/s and relative to
  ``max |omega_ref|`` (omega starts from rest, so a pointwise ratio would be meaningless).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

from . import reference
from .model.jet import norms
from .model.mechanism import Mechanism
from .model.topology import pairs
from .reference import reference_trace
from .reference.batch import FrameLoads, frame_loads
from .runs import Trace
from .units import RunKind, shown

# The acceptance thresholds (tests assert them; never loosen to pass).
POSITION_UM = 0.1
VELOCITY_REL = 2e-5
ACCELERATION_REL = 2e-3
LOOP_UM = 0.1
THREAD_UM = 0.1
OMEGA_REL = 5e-4
TORQUE_REL = 1e-3  # of the driving torque's range (max - min)
FORCE_REL = 1e-3  # of each pair's largest force
SHAKING_REL = 1e-3  # the frame's shaking force and moment, of the reference's range
SPEED_REL = 1e-6  # the kinematic run's crank speed, max |omega - omega0| / |omega0|: the motion is imposed
MIN_SAMPLES = 100  # a run with fewer samples is too short to judge: it never passes
STEADY_DELTA_REL = 1e-3  # MuJoCo's coefficient of speed fluctuation vs the reference's, relative
BRANCH_TOL_M = 1e-5  # 10 um: 100 times the position threshold, far below any branch's distance


def thresholds() -> dict[str, float]:
    """The agreement thresholds by name, as the report records them."""
    return {
        "position_um": POSITION_UM,
        "velocity_rel": VELOCITY_REL,
        "acceleration_rel": ACCELERATION_REL,
        "loop_um": LOOP_UM,
        "thread_um": THREAD_UM,
        "omega_rel": OMEGA_REL,
        "speed_held_rel": SPEED_REL,
        "min_samples": MIN_SAMPLES,
    }


def steady_failures(name: str, mujoco_delta: float, reference_delta: float) -> list[str]:
    """The steady-motion rule: MuJoCo's delta within STEADY_DELTA_REL of the reference's."""
    if abs(mujoco_delta - reference_delta) <= STEADY_DELTA_REL * max(reference_delta, 1e-3):
        return []
    return [f"steady {name}: MuJoCo delta {mujoco_delta:.5f} vs reference {reference_delta:.5f}"]


@dataclass(frozen=True)
class PointError:
    """Errors of one point: position um, velocity and acceleration relative to their range."""

    name: str
    position_um: float
    velocity_rel: float
    acceleration_rel: float


@dataclass(frozen=True)
class Check:
    """One compared quantity of a run: ``value`` in ``unit``; ``limit`` its threshold (an upper
    bound, or a lower one with ``at_least``), or None for a quantity that is reported for
    information and held to nothing."""

    run: str
    quantity: str
    value: float
    unit: str
    limit: float | None
    at_least: bool = False

    @property
    def passed(self) -> bool | None:
        """True or False against the threshold (NaN fails); None for an informational quantity."""
        if self.limit is None:
            return None
        return bool(self.value >= self.limit) if self.at_least else bool(self.value <= self.limit)

    @property
    def result(self) -> str:
        return {True: "pass", False: "FAIL", None: "informational"}[self.passed]

    def as_dict(self) -> dict:
        return {
            "run": self.run,
            "quantity": self.quantity,
            "value": self.value,
            "unit": self.unit,
            "threshold": self.limit,
            "result": self.result,
        }


@dataclass(frozen=True, kw_only=True)
class Agreement:
    """Worst-case agreement of one run; see the module docstring for definitions."""

    kind: str
    samples: int
    points: tuple[PointError, ...]
    position_um: float
    velocity_rel: float
    acceleration_rel: float
    loop_um: float
    thread_um: float | None
    omega_abs: float | None = None
    omega_rel: float | None = None
    link_omega_rel: float = 0.0  # angular velocities of the links, relative to their range
    link_eps_rel: float = 0.0  # angular accelerations of the links, relative to their range
    speed_rel: float | None = None  # kinematic run: max |omega - omega0| / |omega0|

    def checks(self) -> tuple[Check, ...]:
        """Every quantity of the run, thresholded or informational.

        The kinematic run is held to the point, loop, velocity, acceleration and thread
        thresholds and to its imposed speed; the dynamic run to omega. The dynamic run's
        point errors are informational: its points follow a crank whose motion is itself
        integrated, and within the run they reach several times the kinematic thresholds
        (README, Known limits). Link angular rates are informational in both. Every run
        needs at least MIN_SAMPLES samples to be judged at all.
        """
        kin = self.kind == RunKind.KINEMATICS
        run = str(self.kind)

        def held(limit: float) -> float | None:
            return limit if kin else None

        out = [
            Check(run, "samples", float(self.samples), "", float(MIN_SAMPLES), at_least=True),
            Check(run, "point position", self.position_um, "um", held(POSITION_UM)),
            Check(run, "loop gap", self.loop_um, "um", held(LOOP_UM)),
            Check(run, "point velocity", self.velocity_rel, "of range", held(VELOCITY_REL)),
            Check(run, "point acceleration", self.acceleration_rel, "of range", held(ACCELERATION_REL)),
        ]
        if self.thread_um is not None:
            out.append(Check(run, "thread length", self.thread_um, "um", held(THREAD_UM)))
        if self.speed_rel is not None:
            out.append(Check(run, "crank speed held", self.speed_rel, "relative", SPEED_REL))
        if self.omega_rel is not None:
            out.append(Check(run, "crank speed omega", self.omega_rel, "of max", OMEGA_REL))
        out += [
            Check(run, "link angular velocity", self.link_omega_rel, "of range", None),
            Check(run, "link angular acceleration", self.link_eps_rel, "of range", None),
        ]
        return tuple(out)

    def failures(self) -> list[str]:
        """Threshold violations as readable lines (empty if all hold)."""
        out = []
        for c in self.checks():
            if c.passed is False:
                if c.at_least:
                    out.append(
                        f"{self.kind}: only {self.samples} samples: at least {MIN_SAMPLES} are needed to judge a run"
                    )
                else:
                    out.append(f"{self.kind}: {c.quantity} error {c.value:.3g} {shown(c.unit)} exceeds {c.limit:g}")
        return out

    def as_dict(self) -> dict:
        d = asdict(self)
        d["points"] = {p.name: {k: v for k, v in asdict(p).items() if k != "name"} for p in self.points}
        d["checks"] = [c.as_dict() for c in self.checks()]
        return d


def _rel(err: np.ndarray, ref: np.ndarray) -> float:
    scale = float(norms(ref).max())
    return float(norms(err).max() / scale) if scale > 0 else 0.0


def reference_at(mech: Mechanism, mj: Trace, kin: reference.Kinematics | None = None) -> Trace:
    """The reference at MuJoCo's own crank angle, speed and acceleration at each of ``mj``'s
    samples: what :func:`agreement` compares with, and what a residual panel subtracts.
    ``kin``: the reference solved at ``mj.phi`` if the caller has it (not solved again), as
    :func:`unchecked_at` gives it; where it does not close, the reference is solved again with
    the assembly check, which names the block."""
    kin = _closing(kin)
    return reference_trace(mech, reference.Motion(mj.time, mj.phi, mj.omega, mj.eps), mj.kind, kin=kin)


@dataclass(frozen=True)
class PointLimits:
    """The kinematic thresholds of one point in absolute units, as :func:`agreement` applies
    them: ``position`` m, ``velocity`` m/s (VELOCITY_REL of the largest reference speed),
    ``acceleration`` m/s^2 (ACCELERATION_REL of the largest reference acceleration)."""

    position: float
    velocity: float
    acceleration: float


def point_limits(ref: Trace, point: str) -> PointLimits:
    """The thresholds of ``point`` (see :class:`PointLimits`) for the reference trace ``ref``."""
    return PointLimits(
        POSITION_UM * 1e-6,
        VELOCITY_REL * float(norms(ref.velocities[point]).max()),
        ACCELERATION_REL * float(norms(ref.accelerations[point]).max()),
    )


def omega_limit(ref_omega: np.ndarray) -> float:
    """The dynamic run's crank-speed threshold, rad/s: OMEGA_REL of the largest reference speed."""
    return OMEGA_REL * float(np.abs(ref_omega).max())


def torque_limit(ref_torque: np.ndarray) -> float:
    """The driving torque's threshold, N*m: TORQUE_REL of the reference torque's range."""
    return TORQUE_REL * float(np.ptp(ref_torque))


def force_limit(ref_force: np.ndarray) -> float:
    """A pair reaction's threshold, N: FORCE_REL of the pair's largest reference force."""
    return FORCE_REL * float(norms(ref_force).max())


def shaking_force_limit(ref_force: np.ndarray) -> float:
    """The frame shaking force's threshold, N: SHAKING_REL of the reference force's range (the
    larger of its components' max - min), as :func:`loads` applies it."""
    return SHAKING_REL * float(np.ptp(ref_force, axis=0).max())


def agreement(
    mech: Mechanism, mj: Trace, ref_motion: reference.Motion | None = None, *, ref: Trace | None = None
) -> Agreement:
    """Compare a MuJoCo trace with the reference (see module docstring).

    ``ref_motion``: for a dynamic run, the reference's own crank motion at the same times.
    ``ref``: :func:`reference_at` of ``mj`` if the caller has it already (not computed again).
    """
    ref = ref if ref is not None else reference_at(mech, mj)
    pts = []
    for n in mech.point_names:
        if n in mech.ground:
            continue
        pos = float(norms(mj.points[n] - ref.points[n]).max())
        pts.append(
            PointError(
                n,
                pos * 1e6,
                _rel(mj.velocities[n] - ref.velocities[n], ref.velocities[n]),
                _rel(mj.accelerations[n] - ref.accelerations[n], ref.accelerations[n]),
            )
        )
    thread = None
    if mj.thread_length is not None and ref.thread_length is not None:
        thread = float(np.abs(mj.thread_length - ref.thread_length).max()) * 1e6
    w_abs = w_rel = None
    if ref_motion is not None:
        d = np.abs(mj.omega - ref_motion.omega)
        w_abs = float(d.max())
        w_rel = w_abs / float(np.abs(ref_motion.omega).max())
    loop = float(mj.loop_gap.max(initial=0.0)) * 1e6 if mj.loop_gap is not None else 0.0
    # Links share one scale, the largest any link reaches: a uniformly turning crank has no
    # angular acceleration of its own to be relative to.
    lw = le = 0.0
    if mj.link_omega:
        links = list(mj.link_omega)
        sw = max(np.abs(ref.link_omega[l]).max() for l in links)
        se = max(np.abs(ref.link_eps[l]).max() for l in links)
        lw = max(np.abs(mj.link_omega[l] - ref.link_omega[l]).max() for l in links) / sw if sw > 0 else 0.0
        le = max(np.abs(mj.link_eps[l] - ref.link_eps[l]).max() for l in links) / se if se > 0 else 0.0
    return Agreement(
        kind=mj.kind,
        samples=len(mj.time),
        points=tuple(pts),
        position_um=max(p.position_um for p in pts),
        velocity_rel=max(p.velocity_rel for p in pts),
        acceleration_rel=max(p.acceleration_rel for p in pts),
        loop_um=loop,
        thread_um=thread,
        omega_abs=w_abs,
        omega_rel=w_rel,
        link_omega_rel=lw,
        link_eps_rel=le,
        speed_rel=float(np.abs(mj.omega - mj.omega[0]).max() / abs(mj.omega[0]))
        if mj.kind == RunKind.KINEMATICS and mj.omega[0] != 0
        else None,
    )


def table(agreements: list[Agreement]) -> str:
    """Every check of every run, one per line: measured value, threshold and result (pass,
    FAIL, or informational for a quantity held to no threshold)."""

    def num(v: float | None, unit: str) -> str:
        if v is None:
            return "-"
        if unit == "um":
            return f"{v:.4f}"
        return f"{v:.0f}" if unit == "" else f"{v:.2e}"

    rows = [f"{'run':<11} {'quantity':<26} {'measured':>10} {'unit':<9} {'threshold':>10}  result"]
    for a in agreements:
        for c in a.checks():
            limit = "-" if c.limit is None else (f">= {c.limit:g}" if c.at_least else f"{c.limit:g}")
            rows.append(
                f"{c.run:<11} {c.quantity:<26} {num(c.value, c.unit):>10} {shown(c.unit):<9} {limit:>10}  {c.result}"
            )
    rows.append(
        "thresholds hold the kinematic run's points, loops, thread and imposed speed and the dynamic run's "
        "crank speed; the rest is informational"
    )
    return "\n".join(rows)


@dataclass(frozen=True)
class Loads:
    """Driving torque and pair reactions of a constant-speed MuJoCo run against kinetostatics.

    ``speed`` the run's crank speed, rad/s (its first sample: the imposed speed);
    ``torque_rel``: max |tau_mj - tau_ref| / (max - min of tau_ref); ``pairs[label]``: the
    largest reference force (N), the largest MuJoCo force (N) and max |F_mj - F_ref| / the
    largest reference force; prismatic moments likewise (N*m, error relative to the largest
    moment, or absolute N*m when the reference moment is zero). The torque's cycle statistics
    are :func:`mjlink.analysis.torque_cycle`'s, over exactly one period.
    """

    speed: float
    torque_rel: float
    pairs: dict
    force_rel: float
    shaking_force_rel: float = 0.0
    shaking_moment_rel: float | None = 0.0  # None: not compared (a geared mechanism)

    def failures(self) -> list[str]:
        out = []
        if not self.shaking_force_rel <= SHAKING_REL:
            out.append(f"loads: shaking force error {self.shaking_force_rel:.3g} of its range exceeds {SHAKING_REL:g}")
        if self.shaking_moment_rel is not None and not self.shaking_moment_rel <= SHAKING_REL:
            out.append(
                f"loads: shaking moment error {self.shaking_moment_rel:.3g} of its range exceeds {SHAKING_REL:g}"
            )
        if not self.torque_rel <= TORQUE_REL:
            out.append(f"loads: driving torque error {self.torque_rel:.3g} of its range exceeds {TORQUE_REL:g}")
        for lab, p in self.pairs.items():
            if not p["error_rel"] <= FORCE_REL:
                out.append(
                    f"loads: reaction {lab} error {p['error_rel']:.3g} of its largest force exceeds {FORCE_REL:g}"
                )
        return out


def loads(
    mech: Mechanism,
    mj: Trace,
    *,
    rx: reference.Reactions | None = None,
    frames: tuple[FrameLoads, FrameLoads] | None = None,
) -> Loads:
    """Compare a kinematic run's recorded torque and reactions with the reference kinetostatics
    evaluated at MuJoCo's own crank state. ``rx``: those reactions, and ``frames``: the
    reference's and MuJoCo's frame loads (:func:`frame_reference`, :func:`frame_mujoco`), if
    the caller has them (not computed again)."""
    if mj.torque is None:
        raise ValueError("the trace has no recorded loads (run a kinematic case)")
    rx = rx if rx is not None else reference.reactions(mech, mj.phi, mj.omega, mj.eps)
    tau = rx.torque
    pairs = {}
    for lab, f_ref in rx.forces.items():
        f_mj = mj.reactions[lab]
        peak = float(norms(f_ref).max())
        entry = {
            "max_force_N": peak,
            "max_force_mujoco_N": float(norms(f_mj).max()),
            "error_rel": float(norms(f_mj - f_ref).max() / peak) if peak > 0 else 0.0,
        }
        if lab in rx.moments:
            m_ref, m_mj = rx.moments[lab], mj.moments[lab]
            mpk = float(np.abs(m_ref).max())
            entry["max_moment_N_m"] = mpk
            entry["moment_error"] = (
                float(np.abs(m_mj - m_ref).max() / mpk) if mpk > 1e-12 else float(np.abs(m_mj).max())
            )
        pairs[lab] = entry
    ref, got = frames if frames is not None else (frame_reference(mech, mj), frame_mujoco(mech, mj))
    f_range = float(np.ptp(ref.force, axis=0).max())
    m_range = float(np.ptp(ref.moment))
    return Loads(
        float(mj.omega[0]),
        float(np.abs(mj.torque - tau).max() / np.ptp(tau)) if np.ptp(tau) > 0 else 0.0,
        pairs,
        max((p["error_rel"] for p in pairs.values()), default=0.0),
        float(norms(got.force - ref.force).max() / f_range) if f_range > 0 else 0.0,
        None
        if mech.geared and not mj.gear_torques
        else float(np.abs(got.moment - ref.moment).max() / m_range)
        if m_range > 0
        else 0.0,
    )


def frame_reference(mech: Mechanism, mj: Trace, kin: reference.Kinematics | None = None) -> FrameLoads:
    """The reference's shaking force and moment at MuJoCo's own crank states (the links' sum,
    :func:`mjlink.reference.batch.frame_loads`); ``kin`` as for :func:`reference_at`."""
    kin = _closing(kin) or reference.solve(mech, mj.phi)
    return frame_loads(mech, kin, mj.omega, mj.eps)


def frame_mujoco(mech: Mechanism, mj: Trace) -> FrameLoads:
    """MuJoCo's shaking force (N, (n, 2)) and moment (N*m about the input crank's pivot) from
    a run's recorded pair forces: minus the ground pairs' forces on their links (with their
    moments, for a slide), minus the drive's torque, plus the crank bearing's friction, minus
    what the gear couplings put on the frame (from the torque each geared shaft's joint takes
    through its coupling, the trace's ``gear_torques``, and the input crank's share by the ratio).
    A trace without them (a geared mechanism's run that recorded no loads) has its moment left
    uncompared (:class:`Loads`)."""
    assert mj.torque is not None
    P = mj.points
    pivot = P[mech.input_crank.pivot][:, :2]
    force = np.zeros((len(mj.phi), 2))
    moment = -mj.torque + mech.dynamics.damping * mj.omega
    for _, pr in pairs(mech):
        if pr.parent is not None:
            continue
        f = -mj.reactions[pr.label][:, :2]
        force += f
        if pr.revolute:
            d = P[pr.pin][:, :2] - pivot
        else:
            d = P[mech.link(pr.child).points[0]][:, :2] - pivot
            moment = moment - mj.moments[pr.label]
        if pr.label in mj.gear_torques:
            # The coupling puts tau on the geared shaft and -ratio tau on the input crank (its
            # constraint q_g = phase + ratio q_in): the frame carries minus their sum.
            ratio = next(c.ratio for c in mech.geared if mech.carrier(c).name == pr.child)
            moment = moment - (1.0 - ratio) * mj.gear_torques[pr.label]
        moment = moment + d[:, 0] * f[:, 1] - d[:, 1] * f[:, 0]
    return FrameLoads(force, moment)


# ------------------------------------------------------------------------ branch-switch watchdog
def _closing(kin: reference.Kinematics | None) -> reference.Kinematics | None:
    """``kin`` if it closes at every angle, else None (to be solved with the check)."""
    return kin if kin is not None and kin.assembles().all() else None


def unchecked_at(mech: Mechanism, phi: np.ndarray) -> reference.Kinematics:
    """The reference at the input angles ``phi`` (rad, a run's own), every point, without the
    assembly check: where it cannot close, its values are meaningless, and the watchdog finds
    MuJoCo away from them. The same values as the checked solve where it closes."""
    return reference.solve(mech, phi, check=False)  # floating-point warnings silenced there


def branch_switch(
    mech: Mechanism, trace, tol_m: float = BRANCH_TOL_M, kin: reference.Kinematics | None = None
) -> str | None:
    """Where a MuJoCo ``trace`` left the reference's assembly branch, as one line; None if it did not.

    The reference is evaluated at MuJoCo's own input angles ``trace.phi``; a moving point more
    than ``tol_m`` (m) away from it, or non-finite, has left it. The first such point in
    construction order at the first such sample is named, with the time and input angle;
    for a dyad or slider the message says whether MuJoCo follows the other branch (the mirror
    solution, the opposite ``sign`` or ``toward``). ``kin``: the reference solved at
    ``trace.phi`` (unchecked, as here) if the caller has it.
    """
    if kin is None:
        kin = unchecked_at(mech, trace.phi)
    first, who = None, None
    for n in mech.moving_points:
        mj, ref = np.asarray(trace.points[n]), kin.position(n)
        dev = norms(mj - ref)
        bad = ~(dev <= tol_m)
        if bad.any():
            i = int(np.argmax(bad))
            if first is None or i < first:
                first, who = i, n
    if first is None:
        return None
    i, n = first, who
    assert n is not None
    t, phi = float(trace.time[i]), math.degrees(float(trace.phi[i]))
    mj = np.asarray(trace.points[n])
    dev = norms(mj - kin.position(n))
    step = next(s for s in mech.steps if s.point == n)
    where = f"at t = {t:.6g} s, input angle {phi:.2f} deg"
    src = mech.path or mech.name
    if not np.isfinite(mj[i]).all():
        return f"{src}: MuJoCo's point {n} became non-finite {where}"
    after = np.arange(i, len(dev))
    j = int(after[np.argmax(np.where(np.isfinite(dev[after]), dev[after], -1.0))])
    other = step.mirror(kin.positions(), j)
    if other is not None and np.linalg.norm(mj[j] - other) < dev[j]:
        return (
            f"{src}: MuJoCo left the reference's assembly branch at {n} ({step.named()}) {where}: it follows the "
            f"other branch ({step.flipped()}), up to {dev[j] * 1e3:.3g} mm away; the run is not the file's mechanism"
        )
    return (
        f"{src}: MuJoCo left the reference's solution at {n} {where}: {dev[i] * 1e3:.3g} mm away, up to "
        f"{dev[j] * 1e3:.3g} mm later (tolerance {tol_m * 1e3:g} mm)"
    )
