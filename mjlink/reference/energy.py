"""The equation of motion solved over the crank angle, vectorized: the reference's fast path.

With the kinetic energy T = J(phi) omega^2 / 2 and the angle turned s = sigma (phi - phi0)
(sigma the sense of motion), the papers' equation ``J phi'' + J'/2 phi'^2 = Q(phi) + A -
B phi'`` (A the moment plus the motor's stall torque, B the motor's slope plus the damping)
becomes one first-order equation in s::

    dT/ds = f(s) - B sqrt(2 T / J(s)),      f(s) = sigma (Q(phi) + A),
    dt/ds = sqrt(J(s) / (2 T)).

J and Q are periodic in s: on panels of a fixed grid over one period (force tables' corners
on panel edges) they are evaluated once and reused for every turn, and the only coupling
left is the damping term. A block of turns is solved at once by Newton's method on the
integral form ``T = T0 + int (f - g(T)) ds`` with spectral (Chebyshev-Lobatto) integration
on every panel: each Newton step is a linear equation solved in closed form (an integrating
factor), vectorized over every node of the block. A start from rest, where T grows like s,
is resolved by panels refined geometrically towards s = 0. The times of the nodes follow by
the same integration, and the requested times are found by Newton's method on each panel's
interpolant.

The panels are sized for J and Q (and, under a stiff motor, for the damping's decay at the
steady speed); a solution that is not resolved on them, as when the speed changes faster
than the crank turns through a panel, is detected by its own last Chebyshev coefficients and
solved again on finer panels. It applies while the crank keeps turning one way. A run in
which the crank would stop or reverse, whose start from rest has no sense of motion, or that
finer panels do not resolve, is left to the time-domain solver
(:func:`mjlink.reference.dynamics.forward_dynamics` falls back to LSODA): :func:`solve`
returns None. Units SI (rad, s, kg*m^2, N*m, J).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np
from numpy.polynomial import chebyshev as C


class SpectralDynamics(Protocol):
    """What the solver needs of the mechanism's reduced dynamics
    (:class:`mjlink.reference.dynamics.SpectralDynamics` is one): the ``period`` (rad), the
    ``tables`` of forces given as tables (their ``angles``, rad) and ``evaluate``, the rows J,
    J', Q at input angles."""

    @property
    def period(self) -> float: ...

    @property
    def tables(self) -> Sequence[Any]: ...

    def evaluate(self, phi: Any) -> np.ndarray: ...


NODES = 24  # Chebyshev-Lobatto nodes per panel
GRADED = 36  # geometric panels towards s = 0 for a start from rest (down to 2^-36 of a panel)
NEWTON_TOL = 1e-15  # Newton's step, relative to the block's largest energy
MAX_NEWTON = 40
MAX_DECAY = 300.0  # largest integrating-factor exponent in a block (e^300 fits a double)
TAIL = 1e-14  # the panels' width: f's last Chebyshev coefficients below this of its size
RESOLVED = 1e-12  # the solution's last Chebyshev coefficients on a panel, as a share (1e-14 when resolved)


@dataclass(frozen=True)
class _Cheb:
    """Lobatto nodes x (n,) on [-1, 1], the cumulative integration matrix (n, n) from -1, the
    barycentric weights and the matrix (n, n) from nodal values to Chebyshev coefficients."""

    x: np.ndarray
    integrate: np.ndarray
    weights: np.ndarray
    to_coef: np.ndarray


def _cheb(n: int) -> _Cheb:
    x = -np.cos(np.pi * np.arange(n) / (n - 1))
    to_coef = np.linalg.inv(C.chebvander(x, n - 1))
    integ = np.zeros((n + 1, n))
    for j in range(n):
        e = np.zeros(n)
        e[j] = 1.0
        integ[:, j] = C.chebint(e, lbnd=-1.0)
    integrate = C.chebvander(x, n) @ integ @ to_coef
    w = np.where(np.arange(n) % 2 == 0, 1.0, -1.0)
    w[0] *= 0.5
    w[-1] *= 0.5
    return _Cheb(x, integrate, w, to_coef)


_CH = _cheb(NODES)


def _tail(values: np.ndarray) -> np.ndarray:
    """Size of the last two Chebyshev coefficients of nodal values (..., n) per panel."""
    coef = values @ _CH.to_coef[-2:].T
    return np.abs(coef).max(axis=-1)


@dataclass(kw_only=True)
class _Block:
    """One solved block: panel edges ``a``, ``b`` (p,) in s, nodal s, T, t, J (p, n), and the
    integrating factor's exponent over it (``decay``, 0 without damping)."""

    a: np.ndarray
    b: np.ndarray
    s: np.ndarray
    T: np.ndarray
    t: np.ndarray
    J: np.ndarray
    decay: float


class _Problem:
    """The equation in s: the series ``sd``, the start ``phi0``, the sense ``sigma`` (+1 or
    -1) and the drive's A and B (see :func:`solve`)."""

    def __init__(self, sd: SpectralDynamics, phi0: float, sigma: float, A: float, B: float):
        self.sd, self.phi0, self.sigma, self.A, self.B = sd, phi0, sigma, A, B
        self.period = float(sd.period)

    def fj(self, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """f and J at the angles turned s (any shape)."""
        J, _, Q = self.sd.evaluate(self.phi0 + self.sigma * s.ravel())
        return (self.sigma * (Q + self.A)).reshape(s.shape), J.reshape(s.shape)

    def panels(self, m: int) -> np.ndarray:
        """Edges (in s, over one period, from 0) of the periodic panel grid: ``m`` uniform
        panels at least, with every force table's corner added, doubled until f and J are
        resolved to TAIL."""
        breaks = []
        for f in self.sd.tables:  # forces given as tables: they have angles
            for ang in f.angles or ():
                breaks.append((self.sigma * (ang - self.phi0)) % self.period)
        while True:
            edges = np.unique(np.concatenate([np.linspace(0.0, self.period, m + 1), breaks]))
            edges = edges[np.concatenate([[True], np.diff(edges) > 1e-12 * self.period])]
            edges[-1] = self.period
            s = self._nodes(edges[:-1], edges[1:])
            f, J = self.fj(s)
            scale = np.abs(f).max() + 1e-300
            if ((_tail(f) <= TAIL * scale).all() and (_tail(J) <= TAIL * np.abs(J).max()).all()) or m >= 1 << 14:
                return edges
            m *= 2

    @staticmethod
    def _nodes(a: np.ndarray, b: np.ndarray) -> np.ndarray:
        return 0.5 * (a + b)[:, None] + 0.5 * (b - a)[:, None] * _CH.x[None, :]


def _cumulative(values: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """int from the block's start to every node of values (p, n), spectral on each panel."""
    within = (values @ _CH.integrate.T) * (0.5 * (b - a))[:, None]
    offsets = np.concatenate([[0.0], np.cumsum(within[:, -1])[:-1]])
    return within + offsets[:, None]


def _solve_block(
    prob: _Problem, a: np.ndarray, b: np.ndarray, f: np.ndarray, J: np.ndarray, T0: float, t0: float
) -> _Block | str:
    """Newton's method on T = T0 + int (f - B sqrt(2T/J)) ds over the panels a, b: the
    solved block, or why not ("decay": the integrating factor exceeds MAX_DECAY over the
    block; "stall": the crank would stop; "newton", "diverged")."""
    B = prob.B
    decay = 0.0
    s = _Problem._nodes(a, b)
    F = _cumulative(f, a, b)
    # A first guess, one panel at a time, stable however stiff the damping: the damping at
    # the panel's mean speed z (the mean of the end energies: J z^2 = T_start + T_end), so
    # that J z^2 + B w z - (2 T_start + int f) = 0 (w the panel's width).
    T = np.empty_like(f)
    start = T0
    Fp = F - np.concatenate([[0.0], F[:-1, -1]])[:, None]  # int of f from each panel's start
    for i in range(len(a)):
        width, Jm = b[i] - a[i], J[i, NODES // 2]
        c = max(2.0 * start + Fp[i, -1], 0.0)
        z = 2.0 * c / (B * width + math.sqrt((B * width) ** 2 + 4.0 * Jm * c)) if c > 0.0 else 0.0
        T[i] = start + Fp[i] - B * z * (s[i] - a[i])
        start = float(T[i, -1])
    T = np.maximum(T, 0.0)
    last = math.inf
    for _ in range(MAX_NEWTON):
        w = np.sqrt(2.0 * np.maximum(T, 0.0) / J)  # |omega|
        R = T0 + F - _cumulative(B * w, a, b) - T
        if B == 0.0:
            step = R
        else:
            with np.errstate(divide="ignore"):
                p = np.where(w > 0.0, B / (J * w), 0.0)
            P = _cumulative(p, a, b)
            decay = float(P.max())
            if decay > MAX_DECAY:
                return "decay"
            step = R - np.exp(-P) * _cumulative(p * np.exp(P) * R, a, b)
        T = T + step
        if not np.isfinite(T).all():
            return "diverged"
        size = np.abs(step).max() / max(np.abs(T).max(), 1e-300)
        # Converged: at rounding level, or no longer shrinking once near it (sums over
        # hundreds of panels round at some 1e-14 of the energy).
        if size <= NEWTON_TOL or (size < 1e-11 and size > 0.5 * last):
            break
        last = size
    else:
        return "newton"
    if (T <= 0.0).any():  # the crank would stop or turn back
        return "stall"
    rate = np.sqrt(J / (2.0 * T))  # dt/ds
    t = t0 + _cumulative(rate, a, b)
    # Resolved: the panels were sized for f and J, and the energy and dt/ds are smooth on
    # them too unless the speed changes faster than the crank turns through a panel (a
    # start in motion far below the steady speed under strong damping): their last
    # Chebyshev coefficients, as a share of the block's energy and duration, say so.
    span = float(t[-1, -1] - t[0, 0]) + 1e-300
    if (_tail(T) > RESOLVED * np.abs(T).max()).any() or (
        _tail(rate * (0.5 * (b - a))[:, None]) > RESOLVED * span
    ).any():
        return "resolution"
    return _Block(a=a, b=b, s=s, T=T, t=t, J=J, decay=decay)


def solve(
    sd: SpectralDynamics, phi0: float, omega0: float, A: float, B: float, t_eval: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """(phi, omega) at the times ``t_eval`` (s, increasing, from the initial state's time
    ``t_eval[0]``), or None where this method does not apply (see the module's note).

    Args:
      sd: the mechanism's :class:`~mjlink.reference.dynamics.SpectralDynamics`.
      phi0, omega0: initial angle (rad) and speed (rad/s).
      A: constant driving torque (N*m); B: its decrease per unit speed (N*m*s), the motor's
        slope plus the damping: the torque on the crank is Q(phi) + A - B omega.
      t_eval: (N,) times.
    Returns:
      (phi, omega, (J, J', Q)): (N,) rad, (N,) rad/s and (3, N) at those angles, or None.
    """
    t_eval = np.asarray(t_eval, dtype=float)
    J0, _, Q0 = (float(v[0]) for v in sd.evaluate([phi0]))
    if omega0 != 0.0:
        sigma = math.copysign(1.0, omega0)
    elif Q0 + A != 0.0:
        sigma = math.copysign(1.0, Q0 + A)
    else:
        return None
    prob = _Problem(sd, phi0, sigma, A, B)
    # Panels short enough for the damping's decay over one of them, B ds / (J omega), to stay
    # near 4 at the steady speed |A| / B (beyond, Newton's linear step, solved by an
    # integrating factor sampled on the panel's nodes, stops being exact and converging).
    m = 16
    if B > 0.0 and A != 0.0:
        J_min = float(sd.evaluate(phi0 + prob.period * np.arange(64) / 64)[0].min())
        m = max(m, 1 << max(0, math.ceil(math.log2(B * B * prob.period / (4.0 * J_min * abs(A))))))
    for _ in range(4):  # and finer again if Newton does not converge or the solution is not resolved
        out = _solve(prob, t_eval, J0, omega0, m)
        if out not in ("newton", "resolution"):
            return None if isinstance(out, str) else out
        m *= 2
    return None


def _solve(prob: _Problem, t_eval: np.ndarray, J0: float, omega0: float, m: int):
    edges = prob.panels(m)
    pa, pb = edges[:-1], edges[1:]
    fp, Jp = prob.fj(_Problem._nodes(pa, pb))
    per = len(pa)
    T0 = 0.5 * J0 * omega0 * omega0
    rest = T0 == 0.0
    t_now = float(t_eval[0])
    blocks: list[_Block] = []
    first, count = 0, per  # the next block: global panel indices first ... first + count - 1
    while t_now < t_eval[-1] or not blocks:
        turn, local = np.divmod(np.arange(first, first + count), per)
        a, b = pa[local] + turn * prob.period, pb[local] + turn * prob.period
        f, J = fp[local], Jp[local]
        T_start, t_start = T0, t_now
        if rest and first == 0:
            # From rest T grows like f(0) s and dt/ds like s^-1/2: panels refined geometrically
            # towards s = 0 take the first panel's place, and the stretch [0, a0] before them
            # (a0 = 2^-GRADED of a panel) is taken in closed form, T = f(0) s.
            f0 = float(prob.fj(np.zeros(1))[0][0])
            if f0 <= 0.0:
                return "stall"
            ends = b[0] * 0.5 ** np.arange(GRADED, -1, -1)
            ga, gb = ends[:-1], ends[1:]
            gf, gJ = prob.fj(_Problem._nodes(ga, gb))
            a, b = np.concatenate([ga, a[1:]]), np.concatenate([gb, b[1:]])
            f, J = np.concatenate([gf, f[1:]]), np.concatenate([gJ, J[1:]])
            T_start = f0 * a[0]
            t_start = t_now + 2.0 * math.sqrt(a[0] * J0 / (2.0 * f0))
        blk = _solve_block(prob, a, b, f, J, T_start, t_start)
        if blk == "decay" and count > 1:  # too stiff for one integrating factor: fewer panels
            count = max(1, count // 4)
            continue
        if not isinstance(blk, _Block):
            return blk
        blocks.append(blk)
        t_prev, t_now, T0 = t_now, float(blk.t[-1, -1]), float(blk.T[-1, -1])
        first += count
        # The next block: the panels the time left needs at this block's pace, within 64
        # turns and a quarter of the integrating factor's range.
        pace = (t_now - t_prev) / count
        need = math.ceil((t_eval[-1] - t_now) / max(pace, 1e-300)) + 1
        room = math.floor(0.25 * MAX_DECAY * count / max(blk.decay, 1e-300))
        count = int(max(1, min(64 * per, need, room)))
    return _evaluate(prob, blocks, t_eval, rest)


def _evaluate(prob: _Problem, blocks: list[_Block], t_eval: np.ndarray, rest: bool):
    a = np.concatenate([blk.a for blk in blocks])
    b = np.concatenate([blk.b for blk in blocks])
    T = np.concatenate([blk.T for blk in blocks])
    t = np.concatenate([blk.t for blk in blocks])
    J = np.concatenate([blk.J for blk in blocks])
    # Each time on the first panel that ends at or after it; Newton on that panel's t(s),
    # from the linear interpolation of time across it.
    k = np.clip(np.searchsorted(t[:, -1], t_eval), 0, len(a) - 1)
    ta, tb = t[k, 0], t[k, -1]
    w_nodes = np.sqrt(2.0 * T / J)
    frac = np.clip((t_eval - ta) / np.where(tb > ta, tb - ta, 1.0), 0.0, 1.0)
    s = a[k] + frac * (b[k] - a[k])
    for _ in range(30):
        x = (2.0 * s - a[k] - b[k]) / (b[k] - a[k])
        miss = _bary(x, t[k]) - t_eval
        s = np.clip(s - miss * _bary(x, w_nodes[k]), a[k], b[k])
        if (np.abs(miss) <= 1e-15 * np.maximum(np.abs(t_eval), tb - ta)).all():
            break
    x = (2.0 * s - a[k] - b[k]) / (b[k] - a[k])
    Ts = _bary(x, T[k])
    early = t_eval < t[0, 0]
    if rest and early.any():  # before the first node: T = f0 s, t - t_start = 2 sqrt(s J0 / (2 f0))
        f0, J0 = (float(v[0]) for v in prob.fj(np.zeros(1)))
        dt = t_eval[early] - t_eval[0]
        s[early] = dt**2 * f0 / (2.0 * J0)
        Ts[early] = f0 * s[early]
    phi = prob.phi0 + prob.sigma * s
    vals = prob.sd.evaluate(phi)
    omega = prob.sigma * np.sqrt(2.0 * np.maximum(Ts, 0.0) / vals[0])
    return phi, omega, vals


def _bary(x: np.ndarray, values: np.ndarray) -> np.ndarray:
    """Barycentric interpolation at x (N,) in [-1, 1] of nodal values (N, n) on the Lobatto nodes."""
    d = x[:, None] - _CH.x[None, :]
    exact = d == 0.0
    d = np.where(exact, 1.0, d)
    q = _CH.weights[None, :] / d
    out = (q * values).sum(axis=1) / q.sum(axis=1)
    hit = exact.any(axis=1)
    if hit.any():
        out[hit] = values[hit][exact[hit]]
    return out
