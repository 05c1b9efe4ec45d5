"""Mechanism files: TOML in the papers' units, read once into typed, validated objects.

A mechanism file (see ``mechanisms/README.md``) names fixed points, builds every moving
point with the papers' building blocks in order, and groups points into rigid links. Both
the vector-method reference (:mod:`mjlink.reference`) and the MuJoCo builder
(:mod:`mjlink.sim.builder`) derive from the :class:`Mechanism` returned here; nothing else
holds a copy of the geometry.

Units: files use mm, deg, g, kg*m^2, N, N*m, N*m*s, rad/s and s. The objects returned here
are in SI (m, rad, kg, kg*m^2, N, N*m, N*m*s, rad/s, s).
"""

from __future__ import annotations

import bisect
import dataclasses
import itertools
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import FileTooLargeError, MechanismFileError
from ..units import DEG, MM, G
from . import blocks as _blocks
from . import catalogue as _catalogue
from . import names as _names
from . import timing as _timing
from .blocks import Attached, Block, Crank, Dyad, Slider
from .limits import (
    HEAD,
    MAX_ANGLE_DEG,
    MAX_CHECK_POINT_SAMPLES,
    MAX_CYCLES,
    MAX_DAMPING,
    MAX_DURATION_S,
    MAX_FILE_BYTES,
    MAX_FORCE_N,
    MAX_GRAVITY,
    MAX_INERTIA,
    MAX_LENGTH_MM,
    MAX_MASS_G,
    MAX_POINTS,
    MAX_SPEED,
    MAX_SYNTH_PRESSURE_DEG,
    MAX_SYNTH_RATIO,
    MAX_TITLE_CHARS,
    MAX_TORQUE_NM,
    MIN_BAR_MM,
    MIN_DURATION_S,
    MIN_SPEED,
    SAMPLES_PER_TURN,
    TARGET_DELTA,
    above,
    below,
)
from .names import RESERVED_LINK_NAMES
from .presser import (
    FABRIC_DEFAULTS,
    PRESSER_DEFAULTS,
    Fabric,
    Presser,
    read_fabric,
    read_presser,
    unfit,
)
from .reader import Reader, shown
from .tension import ThreadTension, read_tension
from .timing import Balance, Timing

__all__ = [
    "Attached",
    "Block",
    "Counterweight",
    "Crank",
    "Dyad",
    "Dynamics",
    "Force",
    "Link",
    "Mechanism",
    "Motor",
    "Slider",
    "SteadyCase",
    "Synthesis",
    "load",
    "parse",
]


@dataclass(frozen=True)
class Link:
    """A rigid link: the points it carries and its mass properties.

    ``mass`` kg; ``inertia`` kg*m^2 about the centre of mass, normal to the plane; ``com``
    the point that is its centre of mass (None: massless). ``guide``: two points of another
    link (or of the ground) along whose line this link translates (a prismatic pair).
    """

    name: str
    points: tuple[str, ...]
    mass: float = 0.0
    inertia: float = 0.0
    com: str | None = None
    guide: tuple[str, str] | None = None

    @property
    def direction(self) -> tuple[str, str]:
        """The two points whose line gives the link's angle: its guide's if it slides, else its
        first two."""
        a, b = self.guide if self.guide else self.points[:2]
        return a, b


@dataclass(frozen=True)
class Force:
    """An external force (N, world frame) acting at a named point: constant ``value``, or a
    table against the input angle (``angles`` rad, increasing, within one period; ``values``
    (n, 3) N), interpolated linearly and periodically over the mechanism's period."""

    point: str
    value: tuple[float, float, float] = (0.0, 0.0, 0.0)
    angles: tuple[float, ...] | None = None
    values: tuple[tuple[float, float, float], ...] | None = None
    # A factor on a table, one per row (N,) where a design study varies it per variant (a
    # single variant's factor is applied to ``values`` directly).
    scale: Any = 1.0

    def at(self, phi, period: float) -> np.ndarray:
        """The force (N) at input angles phi (rad): (N, 3). A table is interpolated as
        :meth:`at_scalar` does, step for step, on every angle at once."""
        phi = np.atleast_1d(np.asarray(phi, dtype=float))
        if self.angles is None:
            return np.broadcast_to(np.asarray(self.value), (len(phi), 3))
        a = np.asarray(self.angles)
        vals = np.asarray(self.values, dtype=float)
        x = (phi - a[0]) % period + a[0]
        i = np.searchsorted(a, x, side="right")
        ends = np.append(a, a[0] + period)  # after the last row, the first one a period on
        rows = np.vstack([vals, vals[:1]])
        x0, x1, v0, v1 = ends[i - 1], ends[i], rows[i - 1], rows[i]
        w = (x - x0) / (x1 - x0)
        table = v0 + w[:, None] * (v1 - v0)
        return table if np.ndim(self.scale) == 0 and self.scale == 1.0 else table * np.asarray(self.scale)[..., None]

    def at_scalar(self, phi: float, period: float) -> tuple[float, float, float]:
        """The force (N) at one input angle (rad), without numpy's per-call overhead: the
        ODE and MuJoCo's per-stage callback call this tens of thousands of times. The one
        interpolation of a table: linear between its rows, from the last row to the first a
        period later (the file holds a table's angles within one period); :meth:`at` is the
        same on arrays (tested equal)."""
        if self.angles is None:
            return self.value

        a, vals = self.angles, self.values
        assert vals is not None  # a table has both angles and values (parse)
        x = (phi - a[0]) % period + a[0]
        i = bisect.bisect_right(a, x)
        x0, v0 = a[i - 1], vals[i - 1]
        x1, v1 = (a[i], vals[i]) if i < len(a) else (a[0] + period, vals[0])
        w = (x - x0) / (x1 - x0)
        return (v0[0] + w * (v1[0] - v0[0]), v0[1] + w * (v1[1] - v0[1]), v0[2] + w * (v1[2] - v0[2]))


@dataclass(frozen=True)
class Motor:
    """A drive motor's linear characteristic: torque ``stall_torque`` (N*m) at rest, falling
    linearly to zero at ``no_load_speed`` (rad/s); both signed in the input crank's sense."""

    stall_torque: float
    no_load_speed: float

    def torque(self, omega):
        """Torque (N*m) at crank speed omega (rad/s)."""
        return self.stall_torque * (1.0 - np.asarray(omega) / self.no_load_speed)


@dataclass(frozen=True, kw_only=True)
class Dynamics:
    """The forward-dynamics case.

    ``moment`` driving moment on the input crank, N*m; ``damping`` viscous torque
    coefficient on it, N*m*s; ``omega0`` initial crank speed, rad/s; ``duration`` s;
    ``gravity`` m/s^2 along -Y; ``forces`` external forces at points; ``paper_rk4_steps`` the
    number of fixed steps the source paper's own RK4 took over ``duration`` (None: the paper
    integrated no equation of motion, and no "paper's RK4" is computed or drawn).
    """

    moment: float = 0.0
    damping: float = 0.0
    omega0: float = 0.0
    duration: float = 1.0
    gravity: float = 9.81
    forces: tuple[Force, ...] = ()
    motor: Motor | None = None
    paper_rk4_steps: int | None = None

    def drive_torque(self, omega):
        """Driving torque on the input crank (N*m) at speed omega (rad/s): moment + motor."""
        return self.moment + (self.motor.torque(omega) if self.motor else 0.0 * np.asarray(omega))


@dataclass(frozen=True)
class SteadyCase:
    """The load for a steady-motion study: a motor characteristic (N*m at rest, rad/s at no
    load, signed in the crank's sense) and the target coefficient of speed fluctuation."""

    motor: Motor
    target_delta: float = 0.02


@dataclass(frozen=True)
class Synthesis:
    """Inputs of a crank-slider metric synthesis (seed 002): ``stroke`` and ``offset`` m,
    ``ratio`` lambda = r / l, ``max_pressure_angle`` rad (the allowed [theta])."""

    stroke: float
    offset: float
    ratio: float
    max_pressure_angle: float


@dataclass(frozen=True)
class Counterweight:
    """A point mass rigidly on the input crank: ``mass`` kg at ``radius`` m from the crank's
    pivot, at ``angle`` rad from the crank's direction pivot -> crank pin (pi: opposite the pin).
    Numbers may be one per row in a design study."""

    mass: Any
    radius: Any
    angle: Any


COUNTERWEIGHT = "counterweight"  # its point's name in the reference's kinematics


@dataclass(frozen=True, kw_only=True)
class Mechanism:
    """A validated mechanism, SI units. Build with :func:`load`."""

    name: str
    title: str
    source: str
    path: Path | None
    ground: dict[str, np.ndarray] = field(repr=False)
    steps: tuple[Block, ...]
    links: tuple[Link, ...]
    phi0: float
    speed: float
    cycles: float
    dynamics: Dynamics
    thread: tuple[str, ...] | None = None
    thread_elongation: float | None = None  # m, the papers' dP in the feed Pd = dlF - dP
    has_dynamics: bool = False  # a [dynamics] table was given
    synthesis: Synthesis | None = None
    steady: SteadyCase | None = None
    counterweight: Counterweight | None = None
    timing: Timing | None = None  # a sewing head's [timing] table (mjlink.model.timing)
    balance: Balance | None = None  # its needle thread's [balance] (mjlink.model.timing)
    tension: ThreadTension | None = None  # its [tension] table (mjlink.model.tension); None: the defaults
    presser: Presser | None = None  # its [presser] table (mjlink.model.presser); None: the defaults
    fabric: Fabric | None = None  # its [fabric] table (mjlink.model.presser); None: the defaults
    # The text this mechanism was parsed from, read once: every output of a run (design.html's
    # "Save as TOML") comes from it, never from the file read again, which may have changed.
    text: str | None = field(default=None, repr=False, compare=False)

    @property
    def input_crank(self) -> Crank:
        return _blocks.input_crank(self.steps)

    @property
    def geared(self) -> tuple[Crank, ...]:
        """The cranks geared to the input crank."""
        return _blocks.geared(self.steps)

    @property
    def input_link(self) -> Link:
        return self.link(self.input_crank.carriers(self.links)[0])

    def carrier(self, block: Block) -> Link:
        """The link that carries a crank's bar (the first of a block's carriers)."""
        return self.link(block.carriers(self.links)[0])

    def link(self, name: str) -> Link:
        """The link called ``name``."""
        return next(l for l in self.links if l.name == name)

    @property
    def point_names(self) -> tuple[str, ...]:
        return tuple(self.ground) + tuple(s.point for s in self.steps)

    @property
    def moving_points(self) -> tuple[str, ...]:
        return tuple(s.point for s in self.steps)

    @property
    def period(self) -> float:
        """Input angle (rad) after which every point repeats: 2 pi times the gears' denominator."""
        q = 1
        for s in self.steps:
            q = math.lcm(q, s.period_turns)
        return 2.0 * math.pi * q

    def link_of(self, point: str) -> Link | None:
        """The first link carrying ``point`` (None for a ground point on no link)."""
        return next((l for l in self.links if point in l.points), None)


# ----------------------------------------------------------------------------- reading
def _read_link(r: Reader, name: str, raw: Any) -> Link:
    where = f"[links.{name}]"
    r.name(name, where)
    if name in RESERVED_LINK_NAMES:
        raise r.fail(
            where,
            f"'{name}' is reserved for the model's own elements (reserved: "
            f"{', '.join(RESERVED_LINK_NAMES)}): choose another link name",
        )
    raw = r.table(raw, where)
    r.keys(raw, where, ["points"], ["mass", "inertia", "com", "guide"])
    points = r.names(raw["points"], f"{where} points")
    mass = r.number(
        raw, "mass", where, default=0.0, nonneg=True, scale=G, hi=MAX_MASS_G, unit=" g", why="a machine part"
    )
    inertia = r.number(
        raw, "inertia", where, default=0.0, nonneg=True, hi=MAX_INERTIA, unit=" kg*m^2", why="a machine part"
    )
    com = r.name(raw["com"], f"{where} com") if "com" in raw else None
    if mass > 0 and com is None:
        raise r.fail(where, "has a mass but no 'com' (the point that is its centre of mass)")
    if inertia > 0 and mass == 0:
        raise r.fail(where, "has a moment of inertia but zero mass")
    pair = r.names(raw["guide"], f"{where} guide", length=2) if "guide" in raw else None
    guide = (pair[0], pair[1]) if pair else None
    if guide is not None and guide[0] == guide[1]:
        raise r.fail(f"{where} guide", "needs two different points")
    if len(set(points)) != len(points):
        raise r.fail(f"{where} points", "lists a point twice")
    if len(points) < 2 and guide is None:
        raise r.fail(f"{where} points", "a link needs two points (or one point and a 'guide' it slides on)")
    if com is not None and com not in points:
        points = (*points, com)
    return Link(name, points, mass, inertia, com, guide)


def _read_counterweight(r: Reader, raw: Any) -> Counterweight:
    where = "[counterweight]"
    raw = r.table(raw, where)
    r.keys(raw, where, ["mass", "radius"], ["angle"])
    return Counterweight(
        r.number(raw, "mass", where, nonneg=True, scale=G, hi=MAX_MASS_G, unit=" g", why="a machine part"),
        r.number(raw, "radius", where, nonneg=True, scale=MM, hi=MAX_LENGTH_MM, unit=" mm"),
        r.number(raw, "angle", where, scale=DEG, hi=MAX_ANGLE_DEG, unit=" deg", why="an angle")
        if "angle" in raw
        else math.pi,  # opposite the crank pin, where a counterweight balances it
    )


MAX_PAPER_RK4_STEPS = 1_000_000
_LIMITS = "see mechanisms/README.md, Limits"


def _steps(r: Reader, raw: dict, key: str, where: str) -> int | None:
    """An optional whole number of integration steps (1..MAX_PAPER_RK4_STEPS), None if absent."""
    if key not in raw:
        return None
    v = raw[key]
    if isinstance(v, bool) or not isinstance(v, int) or not 1 <= v <= MAX_PAPER_RK4_STEPS:
        raise r.fail(
            f"{where} {key}", f"must be a whole number of steps from 1 to {MAX_PAPER_RK4_STEPS:,}, got {shown(v)}"
        )
    return v


def _read_motor(r: Reader, raw: Any, where: str) -> Motor:
    raw = r.table(raw, where)
    if where == "[dynamics.motor]":
        r.keys(raw, where, ["stall_torque", "no_load_speed"])
    ts = r.number(raw, "stall_torque", where, hi=MAX_TORQUE_NM, unit=" N*m", why=_LIMITS)
    w0 = r.number(
        raw, "no_load_speed", where, lo=MIN_SPEED, hi=MAX_SPEED, unit=" rad/s", why="see mechanisms/README.md, Limits"
    )
    if ts == 0 or w0 == 0 or (ts > 0) != (w0 > 0):
        raise r.fail(where, "stall_torque and no_load_speed must be non-zero and of the same sign")
    return Motor(ts, w0)


_FORCE = {"unit": "N", "hi": MAX_FORCE_N, "what": "force components", "why": _LIMITS}


def _read_force(r: Reader, raw: Any, w: str, known: set[str], period_deg: float) -> Force:
    """One ``[[dynamics.force]]``: a constant force, or a table whose angles (deg) increase
    strictly within one period of the mechanism, [0, ``period_deg``): an angle beyond it would
    repeat another and be read differently by two interpolations."""
    fr = r.table(raw, w)
    r.keys(fr, w, ["point"], ["value", "angles", "values"])
    p = r.name(fr["point"], f"{w} point")
    if p not in known:
        raise r.fail(w, f"uses point '{p}', which is not defined")
    if ("value" in fr) == ("angles" in fr or "values" in fr):
        raise r.fail(w, "give either 'value' (constant) or 'angles' and 'values' (a table)")
    if "value" in fr:
        return Force(p, tuple(r.vector(fr["value"], f"{w} value", **_FORCE)))
    if "angles" not in fr or "values" not in fr:
        raise r.fail(w, "a force table needs both 'angles' (deg) and 'values' (N)")
    angs = fr["angles"]
    if not isinstance(angs, list) or len(angs) < 2:
        raise r.fail(f"{w} angles", "must be a list of at least two angles (deg)")
    a = [r.number({f"[{j}]": x}, f"[{j}]", f"{w} angles", unit=" deg") for j, x in enumerate(angs)]
    out = next((x for x in a if x < 0.0 or x >= period_deg), None)
    if out is not None:
        # The same angle within the period, where it still has digits to say it with.
        same = f": write it as {out % period_deg:g}, in order" if abs(out) < 10 * period_deg else ""
        raise r.fail(
            f"{w} angles",
            f"must lie within one period of the mechanism, 0 to {period_deg:g} deg (excluded), got {out:g} deg{same}",
        )
    if not all(x1 > x0 for x0, x1 in itertools.pairwise(a)):
        raise r.fail(f"{w} angles", "must increase strictly")
    vals = fr["values"]
    if not isinstance(vals, list) or len(vals) != len(angs):
        raise r.fail(f"{w} values", f"must list one force per angle ({len(angs)})")
    rows = tuple(tuple(r.vector(v, f"{w} values", **_FORCE)) for v in vals)
    return Force(p, angles=tuple(x * DEG for x in a), values=rows)


def _cycle(steps: tuple[Block, ...], start: str, first: str) -> list[str] | None:
    """The chain ``start -> first -> ... -> start`` (each uses the next) if ``first`` is built,
    directly or through other blocks, from ``start``; None if it is not."""
    by_point = {s.point: s for s in steps}
    seen: set[str] = set()

    def walk(p: str) -> list[str] | None:
        if p == start:
            return [p]
        if p in seen or p not in by_point:
            return None
        seen.add(p)
        for q in by_point[p].inputs:
            rest = walk(q)
            if rest is not None:
                return [p, *rest]
        return None

    rest = walk(first)
    return [start, *rest] if rest is not None else None


def parse(text: str, path: Path | str = "<string>") -> Mechanism:
    """Parse and validate a mechanism file's text. Raises MechanismFileError."""
    r = Reader(path)
    data = r.toml(text)
    r.keys(
        data,
        "",
        ["mechanism", "ground", "construct", "links", "input"],
        [
            "dynamics",
            "thread",
            "synthesis",
            "steady",
            "counterweight",
            "timing",
            "balance",
            "tension",
            "presser",
            "fabric",
        ],
    )

    meta = r.table(data["mechanism"], "[mechanism]")
    r.keys(meta, "[mechanism]", ["name", "title"], ["source"])
    name = r.name(meta["name"], "[mechanism] name")
    title = r.string(meta, "title", "[mechanism]", max_length=MAX_TITLE_CHARS)
    source = r.string(meta, "source", "[mechanism]", default="", max_length=MAX_TITLE_CHARS)

    ground = {}
    for k, v in r.table(data["ground"], "[ground]").items():
        ground[r.name(k, "[ground]")] = r.vector(v, f"[ground] {k}", scale=MM, hi=MAX_LENGTH_MM, unit="mm")
    if not ground:
        raise r.fail("[ground]", "needs at least one fixed point")

    raw_steps = data["construct"]
    if not isinstance(raw_steps, list):
        raise r.fail("[[construct]]", "must be an array of tables: write each block under its own [[construct]]")
    if not raw_steps:
        raise r.fail("[[construct]]", "needs at least one block (a crank first)")
    if len(ground) + len(raw_steps) > MAX_POINTS:
        raise r.fail(
            "[[construct]]",
            f"{len(ground)} ground and {len(raw_steps)} built points: at most {MAX_POINTS} in all "
            "(every check solves each point over the cycle; see mechanisms/README.md, Limits)",
        )
    steps = tuple(_blocks.read(r, s, i) for i, s in enumerate(raw_steps))

    # Construction order: every block may only use points already defined.
    known = set(ground)
    for s in steps:
        where = f"[[construct]] {s.point}"
        if s.point in known:
            raise r.fail(where, f"point '{s.point}' is defined twice")
        for p in s.inputs:
            if p not in known:
                if not any(t.point == p for t in steps):
                    raise r.fail(where, f"uses point '{p}', which is not defined")
                cycle = _cycle(steps, s.point, p)
                if cycle:
                    raise r.fail(
                        where,
                        f"uses point '{p}', which is built from '{s.point}' itself: the blocks "
                        f"{' -> '.join(cycle)} form a cycle, so no order can build them",
                    )
                raise r.fail(where, f"uses point '{p}', which is defined later: order the blocks so inputs come first")
        known.add(s.point)
    if not steps[0].is_input:
        raise r.fail("[[construct]]", "the first block must be the input crank (a crank with no ratio or phase)")
    for i, s in enumerate(steps):
        s.check(r, ground, i == 0)

    links_raw = r.table(data["links"], "[links]")
    if not links_raw:
        raise r.fail("[links]", "needs at least one link")
    links = tuple(_read_link(r, k, v) for k, v in links_raw.items())
    for l in links:
        for p in l.points + (l.guide or ()):
            if p not in known:
                raise r.fail(f"[links.{l.name}]", f"uses point '{p}', which is not defined")
        if l.name in ground or l.name in known:
            raise r.fail(f"[links.{l.name}]", "a link may not share its name with a point")
    for s in steps:
        if not any(s.point in l.points for l in links):
            raise r.fail(
                f"[[construct]] {s.point}", f"point '{s.point}' belongs to no link: list it in a [links.*] points"
            )
    pivot = steps[0].inputs[0]
    if not any(pivot in l.points and steps[0].point in l.points for l in links):
        raise r.fail("[links]", f"no link carries the input crank {pivot}-{steps[0].point}")
    clash = _names.element_clash(links, set(ground))
    if clash:
        raise r.fail(f"[links.{clash[0]}]", clash[1])

    inp = r.table(data["input"], "[input]")
    r.keys(inp, "[input]", ["phi0", "speed"], ["cycles"])
    phi0 = r.number(inp, "phi0", "[input]", scale=DEG, hi=MAX_ANGLE_DEG, unit=" deg", why="an angle")
    speed = r.number(inp, "speed", "[input]", unit=" rad/s")
    if speed == 0:
        raise r.fail("[input] speed", "must be non-zero (rad/s, CCW positive)")
    if below(abs(speed), MIN_SPEED) or above(abs(speed), MAX_SPEED):
        raise r.fail(
            "[input] speed",
            f"must be between {MIN_SPEED:g} and {MAX_SPEED:g} rad/s in magnitude "
            f"(see mechanisms/README.md, Limits), got {speed:g} rad/s",
        )
    cycles = r.number(inp, "cycles", "[input]", default=1.0, positive=True, hi=MAX_CYCLES)

    dyn_raw = r.table(data.get("dynamics", {}), "[dynamics]")
    r.keys(
        dyn_raw,
        "[dynamics]",
        [],
        [
            "moment",
            "damping",
            "omega0",
            "duration",
            "gravity",
            "force",
            "motor",
            "paper_rk4_steps",
        ],
    )
    forces = []
    raw_forces = dyn_raw.get("force", [])
    if not isinstance(raw_forces, list):
        raise r.fail("[[dynamics.force]]", "must be an array of tables ([[dynamics.force]])")
    turns = 1
    for s in steps:
        turns = math.lcm(turns, s.period_turns)
    for i, fr in enumerate(raw_forces):
        forces.append(_read_force(r, fr, f"[[dynamics.force]] #{i + 1}", known, 360.0 * turns))
    motor = _read_motor(r, dyn_raw["motor"], "[dynamics.motor]") if "motor" in dyn_raw else None
    if "dynamics" in data:
        massless = [l.name for l in links if l.mass <= 0]
        if massless:
            raise r.fail(
                f"[links.{massless[0]}]",
                "has no mass, but the file has a [dynamics] case: give every "
                "link its mass, inertia and com (a massless link is allowed only for kinematics)",
            )
    steady = None
    if "steady" in data:
        st = r.table(data["steady"], "[steady]")
        r.keys(st, "[steady]", ["stall_torque", "no_load_speed"], ["target_delta"])
        steady = SteadyCase(
            _read_motor(r, st, "[steady]"),
            r.number(
                st,
                "target_delta",
                "[steady]",
                default=0.02,
                bound=TARGET_DELTA,
            ),
        )
    elif motor is not None:
        steady = SteadyCase(motor)
    dynamics = Dynamics(
        moment=r.number(dyn_raw, "moment", "[dynamics]", default=0.0, hi=MAX_TORQUE_NM, unit=" N*m", why=_LIMITS),
        damping=r.number(
            dyn_raw, "damping", "[dynamics]", default=0.0, nonneg=True, hi=MAX_DAMPING, unit=" N*m*s", why=_LIMITS
        ),
        omega0=r.number(
            dyn_raw,
            "omega0",
            "[dynamics]",
            default=0.0,
            hi=MAX_SPEED,
            unit=" rad/s",
            why="see mechanisms/README.md, Limits",
        ),
        duration=r.number(
            dyn_raw,
            "duration",
            "[dynamics]",
            default=1.0,
            positive=True,
            lo=MIN_DURATION_S,
            hi=MAX_DURATION_S,
            unit=" s",
        ),
        gravity=r.number(
            dyn_raw, "gravity", "[dynamics]", default=9.81, nonneg=True, hi=MAX_GRAVITY, unit=" m/s^2", why=_LIMITS
        ),
        forces=tuple(forces),
        motor=motor,
        paper_rk4_steps=_steps(r, dyn_raw, "paper_rk4_steps", "[dynamics]"),
    )

    thread = elongation = None
    if "thread" in data:
        th = r.table(data["thread"], "[thread]")
        r.keys(th, "[thread]", ["path"], ["elongation"])
        thread = r.names(th["path"], "[thread] path", min_length=2)
        if "elongation" in th:
            elongation = r.number(
                th, "elongation", "[thread]", nonneg=True, scale=MM, hi=MAX_LENGTH_MM, unit=" mm", why=_LIMITS
            )
        for p in thread:
            if p not in known:
                raise r.fail("[thread] path", f"uses point '{p}', which is not defined")
        for a, b in itertools.pairwise(thread):
            if a == b:
                raise r.fail(
                    "[thread] path", f"names '{a}' twice in a row: the thread runs from each point to the next"
                )

    synthesis = None
    if "synthesis" in data:
        sy = r.table(data["synthesis"], "[synthesis]")
        r.keys(sy, "[synthesis]", ["stroke", "offset", "lambda", "max_pressure_angle"])
        theta = r.number(sy, "max_pressure_angle", "[synthesis]", positive=True, unit=" deg")
        if theta >= MAX_SYNTH_PRESSURE_DEG:
            raise r.fail("[synthesis] max_pressure_angle", f"must be below 90 deg, got {theta:g}")
        ratio = r.number(sy, "lambda", "[synthesis]", positive=True)
        if ratio >= MAX_SYNTH_RATIO:
            raise r.fail(
                "[synthesis] lambda", f"must be below 1 (a crank longer than its rod cannot turn), got {ratio:g}"
            )
        bar: dict[str, Any] = {"scale": MM, "hi": MAX_LENGTH_MM, "unit": " mm", "why": _LIMITS}
        synthesis = Synthesis(
            r.number(sy, "stroke", "[synthesis]", positive=True, lo=MIN_BAR_MM, **bar),
            r.number(sy, "offset", "[synthesis]", nonneg=True, **bar),
            ratio,
            theta * DEG,
        )

    mech = Mechanism(
        name=name,
        title=title,
        source=source,
        path=Path(path) if path != "<string>" else None,
        ground=ground,
        steps=steps,
        links=links,
        phi0=phi0,
        speed=speed,
        cycles=cycles,
        dynamics=dynamics,
        thread=thread,
        thread_elongation=elongation,
        has_dynamics="dynamics" in data,
        synthesis=synthesis,
        steady=steady,
        counterweight=_read_counterweight(r, data["counterweight"]) if "counterweight" in data else None,
        timing=_timing.read(r, data["timing"], set(ground), steps, links) if "timing" in data else None,
        text=text,
    )
    fed = mech.timing is not None and mech.timing.has("feed_dog")
    if "fabric" in data:
        mech = dataclasses.replace(mech, fabric=read_fabric(r, data["fabric"], fed))
        if mech.fabric is not None and mech.fabric.plies:
            mech = _plied(r, mech, data["timing"])
    if "balance" in data:
        mech = dataclasses.replace(
            mech, balance=_timing.read_balance(r, data["balance"], thread, mech.timing, steps, ground)
        )
    if "tension" in data:
        mech = dataclasses.replace(mech, tension=read_tension(r, data["tension"], mech.balance is not None))
    if "presser" in data:
        thick = mech.timing.fabric if mech.timing is not None else 0.0
        mech = dataclasses.replace(mech, presser=read_presser(r, data["presser"], fed, thick))
    if mech.timing is not None and (mech.presser is not None or mech.fabric is not None or mech.timing.has("feed_dog")):
        # The defaults a head without the tables feeds with are held as a written table is.
        where, why = unfed(mech)
        if why:
            raise r.fail(where, why)
    # The cost of every check over a cycle (see limits.MAX_CHECK_POINT_SAMPLES), before any.
    turns = round(mech.period / (2 * math.pi))
    if mech.timing is not None and turns != 1:
        raise r.fail(
            "[timing]",
            f"a head makes one stitch per main-shaft turn, but its shafts repeat only after {turns} turns: "
            "every geared crank's ratio must be a whole number",
        )
    if len(mech.point_names) * SAMPLES_PER_TURN * turns > MAX_CHECK_POINT_SAMPLES:
        raise r.fail(
            "",
            f"{len(mech.point_names)} points over a period of {turns} crank turns: checking them takes "
            f"{len(mech.point_names) * turns} point-turns, at most {MAX_CHECK_POINT_SAMPLES // SAMPLES_PER_TURN} "
            "(use fewer points, or gear ratios with a smaller denominator; see mechanisms/README.md, Limits)",
        )
    return mech


PLIES_AGREE = 1e-9  # m: a [timing] fabric this close to the plies' thickness together is theirs


def _plied(r: Reader, mech: Mechanism, timing: Any) -> Mechanism:
    """The head with its ``[timing] fabric`` the plies' thickness together: left out, it is
    theirs; given, it must be."""
    assert mech.timing is not None and mech.fabric is not None
    total = sum(p.thickness for p in mech.fabric.plies)
    bound = HEAD["timing.fabric"]
    if bound.refuses(total / MM) is not None:
        raise r.fail("[[fabric.ply]]", f"the plies together {bound.refuses(total / MM)}")
    if isinstance(timing, dict) and "fabric" in timing and abs(mech.timing.fabric - total) > PLIES_AGREE:
        raise r.fail(
            "[timing] fabric",
            f"is {mech.timing.fabric / MM:g} mm but the [[fabric.ply]] plies together are {total / MM:g} mm: "
            "leave it out (the plies' is taken) or make them agree",
        )
    return dataclasses.replace(mech, timing=dataclasses.replace(mech.timing, fabric=total))


def unfed(mech: Mechanism) -> tuple[str, str]:
    """Why the head's presser and fabric (its tables, or the defaults) cannot be fed, as (the
    table or key at fault, why), or ('', '') if they can (:func:`~.presser.unfit`)."""
    if mech.timing is None:
        return "", ""
    p, f = mech.presser or PRESSER_DEFAULTS, mech.fabric or FABRIC_DEFAULTS
    return unfit(p, f, float(mech.timing.fabric), default_presser=mech.presser is None)


def load(path: str | Path) -> Mechanism:
    """Read and validate a mechanism file. Raises MechanismFileError with a one-line message."""
    p = Path(path)
    what = _catalogue.what_is(p)
    if what is not None:
        raise MechanismFileError(f"{p}: is {what}, not a mechanism file")
    try:
        size = p.stat().st_size
        if size > MAX_FILE_BYTES:
            raise FileTooLargeError(
                f"{p}: {size} bytes; a mechanism file is at most {MAX_FILE_BYTES} bytes (1 MiB): it is read whole"
            )
        text = p.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise MechanismFileError(f"{p}: no such file") from None
    except (OSError, UnicodeDecodeError) as e:
        raise MechanismFileError(f"{p}: cannot read: {e}") from None
    return parse(text, p)
