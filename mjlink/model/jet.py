"""Second-order jets: a value with its exact first and second derivatives.

The building blocks are written once, in terms of these, and so give positions together
with their exact derivatives with respect to the input crank angle phi (chain rule applied
operation by operation, no finite differences). Everything is vectorized: a scalar jet holds
arrays of shape (N,), a vector jet arrays of shape (N, 3).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class S:
    """Scalar jet: ``v`` value, ``d`` = dv/dphi, ``dd`` = d2v/dphi2; arrays of shape (N,)."""

    v: np.ndarray
    d: np.ndarray
    dd: np.ndarray

    def __add__(self, o: S | float) -> S:
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


def const(v, n: int) -> S:
    v = np.broadcast_to(np.asarray(v, dtype=float), (n,))
    z = np.zeros(n)
    return S(v, z, z)


def sqrt(a: S) -> S:
    r = np.sqrt(a.v)
    return a.chain(r, 0.5 / r, -0.25 / (r * a.v))


def cos(a: S) -> S:
    c, s = np.cos(a.v), np.sin(a.v)
    return a.chain(c, -s, -c)


def sin(a: S) -> S:
    c, s = np.cos(a.v), np.sin(a.v)
    return a.chain(s, c, -s)


def arccos(a: S) -> S:
    w = 1.0 - a.v**2
    r = np.sqrt(w)
    return a.chain(np.arccos(a.v), -1.0 / r, -a.v / (w * r))


@dataclass(frozen=True)
class V:
    """Vector jet: point ``v`` (N, 3) with ``d`` = dv/dphi and ``dd`` = d2v/dphi2."""

    v: np.ndarray
    d: np.ndarray
    dd: np.ndarray

    def __add__(self, o: V) -> V:
        return V(self.v + o.v, self.d + o.d, self.dd + o.dd)

    def __sub__(self, o: V) -> V:
        return V(self.v - o.v, self.d - o.d, self.dd - o.dd)

    def scale(self, s: S) -> V:
        a, b = s.v[:, None], s.d[:, None]
        return V(self.v * a, self.d * a + self.v * b, self.dd * a + 2.0 * self.d * b + self.v * s.dd[:, None])

    def dot(self, o: V) -> S:
        return S(
            np.einsum("ij,ij->i", self.v, o.v),
            np.einsum("ij,ij->i", self.d, o.v) + np.einsum("ij,ij->i", self.v, o.d),
            np.einsum("ij,ij->i", self.dd, o.v)
            + 2.0 * np.einsum("ij,ij->i", self.d, o.d)
            + np.einsum("ij,ij->i", self.v, o.dd),
        )

    def norm(self) -> S:
        return sqrt(self.dot(self))

    def planar(self) -> V:
        """The in-plane part (z set to zero)."""
        m = np.array([1.0, 1.0, 0.0])
        return V(self.v * m, self.d * m, self.dd * m)

    def with_z(self, z: float) -> V:
        v = self.v.copy()
        v[:, 2] = z
        d, dd = self.d.copy(), self.dd.copy()
        d[:, 2] = 0.0
        dd[:, 2] = 0.0
        return V(v, d, dd)


def vconst(p: np.ndarray, n: int) -> V:
    v = np.broadcast_to(np.asarray(p, dtype=float), (n, 3)).copy()
    z = np.zeros((n, 3))
    return V(v, z, z)


def _rot(v: np.ndarray, c: np.ndarray, s: np.ndarray) -> np.ndarray:
    """Rotate the xy part of (N, 3) rows by the angle with cosine c, sine s; z unchanged."""
    out = np.empty_like(v)
    out[:, 0] = c * v[:, 0] - s * v[:, 1]
    out[:, 1] = s * v[:, 0] + c * v[:, 1]
    out[:, 2] = v[:, 2]
    return out


def _perp(v: np.ndarray) -> np.ndarray:
    """In-plane rotation by +90 deg; z dropped (the derivative of a rotation has no z part)."""
    out = np.zeros_like(v)
    out[:, 0] = -v[:, 1]
    out[:, 1] = v[:, 0]
    return out


def rotate(p: V, a: S) -> V:
    """R(a) p about Z, with the derivatives of both the vector and the angle."""
    c, s = np.cos(a.v), np.sin(a.v)
    rv, rd, rdd = _rot(p.v, c, s), _rot(p.d, c, s), _rot(p.dd, c, s)
    ad, add = a.d[:, None], a.dd[:, None]
    return V(
        rv, rd + ad * _perp(rv), rdd + 2.0 * ad * _perp(rd) + add * _perp(rv) - ad**2 * rv * np.array([1.0, 1.0, 0.0])
    )


def angle(p: V) -> S:
    """Direction angle atan2(y, x) of the in-plane part of p, rad in (-pi, pi]."""
    x, y = p.v[:, 0], p.v[:, 1]
    xd, yd = p.d[:, 0], p.d[:, 1]
    xdd, ydd = p.dd[:, 0], p.dd[:, 1]
    r2 = x * x + y * y
    num = x * yd - y * xd
    dnum = x * ydd - y * xdd
    dr2 = 2.0 * (x * xd + y * yd)
    d = num / r2
    return S(np.arctan2(y, x), d, (dnum - d * dr2) / r2)
