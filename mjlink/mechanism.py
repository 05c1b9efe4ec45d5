"""Mechanism files: TOML in the papers' units, read once into typed, validated objects.

A mechanism file (see ``mechanisms/README.md``) names fixed points, builds every moving
point with the papers' building blocks in order, and groups points into rigid links. Both
the vector-method reference (:mod:`mjlink.reference`) and the MuJoCo builder
(:mod:`mjlink.builder`) derive from the :class:`Mechanism` returned here; nothing else
holds a copy of the geometry.

Units: files use mm, deg, g, kg*m^2, N, N*m, N*m*s, rad/s and s. The objects returned here
are in SI (m, rad, kg, kg*m^2, N, N*m, N*m*s, rad/s, s).
"""

from __future__ import annotations

import difflib
import math
import re
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterable

import numpy as np

from .errors import MechanismFileError

MM = 1e-3
G = 1e-3
DEG = math.pi / 180.0

# A letter, then letters, digits or _; at most 32. ASCII only; \Z (unlike $) refuses a trailing
# newline. Names become MuJoCo element names, CSV column prefixes and the output folder's name,
# so they can never hold a path separator, a dot, a space or anything MJCF would need to escape.
_NAME_RE = re.compile(r"^[A-Za-z][A-Za-z0-9_]{0,31}\Z")

# Plausibility limits (mechanisms/README.md, "Limits"). Lengths and coordinates, mm: beyond a
# metre the agreement thresholds, which are absolute (0.1 um), are no longer met at machine
# speeds (errors grow with size); bars below 0.1 mm are not machine parts, and far below it
# MuJoCo's fixed tolerances dominate (a 2 um crank-slider missed the thresholds).
MAX_LENGTH_MM = 1000.0
MIN_BAR_MM = 0.1
# [input] speed, rad/s: below 1 rad/s a kinematic run of one turn needs > 125 000 steps;
# above 1e4 rad/s a turn is shorter than 13 steps. [input] cycles at most MAX_CYCLES.
MIN_SPEED, MAX_SPEED = 1.0, 1e4
MAX_CYCLES = 100.0
MAX_GEAR_RATIO = 64.0
# Angles in files (phi0, phase, attached angle): beyond a turn or two they only lose precision
# (phi0 = 1e300 deg leaves no digits for the crank's motion).
MAX_ANGLE_DEG = 720.0
# A link's mass (g) and moment of inertia (kg*m^2): a tonne and 1000 kg*m^2 are far beyond any
# machine part; absurd values would only overflow the reduced inertia or MuJoCo's mass matrix.
MAX_MASS_G, MAX_INERTIA = 1e6, 1e3
# Link names the MJCF already uses for its own elements (body 'world', materials
# 'mat_ground' and 'mat_eyelet'; a link NAME gets material 'mat_NAME').
RESERVED_LINK_NAMES = ("world", "ground", "eyelet")


# ----------------------------------------------------------------------------- blocks
@dataclass(frozen=True)
class Crank:
    """Block 1: ``point = pivot + length (cos a, sin a)``.

    ``a = phase + ratio (phi - phi0)`` where phi is the input crank angle. The input crank
    has ratio 1 and phase phi0; a geared crank has its own ratio (signed: negative turns
    the other way) and phase (its angle when phi = phi0). Lengths m, angles rad.
    """

    point: str
    pivot: str
    length: float
    ratio: float = 1.0
    phase: float | None = None

    @property
    def inputs(self) -> tuple[str, ...]:
        return (self.pivot,)


@dataclass(frozen=True)
class Dyad:
    """Block 2, RRR dyad: joint ``point`` at ``length_a`` from ``a`` and ``length_b`` from ``b``.

    ``point = b + rho(a - b, sign * U, length_b)`` with U from the cosine rule; ``sign``
    (+1 or -1) is the assembly branch. Lengths m.
    """

    point: str
    a: str
    b: str
    length_a: float
    length_b: float
    sign: int

    @property
    def inputs(self) -> tuple[str, ...]:
        return (self.a, self.b)


@dataclass(frozen=True)
class Attached:
    """Block 3: ``point = origin + rho(toward - origin, angle, length)``, at height ``z``.

    ``z`` (m) is the point's out-of-plane coordinate; None keeps the origin's. Angle rad.
    """

    point: str
    origin: str
    toward: str
    angle: float
    length: float
    z: float | None = None

    @property
    def inputs(self) -> tuple[str, ...]:
        return (self.origin, self.toward)


@dataclass(frozen=True)
class Slider:
    """Block 4, RRP dyad: ``point`` at ``length`` from ``start``, on the guide line ``guide``.

    Of the two solutions the one lying towards guide point ``toward`` is taken (the papers'
    "point at infinity"). Length m.
    """

    point: str
    start: str
    length: float
    guide: tuple[str, str]
    toward: str

    @property
    def inputs(self) -> tuple[str, ...]:
        return (self.start, *self.guide)


Block = Crank | Dyad | Attached | Slider
BLOCKS: dict[str, type] = {"crank": Crank, "dyad": Dyad, "attached": Attached, "slider": Slider}


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


@dataclass(frozen=True)
class Force:
    """An external force (N, world frame) acting at a named point: constant ``value``, or a
    table against the input angle (``angles`` rad, increasing, within one period; ``values``
    (n, 3) N), interpolated linearly and periodically over the mechanism's period."""

    point: str
    value: tuple[float, float, float] = (0.0, 0.0, 0.0)
    angles: tuple[float, ...] | None = None
    values: tuple[tuple[float, float, float], ...] | None = None

    def at(self, phi, period: float) -> np.ndarray:
        """The force (N) at input angles phi (rad): (N, 3)."""
        phi = np.atleast_1d(np.asarray(phi, dtype=float))
        if self.angles is None:
            return np.broadcast_to(np.asarray(self.value), (len(phi), 3))
        vals = np.asarray(self.values)
        return np.column_stack([np.interp(phi, self.angles, vals[:, i], period=period) for i in range(3)])

    def at_scalar(self, phi: float, period: float) -> tuple[float, float, float]:
        """The force (N) at one input angle (rad), without numpy's per-call overhead: the
        ODE and MuJoCo's per-stage callback call this tens of thousands of times. Equal to
        :meth:`at` (tested)."""
        if self.angles is None:
            return self.value
        import bisect

        a = self.angles
        x = (phi - a[0]) % period + a[0]
        i = bisect.bisect_right(a, x)
        x0, v0 = a[i - 1], self.values[i - 1]
        x1, v1 = (a[i], self.values[i]) if i < len(a) else (a[0] + period, self.values[0])
        w = (x - x0) / (x1 - x0)
        return tuple(p + w * (q - p) for p, q in zip(v0, v1))


@dataclass(frozen=True)
class Motor:
    """A drive motor's linear characteristic: torque ``stall_torque`` (N*m) at rest, falling
    linearly to zero at ``no_load_speed`` (rad/s); both signed in the input crank's sense."""

    stall_torque: float
    no_load_speed: float

    def torque(self, omega):
        """Torque (N*m) at crank speed omega (rad/s)."""
        return self.stall_torque * (1.0 - np.asarray(omega) / self.no_load_speed)


@dataclass(frozen=True)
class Dynamics:
    """The forward-dynamics case.

    ``moment`` driving moment on the input crank, N*m; ``damping`` viscous torque
    coefficient on it, N*m*s; ``omega0`` initial crank speed, rad/s; ``duration`` s;
    ``gravity`` m/s^2 along -Y; ``forces`` external forces at points.
    """

    moment: float = 0.0
    damping: float = 0.0
    omega0: float = 0.0
    duration: float = 1.0
    gravity: float = 9.81
    forces: tuple[Force, ...] = ()
    motor: Motor | None = None

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

    @property
    def input_crank(self) -> Crank:
        return next(s for s in self.steps if isinstance(s, Crank))

    @property
    def input_link(self) -> Link:
        crank = self.input_crank
        return next(l for l in self.links if crank.pivot in l.points and crank.point in l.points)

    @property
    def point_names(self) -> tuple[str, ...]:
        return tuple(self.ground) + tuple(s.point for s in self.steps)

    @property
    def moving_points(self) -> tuple[str, ...]:
        return tuple(s.point for s in self.steps)

    @property
    def period(self) -> float:
        """Input angle (rad) after which every point repeats: 2 pi times the gears' denominator."""
        from fractions import Fraction

        q = 1
        for s in self.steps:
            if isinstance(s, Crank):
                q = math.lcm(q, Fraction(s.ratio).limit_denominator(64).denominator)
        return 2.0 * math.pi * q

    def link_of(self, point: str) -> Link | None:
        """The first link carrying ``point`` (None for a ground point on no link)."""
        return next((l for l in self.links if point in l.points), None)


# ----------------------------------------------------------------------------- reading
class _Reader:
    """Walks a parsed TOML table, turning every problem into one clear line."""

    def __init__(self, path: Path | str):
        self.path = str(path)

    def fail(self, where: str, msg: str) -> MechanismFileError:
        return MechanismFileError(f"{self.path}: {where}: {msg}" if where else f"{self.path}: {msg}")

    def table(self, data: Any, where: str) -> dict:
        if not isinstance(data, dict):
            raise self.fail(where, f"must be a table, got {type(data).__name__}")
        return data

    def keys(self, data: dict, where: str, required: Iterable[str], optional: Iterable[str] = ()):
        required, optional = list(required), list(optional)
        valid = required + optional
        for k in data:
            if k not in valid:
                near = difflib.get_close_matches(k, valid, n=1)
                hint = f" (did you mean '{near[0]}'?)" if near else f" (valid keys: {', '.join(valid)})"
                raise self.fail(where, f"unknown key '{k}'{hint}")
        for k in required:
            if k not in data:
                raise self.fail(where, f"missing key '{k}'")

    def number(self, data: dict, key: str, where: str, *, default=None, positive=False,
               nonneg=False, scale=1.0, lo=None, hi=None, unit="", why="") -> float:
        """A finite number; ``lo``/``hi`` bound its magnitude (file units, ``unit`` for messages)."""
        if key not in data:
            if default is None:
                raise self.fail(where, f"missing key '{key}'")
            return default
        v = data[key]
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise self.fail(f"{where} {key}", f"must be a number, got {type(v).__name__} {v!r}")
        try:
            v = float(v)
        except OverflowError:  # TOML integers may have any number of digits
            raise self.fail(f"{where} {key}", f"must be finite, got an integer of {len(str(v))} digits") from None
        if not math.isfinite(v):
            raise self.fail(f"{where} {key}", f"must be finite, got {v}")
        if positive and v <= 0:
            raise self.fail(f"{where} {key}", f"must be > 0, got {v:g}")
        if nonneg and v < 0:
            raise self.fail(f"{where} {key}", f"must be >= 0, got {v:g}")
        why = f" ({why})" if why else ""
        if hi is not None and abs(v) > hi:
            raise self.fail(f"{where} {key}", f"must be at most {hi:g}{unit} in magnitude{why}, got {v:g}")
        if lo is not None and abs(v) < lo:
            raise self.fail(f"{where} {key}", f"must be at least {lo:g}{unit} in magnitude{why}, got {v:g}")
        return v * scale

    def string(self, data: dict, key: str, where: str, *, default=None) -> str:
        if key not in data:
            if default is None:
                raise self.fail(where, f"missing key '{key}'")
            return default
        v = data[key]
        if not isinstance(v, str):
            raise self.fail(f"{where} {key}", f"must be a string, got {type(v).__name__} {v!r}")
        return v

    def name(self, v: Any, where: str) -> str:
        if not isinstance(v, str) or not _NAME_RE.match(v):
            raise self.fail(where, f"invalid name {v!r}: use a letter then letters, digits or _ (at most 32)")
        return v

    def vector(self, v: Any, where: str, sizes=(2, 3), scale=1.0, hi=None) -> np.ndarray:
        """A list of 2 or 3 finite numbers (z = 0 if absent); ``hi`` bounds each coordinate, mm."""
        if not isinstance(v, list) or len(v) not in sizes:
            raise self.fail(where, f"must be a list of {' or '.join(map(str, sizes))} numbers, got {v!r}")
        out = []
        for x in v:
            try:
                ok = not isinstance(x, bool) and isinstance(x, (int, float)) and math.isfinite(float(x))
            except OverflowError:
                ok = False
            if not ok:
                raise self.fail(where, f"must hold finite numbers, got {v!r}")
            if hi is not None and abs(float(x)) > hi:
                raise self.fail(where, f"coordinates must be at most {hi:g} mm in magnitude (mjlink models machine "
                                       f"linkages; see mechanisms/README.md), got {v!r}")
            out.append(float(x) * scale)
        while len(out) < 3:
            out.append(0.0)
        return np.array(out)

    def names(self, v: Any, where: str, *, length: int | None = None, min_length: int = 1) -> tuple[str, ...]:
        if not isinstance(v, list) or (length is not None and len(v) != length) or len(v) < min_length:
            want = f"{length}" if length is not None else f"at least {min_length}"
            raise self.fail(where, f"must be a list of {want} point names, got {v!r}")
        return tuple(self.name(x, where) for x in v)


def _read_step(r: _Reader, raw: Any, i: int) -> Block:
    where = f"[[construct]] #{i + 1}"
    raw = r.table(raw, where)
    kind = r.string(raw, "block", where)
    if kind not in BLOCKS:
        near = difflib.get_close_matches(kind, list(BLOCKS), n=1)
        hint = f"did you mean '{near[0]}'? " if near else ""
        raise r.fail(f"{where} block", f"unknown block '{kind}' ({hint}valid: {', '.join(BLOCKS)})")
    point = r.name(raw.get("point"), f"{where} point") if "point" in raw else None
    if point is None:
        raise r.fail(where, "missing key 'point'")
    where = f"[[construct]] {point} ({kind})"
    bar = dict(positive=True, scale=MM, lo=MIN_BAR_MM, hi=MAX_LENGTH_MM, unit=" mm",
               why="mjlink models machine linkages; see mechanisms/README.md")
    if kind == "crank":
        r.keys(raw, where, ["block", "point", "pivot", "length"], ["ratio", "phase"])
        ratio = r.number(raw, "ratio", where, default=1.0)
        if ratio == 0:
            raise r.fail(f"{where} ratio", "must be non-zero")
        if not 1 / MAX_GEAR_RATIO <= abs(ratio) <= MAX_GEAR_RATIO:
            raise r.fail(f"{where} ratio", f"must be between 1/{MAX_GEAR_RATIO:g} and {MAX_GEAR_RATIO:g} in magnitude, "
                                           f"got {ratio:g}")
        phase = (r.number(raw, "phase", where, scale=DEG, hi=MAX_ANGLE_DEG, unit=" deg", why="an angle")
                 if "phase" in raw else None)
        return Crank(point, r.name(raw["pivot"], f"{where} pivot"), r.number(raw, "length", where, **bar), ratio, phase)
    if kind == "dyad":
        r.keys(raw, where, ["block", "point", "a", "b", "length_a", "length_b", "sign"])
        sign = raw["sign"]
        if isinstance(sign, bool) or sign not in (1, -1):
            raise r.fail(f"{where} sign", f"must be +1 or -1 (the assembly branch), got {sign!r}")
        a, b = r.name(raw["a"], f"{where} a"), r.name(raw["b"], f"{where} b")
        if a == b:
            raise r.fail(f"{where} b", f"must differ from a (both are '{a}'): a dyad joins two different points")
        return Dyad(point, a, b, r.number(raw, "length_a", where, **bar), r.number(raw, "length_b", where, **bar),
                    int(sign))
    if kind == "attached":
        r.keys(raw, where, ["block", "point", "origin", "toward", "angle", "length"], ["z"])
        z = r.number(raw, "z", where, scale=MM, hi=MAX_LENGTH_MM, unit=" mm") if "z" in raw else None
        origin, toward = r.name(raw["origin"], f"{where} origin"), r.name(raw["toward"], f"{where} toward")
        if origin == toward:
            raise r.fail(f"{where} toward", f"must differ from origin (both are '{origin}'): "
                                            "the direction from origin to toward would be undefined")
        return Attached(point, origin, toward,
                        r.number(raw, "angle", where, scale=DEG, hi=MAX_ANGLE_DEG, unit=" deg", why="an angle"),
                        r.number(raw, "length", where, nonneg=True, scale=MM, hi=MAX_LENGTH_MM, unit=" mm"), z)
    r.keys(raw, where, ["block", "point", "start", "length", "guide", "toward"])
    guide = r.names(raw["guide"], f"{where} guide", length=2)
    toward = r.name(raw["toward"], f"{where} toward")
    if toward not in guide:
        raise r.fail(f"{where} toward", f"must be one of the guide points {guide[0]}, {guide[1]}; got '{toward}'")
    return Slider(point, r.name(raw["start"], f"{where} start"), r.number(raw, "length", where, **bar), guide, toward)


def _read_link(r: _Reader, name: str, raw: Any) -> Link:
    where = f"[links.{name}]"
    r.name(name, where)
    if name in RESERVED_LINK_NAMES:
        raise r.fail(where, f"'{name}' is reserved for the model's own elements (reserved: "
                            f"{', '.join(RESERVED_LINK_NAMES)}): choose another link name")
    raw = r.table(raw, where)
    r.keys(raw, where, ["points"], ["mass", "inertia", "com", "guide"])
    points = r.names(raw["points"], f"{where} points")
    mass = r.number(raw, "mass", where, default=0.0, nonneg=True, scale=G, hi=MAX_MASS_G, unit=" g",
                    why="a machine part")
    inertia = r.number(raw, "inertia", where, default=0.0, nonneg=True, hi=MAX_INERTIA, unit=" kg*m^2",
                       why="a machine part")
    com = r.name(raw["com"], f"{where} com") if "com" in raw else None
    if mass > 0 and com is None:
        raise r.fail(where, "has a mass but no 'com' (the point that is its centre of mass)")
    if inertia > 0 and mass == 0:
        raise r.fail(where, "has a moment of inertia but zero mass")
    guide = r.names(raw["guide"], f"{where} guide", length=2) if "guide" in raw else None
    if guide is not None and guide[0] == guide[1]:
        raise r.fail(f"{where} guide", "needs two different points")
    if len(set(points)) != len(points):
        raise r.fail(f"{where} points", "lists a point twice")
    if len(points) < 2 and guide is None:
        raise r.fail(f"{where} points", "a link needs two points (or one point and a 'guide' it slides on)")
    if com is not None and com not in points:
        points = points + (com,)
    return Link(name, points, mass, inertia, com, guide)


def _read_motor(r: _Reader, raw: Any, where: str) -> Motor:
    raw = r.table(raw, where)
    if where == "[dynamics.motor]":
        r.keys(raw, where, ["stall_torque", "no_load_speed"])
    ts = r.number(raw, "stall_torque", where)
    w0 = r.number(raw, "no_load_speed", where)
    if ts == 0 or w0 == 0 or (ts > 0) != (w0 > 0):
        raise r.fail(where, "stall_torque and no_load_speed must be non-zero and of the same sign")
    return Motor(ts, w0)


def _element_name_clash(links: tuple[Link, ...], ground: set[str]) -> tuple[str, str] | None:
    """Two links whose MuJoCo element names would coincide: (link, message), or None.

    The builder names a link's joint ``LINK_POINT`` (or ``LINK_slide``) and a loop-closing
    equality ``loop_POINT_PARENT_CHILD``; names with underscores can collide (link ``a_b`` at
    point ``c`` and link ``a`` at point ``b_c``). Every candidate is checked, used or not.
    """
    owners: dict[str, list[str]] = {}
    for l in links:
        for p in l.points:
            owners.setdefault(p, []).append(l.name)
    joints: dict[str, tuple[str, str]] = {}
    loops: dict[str, tuple[str, str, str]] = {}
    for l in links:
        cands = [(f"{l.name}_{p}", (l.name, p)) for p in l.points if p in ground or len(owners[p]) > 1]
        if l.guide:
            cands.append((f"{l.name}_slide", (l.name, "slide")))
        for n, who in cands:
            if joints.setdefault(n, who) != who:
                return l.name, (f"its joint name '{n}' would be the same as link {joints[n][0]}'s: rename the link "
                                f"or the point (names with underscores can run together)")
    for p, ls in owners.items():
        bodies = ls + (["ground"] if p in ground else [])
        for a in bodies:
            for b in bodies:
                if a != b:
                    n = f"loop_{p}_{a}_{b}"
                    if loops.setdefault(n, (p, a, b)) != (p, a, b):
                        return b if b != "ground" else a, (f"its loop equality name '{n}' would be the same as "
                                                           f"another's: rename the link or the point")
    return None


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
    r = _Reader(path)
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise r.fail("", f"TOML syntax error: {e}") from None
    r.keys(data, "", ["mechanism", "ground", "construct", "links", "input"],
           ["dynamics", "thread", "synthesis", "steady"])

    meta = r.table(data["mechanism"], "[mechanism]")
    r.keys(meta, "[mechanism]", ["name", "title"], ["source"])
    name = r.name(meta["name"], "[mechanism] name")
    title = r.string(meta, "title", "[mechanism]")
    source = r.string(meta, "source", "[mechanism]", default="")

    ground = {}
    for k, v in r.table(data["ground"], "[ground]").items():
        ground[r.name(k, "[ground]")] = r.vector(v, f"[ground] {k}", scale=MM, hi=MAX_LENGTH_MM)
    if not ground:
        raise r.fail("[ground]", "needs at least one fixed point")

    raw_steps = data["construct"]
    if not isinstance(raw_steps, list):
        raise r.fail("[[construct]]", "must be an array of tables: write each block under its own [[construct]]")
    if not raw_steps:
        raise r.fail("[[construct]]", "needs at least one block (a crank first)")
    steps = tuple(_read_step(r, s, i) for i, s in enumerate(raw_steps))

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
                    raise r.fail(where, f"uses point '{p}', which is built from '{s.point}' itself: the blocks "
                                        f"{' -> '.join(cycle)} form a cycle, so no order can build them")
                raise r.fail(where, f"uses point '{p}', which is defined later: order the blocks so inputs come first")
        known.add(s.point)
    cranks = [s for s in steps if isinstance(s, Crank)]
    if not isinstance(steps[0], Crank) or steps[0].ratio != 1.0 or steps[0].phase is not None:
        raise r.fail("[[construct]]", "the first block must be the input crank (a crank with no ratio or phase)")
    for c in cranks:
        if c.pivot not in ground:
            raise r.fail(f"[[construct]] {c.point}", f"crank pivot '{c.pivot}' must be a [ground] point")
        if c is not steps[0] and c.phase is None:
            raise r.fail(f"[[construct]] {c.point}", "a geared crank needs 'phase' (its angle at the initial input angle)")
    for s in steps:
        if isinstance(s, Slider) and s.guide[0] == s.guide[1]:
            raise r.fail(f"[[construct]] {s.point} guide", "needs two different points")

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
            raise r.fail(f"[[construct]] {s.point}", f"point '{s.point}' belongs to no link: list it in a [links.*] points")
    if not any(steps[0].pivot in l.points and steps[0].point in l.points for l in links):
        raise r.fail("[links]", f"no link carries the input crank {steps[0].pivot}-{steps[0].point}")
    clash = _element_name_clash(links, set(ground))
    if clash:
        raise r.fail(f"[links.{clash[0]}]", clash[1])

    inp = r.table(data["input"], "[input]")
    r.keys(inp, "[input]", ["phi0", "speed"], ["cycles"])
    phi0 = r.number(inp, "phi0", "[input]", scale=DEG, hi=MAX_ANGLE_DEG, unit=" deg", why="an angle")
    speed = r.number(inp, "speed", "[input]")
    if speed == 0:
        raise r.fail("[input] speed", "must be non-zero (rad/s, CCW positive)")
    if not MIN_SPEED <= abs(speed) <= MAX_SPEED:
        raise r.fail("[input] speed", f"must be between {MIN_SPEED:g} and {MAX_SPEED:g} rad/s in magnitude "
                                      f"(see mechanisms/README.md, Limits), got {speed:g}")
    cycles = r.number(inp, "cycles", "[input]", default=1.0, positive=True, hi=MAX_CYCLES)

    dyn_raw = r.table(data.get("dynamics", {}), "[dynamics]")
    r.keys(dyn_raw, "[dynamics]", [], ["moment", "damping", "omega0", "duration", "gravity", "force", "motor"])
    forces = []
    raw_forces = dyn_raw.get("force", [])
    if not isinstance(raw_forces, list):
        raise r.fail("[[dynamics.force]]", "must be an array of tables ([[dynamics.force]])")
    for i, fr in enumerate(raw_forces):
        w = f"[[dynamics.force]] #{i + 1}"
        fr = r.table(fr, w)
        r.keys(fr, w, ["point"], ["value", "angles", "values"])
        p = r.name(fr["point"], f"{w} point")
        if p not in known:
            raise r.fail(w, f"uses point '{p}', which is not defined")
        if ("value" in fr) == ("angles" in fr or "values" in fr):
            raise r.fail(w, "give either 'value' (constant) or 'angles' and 'values' (a table)")
        if "value" in fr:
            forces.append(Force(p, tuple(r.vector(fr["value"], f"{w} value"))))
            continue
        if "angles" not in fr or "values" not in fr:
            raise r.fail(w, "a force table needs both 'angles' (deg) and 'values' (N)")
        angs = fr["angles"]
        if not isinstance(angs, list) or len(angs) < 2:
            raise r.fail(f"{w} angles", "must be a list of at least two angles (deg)")
        a = np.array([r.number({"a": x}, "a", f"{w} angles") for x in angs]) * DEG
        if not np.all(np.diff(a) > 0):
            raise r.fail(f"{w} angles", "must increase strictly")
        vals = fr["values"]
        if not isinstance(vals, list) or len(vals) != len(angs):
            raise r.fail(f"{w} values", f"must list one force per angle ({len(angs)})")
        forces.append(Force(p, angles=tuple(a), values=tuple(tuple(r.vector(v, f"{w} values")) for v in vals)))
    motor = _read_motor(r, dyn_raw["motor"], "[dynamics.motor]") if "motor" in dyn_raw else None
    if "dynamics" in data:
        massless = [l.name for l in links if l.mass <= 0]
        if massless:
            raise r.fail(f"[links.{massless[0]}]", "has no mass, but the file has a [dynamics] case: give every "
                         "link its mass, inertia and com (a massless link is allowed only for kinematics)")
    steady = None
    if "steady" in data:
        st = r.table(data["steady"], "[steady]")
        r.keys(st, "[steady]", ["stall_torque", "no_load_speed"], ["target_delta"])
        steady = SteadyCase(_read_motor(r, st, "[steady]"),
                            r.number(st, "target_delta", "[steady]", default=0.02, positive=True))
    elif motor is not None:
        steady = SteadyCase(motor)
    dynamics = Dynamics(
        moment=r.number(dyn_raw, "moment", "[dynamics]", default=0.0),
        damping=r.number(dyn_raw, "damping", "[dynamics]", default=0.0, nonneg=True),
        omega0=r.number(dyn_raw, "omega0", "[dynamics]", default=0.0),
        duration=r.number(dyn_raw, "duration", "[dynamics]", default=1.0, positive=True),
        gravity=r.number(dyn_raw, "gravity", "[dynamics]", default=9.81, nonneg=True),
        forces=tuple(forces),
        motor=motor,
    )

    thread = elongation = None
    if "thread" in data:
        th = r.table(data["thread"], "[thread]")
        r.keys(th, "[thread]", ["path"], ["elongation"])
        thread = r.names(th["path"], "[thread] path", min_length=2)
        if "elongation" in th:
            elongation = r.number(th, "elongation", "[thread]", nonneg=True, scale=MM)
        for p in thread:
            if p not in known:
                raise r.fail("[thread] path", f"uses point '{p}', which is not defined")

    synthesis = None
    if "synthesis" in data:
        sy = r.table(data["synthesis"], "[synthesis]")
        r.keys(sy, "[synthesis]", ["stroke", "offset", "lambda", "max_pressure_angle"])
        theta = r.number(sy, "max_pressure_angle", "[synthesis]", positive=True)
        if theta >= 90:
            raise r.fail("[synthesis] max_pressure_angle", f"must be below 90 deg, got {theta:g}")
        synthesis = Synthesis(r.number(sy, "stroke", "[synthesis]", positive=True, scale=MM),
                              r.number(sy, "offset", "[synthesis]", nonneg=True, scale=MM),
                              r.number(sy, "lambda", "[synthesis]", positive=True), theta * DEG)

    return Mechanism(name, title, source, Path(path) if path != "<string>" else None, ground, steps,
                     links, phi0, speed, cycles, dynamics, thread, elongation, "dynamics" in data, synthesis,
                     steady)


def load(path: str | Path) -> Mechanism:
    """Read and validate a mechanism file. Raises MechanismFileError with a one-line message."""
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise MechanismFileError(f"{p}: no such file") from None
    except (OSError, UnicodeDecodeError) as e:
        raise MechanismFileError(f"{p}: cannot read: {e}") from None
    return parse(text, p)
