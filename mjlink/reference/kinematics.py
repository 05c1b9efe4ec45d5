"""The vector-method reference kinematics: the papers' analysis, exact and vectorized.

The building blocks (:mod:`mjlink.model.blocks`) are composed in the file's order on jets
(:mod:`mjlink.model.jet`), so every point comes with its exact first and second derivatives
with respect to the input angle phi. Velocities and accelerations follow as
``v = P' omega`` and ``a = P'' omega^2 + P' eps``. Each block also reports its closure
margin, from which the assembly ranges follow.

All quantities SI (m, rad).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field

import numpy as np

from ..errors import AssemblyError, MechanismFileError
from ..model import jet
from ..model.blocks import Attached, Block
from ..model.mechanism import COUNTERWEIGHT, Link, Mechanism


def link_angle(points: dict[str, jet.V], link: Link) -> jet.S:
    """Angle of a link: of its guide line if it slides, else of its first two points."""
    a, b = link.direction
    return jet.angle((points[b] - points[a]).planar())


# ------------------------------------------------------------------------------ kinematics
@dataclass(frozen=True)
class Kinematics:
    """Reference positions of every point over an array of input angles.

    ``phi`` (N,) rad; ``points[name]`` and ``angles[link]`` are jets: value, first and
    second derivative with respect to phi (m, m/rad, m/rad^2; rad, -, 1/rad); ``margins[point]``
    each closing block's margin (>= 0 where it assembles).
    """

    mechanism: Mechanism
    phi: np.ndarray
    points: dict[str, jet.V]
    angles: dict[str, jet.S]
    margins: dict[str, np.ndarray] = field(default_factory=dict)

    def assembles(self) -> np.ndarray:
        """(N,) bool: every block closes (its margin is >= 0) at that angle."""
        ok = np.ones(len(self.phi), dtype=bool)
        for m in self.margins.values():
            ok &= m >= 0.0
        return ok

    def positions(self) -> dict[str, np.ndarray]:
        """Every point's (N, 3) positions, m."""
        return {k: v.v for k, v in self.points.items()}

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
        for a, b in itertools.pairwise(path):
            seg = (self.points[b] - self.points[a]).norm()
            total = seg if total is None else total + seg
        return total


def angle_ranges(phi: np.ndarray, bad: np.ndarray, period: float | None = None) -> str:
    """Human-readable input-angle ranges (deg) where ``bad`` holds, at the angles ``phi`` (rad).

    With the mechanism's ``period`` (rad) the ranges are given within one period from 0, in
    order, whatever ``phi`` starts at: where ``phi`` covers the whole period a range that runs
    through its start is one range, and one that runs through 0 is written as its two parts
    ("0.0..10.0, 350.0..360.0")."""
    deg = np.degrees(phi)
    spans: list[list[int]] = []
    start = None
    for i, b in enumerate(bad):
        if b and start is None:
            start = i
        if (not b or i == len(bad) - 1) and start is not None:
            spans.append([start, i if b else i - 1])
            start = None
    if period is None:
        parts = [(float(deg[a]), float(deg[b])) for a, b in spans]
    else:
        p = math.degrees(period)
        shown = deg % p
        shown[np.abs(shown - p) < 1e-9] = 0.0
        whole = abs(abs(deg[-1] - deg[0]) - p) < 1e-9 * p
        if whole and len(spans) > 1 and spans[0][0] == 0 and spans[-1][1] == len(bad) - 1:
            spans[0][0] = spans.pop()[0]
        parts = []
        for a, b in spans:
            lo, hi = float(shown[a]), float(shown[b])
            parts += [(lo, hi)] if lo <= hi or a == b else [(0.0, hi), (lo, p)]
        parts.sort()
    out = [f"{lo:.1f}..{hi:.1f}" for lo, hi in parts]
    return ", ".join(out[:6]) + (" ..." if len(out) > 6 else "")


def solve(mech: Mechanism, phi, *, check: bool = True, only: Iterable[str] | None = None) -> Kinematics:
    """Positions and exact derivatives of every point at the input angles ``phi`` (rad).

    Raises AssemblyError naming the block and the angle ranges where it cannot close
    (unless ``check`` is False, when such angles give clipped, meaningless values).

    ``only``: the points the caller reads (None: all of them). Then only the blocks those
    points, the links' angles and the counterweight are built from are solved, and
    ``points`` holds just these (the ground's always); a named point drawn or traced but
    carrying no load costs the dynamics and kinetostatics nothing.
    """
    phi = np.atleast_1d(np.asarray(phi, dtype=float))
    steps = mech.steps if only is None else _steps_for(mech, only)
    if not check:  # unassemblable angles are expected here and give NaN derivatives
        with np.errstate(all="ignore"):
            return _solve(mech, phi, False, steps)
    return _solve(mech, phi, True, steps)


def _steps_for(mech: Mechanism, only: Iterable[str]) -> tuple[Block, ...]:
    """The blocks, in the file's order, that the points ``only`` depend on, with those the
    links' angles and the counterweight are measured from."""
    need = set(only)
    for l in mech.links:
        need.update(l.direction)
    if mech.counterweight is not None:
        need.update((mech.input_crank.pivot, mech.input_crank.point))
    out = []
    for s in reversed(mech.steps):
        if s.point in need:
            need.update(s.inputs)
            out.append(s)
    return tuple(reversed(out))


def _solve(mech: Mechanism, phi: np.ndarray, check: bool, steps: Sequence[Block]) -> Kinematics:
    n = len(phi)
    pts: dict[str, jet.V] = {k: jet.vconst(v, n) for k, v in mech.ground.items()}
    inp = jet.S(phi, np.ones(n), np.zeros(n))
    margins: dict[str, np.ndarray] = {}
    with jet.sharing():  # points attached to one pair of points share its direction
        for s in steps:
            solved = s.solve(pts, inp, mech.phi0)
            pts[s.point] = solved.point
            if solved.margin is not None:
                margins[s.point] = solved.margin
                bad = ~(solved.margin >= 0.0)
                if check and bad.any():
                    raise AssemblyError(s.cannot_close(mech.name, angle_ranges(phi, bad)))
    cw = mech.counterweight
    if cw is not None:  # a point mass on the input crank, placed as an attached point
        crank = mech.input_crank
        block = Attached(COUNTERWEIGHT, crank.pivot, crank.point, cw.angle, cw.radius)
        pts[COUNTERWEIGHT] = block.solve(pts, inp, mech.phi0).point
    angles = {l.name: link_angle(pts, l) for l in mech.links}
    return Kinematics(mech, phi, pts, angles, margins)


def check_rigidity(mech: Mechanism, samples: int = 361, rtol: float = 1e-9, kin: Kinematics | None = None) -> None:
    """Every link's points must keep their distances (and a sliding link its guide's angle),
    at ``samples`` input angles over the period.

    ``kin``: the reference over the period, solved already (the file check's, at more angles:
    every k-th of them is used), else solved here. Catches files whose construction
    contradicts their link lists. Raises MechanismFileError.
    """
    if kin is None:
        kin = solve(mech, mech.phi0 + np.linspace(0.0, mech.period, samples, endpoint=False))
    every = max(1, len(kin.phi) // samples)
    src = mech.path or mech.name
    for l in mech.links:
        # Each point against all later ones at once: a link carrying many named points would
        # otherwise cost a Python pass per pair, quadratic in its points.
        xyz = np.stack([kin.points[a].v[::every] for a in l.points])
        for i in range(len(xyz) - 1):
            d = jet.norms(xyz[i + 1 :] - xyz[i])
            hi, lo = d.max(axis=1), d.min(axis=1)
            loose = np.flatnonzero(hi - lo > rtol * np.maximum(hi, 1e-3))
            if len(loose):
                j = loose[0]
                raise MechanismFileError(
                    f"{src}: [links.{l.name}]: points {l.points[i]} and {l.points[i + 1 + j]} do not stay at a "
                    f"fixed distance ({lo[j] * 1e3:.4f}..{hi[j] * 1e3:.4f} mm): they are not on one rigid link"
                )
        if len(l.points) >= 2 and l.guide:
            own = jet.angle((kin.points[l.points[1]] - kin.points[l.points[0]]).planar()).v
            ref = kin.angles[l.name].v
            dev = np.abs(np.angle(np.exp(1j * (own - ref)) / np.exp(1j * (own[0] - ref[0]))))
            if dev.max() > 1e-9:
                raise MechanismFileError(
                    f"{src}: [links.{l.name}]: slides on {l.guide[0]}-{l.guide[1]} but turns relative to that guide"
                )
