"""A sewing head's ``[timing]`` table: which points are the needle, the hook and the feed dog,
and the makers' settings their motions must meet.

The checks themselves (``mjlink.analysis.timing``) measure events over one stitch from the
reference; this module only reads and validates the table. Lengths in the file are mm and
angles deg; here m and rad, like the rest of :class:`~mjlink.model.mechanism.Mechanism`.

A chain-stitch head (stitch type 101) names its looper's point as ``hook_point``: the timing's
"hook" is then the looper, and ``loop_release`` the looper's turn from picking the loop up to
holding it spread (docs/head.md, A chain-stitch head).

A file names its roles once and ships one table of settings per machine, named by its model
and holding the windows that machine's manual gives (a table may give fewer than all four); a
table that takes its values from several machines is named as a composite and its ``source``
names each value's machine::

    [timing]
    needle_bar = "NB"        # the needle bar's point whose rise from bottom dead centre is measured
    needle_point = "NT"      # the needle's tip
    needle_eye = "NE"        # the top of the needle's eye
    hook_point = "HP"        # the hook's blade point: a crank's point (its pivot is the hook shaft)
    feed_dog = "F"           # the top of the feed dog's teeth
    take_up = "P5"           # the take-up lever's thread eyelet
    plate = -100.0           # mm: height (y) of the throat plate's top
    fabric = 1.5             # mm: thickness of the fabric on the plate
    loop_release = 270.0     # deg of hook turn from picking the loop up to releasing it
    feed_in_fabric = 0.2     # mm: most feed allowed while the needle is in the fabric
    target = "juki_lu2210n7" # the settings the head is built to
    stitch = "301"           # the stitch type (ISO 4915): "301" lockstitch, "101" chain stitch

    [timing.juki_lu2210n7]
    source = "Juki LU-2210N-7 engineer's manual, (4) Needle-to-Hook Relation"
    hook_rise = [1.8, 2.2]            # mm
    hook_above_eye = [1.2, 1.6]       # mm
"""

from __future__ import annotations

import enum
import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from ..units import DEG, MM
from .blocks import Block, Crank
from .limits import HEAD, MAX_TITLE_CHARS
from .reader import Reader

if TYPE_CHECKING:
    from .mechanism import Link, Mechanism

ROLES = {
    "needle_bar": "the needle bar's rise from its bottom dead centre is measured",
    "needle_point": "the needle point passes through the plate and the fabric",
    "needle_eye": "the eye's height is measured as the hook meets the needle",
    "hook_point": "the hook's point picks the loop up from the needle",
    "feed_dog": "the dog rises through the plate and feeds",
    "take_up": "the eyelet's highest point is timed against the loop's release",
}
"""The points a head's ``[timing]`` table names, each with what its point does in the checks:
every one must move with the mechanism (not a ``[ground]`` point, nor one built from ground
points only), the hook point must be a geared crank's (its pivot is the hook shaft), and the
needle's points ride on one link (the needle's centre line runs through its bar and its
point, which differ).

A table names the parts it has (:data:`NEEDS`): a needle drive alone (``needle_bar`` and
``needle_point``), a feed alone (``feed_dog``), or a whole head. The hook needs the needle and
its eye, the take-up the hook; each check is made where its parts are named."""

NEEDLE = ("needle_bar", "needle_point", "needle_eye")

NEEDS = {
    "needle_bar": ("needle_point",),
    "needle_point": ("needle_bar",),
    "needle_eye": ("needle_bar", "needle_point"),
    "hook_point": ("needle_bar", "needle_point", "needle_eye"),
    "take_up": ("hook_point",),
    "feed_dog": (),
}
"""What each role needs named besides it: the needle's line runs through its bar and its point,
the hook meets the needle at its eye, the take-up is timed against the hook's release."""

WINDOW_ROLES = {
    "hook_rise": ("needle_bar", "needle_point", "hook_point"),
    "hook_above_eye": ("needle_bar", "needle_point", "needle_eye", "hook_point"),
    "dog_height": ("feed_dog",),
    "needle_at_dog_flush": ("needle_bar", "needle_point", "feed_dog"),
}
"""The roles a maker's window measures."""


class StitchType(enum.Enum):
    """A stitch type (ISO 4915) whose needle thread mjlink follows, valued as ``[timing] stitch``
    writes it."""

    LOCKSTITCH = "301"
    CHAIN = "101"

    @property
    def description(self) -> str:
        return _DESCRIPTION[self]

    @property
    def loop_body(self) -> str:
        """The ``[balance]`` key (and :class:`Balance` field) of what the needle's loop is drawn
        round: a lockstitch's bobbin case, a chain stitch's looper."""
        return _LOOP_BODY[self]


_DESCRIPTION = {StitchType.LOCKSTITCH: "lockstitch", StitchType.CHAIN: "single-thread chain stitch"}
_LOOP_BODY = {StitchType.LOCKSTITCH: "bobbin_case", StitchType.CHAIN: "looper"}

BOBBIN_CASE_WIDTH = 10.0 * MM
"""A lockstitch's ``[balance] bobbin_case_width`` when the file gives none, m: a case round an
industrial bobbin about 9 mm wide [choice: no public hook catalogue with the case's width was
found]."""
MIN_HOOK_LEG = 0.01 * MM  # the check spring's hook this near a neighbour on the path lies on it
MIN_HOOK_TURN_DEG = 1.0  # a thread turning less round the hook pulls it nowhere in particular
MIN_SPRING_ARM = 1.0 * MM  # a check spring's arm, some 10 to 30 mm from the stud to its hook
# The thread pulls a swinging hook along its arc with at least this share of its pull along the
# straight stroke (the bisector): less, and it pulls the hook at its stud, not round it.
MIN_ARC_PULL = 0.01


SETTINGS = {
    "hook_rise": "needle bar rise from its bottom dead centre when the hook point reaches the needle's centre line",
    "hook_above_eye": "height of the hook point above the top of the needle's eye at that moment",
    "dog_height": "height of the feed dog's teeth above the throat plate at their highest",
    "needle_at_dog_flush": "height of the needle point above the throat plate when the descending feed dog "
    "is flush with it",
}
"""A maker's settings: each a window [lo, hi] in mm (the manuals' value and tolerance)."""


@dataclass(frozen=True)
class Window:
    """A closed interval [lo, hi] in SI units; ``None`` for an open end."""

    lo: float | None
    hi: float | None

    def holds(self, value: float) -> bool:
        return (self.lo is None or value >= self.lo) and (self.hi is None or value <= self.hi)


@dataclass(frozen=True)
class MakerSettings:
    """One machine's published settings (or a composite's, named as such) for the head
    (``[timing.NAME]``), windows in m."""

    name: str
    source: str
    windows: dict[str, Window]


@dataclass(frozen=True, kw_only=True)
class Timing:
    """A head's ``[timing]`` table in SI units (m, rad); ``stitch`` its stitch type."""

    roles: dict[str, str]
    plate: float
    fabric: float
    loop_release: float
    feed_in_fabric: float
    target: str  # '' for a table without a maker's settings
    settings: tuple[MakerSettings, ...]
    stitch: StitchType = StitchType.LOCKSTITCH

    def maker(self, name: str) -> MakerSettings:
        return next(s for s in self.settings if s.name == name)

    def has(self, *roles: str) -> bool:
        """Whether every one of ``roles`` is named."""
        return all(r in self.roles for r in roles)


def moving(steps: Iterable[Block]) -> set[str]:
    """The built points that move with the input crank: every crank's point (a crank turns
    about its [ground] pivot) and every point built from a moving one; a point built from
    [ground] points only stays where it is."""
    out: set[str] = set()
    for s in steps:  # in build order: a block's inputs come first
        if isinstance(s, Crank) or any(p in out for p in s.inputs):
            out.add(s.point)
    return out


def _number(r: Reader, data: dict, key: str, where: str, bound: str, scale: float = 1.0, **kw: Any) -> float:
    """A number of the head's tables held to its range in limits.HEAD (``bound``)."""
    b = HEAD[bound]
    return r.number(data, key, where, scale=scale, unit=f" {b.unit}" if b.unit else "", bound=b, **kw)


def _roles(r: Reader, scalars: dict, ground: set[str], steps: Sequence[Block], links: Sequence[Link]) -> dict[str, str]:
    """The role -> point table, each point able to play its role (see :data:`ROLES`)."""
    built = {s.point for s in steps}
    moves = moving(steps)
    hooks = {s.point: s for s in steps if isinstance(s, Crank) and not s.is_input}
    roles = {}
    named = [k for k in ROLES if k in scalars]
    for role in named:
        missing = [k for k in NEEDS[role] if k not in named]
        if missing:
            raise r.fail(f"[timing] {role}", f"needs {' and '.join(missing)} named too ({ROLES[role]})")
    if not ({"needle_bar", "needle_point"} <= set(named) or "feed_dog" in named):
        raise r.fail(
            "[timing]",
            "names no part to time: give the needle (needle_bar and needle_point), the feed dog (feed_dog), or both",
        )
    for role, does in ROLES.items():
        if role not in scalars:
            continue
        where = f"[timing] {role}"
        p = r.name(scalars[role], where)
        if p not in ground and p not in built:
            raise r.fail(where, f"names point '{p}', which is not defined")
        if p not in moves:
            what = "a [ground] point" if p in ground else "built from [ground] points only"
            raise r.fail(where, f"'{p}' does not move ({what}), but {does}: name a point that moves with the head")
        if role == "hook_point" and p not in hooks:
            raise r.fail(
                where,
                f"'{p}' must be the point of a geared crank (the hook turns with its shaft; {does})",
            )
        roles[role] = p
    if "needle_bar" not in roles:
        return roles
    needle = {k: roles[k] for k in NEEDLE if k in roles}
    if needle["needle_bar"] == needle["needle_point"]:
        raise r.fail(
            "[timing] needle_point",
            f"'{needle['needle_point']}' is the needle_bar's point too: the needle's centre line runs through two "
            "points of it",
        )
    if not any(set(needle.values()) <= set(l.points) for l in links):
        named = " and ".join(f"{k} '{v}'" for k, v in needle.items())
        raise r.fail(
            "[timing]",
            f"{named} are on no one link: the needle is held in its bar, so one link carries "
            f"{'all three' if len(needle) == 3 else 'both'}",
        )
    return roles


def read(r: Reader, raw: Any, ground: set[str], steps: Sequence[Block], links: Sequence[Link]) -> Timing:
    """The ``[timing]`` table, validated: roles name points that can play them (:data:`ROLES`),
    every number lies within its range (limits.HEAD), each maker's windows are ordered pairs
    in mm, ``target`` names one of them."""
    t = r.table(raw, "[timing]")
    makers = {k: v for k, v in t.items() if isinstance(v, dict)}
    scalars = {k: v for k, v in t.items() if not isinstance(v, dict)}
    required = ["plate"]
    optional = [*ROLES, "target", "fabric", "loop_release", "feed_in_fabric", "stitch"]
    for k in makers:  # a table is a maker's settings, never the value of one of [timing]'s own keys
        if k in required or k in optional:
            raise r.fail(f"[timing] {k}", f"must be a {'point name' if k in ROLES else 'value'}, got a table")
    r.keys(scalars, "[timing]", required, optional)
    roles = _roles(r, scalars, ground, steps, links)
    settings = tuple(_maker(r, name, body, roles) for name, body in makers.items())
    if makers:
        if "target" not in scalars:
            raise r.fail(
                "[timing]", f"needs 'target': which of the settings tables {', '.join(makers)} the head is built to"
            )
        target = r.string(scalars, "target", "[timing]")
        if target not in makers:
            raise r.fail("[timing] target", f"'{target}' is not one of the settings tables {', '.join(makers)}")
    elif "target" in scalars:
        raise r.fail("[timing] target", "names settings, but the table has no maker's settings table ([timing.NAME])")
    else:
        target = ""
    written = r.string(scalars, "stitch", "[timing]", default=StitchType.LOCKSTITCH.value)
    try:
        stitch = StitchType(written)
    except ValueError:
        kinds = ", ".join(f"'{k.value}' ({k.description})" for k in StitchType)
        raise r.fail("[timing] stitch", f"{r.shown(written)} is not a stitch type mjlink follows: {kinds}") from None
    return Timing(
        roles=roles,
        plate=_number(r, scalars, "plate", "[timing]", "timing.plate", MM),
        # The defaults in SI, as the reader gives them back unscaled.
        fabric=_number(r, scalars, "fabric", "[timing]", "timing.fabric", MM, default=1.5 * MM),
        loop_release=_number(r, scalars, "loop_release", "[timing]", "timing.loop_release", DEG, default=270.0 * DEG),
        feed_in_fabric=_number(r, scalars, "feed_in_fabric", "[timing]", "timing.feed_in_fabric", MM, default=0.2 * MM),
        target=target,
        settings=settings,
        stitch=stitch,
    )


def _maker(r: Reader, name: str, raw: Any, roles: dict[str, str]) -> MakerSettings:
    where = f"[timing.{r.name(name, '[timing]')}]"
    body = r.table(raw, where)
    r.keys(body, where, [], ["source", *SETTINGS])
    windows = {}
    for key in SETTINGS:
        if key not in body:
            continue
        missing = [k for k in WINDOW_ROLES[key] if k not in roles]
        if missing:
            raise r.fail(
                f"{where} {key}",
                f"measures the {' and '.join(missing)}, which [timing] does not name ({SETTINGS[key]})",
            )
        pair = body[key]
        if not (isinstance(pair, list) and len(pair) == 2):
            raise r.fail(f"{where} {key}", f"must be a window [lo, hi] in mm, got {r.shown(pair)}")
        lo = _number(r, {"lo": pair[0]}, "lo", f"{where} {key}", "timing.window", MM)
        hi = _number(r, {"hi": pair[1]}, "hi", f"{where} {key}", "timing.window", MM)
        if lo > hi:
            raise r.fail(f"{where} {key}", f"lo {lo / MM:g} mm is above hi {hi / MM:g} mm")
        windows[key] = Window(lo, hi)
    if not windows:
        raise r.fail(where, f"gives no setting (any of {', '.join(SETTINGS)})")
    return MakerSettings(name, r.string(body, "source", where, default="", max_length=MAX_TITLE_CHARS), windows)


@dataclass(frozen=True, kw_only=True)
class Balance:
    """A head's ``[balance]`` table in SI units: the stitch (``stitch_length``; the fabric's
    thickness and the stitch type are the ``[timing]`` table's), the diameter of what the loop
    is drawn around (a lockstitch's ``bobbin_case``, a chain stitch's ``looper``; the other is
    0), the check spring (its point on the ``[thread]`` path and its travel) and the thread's
    ``stretch`` at its working tension (a fraction: what the take-up may hold back is what the
    thread in the path stretches)."""

    stitch_length: float
    bobbin_case: float
    check_spring: str
    check_spring_travel: float
    stretch: float = 0.01  # the thread's elastic elongation at its working tension, a fraction
    looper: float = 0.0
    bobbin_case_width: float = 0.0  # a lockstitch's: across the case's faces, which the loop passes over
    # The point the spring's hook swings about (a spring wound on the tension stud), on an axis
    # normal to the face; None: the hook slides on a straight stroke (:class:`Stroke`).
    check_spring_pivot: str | None = None


def read_balance(
    r: Reader,
    raw: Any,
    thread: tuple[str, ...] | None,
    timing: Timing | None,
    steps: Sequence[Block],
    ground: Mapping[str, np.ndarray],
) -> Balance:
    """The ``[balance]`` table: needs ``[timing]`` (the needle, hook and plate) and a
    ``[thread]`` path that ends at the needle's eye and holds the check spring's point, the
    thread turning round it where it and its neighbours are ``ground`` points; the loop's body
    lies inside the circle the hook point turns on (``steps`` hold its crank)."""
    t = r.table(raw, "[balance]")
    if timing is None:
        raise r.fail("[balance]", "needs a [timing] table (the needle, the hook and the plate)")
    if not timing.has("needle_eye", "hook_point"):
        raise r.fail("[balance]", "needs the needle's eye and the hook named in [timing] (needle_eye, hook_point)")
    body = timing.stitch.loop_body
    optional = ["stretch", "bobbin_case_width"] if timing.stitch is StitchType.LOCKSTITCH else ["stretch"]
    optional.append("check_spring_pivot")
    r.keys(t, "[balance]", ["stitch_length", body, "check_spring", "check_spring_travel"], optional)
    if not thread or thread[-1] != timing.roles["needle_eye"]:
        raise r.fail(
            "[balance]",
            f"needs a [thread] path that ends at the needle's eye '{timing.roles['needle_eye']}' "
            "(from the tension discs through the take-up to the needle)",
        )
    spring = r.name(t["check_spring"], "[balance] check_spring")
    if spring not in thread:
        raise r.fail("[balance] check_spring", f"'{spring}' is not a point of the [thread] path")
    if spring in (thread[0], thread[-1]):
        # The thread turns round the spring's hook: it needs a point of the path either side.
        raise r.fail(
            "[balance] check_spring",
            f"'{spring}' must lie between the path's first point (the tension discs) and the eye",
        )
    k = thread.index(spring)
    if all(p in ground for p in thread[k - 1 : k + 2]):
        up, hook, down = (np.asarray(ground[p], dtype=float) for p in thread[k - 1 : k + 2])
        a, b = float(np.linalg.norm(up - hook)), float(np.linalg.norm(down - hook))
        for leg, near in ((a, thread[k - 1]), (b, thread[k + 1])):
            if leg < MIN_HOOK_LEG:
                raise r.fail("[balance] check_spring", f"'{spring}' lies on '{near}': the thread must reach its hook")
        turn = math.degrees(math.pi - math.acos(max(-1.0, min(1.0, float(np.dot(up - hook, down - hook)) / (a * b)))))
        if turn < MIN_HOOK_TURN_DEG:
            raise r.fail(
                "[balance] check_spring",
                f"the thread runs straight past '{spring}' (it turns {turn:.2g} deg there): it must turn round the "
                "spring's hook, which it pulls along the bisector of that turn",
            )
    travel = _number(r, t, "check_spring_travel", "[balance]", "balance.check_spring_travel", MM)
    pivot = None
    if "check_spring_pivot" in t:
        pivot = r.name(t["check_spring_pivot"], "[balance] check_spring_pivot")
        if pivot not in ground or spring not in ground:
            raise r.fail(
                "[balance] check_spring_pivot",
                f"'{pivot}' and the hook '{spring}' must be [ground] points: the spring swings on the frame",
            )
        if all(p in ground for p in thread[k - 1 : k + 2]):  # else checked where the path moves
            legs = [np.asarray(ground[p], dtype=float) for p in thread[k - 1 : k + 2]]
            try:
                spring_stroke(legs[0], legs[1], legs[2], np.asarray(ground[pivot], dtype=float), travel)
            except ValueError as e:
                raise r.fail("[balance] check_spring_pivot", str(e)) from None
    diameter = _number(r, t, body, "[balance]", "balance.loop_body", MM)
    hook = next(s for s in steps if isinstance(s, Crank) and s.point == timing.roles["hook_point"])
    if diameter >= 2.0 * hook.length:
        raise r.fail(
            f"[balance] {body}",
            f"{diameter / MM:g} mm does not fit inside the hook point's circle ({2.0 * hook.length / MM:g} mm across: "
            f"'{hook.point}' turns {hook.length / MM:g} mm about '{hook.pivot}'): the point draws the loop round it",
        )
    return Balance(
        stitch_length=_number(r, t, "stitch_length", "[balance]", "balance.stitch_length", MM),
        bobbin_case=diameter if timing.stitch is StitchType.LOCKSTITCH else 0.0,
        check_spring=spring,
        check_spring_travel=travel,
        stretch=_number(r, t, "stretch", "[balance]", "balance.stretch", default=0.01),
        looper=diameter if timing.stitch is StitchType.CHAIN else 0.0,
        bobbin_case_width=(
            _number(r, t, "bobbin_case_width", "[balance]", "balance.bobbin_case_width", MM, default=BOBBIN_CASE_WIDTH)
            if timing.stitch is StitchType.LOCKSTITCH
            else 0.0
        ),
        check_spring_pivot=pivot,
    )


def spring_pull(up: np.ndarray, rest: np.ndarray, down: np.ndarray) -> np.ndarray:
    """(..., 3): the direction the check spring's hook travels from ``rest``, its neighbours on
    the thread's path at ``up`` and ``down``: the bisector of the thread's turn there, towards
    the straight line between the neighbours, the way the thread pulls it. One convention for
    the balance, the reference's tension and MuJoCo's spring; nought where the thread runs
    straight past the hook or the hook lies on a neighbour."""

    def unit(v: np.ndarray) -> np.ndarray:
        n = np.linalg.norm(v, axis=-1, keepdims=True)
        out: np.ndarray = v / np.where(n > 0.0, n, 1.0)
        return out

    return unit(unit(up - rest) + unit(down - rest))


@dataclass(frozen=True, kw_only=True)
class Stroke:
    """The check spring's hook over its travel ``x`` (m, from its rest stop): from ``rest``
    (..., 3) along ``pull`` (..., 3, a unit vector, the way the thread pulls it there), on a
    straight line where ``arm`` is infinite (a slide), else on the arc of radius ``arm`` (m)
    about an axis normal to the face (Z) through ``rest - radial`` (``radial`` (..., 3), from
    that axis to the hook at rest, in the face's plane): a spring wound on a stud swings its
    hook round it. ``x`` is the hook's travel along its path (on an arc, the arc's length)."""

    rest: np.ndarray
    pull: np.ndarray
    radial: np.ndarray
    arm: float

    @property
    def swings(self) -> bool:
        """Whether the hook swings on an arc (not a slide)."""
        return math.isfinite(self.arm)

    def at(self, x: float) -> np.ndarray:
        """(..., 3) m: the hook ``x`` m along its travel."""
        if not self.swings:
            out: np.ndarray = self.rest + x * self.pull
            return out
        phi = x / self.arm
        return self.rest + (math.cos(phi) - 1.0) * self.radial + self.arm * math.sin(phi) * self.pull

    def tangent(self, x: float) -> np.ndarray:
        """(..., 3): the unit direction the hook moves in ``x`` m along its travel."""
        if not self.swings:
            return self.pull
        phi = x / self.arm
        out: np.ndarray = math.cos(phi) * self.pull - math.sin(phi) / self.arm * self.radial
        return out


def spring_stroke(
    up: np.ndarray, rest: np.ndarray, down: np.ndarray, pivot: np.ndarray | None = None, travel: float = 0.0
) -> Stroke:
    """The check spring's :class:`Stroke`, its hook at ``rest`` between the path's points ``up``
    and ``down`` (each (3,) or (N, 3), N steps of the stitch): a slide along
    :func:`spring_pull`, or, with a ``pivot`` (3,), the arc about it, swung the way the thread
    pulls the hook at the first step (at the needle bar's top; the spring's rest stop holds it
    from the other way).

    Raises:
      ValueError: a hook within :data:`MIN_SPRING_ARM` of its pivot's axis, one the thread
        pulls at its pivot rather than round it (less than :data:`MIN_ARC_PULL` of its pull
        along the arc), or a ``travel`` (m) of more than half a turn on its arm.
    """
    rest = np.asarray(rest, dtype=float)
    pull = spring_pull(np.asarray(up, dtype=float), rest, np.asarray(down, dtype=float))
    if pivot is None:
        return Stroke(rest=rest, pull=pull, radial=np.zeros_like(rest), arm=math.inf)
    radial = rest - np.asarray(pivot, dtype=float)
    radial[..., 2] = 0.0
    first = radial.reshape(-1, 3)[0]
    arm = float(np.linalg.norm(first))
    if arm < MIN_SPRING_ARM:
        raise ValueError(
            f"the check spring's hook is {arm / MM:.3g} mm from its pivot's axis: a spring's arm is at least "
            f"{MIN_SPRING_ARM / MM:g} mm (some 10 to 30 mm)"
        )
    across = np.array([-first[1], first[0], 0.0]) / arm  # round the axis (+Z), in the face
    share = float(np.dot(across, pull.reshape(-1, 3)[0]))
    if abs(share) < MIN_ARC_PULL:
        raise ValueError(
            "the thread pulls the check spring's hook at its pivot, not round it: the pivot must lie off the "
            "bisector of the thread's turn at the hook"
        )
    if travel > math.pi * arm:
        raise ValueError(
            f"a travel of {travel / MM:g} mm is more than half a turn of the check spring's {arm / MM:.3g} mm arm"
        )
    tangent = np.broadcast_to(math.copysign(1.0, share) * across, rest.shape).copy()
    return Stroke(rest=rest, pull=tangent, radial=radial, arm=arm)


def hook_crank(mech: Mechanism) -> Crank:
    """The geared crank whose point is the ``[timing]`` table's hook point: its pivot is the
    hook shaft, the bobbin case's centre."""
    assert mech.timing is not None
    return next(s for s in mech.steps if isinstance(s, Crank) and s.point == mech.timing.roles["hook_point"])
