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
    ``Q`` position-dependent generalized force N*m (driving moment, gravity, point forces)."""

    phi: np.ndarray
    J: np.ndarray
    dJ: np.ndarray
    Q: np.ndarray


def reduced(mech: Mechanism, kin: Kinematics, *, moment: float | None = None) -> Reduced:
    """J(phi), J'(phi) and Q(phi) from the same kinematics (exact derivatives)."""
    dyn = mech.dynamics
    n = len(kin.phi)
    J, dJ = np.zeros(n), np.zeros(n)
    Q = np.full(n, dyn.moment if moment is None else moment)
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
        Q += kin.points[f.point].d @ np.asarray(f.value)
    return Reduced(kin.phi, J, dJ, Q)


class SpectralDynamics:
    """J, J', Q as trigonometric interpolants over one period: the ODE's fast path.

    The ODE needs these at scalar angles tens of thousands of times; evaluating the blocks
    there costs ~0.3 ms a call, the interpolant ~10 us. They are smooth and periodic, so the
    interpolant converges spectrally; ``error`` is its measured maximum deviation from the
    direct evaluation at the midpoints between samples, relative to each function's range
    (``tests`` check it against the plain twin, :func:`reduced` at scalar angles).
    """

    def __init__(self, mech: Mechanism, samples: int = 1024, *, moment: float | None = None):
        self.mech = mech
        self.period = mech.period
        self.phi0 = mech.phi0
        n = samples * int(round(self.period / (2 * np.pi)))
        grid = mech.phi0 + self.period * np.arange(n) / n
        red = reduced(mech, solve(mech, grid), moment=moment)
        vals = np.stack([red.J, red.dJ, red.Q])
        coef = np.fft.rfft(vals, axis=1) / n
        coef[:, 1:] *= 2.0
        if n % 2 == 0:
            coef[:, -1] /= 2.0
        # Drop the negligible tail: the series is evaluated per ODE step.
        mag = np.abs(coef).max(axis=0)
        keep = np.nonzero(mag > 1e-16 * mag.max())[0]
        self._k = keep.max() + 1 if len(keep) else 1
        self._coef = coef[:, : self._k]
        mid = grid + self.period / (2 * n)
        direct = reduced(mech, solve(mech, mid), moment=moment)
        approx = self.evaluate(mid)
        span = np.ptp(vals, axis=1) + np.abs(vals).max(axis=1) * 1e-12 + 1e-300
        self.error = float(max(np.abs(approx[i] - v).max() / span[i]
                               for i, v in enumerate((direct.J, direct.dJ, direct.Q))))

    @property
    def harmonics(self) -> int:
        return self._k

    def evaluate(self, phi) -> np.ndarray:
        """(3, N) array of J, J', Q at input angles phi (rad)."""
        x = 2 * np.pi * (np.atleast_1d(phi) - self.phi0) / self.period
        e = np.exp(1j * np.outer(np.arange(self._k), x))
        return np.real(self._coef @ e)

    def scalar(self, phi: float) -> tuple[float, float, float]:
        x = 2 * np.pi * (phi - self.phi0) / self.period
        e = np.cumprod(np.full(self._k, np.exp(1j * x)))
        v = self._coef[:, 1:] @ e[:-1]
        c0 = self._coef[:, 0]
        return float(c0[0].real + v[0].real), float(c0[1].real + v[1].real), float(c0[2].real + v[2].real)


@dataclass(frozen=True)
class Motion:
    """Crank motion in time: ``t`` s, ``phi`` rad (unwrapped), ``omega`` rad/s, ``eps`` rad/s^2."""

    t: np.ndarray
    phi: np.ndarray
    omega: np.ndarray
    eps: np.ndarray


def _rhs(sd: SpectralDynamics, b: float):
    def f(_t, y):
        J, dJ, Q = sd.scalar(y[0])
        w = y[1]
        return [w, (Q - 0.5 * dJ * w * w - b * w) / J]
    return f


def forward_dynamics(mech: Mechanism, t_eval: np.ndarray, *, rtol: float = 1e-12,
                     sd: SpectralDynamics | None = None) -> Motion:
    """phi(t) from rest state (phi0, omega0), the equation of motion solved tightly (DOP853)."""
    from scipy.integrate import solve_ivp

    sd = sd or SpectralDynamics(mech)
    b = mech.dynamics.damping
    sol = solve_ivp(_rhs(sd, b), (0.0, float(t_eval[-1])), [mech.phi0, mech.dynamics.omega0],
                    method="DOP853", t_eval=t_eval, rtol=rtol, atol=rtol * 1e-2)
    if not sol.success:
        raise AssemblyError(f"{mech.name}: reference ODE failed: {sol.message}")
    phi, omega = sol.y
    J, dJ, Q = sd.evaluate(phi)
    return Motion(t_eval, phi, omega, (Q - 0.5 * dJ * omega**2 - b * omega) / J)


def rk4_dynamics(mech: Mechanism, steps: int = 1000, sd: SpectralDynamics | None = None) -> Motion:
    """The paper's method: classical fixed-step RK4, ``steps`` steps over the duration."""
    sd = sd or SpectralDynamics(mech)
    b = mech.dynamics.damping
    f = _rhs(sd, b)
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
    return Motion(t, y[:, 0], y[:, 1], (Q - 0.5 * dJ * y[:, 1] ** 2 - b * y[:, 1]) / J)


def constant_speed(mech: Mechanism, t: np.ndarray, omega: float | None = None) -> Motion:
    """The kinematic case: phi = phi0 + omega t, eps = 0."""
    w = mech.speed if omega is None else omega
    return Motion(t, mech.phi0 + w * t, np.full_like(t, w), np.zeros_like(t))
