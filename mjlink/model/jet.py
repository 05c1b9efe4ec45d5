"""Second-order jets: a value with its exact first and second derivatives.

The building blocks are written once, in terms of these, and so give positions together
with their exact derivatives with respect to the input crank angle phi (chain rule applied
operation by operation, no finite differences). Everything is vectorized: a scalar jet holds
arrays of shape (N,), a vector jet arrays of shape (N, 3).
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from contextvars import ContextVar
from dataclasses import dataclass

import numpy as np


def norms(v: np.ndarray) -> np.ndarray:
    """Euclidean length of every vector along the last axis of the array ``v`` (..., k), in
    ``v``'s unit: (...). Bit for bit ``np.linalg.norm(v, axis=-1)``, at a sixth of its time for
    k = 2 or 3.

    norm squares ``v`` into a temporary and reduces it along the short last axis, which numpy
    does an element at a time; the same sum written out column by column, ((x*x + y*y) + z*z)
    rounded at every step as the reduction does, is three whole-array multiplications and two
    additions. The agreement's errors, the loop
    gaps and the rigidity check are such lengths, several per named point and run. The plain
    twin is the numpy call (tested on ordinary, huge, tiny and non-finite values).
    """
    v = np.asarray(v, dtype=float)
    if v.ndim < 2 or v.shape[-1] not in (2, 3):
        return np.linalg.norm(v, axis=-1)
    x = v[..., 0]
    s = x * x
    for k in range(1, v.shape[-1]):
        c = v[..., k]
        s += c * c
    return np.sqrt(s, out=s)


@dataclass(frozen=True)
class S:
    """Scalar jet: ``v`` value, ``d`` = dv/dphi, ``dd`` = d2v/dphi2; arrays of shape (N,)."""

    v: np.ndarray
    d: np.ndarray
    dd: np.ndarray

    # Numpy must defer to the jet's reflected operators: ``array / jet`` would otherwise build
    # an object array of jets (one per element), which is slow and huge. Block parameters are
    # arrays when a design study stacks variants into rows.
    __array_ufunc__ = None

    def __add__(self, o: S | float | np.ndarray) -> S:
        if isinstance(o, S):
            return S(self.v + o.v, self.d + o.d, self.dd + o.dd)
        return S(self.v + o, self.d, self.dd)

    __radd__ = __add__

    def __neg__(self) -> S:
        return S(-self.v, -self.d, -self.dd)

    def __sub__(self, o: S | float) -> S:
        return self + (-o)

    def __rsub__(self, o: float) -> S:
        return (-self) + o

    def __mul__(self, o: S | float) -> S:
        if isinstance(o, S):
            return S(self.v * o.v, self.d * o.v + self.v * o.d, self.dd * o.v + 2.0 * self.d * o.d + self.v * o.dd)
        return S(self.v * o, self.d * o, self.dd * o)

    __rmul__ = __mul__

    def __truediv__(self, o: S | float) -> S:
        if not isinstance(o, S):
            return self * (1.0 / o)
        q = self.v / o.v
        dq = (self.d - q * o.d) / o.v
        return S(q, dq, (self.dd - 2.0 * dq * o.d - q * o.dd) / o.v)

    def __rtruediv__(self, o: float) -> S:
        q = o / self.v
        dq = -q * self.d / self.v
        return S(q, dq, (-2.0 * dq * self.d - q * self.dd) / self.v)

    def chain(self, f: np.ndarray, df: np.ndarray, ddf: np.ndarray) -> S:
        """g(self) given g, g', g'' evaluated at self.v."""
        return S(f, df * self.d, ddf * self.d**2 + df * self.dd)


def sqrt(a: S) -> S:
    r = np.sqrt(a.v)
    return a.chain(r, 0.5 / r, -0.25 / (r * a.v))


def _cx(x, y) -> np.ndarray:
    """Complex array x + i y without the temporaries of ``x + 1j * y``."""
    x, y = np.broadcast_arrays(np.asarray(x, dtype=float), np.asarray(y, dtype=float))
    out = np.empty(x.shape, dtype=complex)
    out.real = x
    out.imag = y
    return out


def _re_conj(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Re(a conj(b)) = a.x b.x + a.y b.y, the in-plane dot product of complex points."""
    return a.real * b.real + a.imag * b.imag


class V:
    """Vector jet: a point (N, 3) with its first and second derivatives in phi.

    The in-plane part is held as complex numbers (x + i y), which makes the rotations the
    blocks are made of one complex product each; the z part separately (a float where it is
    the same for every row, as for planar points). ``v``, ``d`` and ``dd`` give the (N, 3)
    arrays (m, m/rad, m/rad^2).
    """

    __slots__ = ("_xyz", "c", "cd", "cdd", "z", "zd", "zdd")
    # Numpy must defer to the jet's reflected operators (see S).
    __array_ufunc__ = None

    def __init__(self, c: np.ndarray, cd: np.ndarray, cdd: np.ndarray, z=0.0, zd=0.0, zdd=0.0):
        self.c, self.cd, self.cdd = c, cd, cdd
        self.z, self.zd, self.zdd = z, zd, zdd
        self._xyz: dict[str, np.ndarray] = {}

    @classmethod
    def from_xyz(cls, v: np.ndarray, d: np.ndarray, dd: np.ndarray) -> V:
        """From (N, 3) value, first and second derivative."""
        return cls(_cx(v[:, 0], v[:, 1]), _cx(d[:, 0], d[:, 1]), _cx(dd[:, 0], dd[:, 1]), v[:, 2], d[:, 2], dd[:, 2])

    def _stack(self, key: str, c: np.ndarray, z) -> np.ndarray:
        out = self._xyz.get(key)
        if out is None:
            out = np.empty((len(c), 3))
            out[:, 0] = c.real
            out[:, 1] = c.imag
            out[:, 2] = z
            self._xyz[key] = out
        return out

    @property
    def v(self) -> np.ndarray:
        """(N, 3) m."""
        return self._stack("v", self.c, self.z)

    @property
    def d(self) -> np.ndarray:
        """(N, 3) m/rad."""
        return self._stack("d", self.cd, self.zd)

    @property
    def dd(self) -> np.ndarray:
        """(N, 3) m/rad^2."""
        return self._stack("dd", self.cdd, self.zdd)

    def __add__(self, o: V) -> V:
        return V(self.c + o.c, self.cd + o.cd, self.cdd + o.cdd, self.z + o.z, self.zd + o.zd, self.zdd + o.zdd)

    def __sub__(self, o: V) -> V:
        return V(self.c - o.c, self.cd - o.cd, self.cdd - o.cdd, self.z - o.z, self.zd - o.zd, self.zdd - o.zdd)

    def scale(self, s: S) -> V:
        a, b, e = s.v, s.d, s.dd
        return V(
            self.c * a,
            self.cd * a + self.c * b,
            self.cdd * a + 2.0 * self.cd * b + self.c * e,
            self.z * a,
            self.zd * a + self.z * b,
            self.zdd * a + 2.0 * self.zd * b + self.z * e,
        )

    def dot(self, o: V) -> S:
        if o is self:
            return self._square()
        v = _re_conj(self.c, o.c) + self.z * o.z
        d = _re_conj(self.cd, o.c) + _re_conj(self.c, o.cd) + self.zd * o.z + self.z * o.zd
        dd = (
            _re_conj(self.cdd, o.c)
            + 2.0 * _re_conj(self.cd, o.cd)
            + _re_conj(self.c, o.cdd)
            + self.zdd * o.z
            + 2.0 * self.zd * o.zd
            + self.z * o.zdd
        )
        n = len(self.c)
        return S(*(np.broadcast_to(x, (n,)) if np.ndim(x) == 0 else x for x in (v, d, dd)))

    def _square(self) -> S:
        v = _re_conj(self.c, self.c) + self.z * self.z
        d = 2.0 * (_re_conj(self.cd, self.c) + self.zd * self.z)
        dd = 2.0 * (_re_conj(self.cdd, self.c) + _re_conj(self.cd, self.cd) + self.zdd * self.z + self.zd * self.zd)
        return S(v, d, dd)

    def norm(self) -> S:
        return sqrt(self._square())

    def planar(self) -> V:
        """The in-plane part (z set to zero)."""
        return V(self.c, self.cd, self.cdd)

    def with_z(self, z) -> V:
        """The same in-plane motion at the fixed height ``z`` (m; scalar or (N,))."""
        return V(self.c, self.cd, self.cdd, z)


def vconst(p: np.ndarray, n: int) -> V:
    """Constant point: ``p`` (3,) or (n, 3), m."""
    p = np.asarray(p, dtype=float)
    z = np.zeros(n, dtype=complex)
    c = np.broadcast_to(_cx(p[..., 0], p[..., 1]), (n,))
    return V(c, z, z, p[..., 2] if p.ndim == 2 else float(p[2]))


def polar(length, a: S) -> V:
    """The in-plane vector ``length`` e^(i a) with its derivatives (length m: a float, or one
    per row; a rad). The derivatives turn the value by 90 deg in real arithmetic, (i a') c and
    (i a'' - a'^2) c, which is cheaper than complex products with a purely imaginary factor."""
    c = _cx(np.cos(a.v), np.sin(a.v))
    c *= length
    x, y, ad, add = c.real, c.imag, a.d, a.dd
    ad2 = ad * ad
    return V(c, _cx(-ad * y, ad * x), _cx(-ad2 * x - add * y, add * x - ad2 * y))


def turn(p: V, cos_a: S, sign: float) -> V:
    """R(a) p about Z for the angle a whose cosine is ``cos_a`` and whose sine has the sign of
    ``sign``: e^(i a) = cos a + i sign sqrt(1 - cos^2 a), with its derivatives from
    sin^2 + cos^2 = 1 (sin' = -cos cos' / sin, sin'' = -(sin'^2 + cos'^2 + cos cos'') / sin).
    The same rotation as through arccos, cos and sin, without those three passes; infinite
    derivatives where sin a = 0 (a dead point), as through arccos."""
    w, wd, wdd = cos_a.v, cos_a.d, cos_a.dd
    s = sign * np.sqrt(1.0 - w * w)
    sd = -w * wd / s
    sdd = -(sd * sd + wd * wd + w * wdd) / s
    e, ed, edd = _cx(w, s), _cx(wd, sd), _cx(wdd, sdd)
    return V(p.c * e, p.cd * e + p.c * ed, p.cdd * e + 2.0 * p.cd * ed + p.c * edd, p.z, p.zd, p.zdd)


# Unit directions computed during the current solve (see :func:`sharing`), by the identity of
# the two points: (a, b, unit from a to b).
_DIRECTIONS: ContextVar[dict[tuple[int, int], tuple[V, V, V]] | None] = ContextVar("directions", default=None)


@contextmanager
def sharing() -> Iterator[None]:
    """Within the block, :func:`direction` computes the unit vector between two given point
    jets once, however many blocks ask for it (a link carrying many named points attaches them
    all to one pair of its points), and forgets it at the end: nothing outlives the solve."""
    token = _DIRECTIONS.set({})
    try:
        yield
    finally:
        _DIRECTIONS.reset(token)


def direction(a: V, b: V) -> V:
    """The in-plane unit vector from ``a`` to ``b`` with its derivatives (shared within
    :func:`sharing`)."""
    memo = _DIRECTIONS.get()
    key = (id(a), id(b))
    if memo is not None and key in memo:
        return memo[key][2]
    d = (b - a).planar()
    u = d.scale(1.0 / d.norm())
    if memo is not None:
        memo[key] = (a, b, u)  # the points held too: their ids cannot be reused meanwhile
    return u


def rotate_fixed(p: V, angle, length=1.0) -> V:
    """``length`` R(angle) p about Z for a fixed angle (rad: a float, or one per row) and
    factor (a float, or one per row): the derivatives are rotated and scaled with the vector
    and the angle adds none."""
    e = length * (np.cos(angle) + 1j * np.sin(angle))
    return V(p.c * e, p.cd * e, p.cdd * e, p.z, p.zd, p.zdd)


def angle(p: V) -> S:
    """Direction angle atan2(y, x) of the in-plane part of p, rad in (-pi, pi]."""
    c, cd, cdd = p.c, p.cd, p.cdd
    r2 = _re_conj(c, c)
    num = c.real * cd.imag - c.imag * cd.real  # x y' - y x'
    dnum = c.real * cdd.imag - c.imag * cdd.real
    dr2 = 2.0 * _re_conj(cd, c)
    d = num / r2
    return S(np.arctan2(c.imag, c.real), d, (dnum - d * dr2) / r2)
