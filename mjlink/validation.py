"""Validation: whether a mechanism can be simulated faithfully, and what it is.

:func:`validate` runs, in this order, the checks that need the geometry over a whole cycle
(the file's own syntax and references are checked when it is read): assembly over the input
crank's full period, no undefined directions, rigid links, one degree of freedom, no pass
near a dead point, a reduced moment of inertia that never vanishes, and a model MuJoCo
compiles. :func:`problems` lists every failing one instead of raising the first.

:func:`check` describes a loaded mechanism without raising for geometric problems: its
points and links, the kinematic pairs the MuJoCo model is built from (tree joints and
loop-closing equalities), gear couplings, the Chebyshev-Gruebler count of degrees of
freedom, the input-angle ranges over which it can be assembled, how near every dyad and
slider comes to a dead point, and every problem :func:`validate` would raise;
:meth:`CheckReport.raise_if_failed` then raises the first problem (one line), so a file that
cannot be simulated is still described before the command fails.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from . import reference
from .analysis import intent
from .analysis.timing import HeadTiming, head_timing
from .errors import AssemblyError, MechanismFileError, MjlinkError, SimulationError, UnknownMechanismError
from .model import catalogue
from .model.blocks import BlockAngle
from .model.describe import feed_lines, thread_lines
from .model.jet import norms
from .model.limits import (
    MAX_ANGLE_DEG,
    MIN_DIRECTION_M,
    MIN_DISTINCT_M,
    SAMPLES_PER_TURN,
    VERIFIED_CRANK_ACCELERATION,
    VERIFIED_SPEED,
    above,
)
from .model.mechanism import Mechanism, load
from .model.topology import pairs as all_pairs
from .model.topology import topology
from .units import PairKind, PairRole

_ERRORS = {
    c.__name__: c for c in (AssemblyError, MechanismFileError, SimulationError, UnknownMechanismError, MjlinkError)
}


def get(name_or_path: str | Path, *, full_turn: bool = True) -> Mechanism:
    """Load and validate a mechanism; with ``full_turn`` its input crank must turn fully.

    Raises MechanismFileError, UnknownMechanismError or AssemblyError with a one-line message.
    """
    return validate(load(catalogue.path_of(name_or_path)), full_turn=full_turn)


def validate(mech: Mechanism, *, full_turn: bool = True) -> Mechanism:
    """The checks of :func:`get` for a mechanism built in code; raises the first problem.

    With ``full_turn`` False a linkage that assembles only over part of the input's turn
    passes (``check`` then reports its ranges); the checks that need the whole cycle are
    skipped for it.
    """
    found = problems(mech, full_turn=full_turn)
    if found:
        raise found[0]
    return mech


# --------------------------------------------------------------------------- angles at joints


def cycle_angles(mech: Mechanism, samples: int | None = None) -> np.ndarray:
    """Input angles (rad) over one period from phi0, SAMPLES_PER_TURN per turn, both ends included."""
    turns = max(1, round(mech.period / (2 * math.pi)))
    n = samples or SAMPLES_PER_TURN * turns + 1
    return mech.phi0 + np.linspace(0.0, mech.period, n)


def block_angles(mech: Mechanism, kin: reference.Kinematics | None = None) -> tuple[BlockAngle, ...]:
    """Transmission angle of every dyad and pressure angle of every slider over the period.

    Evaluated at the same samples as the assembly check, only where the linkage assembles.
    """
    if kin is None:
        kin = reference.solve(mech, cycle_angles(mech), check=False)
    phi = kin.phi
    P = kin.positions()
    out = []
    for s in mech.steps:
        dp = s.dead_point(P)
        if dp is None:
            continue
        margin = dp.margin_deg
        closes = dp.closes & np.isfinite(margin)
        if closes.any():
            i = int(np.argmin(np.where(closes, margin, np.inf)))
            worst, mg, at = float(dp.value_deg[i]), float(margin[i]), _wrap(mech, phi[i])
        else:
            worst = mg = at = math.nan
        fails = reference.angle_ranges(phi, ~closes, mech.period) if not closes.all() else ""
        out.append(
            BlockAngle(
                kind=s.kind,
                point=s.point,
                label=s.label(),
                links=s.carriers(mech.links),
                quantity=dp.quantity,
                worst_deg=worst,
                margin_deg=mg,
                phi_deg=at,
                limit_deg=dp.limit_deg,
                closes=bool(closes.all()),
                fails_deg=fails,
                block=s,
                required_margin_deg=dp.required_margin_deg,
            )
        )
    return tuple(out)


def _wrap(mech: Mechanism, phi: float) -> float:
    """An input angle in deg, within [0, period)."""
    p = math.degrees(mech.period)
    v = math.degrees(phi) % p
    return 0.0 if abs(v - p) < 1e-9 else v


# --------------------------------------------------------------------------- degrees of freedom
@dataclass(frozen=True, kw_only=True)
class Mobility:
    """Degrees of freedom: the Chebyshev-Gruebler count ``W = 3 n - 2 p``, backed by the rank
    of the constraint Jacobian.

    ``moving_links`` n; ``revolute`` pairs: at every point, (bodies meeting there) - 1, the
    ground counting as a body at a [ground] point (so k links pinned together make k - 1
    pairs); ``prismatic`` pairs: one per link with a ``guide``; ``structural`` W; ``gears``
    geared cranks, each tying its crank to the input (one more constraint); ``driven`` =
    W - gears, the count's degrees of freedom of the whole machine.

    The count can balance a free sub-chain against a redundant one (a free-spinning flap and a
    doubled rocker give W = 1), so the constraints themselves are linearized about generic
    positions (link poses x, y, theta; two rows per revolute pair, two per prismatic pair, one
    per gear): ``actual`` = 3 n - rank is the true number of degrees of freedom, ``free`` the
    links that still move with the input crank held, ``redundant`` the pairs whose
    constraints repeat others. A sound mechanism file has ``actual`` 1, nothing free and
    nothing redundant: the input crank's angle drives everything, and no loop closure fights
    another in MuJoCo.
    """

    moving_links: int
    revolute: int
    prismatic: int
    gears: int
    actual: int = 1
    free: tuple[str, ...] = ()
    redundant: tuple[str, ...] = ()

    @property
    def lower_pairs(self) -> int:
        return self.revolute + self.prismatic

    @property
    def structural(self) -> int:
        return 3 * self.moving_links - 2 * self.lower_pairs

    @property
    def driven(self) -> int:
        return self.structural - self.gears

    @property
    def sound(self) -> bool:
        return self.actual == 1 and not self.free and not self.redundant


def mobility(mech: Mechanism, kin: reference.Kinematics | None = None) -> Mobility:
    """Count links, lower pairs and gear couplings, and check the count against the rank of the
    constraint Jacobian (see :class:`Mobility`); ``kin`` the reference over the cycle if it is
    solved already."""
    bodies: dict[str, int] = {}
    for l in mech.links:
        for p in l.points:
            bodies[p] = bodies.get(p, 0) + 1
    revolute = sum(k + (1 if p in mech.ground else 0) - 1 for p, k in bodies.items())
    prismatic = sum(1 for l in mech.links if l.guide)
    gears = len(mech.geared)
    count = Mobility(moving_links=len(mech.links), revolute=revolute, prismatic=prismatic, gears=gears)
    try:
        actual, free, redundant = _rank_mobility(mech, kin)
    except (MechanismFileError, AssemblyError, KeyError, StopIteration, IndexError):
        return count  # a structure the tree or the solver refuses is reported by those checks
    return dataclasses.replace(count, actual=actual, free=free, redundant=redundant)


RANK_TOL = 1e-9  # singular values below this fraction of the largest are zero


def _rank_mobility(
    mech: Mechanism, kin: reference.Kinematics | None = None
) -> tuple[int, tuple[str, ...], tuple[str, ...]]:
    """(3 n - rank, links free with the input held, redundant pairs) from the constraints
    linearized at three generic input angles (the largest rank: a special position can lose
    some)."""
    with np.errstate(all="ignore"):
        if kin is None:
            kin = reference.solve(mech, cycle_angles(mech, 721), check=False)
        ok = np.flatnonzero(kin.assembles() & np.all([np.isfinite(v.v).all(axis=1) for v in kin.points.values()], 0))
    if not len(ok):
        raise AssemblyError("no assembled position")
    picks = ok[[len(ok) * 13 // 100, len(ok) * 47 // 100, len(ok) * 81 // 100]]
    best: tuple[int, np.ndarray, list[tuple[str, int]]] | None = None
    for i in picks:
        J, rows = _constraint_jacobian(mech, kin, int(i))
        r = int(np.linalg.matrix_rank(J, tol=RANK_TOL * max(float(np.linalg.norm(J, 2)), 1e-300)))
        if best is None or r > best[0]:
            best = (r, J, rows)
    assert best is not None
    rank, J, rows = best
    n = len(mech.links)
    tol = RANK_TOL * max(float(np.linalg.norm(J, 2)), 1e-300)
    # Redundant pairs: adding their rows in order leaves the rank where it was.
    redundant: list[str] = []
    start, have = 0, 0
    for label, k in rows:
        r = int(np.linalg.matrix_rank(J[: start + k], tol=tol)) if start + k else 0
        if r < have + k:
            redundant.append(label)
        have, start = r, start + k
    # Free links: what the null space moves with the input crank's angle held.
    held = np.zeros((1, 3 * n))
    held[0, 3 * [l.name for l in mech.links].index(mech.input_link.name) + 2] = 1.0
    A = np.vstack([J, held])
    _, sv, vt = np.linalg.svd(A)
    null = vt[int(np.sum(sv > RANK_TOL * sv.max())) :]
    free = tuple(
        l.name for k, l in enumerate(mech.links) if null.size and np.abs(null[:, 3 * k : 3 * k + 3]).max() > 1e-6
    )
    return 3 * n - rank, free, tuple(dict.fromkeys(redundant))


def _constraint_jacobian(
    mech: Mechanism, kin: reference.Kinematics, i: int
) -> tuple[np.ndarray, list[tuple[str, int]]]:
    """The Jacobian (rows, 3 n) of the pair and gear constraints with respect to the links'
    poses (x, y m; theta rad) at sample ``i``, by central differences (the constraints are
    smooth and the step is far above rounding), and each pair's label with its row count."""
    links = [l.name for l in mech.links]
    P = {k: v.v[i, :2] for k, v in kin.points.items()}
    origin = {l.name: P[l.points[0]] for l in mech.links}
    theta = {l.name: float(kin.angles[l.name].v[i]) for l in mech.links}

    def local(link: str, p: str) -> np.ndarray:
        c, s = math.cos(theta[link]), math.sin(theta[link])
        d = P[p] - origin[link]
        return np.array([c * d[0] + s * d[1], -s * d[0] + c * d[1]])

    # Every perturbed pose at once: Q is (K, 3 n), each function returns K values per row.
    def world(Q: np.ndarray, link: str | None, p: str) -> np.ndarray:
        if link is None:
            return np.broadcast_to(P[p], (len(Q), 2))
        k = links.index(link)
        x, y, t = Q[:, 3 * k], Q[:, 3 * k + 1], Q[:, 3 * k + 2]
        c, s = np.cos(t), np.sin(t)
        r = local(link, p)
        return np.column_stack([x + c * r[0] - s * r[1], y + s * r[0] + c * r[1]])

    def angle(Q: np.ndarray, link: str | None) -> np.ndarray:
        return np.zeros(len(Q)) if link is None else Q[:, 3 * links.index(link) + 2]

    prs = [p for _, p in all_pairs(mech)]

    def constraints(Q: np.ndarray) -> np.ndarray:
        out: list[np.ndarray] = []
        for pr in prs:
            if pr.revolute:
                d = world(Q, pr.parent, pr.pin) - world(Q, pr.child, pr.pin)
                out += [d[:, 0], d[:, 1]]
            else:
                g1, g2 = pr.rail
                u = world(Q, pr.parent, g2) - world(Q, pr.parent, g1)
                nrm = np.column_stack([-u[:, 1], u[:, 0]]) / norms(u)[:, None]
                o = mech.link(pr.child).points[0]
                off = world(Q, pr.child, o) - world(Q, pr.parent, g1)
                out += [np.einsum("ij,ij->i", nrm, off), angle(Q, pr.child) - angle(Q, pr.parent)]
        for s in mech.geared:
            out.append(angle(Q, mech.carrier(s).name) - s.ratio * angle(Q, mech.input_link.name))
        return np.array(out).T  # (K, rows)

    q0 = np.concatenate([[*origin[l], theta[l]] for l in links])
    m = len(q0)
    h = 1e-6 * max(1e-3, float(np.abs(q0[np.arange(m) % 3 != 2]).max(initial=0.0)))
    steps = np.where(np.arange(m) % 3 == 2, 1e-6, h)
    dQ = np.diag(steps)
    C = constraints(np.vstack([q0 + dQ, q0 - dQ]))
    J = ((C[:m] - C[m:]) / (2 * steps[:, None])).T
    rows = [(pr.label, 2) for pr in prs] + [(f"gear {mech.carrier(s).name}", 1) for s in mech.geared]
    return J, rows


def _mobility_problem(mech: Mechanism, m: Mobility) -> MechanismFileError | None:
    src = mech.path or mech.name
    count = f"W = 3*{m.moving_links} - 2*{m.lower_pairs} = {m.structural}" + (
        f", minus {m.gears} gear coupling{'s' if m.gears > 1 else ''}" if m.gears else ""
    )
    if m.driven == 1 and m.sound:
        return None
    if m.driven == 1:
        parts = []
        if m.free:
            parts.append(f"{', '.join(m.free)} still move{'s' if len(m.free) == 1 else ''} with the input crank held")
        if m.redundant:
            parts.append(
                f"pair{'s' if len(m.redundant) > 1 else ''} {', '.join(m.redundant)} repeat constraints "
                f"other pairs already make"
            )
        return MechanismFileError(
            f"{src}: [links]: the count {count} balances, but the linkage has {m.actual} degrees of freedom by the rank "
            f"of its constraints: {'; '.join(parts)} (MuJoCo's loop closures would fight each other or leave a link "
            f"loose)"
        )
    if m.driven > 1:
        hint = next((h for s in mech.steps if (h := s.mobility_hint(mech.links))), "")
        return MechanismFileError(
            f"{src}: [links]: the links give the linkage {m.driven} degrees of freedom ({count}) where it must have "
            f"one, the input crank's angle: a point the construction fixes is free in the linkage"
            f"{hint or ' (a link is missing)'}"
        )
    return MechanismFileError(
        f"{src}: [links]: the links over-constrain the linkage ({count} degrees of freedom where it must have "
        f"one, the input crank's angle): a link or pair repeats a constraint another already makes; remove it "
        f"(MuJoCo's loop closures would fight each other)"
    )


# --------------------------------------------------------------------------- plausibility
# A link's mass and moment of inertia against its size L, the largest distance of its points
# from its centre of mass. No bound is a law: a crank carries a disc and a shaft well beyond
# its pin (warp_knitting's 150 g cranks of 5 mm), the take-up's printed inertias are 1-4 times
# m L^2. So the bounds allow a part ten times the link's size, and give warnings, never errors.
MAX_DENSITY = 2.0e4  # kg/m^3, about tungsten's
MAX_MASS_FACTOR = 1e3  # a solid tungsten block ten times the link's size across
MAX_INERTIA_RATIO = 1e3  # J / (m L^2): a ring thirty times the link's size
MIN_INERTIA_RATIO = 1e-3  # radius of gyration under L / 30: a mass in g written as kg, or an inertia in g*mm^2


def plausibility(mech: Mechanism) -> list[str]:
    """Warnings for masses and inertias far outside what a link's size allows (g, kg*m^2, mm)."""
    kin = reference.solve(mech, [mech.phi0], check=False)
    out = []
    for l in mech.links:
        if l.mass <= 0 or l.com is None:
            continue
        com = kin.position(l.com)[0]
        size = max((float(np.linalg.norm(kin.position(p)[0] - com)) for p in l.points), default=0.0)
        if size <= 0:
            continue
        if l.mass > MAX_MASS_FACTOR * MAX_DENSITY * (2 * size) ** 3:
            out.append(
                f"warning: link {l.name}: {l.mass * 1e3:g} g is heavier than a solid tungsten block ten times its "
                f"size ({20 * size * 1e3:.3g} mm across); check the mass (g in the file)"
            )
        ratio = l.inertia / (l.mass * size**2)
        if ratio > MAX_INERTIA_RATIO:
            out.append(
                f"warning: link {l.name}: inertia {l.inertia:g} kg*m^2 is {ratio:.3g} times m L^2 of a {l.mass * 1e3:g} g "
                f"link reaching {size * 1e3:.3g} mm from its centre of mass; check the inertia (kg*m^2 in the file)"
            )
        elif 0 < ratio < MIN_INERTIA_RATIO:
            out.append(
                f"warning: link {l.name}: inertia {l.inertia:g} kg*m^2 is only {ratio:.3g} times m L^2: is it in "
                f"kg*m^2 (not g*mm^2)?"
            )
    return out


# --------------------------------------------------------------------------- all checks


@dataclass(frozen=True)
class _Cycle:
    """The reference over one period at the checks' samples (assembled or not), solved once
    for every check: ``full`` whether it assembles everywhere, ``ranges`` where it does (deg)."""

    kin: reference.Kinematics
    full: bool
    ranges: str


def _cycle(mech: Mechanism) -> _Cycle:
    phi = cycle_angles(mech)
    with np.errstate(all="ignore"):  # coinciding points divide by zero; reported by the checks
        kin = reference.solve(mech, phi, check=False)
        ok = kin.assembles()
    return _Cycle(kin, bool(ok.all()), reference.angle_ranges(phi, ok, mech.period))


def problems(mech: Mechanism, *, full_turn: bool = True) -> list[MjlinkError]:
    """Every check :func:`validate` makes, as a list of the errors found (in that order).

    Checks that need the whole cycle run only when the linkage assembles over all of it.
    Floating-point warnings are silenced: every non-finite value is turned into a message.
    """
    with np.errstate(all="ignore"):
        return _problems(mech, full_turn, _cycle(mech))


def _problems(mech: Mechanism, full_turn: bool, cycle: _Cycle) -> list[MjlinkError]:
    src = mech.path or mech.name
    found: list[MjlinkError] = []
    kin, ok, ranges = cycle.kin, cycle.full, cycle.ranges
    if not ok:
        if full_turn:
            blocks = [b for b in block_angles(mech, kin) if not b.closes]
            which = "; ".join(f"{b.kind} {b.label} cannot close for input angles {b.fails_deg} deg" for b in blocks)
            found.append(
                AssemblyError(
                    f"{src}: the input crank cannot turn fully: {which + '; ' if which else ''}the linkage assembles "
                    f"only for input angles {ranges or 'none'} deg (it is a rocker there; mjlink does not pretend "
                    f"otherwise)"
                )
            )
        found += _structure(mech, kin)
        return found
    bad = _undefined(mech, kin)
    if bad:
        return [*found, bad, *_structure(mech, kin)]
    try:
        reference.check_rigidity(mech, kin=kin)  # assembled over the whole cycle here
    except MechanismFileError as e:
        found.append(e)
    close = _almost_coincident(mech, kin)
    if close:
        found.append(close)
    found += _structure(mech, kin)
    found += [AssemblyError(b.message(src)) for b in block_angles(mech, kin) if not b.ok]
    inertia = _inertia_problem(mech, kin)
    if inertia:
        found.append(inertia)
    if not found:
        compiled = _compile_problem(mech)
        if compiled:
            found.append(compiled)
    return found


def _structure(mech: Mechanism, kin: reference.Kinematics) -> list[MjlinkError]:
    """Pairs the builder can make into a MuJoCo tree, and one degree of freedom."""
    out: list[MjlinkError] = []
    try:
        topology(mech)
    except MechanismFileError as e:
        out.append(e)
    m = _mobility_problem(mech, mobility(mech, kin))
    if m:
        out.append(m)
    return out


def _undefined(mech: Mechanism, kin: reference.Kinematics) -> MechanismFileError | None:
    """A point whose block's direction is undefined (two of its points coincide) somewhere."""
    src = mech.path or mech.name
    seen: set[frozenset[str]] = set()  # many points attached to one pair: that pair once
    for s in mech.steps:
        for p, q, what in s.directions():
            pair = frozenset((p, q))
            if pair in seen:
                continue
            seen.add(pair)
            d = norms((kin.points[p].v - kin.points[q].v)[:, :2])
            if not (d >= MIN_DIRECTION_M).all():
                i = int(np.argmin(np.where(np.isfinite(d), d, -1.0)))
                return MechanismFileError(
                    f"{src}: [[construct]] {s.point}: its {what} {p} and {q} come within {d[i] * 1e3:.3g} mm of each "
                    f"other at input angle {_wrap(mech, kin.phi[i]):.1f} deg, so the direction they define is "
                    f"undefined there"
                )
    for l in mech.links:
        if l.guide:
            p, q = l.guide
            d = norms((kin.points[p].v - kin.points[q].v)[:, :2])
            if not (d >= MIN_DIRECTION_M).all():
                return MechanismFileError(
                    f"{src}: [links.{l.name}] guide: points {p} and {q} coincide "
                    f"(within {MIN_DIRECTION_M * 1e3:g} mm), so the guide has no direction"
                )
    for n in mech.point_names:
        v = kin.points[n].v
        if not np.isfinite(v).all():
            i = int(np.argmax(~np.isfinite(v).all(axis=1)))
            return MechanismFileError(
                f"{src}: [[construct]] {n}: the point is undefined at input angle {_wrap(mech, kin.phi[i]):.1f} deg"
            )
    return None


def _almost_coincident(mech: Mechanism, kin: reference.Kinematics) -> MechanismFileError | None:
    """Two points of one link closer than MIN_DISTINCT_M but not the same point."""
    for l in mech.links:
        # Each point against all later ones at once: a pass per pair would be quadratic in
        # the points a link carries.
        xyz = np.stack([kin.points[p].v[0] for p in l.points])
        for i, a in enumerate(l.points[:-1]):
            d = norms(xyz[i + 1 :] - xyz[i])
            near = np.flatnonzero((d > 0.0) & (d < MIN_DISTINCT_M))
            if len(near):
                b, gap = l.points[i + 1 + near[0]], float(d[near[0]])
                return MechanismFileError(
                    f"{mech.path or mech.name}: [links.{l.name}]: points {a} and {b} are only {gap * 1e3:.3g} mm "
                    f"apart: MuJoCo merges points closer than 0.0001 mm with a body's frame, so make them one point "
                    f"(length 0) or keep them at least {MIN_DISTINCT_M * 1e3:g} mm apart"
                )
    return None


def _inertia_problem(mech: Mechanism, kin: reference.Kinematics) -> MechanismFileError | None:
    """With masses and a [dynamics] table, the reduced moment of inertia must stay positive."""
    if not (mech.has_dynamics and any(l.mass > 0 for l in mech.links)):
        return None
    J = np.zeros(len(kin.phi))
    for l in mech.links:
        J += l.inertia * kin.angles[l.name].d ** 2
        if l.com is not None and l.mass > 0:
            s = kin.points[l.com].d
            J += l.mass * np.einsum("ij,ij->i", s, s)
    if not np.isfinite(J).all() or J.min() > 1e-9 * J.max():
        return None  # non-finite only exactly at a dead point, which is reported as such
    i = int(np.argmin(J))
    return MechanismFileError(
        f"{mech.path or mech.name}: [links]: the reduced moment of inertia J(phi) vanishes at input angle "
        f"{_wrap(mech, kin.phi[i]):.1f} deg (every link with mass or inertia is at rest there), so the equation "
        f"of motion is singular: give the input crank's link {mech.input_link.name} a mass and an inertia"
    )


def _compile_problem(mech: Mechanism) -> MechanismFileError | None:
    """The MJCF must compile (a last guard: names are validated when the file is read)."""
    from .sim import builder  # the one check that needs MuJoCo; sim/ sets MUJOCO_GL first

    try:
        builder.build_spec(mech).compile()
    except ValueError as e:
        msg = " ".join(str(e).split())
        return MechanismFileError(f"{mech.path or mech.name}: MuJoCo cannot compile the model: {msg}")
    return None


def check_angle(option: str, deg: float) -> float:
    """``deg`` if it is an angle a crank may be set to: finite and at most MAX_ANGLE_DEG in
    magnitude, the bound of every angle in a file (beyond a turn or two an angle only loses
    precision); else MjlinkError naming ``option``."""
    if not math.isfinite(deg) or above(abs(deg), MAX_ANGLE_DEG):
        raise MjlinkError(f"{option} must be finite and at most {MAX_ANGLE_DEG:g} deg in magnitude, got {deg:g}")
    return deg


def with_crank_settings(mech: Mechanism, phi0_deg: float | None = None, phase_deg: float | None = None) -> Mechanism:
    """``mech`` with another initial input angle (phi01) and/or geared-crank phase (phi04), deg.

    Raises MjlinkError if a phase is given for a mechanism without a geared crank.
    """
    if phi0_deg is not None:
        check_angle("--phi0", phi0_deg)
        mech = dataclasses.replace(mech, phi0=math.radians(phi0_deg))
    if phase_deg is not None:
        geared = mech.geared
        if not geared:
            raise MjlinkError(f"{mech.name} has no geared crank: --phase/--phi04 does not apply")
        check_angle("--phase", phase_deg)
        new = dataclasses.replace(geared[0], phase=math.radians(phase_deg))
        mech = dataclasses.replace(mech, steps=tuple(new if s is geared[0] else s for s in mech.steps))
    return validate(mech) if (phi0_deg is not None or phase_deg is not None) else mech


# ------------------------------------------------------------------------ the check report
@dataclass(frozen=True)
class PointInfo:
    """A named point: ``ground`` True for a [ground] point; ``made_by`` how it is built; the
    links carrying it; ``at`` its position (3,) m at the input crank's setting (None where the
    linkage does not assemble there)."""

    name: str
    ground: bool
    made_by: str
    links: tuple[str, ...]
    at: tuple[float, float, float] | None = None


@dataclass(frozen=True)
class LinkInfo:
    """A link: its points, ``mass`` kg, ``inertia`` kg*m^2 about its centre of mass, ``com``, ``guide``."""

    name: str
    points: tuple[str, ...]
    mass: float
    inertia: float
    com: str | None
    guide: tuple[str, str] | None


@dataclass(frozen=True)
class PairInfo:
    """A kinematic pair as the builder makes it: ``kind`` 'revolute' (at ``point``) or 'prismatic'
    (along ``guide``) between ``parent`` ('ground' for the frame) and ``child``; ``role`` 'joint'
    (a MuJoCo hinge or slide in the tree), 'loop' (a connect equality closing a loop) or '' if
    the builder cannot place it."""

    kind: PairKind
    point: str | None
    guide: tuple[str, str] | None
    parent: str
    child: str
    role: PairRole


@dataclass(frozen=True)
class GearInfo:
    """A geared crank: ``point`` on ``link``, ``ratio`` to the input, ``phase`` rad at phi0."""

    point: str
    link: str
    ratio: float
    phase: float


@dataclass(frozen=True, kw_only=True)
class CheckReport:
    """Everything :func:`check` found. ``problems`` are (error class name, one-line message)
    pairs in the order :func:`mjlink.validate` checks them; ``notes`` are remarks
    that do not stop a run."""

    name: str
    title: str
    path: str
    points: tuple[PointInfo, ...]
    links: tuple[LinkInfo, ...]
    pairs: tuple[PairInfo, ...]
    gears: tuple[GearInfo, ...]
    mobility: Mobility
    full_turn: bool
    assembly_ranges: str
    angles: tuple[BlockAngle, ...]
    problems: tuple[tuple[str, str], ...]
    notes: tuple[str, ...]
    period_deg: float = 360.0
    timing: HeadTiming | None = None  # a head's timing checks, when it assembles over the turn
    feed: tuple[str, ...] = ()  # a head's presser and fabric, as the feed runs them (feed_lines)
    thread: tuple[str, ...] = ()  # a lockstitch head's thread and its tensioning (thread_lines)

    @property
    def ok(self) -> bool:
        return not self.problems

    @property
    def loops(self) -> tuple[PairInfo, ...]:
        return tuple(p for p in self.pairs if p.role is PairRole.LOOP)

    def error(self) -> MjlinkError | None:
        """The first problem as the error validate raises, or None."""
        if not self.problems:
            return None
        kind, msg = self.problems[0]
        return _ERRORS.get(kind, MjlinkError)(msg)

    def raise_if_failed(self) -> None:
        err = self.error()
        if err is not None:
            raise err


def check_file(name_or_path) -> CheckReport:
    """Load a registered name or a path and :func:`check` it.

    Raises UnknownMechanismError or MechanismFileError (one line) if the file cannot be read
    into a mechanism at all; geometric problems are in the report instead.
    """
    return check(load(catalogue.path_of(name_or_path)))


def check(mech: Mechanism) -> CheckReport:
    """Describe ``mech`` and collect every problem (see the module docstring). Never raises
    for the mechanism's geometry or structure."""
    made_by = {s.point: s.describe() for s in mech.steps}
    cycle = _cycle(mech)
    full, ranges = cycle.full, cycle.ranges
    P = cycle.kin.positions()  # the first sample is the input crank's setting

    def at(n: str) -> tuple[float, float, float] | None:
        x = P[n][0]
        return (float(x[0]), float(x[1]), float(x[2])) if np.all(np.isfinite(x)) else None

    points = tuple(
        PointInfo(
            name=n,
            ground=n in mech.ground,
            made_by=made_by.get(n) or "fixed at (" + ", ".join(f"{x * 1e3:g}" for x in mech.ground[n]) + ") mm",
            links=tuple(l.name for l in mech.links if n in l.points),
            at=at(n) if cycle.kin.assembles()[0] else None,
        )
        for n in mech.point_names
    )
    links = tuple(LinkInfo(l.name, l.points, l.mass, l.inertia, l.com, l.guide) for l in mech.links)

    pairs: list[PairInfo] = []
    try:
        topo = topology(mech)
        for role, group in ((PairRole.JOINT, topo.tree), (PairRole.LOOP, topo.loops)):
            for p in group:
                pairs.append(PairInfo(p.kind, p.point, p.guide, p.parent or "ground", p.child, role))
    except MechanismFileError:
        try:
            for _, p in all_pairs(mech):
                pairs.append(PairInfo(p.kind, p.point, p.guide, p.parent or "ground", p.child, PairRole.UNPLACED))
        except MechanismFileError:
            pass
    gears = tuple(
        GearInfo(s.point, next(iter(s.carriers(mech.links)), "?"), s.ratio, s.phase or 0.0) for s in mech.geared
    )

    with np.errstate(all="ignore"):
        angles = block_angles(mech, cycle.kin)
        probs = tuple((type(e).__name__, str(e)) for e in _problems(mech, True, cycle))

    notes = []
    # Above VERIFIED_SPEED the kinematic run's clock is scaled (sim.simulate.kinematic_case):
    # it is the run at VERIFIED_SPEED, whose crank-pin acceleration is what the envelope bounds.
    acc = mech.input_crank.length * min(abs(mech.speed), VERIFIED_SPEED) ** 2
    lo, hi = VERIFIED_CRANK_ACCELERATION
    if abs(mech.speed) > VERIFIED_SPEED:
        notes.append(
            f"the kinematic run's speed {abs(mech.speed):g} rad/s is above {VERIFIED_SPEED:g} rad/s: its timestep "
            f"and loop time constant are scaled by {VERIFIED_SPEED / abs(mech.speed):.3g}, so that it is the "
            f"verified run at {VERIFIED_SPEED:g} rad/s on a faster clock"
        )
    if not lo <= acc <= hi:
        notes.append(
            f"the crank pin's acceleration in the kinematic run, {acc:.3g} m/s^2 (crank length x speed^2, the "
            "speed at most the verified one), is "
            f"outside the {lo:g}..{hi:g} m/s^2 over which the agreement thresholds are verified "
            + ("(gravity's load on the loop closures is then not negligible)" if acc < lo else "(errors grow with it)")
            + "; 'simulate' reports how close it comes"
        )
    if not any(l.mass > 0 for l in mech.links):
        notes.append("no link has a mass: 'simulate' makes the kinematic run only")
    elif not mech.has_dynamics:
        notes.append("links have masses but there is no [dynamics] table: 'simulate' makes the kinematic run only")
    point_masses = [l.name for l in mech.links if l.mass > 0 and l.inertia == 0 and not l.guide]
    if point_masses:
        notes.append(f"{', '.join(point_masses)}: mass without inertia, treated as a point mass at its 'com'")
    notes += plausibility(mech)
    if full:
        notes += intent.warnings(mech, P)
    return CheckReport(
        name=mech.name,
        title=mech.title,
        path=str(mech.path or "<string>"),
        points=points,
        links=links,
        pairs=tuple(pairs),
        gears=gears,
        mobility=mobility(mech, cycle.kin),
        full_turn=full,
        assembly_ranges=ranges,
        angles=angles,
        problems=probs,
        notes=tuple(notes),
        period_deg=math.degrees(mech.period),
        timing=head_timing(mech) if mech.timing is not None and full and not probs else None,
        feed=feed_lines(mech),
        thread=thread_lines(mech),
    )
