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

_NAME_RE = re.compile(r"^[A-Za-z][A-Za-z0-9_]{0,31}$")


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
    """A constant external force (N, world frame) acting at a named point."""

    point: str
    value: tuple[float, float, float]


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
               nonneg=False, scale=1.0) -> float:
        if key not in data:
            if default is None:
                raise self.fail(where, f"missing key '{key}'")
            return default
        v = data[key]
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise self.fail(f"{where} {key}", f"must be a number, got {type(v).__name__} {v!r}")
        v = float(v)
        if not math.isfinite(v):
            raise self.fail(f"{where} {key}", f"must be finite, got {v}")
        if positive and v <= 0:
            raise self.fail(f"{where} {key}", f"must be > 0, got {v:g}")
        if nonneg and v < 0:
            raise self.fail(f"{where} {key}", f"must be >= 0, got {v:g}")
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

    def vector(self, v: Any, where: str, sizes=(2, 3), scale=1.0) -> np.ndarray:
        if not isinstance(v, list) or len(v) not in sizes:
            raise self.fail(where, f"must be a list of {' or '.join(map(str, sizes))} numbers, got {v!r}")
        out = []
        for x in v:
            if isinstance(x, bool) or not isinstance(x, (int, float)) or not math.isfinite(float(x)):
                raise self.fail(where, f"must hold finite numbers, got {v!r}")
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
    if kind == "crank":
        r.keys(raw, where, ["block", "point", "pivot", "length"], ["ratio", "phase"])
        ratio = r.number(raw, "ratio", where, default=1.0)
        if ratio == 0:
            raise r.fail(f"{where} ratio", "must be non-zero")
        phase = r.number(raw, "phase", where, scale=DEG) if "phase" in raw else None
        return Crank(point, r.name(raw["pivot"], f"{where} pivot"),
                     r.number(raw, "length", where, positive=True, scale=MM), ratio, phase)
    if kind == "dyad":
        r.keys(raw, where, ["block", "point", "a", "b", "length_a", "length_b", "sign"])
        sign = raw["sign"]
        if sign not in (1, -1) or isinstance(sign, bool):
            raise r.fail(f"{where} sign", f"must be +1 or -1 (the assembly branch), got {sign!r}")
        return Dyad(point, r.name(raw["a"], f"{where} a"), r.name(raw["b"], f"{where} b"),
                    r.number(raw, "length_a", where, positive=True, scale=MM),
                    r.number(raw, "length_b", where, positive=True, scale=MM), int(sign))
    if kind == "attached":
        r.keys(raw, where, ["block", "point", "origin", "toward", "angle", "length"], ["z"])
        z = r.number(raw, "z", where, scale=MM) if "z" in raw else None
        return Attached(point, r.name(raw["origin"], f"{where} origin"),
                        r.name(raw["toward"], f"{where} toward"),
                        r.number(raw, "angle", where, scale=DEG),
                        r.number(raw, "length", where, nonneg=True, scale=MM), z)
    r.keys(raw, where, ["block", "point", "start", "length", "guide", "toward"])
    guide = r.names(raw["guide"], f"{where} guide", length=2)
    toward = r.name(raw["toward"], f"{where} toward")
    if toward not in guide:
        raise r.fail(f"{where} toward", f"must be one of the guide points {guide[0]}, {guide[1]}; got '{toward}'")
    return Slider(point, r.name(raw["start"], f"{where} start"),
                  r.number(raw, "length", where, positive=True, scale=MM), guide, toward)


def _read_link(r: _Reader, name: str, raw: Any) -> Link:
    where = f"[links.{name}]"
    r.name(name, where)
    raw = r.table(raw, where)
    r.keys(raw, where, ["points"], ["mass", "inertia", "com", "guide"])
    points = r.names(raw["points"], f"{where} points")
    mass = r.number(raw, "mass", where, default=0.0, nonneg=True, scale=G)
    inertia = r.number(raw, "inertia", where, default=0.0, nonneg=True)
    com = r.name(raw["com"], f"{where} com") if "com" in raw else None
    if mass > 0 and com is None:
        raise r.fail(where, "has a mass but no 'com' (the point that is its centre of mass)")
    if inertia > 0 and mass == 0:
        raise r.fail(where, "has a moment of inertia but zero mass")
    guide = r.names(raw["guide"], f"{where} guide", length=2) if "guide" in raw else None
    if len(set(points)) != len(points):
        raise r.fail(f"{where} points", "lists a point twice")
    if len(points) < 2 and guide is None:
        raise r.fail(f"{where} points", "a link needs two points (or one point and a 'guide' it slides on)")
    if com is not None and com not in points:
        points = points + (com,)
    return Link(name, points, mass, inertia, com, guide)


def parse(text: str, path: Path | str = "<string>") -> Mechanism:
    """Parse and validate a mechanism file's text. Raises MechanismFileError."""
    r = _Reader(path)
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise r.fail("", f"TOML syntax error: {e}") from None
    r.keys(data, "", ["mechanism", "ground", "construct", "links", "input"], ["dynamics", "thread", "synthesis"])

    meta = r.table(data["mechanism"], "[mechanism]")
    r.keys(meta, "[mechanism]", ["name", "title"], ["source"])
    name = r.name(meta["name"], "[mechanism] name")
    title = r.string(meta, "title", "[mechanism]")
    source = r.string(meta, "source", "[mechanism]", default="")

    ground = {}
    for k, v in r.table(data["ground"], "[ground]").items():
        ground[r.name(k, "[ground]")] = r.vector(v, f"[ground] {k}", scale=MM)
    if not ground:
        raise r.fail("[ground]", "needs at least one fixed point")

    raw_steps = data["construct"]
    if not isinstance(raw_steps, list) or not raw_steps:
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
                later = any(t.point == p for t in steps)
                why = "is defined later: order the blocks so inputs come first" if later else "is not defined"
                raise r.fail(where, f"uses point '{p}', which {why}")
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

    inp = r.table(data["input"], "[input]")
    r.keys(inp, "[input]", ["phi0", "speed"], ["cycles"])
    phi0 = r.number(inp, "phi0", "[input]", scale=DEG)
    speed = r.number(inp, "speed", "[input]")
    if speed == 0:
        raise r.fail("[input] speed", "must be non-zero (rad/s, CCW positive)")
    cycles = r.number(inp, "cycles", "[input]", default=1.0, positive=True)

    dyn_raw = r.table(data.get("dynamics", {}), "[dynamics]")
    r.keys(dyn_raw, "[dynamics]", [], ["moment", "damping", "omega0", "duration", "gravity", "force"])
    forces = []
    for i, fr in enumerate(dyn_raw.get("force", [])):
        w = f"[[dynamics.force]] #{i + 1}"
        fr = r.table(fr, w)
        r.keys(fr, w, ["point", "value"])
        p = r.name(fr["point"], f"{w} point")
        if p not in known:
            raise r.fail(w, f"uses point '{p}', which is not defined")
        forces.append(Force(p, tuple(r.vector(fr["value"], f"{w} value"))))
    dynamics = Dynamics(
        moment=r.number(dyn_raw, "moment", "[dynamics]", default=0.0),
        damping=r.number(dyn_raw, "damping", "[dynamics]", default=0.0, nonneg=True),
        omega0=r.number(dyn_raw, "omega0", "[dynamics]", default=0.0),
        duration=r.number(dyn_raw, "duration", "[dynamics]", default=1.0, positive=True),
        gravity=r.number(dyn_raw, "gravity", "[dynamics]", default=9.81, nonneg=True),
        forces=tuple(forces),
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
                     links, phi0, speed, cycles, dynamics, thread, elongation, "dynamics" in data, synthesis)


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
