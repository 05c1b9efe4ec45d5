"""Many heads' needle threads stepped at once: :func:`.tension.step` over a batch of problems.

A study's variants share a path's shape (the same points, stretches and contacts), so one step
of all of them is a handful of array operations on (V, Z) arrays where :func:`.tension.step`
spends a few dozen scalar operations on each. Every decision of the scalar twin is made here
in the same order per variant (the contact most out of its state changes first, the spring's
Newton stops at the same test, a variant stops at its own periodic state), so the two agree to
rounding; tests/test_tension_many.py holds them together.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, cast

import numpy as np

from .tension import (
    MOST_NEWTON,
    SCALE_DONE,
    SPRING_TOL,
    TINY_M,
    TOL,
    Carry,
    NeedleTension,
    Problem,
    step,
)
from .tension import _settle as _settle_one
from .tension_result import TINY
from .tension_state import at_most, hardest, in_path, periodic

__all__ = ["share", "step_many"]

_NEWTON = 60  # a run's tension scale: Newton steps at most (the scalar's bound)
ALONE = 24  # threads still stepping at a stitch's end at most for the plain twin to take them over
FEW = 8  # threads still changing their contacts at most for a step's passes to go on one by one
TOGETHER = 48  # threads at least for an array step to cost less than the twin's (bench/bench_tension.py)
# A thread's stitch in an array step of V threads costs about ARRAY_OWN / V + ARRAY_EACH of the
# twin's (the array's every call has its own cost; measured on the shipped head, 720 steps a
# stitch: 0.66 of it at 48 threads, 0.31 at 192, 0.22 at 512).
ARRAY_OWN = 24.0
ARRAY_EACH = 0.18


def share(n: int) -> float:
    """A thread's cost stepped among ``n`` (:func:`step_many`) against its cost alone."""
    return 1.0 if n < TOGETHER else min(1.0, ARRAY_OWN / n + ARRAY_EACH)


def _runs(state: np.ndarray, lr: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Each stretch's run (the stretches a sliding contact links), from the contacts' ``state``
    and the logarithms ``lr`` (V, Z) of their capstan bounds: ``same`` (V, Z, Z) 1.0 where two
    stretches share a run, ``first`` (V, Z) the index of its run's first stretch and ``w``
    (V, Z) its tension relative to that first stretch's (the sliding contacts' bounds
    multiplied, as logarithms summed along the run)."""
    Z = state.shape[1]
    linked = state != 0
    linked[:, 0] = False
    first = np.maximum.accumulate(np.where(linked, 0, np.arange(Z)), axis=1)
    steps = state * lr  # a sliding contact (+1 or -1) multiplies by its bound or divides
    steps[:, 0] = 0.0  # the discs link nothing before them
    c = np.cumsum(steps, axis=1)
    w = np.exp(c - c.ravel()[first + Z * np.arange(len(c))[:, None]])
    same = (first[:, :, None] == first[:, None, :]).astype(float)
    return same, first, w


def _in_run(same: np.ndarray, x: np.ndarray) -> np.ndarray:
    """(V, Z): the sum of ``x`` (V, Z) over each stretch's run."""
    out: np.ndarray = np.einsum("vij,vj->vi", same, x)
    return out


def _pull(ea: np.ndarray, s: np.ndarray, L: np.ndarray) -> np.ndarray:
    """:func:`.tension._pull` elementwise; ``ea`` (V, 1)."""
    out: np.ndarray = np.where(s > 0.0, ea * s / np.where(s > 0.0, L - s, 1.0), 0.0)
    return out


def _solve(
    s: np.ndarray, L: np.ndarray, ea: np.ndarray, lr: np.ndarray, hold: np.ndarray, state: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The stretches and the discs' feed for the contacts' ``state`` held (one pass of
    :func:`.tension._settle`'s loop): ``ea`` and ``hold`` (V, 1), ``lr`` the logarithms of
    the capstan bounds; and the runs' ``first`` and ``w`` (:func:`_runs`)."""
    same, first, w = _runs(state, lr)
    total = _in_run(same, s)
    discs = (first == 0) & (state[:, :1] != 0)
    taut = ~discs & (total > 0.0)
    wL = w * L
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        # A run paying out of the discs is at their hold.
        held = hold * w
        new_discs = held * L / (ea + held)
        # A taut run shares one tension scale over its thread: Newton from the root of its
        # stretch to second order in the strain (:func:`.tension._scale`).
        A, B = _in_run(same, wL) / ea, _in_run(same, w * wL) / (ea * ea)
        t = np.where(taut, 2.0 * total / (A + np.sqrt(np.maximum(A * A - 4.0 * B * total, 0.0))), 1.0)
        going = taut.copy()  # each run stops at its own step, as the scalar twin's does
        for _ in range(_NEWTON):
            a = ea + t * w
            f = _in_run(same, t * wL / a) - total
            df = _in_run(same, ea * wL / (a * a))
            dt = np.where(going, f / np.where(going, df, 1.0), 0.0)
            t = t - dt
            going &= np.abs(dt) > SCALE_DONE * np.abs(t)
            if not going.any():
                break
        new_taut = t * w * L / (ea + t * w)
        # A slack run: the taut stretches have drawn the slack of the others.
        loose = _in_run(same, np.minimum(s, 0.0))
        new_slack = np.where(s < 0.0, s * total / np.where(loose < 0.0, loose, -1.0), 0.0)
    new = np.where(discs, new_discs, np.where(taut, new_taut, new_slack))
    fed = np.where(discs[:, 0], total[:, 0] - _in_run(same, new)[:, 0], 0.0)
    return new, fed, first, w


def _settle(
    s: np.ndarray,
    L: np.ndarray,
    ea: np.ndarray,
    r: np.ndarray,
    lr: np.ndarray,
    hold: np.ndarray,
    state: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """:func:`.tension._settle` for V threads at once: ``s``, ``L``, ``r``, ``state`` (V, Z)
    (``state`` updated in place), ``lr`` the logarithms of ``r``, ``ea`` and ``hold`` (V, 1);
    with the new stretches and feed, the runs' ``first`` and ``w`` (:func:`_runs`) in the state
    found. Each thread changes its
    contact most out of its state, one a pass, until none is; the ones done leave the passes,
    and the last :data:`FEW` finish theirs one by one."""
    V, Z = s.shape
    new_all = np.empty_like(s)
    fed_all = np.zeros(V)
    first_all = np.empty(s.shape, dtype=np.int64)
    w_all = np.empty_like(s)
    todo = np.arange(V)
    for _ in range(16 * Z):
        sv, Lv, eav, rv, hv, st = s[todo], L[todo], ea[todo], r[todo], hold[todo], state[todo]
        new, fed, first, w = _solve(sv, Lv, eav, lr[todo], hv, st)
        T = _pull(eav, new, Lv)
        e = eav[:, 0]
        score = np.zeros((len(todo), Z + 1))
        to = np.zeros((len(todo), Z + 1), dtype=state.dtype)
        # The discs stop paying out when they would have to take thread back.
        score[:, 0] = np.where((st[:, 0] != 0) & (fed < -TINY_M), -fed * e / Lv[:, 0], 0.0)
        # What each contact passed towards the eye, from the discs' feed down.
        passed = fed[:, None] + np.cumsum(new[:, :-1] - sv[:, :-1], axis=1)
        ta, tb, rj, sj = T[:, :-1], T[:, 1:], rv[:, 1:], st[:, 1:]
        holding = sj == 0
        down = holding & (tb > rj * ta * (1.0 + TOL) + TINY)
        up = holding & ~down & (ta > rj * tb * (1.0 + TOL) + TINY)
        back = ~holding & (sj * passed < -TINY_M)
        score[:, 1:Z] = np.where(
            down, tb - rj * ta, np.where(up, ta - rj * tb, np.where(back, np.abs(passed) * e[:, None] / Lv[:, 1:], 0.0))
        )
        to[:, 1:Z] = np.where(down, 1, np.where(up, -1, 0))
        # The discs start to pay out at their hold (checked last, as the twin does).
        score[:, Z] = np.where((st[:, 0] == 0) & (T[:, 0] > hv[:, 0] * (1.0 + TOL)), T[:, 0] - hv[:, 0], 0.0)
        to[:, Z] = 1
        worst = np.argmax(score, axis=1)
        rows = np.arange(len(todo))
        moves = score[rows, worst] > 0.0
        done = ~moves
        new_all[todo[done]] = new[done]
        fed_all[todo[done]] = fed[done]
        first_all[todo[done]] = first[done]
        w_all[todo[done]] = w[done]
        which = todo[moves]
        state[which, np.where(worst[moves] == Z, 0, worst[moves])] = to[rows[moves], worst[moves]]
        todo = which
        if 0 < len(todo) <= FEW:
            # The few threads whose contacts still change take the plain passes from here:
            # the same decisions, without an array pass's own cost.
            for i in todo.tolist():
                st_i = state[i].tolist()
                new_i, fed_all[i] = _settle_one(
                    s[i].tolist(), L[i].tolist(), float(ea[i, 0]), r[i].tolist(), float(hold[i, 0]), st_i
                )
                new_all[i], state[i] = new_i, st_i
            _, first_all[todo], w_all[todo] = _runs(state[todo], lr[todo])
            return new_all, fed_all, first_all, w_all
        if not len(todo):
            return new_all, fed_all, first_all, w_all
    raise RuntimeError("the thread's contacts found no consistent state")


@dataclass(kw_only=True)
class _Now:
    """V threads' equilibrium in one step (:class:`.tension._Step` as (V, Z) arrays; ``fed``,
    ``ga`` and ``gb`` (V,)), with its runs' ``first`` and ``w`` (:func:`_runs`); without the
    stretches' tangent stiffness, which only the hook's Newton steps need
    (:func:`_hook_stiffness` makes it for the threads that take them)."""

    L: np.ndarray
    r: np.ndarray
    T: np.ndarray
    s: np.ndarray
    state: np.ndarray
    fed: np.ndarray
    ga: np.ndarray
    gb: np.ndarray
    ha: np.ndarray | None  # None on a slide
    hb: np.ndarray | None
    first: np.ndarray
    w: np.ndarray

    def put(self, at: np.ndarray, other: _Now) -> None:
        """Replaces the threads ``at`` by ``other``'s."""
        for name in self.__dataclass_fields__:
            mine = getattr(self, name)
            if mine is not None:
                mine[at] = getattr(other, name)


@dataclass(kw_only=True)
class _Batch:
    """The problems' per-step geometry stacked: (V, N, Z) lengths and bounds, (V, N, 3) the
    spring's neighbours, rest and direction, (V, 1) the thread's numbers, ``cs`` the spring's
    contact."""

    lengths: np.ndarray
    bounds: np.ndarray
    log_bounds: np.ndarray
    up: np.ndarray
    down: np.ndarray
    rest: np.ndarray
    pull: np.ndarray
    radial: np.ndarray
    arm: np.ndarray
    swings: bool  # the hooks swing on arcs (every problem's, or none's)
    friction: np.ndarray
    ea: np.ndarray
    hold: np.ndarray
    cs: int

    def settle(
        self, at: np.ndarray, k: np.ndarray, xh: np.ndarray, s: np.ndarray, prev: np.ndarray, state: np.ndarray
    ) -> _Now:
        """:meth:`.tension._Thread.settle` for the threads ``at`` (V,) of the batch, each at its
        step ``k`` (V,), its spring's hook at ``xh`` (V,) m, from its stretches ``s`` over its
        path ``prev`` and its contacts' ``state`` (V, Z; copied)."""
        L, r, lr = self.lengths[at, k], self.bounds[at, k], self.log_bounds[at, k]
        ua, ub, d, bend = self._legs(at, k, xh)
        la = np.sqrt(np.einsum("ij,ij->i", ua, ua))
        lb = np.sqrt(np.einsum("ij,ij->i", ub, ub))
        j = self.cs
        L[:, j - 1], L[:, j] = la, lb
        turn = -np.einsum("ij,ij->i", ua, ub) / (la * lb)
        lr[:, j] = self.friction[at, 0] * np.arccos(np.clip(turn, -1.0, 1.0))
        r[:, j] = np.exp(lr[:, j])
        ga = np.einsum("ij,ij->i", ua, d) / la
        gb = np.einsum("ij,ij->i", ub, d) / lb
        if bend is None:
            ha = hb = None
        else:
            ha = np.einsum("ij,ij->i", ua, bend) / la
            hb = np.einsum("ij,ij->i", ub, bend) / lb
        st = state.copy()
        ea = self.ea[at]
        moved, fed, first, w = _settle(s + (L - prev), L, ea, r, lr, self.hold[at], st)
        return _Now(
            L=L, r=r, T=_pull(ea, moved, L), s=moved, state=st, fed=fed, ga=ga, gb=gb, ha=ha, hb=hb, first=first, w=w
        )

    def lengths_at(self, at: np.ndarray, k: np.ndarray, xh: np.ndarray) -> np.ndarray:
        """(V, Z) m: the threads' ``at`` path lengths at step ``k`` with the hook at ``xh``."""
        L: np.ndarray = self.lengths[at, k]
        ua, ub, _, _ = self._legs(at, k, xh)
        L[:, self.cs - 1] = np.sqrt(np.einsum("ij,ij->i", ua, ua))
        L[:, self.cs] = np.sqrt(np.einsum("ij,ij->i", ub, ub))
        return L

    def _legs(
        self, at: np.ndarray, k: np.ndarray, xh: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray | None]:
        """The threads' ``at`` legs from the hook at ``xh`` to its neighbours (V, 3 each), the
        hook's direction of travel there and, on an arc, how that direction turns per metre
        (None on a slide): :meth:`.tension._Thread.geometry`'s."""
        d = self.pull[at, k]
        rest = self.rest[at, k]
        if not self.swings:
            return self.up[at, k] - rest - xh[:, None] * d, self.down[at, k] - rest - xh[:, None] * d, d, None
        rad, arm = self.radial[at, k], self.arm[at][:, None]
        phi = xh[:, None] / arm
        cos, sin = np.cos(phi), np.sin(phi)
        hook = rest + (cos - 1.0) * rad + arm * sin * d
        tangent = cos * d - sin / arm * rad
        bend = -(cos * rad / arm + sin * d) / arm
        return self.up[at, k] - hook, self.down[at, k] - hook, tangent, bend


def _rows(a: np.ndarray | None, at: np.ndarray) -> np.ndarray | None:
    """``a``'s rows ``at``, or None for None."""
    return None if a is None else a[at]


def _hook_stiffness(now: _Now, cs: int, pays: np.ndarray, friction: np.ndarray, ea: np.ndarray) -> np.ndarray:
    """:func:`.tension._hook_stiffness` for V threads (N/m, (V,)): ``pays`` (V,) whether the
    discs pay out, ``friction`` (V,) the thread's coefficient, ``ea`` (V, 1) its EA."""
    first, w = now.first, now.w
    Z = w.shape[1]
    a, b = cs - 1, cs
    T, L, s, ga, gb = now.T, now.L, now.s, now.ga, now.gb
    taut = s > 0.0
    c = np.where(taut, ea * L / np.where(taut, L - s, 1.0) ** 2, ea / L)  # dT/ds (.tension._Thread.settle)
    bend = T[:, a] * (1.0 - ga * ga) / L[:, a] + T[:, b] * (1.0 - gb * gb) / L[:, b]
    if now.ha is not None and now.hb is not None:
        bend -= T[:, a] * now.ha + T[:, b] * now.hb  # an arc's tangent turning
    in_a, in_b = first == first[:, a : a + 1], first == first[:, b : b + 1]  # (V, Z) each run's stretches
    wc = w / c
    compliance_a, compliance_b = (wc * in_a).sum(axis=1), (wc * in_b).sum(axis=1)
    live_a, live_b = (s * in_a).sum(axis=1) > 0.0, (s * in_b).sum(axis=1) > 0.0
    held_a, held_b = (first[:, a] == 0) & pays, (first[:, b] == 0) & pays  # the discs pay out: it stays
    t = T.ravel()[first[:, a] + Z * np.arange(len(T))]
    joined = now.state[:, b] != 0
    short_a, short_b = ga * (1.0 - s[:, a] / L[:, a]), gb * (1.0 - s[:, b] / L[:, b])
    # Apart: each run its own stretch.
    out: np.ndarray = bend + np.where(~joined & live_a & ~held_a, ga * w[:, a] * short_a / compliance_a, 0.0)
    out += np.where(~joined & live_b & ~held_b, gb * w[:, b] * short_b / compliance_b, 0.0)
    if not joined.any():
        return out
    # Joined: one run over both stretches, whose weights from the hook on turn with the wrap.
    with np.errstate(divide="ignore", invalid="ignore"):
        wrap = np.where(joined & (friction > 0.0), np.log(now.r[:, b]) / np.where(friction > 0.0, friction, 1.0), 0.0)
        turning = joined & (np.sin(wrap) > TINY)
        dcos = gb / L[:, a] + ga / L[:, b] + np.cos(wrap) * (ga / L[:, a] + gb / L[:, b])
        dw = np.where(turning, -now.state[:, b] * friction * dcos / np.where(turning, np.sin(wrap), 1.0), 0.0)
        beyond = (wc * (in_b & (np.arange(Z) >= b))).sum(axis=1)
        dt = np.where(held_a, 0.0, -(short_a + short_b + t * dw * beyond) / compliance_a)
        both = -(ga * w[:, a] * dt + gb * w[:, b] * (dt + t * dw))
    out += np.where(joined & live_a, both, 0.0)
    return out


def step_many(problems: list[Problem], *, most_cycles: int = 80, cycles: int | None = None) -> list[NeedleTension]:
    """:func:`.tension.step` of every problem, stepped together.

    Args:
      problems: V problems of one path's shape (the same steps N, stretches Z and spring
        contact), from :func:`.tension.prepare`.
      most_cycles: stitches run at most to reach the periodic state (a state found, up to its
        period less one more, to its hardest pulled stitch).
      cycles: run exactly this many stitches (the twin's ``cycles``).
    Returns:
      V :class:`NeedleTension`, each what :func:`.tension.step` gives its problem.
    """
    if len(problems) < TOGETHER:
        return [step(p, most_cycles=most_cycles, cycles=cycles) for p in problems]
    shapes = [(p.lengths.shape, p.spring_at, p.anchored, math.isfinite(p.arm)) for p in problems]
    if len(set(shapes)) > 1:
        # Problems of other shapes (a study varying the hook's wrap from nought: one stretch
        # fewer below the eye) are stepped each with their own kind.
        out: list[NeedleTension | None] = [None] * len(problems)
        for shape in dict.fromkeys(shapes):
            idx = [i for i, sh in enumerate(shapes) if sh == shape]
            for i, t in zip(
                idx, step_many([problems[i] for i in idx], most_cycles=most_cycles, cycles=cycles), strict=True
            ):
                out[i] = t
        return cast(list[NeedleTension], out)
    V = len(problems)
    n, Z = problems[0].lengths.shape
    cs = problems[0].spring_at

    def col(name: str) -> np.ndarray:
        return np.array([float(getattr(p, name)) for p in problems])

    bounds = np.stack([p.bounds for p in problems])
    g = _Batch(
        lengths=np.stack([p.lengths for p in problems]),
        bounds=bounds,
        log_bounds=np.log(bounds),
        up=np.stack([p.up for p in problems]),
        down=np.stack([p.down for p in problems]),
        rest=np.stack([p.rest for p in problems]),
        pull=np.stack([p.pull for p in problems]),
        radial=np.stack([p.radial for p in problems]),
        arm=col("arm"),
        swings=math.isfinite(problems[0].arm),
        friction=col("friction")[:, None],
        ea=col("stiffness")[:, None],
        hold=col("hold")[:, None],
        cs=cs,
    )
    order = np.stack([p.order for p in problems])
    travel, dt, k_s, force, formula = col("travel"), col("dt"), col("rate"), col("force"), col("formula")
    inertia, damp = col("mass") / (dt * dt), col("damping") / dt
    anchored = problems[0].anchored

    out_T = np.zeros((V, n, Z))
    out_x = np.zeros((V, n))
    out_d = np.zeros((V, n))
    last = at_most(most_cycles, cycles)
    feds = np.full((V, last), np.nan)
    helds = np.full((V, last), np.nan)
    tops = np.full((V, last), np.nan)
    period = np.zeros(V, dtype=np.int64)
    finish = np.zeros(V, dtype=np.int64)
    results: list[NeedleTension | None] = [None] * V

    live = np.arange(V)  # the problems still stepping
    s = np.stack([p.start for p in problems])
    x = np.zeros(V)
    v = np.zeros(V)
    state = np.zeros((V, Z), dtype=np.int64)
    prev = g.lengths_at(live, order[:, 0], x)
    for ran in range(1, last + 1):
        if len(live) <= ALONE and ran > 1:
            # A few left (slow to settle): the plain twin steps each from here, cheaper than
            # an array step over a handful of threads.
            for i, at in enumerate(live):
                carry = Carry(
                    s=s[i].tolist(),
                    state=[int(c) for c in state[i]],
                    x=float(x[i]),
                    v=float(v[i]),
                    prev=prev[i].tolist(),
                    feds=tuple(float(f) for f in feds[at, : ran - 1]),
                    helds=tuple(float(f) for f in helds[at, : ran - 1]),
                    tops=tuple(float(f) for f in tops[at, : ran - 1]),
                    period=int(period[at]),
                    finish=int(finish[at]),
                    ran=ran - 1,
                )
                results[at] = step(problems[at], most_cycles=most_cycles, cycles=cycles, carry=carry)
            break
        fed = np.zeros(len(live))
        ordr = order[live]
        tr, dtv, ks, fs = travel[live], dt[live], k_s[live], force[live]
        inr, dmp = inertia[live], damp[live]
        fr = g.friction[live, 0]
        sprung = tr > 0.0
        for stepno in range(n):
            k = ordr[:, stepno]
            if stepno == 0 and ran > 1 and not anchored:
                # The stitch is set: its thread leaves the stretch below the eye.
                f = formula[live]
                taut = s[:, -1] > 0.0
                s[taut, -1] *= (prev[taut, -1] - f[taut]) / prev[taut, -1]
                prev[:, -1] -= f
            xh = np.minimum(np.maximum(x + dtv * v, 0.0), tr)
            now = g.settle(live, k, xh, s, prev, state)
            newton = sprung.copy()
            for _ in range(MOST_NEWTON):
                at = np.flatnonzero(newton)
                if not len(at):
                    break
                f_hook = now.T[at, cs - 1] * now.ga[at] + now.T[at, cs] * now.gb[at]
                xa, va, xt = x[at], v[at], xh[at]
                resid = inr[at] * (xt - xa - dtv[at] * va) + dmp[at] * (xt - xa) + fs[at] + ks[at] * xt - f_hook
                # A hook pressed against its stop stays (the twin's rule, before its stiffness).
                free = ~(((xt == 0.0) & (resid >= 0.0)) | ((xt == tr[at]) & (resid <= 0.0)))
                newton[at[~free]] = False
                at, resid, xt = at[free], resid[free], xt[free]
                if not len(at):
                    break
                sub = _Now(**cast(Any, {name: _rows(getattr(now, name), at) for name in _Now.__dataclass_fields__}))
                stiff = (
                    inr[at] + dmp[at] + ks[at] + _hook_stiffness(sub, cs, sub.state[:, 0] != 0, fr[at], g.ea[live[at]])
                )
                nxt = np.minimum(np.maximum(xt - resid / stiff, 0.0), tr[at])
                still = np.abs(nxt - xt) > SPRING_TOL
                newton[at[~still]] = False
                moving = at[still]
                if not len(moving):
                    break
                xh[moving] = nxt[still]
                now.put(moving, g.settle(live[moving], k[moving], xh[moving], s[moving], prev[moving], state[moving]))
            stops = (xh == 0.0) | (xh == tr)
            v = np.where(sprung, np.where(stops, 0.0, (xh - x) / dtv), v)
            x = np.where(sprung, xh, x)
            s, state, prev = now.s, now.state, now.L
            fed = fed + now.fed
            out_T[live, k] = now.T
            out_x[live, k] = x
            out_d[live, k] = fed
        feds[live, ran - 1] = fed
        helds[live, ran - 1] = [in_path(a, b) for a, b in zip(prev.tolist(), s.tolist(), strict=True)]
        tops[live, ran - 1] = out_T[live].max(axis=(1, 2))
        if cycles is None:
            # A state found: on to its stitch with the highest peak (the twin's rule).
            for i in np.flatnonzero(period[live] == 0):
                at = int(live[i])
                p = periodic(feds[at, :ran].tolist(), helds[at, :ran].tolist())
                if p:
                    period[at] = p
                    finish[at] = hardest(ran, tops[at, ran - p : ran].tolist())
        found = period[live] > 0
        ends = (found & (finish[live] == ran)) | (~found & (ran == (cycles or most_cycles)))
        for i in np.flatnonzero(ends):
            at = int(live[i])
            results[at] = _result(
                problems[at], out_T[at], out_x[at], out_d[at], feds[at, :ran], ran, cycles, int(period[at])
            )
        keep = ~ends
        live = live[keep]
        s, state, prev, x, v = s[keep], state[keep], prev[keep], x[keep], v[keep]
        if not len(live):
            break
    done = [r for r in results if r is not None]
    assert len(done) == V
    return done


def _result(
    pb: Problem,
    T: np.ndarray,
    x: np.ndarray,
    d: np.ndarray,
    feds: np.ndarray,
    ran: int,
    cycles: int | None,
    period: int,
) -> NeedleTension:
    """The twin's result from one problem's last stitch's traces ``T`` (N, Z), ``x`` and ``d``
    (N,), every stitch's draw ``feds`` (ran,) and the state's ``period`` (0: none)."""
    if cycles is not None:
        return pb.result(T.T.copy(), x.copy(), d.copy(), ran, 1, float(feds[-1]))
    per_stitch = float(sum(feds[-period:].tolist()) / period) if period else float(feds[-1])
    return pb.result(T.T.copy(), x.copy(), d.copy(), ran, period, per_stitch)
