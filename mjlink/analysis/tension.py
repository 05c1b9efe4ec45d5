"""The needle thread's tension over a stitch: discs, check spring, capstan friction, elastic thread.

The thread is massless and linear-elastic: a stretch of thread between two contact points
(guides, eyelets, the check spring's hook, the needle's eye) holds ``m`` of unstretched thread
over a path of length ``L`` and pulls with ``T = EA * (L - m) / m`` when ``L > m``, nothing when
it is slack (a loop). The thread moves between neighbouring stretches only by sliding over the
contact between them, which it does when the tension ratio across the contact reaches the
capstan bound ``exp(mu * beta)`` (Euler-Eytelwein, ``beta`` the angle the thread turns through
there): below it the contact holds the thread (stick), at it the thread slides towards the
higher tension and the ratio stays on the bound. The tension discs feed thread from the spool
into the first stretch only while the tension downstream of them is at their hold (the
pre-tension); nothing is drawn back through them. The check spring is a spring-mass-damper
with its stops: its hook is the thread's contact at the ``[balance] check_spring`` point at
rest, held against its rest stop by its preload; the thread's pull draws it along its stroke
(the bisector of the thread's turn there, or its arc round the stud it is wound on:
:class:`~mjlink.model.timing.Stroke`), up to its travel, where the stop takes the load.

Below the needle's eye the thread's taut length is the kinematic balance's (:mod:`.timing`):
the needle thread to the last stitch's end, round the hook's blade and the bobbin case while
the hook carries the loop. From the loop's release until the stitch is set the stitch being
set (one stitch length along the fabric's top and the fabric's thickness, down to the
interlacing and back) lies below the eye as well, so the take-up draws the loop tight against
it; at the setting that stitch's thread is locked in the fabric and leaves the model. The
thread drawn through the discs per stitch, in the periodic state, is what the stitches lock:
consumption emerges from the tensions at the setting. While the hook carries the loop its
blade point parts the thread below the eye into the eye's leg and the rest, a contact like any
guide (``[tension] hook_wrap``) whose turn includes the eye's leg's on the bobbin case, which
the thread crossing the blade slides over. The last stitch's end, where the thread below the eye is
anchored, gives into the fabric in proportion to that thread's pull (``[tension]
fabric_give``: a compressible fabric, a spring in series with the anchored stretch).

Not modelled (docs/head.md, The thread under tension): the thread's mass and waves along it,
viscoelasticity, friction below the eye but the hook's blade's and the bobbin case's (through
the fabric), the bobbin thread's pull at the interlacing (its tension is the check of
the stitch's setting, :attr:`NeedleTension.drawn_up`), a fabric's give other than linear.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np

from ..model.mechanism import Mechanism
from ..model.tension import DEFAULTS, ThreadTension
from ..model.timing import StitchType, spring_stroke
from ..units import MM
from .stitch import _between
from .tension_result import TINY, NeedleTension, _below
from .tension_state import at_most, hardest, in_path, periodic
from .timing import HeadTiming

__all__ = ["NeedleTension", "TensionError", "disc_hold", "needle_tension", "of_head"]

TOL = 1e-9  # a contact holds while its tension ratio is within this of its capstan bound
TINY_M = 1e-15  # m: thread passed this short counts as none
BLADE_ZONE = "past the hook's blade"  # the loop's leg from the blade point to the last stitch's end
SAMPLES = 1440  # steps per stitch: a quarter degree of the main shaft
MOST_NEWTON = 12  # Newton steps on the check spring's hook per step, at most
SPRING_TOL = 1e-12  # m: the hook's place found when a Newton step moves it less
# A run's tension scale: Newton converges quadratically from its start, so a step this small
# against the scale leaves an error of the order of its square, below rounding: taken, and done.
SCALE_DONE = 1e-8


class TensionError(ValueError):
    """A head the tension model does not cover (a chain stitch, no [balance] table)."""


def _unit(v: np.ndarray) -> np.ndarray:
    out: np.ndarray = v / np.linalg.norm(v, axis=-1, keepdims=True)
    return out


def _pull(ea: float, s: float, L: float) -> float:
    """N: a stretch's tension, ``s`` m of stretch over a path ``L`` m (it holds ``L - s`` of
    thread): EA times the strain on the thread's own length, none when slack."""
    return ea * s / (L - s) if s > 0.0 else 0.0


def _stretched(ea: float, T: float, L: float) -> float:
    """m: the stretch of a path ``L`` m at tension ``T`` N (the inverse of :func:`_pull`)."""
    return T * L / (ea + T)


def _scale(ea: float, w: list[float], L: list[float], total: float) -> float:
    """N: the tension scale ``t`` of a run of stretches whose tensions are ``t * w`` over paths
    ``L`` with ``total`` m of stretch between them (> 0): Newton on the run's stretch, which
    grows and bends down with ``t`` (so Newton's steps lie below the root after the first),
    from the root of the stretch to second order in the strain, ``A t - B t^2``."""
    wl = [wi * Li for wi, Li in zip(w, L, strict=True)]
    A = sum(wl) / ea
    B = sum(wi * x for wi, x in zip(w, wl, strict=True)) / (ea * ea)
    t = 2.0 * total / (A + math.sqrt(max(A * A - 4.0 * B * total, 0.0)))
    for _ in range(60):
        f, df = -total, 0.0
        for wi, x in zip(w, wl, strict=True):
            a = ea + t * wi
            f += t * x / a
            df += ea * x / (a * a)
        step = f / df
        t -= step
        if abs(step) <= SCALE_DONE * t:
            break
    return t


def _settle(
    s: list[float], L: list[float], ea: float, r: list[float], hold: float, state: list[int]
) -> tuple[list[float], float]:
    """The thread's equilibrium after a step: the stretches ``s`` (m: each stretch's path length
    ``L`` minus the thread it holds; tension :func:`_pull`), the thread's ``ea`` (N), the
    contacts' capstan bounds ``r`` (``r[j]`` between stretches j-1 and j; ``r[0]`` unused), the
    discs holding up to ``hold`` N. ``state[j]`` is contact j's (the discs' for j = 0): 0
    holding, +1 the thread sliding towards the eye, -1 away from it (never for the discs); it is
    the last step's on entry and this one's on return. Returns the new stretches and the thread
    the discs let in.

    An active set: contacts that slide link their neighbours' tensions (the ratio on its bound),
    so each run of stretches between holding contacts shares one tension scale and keeps its
    thread (a run from the discs that slide through them is at their hold); a holding contact
    beyond its bound starts to slide, one sliding against its direction holds."""
    n = len(s)
    for _ in range(16 * n):
        new = [0.0] * n
        fed = 0.0
        start = 0
        while start < n:
            end = start
            while end + 1 < n and state[end + 1] != 0:
                end += 1
            # Tensions in the run relative to its first stretch's.
            w = [1.0]
            for j in range(start + 1, end + 1):
                w.append(w[-1] * (r[j] if state[j] > 0 else 1.0 / r[j]))
            total = sum(s[start : end + 1])
            if start == 0 and state[0] != 0:
                for i in range(start, end + 1):
                    new[i] = _stretched(ea, hold * w[i - start], L[i])
                fed = total - sum(new[start : end + 1])
            elif total > 0.0:
                scale = _scale(ea, w, L[start : end + 1], total)
                for i in range(start, end + 1):
                    new[i] = _stretched(ea, scale * w[i - start], L[i])
            else:
                # Slack: no tension; the taut stretches have drawn the slack of the others.
                loose = sum(x for x in s[start : end + 1] if x < 0.0)
                for i in range(start, end + 1):
                    new[i] = s[i] * total / loose if s[i] < 0.0 else 0.0
            start = end + 1
        # What each contact passed towards the eye (positive), from the discs' feed down; the
        # worst contact out of its state changes it, one at a time (changing every one at
        # once can cycle). Thread passed is weighed by the stiffness of a stretch, EA / L.
        T = [_pull(ea, x, Li) for x, Li in zip(new, L, strict=True)]
        worst, to, most = -1, 0, 0.0
        passed = fed
        if state[0] != 0 and fed < -TINY_M and -fed * ea / L[0] > most:
            worst, to, most = 0, 0, -fed * ea / L[0]
        for j in range(1, n):
            passed += new[j - 1] - s[j - 1]
            ta, tb = T[j - 1], T[j]
            if state[j] == 0:
                if tb > r[j] * ta * (1.0 + TOL) + TINY and tb - r[j] * ta > most:
                    worst, to, most = j, 1, tb - r[j] * ta
                elif ta > r[j] * tb * (1.0 + TOL) + TINY and ta - r[j] * tb > most:
                    worst, to, most = j, -1, ta - r[j] * tb
            elif state[j] * passed < -TINY_M and abs(passed) * ea / L[j] > most:
                worst, to, most = j, 0, abs(passed) * ea / L[j]
        if state[0] == 0 and T[0] > hold * (1.0 + TOL) and T[0] - hold > most:
            worst, to, most = 0, 1, T[0] - hold
        if worst < 0:
            return new, fed
        state[worst] = to
    raise RuntimeError("the thread's contacts found no consistent state")


def _hook_stiffness(now: _Step, j: int, friction: float) -> float:
    """N/m: how much harder the thread pulls the hook at contact ``j`` (between stretches j-1
    and j) along its travel per metre it moves there, the contacts' states held (the exact
    derivative, so that the spring's Newton steps converge quadratically).

    The hook's move shortens the stretch before it by ``ga`` and the one after by ``gb`` per
    metre and turns both (the tension times each stretch's bend); each run of stretches between
    holding contacts keeps its thread and shares one tension scale ``t`` (``T = t * w``), its
    stretches each ``t * w * L / (EA + t * w)``; where the thread slides over the hook, the
    capstan bound there changes with the wrap, so the weights beyond it do too. A run the discs
    pay out keeps their hold; a slack run pulls with nothing."""
    s, c, L, r, state, T, ga, gb = now.s, now.c, now.L, now.r, now.state, now.T, now.ga, now.gb
    n, i, k = len(s), j - 1, j
    out = T[i] * (1.0 - ga * ga) / L[i] + T[k] * (1.0 - gb * gb) / L[k]
    if now.ha or now.hb:
        out -= T[i] * now.ha + T[k] * now.hb  # the arc's tangent turning
    short_a, short_b = ga * (1.0 - s[i] / L[i]), gb * (1.0 - s[k] / L[k])
    first = i
    while first > 0 and state[first] != 0:
        first -= 1
    last = k
    while last + 1 < n and state[last + 1] != 0:
        last += 1
    pays = state[0] != 0  # a run from the discs paying out keeps their hold

    def run(a: int, b: int) -> tuple[float, float, float, float, float]:
        """The run a..b's weights (relative to its first stretch) of the stretches either side
        of the hook, its compliance, its stretch and its compliance from the hook on."""
        w = 1.0
        at_i = at_k = compliance = total = beyond = 0.0
        for m in range(a, b + 1):
            if m > a:
                w *= r[m] if state[m] > 0 else 1.0 / r[m]
            compliance += w / c[m]
            total += s[m]
            if m >= k:
                beyond += w / c[m]
            if m == i:
                at_i = w
            elif m == k:
                at_k = w
        return at_i, at_k, compliance, total, beyond

    if state[k] == 0:
        # The thread holds on the hook: the runs either side each feel their own stretch.
        wa, _, ca, ta, _ = run(first, i)
        if ta > 0.0 and not (first == 0 and pays):
            out += ga * wa * short_a / ca
        _, wb, cb, tb, _ = run(k, last)
        if tb > 0.0:
            out += gb * wb * short_b / cb
        return out
    wa, wb, compliance, total, beyond = run(first, last)
    if total <= 0.0:
        return out
    dw = 0.0  # the weights from the hook on turn with the wrap, each by its own share
    if friction > 0.0:
        wrap = math.log(r[k]) / friction
        if math.sin(wrap) > TINY:
            dcos = gb / L[i] + ga / L[k] + math.cos(wrap) * (ga / L[i] + gb / L[k])
            dw = -state[k] * friction * dcos / math.sin(wrap)
    t = T[first]
    dt = 0.0 if first == 0 and pays else -(short_a + short_b + t * dw * beyond) / compliance
    return out - (ga * wa * dt + gb * wb * (dt + t * dw))


@dataclass(frozen=True, kw_only=True)
class _Step:
    """The thread's equilibrium in one step, the spring's hook at one place: the path ``L`` (m),
    the capstan bounds ``r``, the stretches' tangent stiffness ``c`` (N/m), tensions ``T`` (N)
    and stretches ``s`` (m), the
    contacts' ``state``, the thread the discs let in (m) and the hook's ``ga``, ``gb`` (how fast
    the stretches either side shorten as it moves)."""

    L: list[float]
    r: list[float]
    c: list[float]
    T: list[float]
    s: list[float]
    state: list[int]
    fed: float
    ga: float
    gb: float
    ha: float = 0.0
    hb: float = 0.0


@dataclass(frozen=True, kw_only=True)
class _Thread:
    """The path over the stitch as plain floats (the stepping loop's work per step is a few
    dozen scalar operations): per step ``k`` the lengths (m) and capstan bounds of the stretches
    and contacts, the check spring's neighbours ``up`` and ``down``, its hook at ``rest`` and
    its ``travel_dir``; the spring's contact ``spring_at``; the thread's ``friction``,
    ``stiffness`` (EA, N) and the discs' ``hold`` (N)."""

    lengths: list[list[float]]
    bounds: list[list[float]]
    up: list[list[float]]
    down: list[list[float]]
    rest: list[list[float]]
    travel_dir: list[list[float]]
    radial: list[list[float]]
    arm: float
    spring_at: int
    friction: float
    stiffness: float
    hold: float

    def geometry(self, k: int, xh: float) -> tuple[list[float], list[float], float, float, float, float]:
        """Step ``k``'s lengths and capstan bounds with the spring's hook ``xh`` (m) along its
        travel, and the hook's ``ga``, ``gb`` and, on an arc, ``ha``, ``hb`` (how its turning
        path turns them; nought on a slide)."""
        L, r = list(self.lengths[k]), list(self.bounds[k])
        up, down, rest, d = self.up[k], self.down[k], self.rest[k], self.travel_dir[k]
        ha = hb = 0.0
        if self.arm == math.inf:
            ua = [up[i] - rest[i] - xh * d[i] for i in range(3)]
            ub = [down[i] - rest[i] - xh * d[i] for i in range(3)]
        else:
            # On the arc: the hook rest + (cos - 1) radial + arm sin pull, moving along its
            # tangent, which turns towards the pivot by 1/arm per metre.
            rad, arm = self.radial[k], self.arm
            cos, sin = math.cos(xh / arm), math.sin(xh / arm)
            hook = [rest[i] + (cos - 1.0) * rad[i] + arm * sin * d[i] for i in range(3)]
            ua = [up[i] - hook[i] for i in range(3)]
            ub = [down[i] - hook[i] for i in range(3)]
            d = [cos * d[i] - sin / arm * rad[i] for i in range(3)]
            bend = [-(cos * rad[i] / arm + sin * self.travel_dir[k][i]) / arm for i in range(3)]
        la = math.sqrt(ua[0] * ua[0] + ua[1] * ua[1] + ua[2] * ua[2])
        lb = math.sqrt(ub[0] * ub[0] + ub[1] * ub[1] + ub[2] * ub[2])
        j = self.spring_at
        L[j - 1], L[j] = la, lb
        turn = -(ua[0] * ub[0] + ua[1] * ub[1] + ua[2] * ub[2]) / (la * lb)
        r[j] = math.exp(self.friction * math.acos(max(-1.0, min(1.0, turn))))
        ga = (ua[0] * d[0] + ua[1] * d[1] + ua[2] * d[2]) / la
        gb = (ub[0] * d[0] + ub[1] * d[1] + ub[2] * d[2]) / lb
        if self.arm != math.inf:
            ha = (ua[0] * bend[0] + ua[1] * bend[1] + ua[2] * bend[2]) / la
            hb = (ub[0] * bend[0] + ub[1] * bend[1] + ub[2] * bend[2]) / lb
        return L, r, ga, gb, ha, hb

    def settle(self, k: int, xh: float, s: list[float], prev: list[float], state: list[int]) -> _Step:
        """Step ``k``'s equilibrium from the last step's stretches ``s`` over its path ``prev``
        and contacts' ``state``, the hook at ``xh``: the thread each stretch holds stays until
        it slides, so its stretch first follows its path's length."""
        L, r, ga, gb, ha, hb = self.geometry(k, xh)
        moved = [si + (Li - Pi) for si, Li, Pi in zip(s, L, prev, strict=True)]
        st = list(state)
        moved, fed = _settle(moved, L, self.stiffness, r, self.hold, st)
        # Each stretch's tangent stiffness dT/ds, for the spring's Newton steps.
        c = [
            self.stiffness * Li / (Li - x) ** 2 if x > 0.0 else self.stiffness / Li
            for x, Li in zip(moved, L, strict=True)
        ]
        T = [_pull(self.stiffness, x, Li) for x, Li in zip(moved, L, strict=True)]
        return _Step(L=L, r=r, c=c, T=T, s=moved, state=st, fed=fed, ga=ga, gb=gb, ha=ha, hb=hb)


def _wrap(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    """(N,) rad: the turn of a thread from ``a`` over ``b`` to ``c`` (each (N, 3))."""
    u, w = _unit(b - a), _unit(c - b)
    out: np.ndarray = np.arccos(np.clip(np.sum(u * w, axis=1), -1.0, 1.0))
    return out


def disc_hold(ratio_to_eye: float, settings: ThreadTension) -> float:
    """The discs' hold, N, that gives ``settings.needle_tension`` to a thread drawn slowly out
    of the eye through contacts whose capstan bounds multiply to ``ratio_to_eye`` (the thread
    slides over every one towards the eye: each multiplies the tension by its bound)."""
    return settings.needle_tension / ratio_to_eye


def of_head(mech: Mechanism, head: HeadTiming) -> NeedleTension | None:
    """:func:`needle_tension` of a lockstitch head with a ``[balance]`` table, else None (a
    chain-stitch head's needle thread is not modelled under tension)."""
    if head.balance is None or mech.timing is None or mech.timing.stitch is not StitchType.LOCKSTITCH:
        return None
    return needle_tension(mech, head)


@dataclass(frozen=True, kw_only=True)
class Problem:
    """One head's thread over its stitch, ready to step (:func:`needle_tension`'s work before
    its loop): ``theta`` (N,) deg; ``zones`` (Z,) names; per step ``lengths`` and ``bounds``
    (N, Z) (m; capstan bounds, ``bounds[:, j]`` between stretches j-1 and j), the check
    spring's neighbours ``up`` and ``down``, its hook at ``rest`` and its ``pull`` direction
    (N, 3) m; ``order`` (N,) the steps' order from the stitch's setting; ``spring_at`` the
    spring's contact; the thread's ``friction``, ``stiffness`` (EA, N) and the discs'
    ``hold`` (N, inf when anchored); ``formula`` m the stitch's locked thread; ``set_at`` deg;
    the spring's ``travel`` m, ``mass`` kg, ``rate`` N/m, ``damping`` N s/m and ``force`` N at
    rest; ``dt`` s a step; ``start`` (Z,) m the stretches at the first step; ``anchored``
    whether the thread is held at both ends (:func:`needle_tension`'s ``anchored``);
    ``breaking_load`` N; ``setting`` (N,) bool the steps from the loop's release to the
    stitch's setting, while the take-up draws the stitch up against the bobbin thread's
    ``bobbin`` N."""

    theta: np.ndarray
    zones: tuple[str, ...]
    lengths: np.ndarray
    bounds: np.ndarray
    up: np.ndarray
    down: np.ndarray
    rest: np.ndarray
    pull: np.ndarray
    radial: np.ndarray
    arm: float
    order: np.ndarray
    spring_at: int
    friction: float
    stiffness: float
    hold: float
    formula: float
    set_at: float
    travel: float
    mass: float
    rate: float
    damping: float
    force: float
    dt: float
    start: np.ndarray
    anchored: bool
    breaking_load: float
    setting: np.ndarray
    bobbin: float

    def result(
        self, tension: np.ndarray, spring: np.ndarray, drawn: np.ndarray, cycles: int, period: int, per_stitch: float
    ) -> NeedleTension:
        """The :class:`NeedleTension` of a stitch run: ``tension`` (Z, N) N, ``spring`` and
        ``drawn`` (N,) m, the ``cycles`` run, the state's ``period`` (0: none) and the thread
        drawn ``per_stitch`` (m)."""
        return NeedleTension(
            theta=self.theta,
            zones=self.zones,
            tension=tension,
            spring=spring,
            drawn=drawn,
            per_stitch=per_stitch,
            formula=self.formula,
            set_at=self.set_at,
            hold=self.hold,
            stiffness=self.stiffness,
            breaking_load=self.breaking_load,
            cycles=cycles,
            converged=period > 0,
            period=period,
            set_pull=float(tension[_below(self.zones), self.setting].max(initial=0.0)),
            bobbin=self.bobbin,
        )


def prepare(
    mech: Mechanism,
    head: HeadTiming,
    *,
    settings: ThreadTension | None = None,
    spring: bool = True,
    samples: int = SAMPLES,
    anchored: float | None = None,
    below: np.ndarray | None = None,
) -> Problem:
    """The :class:`Problem` of :func:`needle_tension` (its arguments)."""
    tm, bal, path = mech.timing, mech.balance, mech.thread
    if tm is None or bal is None or not path or head.balance is None:
        raise TensionError(f"{mech.name}: the tension needs a head with [timing], [thread] and [balance] tables")
    if tm.stitch is not StitchType.LOCKSTITCH:
        raise TensionError(f"{mech.name}: the tension model covers a lockstitch (301) head, not a {tm.stitch.value}")
    cfg = settings or mech.tension or DEFAULTS
    every = len(head.theta) // samples
    if every < 1 or every * samples != len(head.theta):
        raise TensionError(f"{samples} steps do not divide the head's {len(head.theta)} angles")
    theta = head.theta[::every]
    P = {p: head.positions[p][::every] for p in path}
    n = len(theta)
    dt = math.radians(float(theta[1] - theta[0])) / abs(mech.speed)
    release = head.events["loop released"]
    # The balance measured the thread below the eye from this head's [timing] and [balance].
    stitching = head.balance.below[::every] * MM
    formula = bal.stitch_length + tm.fabric
    set_at = head.balance.phases["needle descending"][0]
    k0 = int(np.searchsorted(theta, set_at % 360.0)) % n
    # From the release until the setting the stitch being set lies below the eye too.
    setting = _between(theta, release, set_at) & (np.arange(n) != k0)
    stitching = stitching + np.where(setting, formula, 0.0)
    order = np.roll(np.arange(n), -k0)

    if anchored is not None:
        order = np.arange(n)
    held = anchored is not None and below is None  # held at the eye, nothing below it
    # The loop's turn over the hook's blade splits the thread below the eye in two there.
    split = anchored is None and cfg.hook_wrap > 0.0
    segs = len(path) - (1 if held else 0) + (1 if split else 0)  # the path's, and below the eye
    lengths = np.zeros((segs, n))
    for i in range(len(path) - 1):
        lengths[i] = np.linalg.norm(P[path[i + 1]] - P[path[i]], axis=1)
    # The turn at each contact j (between stretches j-1 and j); the eye's is given.
    wraps = np.zeros((segs, n))
    for j in range(1, len(path) - 1):
        wraps[j] = _wrap(P[path[j - 1]], P[path[j]], P[path[j + 1]])
    if split:
        # While the hook carries the loop the blade point parts the eye's leg from the rest;
        # elsewhere the blade holds nothing and the two stretches are one thread split at its
        # middle (the stitch being set on the far side), sliding freely between them. At the
        # pick-up's first step the caught thread shares out at one tension; from the next the
        # blade holds it by the capstan bound.
        past = head.balance.past[::every] * MM
        carried = np.isfinite(past)
        lengths[-1] = np.where(carried, past, 0.5 * (stitching + np.where(setting, formula, 0.0)))
        lengths[-2] = stitching - lengths[-1]
        if not (lengths[-2:] > TINY_M).all():
            k = int(np.argmin(lengths[-2:].min(axis=0)))
            raise TensionError(
                f"{mech.name}: the hook's blade point meets the needle's eye at {theta[k]:.2f} deg: "
                "no thread between them for the loop's turn over the blade (hook_wrap = 0 lets it slide freely)"
            )
        wraps[-2] = cfg.eye_wrap
        # The legs' own turn at the blade point, at most the file's; and the eye's leg's turn on
        # the bobbin case, which the thread crossing the blade slides over on its way (the
        # fabric's leg, held at the last stitch, is only laid on the case): one capstan.
        turn = np.radians(np.nan_to_num(head.balance.blade_turn[::every]))
        on_case = np.radians(np.nan_to_num(head.balance.case_turn[::every]))
        wraps[-1] = np.where(carried & np.roll(carried, 1), np.minimum(turn, cfg.hook_wrap) + on_case, 0.0)
    elif not held:
        lengths[-1] = stitching if below is None else np.asarray(below)[::every]
        wraps[-1] = cfg.eye_wrap
    if anchored is None:
        # The last stitch gives into the fabric as the thread anchored at it pulls: a spring
        # of give per newton in series with that stretch, whose law (EA times the strain on
        # the thread it holds) then holds EA * give more thread that never flows.
        lengths[-1] += cfg.stiffness * cfg.fabric_give

    cs = path.index(bal.check_spring)
    travel = bal.check_spring_travel if spring else 0.0
    rest, up, down = P[path[cs]], P[path[cs - 1]], P[path[cs + 1]]
    pivot = None if bal.check_spring_pivot is None else mech.ground[bal.check_spring_pivot]
    try:
        stroke = spring_stroke(up, rest, down, pivot, travel)
    except ValueError as e:
        raise TensionError(f"{mech.name}: {e}") from None
    # The discs' hold: the file's needle tension drawn slowly out of the eye at the needle
    # bar's top, the spring pulled to its stop.
    stop = stroke.at(travel)[:1]
    at_top = wraps[:, 0].copy()
    at_top[cs] = _wrap(up[:1], stop, down[:1])[0]
    hold = math.inf if anchored is not None else disc_hold(float(np.exp(cfg.friction * at_top[1:].sum())), cfg)
    # Every stretch at the discs' hold, or the thread held with its slack in the first.
    if anchored is None:
        start = np.array([_stretched(cfg.stiffness, hold, L) for L in lengths[:, order[0]]])
    else:
        start = np.zeros(segs)
        start[0] = float(lengths[:, order[0]].sum()) - anchored
    zones = (*(f"{a}-{b}" for a, b in itertools.pairwise(path)), f"below {path[-1]}")
    if held:
        zones = zones[:-1]
    elif split:
        zones = (*zones, BLADE_ZONE)
    return Problem(
        theta=theta,
        zones=zones,
        lengths=lengths.T.copy(),
        bounds=np.exp(cfg.friction * wraps).T.copy(),
        up=up,
        down=down,
        rest=rest,
        pull=stroke.pull,
        radial=stroke.radial,
        arm=stroke.arm,
        order=order,
        spring_at=cs,
        friction=cfg.friction,
        stiffness=cfg.stiffness,
        hold=hold,
        formula=formula,
        set_at=set_at,
        travel=travel,
        mass=cfg.spring_mass,
        rate=cfg.spring_rate,
        damping=2.0 * cfg.spring_damping * math.sqrt(cfg.spring_rate * cfg.spring_mass),
        force=cfg.spring_force,
        dt=dt,
        start=start,
        anchored=anchored is not None,
        breaking_load=cfg.breaking_load,
        setting=setting if anchored is None else np.zeros(n, dtype=bool),
        bobbin=cfg.bobbin_tension,
    )


def needle_tension(
    mech: Mechanism,
    head: HeadTiming,
    *,
    settings: ThreadTension | None = None,
    spring: bool = True,
    samples: int = SAMPLES,
    most_cycles: int = 80,
    anchored: float | None = None,
    cycles: int | None = None,
    below: np.ndarray | None = None,
) -> NeedleTension:
    """The needle thread's tension over one stitch of a lockstitch ``head``, at the file's speed,
    in its periodic state (the module's docstring says what is modelled).

    Args:
      mech: a lockstitch head with ``[timing]``, ``[thread]`` and ``[balance]`` tables.
      head: its timing (:func:`.timing.head_timing`), whose angles ``samples`` divides.
      settings: the thread and its tensioning parts; ``mech.tension`` or the published
        defaults (:data:`~mjlink.model.tension.DEFAULTS`) when None.
      spring: False takes the check spring away (its hook a fixed guide).
      samples: steps per stitch.
      most_cycles: stitches run at most to reach the periodic state (a state found, up to its
        period less one more, to its hardest pulled stitch).
      anchored: hold this much thread (m, unstretched) at the discs (they never let it
        through) and at the eye, with nothing below it, the spring at rest at the needle bar's
        top and any slack there in the first stretch: what a MuJoCo tendon through the same
        path models (:mod:`mjlink.sim.thread`).
      below: with ``anchored``, the thread below the eye instead of none ((N,) m on the head's
        angles, e.g. :func:`.loop.held_loop`), held at its end.
      cycles: run exactly this many stitches from the start and give the last (``converged``
        then says only that they ran).
    Returns:
      :class:`NeedleTension` on ``samples`` angles.
    Raises:
      TensionError: a chain stitch, or a head without a ``[balance]`` table.
    """
    pb = prepare(mech, head, settings=settings, spring=spring, samples=samples, anchored=anchored, below=below)
    return step(pb, most_cycles=most_cycles, cycles=cycles)


@dataclass(frozen=True, kw_only=True)
class Carry:
    """Where a thread's stepping stands at a stitch's end: its stretches ``s`` (m), contacts'
    ``state``, the spring's hook ``x`` (m) and speed ``v`` (m/s), the path ``prev`` (m), the
    thread each stitch drew through the discs ``feds`` (m, oldest first), the thread in the
    path at its end ``helds`` (m) and its peak tension ``tops`` (N), the ``period`` found (0:
    none yet) and the stitch to ``finish`` at, the stitches ``ran``."""

    s: list[float]
    state: list[int]
    x: float
    v: float
    prev: list[float]
    feds: tuple[float, ...]
    helds: tuple[float, ...]
    tops: tuple[float, ...]
    period: int
    finish: int
    ran: int


def step(pb: Problem, *, most_cycles: int = 80, cycles: int | None = None, carry: Carry | None = None) -> NeedleTension:
    """Steps one :class:`Problem` to its periodic state in plain floats (the twin of
    :func:`.tension_many.step_many`, which steps many at once), from its start or from where
    ``carry`` says a stepping stood."""
    n = len(pb.theta)
    segs = pb.lengths.shape[1]
    cs, travel, dt = pb.spring_at, pb.travel, pb.dt
    thread = _Thread(
        lengths=pb.lengths.tolist(),
        bounds=pb.bounds.tolist(),
        up=pb.up.tolist(),
        down=pb.down.tolist(),
        rest=pb.rest.tolist(),
        travel_dir=pb.pull.tolist(),
        radial=pb.radial.tolist(),
        arm=pb.arm,
        spring_at=cs,
        friction=pb.friction,
        stiffness=pb.stiffness,
        hold=pb.hold,
    )
    k_s = pb.rate
    inertia, damp = pb.mass / (dt * dt), pb.damping / dt
    formula = pb.formula
    s = pb.start.tolist()
    x = v = 0.0
    out_T = np.zeros((n, segs))
    out_x = np.zeros(n)
    out_d = np.zeros(n)
    state = [0] * segs
    feds: list[float] = []
    helds: list[float] = []  # m: the thread in the path at each stitch's end
    tops: list[float] = []
    fed = 0.0
    prev = thread.geometry(int(pb.order[0]), x)[0]
    period, finish = 0, 0
    ran = done = 0
    if carry is not None:
        s, state, x, v, prev, done = list(carry.s), list(carry.state), carry.x, carry.v, list(carry.prev), carry.ran
        feds, helds, tops = list(carry.feds), list(carry.helds), list(carry.tops)
        period, finish = carry.period, carry.finish
    for ran in range(done + 1, at_most(most_cycles, cycles) + 1):
        fed = 0.0
        for step, k in enumerate(pb.order.tolist()):
            if step == 0 and ran > 1 and not pb.anchored:
                # The stitch is set: its thread is locked in the fabric and leaves the stretch
                # below the eye at the tension it was set with.
                if s[-1] > 0.0:
                    s[-1] *= (prev[-1] - formula) / prev[-1]
                prev[-1] -= formula
            # The hook's first place: where its speed would carry it (Newton's start).
            xh = min(max(x + dt * v, 0.0), travel)
            now = thread.settle(k, xh, s, prev, state)
            if travel > 0.0:
                # Backward Euler on the spring, its hook where its inertia, damping and force
                # balance the thread's pull (Newton on the hook's place, the thread settled at
                # each): stable at any speed, the thread being far stiffer than the spring.
                for _ in range(MOST_NEWTON):
                    T = now.T
                    f = T[cs - 1] * now.ga + T[cs] * now.gb
                    g = inertia * (xh - x - dt * v) + damp * (xh - x) + pb.force + k_s * xh - f
                    if (xh == 0.0 and g >= 0.0) or (xh == travel and g <= 0.0):
                        # Pressed against its stop: Newton's step (its stiffness is positive,
                        # the hook's inertia over the step) would only clip it back there.
                        break
                    stiff = inertia + damp + k_s + _hook_stiffness(now, cs, pb.friction)
                    nxt = min(max(xh - g / stiff, 0.0), travel)
                    if abs(nxt - xh) <= SPRING_TOL:
                        break
                    xh = nxt
                    now = thread.settle(k, xh, s, prev, state)
                v = 0.0 if xh in (0.0, travel) else (xh - x) / dt
                x = xh
            s, state, prev = now.s, now.state, now.L
            fed += now.fed
            out_T[k] = now.T
            out_x[k] = x
            out_d[k] = fed
        feds.append(fed)
        helds.append(in_path(prev, s))
        tops.append(float(out_T.max()))
        if cycles is None and not period:
            period = periodic(feds, helds)
            finish = hardest(ran, tops[-period:]) if period else 0
        if (period and ran == finish) or (not period and ran == (cycles or most_cycles)):
            break
    if cycles is not None:
        return pb.result(out_T.T.copy(), out_x, out_d, ran, 1, feds[-1])
    # Any `period` stitches in a row of the repeating state draw the same thread between them.
    per_stitch = sum(feds[-period:]) / period if period else feds[-1]
    return pb.result(out_T.T.copy(), out_x, out_d, ran, period, per_stitch)
