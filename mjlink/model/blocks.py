"""The papers' building blocks, each owning its behaviour.

A mechanism file builds every moving point with one block, in order. Each block type here
knows, for itself: how it is read from its ``[[construct]]`` table, how it solves its point
on jets (exact first and second derivatives in the input angle), its closure margin (where it
assembles), how close it comes to a dead point, its mirror solution (the other assembly
branch), its one-line description for ``check``, which links carry it, and the MuJoCo
coupling it needs beyond the links' pairs (a geared crank's joint equality). Every other
module asks a block; none asks what type it is. Adding a block type is one class here (and
its MJCF emission in the builder if it needs a coupling the pairs do not make).

Units: SI (m, rad) on the objects; the file's mm and deg only in :meth:`Block.read`.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import Iterable
from dataclasses import dataclass
from fractions import Fraction
from typing import TYPE_CHECKING, Any, ClassVar, Protocol

import numpy as np

from ..errors import did_you_mean
from ..units import DEG, MM
from . import jet
from .limits import (
    MAX_ANGLE_DEG,
    MAX_GEAR_RATIO,
    MAX_LENGTH_MM,
    MAX_PRESSURE_DEG,
    MIN_BAR_MM,
    MIN_TRANSMISSION_DEG,
    above,
    below,
)

if TYPE_CHECKING:
    from .reader import Reader

Points = dict[str, np.ndarray]  # point name -> (N, 3) positions, m


class Link(Protocol):
    """What a block needs to know of a link (:class:`mjlink.model.mechanism.Link` is one):
    blocks come before links in a file, so they depend on this shape, not on that module."""

    @property
    def name(self) -> str: ...
    @property
    def points(self) -> tuple[str, ...]: ...
    @property
    def guide(self) -> tuple[str, str] | None: ...


@dataclass(frozen=True)
class Solved:
    """A block's point on jets and its closure margin: ``margin`` (N,) is >= 0 where the block
    assembles (None for a block that always does)."""

    point: jet.V
    margin: np.ndarray | None = None


@dataclass(frozen=True)
class DeadPoint:
    """How near a block comes to its dead point, per input angle: ``value_deg`` the angle that
    measures it (transmission or pressure angle), ``margin_deg`` the distance from the dead
    point, ``closes`` where the block assembles; ``required_margin_deg`` the least margin the
    simulation is faithful with."""

    quantity: str
    value_deg: np.ndarray
    margin_deg: np.ndarray
    closes: np.ndarray
    required_margin_deg: float
    limit_deg: float


@dataclass(frozen=True, kw_only=True)
class BlockAngle:
    """How close one dyad or slider comes to a dead point over the input's period.

    ``kind`` 'dyad' or 'slider'; ``quantity`` 'transmission angle' (dyad: the angle at its joint
    between its two links, 0..180 deg, dead at 0 and 180) or 'pressure angle' (slider: the
    angle between the rod start-point and the guide line, i.e. between the force the rod
    transmits and the slider's motion, 0..90 deg, dead at 90 where the rod stands square to
    the guide); ``worst_deg`` its value where it is closest to the dead point, ``margin_deg``
    the distance from the dead point there, ``phi_deg`` the input angle there (deg, reduced to
    0..period), ``limit_deg`` the allowed value (the least distance from the dead point for a
    dyad's transmission angle, the largest pressure angle for a slider); NaN if the block
    cannot be assembled anywhere. ``closes`` False if it cannot be assembled at some input
    angle, ``fails_deg`` the input-angle ranges where it cannot.
    """

    kind: str
    point: str
    label: str  # 'P2-P3-P4' (dyad a-point-b) or 'P8-P9 on P5-P6' (slider start-point on guide)
    links: tuple[str, ...]
    quantity: str
    worst_deg: float
    margin_deg: float
    phi_deg: float
    limit_deg: float
    closes: bool
    fails_deg: str  # input-angle ranges where the block cannot close ('' if it always does)
    block: Block | None = None
    required_margin_deg: float = 0.0

    @property
    def ok(self) -> bool:
        return self.margin_deg >= self.required_margin_deg

    def message(self, src: object) -> str:
        """The one-line AssemblyError text for a block that passes too near its dead point."""
        assert self.block is not None
        return self.block.dead_point_message(self, src)


@dataclass(frozen=True)
class Gear:
    """A geared crank's coupling to the input: its angle is ``phase + ratio (phi - phi0)``."""

    ratio: float
    phase: float


class Block(ABC):
    """A building block: constructs ``point`` from points defined before it.

    Subclasses set ``kind`` (the ``block`` value in a file) and are registered by it.
    """

    kind: ClassVar[str]
    types: ClassVar[dict[str, type[Block]]] = {}
    # The block's numeric keys a design study may vary (``construct.POINT.KEY``): key ->
    # (SI per file unit, file unit, must be positive). The attribute has the key's name.
    numbers: ClassVar[dict[str, tuple[float, str, bool]]] = {}
    point: str

    def __init_subclass__(cls, **kw: Any) -> None:
        super().__init_subclass__(**kw)
        Block.types[cls.kind] = cls

    # -- reading ------------------------------------------------------------------------
    @classmethod
    @abstractmethod
    def read(cls, r: Reader, raw: dict, point: str, where: str) -> Block:
        """The block from its ``[[construct]]`` table (file units), or a one-line error."""

    def check(self, r: Reader, ground: dict, first: bool) -> None:  # noqa: B027 (optional hook)
        """Rules that need the whole file (``first``: this is the first block); raise ``r.fail``."""

    # -- structure ------------------------------------------------------------------------
    @property
    @abstractmethod
    def inputs(self) -> tuple[str, ...]:
        """The points this block is built from."""

    @property
    def drawn_from(self) -> tuple[str, ...]:
        """Points of the block's own link this point is joined to in a drawing, preferred first."""
        return self.inputs

    def carriers(self, links: Iterable[Link]) -> tuple[str, ...]:
        """Names of the links this block's own bars belong to (empty if it makes no bar)."""
        return ()

    @property
    def gear(self) -> Gear | None:
        """The coupling to the input crank if this block is a geared crank."""
        return None

    @property
    def is_input(self) -> bool:
        """Whether this block is the input crank."""
        return False

    @property
    def period_turns(self) -> int:
        """Input turns after which this block's point repeats (a gear's denominator)."""
        return 1

    def directions(self) -> tuple[tuple[str, str, str], ...]:
        """Point pairs that define a direction for this block (must never coincide): (p, q, what)."""
        return ()

    def mobility_hint(self, links: Iterable[Link]) -> str | None:
        """Why the links leave this block's point free, if they do; None otherwise."""
        return None

    # -- solving ----------------------------------------------------------------------------
    @abstractmethod
    def solve(self, pts: dict[str, jet.V], phi: jet.S, phi0: float) -> Solved:
        """The point on jets from its inputs' jets; ``phi`` the input angle jet, rad."""

    def cannot_close(self, mech_name: str, ranges: str) -> str:
        """The AssemblyError text where the margin is negative over ``ranges`` (deg)."""
        return f"{mech_name}: block {self.point} cannot close for input angles {ranges} deg"

    def dead_point(self, P: Points) -> DeadPoint | None:
        """The dead-point measure over the angles of ``P`` (None: a block without one)."""
        return None

    def label(self) -> str:
        return self.point

    def dead_point_message(self, a: BlockAngle, src: object) -> str:
        return f"{src}: block {a.label} passes within {a.margin_deg:.2f} deg of a dead point"

    # -- the other branch ---------------------------------------------------------------------
    def mirror(self, P: Points, j: int) -> np.ndarray | None:
        """The other solution at sample ``j`` (None if the block has one solution)."""
        return None

    def flipped(self) -> str:
        """How the other branch would be written in the file ('sign +1 instead of -1')."""
        return ""

    def named(self) -> str:
        """The block as a user names it: 'dyad P2-P3-P4'."""
        return f"{self.kind} {self.point}"

    # -- description -------------------------------------------------------------------------
    @abstractmethod
    def describe(self) -> str:
        """One line for ``check`` (lengths mm, angles deg)."""


def _bar(r: Reader) -> dict:
    return dict(
        positive=True,
        scale=MM,
        lo=MIN_BAR_MM,
        hi=MAX_LENGTH_MM,
        unit=" mm",
        why="mjlink models machine linkages; see mechanisms/README.md",
    )


def _links_with(links: Iterable[Link], *points: str) -> list[str]:
    return [l.name for l in links if all(p in l.points for p in points)]


# --------------------------------------------------------------------------------- crank
@dataclass(frozen=True)
class Crank(Block):
    """Block 1: ``point = pivot + length (cos a, sin a)``.

    ``a = phase + ratio (phi - phi0)`` where phi is the input crank angle. The input crank
    has ratio 1 and phase phi0; a geared crank has its own ratio (signed: negative turns
    the other way) and phase (its angle when phi = phi0). Lengths m, angles rad.
    """

    kind: ClassVar[str] = "crank"
    numbers: ClassVar[dict[str, tuple[float, str, bool]]] = {"length": (MM, "mm", True), "phase": (DEG, "deg", False)}
    point: str
    pivot: str
    length: float
    ratio: float = 1.0
    phase: float | None = None

    @classmethod
    def read(cls, r: Reader, raw: dict, point: str, where: str) -> Crank:
        r.keys(raw, where, ["block", "point", "pivot", "length"], ["ratio", "phase"])
        ratio = r.number(raw, "ratio", where, default=1.0)
        if ratio == 0:
            raise r.fail(f"{where} ratio", "must be non-zero")
        if below(abs(ratio), 1 / MAX_GEAR_RATIO) or above(abs(ratio), MAX_GEAR_RATIO):
            raise r.fail(
                f"{where} ratio",
                f"must be between 1/{MAX_GEAR_RATIO:g} and {MAX_GEAR_RATIO:g} in magnitude, got {ratio:g}",
            )
        phase = (
            r.number(raw, "phase", where, scale=DEG, hi=MAX_ANGLE_DEG, unit=" deg", why="an angle")
            if "phase" in raw
            else None
        )
        return cls(
            point, r.name(raw["pivot"], f"{where} pivot"), r.number(raw, "length", where, **_bar(r)), ratio, phase
        )

    def check(self, r: Reader, ground: dict, first: bool) -> None:
        if first and (self.ratio != 1.0 or self.phase is not None):
            raise r.fail("[[construct]]", "the first block must be the input crank (a crank with no ratio or phase)")
        if self.pivot not in ground:
            raise r.fail(f"[[construct]] {self.point}", f"crank pivot '{self.pivot}' must be a [ground] point")
        if not first and self.phase is None:
            raise r.fail(
                f"[[construct]] {self.point}", "a geared crank needs 'phase' (its angle at the initial input angle)"
            )
        if self._turns() is None:
            q = int(MAX_GEAR_RATIO)
            raise r.fail(
                f"[[construct]] {self.point} ratio",
                f"{self.ratio:g} is no ratio p/q with q <= {q}: the mechanism would repeat only after more than {q} "
                f"input turns (or never), so neither its full rotation nor its cycle can be judged; write the ratio "
                f"of the gears' teeth",
            )

    @property
    def inputs(self) -> tuple[str, ...]:
        return (self.pivot,)

    def carriers(self, links: Iterable[Link]) -> tuple[str, ...]:
        return tuple(_links_with(links, self.pivot, self.point)[:1])

    @property
    def gear(self) -> Gear | None:
        return None if self.phase is None else Gear(self.ratio, self.phase)

    @property
    def is_input(self) -> bool:
        return self.phase is None

    @property
    def period_turns(self) -> int:
        turns = self._turns()
        assert turns is not None, "a ratio without a common period is refused when the file is read"
        return turns

    def _turns(self) -> int | None:
        """Input turns after which this crank's angle repeats, if within MAX_GEAR_RATIO."""
        frac = Fraction(self.ratio).limit_denominator(int(MAX_GEAR_RATIO))
        return frac.denominator if abs(float(frac) - self.ratio) <= 1e-12 * abs(self.ratio) else None

    def solve(self, pts: dict[str, jet.V], phi: jet.S, phi0: float) -> Solved:
        phase = phi0 if self.phase is None else self.phase
        angle = (phi - phi0) * self.ratio + phase
        return Solved(pts[self.pivot] + jet.polar(self.length, angle))

    def describe(self) -> str:
        if self.is_input:
            return f"crank about {self.pivot}, {self.length * 1e3:g} mm"
        return (
            f"geared crank about {self.pivot}, {self.length * 1e3:g} mm, ratio {self.ratio:g}, "
            f"phase {math.degrees(self.phase or 0.0):g} deg"
        )


# ---------------------------------------------------------------------------------- dyad
@dataclass(frozen=True)
class Dyad(Block):
    """Block 2, RRR dyad: joint ``point`` at ``length_a`` from ``a`` and ``length_b`` from ``b``.

    ``point = b + rho(a - b, sign * U, length_b)`` with U from the cosine rule; ``sign``
    (+1 or -1) is the assembly branch. Lengths m.
    """

    kind: ClassVar[str] = "dyad"
    numbers: ClassVar[dict[str, tuple[float, str, bool]]] = {"length_a": (MM, "mm", True), "length_b": (MM, "mm", True)}
    point: str
    a: str
    b: str
    length_a: float
    length_b: float
    sign: int

    @classmethod
    def read(cls, r: Reader, raw: dict, point: str, where: str) -> Dyad:
        r.keys(raw, where, ["block", "point", "a", "b", "length_a", "length_b", "sign"])
        sign = raw["sign"]
        if isinstance(sign, bool) or sign not in (1, -1):
            raise r.fail(f"{where} sign", f"must be +1 or -1 (the assembly branch), got {r.shown(sign)}")
        a, b = r.name(raw["a"], f"{where} a"), r.name(raw["b"], f"{where} b")
        if a == b:
            raise r.fail(f"{where} b", f"must differ from a (both are '{a}'): a dyad joins two different points")
        return cls(
            point,
            a,
            b,
            r.number(raw, "length_a", where, **_bar(r)),
            r.number(raw, "length_b", where, **_bar(r)),
            int(sign),
        )

    @property
    def inputs(self) -> tuple[str, ...]:
        return (self.a, self.b)

    def carriers(self, links: Iterable[Link]) -> tuple[str, ...]:
        links = list(links)
        la = next(iter(_links_with(links, self.a, self.point)), None)
        lb = next((n for n in _links_with(links, self.b, self.point) if n != la), None)
        return (la, lb) if la and lb else ()

    def directions(self) -> tuple[tuple[str, str, str], ...]:
        return ((self.a, self.b, "a and b"),)

    def mobility_hint(self, links: Iterable[Link]) -> str | None:
        if self.carriers(links):
            return None
        return (
            f": dyad {self.a}-{self.point}-{self.b} needs its joint {self.point} on one link with {self.a} and on "
            f"another with {self.b}"
        )

    def solve(self, pts: dict[str, jet.V], phi: jet.S, phi0: float) -> Solved:
        a, b = pts[self.a], pts[self.b]
        d = (a - b).planar()
        dist = d.norm()
        cos_u = (dist * dist + (self.length_b**2 - self.length_a**2)) / (dist * (2.0 * self.length_b))
        c = b + jet.turn(
            d.scale(self.length_b / dist), jet.S(np.clip(cos_u.v, -1.0, 1.0), cos_u.d, cos_u.dd), self.sign
        )
        return Solved(c, 1.0 - np.abs(cos_u.v))

    def cannot_close(self, mech_name: str, ranges: str) -> str:
        return (
            f"{mech_name}: dyad {self.a}-{self.point}-{self.b} cannot close for input angles "
            f"{ranges} deg (|cos U| > 1): the input crank cannot turn through these angles (it is a rocker there)"
        )

    def dead_point(self, P: Points) -> DeadPoint:
        d = jet.norms((P[self.a] - P[self.b])[:, :2])
        cos_mu = (self.length_a**2 + self.length_b**2 - d**2) / (2 * self.length_a * self.length_b)
        mu = np.degrees(np.arccos(np.clip(cos_mu, -1.0, 1.0)))
        return DeadPoint(
            "transmission angle",
            mu,
            np.minimum(mu, 180.0 - mu),
            np.abs(cos_mu) <= 1.0,
            MIN_TRANSMISSION_DEG,
            MIN_TRANSMISSION_DEG,
        )

    def label(self) -> str:
        return f"{self.a}-{self.point}-{self.b}"

    def dead_point_message(self, a: BlockAngle, src: object) -> str:
        between = f" between links {a.links[0]} and {a.links[1]}" if len(a.links) == 2 else ""
        return (
            f"{src}: dyad {a.label} passes within {a.margin_deg:.2f} deg of a dead point: its "
            f"transmission angle at {self.point}{between} reaches {a.worst_deg:.2f} deg at "
            f"input angle {a.phi_deg:.1f} deg; MuJoCo follows the linkage faithfully only while it "
            f"stays within {a.limit_deg:g}..{180 - a.limit_deg:g} deg (mechanisms/README.md, Dead points)"
        )

    def mirror(self, P: Points, j: int) -> np.ndarray:
        c, a, b = (P[p][j] for p in (self.point, self.a, self.b))
        u = (a - b)[:2] / np.linalg.norm((a - b)[:2])
        r = (c - b)[:2]
        m2 = 2 * np.dot(r, u) * u - r  # reflection of C across the line a-b
        return np.array([b[0] + m2[0], b[1] + m2[1], c[2]])

    def flipped(self) -> str:
        return f"sign {-self.sign:+d} instead of {self.sign:+d}"

    def named(self) -> str:
        return f"dyad {self.a}-{self.point}-{self.b}"

    def describe(self) -> str:
        return (
            f"dyad {self.a}-{self.point}-{self.b}, {self.length_a * 1e3:g} / {self.length_b * 1e3:g} mm, "
            f"sign {self.sign:+d}"
        )


# ------------------------------------------------------------------------------ attached
@dataclass(frozen=True)
class Attached(Block):
    """Block 3: ``point = origin + rho(toward - origin, angle, length)``, at height ``z``.

    ``z`` (m) is the point's out-of-plane coordinate; None keeps the origin's. Angle rad.
    """

    kind: ClassVar[str] = "attached"
    numbers: ClassVar[dict[str, tuple[float, str, bool]]] = {
        "angle": (DEG, "deg", False),
        "length": (MM, "mm", False),
        "z": (MM, "mm", False),
    }
    point: str
    origin: str
    toward: str
    angle: float
    length: float
    z: float | None = None

    @classmethod
    def read(cls, r: Reader, raw: dict, point: str, where: str) -> Attached:
        r.keys(raw, where, ["block", "point", "origin", "toward", "angle", "length"], ["z"])
        z = r.number(raw, "z", where, scale=MM, hi=MAX_LENGTH_MM, unit=" mm") if "z" in raw else None
        origin, toward = r.name(raw["origin"], f"{where} origin"), r.name(raw["toward"], f"{where} toward")
        if origin == toward:
            raise r.fail(
                f"{where} toward",
                f"must differ from origin (both are '{origin}'): "
                "the direction from origin to toward would be undefined",
            )
        return cls(
            point,
            origin,
            toward,
            r.number(raw, "angle", where, scale=DEG, hi=MAX_ANGLE_DEG, unit=" deg", why="an angle"),
            r.number(raw, "length", where, nonneg=True, scale=MM, hi=MAX_LENGTH_MM, unit=" mm"),
            z,
        )

    @property
    def inputs(self) -> tuple[str, ...]:
        return (self.origin, self.toward)

    def directions(self) -> tuple[tuple[str, str, str], ...]:
        return ((self.origin, self.toward, "origin and toward"),)

    def solve(self, pts: dict[str, jet.V], phi: jet.S, phi0: float) -> Solved:
        origin = pts[self.origin]
        q = origin + jet.rotate_fixed(jet.direction(origin, pts[self.toward]), self.angle, self.length)
        return Solved(q.with_z(self.z) if self.z is not None else q)

    def describe(self) -> str:
        return (
            f"attached to {self.origin}->{self.toward}, {math.degrees(self.angle):g} deg, "
            f"{self.length * 1e3:g} mm" + ("" if self.z is None else f", z {self.z * 1e3:g} mm")
        )


# -------------------------------------------------------------------------------- slider
@dataclass(frozen=True)
class Slider(Block):
    """Block 4, RRP dyad: ``point`` at ``length`` from ``start``, on the guide line ``guide``.

    Of the two solutions the one lying towards guide point ``toward`` is taken (the papers'
    "point at infinity"). Length m.
    """

    kind: ClassVar[str] = "slider"
    numbers: ClassVar[dict[str, tuple[float, str, bool]]] = {"length": (MM, "mm", True)}
    point: str
    start: str
    length: float
    guide: tuple[str, str]
    toward: str

    @classmethod
    def read(cls, r: Reader, raw: dict, point: str, where: str) -> Slider:
        r.keys(raw, where, ["block", "point", "start", "length", "guide", "toward"])
        guide = r.names(raw["guide"], f"{where} guide", length=2)
        toward = r.name(raw["toward"], f"{where} toward")
        if toward not in guide:
            raise r.fail(f"{where} toward", f"must be one of the guide points {guide[0]}, {guide[1]}; got '{toward}'")
        return cls(
            point,
            r.name(raw["start"], f"{where} start"),
            r.number(raw, "length", where, **_bar(r)),
            (guide[0], guide[1]),
            toward,
        )

    def check(self, r: Reader, ground: dict, first: bool) -> None:
        if self.guide[0] == self.guide[1]:
            raise r.fail(f"[[construct]] {self.point} guide", "needs two different points")

    @property
    def inputs(self) -> tuple[str, ...]:
        return (self.start, *self.guide)

    @property
    def drawn_from(self) -> tuple[str, ...]:
        return ()

    def directions(self) -> tuple[tuple[str, str, str], ...]:
        return ((self.guide[0], self.guide[1], "guide points"),)

    def mobility_hint(self, links: Iterable[Link]) -> str | None:
        if any(self.point in l.points and l.guide and set(l.guide) == set(self.guide) for l in links):
            return None
        return f': slider {self.point} needs a link carrying {self.point} with guide = ["{self.guide[0]}", "{self.guide[1]}"]'

    def solve(self, pts: dict[str, jet.V], phi: jet.S, phi0: float) -> Solved:
        # F +- sqrt(L^2 - |A - F|^2) u, F the foot of the perpendicular from the start point,
        # u the unit guide vector; toward the second guide point picks +.
        start, n1, n2 = pts[self.start], pts[self.guide[0]], pts[self.guide[1]]
        g = (n2 - n1).planar()
        u = g.scale(1.0 / g.norm())
        foot = n1 + u.scale((start - n1).planar().dot(u))
        off = (start - foot).planar()
        h2 = (off.dot(off) * -1.0) + self.length**2
        h = jet.sqrt(jet.S(np.maximum(h2.v, 0.0), h2.d, h2.dd))
        return Solved(foot + u.scale(h if self.toward == self.guide[1] else -h), h2.v)

    def cannot_close(self, mech_name: str, ranges: str) -> str:
        return (
            f"{mech_name}: slider {self.start}-{self.point} (length {self.length * 1e3:g} mm) cannot "
            f"reach its guide {self.guide[0]}-{self.guide[1]} for input angles {ranges} deg"
        )

    def dead_point(self, P: Points) -> DeadPoint:
        a = P[self.start][:, :2]
        n1, n2 = (P[g][:, :2] for g in self.guide)
        g = n2 - n1
        with np.errstate(all="ignore"):
            u = g / jet.norms(g)[:, None]
            off = (a - n1) - np.einsum("ij,ij->i", a - n1, u)[:, None] * u
            ratio = jet.norms(off) / self.length  # sin of the pressure angle
        value = np.degrees(np.arcsin(np.clip(ratio, 0.0, 1.0)))
        return DeadPoint("pressure angle", value, 90.0 - value, ratio <= 1.0, 90.0 - MAX_PRESSURE_DEG, MAX_PRESSURE_DEG)

    def label(self) -> str:
        return f"{self.start}-{self.point} on {self.guide[0]}-{self.guide[1]}"

    def dead_point_message(self, a: BlockAngle, src: object) -> str:
        return (
            f"{src}: slider {a.label} passes within {a.margin_deg:.2f} deg of a dead point: its pressure "
            f"angle reaches {a.worst_deg:.2f} deg at input angle {a.phi_deg:.1f} deg; MuJoCo follows the "
            f"linkage faithfully only up to {a.limit_deg:g} deg (mechanisms/README.md, Dead points)"
        )

    def mirror(self, P: Points, j: int) -> np.ndarray:
        c, s, n1, n2 = (P[p][j] for p in (self.point, self.start, *self.guide))
        u = (n2 - n1)[:2] / np.linalg.norm((n2 - n1)[:2])
        foot = n1[:2] + np.dot((s - n1)[:2], u) * u
        m2 = 2 * foot - c[:2]  # reflection of C across the foot of the perpendicular
        return np.array([m2[0], m2[1], c[2]])

    def flipped(self) -> str:
        return f"toward {next(g for g in self.guide if g != self.toward)} instead of {self.toward}"

    def named(self) -> str:
        return f"slider {self.start}-{self.point}"

    def describe(self) -> str:
        return (
            f"slider from {self.start}, {self.length * 1e3:g} mm, on {self.guide[0]}-{self.guide[1]} "
            f"towards {self.toward}"
        )


# ------------------------------------------------------------------------ whole sequences
def input_crank(steps: Iterable[Block]) -> Crank:
    """The input crank of a construction sequence (its first crank without a gear)."""
    return next(s for s in steps if isinstance(s, Crank) and s.is_input)


def geared(steps: Iterable[Block]) -> tuple[Crank, ...]:
    """The geared cranks of a construction sequence, in order."""
    return tuple(s for s in steps if isinstance(s, Crank) and not s.is_input)


def sliders(steps: Iterable[Block]) -> tuple[Slider, ...]:
    """The sliders of a construction sequence, in order."""
    return tuple(s for s in steps if isinstance(s, Slider))


def read(r: Reader, raw: Any, i: int) -> Block:
    """One ``[[construct]]`` table (the ``i``-th) as its block, or a one-line error."""

    where = f"[[construct]] #{i + 1}"
    raw = r.table(raw, where)
    kind = r.string(raw, "block", where)
    if kind not in Block.types:
        hint = did_you_mean(kind, list(Block.types))
        raise r.fail(f"{where} block", f"unknown block '{kind}' ({hint}valid: {', '.join(Block.types)})")
    point = r.name(raw.get("point"), f"{where} point") if "point" in raw else None
    if point is None:
        raise r.fail(where, "missing key 'point'")
    return Block.types[kind].read(r, raw, point, f"[[construct]] {point} ({kind})")
