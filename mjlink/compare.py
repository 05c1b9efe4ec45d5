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
from .model.mechanism import Mechanism
from .reference import reference_trace
from .runs import Trace
from .units import RunKind

# The issue's acceptance thresholds (tests assert them; never loosen to pass).
POSITION_UM = 0.1
VELOCITY_REL = 2e-5
ACCELERATION_REL = 2e-3
LOOP_UM = 0.1
THREAD_UM = 0.1
OMEGA_REL = 5e-4
TORQUE_REL = 1e-3  # of the driving torque's range (max - min)
FORCE_REL = 1e-3  # of each pair's largest force
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

    def failures(self) -> list[str]:
        """Threshold violations as readable lines (empty if all hold)."""
        out = []
        # The issue's thresholds: point-wise ones for the kinematic run, omega for the
        # dynamic run (whose point errors are reported, not thresholded).
        checks = []
        if self.kind == RunKind.KINEMATICS:
            checks += [
                ("position", self.position_um, POSITION_UM, "um"),
                ("loop gap", self.loop_um, LOOP_UM, "um"),
                ("velocity", self.velocity_rel, VELOCITY_REL, "of range"),
                ("acceleration", self.acceleration_rel, ACCELERATION_REL, "of range"),
            ]
            if self.thread_um is not None:
                checks.append(("thread length", self.thread_um, THREAD_UM, "um"))
        if self.omega_rel is not None:
            checks.append(("omega", self.omega_rel, OMEGA_REL, "relative"))
        for what, got, limit, unit in checks:
            if not got <= limit:
                out.append(f"{self.kind}: {what} error {got:.3g} {unit} exceeds {limit:g}")
        return out

    def as_dict(self) -> dict:
        d = asdict(self)
        d["points"] = {p.name: {k: v for k, v in asdict(p).items() if k != "name"} for p in self.points}
        return d


def _rel(err: np.ndarray, ref: np.ndarray) -> float:
    scale = float(np.linalg.norm(ref, axis=1).max())
    return float(np.linalg.norm(err, axis=1).max() / scale) if scale > 0 else 0.0


def agreement(mech: Mechanism, mj: Trace, ref_motion: reference.Motion | None = None) -> Agreement:
    """Compare a MuJoCo trace with the reference (see module docstring).

    ``ref_motion``: for a dynamic run, the reference's own crank motion at the same times.
    """
    ref = reference_trace(mech, reference.Motion(mj.time, mj.phi, mj.omega, mj.eps), mj.kind)
    pts = []
    for n in mech.point_names:
        if n in mech.ground:
            continue
        pos = float(np.linalg.norm(mj.points[n] - ref.points[n], axis=1).max())
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
        mj.kind,
        len(mj.time),
        tuple(pts),
        max(p.position_um for p in pts),
        max(p.velocity_rel for p in pts),
        max(p.acceleration_rel for p in pts),
        loop,
        thread,
        w_abs,
        w_rel,
        lw,
        le,
    )


def table(agreements: list[Agreement]) -> str:
    """A short fixed-width table of the worst errors per run."""
    rows = [
        f"{'run':<11} {'pos um':>9} {'vel/range':>10} {'acc/range':>10} {'loop um':>9} "
        f"{'thread um':>10} {'omega rel':>10}"
    ]
    f = lambda v, fmt: "-" if v is None else format(v, fmt)  # noqa: E731
    for a in agreements:
        rows.append(
            f"{a.kind:<11} {a.position_um:>9.4f} {a.velocity_rel:>10.2e} {a.acceleration_rel:>10.2e} "
            f"{a.loop_um:>9.4f} {f(a.thread_um, '10.4f'):>10} {f(a.omega_rel, '10.2e'):>10}"
        )
    rows.append(
        f"thresholds  {POSITION_UM:>9g} {VELOCITY_REL:>10.0e} {ACCELERATION_REL:>10.0e} "
        f"{LOOP_UM:>9g} {THREAD_UM:>10g} {OMEGA_REL:>10.0e}   (omega: dynamic run; others: kinematic run)"
    )
    return "\n".join(rows)


@dataclass(frozen=True)
class Loads:
    """Driving torque and pair reactions of a constant-speed MuJoCo run against kinetostatics.

    ``torque_rel``: max |tau_mj - tau_ref| / (max - min of tau_ref); ``pairs[label]``: the
    largest reference force (N), the largest MuJoCo force (N) and max |F_mj - F_ref| / the
    largest reference force; prismatic moments likewise (N*m, error relative to the largest
    moment, or absolute N*m when the reference moment is zero). Torque statistics from the
    reference: peak |tau| N*m, RMS N*m, mean power W.
    """

    speed: float
    torque_rel: float
    torque_peak: float
    torque_rms: float
    power_mean: float
    pairs: dict
    force_rel: float

    def failures(self) -> list[str]:
        out = []
        if not self.torque_rel <= TORQUE_REL:
            out.append(f"loads: driving torque error {self.torque_rel:.3g} of its range exceeds {TORQUE_REL:g}")
        for lab, p in self.pairs.items():
            if not p["error_rel"] <= FORCE_REL:
                out.append(
                    f"loads: reaction {lab} error {p['error_rel']:.3g} of its largest force exceeds {FORCE_REL:g}"
                )
        return out


def loads(mech: Mechanism, mj: Trace) -> Loads:
    """Compare a kinematic run's recorded torque and reactions with the reference kinetostatics
    evaluated at MuJoCo's own crank state."""
    if mj.torque is None:
        raise ValueError("the trace has no recorded loads (run a kinematic case)")
    rx = reference.reactions(mech, mj.phi, mj.omega, mj.eps)
    tau = rx.torque
    pairs = {}
    for lab, f_ref in rx.forces.items():
        f_mj = mj.reactions[lab]
        peak = float(np.linalg.norm(f_ref, axis=1).max())
        entry = {
            "max_force_N": peak,
            "max_force_mujoco_N": float(np.linalg.norm(f_mj, axis=1).max()),
            "error_rel": float(np.linalg.norm(f_mj - f_ref, axis=1).max() / peak) if peak > 0 else 0.0,
        }
        if lab in rx.moments:
            m_ref, m_mj = rx.moments[lab], mj.moments[lab]
            mpk = float(np.abs(m_ref).max())
            entry["max_moment_N_m"] = mpk
            entry["moment_error"] = (
                float(np.abs(m_mj - m_ref).max() / mpk) if mpk > 1e-12 else float(np.abs(m_mj).max())
            )
        pairs[lab] = entry
    return Loads(
        float(np.mean(mj.omega)),
        float(np.abs(mj.torque - tau).max() / np.ptp(tau)) if np.ptp(tau) > 0 else 0.0,
        float(np.abs(tau).max()),
        float(np.sqrt(np.mean(tau**2))),
        float(np.mean(tau * mj.omega)),
        pairs,
        max((p["error_rel"] for p in pairs.values()), default=0.0),
    )


# ------------------------------------------------------------------------ branch-switch watchdog
def branch_switch(mech: Mechanism, trace, tol_m: float = BRANCH_TOL_M) -> str | None:
    """Where a MuJoCo ``trace`` left the reference's assembly branch, as one line; None if it did not.

    The reference is evaluated at MuJoCo's own input angles ``trace.phi``; a moving point more
    than ``tol_m`` (m) away from it, or non-finite, has left it. The first such point in
    construction order at the first such sample is named, with the time and input angle;
    for a dyad or slider the message says whether MuJoCo follows the other branch (the mirror
    solution, the opposite ``sign`` or ``toward``).
    """
    with np.errstate(all="ignore"):
        kin = reference.solve(mech, np.asarray(trace.phi, dtype=float), check=False)
    first, who = None, None
    for n in mech.moving_points:
        mj, ref = np.asarray(trace.points[n]), kin.position(n)
        dev = np.linalg.norm(mj - ref, axis=1)
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
    dev = np.linalg.norm(mj - kin.position(n), axis=1)
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
