"""The vector-method reference: the papers' analysis, exact and vectorized over crank angle.

Kinematics compose the building blocks (crank, RRR dyad, attached point, RRP slider, geared
crank) in the file's order on jets (:mod:`mjlink.jet`), so every point comes with its exact
first and second derivatives with respect to the input angle phi. Velocities and
accelerations follow as ``v = P' omega`` and ``a = P'' omega^2 + P' eps``.

Dynamics use the reduced-inertia Lagrange equation of a one-degree-of-freedom machine::

    J(phi) phi'' + 1/2 J'(phi) phi'^2 + b phi' = Q(phi)
    J(phi) = sum_i J_Si (dtheta_i/dphi)^2 + m_i |dS_i/dphi|^2
    Q(phi) = M1 + sum_i m_i g . dS_i/dphi + sum_k F_k . dP_k/dphi

All quantities SI (m, rad, kg, s).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import jet
from .errors import AssemblyError, MechanismFileError
from .mechanism import Attached, Crank, Dyad, Link, Mechanism, Slider


# ------------------------------------------------------------------------ building blocks
def crank(pivot: jet.V, length: float, angle: jet.S) -> jet.V:
    """Block 1: ``pivot + length (cos a, sin a)``."""
    n = len(angle.v)
    ex = jet.vconst([length, 0.0, 0.0], n)
    return pivot + jet.rotate(ex, angle)


def dyad(a: jet.V, b: jet.V, length_a: float, length_b: float, sign: int) -> tuple[jet.V, np.ndarray]:
    """Block 2 (RRR): ``b + rho(a - b, sign U, length_b)``; also the cosine of U.

    Where ``|cos U| > 1`` the dyad cannot close; the caller turns that into an error.
    """
    d = (a - b).planar()
    dist = d.norm()
    cos_u = (dist * dist + (length_b**2 - length_a**2)) / (dist * (2.0 * length_b))
    u = jet.arccos(jet.S(np.clip(cos_u.v, -1.0, 1.0), cos_u.d, cos_u.dd))
    c = b + jet.rotate(d.scale(length_b / dist), u * float(sign))
    return c, cos_u.v


def attached(origin: jet.V, toward: jet.V, angle: float, length: float, z: float | None) -> jet.V:
    """Block 3: ``origin + rho(toward - origin, angle, length)``, at height z (None: origin's)."""
    d = (toward - origin).planar()
    n = len(d.v)
    q = origin + jet.rotate(d.scale(length / d.norm()), jet.const(angle, n))
    return q.with_z(z) if z is not None else q


def slider(start: jet.V, length: float, n1: jet.V, n2: jet.V, toward_n2: bool) -> tuple[jet.V, np.ndarray]:
    """Block 4 (RRP): the point at ``length`` from ``start`` on line n1-n2; also the squared half-chord.

    ``F +- sqrt(L^2 - |A - F|^2) u`` with F the foot of the perpendicular, u the unit guide
    vector; ``toward_n2`` picks the + solution.
    """
    g = (n2 - n1).planar()
    u = g.scale(1.0 / g.norm())
    foot = n1 + u.scale((start - n1).planar().dot(u))
    off = (start - foot).planar()
    h2 = (off.dot(off) * -1.0) + length**2
    h = jet.sqrt(jet.S(np.maximum(h2.v, 0.0), h2.d, h2.dd))
    p = foot + u.scale(h if toward_n2 else -h)
    return p, h2.v


def link_angle(points: dict[str, jet.V], link: Link) -> jet.S:
    """Angle of a link: of its guide line if it slides, else of its first two points."""
    a, b = link.guide if link.guide else link.points[:2]
    return jet.angle((points[b] - points[a]).planar())


# ------------------------------------------------------------------------------ kinematics
@dataclass(frozen=True)
class Kinematics:
    """Reference positions of every point over an array of input angles.

    ``phi`` (N,) rad; ``points[name]`` and ``angles[link]`` are jets: value, first and
    second derivative with respect to phi (m, m/rad, m/rad^2; rad, -, 1/rad).
    """

    mechanism: Mechanism
    phi: np.ndarray
    points: dict[str, jet.V]
    angles: dict[str, jet.S]

    def position(self, name: str) -> np.ndarray:
        """(N, 3) m."""
        return self.points[name].v

    def velocity(self, name: str, omega) -> np.ndarray:
        """(N, 3) m/s for crank speed omega (rad/s, scalar or (N,))."""
        return self.points[name].d * np.asarray(omega, dtype=float).reshape(-1, 1)

    def acceleration(self, name: str, omega, eps) -> np.ndarray:
        """(N, 3) m/s^2 for crank speed omega (rad/s) and acceleration eps (rad/s^2)."""
        w = np.asarray(omega, dtype=float).reshape(-1, 1)
        e = np.asarray(eps, dtype=float).reshape(-1, 1)
        p = self.points[name]
        return p.dd * w**2 + p.d * e

    def thread_length(self) -> jet.S | None:
        """Length of the thread polyline (m) with its derivatives, or None if there is no thread."""
        path = self.mechanism.thread
        if not path:
            return None
        total = None
        for a, b in zip(path[:-1], path[1:]):
            seg = (self.points[b] - self.points[a]).norm()
            total = seg if total is None else total + seg
        return total


def _angle_ranges(phi: np.ndarray, bad: np.ndarray) -> str:
    """Human-readable input-angle ranges (deg) where ``bad`` holds."""
    deg = np.degrees(phi)
    out, start = [], None
    for i, b in enumerate(bad):
        if b and start is None:
            start = i
        if (not b or i == len(bad) - 1) and start is not None:
            end = i if b else i - 1
            out.append(f"{deg[start]:.1f}..{deg[end]:.1f}")
            start = None
    return ", ".join(out[:6]) + (" ..." if len(out) > 6 else "")


def solve(mech: Mechanism, phi, *, check: bool = True) -> Kinematics:
    """Positions and exact derivatives of every point at the input angles ``phi`` (rad).

    Raises AssemblyError naming the block and the angle ranges where it cannot close
    (unless ``check`` is False, when such angles give clipped, meaningless values).
    """
    phi = np.atleast_1d(np.asarray(phi, dtype=float))
    if not check:  # unassemblable angles are expected here and give NaN derivatives
        with np.errstate(all="ignore"):
            return _solve(mech, phi, False)
    return _solve(mech, phi, True)


def _solve(mech: Mechanism, phi: np.ndarray, check: bool) -> Kinematics:
    n = len(phi)
    pts: dict[str, jet.V] = {k: jet.vconst(v, n) for k, v in mech.ground.items()}
    inp = jet.S(phi, np.ones(n), np.zeros(n))
    for s in mech.steps:
        if isinstance(s, Crank):
            phase = mech.phi0 if s.phase is None else s.phase
            pts[s.point] = crank(pts[s.pivot], s.length, (inp - mech.phi0) * s.ratio + phase)
        elif isinstance(s, Dyad):
            pts[s.point], cos_u = dyad(pts[s.a], pts[s.b], s.length_a, s.length_b, s.sign)
            bad = ~(np.abs(cos_u) <= 1.0)
            if check and bad.any():
                raise AssemblyError(
                    f"{mech.name}: dyad {s.a}-{s.point}-{s.b} cannot close for input angles "
                    f"{_angle_ranges(phi, bad)} deg (|cos U| > 1): the input crank cannot turn "
                    f"through these angles (it is a rocker there)")
        elif isinstance(s, Attached):
            pts[s.point] = attached(pts[s.origin], pts[s.toward], s.angle, s.length, s.z)
        elif isinstance(s, Slider):
            n1, n2 = (pts[g] for g in s.guide)
            pts[s.point], h2 = slider(pts[s.start], s.length, n1, n2, s.toward == s.guide[1])
            bad = ~(h2 >= 0.0)
            if check and bad.any():
                raise AssemblyError(
                    f"{mech.name}: slider {s.start}-{s.point} (length {s.length * 1e3:g} mm) cannot "
                    f"reach its guide {s.guide[0]}-{s.guide[1]} for input angles "
                    f"{_angle_ranges(phi, bad)} deg")
    angles = {l.name: link_angle(pts, l) for l in mech.links}
    return Kinematics(mech, phi, pts, angles)


def assembly_ranges(mech: Mechanism, samples: int = 3601) -> tuple[bool, str]:
    """Whether the input crank turns fully; the input-angle ranges (deg) where it assembles."""
    phi = mech.phi0 + np.linspace(0.0, mech.period, samples)
    kin = solve(mech, phi, check=False)
    ok = np.ones(samples, dtype=bool)
    for s in mech.steps:
        if isinstance(s, Dyad):
            d = (kin.points[s.a].v - kin.points[s.b].v)[:, :2]
            dist = np.linalg.norm(d, axis=1)
            c = (dist**2 + s.length_b**2 - s.length_a**2) / (2 * dist * s.length_b)
            ok &= np.abs(c) <= 1.0
        elif isinstance(s, Slider):
            a = kin.points[s.start].v[:, :2]
            n1, n2 = (kin.points[g].v[:, :2] for g in s.guide)
            u = (n2 - n1) / np.linalg.norm(n2 - n1, axis=1, keepdims=True)
            off = (a - n1) - np.einsum("ij,ij->i", a - n1, u)[:, None] * u
            ok &= np.einsum("ij,ij->i", off, off) <= s.length**2
    return bool(ok.all()), _angle_ranges(phi, ok)


def check_rigidity(mech: Mechanism, samples: int = 361, rtol: float = 1e-9) -> None:
    """Every link's points must keep their distances (and a sliding link its guide's angle).

    Catches files whose construction contradicts their link lists. Raises MechanismFileError.
    """
    phi = mech.phi0 + np.linspace(0.0, mech.period, samples, endpoint=False)
    kin = solve(mech, phi)
    src = mech.path or mech.name
    for l in mech.links:
        for i, a in enumerate(l.points):
            for b in l.points[i + 1:]:
                d = np.linalg.norm(kin.points[a].v - kin.points[b].v, axis=1)
                if d.max() - d.min() > rtol * max(d.max(), 1e-3):
                    raise MechanismFileError(
                        f"{src}: [links.{l.name}]: points {a} and {b} do not stay at a fixed distance "
                        f"({d.min() * 1e3:.4f}..{d.max() * 1e3:.4f} mm): they are not on one rigid link")
        if len(l.points) >= 2 and l.guide:
            own = jet.angle((kin.points[l.points[1]] - kin.points[l.points[0]]).planar()).v
            ref = kin.angles[l.name].v
            dev = np.abs(np.angle(np.exp(1j * (own - ref)) / np.exp(1j * (own[0] - ref[0]))))
            if dev.max() > 1e-9:
                raise MechanismFileError(
                    f"{src}: [links.{l.name}]: slides on {l.guide[0]}-{l.guide[1]} but turns relative to that guide")


# -------------------------------------------------------------------------------- dynamics
@dataclass(frozen=True)
class Reduced:
    """Reduced dynamics over input angles: ``J`` kg*m^2, ``dJ`` = dJ/dphi kg*m^2/rad,
    ``Q`` generalized force of gravity and the external point forces, N*m (the drive's torque
    and the damping, which depend on speed, are added by the equation of motion)."""

    phi: np.ndarray
    J: np.ndarray
    dJ: np.ndarray
    Q: np.ndarray


def reduced(mech: Mechanism, kin: Kinematics, *, tables: bool = True) -> Reduced:
    """J(phi), J'(phi) and Q(phi) from the same kinematics (exact derivatives).

    ``tables`` False leaves out forces given as tables against the angle (the fast path adds
    them separately, since a table is not smooth).
    """
    dyn = mech.dynamics
    n = len(kin.phi)
    J, dJ, Q = np.zeros(n), np.zeros(n), np.zeros(n)
    grav = np.array([0.0, -dyn.gravity, 0.0])
    for l in mech.links:
        th = kin.angles[l.name]
        J += l.inertia * th.d**2
        dJ += 2.0 * l.inertia * th.d * th.dd
        if l.com is not None and l.mass > 0:
            s = kin.points[l.com]
            J += l.mass * np.einsum("ij,ij->i", s.d, s.d)
            dJ += 2.0 * l.mass * np.einsum("ij,ij->i", s.d, s.dd)
            Q += l.mass * s.d @ grav
    for f in dyn.forces:
        if f.angles is None or tables:
            Q += np.einsum("ij,ij->i", kin.points[f.point].d, f.at(kin.phi, mech.period))
    return Reduced(kin.phi, J, dJ, Q)


class SpectralDynamics:
    """J, J', Q as trigonometric interpolants over one period: the ODE's fast path.

    The ODE needs these at scalar angles tens of thousands of times; evaluating the blocks
    there costs ~0.3 ms a call, the interpolant ~10 us. They are smooth and periodic, so the
    interpolant converges spectrally; ``error`` is its measured maximum deviation from the
    direct evaluation at the midpoints between samples, relative to each function's range
    (tests check it against the plain twin, :func:`reduced` at scalar angles). Forces given
    as tables are not smooth: their points' derivatives are interpolated instead and the
    table is applied exactly. ``extra_inertia`` (kg*m^2) adds a flywheel on the input crank.
    """

    def __init__(self, mech: Mechanism, samples: int = 1024, *, extra_inertia: float = 0.0):
        self.mech = mech
        self.period = mech.period
        self.phi0 = mech.phi0
        self.tables = [f for f in mech.dynamics.forces if f.angles is not None]
        n = samples * int(round(self.period / (2 * np.pi)))
        grid = mech.phi0 + self.period * np.arange(n) / n
        vals = self._direct(grid) + np.array([[extra_inertia], [0.0], [0.0]] + [[0.0]] * (3 * len(self.tables)))
        coef = np.fft.rfft(vals, axis=1) / n
        coef[:, 1:] *= 2.0
        if n % 2 == 0:
            coef[:, -1] /= 2.0
        # Drop the tail whose sum is below 1e-14 of each row's size: the series is evaluated
        # per ODE step, and most linkages need tens of harmonics, not hundreds.
        size = np.abs(vals).max(axis=1) + 1e-300
        tail = np.cumsum(np.abs(coef[:, ::-1]), axis=1)[:, ::-1] / size[:, None]
        ok = np.all(tail <= 1e-14, axis=0)
        self._k = int(np.argmax(ok)) if ok.any() else coef.shape[1]
        self._k = max(self._k, 1)
        self._coef = coef[:, : self._k]
        mid = grid + self.period / (2 * n)
        direct = self._direct(mid)
        direct[0] += extra_inertia
        approx = self._series(mid)
        span = np.ptp(vals, axis=1) + np.abs(vals).max(axis=1) * 1e-12 + 1e-300
        self.error = float((np.abs(approx - direct).max(axis=1) / span).max())

    def _direct(self, phi: np.ndarray) -> np.ndarray:
        kin = solve(self.mech, phi)
        red = reduced(self.mech, kin, tables=False)
        rows = [red.J, red.dJ, red.Q]
        for f in self.tables:
            rows += list(kin.points[f.point].d.T)
        return np.array(rows)

    def _series(self, phi) -> np.ndarray:
        x = 2 * np.pi * (np.atleast_1d(phi) - self.phi0) / self.period
        e = np.exp(1j * np.outer(np.arange(self._k), x))
        return np.real(self._coef @ e)

    @property
    def harmonics(self) -> int:
        return self._k

    def evaluate(self, phi) -> np.ndarray:
        """(3, N) array of J, J', Q at input angles phi (rad)."""
        phi = np.atleast_1d(phi)
        s = self._series(phi)
        out = s[:3].copy()
        for i, f in enumerate(self.tables):
            out[2] += np.einsum("ij,ji->i", f.at(phi, self.period), s[3 + 3 * i: 6 + 3 * i])
        return out

    def scalar(self, phi: float) -> tuple[float, float, float]:
        x = 2 * np.pi * (phi - self.phi0) / self.period
        e = np.cumprod(np.full(self._k, np.exp(1j * x)))
        v = (self._coef[:, 1:] @ e[:-1]).real + self._coef[:, 0].real
        q = v[2]
        for i, f in enumerate(self.tables):
            fx, fy, fz = f.at_scalar(phi, self.period)
            q += fx * v[3 + 3 * i] + fy * v[4 + 3 * i] + fz * v[5 + 3 * i]
        return float(v[0]), float(v[1]), float(q)


@dataclass(frozen=True)
class Motion:
    """Crank motion in time: ``t`` s, ``phi`` rad (unwrapped), ``omega`` rad/s, ``eps`` rad/s^2."""

    t: np.ndarray
    phi: np.ndarray
    omega: np.ndarray
    eps: np.ndarray


def _accel(mech: Mechanism, J, dJ, Q, w):
    """phi'' from the equation of motion (drive torque from the motor law, damping)."""
    dyn = mech.dynamics
    return (Q + dyn.drive_torque(w) - dyn.damping * w - 0.5 * dJ * w * w) / J


def _rhs(sd: SpectralDynamics):
    mech = sd.mech

    def f(_t, y):
        J, dJ, Q = sd.scalar(y[0])
        return [y[1], _accel(mech, J, dJ, Q, y[1])]
    return f


# DOP853's relative tolerance for the "tight" solution: at 1e-10 it agrees with 1e-12 to
# 2e-8 of omega on the take-up, four orders below the MuJoCo threshold, in a third of the time.
TIGHT_RTOL = 1e-10


def forward_dynamics(mech: Mechanism, t_eval: np.ndarray, *, rtol: float = TIGHT_RTOL,
                     sd: SpectralDynamics | None = None, phi0: float | None = None,
                     omega0: float | None = None) -> Motion:
    """phi(t) from (phi0, omega0) (default: the file's), the equation of motion solved tightly (DOP853)."""
    from scipy.integrate import solve_ivp

    sd = sd or SpectralDynamics(mech)
    y0 = [mech.phi0 if phi0 is None else phi0, mech.dynamics.omega0 if omega0 is None else omega0]
    sol = solve_ivp(_rhs(sd), (float(t_eval[0]), float(t_eval[-1])), y0,
                    method="DOP853", t_eval=t_eval, rtol=rtol, atol=rtol * 1e-2)
    if not sol.success:
        raise AssemblyError(f"{mech.name}: reference ODE failed: {sol.message}")
    phi, omega = sol.y
    J, dJ, Q = sd.evaluate(phi)
    return Motion(t_eval, phi, omega, _accel(mech, J, dJ, Q, omega))


def rk4_dynamics(mech: Mechanism, steps: int = 1000, sd: SpectralDynamics | None = None) -> Motion:
    """The paper's method: classical fixed-step RK4, ``steps`` steps over the duration."""
    sd = sd or SpectralDynamics(mech)
    f = _rhs(sd)
    h = mech.dynamics.duration / steps
    y = np.empty((steps + 1, 2))
    y[0] = mech.phi0, mech.dynamics.omega0
    for i in range(steps):
        k1 = np.array(f(0, y[i]))
        k2 = np.array(f(0, y[i] + 0.5 * h * k1))
        k3 = np.array(f(0, y[i] + 0.5 * h * k2))
        k4 = np.array(f(0, y[i] + h * k3))
        y[i + 1] = y[i] + h / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)
    t = h * np.arange(steps + 1)
    J, dJ, Q = sd.evaluate(y[:, 0])
    return Motion(t, y[:, 0], y[:, 1], _accel(mech, J, dJ, Q, y[:, 1]))


def constant_speed(mech: Mechanism, t: np.ndarray, omega: float | None = None) -> Motion:
    """The kinematic case: phi = phi0 + omega t, eps = 0."""
    w = mech.speed if omega is None else omega
    return Motion(t, mech.phi0 + w * t, np.full_like(t, w), np.zeros_like(t))


# ---------------------------------------------------------------------- inverse dynamics
def driving_torque(mech: Mechanism, phi, omega, eps=0.0) -> np.ndarray:
    """Torque (N*m) the drive must apply to the input crank for the motion (phi, omega, eps).

    ``tau = J eps + 1/2 J' omega^2 + b omega - Q``: inverse dynamics of the reduced equation
    (the file's driving moment and motor are not counted: this is what they must supply).
    """
    phi = np.atleast_1d(np.asarray(phi, dtype=float))
    red = reduced(mech, solve(mech, phi))
    w = np.broadcast_to(np.asarray(omega, dtype=float), phi.shape)
    e = np.broadcast_to(np.asarray(eps, dtype=float), phi.shape)
    return red.J * e + 0.5 * red.dJ * w**2 + mech.dynamics.damping * w - red.Q


@dataclass(frozen=True)
class Reactions:
    """Forces in every kinematic pair over input angles (kinetostatics).

    ``forces[label]`` (N, 3) N: the force on the pair's child link from its parent (the ground
    for a pivot), world frame; for a prismatic pair the force normal to the guide, applied at
    the sliding link's first point, with the pair's moment in ``moments[label]`` (N,) N*m.
    ``torque`` (N,) N*m on the input crank; ``gear[label]`` (N,) N*m on each geared crank.
    Labels: ``P3:lever-rocker`` (point:parent-child), ``slide:cylinder-plunger``.
    """

    phi: np.ndarray
    forces: dict[str, np.ndarray]
    moments: dict[str, np.ndarray]
    torque: np.ndarray
    gear: dict[str, np.ndarray]


def pair_label(pr) -> str:
    """Readable label of a kinematic pair (see :class:`Reactions`)."""
    parent = pr.parent or "ground"
    return f"{pr.point}:{parent}-{pr.child}" if pr.kind == "hinge" else f"slide:{parent}-{pr.child}"


def reactions(mech: Mechanism, phi, omega, eps=0.0) -> Reactions:
    """Kinetostatic analysis: Newton-Euler for every moving link, one linear solve per angle.

    Unknowns: two force components per revolute pair, the normal force and moment of each
    prismatic pair, the driving torque and one torque per gear coupling (the input crank
    takes ``-ratio`` times it: ideal gears transmit power without loss). With W = 1 these are
    exactly 3 per moving link. Units N, N*m; rad, rad/s, rad/s^2 in.
    """
    from .mechanism import Crank
    from .topology import pairs

    phi = np.atleast_1d(np.asarray(phi, dtype=float))
    n = len(phi)
    w = np.broadcast_to(np.asarray(omega, dtype=float), (n,))
    e = np.broadcast_to(np.asarray(eps, dtype=float), (n,))
    kin = solve(mech, phi)
    P = {k: v.v for k, v in kin.points.items()}
    prs = [p for _, p in pairs(mech)]
    links = [l.name for l in mech.links]
    row = {name: 3 * i for i, name in enumerate(links)}
    geared = [s for s in mech.steps if isinstance(s, Crank) and s is not mech.input_crank]
    nu = 2 * len(prs) + 1 + len(geared)
    if nu != 3 * len(links):
        from .errors import MechanismFileError

        raise MechanismFileError(
            f"{mech.path or mech.name}: kinetostatics needs a mechanism with one degree of freedom as driven "
            f"({len(prs)} pairs, {len(geared)} gears and {len(links)} links give {nu} unknowns for "
            f"{3 * len(links)} equations)")
    A = np.zeros((n, 3 * len(links), nu))
    b = np.zeros((n, 3 * len(links)))
    origin = {l.name: P[l.points[0]] for l in mech.links}

    col = 0
    for pr in prs:
        if pr.kind == "hinge":
            at = P[pr.point]
            for link, sgn in ((pr.child, 1.0), (pr.parent, -1.0)):
                if link is None:
                    continue
                r0, d = row[link], at - origin[link]
                A[:, r0, col] += sgn
                A[:, r0 + 1, col + 1] += sgn
                A[:, r0 + 2, col] += -sgn * d[:, 1]  # moment of (Fx, 0): -dy Fx
                A[:, r0 + 2, col + 1] += sgn * d[:, 0]  # moment of (0, Fy): dx Fy
        else:
            g = (P[pr.guide[1]] - P[pr.guide[0]])[:, :2]
            u = g / np.linalg.norm(g, axis=1, keepdims=True)
            nrm = np.column_stack([-u[:, 1], u[:, 0]])
            at = origin[pr.child]
            for link, sgn in ((pr.child, 1.0), (pr.parent, -1.0)):
                if link is None:
                    continue
                r0, d = row[link], at - origin[link]
                A[:, r0, col] += sgn * nrm[:, 0]
                A[:, r0 + 1, col] += sgn * nrm[:, 1]
                A[:, r0 + 2, col] += sgn * (d[:, 0] * nrm[:, 1] - d[:, 1] * nrm[:, 0])
                A[:, r0 + 2, col + 1] += sgn
        col += 2
    A[:, row[mech.input_link.name] + 2, col] = 1.0
    col_tau = col
    col += 1
    gear_cols = {}
    for s in geared:
        gl = next(l for l in mech.links if s.pivot in l.points and s.point in l.points)
        A[:, row[gl.name] + 2, col] += 1.0
        A[:, row[mech.input_link.name] + 2, col] += -s.ratio
        gear_cols[gl.name] = col
        col += 1

    grav = np.array([0.0, -mech.dynamics.gravity])
    for l in mech.links:
        r0 = row[l.name]
        th = kin.angles[l.name]
        alpha = th.dd * w**2 + th.d * e
        rhs_f = np.zeros((n, 2))
        rhs_m = l.inertia * alpha
        if l.com is not None and l.mass > 0:
            s = kin.points[l.com]
            a = (s.dd * w[:, None] ** 2 + s.d * e[:, None])[:, :2]
            d = (s.v - origin[l.name])[:, :2]
            f_net = l.mass * (a - grav)  # inertial force minus gravity: what the pairs must supply
            rhs_f += f_net
            rhs_m = rhs_m + d[:, 0] * f_net[:, 1] - d[:, 1] * f_net[:, 0]
        b[:, r0:r0 + 2] = rhs_f
        b[:, r0 + 2] = rhs_m
    for f in mech.dynamics.forces:
        owner = mech.link_of(f.point)
        if owner is None:
            continue
        F = f.at(phi, mech.period)[:, :2]
        d = (P[f.point] - origin[owner.name])[:, :2]
        r0 = row[owner.name]
        b[:, r0:r0 + 2] -= F
        b[:, r0 + 2] -= d[:, 0] * F[:, 1] - d[:, 1] * F[:, 0]
    # Damping acts on the input crank joint like a torque -b omega.
    b[:, row[mech.input_link.name] + 2] += mech.dynamics.damping * w

    x = np.linalg.solve(A, b[..., None])[..., 0]
    forces, moments = {}, {}
    col = 0
    for pr in prs:
        lab = pair_label(pr)
        if pr.kind == "hinge":
            forces[lab] = np.column_stack([x[:, col], x[:, col + 1], np.zeros(n)])
        else:
            g = (P[pr.guide[1]] - P[pr.guide[0]])[:, :2]
            u = g / np.linalg.norm(g, axis=1, keepdims=True)
            forces[lab] = np.column_stack([-u[:, 1] * x[:, col], u[:, 0] * x[:, col], np.zeros(n)])
            moments[lab] = x[:, col + 1]
        col += 2
    return Reactions(phi, forces, moments, x[:, col_tau], {k: x[:, c] for k, c in gear_cols.items()})


# ---------------------------------------------------------------------- steady motion
@dataclass(frozen=True)
class Steady:
    """Periodic steady motion under the file's drive (motor characteristic).

    ``phi`` rad over one period, ``omega`` rad/s there, ``t`` s from its start; ``delta`` the
    coefficient of speed fluctuation (omega_max - omega_min) / omega_mean with omega_mean the
    time average; ``extra_inertia`` kg*m^2 added on the crank (a flywheel)."""

    phi: np.ndarray
    omega: np.ndarray
    t: np.ndarray
    omega_mean: float
    delta: float
    extra_inertia: float


def steady_variant(mech: Mechanism, motor=None) -> Mechanism:
    """``mech`` driven by the steady-motion motor (argument, or the file's [steady] one) alone."""
    import dataclasses

    motor = motor or (mech.steady.motor if mech.steady else None)
    if motor is None:
        raise AssemblyError(f"{mech.name}: no steady motion without a motor characteristic "
                            "(give [steady] or [dynamics.motor] in the file, or --stall-torque and --no-load-speed)")
    return dataclasses.replace(mech, dynamics=dataclasses.replace(mech.dynamics, motor=motor, moment=0.0))


def steady_motion(mech: Mechanism, *, extra_inertia: float = 0.0, samples: int = 2049,
                  start: float | None = None) -> Steady:
    """The periodic orbit omega(phi) of the equation of motion under the drive of ``mech``
    (see :func:`steady_variant`), found by shooting in phi with a secant iteration.

    With phi as the independent variable ``d(omega)/d(phi) = phi''/omega`` and
    ``dt/dphi = 1/omega``; the speed at phi0 is chosen so that it returns after one period.
    ``start`` rad/s: a first guess (default: where the motor balances the damping).
    """
    from scipy.integrate import solve_ivp
    from scipy.optimize import brentq

    dyn = mech.dynamics
    motor = dyn.motor
    if motor is None:
        raise AssemblyError(f"{mech.name}: steady motion needs a motor characteristic (see steady_variant)")
    sd = SpectralDynamics(mech, samples=512, extra_inertia=extra_inertia)
    sign = np.sign(motor.no_load_speed)
    span = sign * mech.period

    def rhs(phi, y):
        J, dJ, Q = sd.scalar(phi)
        return [_accel(mech, J, dJ, Q, y[0]) / y[0], 1.0 / y[0]]

    def excess(w0):
        sol = solve_ivp(rhs, (mech.phi0, mech.phi0 + span), [w0, 0.0], method="DOP853", rtol=1e-10, atol=1e-12)
        ok = sol.success and sol.status == 0 and np.all(sol.y[0] * sign > 0)
        return sol.y[0, -1] - w0 if ok else np.nan

    w_bal = motor.stall_torque / (dyn.damping + motor.stall_torque / motor.no_load_speed)
    x0 = start if start is not None else w_bal
    x1, f0 = x0 * 1.02, excess(x0)
    root = None
    for _ in range(30):  # secant: the excess is smooth and nearly linear near the orbit
        f1 = excess(x1)
        if not (np.isfinite(f0) and np.isfinite(f1)) or f1 == f0:
            break
        x0, x1, f0 = x1, x1 - f1 * (x1 - x0) / (f1 - f0), f1
        if abs(x1 - x0) <= 1e-12 * abs(x1):
            root = x1
            break
    if root is None:  # fall back on a bracket scan
        grid = sign * np.geomspace(abs(motor.no_load_speed) * 1e-2, abs(motor.no_load_speed) * 2, 40)
        vals = [excess(w) for w in grid]
        for (a, fa), (b, fb) in zip(zip(grid, vals), zip(grid[1:], vals[1:])):
            if np.isfinite(fa) and np.isfinite(fb) and fa * fb < 0:
                root = brentq(excess, a, b, xtol=1e-12, rtol=1e-13)
    if root is None:
        raise AssemblyError(f"{mech.name}: no periodic steady motion found for this drive")
    phis = mech.phi0 + np.linspace(0.0, span, samples)
    sol = solve_ivp(rhs, (phis[0], phis[-1]), [root, 0.0], method="DOP853", t_eval=phis, rtol=1e-11, atol=1e-12)
    omega, t = sol.y
    mean = float(abs(span) / abs(t[-1])) * sign
    return Steady(phis, omega, t, float(mean), float((omega.max() - omega.min()) / abs(mean)), extra_inertia)


def flywheel_for(mech: Mechanism, target_delta: float) -> tuple[float, Steady]:
    """Flywheel inertia (kg*m^2, on the input crank) that brings delta to ``target_delta``.

    1/delta grows nearly linearly with added inertia, so a secant on 1/delta converges in a
    few steady-motion solves.
    """
    base = steady_motion(mech)
    if base.delta <= target_delta:
        return 0.0, base
    # Classical first guess: J_f = dE / (omega_m^2 delta), dE the swing of kinetic energy.
    J = SpectralDynamics(mech, samples=256).evaluate(base.phi)[0]
    energy = 0.5 * J * base.omega**2
    x0, g0 = 0.0, 1.0 / base.delta - 1.0 / target_delta
    x1 = max(np.ptp(energy) / (base.omega_mean**2 * target_delta), 1e-12)
    st = base
    for _ in range(40):
        st = steady_motion(mech, extra_inertia=x1, start=st.omega[0])
        g1 = 1.0 / st.delta - 1.0 / target_delta
        if abs(st.delta - target_delta) <= 1e-6 * target_delta or g1 == g0:
            break
        x0, x1, g0 = x1, max(x1 - g1 * (x1 - x0) / (g1 - g0), 0.5 * x1), g1
    return x1, st
