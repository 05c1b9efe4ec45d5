"""``check``: what a mechanism file defines and whether mjlink can simulate it faithfully.

:func:`check` describes a loaded mechanism without raising for geometric problems: its points
and links, the kinematic pairs the MuJoCo model is built from (:func:`mjlink.builder.pairs`
and :func:`mjlink.builder.topology`: tree joints and loop-closing equalities), gear couplings,
the Chebyshev-Gruebler count of degrees of freedom, the input-angle ranges over which it can
be assembled, how near every dyad and slider comes to a dead point, and every problem
:func:`mjlink.registry.validate` would raise. :func:`format_report` prints it;
:meth:`CheckReport.raise_if_failed` then raises the first problem (one line), so a file that
cannot be simulated is still described before the command fails.

:func:`branch_switch` is the watchdog for a MuJoCo run that snapped through a dead point
onto the other assembly branch: it compares the run with the reference at MuJoCo's own input
angles.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from . import reference, registry
from .errors import AssemblyError, MechanismFileError, MjlinkError, SimulationError, UnknownMechanismError
from .mechanism import Attached, Crank, Dyad, Mechanism, Slider, load

_ERRORS = {c.__name__: c for c in (AssemblyError, MechanismFileError, SimulationError, UnknownMechanismError,
                                   MjlinkError)}
BRANCH_TOL_M = 1e-5  # 10 um: 100 times the position threshold, far below any branch's distance


@dataclass(frozen=True)
class PointInfo:
    """A named point: ``ground`` True for a [ground] point; ``made_by`` how it is built; the links carrying it."""

    name: str
    ground: bool
    made_by: str
    links: tuple[str, ...]


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

    kind: str
    point: str | None
    guide: tuple[str, str] | None
    parent: str
    child: str
    role: str


@dataclass(frozen=True)
class GearInfo:
    """A geared crank: ``point`` on ``link``, ``ratio`` to the input, ``phase`` rad at phi0."""

    point: str
    link: str
    ratio: float
    phase: float


@dataclass(frozen=True)
class CheckReport:
    """Everything :func:`check` found. ``problems`` are (error class name, one-line message)
    pairs in the order :func:`mjlink.registry.validate` checks them; ``notes`` are remarks
    that do not stop a run."""

    name: str
    title: str
    path: str
    points: tuple[PointInfo, ...]
    links: tuple[LinkInfo, ...]
    pairs: tuple[PairInfo, ...]
    gears: tuple[GearInfo, ...]
    mobility: registry.Mobility
    full_turn: bool
    assembly_ranges: str
    angles: tuple[registry.BlockAngle, ...]
    problems: tuple[tuple[str, str], ...]
    notes: tuple[str, ...]
    period_deg: float = 360.0

    @property
    def ok(self) -> bool:
        return not self.problems

    @property
    def loops(self) -> tuple[PairInfo, ...]:
        return tuple(p for p in self.pairs if p.role == "loop")

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
    return check(load(registry.path_of(name_or_path)))


def check(mech: Mechanism) -> CheckReport:
    """Describe ``mech`` and collect every problem (see the module docstring). Never raises
    for the mechanism's geometry or structure."""
    from . import builder  # lazily, as registry does: mujoco reads MUJOCO_GL when first imported

    made_by = {}
    for s in mech.steps:
        if isinstance(s, Crank):
            made_by[s.point] = (f"crank about {s.pivot}, {s.length * 1e3:g} mm" if s is mech.input_crank else
                                f"geared crank about {s.pivot}, {s.length * 1e3:g} mm, ratio {s.ratio:g}, "
                                f"phase {math.degrees(s.phase):g} deg")
        elif isinstance(s, Dyad):
            made_by[s.point] = (f"dyad {s.a}-{s.point}-{s.b}, {s.length_a * 1e3:g} / {s.length_b * 1e3:g} mm, "
                                f"sign {s.sign:+d}")
        elif isinstance(s, Attached):
            made_by[s.point] = (f"attached to {s.origin}->{s.toward}, {math.degrees(s.angle):g} deg, "
                                f"{s.length * 1e3:g} mm" + ("" if s.z is None else f", z {s.z * 1e3:g} mm"))
        elif isinstance(s, Slider):
            made_by[s.point] = (f"slider from {s.start}, {s.length * 1e3:g} mm, on {s.guide[0]}-{s.guide[1]} "
                                f"towards {s.toward}")
    points = tuple(
        PointInfo(n, n in mech.ground,
                  made_by.get(n) or "fixed at (" + ", ".join(f"{x * 1e3:g}" for x in mech.ground[n]) + ") mm",
                  tuple(l.name for l in mech.links if n in l.points))
        for n in mech.point_names)
    links = tuple(LinkInfo(l.name, l.points, l.mass, l.inertia, l.com, l.guide) for l in mech.links)

    pairs: list[PairInfo] = []
    try:
        topo = builder.topology(mech)
        for role, group in (("joint", topo.tree), ("loop", topo.loops)):
            for p in group:
                pairs.append(PairInfo("revolute" if p.kind == "hinge" else "prismatic", p.point, p.guide,
                                      p.parent or "ground", p.child, role))
    except MechanismFileError:
        try:
            for _, p in builder.pairs(mech):
                pairs.append(PairInfo("revolute" if p.kind == "hinge" else "prismatic", p.point, p.guide,
                                      p.parent or "ground", p.child, ""))
        except MechanismFileError:
            pass
    gears = tuple(GearInfo(s.point, next((l.name for l in mech.links if s.pivot in l.points and s.point in l.points),
                                         "?"), s.ratio, s.phase)
                  for s in mech.steps if isinstance(s, Crank) and s is not mech.input_crank)

    phi = registry.cycle_angles(mech)
    with np.errstate(all="ignore"):
        full, ranges = reference.assembly_ranges(mech, samples=len(phi))
        angles = registry.block_angles(mech, reference.solve(mech, phi, check=False))
    probs = tuple((type(e).__name__, str(e)) for e in registry.problems(mech, full_turn=True))

    notes = []
    acc = mech.input_crank.length * mech.speed**2
    lo, hi = registry.VERIFIED_CRANK_ACCELERATION
    if abs(mech.speed) > registry.VERIFIED_SPEED:
        notes.append(f"the kinematic run's speed {abs(mech.speed):g} rad/s is above the {registry.VERIFIED_SPEED:g} "
                     "rad/s up to which the agreement thresholds are verified; 'simulate' reports how close it comes")
    if not lo <= acc <= hi:
        notes.append(f"the crank pin's acceleration in the kinematic run, {acc:.3g} m/s^2 (crank length x speed^2), is "
                     f"outside the {lo:g}..{hi:g} m/s^2 over which the agreement thresholds are verified "
                     + ("(gravity's load on the loop closures is then not negligible)" if acc < lo else
                        "(errors grow with it)") + "; 'simulate' reports how close it comes")
    if not any(l.mass > 0 for l in mech.links):
        notes.append("no link has a mass: 'simulate' makes the kinematic run only")
    elif not mech.has_dynamics:
        notes.append("links have masses but there is no [dynamics] table: 'simulate' makes the kinematic run only")
    point_masses = [l.name for l in mech.links if l.mass > 0 and l.inertia == 0 and not l.guide]
    if point_masses:
        notes.append(f"{', '.join(point_masses)}: mass without inertia, treated as a point mass at its 'com'")
    return CheckReport(mech.name, mech.title, str(mech.path or "<string>"), points, links, tuple(pairs), gears,
                       registry.mobility(mech), full, ranges, angles, probs, tuple(notes), math.degrees(mech.period))


def format_report(r: CheckReport) -> str:
    """The report as text for a terminal (lengths mm, masses g, angles deg)."""
    out = [f"{r.name}: {r.title}", f"file: {r.path}", ""]
    w = max([len(p.name) for p in r.points] + [4])
    wm = max(len(p.made_by) for p in r.points)
    out.append(f"points ({sum(p.ground for p in r.points)} ground, {sum(not p.ground for p in r.points)} moving)")
    for p in r.points:
        on = f"on {', '.join(p.links)}" if p.links else "on no link"
        out.append(f"  {p.name:<{w}}  {'ground' if p.ground else 'moving'}  {p.made_by:<{wm}}  {on}")
    out.append("")
    out.append(f"links ({len(r.links)} moving)")
    wl = max([len(l.name) for l in r.links] + [4])
    for l in r.links:
        extra = []
        if l.mass > 0:
            extra.append(f"mass {l.mass * 1e3:g} g at {l.com}, inertia {l.inertia:g} kg*m^2")
        else:
            extra.append("massless")
        if l.guide:
            extra.append(f"slides along {l.guide[0]}-{l.guide[1]}")
        out.append(f"  {l.name:<{wl}}  points {', '.join(l.points)}; {'; '.join(extra)}")
    out.append("")
    out.append("kinematic pairs (as MuJoCo builds them: tree joints, loop-closing equalities)")
    if not r.pairs:
        out.append("  none could be formed (see problems)")
    for p in r.pairs:
        where = f"at {p.point}" if p.kind == "revolute" else f"along {p.guide[0]}-{p.guide[1]}"
        role = {"joint": "joint " + (f"{p.child}_{p.point}" if p.kind == "revolute" else f"{p.child}_slide"),
                "loop": "closes a loop: connect equality", "": "not placed"}[p.role]
        out.append(f"  {p.kind:<9} {where:<14} {p.parent + ' - ' + p.child:<{2 * wl + 3}}  {role}")
    loops = r.loops
    out.append(f"loops: {len(loops)}" + (f" (closed at {', '.join(str(p.point) for p in loops)})" if loops else ""))
    if r.gears:
        for g in r.gears:
            out.append(f"gear coupling: {g.link} ({g.point}) turns {g.ratio:g} times the input crank, "
                       f"phase {math.degrees(g.phase):g} deg at phi0 (joint equality)")
    else:
        out.append("gear couplings: none")
    m = r.mobility
    out.append(f"degrees of freedom: structural W = 3 n - 2 p = 3*{m.moving_links} - 2*{m.lower_pairs} = "
               f"{m.structural} ({m.revolute} revolute + {m.prismatic} prismatic pairs); with "
               f"{m.gears} gear coupling{'' if m.gears == 1 else 's'}: {m.driven}"
               + (" (the input crank's angle; none left once it is driven)" if m.driven == 1 else
                  "  <-- must be 1"))
    out.append("")
    if r.full_turn:
        out.append(f"assembly: the input crank turns fully (over {r.period_deg:g} deg)")
    else:
        out.append(f"assembly: NOT over a full turn; assembles only for input angles {r.assembly_ranges or 'none'} deg")
        for a in r.angles:
            if not a.closes:
                out.append(f"  {a.kind} {a.label} cannot close for input angles {a.fails_deg} deg")
    out.append(f"dead points (limits: transmission angle {registry.MIN_TRANSMISSION_DEG:g}.."
               f"{180 - registry.MIN_TRANSMISSION_DEG:g} deg, pressure angle <= {registry.MAX_PRESSURE_DEG:g} deg"
               + ("" if r.full_turn else "; where it assembles") + ")")
    if not r.angles:
        out.append("  no dyad or slider")
    for a in r.angles:
        if math.isnan(a.worst_deg):
            out.append(f"  {a.kind} {a.label}: never assembles")
            continue
        verdict = ("ok" if a.ok else "TOO CLOSE") if r.full_turn else "(not judged: no full turn)"
        if a.kind == "dyad":
            out.append(f"  dyad {a.label:<22} transmission angle {a.worst_deg:7.2f} deg at input {a.phi_deg:6.1f} deg "
                       f"({a.margin_deg:.2f} deg from the dead point)  {verdict}")
        else:
            out.append(f"  slider {a.label:<20} pressure angle up to {a.worst_deg:5.2f} deg at input "
                       f"{a.phi_deg:6.1f} deg ({a.margin_deg:.2f} deg from the dead point)  {verdict}")
    if r.notes:
        out.append("")
        out += [f"note: {n}" for n in r.notes]
    out.append("")
    if r.problems:
        out.append(f"problems ({len(r.problems)}):")
        out += [f"  - {msg}" for _, msg in r.problems]
        out.append("result: cannot be simulated faithfully as it stands")
    else:
        out.append("result: ok, ready for 'python -m mjlink simulate'")
    return "\n".join(out)


# ------------------------------------------------------------------------ branch-switch watchdog
def branch_switch(mech: Mechanism, trace, tol_m: float = BRANCH_TOL_M) -> str | None:
    """Where a MuJoCo ``trace`` left the reference's assembly branch, as one line; None if it did not.

    The reference is evaluated at MuJoCo's own input angles ``trace.phi``; a moving point more
    than ``tol_m`` (m) away from it, or non-finite, has left it. The first such point in
    construction order at the first such sample is named, with the time and input angle;
    for a dyad or slider the message says whether MuJoCo follows the other branch (the mirror
    solution, the opposite ``sign`` or ``toward``).
    """
    with np.errstate(all="ignore"):
        kin = reference.solve(mech, np.asarray(trace.phi, dtype=float), check=False)
    first, who = None, None
    for n in mech.moving_points:
        mj, ref = np.asarray(trace.points[n]), kin.position(n)
        dev = np.linalg.norm(mj - ref, axis=1)
        bad = ~(dev <= tol_m)
        if bad.any():
            i = int(np.argmax(bad))
            if first is None or i < first:
                first, who = i, n
    if first is None:
        return None
    i, n = first, who
    t, phi = float(trace.time[i]), math.degrees(float(trace.phi[i]))
    mj = np.asarray(trace.points[n])
    dev = np.linalg.norm(mj - kin.position(n), axis=1)
    step = next(s for s in mech.steps if s.point == n)
    where = f"at t = {t:.6g} s, input angle {phi:.2f} deg"
    src = mech.path or mech.name
    if not np.isfinite(mj[i]).all():
        return f"{src}: MuJoCo's point {n} became non-finite {where}"
    after = np.arange(i, len(dev))
    j = int(after[np.argmax(np.where(np.isfinite(dev[after]), dev[after], -1.0))])
    other = _mirror(step, kin, j)
    if other is not None and np.linalg.norm(mj[j] - other) < dev[j]:
        flip = (f"sign {-step.sign:+d} instead of {step.sign:+d}" if isinstance(step, Dyad) else
                f"toward {next(g for g in step.guide if g != step.toward)} instead of {step.toward}")
        kind = f"dyad {step.a}-{n}-{step.b}" if isinstance(step, Dyad) else f"slider {step.start}-{n}"
        return (f"{src}: MuJoCo left the reference's assembly branch at {n} ({kind}) {where}: it follows the other "
                f"branch ({flip}), up to {dev[j] * 1e3:.3g} mm away; the run is not the file's mechanism")
    return (f"{src}: MuJoCo left the reference's solution at {n} {where}: {dev[i] * 1e3:.3g} mm away, up to "
            f"{dev[j] * 1e3:.3g} mm later (tolerance {tol_m * 1e3:g} mm)")


def _mirror(step, kin: reference.Kinematics, j: int) -> np.ndarray | None:
    """The other solution of a dyad or slider at sample j (from the reference's own inputs)."""
    if isinstance(step, Dyad):
        c, a, b = (kin.position(p)[j] for p in (step.point, step.a, step.b))
        u = (a - b)[:2] / np.linalg.norm((a - b)[:2])
        r = (c - b)[:2]
        m2 = 2 * np.dot(r, u) * u - r  # reflection of C across the line a-b
        return np.array([b[0] + m2[0], b[1] + m2[1], c[2]])
    if isinstance(step, Slider):
        c, s, n1, n2 = (kin.position(p)[j] for p in (step.point, step.start, *step.guide))
        u = (n2 - n1)[:2] / np.linalg.norm((n2 - n1)[:2])
        foot = n1[:2] + np.dot((s - n1)[:2], u) * u
        m2 = 2 * foot - c[:2]  # reflection of C across the foot of the perpendicular
        return np.array([m2[0], m2[1], c[2]])
    return None
