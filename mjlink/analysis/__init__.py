"""Derived quantities: what the figures show, computed from mechanisms and traces.

The plots (:mod:`mjlink.plotting`) only draw; every physical quantity they show beyond a
trace's own samples is computed here: the thread length and the needle-thread feed, a
slider's motion along its (possibly moving) guide and its pressure angle, the harmonic
content of a signal over the mechanism period, drive power, and the choice of what is worth
plotting (the key point, the links whose rotation matters, the geared crank of a phase study).

Inputs are :class:`mjlink.runs.Trace` objects and :class:`mjlink.model.mechanism.Mechanism`
objects in SI units; every result is SI as well (m, m/s, m/s^2, rad, rad/s, N, N*m, W), as
each docstring says. N below is the number of samples of a trace. No matplotlib, no mujoco.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from itertools import pairwise

import numpy as np

from .. import reference
from ..model import blocks
from ..model.blocks import Crank, Slider
from ..model.jet import norms
from ..model.mechanism import Mechanism
from ..model.names import GROUND
from ..model.topology import pairs
from ..runs import Trace


def _dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise dot product of two (N, k) arrays: (N,)."""
    out: np.ndarray = np.einsum("ij,ij->i", a, b)
    return out


def magnitude(vectors: np.ndarray) -> np.ndarray:
    """Length of every row of ``vectors`` (N, 3), in the vectors' unit (a point's speed |v| in
    m/s from its velocities, a pair's force |F| in N from its forces): (N,)."""
    return norms(vectors)


def angle_turned(phi: np.ndarray) -> np.ndarray:
    """Angle (rad, >= 0) the input crank has turned since the first sample of ``phi`` (N,) rad,
    whichever way it turns: (N,)."""
    phi = np.asarray(phi)
    out: np.ndarray = np.abs(phi - phi[0])
    return out


# ----------------------------------------------------------------------------- thread
def thread_length(mech: Mechanism, trace: Trace) -> np.ndarray:
    """Length (m) of the thread ``mech.thread`` in every sample of ``trace``: (N,).

    The run's own record if it has one, else the sum of the straight spans between the
    thread's points (zero without a thread)."""
    if trace.thread_length is not None:
        return np.asarray(trace.thread_length)
    total = np.zeros(len(trace.time))
    for a, b in pairwise(mech.thread or ()):
        total = total + norms(trace.points[b] - trace.points[a])
    return total


def thread_feed(mech: Mechanism, trace: Trace) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The needle-thread feed over the first turn of the input crank (seed 003).

    Takes the samples of ``trace`` up to and including the first at or past a full turn from
    its first sample (K of them). Returns the thread length lF (m), its increment
    dlF = lF(phi) - lF(phi0) (m) and the feed Pd = dlF - dP (m), dP the file's thread
    elongation (0 if it has none); each (K,).
    """
    turned = angle_turned(trace.phi)
    k = min(int(np.searchsorted(turned, 2.0 * math.pi * (1.0 - 1e-9))) + 1, len(turned))
    length = thread_length(mech, trace)[:k]
    increment = length - length[0]
    return length, increment, increment - (mech.thread_elongation or 0.0)


# ----------------------------------------------------------------------------- sliders (seed 002)
def slider_motion(trace: Trace, slider: Slider) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The slider point's motion along its guide, relative to the guide (which may move).

    ``s = (P - n1) . u`` with ``u = (n2 - n1) / L`` and L = |n2 - n1| constant (the guide's
    points are on one rigid link), so ``u' = (v_n2 - v_n1) / L`` and ``u'' = (a_n2 - a_n1) / L``
    exactly, and ``s' = (v_P - v_n1) . u + (P - n1) . u'``,
    ``s'' = (a_P - a_n1) . u + 2 (v_P - v_n1) . u' + (P - n1) . u''``. Planar components, as
    the slider block.

    Args:
        trace: positions (m), velocities (m/s) and accelerations (m/s^2) of the slider's
            point and of both guide points, each (N, 3).
        slider: the slider block.

    Returns:
        s (m), ds/dt (m/s), d2s/dt2 (m/s^2), each (N,).
    """
    n1, n2 = slider.guide
    P, V, A = trace.points, trace.velocities, trace.accelerations
    g = P[n2][:, :2] - P[n1][:, :2]
    L = norms(g)[:, None]
    u = g / L
    ud = (V[n2][:, :2] - V[n1][:, :2]) / L
    udd = (A[n2][:, :2] - A[n1][:, :2]) / L
    r = P[slider.point][:, :2] - P[n1][:, :2]
    rd = V[slider.point][:, :2] - V[n1][:, :2]
    rdd = A[slider.point][:, :2] - A[n1][:, :2]
    return _dot(r, u), _dot(rd, u) + _dot(r, ud), _dot(rdd, u) + 2.0 * _dot(rd, ud) + _dot(r, udd)


def pressure_angle(trace: Trace, slider: Slider) -> np.ndarray:
    """The pressure angle of the prismatic pair: the angle between the rod start->point that
    pushes the slider and its guide (0: the rod pushes along the guide).

    Args:
        trace: positions (m) of the slider's start, point and guide points, each (N, 3).
        slider: the slider block.

    Returns:
        The angle (rad, in [0, pi/2]), (N,).
    """
    n1, n2 = slider.guide
    g = trace.points[n2][:, :2] - trace.points[n1][:, :2]
    d = trace.points[slider.point][:, :2] - trace.points[slider.start][:, :2]
    c = np.abs(_dot(d, g)) / (norms(d) * norms(g))
    out: np.ndarray = np.arccos(np.clip(c, 0.0, 1.0))
    return out


def guide_moves(mech: Mechanism, slider: Slider) -> bool:
    """Whether the slider's guide moves (a guide point is not a ground point)."""
    n1, n2 = slider.guide
    return not (n1 in mech.ground and n2 in mech.ground)


def sliding_with(mech: Mechanism, slider: Slider) -> list[str]:
    """The other points of the sliding link (not mere centres of mass, see :func:`mass_centres`):
    each moves along the guide by the same s as the slider's point, plus a constant."""
    body = next((l for l in mech.links if slider.point in l.points and l.guide == slider.guide), None)
    coms = mass_centres(mech)
    return [q for q in (body.points if body else ()) if q != slider.point and q not in coms]


# ----------------------------------------------------------------------------- harmonics
def harmonics(mech: Mechanism, trace: Trace, y: np.ndarray, kmax: int = 12) -> np.ndarray | None:
    """Amplitudes of the harmonics k = 1..kmax of the mechanism period in a sampled signal.

    The samples are resampled uniformly in the input angle (linear interpolation of the
    trace, whose steps are ~0.3 deg), so a crank speed that is not quite constant does not
    smear the lines.

    Args:
        mech: the mechanism; only its ``period`` is read, the input angle (rad) after which
            it repeats.
        trace: the run; only its ``phi`` is read, the input angles (rad) of the samples, (N,).
        y: the signal, (N,), in any unit.
        kmax: the highest harmonic.

    Returns:
        The amplitudes A_1..A_kmax (the unit of ``y``), (kmax,), over one period from the first
        sample; None if the trace covers less than one period or does not turn steadily.
    """
    turned = angle_turned(trace.phi)
    if turned[-1] < mech.period * (1.0 - 1e-9) or not np.all(np.diff(turned) > 0):
        return None
    m = 2048 * max(1, round(mech.period / (2.0 * math.pi)))
    grid = mech.period * np.arange(m) / m
    c = np.fft.rfft(np.interp(grid, turned, y)) / m
    return 2.0 * np.abs(c[1 : kmax + 1])


def higher_harmonics_share(amp: np.ndarray) -> float:
    """The higher harmonics (k >= 2) against the first, sqrt(sum A_k^2) / A_1, as a fraction
    (dimensionless); ``amp`` (kmax,) the amplitudes A_1..A_kmax of :func:`harmonics`."""
    return float(np.sqrt(np.sum(amp[1:] ** 2)) / amp[0])


# ----------------------------------------------------------------------------- loads
def drive_power(torque: np.ndarray, omega: np.ndarray) -> np.ndarray:
    """Power (W) the drive puts in: torque (N*m) times crank speed (rad/s), each (N,): (N,)."""
    power: np.ndarray = torque * omega
    return power


def period_angle(mech: Mechanism, phi: np.ndarray) -> np.ndarray:
    """Input angles ``phi`` (rad) as the angle turned from phi0 within the period, rad in
    [0, period): the abscissa on which a periodic orbit and a run's last period line up
    whatever crank angle the run's last period starts at."""
    sense = 1.0 if mech.speed >= 0 else -1.0
    out: np.ndarray = np.mod(sense * (np.asarray(phi, dtype=float) - mech.phi0), mech.period)
    return out


def last_period_at(
    mech: Mechanism, trace: Trace, duration: float, ref_phi: np.ndarray, ref_omega: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """MuJoCo's last ``duration`` s of ``trace`` against a reference orbit (``ref_phi`` rad,
    ``ref_omega`` rad/s over one period) on the same abscissa: the angle turned from phi0
    within the period (rad, sorted), MuJoCo's speed there and the reference's interpolated
    there (rad/s, periodic), each (M,)."""
    last = trace.time >= trace.time[-1] - abs(duration)
    a = period_angle(mech, trace.phi[last])
    order = np.argsort(a)
    ar = period_angle(mech, ref_phi)
    k = np.argsort(ar)
    ref = np.interp(a[order], ar[k], np.asarray(ref_omega)[k], period=mech.period)
    return a[order], trace.omega[last][order], ref


# ----------------------------------------------------------------------------- geometry
def is_spatial(mech: Mechanism) -> bool:
    """Whether some point of the mechanism lies off the plane z = 0 at phi0."""
    kin = reference.solve(mech, [mech.phi0])
    return any(abs(float(kin.position(p)[0, 2])) > 1e-12 for p in mech.point_names)


def geared_crank(mech: Mechanism) -> Crank | None:
    """The first crank geared to the input crank, None if there is none."""
    return mech.geared[0] if mech.geared else None


def cranks_moving(mech: Mechanism) -> dict[str, set[str]]:
    """Each point -> the cranks (by their points) that move it: a crank's point moves with its
    crank, a built point with every crank its inputs move with; a ground point with none."""
    out: dict[str, set[str]] = {g: set() for g in mech.ground}
    for s in mech.steps:  # in build order: a block's inputs come first
        out[s.point] = set().union(*(out.get(p, set()) for p in s.inputs)) | (
            {s.point} if isinstance(s, Crank) else set()
        )
    return out


def phase_point(mech: Mechanism) -> tuple[Crank, str] | None:
    """A geared crank and a point whose path its setting changes: a point moved by both the
    input crank and that crank (a point moved by one of them alone only moves at other times
    when the setting changes, along the same path). The key point if it is one, else the first
    such point in the file's order that is not merely a centre of mass; None where there is none
    (a head whose needle and feed are driven apart)."""
    moved = cranks_moving(mech)
    coms = mass_centres(mech)
    key = key_point(mech)
    for g in mech.geared:
        both = [p for p in mech.moving_points if {mech.input_crank.point, g.point} <= moved.get(p, set())]
        if key in both:
            return g, key
        rest = [p for p in both if p not in coms]
        if rest:
            return g, rest[0]
    return None


def geared_path(mech: Mechanism, crank: Crank, phase: float, point: str, phi: np.ndarray) -> np.ndarray:
    """Positions (m), (N, 3), of ``point`` at the input angles ``phi`` (N,) rad when the geared
    ``crank`` is set to ``phase`` (rad, its angle at phi0) instead of its file's phase.

    Raises AssemblyError if the mechanism cannot assemble so."""
    steps = tuple(dataclasses.replace(s, phase=phase) if s is crank else s for s in mech.steps)
    return reference.solve(dataclasses.replace(mech, steps=steps), phi).position(point)


# ----------------------------------------------------------------------------- what to plot
def mass_centres(mech: Mechanism) -> set[str]:
    """Points that are a link's centre of mass and nothing else: no block builds from them and
    no other link carries them (the needle-bar joint C of the crank-slider is its centre of
    mass too, but the rod's centre is built from it, so it stays a point of the mechanism)."""
    used = {p for s in mech.steps for p in s.inputs}
    return {
        l.com
        for l in mech.links
        if l.com is not None and l.com not in used and sum(l.com in k.points for k in mech.links) == 1
    }


def key_point(mech: Mechanism) -> str:
    """The point worth a kinematics plot: the first moving thread point, else the last
    constructed point that is not merely a centre of mass (see :func:`mass_centres`; a
    slider joint that is also its link's centre of mass counts), else the last constructed."""
    for p in mech.thread or ():
        if p not in mech.ground:
            return p
    coms = mass_centres(mech)
    return next((s.point for s in reversed(mech.steps) if s.point not in coms), mech.steps[-1].point)


def motion_links(mech: Mechanism) -> list[str]:
    """Links worth a rotation plot: every moving link carrying a slider's guide (both its
    points); else the link carrying the key point that is neither a crank nor a slider
    translating on a fixed guide; else none."""
    out = []
    for s in blocks.sliders(mech.steps):
        if not guide_moves(mech, s):
            continue
        n1, n2 = s.guide
        l = next((l for l in mech.links if n1 in l.points and n2 in l.points), None)
        if l is not None and l.name not in out:
            out.append(l.name)
    if out:
        return out
    cranks = [(c.pivot, c.point) for c in (mech.input_crank, *mech.geared)]
    p = key_point(mech)
    for l in mech.links:
        if p not in l.points or any(a in l.points and b in l.points for a, b in cranks):
            continue
        if l.guide and all(g in mech.ground for g in l.guide):
            continue  # translates: no rotation to show
        return [l.name]
    return []


# ----------------------------------------------------------------------------- cycle statistics
CYCLE_SAMPLES = 3600  # input-angle samples per crank turn for per-cycle statistics


def one_period(mech: Mechanism, per_turn: int = CYCLE_SAMPLES) -> np.ndarray:
    """Input angles (rad) covering exactly one period from phi0, uniformly, the end excluded:
    (per_turn x turns,). The mean of a periodic quantity over these is its cycle mean (exact
    for the trigonometric polynomials the reference's smooth quantities are, to rounding);
    counting the period's end as well would weigh one angle twice."""
    turns = max(1, round(mech.period / (2.0 * math.pi)))
    n = per_turn * turns
    return mech.phi0 + mech.period * np.arange(n) / n


@dataclass(frozen=True)
class TorqueCycle:
    """The driving torque over exactly one period at constant crank speed ``omega`` (rad/s).

    ``peak`` max |tau| N*m; ``rms`` sqrt(mean tau^2) N*m; ``mean`` mean tau N*m; ``power``
    mean power tau * omega, W (at constant speed only damping and the file's non-conservative
    loads contribute: inertia and gravity give back over a cycle what they take); ``energy``
    the swing of the energy fluctuation, max - min of the integral of (tau - mean) dphi, J.
    """

    omega: float
    peak: float
    rms: float
    mean: float
    power: float
    energy: float


def torque_cycle(mech: Mechanism, omega: float, per_turn: int = CYCLE_SAMPLES) -> TorqueCycle:
    """Statistics of the reference driving torque over exactly one period (see :class:`TorqueCycle`)."""
    phi = one_period(mech, per_turn)
    tau = reference.driving_torque(mech, phi, omega)
    mean = float(tau.mean())
    work = energy_fluctuation(phi, tau)
    return TorqueCycle(
        float(omega),
        float(np.abs(tau).max()),
        float(np.sqrt(np.mean(tau**2))),
        mean,
        mean * float(omega),
        float(np.ptp(work)),
    )


def energy_fluctuation(phi: np.ndarray, torque: np.ndarray) -> np.ndarray:
    """The energy the crank's shaft stores and gives back over a cycle at constant speed:
    E(phi) = integral of (T - T_mean) dphi from the first angle, J, at the angles ``phi``
    (rad, uniform, one period with its end excluded, as :func:`one_period` gives) for the
    driving torque ``torque`` (N*m); shape (N + 1,), the last value the period's end (0 to
    rounding). Its swing max - min is what a flywheel has to absorb."""
    phi = np.asarray(phi, dtype=float)
    tau = np.asarray(torque, dtype=float)
    step = float(phi[1] - phi[0])
    # Trapezoids on the periodic samples (the period's end is the first sample again).
    t = tau - tau.mean()
    return np.concatenate([[0.0], np.cumsum(0.5 * (t + np.roll(t, -1)))]) * step


def flywheel_estimate(energy_swing: float, omega: float, delta: float) -> float:
    """The classical flywheel estimate J = dE / (delta omega^2), kg*m^2: the whole rotating
    inertia, reduced to the crank, that keeps the coefficient of speed fluctuation at ``delta``
    when the shaft's energy swings by ``energy_swing`` J at mean speed ``omega`` rad/s. The
    steady-motion study (:func:`mjlink.reference.flywheel_for`) gives the exact figure under a
    motor characteristic; this is the one designers size from the torque diagram."""
    return float(energy_swing / (delta * omega * omega))


@dataclass(frozen=True)
class PairLoad:
    """One revolute pair's reaction as its bearing sees it.

    ``label`` the pair (``P3:lever-rocker``); ``frame`` the link whose frame the force is
    resolved in: the parent, which carries the bearing, or ``ground`` (fixed axes) for a frame
    pivot; ``force`` (N, 2) N, the force on the child, in that frame (x along the link's first
    two points, y normal to it, counter-clockwise); ``magnitude`` (N,) N."""

    label: str
    frame: str
    force: np.ndarray
    magnitude: np.ndarray


def pair_loads(mech: Mechanism, rx: reference.Reactions) -> list[PairLoad]:
    """Every revolute pair's reaction in the frame of the link that carries its bearing (see
    :class:`PairLoad`): the polar load diagram of a bearing. Prismatic pairs are left out (their
    load is a normal force and a moment along the guide, not a vector turning in a bearing)."""

    kin = reference.solve(mech, rx.phi)
    out = []
    for _, pr in pairs(mech):
        if not pr.revolute or pr.label not in rx.forces:
            continue
        f = np.asarray(rx.forces[pr.label])[:, :2]
        if pr.parent is None:
            local = f
        else:
            a = kin.angles[pr.parent].v
            c, s = np.cos(a), np.sin(a)
            local = np.column_stack([c * f[:, 0] + s * f[:, 1], -s * f[:, 0] + c * f[:, 1]])
        out.append(PairLoad(pr.label, pr.parent or GROUND, local, np.hypot(local[:, 0], local[:, 1])))
    return out


def energy_cycle(mech: Mechanism, omega: float, per_turn: int = 720) -> tuple[np.ndarray, np.ndarray]:
    """The reference's energy fluctuation over one period at constant crank speed ``omega``
    (rad/s), integrated the way the crank turns (from phi0 down for a clockwise crank): input
    angles (rad, (N + 1,), the period's end included) and :func:`energy_fluctuation` at them (J)."""
    sense = 1.0 if omega >= 0 else -1.0
    phi = mech.phi0 + sense * (one_period(mech, per_turn) - mech.phi0)
    e = energy_fluctuation(phi, reference.driving_torque(mech, phi, omega))
    return np.append(phi, phi[0] + sense * mech.period), e


def link_segments(mech: Mechanism) -> list[tuple[str, str, str]]:
    """Point pairs to draw, each with the link it belongs to, ``(link, a, b)``: one polyline per
    link, following how each point was built.

    Joining a point to the link point it was constructed from shows the link's real shape
    (e.g. a lever's arm from its joint, not a chord from its first point); points built
    from nothing on their own link hang off the link's first point.
    """
    built = {s.point: s for s in mech.steps}
    out: list[tuple[str, str, str]] = []
    for link in mech.links:
        pts = [p for p in link.points if p != link.com]
        if link.guide:
            # A slider body: its points in listed order; there is no pivot to radiate from.
            out += [(link.name, a, b) for a, b in pairwise(pts)]
            continue
        for p in pts[1:]:
            cand = built[p].drawn_from if p in built else ()
            parent = next((c for c in cand if c in pts and c != p), pts[0])
            out.append((link.name, parent, p))
    return out


def segments(mech: Mechanism) -> list[tuple[str, str]]:
    """The point pairs of :func:`link_segments`, without their links."""
    return [(a, b) for _, a, b in link_segments(mech)]
