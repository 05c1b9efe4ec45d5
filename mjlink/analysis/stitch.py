"""Where the needle thread meets the fabric over a stitch, and the grid helpers the head's
timing and its thread share: events placed between samples, extremes refined between them,
angles taken forwards round the stitch."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..model.timing import Stroke, spring_pull, spring_stroke
from ..units import MM
from .loop import blade_turn, leg_and_arrival, wrapped

if TYPE_CHECKING:
    from ..model.blocks import Crank
    from ..model.mechanism import Mechanism
    from ..model.timing import Balance, Timing
    from .timing import HeadTiming


def _crossing(theta: np.ndarray, f: np.ndarray, level: float, falling: bool) -> np.ndarray:
    """Angles (deg) where ``f`` crosses ``level`` (falling or rising), interpolated; the grid is
    periodic (the last sample is followed by the first, one stitch later)."""
    a, b = f - level, np.roll(f - level, -1)
    i = np.nonzero((a > 0) & (b <= 0) if falling else (a < 0) & (b >= 0))[0]
    t1 = np.where(i + 1 < len(theta), theta[(i + 1) % len(theta)], theta[0] + 360.0)
    frac = a[i] / (a[i] - b[i])
    out: np.ndarray = theta[i] + frac * (t1 - theta[i])
    return out


def _at(theta: np.ndarray, f: np.ndarray, t: float) -> float:
    return float(np.interp(t % 360.0, np.append(theta, theta[0] + 360.0), np.append(f, f[0])))


def _travel(head: HeadTiming, start: float, stitch_length: float) -> np.ndarray:
    """(N,) m: how far the feed has carried the fabric since the angle ``start`` (deg): the
    dog's advance while it is above the plate (the part of each step between two samples it
    spends there, its height taken linear between them), summed round the stitch from
    ``start`` and scaled so that one turn carries it the stitch length."""
    th = head.theta
    adv = head.curves["dog advance"] * MM
    h = head.curves["dog height"]
    h1 = np.roll(h, -1)
    # The fraction of each step the dog is above the plate: all of it, none, or up to (from)
    # where it passes the plate.
    with np.errstate(divide="ignore", invalid="ignore"):
        cut = np.clip(h / (h - h1), 0.0, 1.0)
    up = np.where((h > 0) & (h1 > 0), 1.0, np.where(h > 0, cut, np.where(h1 > 0, 1.0 - cut, 0.0)))
    step = np.diff(np.append(adv, adv[0]))
    fed = np.where(step > 0, step, 0.0) * up
    total = float(fed.sum())
    if total <= 0:
        return np.zeros(len(th))
    cum = np.concatenate([[0.0], np.cumsum(fed)])  # at each sample and at 360 deg
    at = float(np.interp(start % 360.0, np.append(th, 360.0), cum))
    moved = np.where(th >= start % 360.0, cum[:-1] - at, cum[:-1] + total - at)
    out: np.ndarray = moved / total * stitch_length
    return out


@dataclass(frozen=True, kw_only=True)
class StitchEnd:
    """Where the needle thread meets the fabric's top, behind the needle's line (in the feed's
    direction, m), by the one convention both stitch types follow.

    ``hole`` (N,): the hole the needle is in or last left. At the needle's line from the
    point's entry into the fabric until it leaves it, rising; then the feed carries it (the
    dog's advance while it is above the plate, since the needle left, scaled to the stitch
    length) until the needle enters again, a stitch length on when the feed is done.
    ``end`` (N,): the end of the last stitch on the fabric's top, where the thread from the
    needle runs to: the hole the needle left; from the needle's entry into its next hole until
    the loop's release (``unset``) the stitch through that hole is not yet set, and the thread
    runs along the top from the needle's new hole back to the old one, which the feed goes on
    carrying (a stitch length behind the new hole once the needle has left it too).
    ``inside`` (N,) bool: the needle point in the fabric, from ``enters`` to ``leaves`` (deg).
    """

    hole: np.ndarray
    end: np.ndarray
    inside: np.ndarray
    unset: np.ndarray
    enters: float
    leaves: float


def stitch_end(head: HeadTiming, fabric: float, stitch_length: float, release: float) -> StitchEnd:
    """The last stitch's end and the needle's hole over the stitch ``head`` measured
    (:class:`StitchEnd`), for a fabric ``fabric`` thick (m) sewn at ``stitch_length`` (m); the
    loop is released (a chain stitch's held loop cast off) at ``release`` (deg)."""
    th, ev = head.theta, head.events
    point = head.curves["needle point"]
    entry = _crossing(th, point, fabric / MM, True)
    enters = float(entry[0]) if len(entry) else ev["needle point through the plate, down"]
    out_of = _crossing(th, point, fabric / MM, False)
    leaves = float(out_of[0]) if len(out_of) else ev["needle point through the plate, up"]
    since = _travel(head, leaves, stitch_length)  # the hole left, from the moment it was left
    inside = _between(th, enters, leaves)
    hole = np.where(inside, 0.0, since)
    unset = _between(th, enters, release)
    # The stitch not yet set: its hole is the one left a turn before, carried on from there.
    old = np.where(inside, since, since + stitch_length)
    return StitchEnd(
        hole=hole, end=np.where(unset, old, hole), inside=inside, unset=unset, enters=enters, leaves=leaves
    )


def _peak(x: np.ndarray, where: np.ndarray) -> float:
    """The largest of ``x`` over the samples ``where``, refined between samples: the vertex of
    the parabola through the best sample and its neighbours when both are in ``where`` (a
    study's coarse angles then find what simulate's fine ones do)."""
    if not where.any():
        return math.nan
    j = int(np.argmax(np.where(where, x, -np.inf)))
    n = len(x)
    top = _vertex(x, j) if where[(j - 1) % n] and where[(j + 1) % n] else None
    return float(x[j]) if top is None else top[1]


def _vertex(x: np.ndarray, j: int) -> tuple[float, float] | None:
    """The vertex of the parabola through sample ``j`` of ``x`` and its neighbours: its offset
    from ``j`` in samples and its value, or None where the parabola has no largest value."""
    n = len(x)
    a, b, c = x[(j - 1) % n], x[j], x[(j + 1) % n]
    curv = a - 2.0 * b + c
    if not curv < 0:
        return None
    return float(0.5 * (a - c) / curv), float(b - (a - c) ** 2 / (8.0 * curv))


def _set_point(
    theta: np.ndarray, path: np.ndarray, below: np.ndarray, window: np.ndarray, enters: float
) -> tuple[float, float, float, float]:
    """Where the stitch is set: the longest ``path`` (N,) over the angles ``window`` (N,) bool,
    refined between samples. Returns the set point (deg), the path and the thread ``below``
    the eye (N,) there, and where the balance's phase starts (deg): the set point, or the
    longest sample where the take-up is still drawing as the needle enters the fabric
    (``enters``, deg), which then sets the stitch."""
    n = len(theta)
    i0 = int(np.argmax(np.where(window, path, -np.inf)))
    start = float(theta[i0])
    if not window[(i0 + 1) % n] and path[(i0 + 1) % n] > path[i0]:
        # Set at the entry itself, between two samples (a study's coarse grid then agrees with
        # simulate's fine one).
        return enters, _at(theta, path, enters), _at(theta, below, enters), start
    if window[(i0 - 1) % n] and window[(i0 + 1) % n] and (top := _vertex(path, i0)) is not None:
        # Between two samples. A take-up that dwells at its top leaves the path flat there
        # while the needle and the feed still move the thread below the eye, so the sample
        # nearest the top would shift the whole demand by what they move in half a step.
        drawn = float(theta[i0] + top[0] * ((theta[(i0 + 1) % n] - theta[i0]) % 360.0))
        return drawn, top[1], _at(theta, below, drawn), drawn
    return start, float(path[i0]), float(below[i0]), start


def _carried(tm: Timing, hook: Crank, pick: float) -> float:
    """The crank angle (deg) at which the hook has carried the loop ``loop_release`` of its own
    turn from the pick-up at ``pick``: a lockstitch's release, a chain stitch's loop spread."""
    return (pick + math.degrees(tm.loop_release) / abs(hook.ratio)) % 360.0


def spring_holds(
    up: np.ndarray, rest: np.ndarray, down: np.ndarray, travel: float, pivot: np.ndarray | None = None
) -> np.ndarray:
    """(N,) m: the thread a check spring's hook holds in the path, from its rest (``rest``
    (N, 3), the path's point) to anywhere within its ``travel`` (m), its neighbours on the path
    ``up`` and ``down`` (N, 3); with a ``pivot`` (3,), the hook swinging round it
    (:func:`~mjlink.model.timing.spring_stroke`).

    On a slide the hook moves along the bisector of the thread's turn at rest, towards the
    straight line between its neighbours, as the tension model moves it. The path's length
    along that line is convex and least where it meets the straight line (the triangle's
    bisector, of length 2 a b cos(alpha / 2) / (a + b)): a hook that travels beyond it holds no
    more. A thread that turns back round the hook holds nearly twice the hook's travel; one
    that turns little, far less than its travel. On an arc the hold is the path's length at
    rest less its least over the arc: a thread that leaves the stud along the arm keeps that
    leg's length, and the hook holds at most the arc's chord."""
    if pivot is not None:
        return _arc_holds(spring_stroke(up, rest, down, pivot, travel), up, down, travel)
    a, b = np.linalg.norm(up - rest, axis=1), np.linalg.norm(down - rest, axis=1)
    # A hook on its neighbour (a study's variant may put it there) holds nothing.
    on = (a <= 0.0) | (b <= 0.0)
    a, b = np.where(on, 1.0, a), np.where(on, 1.0, b)
    pull = spring_pull(up, rest, down)
    # 2 cos(alpha / 2), alpha the angle between the legs at rest: the unit legs' sum's length.
    two_cos = np.sum(((up - rest) / a[:, None] + (down - rest) / b[:, None]) * pull, axis=1)
    at = rest + np.minimum(travel, a * b * two_cos / (a + b))[:, None] * pull
    out: np.ndarray = a + b - np.linalg.norm(up - at, axis=1) - np.linalg.norm(down - at, axis=1)
    return np.where(on, 0.0, out)


ARC_SAMPLES = 64  # the arc's stretches searched for the path's least length, each then refined
_GOLDEN = (math.sqrt(5.0) - 1.0) / 2.0


def _arc_holds(stroke: Stroke, up: np.ndarray, down: np.ndarray, travel: float) -> np.ndarray:
    """(N,) m: :func:`spring_holds` on an arc: the path's length at rest less its least along the
    stroke, found on :data:`ARC_SAMPLES` stretches of it and refined by golden section in the
    best one and its neighbours (the path's length along an arc of at most half a turn has one
    least point there; on an exact sample the refinement keeps it)."""

    def path(x: np.ndarray) -> np.ndarray:
        # x (N, K) m along the arc -> (N, K) the path's length with the hook there.
        phi = x / stroke.arm
        hook = (
            stroke.rest[:, None, :]
            + (np.cos(phi) - 1.0)[..., None] * stroke.radial[:, None, :]
            + (stroke.arm * np.sin(phi))[..., None] * stroke.pull[:, None, :]
        )
        out: np.ndarray = np.linalg.norm(up[:, None, :] - hook, axis=2) + np.linalg.norm(
            down[:, None, :] - hook, axis=2
        )
        return out

    n = len(up)
    grid = np.broadcast_to(np.linspace(0.0, travel, ARC_SAMPLES + 1), (n, ARC_SAMPLES + 1))
    lengths = path(grid)
    best = np.argmin(lengths, axis=1)
    rows = np.arange(n)
    lo = grid[rows, np.maximum(best - 1, 0)]
    hi = grid[rows, np.minimum(best + 1, ARC_SAMPLES)]
    least = lengths[rows, best]
    a, b = hi - _GOLDEN * (hi - lo), lo + _GOLDEN * (hi - lo)
    fa, fb = path(a[:, None])[:, 0], path(b[:, None])[:, 0]
    while float(np.max(hi - lo)) > 1e-12 * max(travel, 1e-300):
        left = fa < fb
        hi = np.where(left, b, hi)
        lo = np.where(left, lo, a)
        a, b = hi - _GOLDEN * (hi - lo), lo + _GOLDEN * (hi - lo)
        fa, fb = path(a[:, None])[:, 0], path(b[:, None])[:, 0]
    least = np.minimum(least, np.minimum(fa, fb))
    out: np.ndarray = lengths[:, 0] - least
    return out


def _between(theta: np.ndarray, a: float, b: float) -> np.ndarray:
    """(N,) bool: the angles from ``a`` to ``b`` (deg), going forwards round the stitch."""
    return (theta - a) % 360.0 <= (b - a) % 360.0


__all__ = ["StitchEnd", "spring_holds", "stitch_end"]


def _geometry(
    mech: Mechanism, head: HeadTiming, hook: Crank
) -> tuple[Timing, Balance, float, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """What the thread below the eye is measured from: the head's ``[timing]`` and ``[balance]``,
    the hook's (a looper's) sense of rotation (+1 counter-clockwise), the needle's point, the
    top of its eye and the hook's point over the stitch ((N, 3) m each) and the hook shaft's
    centre ((2,) m)."""
    tm, bal = mech.timing, mech.balance
    assert tm is not None and bal is not None
    P = head.positions
    sense = math.copysign(1.0, hook.ratio * (mech.speed or 1.0))
    nt, eye, hp = P[tm.roles["needle_point"]], P[tm.roles["needle_eye"]], P[tm.roles["hook_point"]]
    return tm, bal, sense, nt, eye, hp, P[hook.pivot][0, :2]


def _lock_below(
    mech: Mechanism, head: HeadTiming, hook: Crank, at: StitchEnd
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """A lockstitch's needle thread below the eye (:func:`.timing.thread_balance`), the last stitch's
    end and the needle's hole where ``at`` puts them: ``(below the eye (N,) m, below the throat
    plate (N,) m, past the blade point (N,) m, the turn at the blade point (N,) rad, the eye's
    leg's turn on the case (N,) rad)``, the second the loop's two legs while the hook carries
    it, the third the part of the first from the blade point on (the fabric's leg, up through
    the hole and along the top to the last stitch's end), the fourth the thread's turn between
    the legs there (:func:`mjlink.analysis.loop.blade_turn`), the fifth how far the eye's leg
    turns on the bobbin case (:func:`mjlink.analysis.loop.case_turn`): the thread crossing the
    blade slides over the case along that leg, while the fabric's leg, held at the last
    stitch, is only laid on it; all four NaN elsewhere.

    Each leg runs to the hook's blade point outside the bobbin case on its own side
    (:func:`mjlink.analysis.loop.case_leg`): the fabric's from the underside of the needle's
    hole, the eye's from the eye while it is under the plate, and otherwise from the eye down
    the needle (the eye in the fabric) or straight to the hole's top, through the fabric and
    from the hole's underside."""
    tm, bal, _, nt, eye, hp, centre = _geometry(mech, head, hook)
    th, ev = head.theta, head.events
    x_n = nt[:, 0]
    bottom = np.column_stack([x_n + at.hole, np.full(len(th), tm.plate)])  # the needle's hole's underside
    top_y = tm.plate + tm.fabric
    pick, release = ev["hook picks the loop"], ev["loop released"]
    y_eye = eye[:, 1]
    above = y_eye >= top_y
    below = np.where(above, np.hypot(eye[:, 0] - x_n - at.end, y_eye - top_y), (top_y - y_eye) + at.end)
    loop = _between(th, pick, release)
    under = np.full(len(th), np.nan)
    past = np.full(len(th), np.nan)
    turn = np.full(len(th), np.nan)
    slid = np.full(len(th), np.nan)
    if loop.any():
        i = np.nonzero(loop)[0]
        r, w = bal.bobbin_case / 2.0, bal.bobbin_case_width / 2.0
        blade = hp[i, :2]
        leg_fabric, to_fabric, on_fabric = leg_and_arrival(bottom[i], blade, centre, r, w)
        under_plate = y_eye[i] <= tm.plate
        from_eye, to_eye, on_eye = leg_and_arrival(eye[i, :2], blade, centre, r, w)
        leg_eye = np.where(under_plate, from_eye, leg_fabric)
        to_hole = np.where(
            y_eye[i] <= top_y,
            y_eye[i] - tm.plate,  # down the needle in its hole
            np.hypot(eye[i, 0] - x_n[i] - at.hole[i], y_eye[i] - top_y) + tm.fabric,
        )
        under[i] = leg_eye + leg_fabric
        # Up through the needle's hole and along the top to the last stitch's end.
        past[i] = leg_fabric + tm.fabric + (at.end[i] - at.hole[i])
        below[i] = under[i] + np.where(under_plate, 0.0, to_hole) + tm.fabric + (at.end[i] - at.hole[i])
        # The eye's leg over the front face, from the hole as the fabric's where the eye is above the plate.
        turn[i] = blade_turn(np.where(under_plate[:, None], to_eye, to_fabric), to_fabric)
        slid[i] = np.where(under_plate, on_eye, on_fabric)
    return below, under, past, turn, slid


def _chain_below(mech: Mechanism, head: HeadTiming, hook: Crank, at: StitchEnd) -> np.ndarray:
    """(N,) m: a single-thread chain stitch's (101) needle thread below the eye, up to a
    constant (docs/head.md, A chain-stitch head), the held loop's hole where ``at`` puts the
    last stitch's end.

    Each loop is taken by the looper's point at the pick-up and carried round the looper's body
    (a circle of the ``looper`` diameter on the looper's shaft) for ``loop_release`` of looper
    turn, then held there, spread, while the needle rises, the feed carries the loop's hole on
    by the stitch length and the needle comes down through the held loop; the looper casts it
    off as it takes the next loop, and the take-up draws it tight round that one. Both legs of
    the loop come up through its hole: from the eye the thread runs down the needle to the
    loop's hole (the needle in it), or straight to the hole's top (the needle out), or along the
    fabric's top from the needle's new hole back to it (the needle down again); then through
    the fabric, round the looper's point and back up through the fabric. The looper's twist of
    the loop and the loop's slip around the body while held are not modelled."""
    tm, bal, sense, nt, eye, hp, centre = _geometry(mech, head, hook)
    th, ev = head.theta, head.events
    x_n, y_eye = nt[:, 0], eye[:, 1]
    top_y = tm.plate + tm.fabric
    pick = ev["hook picks the loop"]
    ratio = abs(hook.ratio)
    in_own_hole = at.inside & ~at.unset  # from the pick-up until the needle leaves the loop's hole
    off = at.end  # the held loop's hole: the needle's own from the pick-up until it leaves it
    hole = np.column_stack([x_n + off, np.full(len(th), tm.plate)])  # the hole's underside
    # The looper's point carries the loop for loop_release of its turn, then holds it there.
    turn = np.minimum(np.radians((th - pick) % 360.0) * ratio, tm.loop_release)
    spread = _carried(tm, hook, pick)
    held = np.array([_at(th, hp[:, 0], spread), _at(th, hp[:, 1], spread)])
    carrying = _between(th, pick, spread)
    point = np.where(carrying[:, None], hp[:, :2], held[None, :])
    r = bal.looper / 2.0
    leg = wrapped(hole, point, centre, r, turn, sense)
    # From the eye to the hole's underside.
    to_hole = np.where(
        in_own_hole,
        y_eye - tm.plate,  # down the needle in the loop's own hole
        np.where(
            y_eye >= top_y,
            np.hypot(eye[:, 0] - x_n - off, y_eye - top_y),  # straight to the hole's top
            (top_y - y_eye) + off,  # the needle down again: up it and along the fabric's top
        )
        + tm.fabric,
    )
    below_plate = in_own_hole & (y_eye < tm.plate)
    eye_leg = np.where(below_plate, wrapped(eye[:, :2], point, centre, r, turn, sense), to_hole + leg)
    out: np.ndarray = eye_leg + leg + tm.fabric
    return out
