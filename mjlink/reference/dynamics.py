"""Reduced-inertia dynamics of a one-degree-of-freedom machine: the papers' Lagrange equation.

::

    J(phi) phi'' + 1/2 J'(phi) phi'^2 + b phi' = Q(phi) + M(phi')
    J(phi) = sum_i J_Si (dtheta_i/dphi)^2 + m_i |dS_i/dphi|^2
    Q(phi) = sum_i m_i g . dS_i/dphi + sum_k F_k . dP_k/dphi

J, J' and Q come from the kinematics' exact derivatives; the equation is solved tightly
(LSODA, DOP853 its tested twin), by the paper's fixed-step RK4, or for its periodic steady orbit under a motor
characteristic. All quantities SI (m, rad, kg, s, N*m).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from ..errors import AssemblyError
from ..model.mechanism import COUNTERWEIGHT, Mechanism
from . import energy
from .kinematics import Kinematics, solve


@dataclass(frozen=True)
class Reduced:
    """Reduced dynamics over input angles: ``J`` kg*m^2, ``dJ`` = dJ/dphi kg*m^2/rad,
    ``Q`` generalized force of gravity and the external point forces, N*m (the drive's torque
    and the damping, which depend on speed, are added by the equation of motion)."""

    phi: np.ndarray
    J: np.ndarray
    dJ: np.ndarray
    Q: np.ndarray


def load_points(mech: Mechanism) -> set[str]:
    """The points the equation of motion reads besides the links' angles: the centres of mass
    and the points the file's forces act at (for ``solve(..., only=...)``)."""
    return {l.com for l in mech.links if l.com is not None} | {f.point for f in mech.dynamics.forces}


def reduced(mech: Mechanism, kin: Kinematics, *, tables: bool = True) -> Reduced:
    """J(phi), J'(phi) and Q(phi) from the same kinematics (exact derivatives).

    ``tables`` False leaves out forces given as tables against the angle (the fast path adds
    them separately, since a table is not smooth).
    """
    dyn = mech.dynamics
    n = len(kin.phi)
    J, dJ, Q = np.zeros(n), np.zeros(n), np.zeros(n)
    for l in mech.links:
        th = kin.angles[l.name]
        J += l.inertia * th.d**2
        dJ += 2.0 * l.inertia * th.d * th.dd
        # Masses and gravity may be one per row (a design study's variants): no truth tests
        # on them, and gravity (along -Y) enters through the y component alone.
        if l.com is not None and np.any(np.asarray(l.mass) > 0):
            s = kin.points[l.com]
            J += l.mass * np.einsum("ij,ij->i", s.d, s.d)
            dJ += 2.0 * l.mass * np.einsum("ij,ij->i", s.d, s.dd)
            Q += l.mass * s.d[:, 1] * -dyn.gravity
    cw = mech.counterweight
    if cw is not None:  # a point mass on the input crank
        c = kin.points[COUNTERWEIGHT]
        J += cw.mass * np.einsum("ij,ij->i", c.d, c.d)
        dJ += 2.0 * cw.mass * np.einsum("ij,ij->i", c.d, c.dd)
        Q += cw.mass * c.d[:, 1] * -dyn.gravity
    for f in dyn.forces:
        if f.angles is None or tables:
            Q += np.einsum("ij,ij->i", kin.points[f.point].d, f.at(kin.phi, mech.period))
    return Reduced(kin.phi, J, dJ, Q)


class SpectralDynamics:
    """J, J', Q as trigonometric interpolants over one period: the ODE's fast path.

    The ODE needs these at scalar angles tens of thousands of times; evaluating the blocks
    there costs far more a call than the interpolant. They are smooth and periodic, so the
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
        n = samples * round(self.period / (2 * np.pi))
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
        kin = solve(self.mech, phi, only=load_points(self.mech))
        red = reduced(self.mech, kin, tables=False)
        rows = [red.J, red.dJ, red.Q]
        for f in self.tables:
            rows += list(kin.points[f.point].d.T)
        return np.array(rows)

    def _series(self, phi) -> np.ndarray:
        """The series at angles phi (N,): (rows, N). e^(i n x) as e^(i 16 q x) e^(i r x)
        (n = 16 q + r), both exact exponentials: 1/16 + 16/n of the exponentials of the
        plain outer product for one rounding more, and in chunks of 1024 angles, so that
        the (harmonics, angles) factor stays in cache."""
        x = 2 * np.pi * (np.atleast_1d(np.asarray(phi, dtype=float)) - self.phi0) / self.period
        k, step = self._k, 16
        q, r = np.arange(-(-k // step)), np.arange(step)
        out = np.empty((self._coef.shape[0], len(x)))
        for i in range(0, len(x), 1024):
            xs = x[i : i + 1024]
            e = np.exp(1j * step * np.outer(q, xs))[:, None, :] * np.exp(1j * np.outer(r, xs))[None, :, :]
            out[:, i : i + 1024] = (self._coef @ e.reshape(-1, len(xs))[:k]).real
        return out

    @property
    def harmonics(self) -> int:
        return self._k

    def evaluate(self, phi) -> np.ndarray:
        """(3, N) array of J, J', Q at input angles phi (rad)."""
        phi = np.atleast_1d(phi)
        s = self._series(phi)
        out = s[:3].copy()
        for i, f in enumerate(self.tables):
            out[2] += np.einsum("ij,ji->i", f.at(phi, self.period), s[3 + 3 * i : 6 + 3 * i])
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
    """Crank motion in time: ``t`` s, ``phi`` rad (unwrapped), ``omega`` rad/s, ``eps`` rad/s^2;
    ``method`` what solved the equation of motion ("energy", "LSODA", "DOP853", "RK4"; empty
    for an imposed motion)."""

    t: np.ndarray
    phi: np.ndarray
    omega: np.ndarray
    eps: np.ndarray
    method: str = ""


def _accel(mech: Mechanism, J, dJ, Q, w):
    """phi'' from the equation of motion (drive torque from the motor law, damping)."""
    dyn = mech.dynamics
    return (Q + dyn.drive_torque(w) - dyn.damping * w - 0.5 * dJ * w * w) / J


def _rhs(sd: SpectralDynamics):
    """(phi, omega)' at (t, y): plain floats, the drive law unrolled (:meth:`Dynamics.drive_torque`
    and :func:`_accel` with numpy cost more per call than the table itself)."""
    dyn = sd.mech.dynamics
    moment, damping = float(dyn.moment), float(dyn.damping)
    stall = float(dyn.motor.stall_torque) if dyn.motor else 0.0
    slope = stall / float(dyn.motor.no_load_speed) if dyn.motor else 0.0
    scalar = sd.scalar

    def f(_t, y):
        phi, w = y
        J, dJ, Q = scalar(phi)
        return [w, (Q + moment + stall - slope * w - damping * w - 0.5 * dJ * w * w) / J]

    return f


# The "tight" solution's relative tolerance (LSODA, scipy's odeint: its stepping is compiled,
# only the right-hand side is Python): at 1e-11 it agrees with DOP853 at 1e-12 to 6e-9 of
# omega on the take-up, five orders below the MuJoCo threshold, and closer than DOP853 at
# 1e-10 (which agreed to 1.7e-8) at a fraction of its cost: the compiled stepper calls the
# Python right-hand side less often. DOP853 at 1e-12 is the tested twin (tests/test_dynamics.py).
TIGHT_RTOL = 1e-11


def forward_dynamics(
    mech: Mechanism,
    t_eval: np.ndarray,
    *,
    rtol: float = TIGHT_RTOL,
    sd: SpectralDynamics | None = None,
    phi0: float | None = None,
    omega0: float | None = None,
    method: str = "auto",
) -> Motion:
    """phi(t) from (phi0, omega0) (default: the file's) at the times ``t_eval`` (s, increasing),
    the equation of motion solved tightly.

    ``method``: "auto" (default) solves it over the crank angle (:mod:`.energy`: vectorized,
    no time stepping) and falls back to LSODA where that does not apply (a crank that stops
    or turns back); "LSODA" (scipy's odeint at ``rtol``, see :data:`TIGHT_RTOL`) and
    "DOP853" (scipy's explicit Runge-Kutta, the twin the tests compare with) step in time.
    The returned :class:`Motion` names the method that solved it.
    """
    sd = sd or SpectralDynamics(mech)
    y0 = [mech.phi0 if phi0 is None else phi0, mech.dynamics.omega0 if omega0 is None else omega0]
    t_eval = np.asarray(t_eval, dtype=float)
    if method == "auto":
        dyn = mech.dynamics
        stall = float(dyn.motor.stall_torque) if dyn.motor else 0.0
        slope = stall / float(dyn.motor.no_load_speed) if dyn.motor else 0.0
        try:
            with np.errstate(all="ignore"):  # a failure shows as None or non-finite values
                out = energy.solve(sd, y0[0], y0[1], float(dyn.moment) + stall, slope + float(dyn.damping), t_eval)
        except (ArithmeticError, ValueError, np.linalg.LinAlgError):
            out = None
        if out is not None and all(np.isfinite(x).all() for x in out[:2]):
            phi, omega, (J, dJ, Q) = out
            return Motion(t_eval, phi, omega, _accel(mech, J, dJ, Q, omega), "energy")
        method = "LSODA"
    from scipy.integrate import odeint, solve_ivp  # here: scipy, only when the energy solution does not serve

    f = _rhs(sd)
    if method == "DOP853":
        sol = solve_ivp(
            f, (float(t_eval[0]), float(t_eval[-1])), y0, method="DOP853", t_eval=t_eval, rtol=rtol, atol=rtol * 1e-2
        )
        if not sol.success:
            raise AssemblyError(f"{mech.name}: reference ODE failed: {sol.message}")
        phi, omega = sol.y
    elif method == "LSODA":
        y, info = odeint(f, y0, t_eval, rtol=rtol, atol=rtol * 1e-2, mxstep=1_000_000, full_output=True, tfirst=True)
        if info["message"] != "Integration successful.":
            raise AssemblyError(f"{mech.name}: reference ODE failed: {info['message']}")
        phi, omega = y[:, 0], y[:, 1]
    else:
        raise ValueError(f"unknown method {method!r}: auto, LSODA or DOP853")
    J, dJ, Q = sd.evaluate(phi)
    return Motion(t_eval, phi, omega, _accel(mech, J, dJ, Q, omega), method)


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
    return Motion(t, y[:, 0], y[:, 1], _accel(mech, J, dJ, Q, y[:, 1]), "RK4")


def constant_speed(mech: Mechanism, t: np.ndarray, omega: float | None = None) -> Motion:
    """The kinematic case: phi = phi0 + omega t, eps = 0."""
    w = mech.speed if omega is None else omega
    return Motion(t, mech.phi0 + w * t, np.full_like(t, w), np.zeros_like(t))


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
    motor = motor or (mech.steady.motor if mech.steady else None)
    if motor is None:
        raise AssemblyError(
            f"{mech.name}: no steady motion without a motor characteristic "
            "(give [steady] or [dynamics.motor] in the file, or --stall-torque and --no-load-speed)"
        )
    return dataclasses.replace(mech, dynamics=dataclasses.replace(mech.dynamics, motor=motor, moment=0.0))


def steady_motion(
    mech: Mechanism, *, extra_inertia: float = 0.0, samples: int = 2049, start: float | None = None
) -> Steady:
    """The periodic orbit omega(phi) of the equation of motion under the drive of ``mech``
    (see :func:`steady_variant`), found by shooting in phi with a secant iteration.

    With phi as the independent variable ``d(omega)/d(phi) = phi''/omega`` and
    ``dt/dphi = 1/omega``; the speed at phi0 is chosen so that it returns after one period.
    ``start`` rad/s: a first guess (default: where the motor balances the damping).
    """
    from scipy.integrate import solve_ivp  # see forward_dynamics
    from scipy.optimize import brentq  # as solve_ivp: here, not at the top

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
