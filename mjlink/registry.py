"""The registry of mechanisms (every ``mechanisms/*.toml`` of this checkout, by name) and the
checks every mechanism passes before anything is built from it.

Names and paths, the rule (one argument, never both readings):

* An argument that ends in ``.toml``, contains a path separator (``/``, or ``\\`` on
  Windows), or starts with ``~`` or ``.`` is a **path**, always: ``~`` is expanded, a relative
  path is taken from the current folder, spaces need only the shell's quoting. It is never
  looked up as a name: ``./takeup.toml`` is the file in the current folder even though
  ``takeup`` is registered. A :class:`pathlib.Path` is always a path.
* Any other argument is a **registered name** (:func:`names`): ``mechanisms/NAME.toml`` of
  this checkout. A file in the current folder called like a registered mechanism is not
  used for the bare name; write ``./takeup``. Only a bare word that is no registered name but
  is an existing file is read as that file (so ``my_linkage`` works without an extension).

:func:`validate` runs, in this order, the checks that need the geometry over a whole cycle
(the file's own syntax and references are checked by :mod:`mjlink.mechanism`): assembly over
the input crank's full period, no undefined directions, rigid links, one degree of freedom,
no pass near a dead point, a reduced moment of inertia that never vanishes, and a model
MuJoCo compiles. :func:`problems` lists every failing one instead of raising the first
(``python -m mjlink check`` reports them all).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from . import reference
from .errors import AssemblyError, MechanismFileError, MjlinkError, UnknownMechanismError
from .mechanism import MAX_ANGLE_DEG, Attached, Crank, Dyad, Mechanism, Slider, load

MECHANISMS_DIR = Path(__file__).resolve().parent.parent / "mechanisms"

# Dead points (mechanisms/README.md, "Dead points"), measured with the kinematic run (dt 50 us)
# on four-bars and crank-sliders whose links carry bar-like masses: four-bars miss the
# velocity threshold (2e-5 of range) from 8-12 deg from the dead point at 100-150 rad/s and
# the position threshold (0.1 um) at 20 deg with a 40 mm crank at 150 rad/s; crank-sliders
# (20 mm crank) miss 0.1 um once the pressure angle passes 75-80 deg (100 rad/s) or 70-75 deg
# (150 rad/s). Errors grow
# with speed and, for positions, with crank length x speed^2. Within the envelope below the
# limits keep every run measured within the thresholds.
MIN_TRANSMISSION_DEG = 20.0  # a dyad's transmission angle stays within [20, 160] deg
MAX_PRESSURE_DEG = 60.0  # a slider's pressure angle stays at most 60 deg
# The envelope over which the thresholds are verified (test_property.py generates inside it):
# crank speed up to 150 rad/s, crank-pin acceleration r omega^2 between 10 m/s^2 (below it
# gravity's load on the soft loop closures dominates the acceleration error) and 500 m/s^2
# (errors grow with it), links with comparable, bar-like masses. Outside it a run is reported,
# not refused: the agreement table shows how close it came and --strict fails on a miss.
VERIFIED_SPEED = 150.0  # rad/s
VERIFIED_CRANK_ACCELERATION = (10.0, 500.0)  # m/s^2, crank length x speed^2
MIN_DIRECTION_M = 1e-6  # points that define a direction (attached, guide) stay this far apart
# Points of one link are one point or at least this far apart: MuJoCo's compiler takes a site or
# centre of mass within 1e-7 m of its body's frame for the frame itself (measured: a centre of
# mass 1e-4 mm from its crank's pivot was simulated on the pivot, a 0.1 um position error).
MIN_DISTINCT_M = 1e-6
SAMPLES_PER_TURN = 3600  # input-angle samples per crank turn for every check over a cycle


def names() -> list[str]:
    """Names of the registered mechanisms, sorted."""
    return sorted(p.stem for p in MECHANISMS_DIR.glob("*.toml"))


def _is_path(s: str) -> bool:
    seps = {"/", os.sep} | ({os.altsep} if os.altsep else set())
    return s.endswith(".toml") or any(c in s for c in seps) or s.startswith(("~", "."))


def path_of(name_or_path: str | Path) -> Path:
    """The file of a registered name, or the given path (see the module docstring for the rule).

    Raises UnknownMechanismError (one line) for an unknown name, a missing file or a folder.
    """
    s = str(name_or_path)
    if not s.strip():
        raise UnknownMechanismError(f"empty mechanism name (valid: {', '.join(names())}, or a path to a .toml file)")
    if isinstance(name_or_path, Path) or _is_path(s):
        p = Path(s).expanduser()
        shown = s if str(p) == s else f"{s} ({p})"
        if p.is_dir():
            raise UnknownMechanismError(f"{shown}: is a folder, not a mechanism file")
        if not p.is_file():
            raise UnknownMechanismError(f"{shown}: no such mechanism file")
        return p
    if s in names():
        return MECHANISMS_DIR / f"{s}.toml"
    p = Path(s)
    if p.is_file():
        return p
    raise UnknownMechanismError(f"unknown mechanism '{s}' (valid: {', '.join(names())}, or a path to a .toml file)")


def get(name_or_path: str | Path, *, full_turn: bool = True) -> Mechanism:
    """Load and validate a mechanism; with ``full_turn`` its input crank must turn fully.

    Raises MechanismFileError, UnknownMechanismError or AssemblyError with a one-line message.
    """
    return validate(load(path_of(name_or_path)), full_turn=full_turn)


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
@dataclass(frozen=True)
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

    @property
    def ok(self) -> bool:
        if self.kind == "dyad":
            return self.margin_deg >= self.limit_deg
        return self.worst_deg <= self.limit_deg

    def message(self, src) -> str:
        """The one-line AssemblyError text for a block that passes too near its dead point."""
        if self.kind == "dyad":
            return (f"{src}: dyad {self.label} passes within {self.margin_deg:.2f} deg of a dead point: its "
                    f"transmission angle at {self.point}{_between(self.links)} reaches {self.worst_deg:.2f} deg at "
                    f"input angle {self.phi_deg:.1f} deg; MuJoCo follows the linkage faithfully only while it "
                    f"stays within {self.limit_deg:g}..{180 - self.limit_deg:g} deg (mechanisms/README.md, Dead points)")
        return (f"{src}: slider {self.label} passes within {self.margin_deg:.2f} deg of a dead point: its pressure "
                f"angle reaches {self.worst_deg:.2f} deg at input angle {self.phi_deg:.1f} deg; MuJoCo follows the "
                f"linkage faithfully only up to {self.limit_deg:g} deg (mechanisms/README.md, Dead points)")


def _between(links: tuple[str, ...]) -> str:
    return f" between links {links[0]} and {links[1]}" if len(links) == 2 else ""


def cycle_angles(mech: Mechanism, samples: int | None = None) -> np.ndarray:
    """Input angles (rad) over one period from phi0, SAMPLES_PER_TURN per turn, both ends included."""
    turns = max(1, int(round(mech.period / (2 * math.pi))))
    n = samples or SAMPLES_PER_TURN * turns + 1
    return mech.phi0 + np.linspace(0.0, mech.period, n)


def block_angles(mech: Mechanism, kin: reference.Kinematics | None = None) -> tuple[BlockAngle, ...]:
    """Transmission angle of every dyad and pressure angle of every slider over the period.

    Evaluated at the same samples as the assembly check, only where the linkage assembles.
    """
    if kin is None:
        kin = reference.solve(mech, cycle_angles(mech), check=False)
    phi = kin.phi
    out = []
    every: np.ndarray | None = None
    for s in mech.steps:
        if not isinstance(s, (Dyad, Slider)):
            continue
        if isinstance(s, Dyad):
            d = np.linalg.norm((kin.points[s.a].v - kin.points[s.b].v)[:, :2], axis=1)
            cos_mu = (s.length_a**2 + s.length_b**2 - d**2) / (2 * s.length_a * s.length_b)
            closes = np.abs(cos_mu) <= 1.0
            mu = np.degrees(np.arccos(np.clip(cos_mu, -1.0, 1.0)))
            margin = np.minimum(mu, 180.0 - mu)
            value, label = mu, f"{s.a}-{s.point}-{s.b}"
            links = _dyad_links(mech, s)
            quantity, limit = "transmission angle", MIN_TRANSMISSION_DEG
        else:
            a = kin.points[s.start].v[:, :2]
            n1, n2 = (kin.points[g].v[:, :2] for g in s.guide)
            g = n2 - n1
            with np.errstate(all="ignore"):
                u = g / np.linalg.norm(g, axis=1, keepdims=True)
                off = (a - n1) - np.einsum("ij,ij->i", a - n1, u)[:, None] * u
                ratio = np.linalg.norm(off, axis=1) / s.length  # sin of the pressure angle
            closes = ratio <= 1.0
            value = np.degrees(np.arcsin(np.clip(ratio, 0.0, 1.0)))
            margin = 90.0 - value
            label = f"{s.start}-{s.point} on {s.guide[0]}-{s.guide[1]}"
            links = ()
            quantity, limit = "pressure angle", MAX_PRESSURE_DEG
        closes = closes & np.isfinite(margin)
        every = closes if every is None else every & closes
        if closes.any():
            i = int(np.argmin(np.where(closes, margin, np.inf)))
            worst, mg, at = float(value[i]), float(margin[i]), _wrap(mech, phi[i])
        else:
            worst = mg = at = math.nan
        fails = reference._angle_ranges(phi, ~closes) if not closes.all() else ""
        out.append(BlockAngle("dyad" if isinstance(s, Dyad) else "slider", s.point, label, links, quantity,
                              worst, mg, at, limit, bool(closes.all()), fails))
    return tuple(out)


def _wrap(mech: Mechanism, phi: float) -> float:
    """An input angle in deg, within [0, period)."""
    p = math.degrees(mech.period)
    v = math.degrees(phi) % p
    return 0.0 if abs(v - p) < 1e-9 else v


def _dyad_links(mech: Mechanism, s: Dyad) -> tuple[str, ...]:
    la = next((l.name for l in mech.links if s.a in l.points and s.point in l.points), None)
    lb = next((l.name for l in mech.links if s.b in l.points and s.point in l.points and l.name != la), None)
    return (la, lb) if la and lb else ()


# --------------------------------------------------------------------------- degrees of freedom
@dataclass(frozen=True)
class Mobility:
    """The Chebyshev-Gruebler count ``W = 3 n - 2 p`` of a planar linkage.

    ``moving_links`` n; ``revolute`` pairs: at every point, (bodies meeting there) - 1, the
    ground counting as a body at a [ground] point (so k links pinned together make k - 1
    pairs); ``prismatic`` pairs: one per link with a ``guide``; ``structural`` W; ``gears``
    geared cranks, each tying its crank to the input (one more constraint); ``driven`` =
    W - gears, the degrees of freedom of the whole machine: a sound mechanism file has exactly
    one, the input crank's angle (the motor drives it; nothing else may move freely).
    """

    moving_links: int
    revolute: int
    prismatic: int
    gears: int

    @property
    def lower_pairs(self) -> int:
        return self.revolute + self.prismatic

    @property
    def structural(self) -> int:
        return 3 * self.moving_links - 2 * self.lower_pairs

    @property
    def driven(self) -> int:
        return self.structural - self.gears


def mobility(mech: Mechanism) -> Mobility:
    """Count links, lower pairs and gear couplings (see :class:`Mobility`)."""
    bodies: dict[str, int] = {}
    for l in mech.links:
        for p in l.points:
            bodies[p] = bodies.get(p, 0) + 1
    revolute = sum(k + (1 if p in mech.ground else 0) - 1 for p, k in bodies.items())
    prismatic = sum(1 for l in mech.links if l.guide)
    gears = sum(1 for s in mech.steps if isinstance(s, Crank)) - 1
    return Mobility(len(mech.links), revolute, prismatic, gears)


def _mobility_problem(mech: Mechanism, m: Mobility) -> MechanismFileError | None:
    if m.driven == 1:
        return None
    src = mech.path or mech.name
    count = (f"W = 3*{m.moving_links} - 2*{m.lower_pairs} = {m.structural}"
             + (f", minus {m.gears} gear coupling{'s' if m.gears > 1 else ''}" if m.gears else ""))
    if m.driven > 1:
        hint = ""
        for s in mech.steps:
            if isinstance(s, Dyad) and not _dyad_links(mech, s):
                hint = (f": dyad {s.a}-{s.point}-{s.b} needs its joint {s.point} on one link with {s.a} and on "
                        f"another with {s.b}")
                break
            if isinstance(s, Slider) and not any(s.point in l.points and l.guide and set(l.guide) == set(s.guide)
                                                 for l in mech.links):
                hint = (f": slider {s.point} needs a link carrying {s.point} with guide = "
                        f"[\"{s.guide[0]}\", \"{s.guide[1]}\"]")
                break
        return MechanismFileError(
            f"{src}: [links]: the links give the linkage {m.driven} degrees of freedom ({count}) where it must have "
            f"one, the input crank's angle: a point the construction fixes is free in the linkage"
            f"{hint or ' (a link is missing)'}")
    return MechanismFileError(
        f"{src}: [links]: the links over-constrain the linkage ({count} degrees of freedom where it must have "
        f"one, the input crank's angle): a link or pair repeats a constraint another already makes; remove it "
        f"(MuJoCo's loop closures would fight each other)")


# --------------------------------------------------------------------------- all checks
def problems(mech: Mechanism, *, full_turn: bool = True) -> list[MjlinkError]:
    """Every check :func:`validate` makes, as a list of the errors found (in that order).

    Checks that need the whole cycle run only when the linkage assembles over all of it.
    Floating-point warnings are silenced: every non-finite value is turned into a message.
    """
    with np.errstate(all="ignore"):
        return _problems(mech, full_turn)


def _problems(mech: Mechanism, full_turn: bool) -> list[MjlinkError]:
    src = mech.path or mech.name
    found: list[MjlinkError] = []
    phi = cycle_angles(mech)
    with np.errstate(all="ignore"):  # coinciding points divide by zero; reported below
        ok, ranges = reference.assembly_ranges(mech, samples=len(phi))
    if not ok:
        if full_turn:
            with np.errstate(all="ignore"):
                kin = reference.solve(mech, phi, check=False)
            blocks = [b for b in block_angles(mech, kin) if not b.closes]
            which = "; ".join(f"{b.kind} {b.label} cannot close for input angles {b.fails_deg} deg" for b in blocks)
            found.append(AssemblyError(
                f"{src}: the input crank cannot turn fully: {which + '; ' if which else ''}the linkage assembles "
                f"only for input angles {ranges or 'none'} deg (it is a rocker there; mjlink does not pretend "
                f"otherwise)"))
        found += _structure(mech)
        return found
    with np.errstate(all="ignore"):
        kin = reference.solve(mech, phi, check=False)
    bad = _undefined(mech, kin)
    if bad:
        return found + [bad] + _structure(mech)
    try:
        reference.check_rigidity(mech)
    except MechanismFileError as e:
        found.append(e)
    close = _almost_coincident(mech, kin)
    if close:
        found.append(close)
    found += _structure(mech)
    found += [AssemblyError(b.message(src)) for b in block_angles(mech, kin) if not b.ok]
    inertia = _inertia_problem(mech, kin)
    if inertia:
        found.append(inertia)
    if not found:
        compiled = _compile_problem(mech)
        if compiled:
            found.append(compiled)
    return found


def _structure(mech: Mechanism) -> list[MjlinkError]:
    """Pairs the builder can make into a MuJoCo tree, and one degree of freedom."""
    from . import builder  # lazily: mujoco must not be imported before the GL backend is chosen

    out: list[MjlinkError] = []
    try:
        builder.topology(mech)
    except MechanismFileError as e:
        out.append(e)
    m = _mobility_problem(mech, mobility(mech))
    if m:
        out.append(m)
    return out


def _undefined(mech: Mechanism, kin: reference.Kinematics) -> MechanismFileError | None:
    """A point whose block's direction is undefined (two of its points coincide) somewhere."""
    src = mech.path or mech.name
    for s in mech.steps:
        pairs = []
        if isinstance(s, Attached):
            pairs = [(s.origin, s.toward, "origin and toward")]
        elif isinstance(s, Slider):
            pairs = [(s.guide[0], s.guide[1], "guide points")]
        elif isinstance(s, Dyad):
            pairs = [(s.a, s.b, "a and b")]
        for p, q, what in pairs:
            d = np.linalg.norm((kin.points[p].v - kin.points[q].v)[:, :2], axis=1)
            if not (d >= MIN_DIRECTION_M).all():
                i = int(np.argmin(np.where(np.isfinite(d), d, -1.0)))
                return MechanismFileError(
                    f"{src}: [[construct]] {s.point}: its {what} {p} and {q} come within {d[i] * 1e3:.3g} mm of each "
                    f"other at input angle {_wrap(mech, kin.phi[i]):.1f} deg, so the direction they define is "
                    f"undefined there")
    for l in mech.links:
        if l.guide:
            p, q = l.guide
            d = np.linalg.norm((kin.points[p].v - kin.points[q].v)[:, :2], axis=1)
            if not (d >= MIN_DIRECTION_M).all():
                return MechanismFileError(f"{src}: [links.{l.name}] guide: points {p} and {q} coincide "
                                          f"(within {MIN_DIRECTION_M * 1e3:g} mm), so the guide has no direction")
    for n in mech.point_names:
        v = kin.points[n].v
        if not np.isfinite(v).all():
            i = int(np.argmax(~np.isfinite(v).all(axis=1)))
            return MechanismFileError(f"{src}: [[construct]] {n}: the point is undefined at input angle "
                                      f"{_wrap(mech, kin.phi[i]):.1f} deg")
    return None


def _almost_coincident(mech: Mechanism, kin: reference.Kinematics) -> MechanismFileError | None:
    """Two points of one link closer than MIN_DISTINCT_M but not the same point."""
    for l in mech.links:
        for i, a in enumerate(l.points):
            for b in l.points[i + 1:]:
                d = float(np.linalg.norm(kin.points[a].v[0] - kin.points[b].v[0]))
                if 0.0 < d < MIN_DISTINCT_M:
                    return MechanismFileError(
                        f"{mech.path or mech.name}: [links.{l.name}]: points {a} and {b} are only {d * 1e3:.3g} mm apart: "
                        f"MuJoCo merges points closer than 0.0001 mm with a body's frame, so make them one point "
                        f"(length 0) or keep them at least {MIN_DISTINCT_M * 1e3:g} mm apart")
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
        f"of motion is singular: give the input crank's link {mech.input_link.name} a mass and an inertia")


def _compile_problem(mech: Mechanism) -> MechanismFileError | None:
    """The MJCF must compile (a last guard: names are validated when the file is read)."""
    from . import builder

    try:
        builder.build_spec(mech).compile()
    except ValueError as e:
        msg = " ".join(str(e).split())
        return MechanismFileError(f"{mech.path or mech.name}: MuJoCo cannot compile the model: {msg}")
    return None


def with_crank_settings(mech: Mechanism, phi0_deg: float | None = None, phase_deg: float | None = None) -> Mechanism:
    """``mech`` with another initial input angle (phi01) and/or geared-crank phase (phi04), deg.

    Raises MjlinkError if a phase is given for a mechanism without a geared crank.
    """
    import dataclasses

    if phi0_deg is not None:
        if not math.isfinite(phi0_deg) or abs(phi0_deg) > MAX_ANGLE_DEG:
            raise MjlinkError(f"--phi0 must be finite and at most {MAX_ANGLE_DEG:g} deg in magnitude, got {phi0_deg}")
        mech = dataclasses.replace(mech, phi0=math.radians(phi0_deg))
    if phase_deg is not None:
        geared = [s for s in mech.steps if isinstance(s, Crank) and s is not mech.input_crank]
        if not geared:
            raise MjlinkError(f"{mech.name} has no geared crank: --phase/--phi04 does not apply")
        if not math.isfinite(phase_deg) or abs(phase_deg) > MAX_ANGLE_DEG:
            raise MjlinkError(f"--phase must be finite and at most {MAX_ANGLE_DEG:g} deg in magnitude, got {phase_deg}")
        new = dataclasses.replace(geared[0], phase=math.radians(phase_deg))
        mech = dataclasses.replace(mech, steps=tuple(new if s is geared[0] else s for s in mech.steps))
    return validate(mech) if (phi0_deg is not None or phase_deg is not None) else mech
