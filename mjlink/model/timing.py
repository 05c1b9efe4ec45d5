"""A sewing head's ``[timing]`` table: which points are the needle, the hook and the feed dog,
and the makers' settings their motions must meet.

The checks themselves (``mjlink.analysis.timing``) measure events over one stitch from the
reference; this module only reads and validates the table. Lengths in the file are mm and
angles deg; here m and rad, like the rest of :class:`~mjlink.model.mechanism.Mechanism`.

A chain-stitch head (stitch type 101) names its looper's point as ``hook_point``: the timing's
"hook" is then the looper, and ``loop_release`` the looper's turn from picking the loop up to
holding it spread (docs/head.md, A chain-stitch head).

A file names its roles once and ships one table per maker::

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
    target = "juki"          # the settings the head is built to
    stitch = "301"           # the stitch type (ISO 4915): "301" lockstitch, "101" chain stitch

    [timing.juki]
    source = "..."
    hook_rise = [1.8, 2.2]            # mm
    hook_above_eye = [1.2, 1.6]       # mm
    dog_height = [0.75, 0.85]         # mm
    needle_at_dog_flush = [-0.2, 0.2] # mm
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from ..units import DEG, MM
from .reader import Reader

ROLES = ("needle_bar", "needle_point", "needle_eye", "hook_point", "feed_dog", "take_up")
"""The points a head's ``[timing]`` table names."""

STITCHES = {"301": "lockstitch", "101": "single-thread chain stitch"}
"""The stitch types (ISO 4915) whose needle thread mjlink follows."""

LOOP_BODY = {"301": "bobbin_case", "101": "looper"}
"""Per stitch type, the ``[balance]`` key (and :class:`Balance` field) of what the needle's loop
is drawn round: a lockstitch's bobbin case, a chain stitch's looper."""

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
    """One maker's published settings for the head (``[timing.NAME]``), windows in m."""

    name: str
    source: str
    windows: dict[str, Window]


@dataclass(frozen=True)
class Timing:
    """A head's ``[timing]`` table in SI units (m, rad); ``stitch`` its stitch type (a key of
    :data:`STITCHES`)."""

    roles: dict[str, str]
    plate: float
    fabric: float
    loop_release: float
    feed_in_fabric: float
    target: str
    settings: tuple[MakerSettings, ...]
    stitch: str = "301"

    def maker(self, name: str) -> MakerSettings:
        return next(s for s in self.settings if s.name == name)


def read(r: Reader, raw: Any, known: set[str], hook_cranks: set[str]) -> Timing:
    """The ``[timing]`` table, validated: roles name defined points (the hook point a crank's),
    each maker's windows are ordered pairs in mm, ``target`` names one of them."""
    t = r.table(raw, "[timing]")
    makers = {k: v for k, v in t.items() if isinstance(v, dict)}
    scalars = {k: v for k, v in t.items() if not isinstance(v, dict)}
    r.keys(
        scalars,
        "[timing]",
        [*ROLES, "plate", "target"],
        ["fabric", "loop_release", "feed_in_fabric", "stitch"],
    )
    roles = {}
    for role in ROLES:
        p = r.name(scalars[role], f"[timing] {role}")
        if p not in known:
            raise r.fail(f"[timing] {role}", f"names point '{p}', which is not defined")
        roles[role] = p
    if roles["hook_point"] not in hook_cranks:
        raise r.fail(
            "[timing] hook_point",
            f"'{roles['hook_point']}' must be the point of a geared crank (the hook turns with its shaft)",
        )
    if not makers:
        raise r.fail("[timing]", "needs at least one maker's settings table, e.g. [timing.juki]")
    settings = tuple(_maker(r, name, body) for name, body in makers.items())
    target = r.string(scalars, "target", "[timing]")
    if target not in makers:
        raise r.fail("[timing] target", f"'{target}' is not one of the settings tables {', '.join(makers)}")
    stitch = r.string(scalars, "stitch", "[timing]", default="301")
    if stitch not in STITCHES:
        kinds = ", ".join(f"'{k}' ({v})" for k, v in STITCHES.items())
        raise r.fail("[timing] stitch", f"'{stitch}' is not a stitch type mjlink follows: {kinds}")
    return Timing(
        roles,
        r.number(scalars, "plate", "[timing]", scale=MM, unit=" mm"),
        r.number(scalars, "fabric", "[timing]", nonneg=True, scale=MM, unit=" mm", default=1.5),
        r.number(scalars, "loop_release", "[timing]", positive=True, scale=DEG, unit=" deg", default=270.0),
        r.number(scalars, "feed_in_fabric", "[timing]", nonneg=True, scale=MM, unit=" mm", default=0.2),
        target,
        settings,
        stitch,
    )


def _maker(r: Reader, name: str, raw: Any) -> MakerSettings:
    where = f"[timing.{r.name(name, '[timing]')}]"
    body = r.table(raw, where)
    r.keys(body, where, [], ["source", *SETTINGS])
    windows = {}
    for key in SETTINGS:
        if key not in body:
            continue
        pair = body[key]
        if not (isinstance(pair, list) and len(pair) == 2):
            raise r.fail(f"{where} {key}", "must be a window [lo, hi] in mm")
        lo = r.number({"lo": pair[0]}, "lo", f"{where} {key}", scale=MM, unit=" mm")
        hi = r.number({"hi": pair[1]}, "hi", f"{where} {key}", scale=MM, unit=" mm")
        if lo > hi:
            raise r.fail(f"{where} {key}", f"lo {lo / MM:g} mm is above hi {hi / MM:g} mm")
        windows[key] = Window(lo, hi)
    if not windows:
        raise r.fail(where, f"gives no setting (any of {', '.join(SETTINGS)})")
    return MakerSettings(name, r.string(body, "source", where, default=""), windows)


@dataclass(frozen=True)
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


def read_balance(r: Reader, raw: Any, thread: tuple[str, ...] | None, timing: Timing | None) -> Balance:
    """The ``[balance]`` table: needs ``[timing]`` (the needle, hook and plate) and a
    ``[thread]`` path that ends at the needle's eye and holds the check spring's point."""
    t = r.table(raw, "[balance]")
    if timing is None:
        raise r.fail("[balance]", "needs a [timing] table (the needle, the hook and the plate)")
    body = LOOP_BODY[timing.stitch]
    r.keys(t, "[balance]", ["stitch_length", body, "check_spring", "check_spring_travel"], ["stretch"])
    if not thread or thread[-1] != timing.roles["needle_eye"]:
        raise r.fail(
            "[balance]",
            f"needs a [thread] path that ends at the needle's eye '{timing.roles['needle_eye']}' "
            "(from the tension discs through the take-up to the needle)",
        )
    spring = r.name(t["check_spring"], "[balance] check_spring")
    if spring not in thread:
        raise r.fail("[balance] check_spring", f"'{spring}' is not a point of the [thread] path")
    diameter = r.number(t, body, "[balance]", positive=True, scale=MM, hi=200.0, unit=" mm")
    return Balance(
        r.number(t, "stitch_length", "[balance]", positive=True, scale=MM, hi=50.0, unit=" mm"),
        diameter if body == "bobbin_case" else 0.0,
        spring,
        r.number(t, "check_spring_travel", "[balance]", nonneg=True, scale=MM, hi=100.0, unit=" mm"),
        r.number(t, "stretch", "[balance]", nonneg=True, hi=0.2, default=0.01),
        diameter if body == "looper" else 0.0,
    )
