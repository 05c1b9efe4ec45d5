"""The needle thread's loop round the bobbin case: the geometry of its legs.

A leg runs from a point of the head's plane (the needle's eye, or the underside of the needle's
hole) to the hook's blade point, which carries the loop's middle. The bobbin case is a cylinder
on the hook's axis (normal to the head's plane), its diameter and width the ``[balance]``
table's; the needle and the blade point turn in its middle plane [choice: docs/head.md, The
thread balance]. The blade spreads the loop over the case: one leg passes its front face, the
other its back face, each the shortest thread outside the case on its own side. By the case's
symmetry both sides measure alike, so one function serves both legs.

Lengths are m, points (N, 2) m in the head's plane; every function works on N samples at once.
"""

from __future__ import annotations

import numpy as np

from ..model.mechanism import Mechanism
from ..model.timing import hook_crank

NEWTON_STEPS = 40
"""Most Newton steps of the path over a face; the shipped head's samples meet their tolerance in
about ten."""


def wrapped(
    a: np.ndarray, b: np.ndarray, centre: np.ndarray, radius: float, turned: np.ndarray, sense: float
) -> np.ndarray:
    """Length of a thread from points ``a`` to points ``b`` (each (N, 2), m) that the hook has
    drawn around a circle (a chain stitch's looper: ``centre`` (2,), ``radius``) in its sense of
    rotation ``sense`` (+1 counter-clockwise): tangent from ``a``, the arc, tangent to ``b``,
    or the straight segment where the arc would be negative (the circle is not yet in the way).
    ``turned`` (N,) rad is how far round from ``a``'s side ``b`` has been carried (unwrapped),
    which tells the arc's turns apart."""
    ra, rb = a - centre, b - centre
    da, db = np.hypot(*ra.T), np.hypot(*rb.T)
    ta = np.sqrt(np.maximum(da**2 - radius**2, 0.0))
    tb = np.sqrt(np.maximum(db**2 - radius**2, 0.0))
    # Tangent points: leaving a forwards, arriving at b from behind (angles from the centre).
    ga = np.arctan2(ra[:, 1], ra[:, 0]) + sense * np.arccos(np.clip(radius / da, -1.0, 1.0))
    gb = np.arctan2(rb[:, 1], rb[:, 0]) - sense * np.arccos(np.clip(radius / db, -1.0, 1.0))
    # The arc from a's tangent point to b's, the turns counted from how far b was carried.
    start = np.arctan2(ra[:, 1], ra[:, 0])
    arc = sense * (gb - ga)
    arc = arc + 2.0 * np.pi * np.round((turned - sense * (np.arctan2(rb[:, 1], rb[:, 0]) - start)) / (2.0 * np.pi))
    straight = np.hypot(*(b - a).T)
    out: np.ndarray = np.where(arc > 0.0, ta + radius * arc + tb, straight)
    return out


def crossing(a: np.ndarray, b: np.ndarray, centre: np.ndarray, radius: float) -> tuple[np.ndarray, np.ndarray]:
    """Where the segments ``a`` -> ``b`` ((N, 2) each) cross a circle: ``(hits, (N, 2) s)``,
    ``hits`` (N,) bool where the segment passes inside it, ``s`` the fractions along the segment
    of its entry and exit (NaN where it misses)."""
    d = b - a
    f = a - centre
    A = np.einsum("ij,ij->i", d, d)
    B = 2.0 * np.einsum("ij,ij->i", f, d)
    C = np.einsum("ij,ij->i", f, f) - radius**2
    disc = B * B - 4.0 * A * C
    with np.errstate(invalid="ignore", divide="ignore"):
        root = np.sqrt(disc)
        s = np.column_stack([(-B - root) / (2.0 * A), (-B + root) / (2.0 * A)])
    hits = (disc > 0.0) & (s[:, 1] > 0.0) & (s[:, 0] < 1.0)
    return hits, np.where(hits[:, None], s, np.nan)


def _rim_arc(
    a: np.ndarray, b: np.ndarray, centre: np.ndarray, radius: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(N,) rad: the arc a thread from ``a`` to ``b`` wraps round a circle the shorter way,
    between its tangent points (not positive where the circle is not in its way); with the
    ends' distances from the centre."""
    ra, rb = a - centre, b - centre
    da, db = np.hypot(*ra.T), np.hypot(*rb.T)
    with np.errstate(invalid="ignore"):
        between = np.arccos(np.clip(np.einsum("ij,ij->i", ra, rb) / (da * db), -1.0, 1.0))
        arc = between - np.arccos(np.clip(radius / da, -1.0, 1.0)) - np.arccos(np.clip(radius / db, -1.0, 1.0))
    return arc, da, db


def around_rim(a: np.ndarray, b: np.ndarray, centre: np.ndarray, radius: float) -> np.ndarray:
    """(N,) m: the shortest thread from ``a`` to ``b`` in the plane round a circle (the case's
    rim) the shorter way: tangent, arc, tangent; the straight segment where the circle is not
    in the way. A point inside the circle has no such path: +inf."""
    arc, da, db = _rim_arc(a, b, centre, radius)
    with np.errstate(invalid="ignore"):
        wrap = np.sqrt(np.maximum(da**2 - radius**2, 0.0)) + np.sqrt(np.maximum(db**2 - radius**2, 0.0)) + radius * arc
    straight = np.hypot(*(b - a).T)
    out: np.ndarray = np.where((da < radius) | (db < radius), np.inf, np.where(arc > 0.0, wrap, straight))
    return out


def _end(a: np.ndarray, centre: np.ndarray, radius: float) -> tuple[np.ndarray, ...]:
    """What :func:`over_face` needs of one free end ``a`` (N, 2): its direction from the centre
    (rad), the half-width of the rim's arc it sees (rad), its distance and its tangent's length."""
    ra = a - centre
    da = np.hypot(*ra.T)
    seen = np.arccos(np.clip(radius / da, -1.0, 1.0))
    return np.arctan2(ra[:, 1], ra[:, 0]), seen, da, np.sqrt(np.maximum(da**2 - radius**2, 0.0))


def _to_edge(
    beta: np.ndarray, end: tuple[np.ndarray, ...], radius: float, half_width: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The thread from a free end to the face's edge at angle ``beta`` (rad): straight where the
    end sees that point of the rim; past the arc it sees, tangent to the case's side and up it
    on a helix, which the side unrolled into a plane makes one straight line. Returns the
    length and its first and second derivatives in ``beta``."""
    toward, seen, da, ta = end
    delta = np.angle(np.exp(1j * (beta - toward)))  # from the end's direction, in (-pi, pi]
    w2 = half_width**2
    direct = np.abs(delta) <= seen
    f_d = np.sqrt(np.maximum(da**2 + radius**2 - 2.0 * da * radius * np.cos(delta), 0.0) + w2)
    u = ta + radius * (np.abs(delta) - seen)
    f_h = np.sqrt(u**2 + w2)
    f = np.where(direct, f_d, f_h)
    g = np.where(direct, da * radius * np.sin(delta) / f_d, np.sign(delta) * radius * u / f_h)
    h = np.where(
        direct,
        da * radius * np.cos(delta) / f_d - (da * radius * np.sin(delta)) ** 2 / f_d**3,
        radius**2 * w2 / f_h**3,
    )
    return f, g, h


def over_face(
    a: np.ndarray, b: np.ndarray, centre: np.ndarray, radius: float, half_width: float
) -> tuple[np.ndarray, np.ndarray]:
    """The shortest thread from ``a`` to ``b`` (both in the middle plane) over one face of the
    case, a cylinder of ``radius`` whose faces lie ``half_width`` either side of that plane: to a
    point of the face's edge, straight across the face, and from a second point of the edge to
    ``b``. Each free end reaches the edge straight where it sees that point of the rim, and
    otherwise runs tangent to the case's side and climbs it on a helix (:func:`_to_edge`).

    Returns ``(length (N,) m, (N, 2) edge angles rad)``. The two angles minimise the length by
    Newton's method on its exact gradient and Hessian (a gradient step where the Hessian is not
    positive; either halved until it shortens the path), from two starts, the shorter result
    kept: where the segment a -> b crosses the rim (where it misses, where it passes nearest),
    and both angles at their mean. Where the shortest path touches the edge at a single point
    (both angles one) the length has a kink; a step that would cross it stops on it, and the
    search then moves both angles as one until parting them shortens the path. Without that a
    search near the kink ended up to 11 µm long, and one from the crossing alone in a longer
    local minimum (up to 0.33 mm, against a grid search, on a sized eyelet take-up)."""
    d = b - a
    hits, s = crossing(a, b, centre, radius)
    near = np.clip(np.einsum("ij,ij->i", centre - a, d) / np.einsum("ij,ij->i", d, d), 0.0, 1.0)
    s = np.where(hits[:, None], s, near[:, None])
    p = a[:, None, :] + s[:, :, None] * d[:, None, :]
    crossed = np.arctan2(p[..., 1] - centre[1], p[..., 0] - centre[0])
    ea, eb = _end(a, centre, radius), _end(b, centre, radius)
    # Two starts a sample: there, and on the kink (below) between them, the shorter found kept.
    n = len(a)
    src = np.concatenate([np.arange(n), np.arange(n)])
    mid = np.angle(np.exp(1j * crossed).sum(axis=1))
    beta = np.concatenate([crossed, np.column_stack([mid, mid])])

    def terms(bt: np.ndarray, k: np.ndarray) -> tuple[np.ndarray, ...]:
        """The length and its derivatives at the edge angles ``bt`` of the samples ``k``."""
        ek = tuple(x[src[k]] for x in ea), tuple(x[src[k]] for x in eb)
        fa, ga, ha = _to_edge(bt[:, 0], ek[0], radius, half_width)
        fb, gb, hb = _to_edge(bt[:, 1], ek[1], radius, half_width)
        half = 0.5 * (bt[:, 0] - bt[:, 1])
        sn = np.sign(np.sin(half))
        chord = 2.0 * radius * np.abs(np.sin(half))
        dc = radius * np.cos(half) * sn  # in beta_1; minus this in beta_2
        hc = -0.5 * radius * np.abs(np.sin(half))  # both second derivatives; minus it mixed
        return fa + chord + fb, ga + dc, gb - dc, ha + hc, hb + hc, -hc

    # Where the shortest path reaches the edge at one point (both angles one: it climbs to the
    # edge and back without crossing the face) the chord's |sin| has a kink, which Newton's
    # steps in both angles only approach by halvings: a sample whose step would cross it lands
    # on it and then moves along it (both angles one), until moving them apart shortens the
    # path (the chord's slope, r each way, is less than the ends' pull apart).
    on = np.arange(2 * n) >= n

    def moved(bt: np.ndarray, st: np.ndarray, kink: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The angles ``bt`` moved by ``st``; a step that crosses the kink stops on it."""
        new = bt + st
        h0, h1 = 0.5 * (bt[:, 0] - bt[:, 1]), 0.5 * (new[:, 0] - new[:, 1])
        cross = ~kink & (np.sin(h0) * np.sin(h1) < 0.0)
        at = np.pi * np.floor(np.maximum(h0, h1) / np.pi)
        with np.errstate(invalid="ignore", divide="ignore"):
            t = np.where(cross, (at - h0) / (h1 - h0), 1.0)
        new = np.where(cross[:, None], bt + t[:, None] * st, new)
        new[:, 1] = np.where(cross | kink, new[:, 0], new[:, 1])
        return new, cross

    active = np.arange(2 * n)
    for _ in range(NEWTON_STEPS):
        bt = beta[active]
        f0, g1, g2, h11, h22, h12 = terms(bt, active)
        kink = on[active]
        apart = g1 - g2  # the ends' pull to move the points apart; the chord resists with 2 r
        leave = kink & (np.abs(apart) > 2.0 * radius)
        kink &= ~leave
        on[active[leave]] = False
        det = h11 * h22 - h12 * h12
        convex = (h11 > 0.0) & (det > 0.0)
        along = h11 + h22
        with np.errstate(invalid="ignore", divide="ignore"):
            n1 = np.where(convex, -(h22 * g1 - h12 * g2) / det, -g1 / radius**2)
            n2 = np.where(convex, -(h11 * g2 - h12 * g1) / det, -g2 / radius**2)
            # Along the kink: Newton in the one angle both share.
            m = np.where(along > 0.0, -(g1 + g2) / along, -(g1 + g2) / (2.0 * radius**2))
        n1, n2 = np.where(kink, m, n1), np.where(kink, m, n2)
        # Off the kink: a gradient step on the side it leaves to (the chord's slope r there).
        side = np.sign(apart) * radius
        n1 = np.where(leave, -(g1 - side) / radius**2, n1)
        n2 = np.where(leave, -(g2 + side) / radius**2, n2)
        # Damped: no step longer than a quarter turn.
        scale = np.minimum(1.0, (np.pi / 4.0) / np.maximum(np.hypot(n1, n2), 1e-300))
        step = np.nan_to_num(np.column_stack([n1, n2]) * scale[:, None])
        # Backtracking: a step that lengthens the path (beyond rounding) is halved until it does not.
        for _ in range(40):
            new, cross = moved(bt, step, kink)
            longer = terms(new, active)[0] > f0 * (1.0 + 1e-14)
            if not longer.any():
                break
            step[longer] *= 0.5
        new, cross = moved(bt, step, kink)
        on[active[cross]] = True
        beta[active] = new
        # A sample is done once its step is 1e-10 rad: at the minimum the length then errs by the
        # step's square times the radius, far below what double precision resolves in it.
        active = active[np.abs(new - bt).max(axis=1) >= 1e-10]
        if not len(active):
            break
    found = terms(beta, np.arange(2 * n))[0]
    first = found[:n] <= found[n:]
    return np.where(first, found[:n], found[n:]), np.where(first[:, None], beta[:n], beta[n:])


def case_leg(
    a: np.ndarray, b: np.ndarray, centre: np.ndarray, radius: float, half_width: float, *, faces: bool = True
) -> np.ndarray:
    """(N,) m: one leg of the loop, from ``a`` to the blade point ``b`` ((N, 2) each, in the
    case's middle plane), the shortest thread outside the bobbin case on the leg's side:
    straight while the case is not in its way; then the shorter of the thread round the case's
    rim in the middle plane (:func:`around_rim`) and the thread over the case's face
    (:func:`over_face`, which climbs the case's side where that is shorter).

    ``faces=False`` is the planar loop: the thread round the rim in the hook's plane only, as a
    tendon wrapping a cylinder makes it (MuJoCo's, :func:`mjlink.sim.thread.run_loop`)."""
    return _leg(a, b, centre, radius, half_width, faces, towards=False)[0]


def leg_and_arrival(
    a: np.ndarray, b: np.ndarray, centre: np.ndarray, radius: float, half_width: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`case_leg` from ``a`` to the blade point ``b`` over the case's front face, the
    unit direction (N, 3) it reaches ``b`` in (x, y in the head's plane, z normal to it towards
    the front face; a leg over the back face reaches it mirrored in z), and (N,) rad how far it
    turns on the case on its way (:func:`case_turn`). The direction: along the straight
    thread; round the rim, along its tangent from the case to ``b`` on the side the thread wraps
    (the shorter way round); over the face, from the face's edge point down to ``b``, or, where
    ``b`` does not see that point of the rim, along the tangent the thread leaves the case's
    side by, falling as the helix unrolled into a plane does."""
    length, into, turn = _leg(a, b, centre, radius, half_width, True, towards=True)
    assert into is not None and turn is not None
    return length, into, turn


def _leg(
    a: np.ndarray, b: np.ndarray, centre: np.ndarray, radius: float, half_width: float, faces: bool, *, towards: bool
) -> tuple[np.ndarray, np.ndarray | None, np.ndarray | None]:
    """:func:`case_leg`'s length, and with ``towards`` :func:`leg_and_arrival`'s direction and
    turn on the case."""
    hits, _ = crossing(a, b, centre, radius)
    out: np.ndarray = np.hypot(*(b - a).T)
    into = np.column_stack([b - a, np.zeros(len(a))]) if towards else None
    turn = np.zeros(len(a)) if towards else None
    if hits.any():
        k = np.nonzero(hits)[0]
        rim = around_rim(a[k], b[k], centre, radius)
        if not faces:
            out[k] = rim
            return out, into, turn
        # Over the face the thread climbs the half-width and comes back down: never shorter than
        # that climb unrolled beside the straight segment. Where the rim's path is no longer,
        # the face's need not be sought.
        may = rim > np.hypot(out[k], 2.0 * half_width)
        face = np.full(len(k), np.inf)
        angles = np.zeros((len(k), 2))  # the face's edge points on a's and on b's side
        if may.any():
            face[may], angles[may] = over_face(a[k[may]], b[k[may]], centre, radius, half_width)
        out[k] = np.minimum(rim, face)
        if into is not None and turn is not None:
            over = face < rim
            into[k] = _arriving(a[k], b[k], centre, radius, half_width, over, angles[:, 1])
            turn[k] = case_turn(a[k], b[k], centre, radius, half_width, np.where(over[:, None], angles, np.nan))
    if into is not None:
        into /= np.linalg.norm(into, axis=1, keepdims=True)
    return out, into, turn


def _angle(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """(N,) rad between the directions ``u`` and ``v`` (N, 3), exact near 0 and pi."""
    out: np.ndarray = np.arctan2(np.linalg.norm(np.cross(u, v), axis=1), np.einsum("ij,ij->i", u, v))
    return out


def _at_edge(
    a: np.ndarray, beta: np.ndarray, centre: np.ndarray, radius: float, half_width: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A free end ``a`` (N, 2) and its thread up to the front face's edge at ``beta`` (N,) rad
    (:func:`_to_edge`'s path): the edge point (N, 3), the thread's direction arriving there
    (N, 3, not unit) and how far it turned on the case's side first (N,) rad: nothing where it
    runs straight to the edge, ``cos(gamma) * phi`` up a helix that winds ``phi`` round the side
    at ``gamma`` to the face (a helix on a cylinder turns its tangent by ``cos(gamma)^2 /
    radius`` per length, over ``radius * phi / cos(gamma)``)."""
    toward, seen, _, ta = _end(a, centre, radius)
    delta = np.angle(np.exp(1j * (beta - toward)))
    edge = np.column_stack(
        [centre[0] + radius * np.cos(beta), centre[1] + radius * np.sin(beta), np.full(len(a), half_width)]
    )
    direct = np.abs(delta) <= seen
    straight = edge - np.column_stack([a, np.zeros(len(a))])
    phi = np.abs(delta) - seen
    u = ta + radius * phi  # the helix and its tangent unrolled, beside the climb
    lean = np.hypot(u, half_width)
    round_ = np.sign(delta)[:, None] * np.column_stack([-np.sin(beta), np.cos(beta), np.zeros(len(a))])
    helix = (u / lean)[:, None] * round_ + np.column_stack([np.zeros((len(a), 2)), half_width / lean])
    wound = np.where(direct, 0.0, phi * u / lean)
    return edge, np.where(direct[:, None], straight, helix), wound


def case_turn(
    a: np.ndarray, b: np.ndarray, centre: np.ndarray, radius: float, half_width: float, edges: np.ndarray
) -> np.ndarray:
    """(N,) rad: how far a leg of the loop from ``a`` to the blade point ``b`` ((N, 2) each,
    in the case's middle plane) turns on the bobbin case, the capstan angle its thread slides
    over the case by: the arc it wraps round the rim in the middle plane where ``edges`` is
    NaN; over the front face where ``edges`` (N, 2) rad gives the face's edge points on a's and
    on b's side (:func:`over_face`), its turns over the edge there (between its way up to the
    edge and across the face, and across the face and down from it) and up and down the
    case's side where it winds round it on a helix (:func:`_at_edge`); nothing where the case
    is not in its way. The turn at ``b`` itself is the blade's (:func:`blade_turn`)."""
    arc = _rim_arc(a, b, centre, radius)[0]
    hits, _ = crossing(a, b, centre, radius)
    rim = np.where(hits, np.maximum(arc, 0.0), 0.0)
    over = np.isfinite(edges).all(axis=1)
    if not over.any():
        return rim
    e = np.where(over[:, None], edges, 0.0)
    up_at, up, wound_a = _at_edge(a, e[:, 0], centre, radius, half_width)
    down_at, down, wound_b = _at_edge(b, e[:, 1], centre, radius, half_width)
    across = down_at - up_at
    # Where both edge points are one the thread climbs to the edge and back without crossing.
    one = np.linalg.norm(across, axis=1) <= 1e-12 * radius
    at_edges = np.where(one, _angle(up, -down), _angle(up, across) + _angle(across, -down))
    out: np.ndarray = np.where(over, at_edges + wound_a + wound_b, rim)
    return out


def _arriving(
    a: np.ndarray,
    b: np.ndarray,
    centre: np.ndarray,
    radius: float,
    half_width: float,
    over: np.ndarray,
    beta: np.ndarray,
) -> np.ndarray:
    """(N, 3), not unit: the last piece of a leg the case is in the way of, towards ``b``, over
    the front face where ``over`` (its edge point on b's side at ``beta``), else round the rim."""
    toward, seen, _, tb = _end(b, centre, radius)
    # Round the rim: the tangent point before b in the sense the thread wraps.
    ra, rb = a - centre, b - centre
    sense = np.sign(ra[:, 0] * rb[:, 1] - ra[:, 1] * rb[:, 0])
    phi = toward - sense * seen
    t = centre + radius * np.column_stack([np.cos(phi), np.sin(phi)])
    rim = np.column_stack([b - t, np.zeros(len(b))])
    # Over the face: from the edge point, or off the side's tangent towards it.
    delta = np.angle(np.exp(1j * (beta - toward)))
    e = centre + radius * np.column_stack([np.cos(beta), np.sin(beta)])
    direct = np.column_stack([b - e, np.full(len(b), -half_width)])
    psi = toward + np.sign(delta) * seen
    th = centre + radius * np.column_stack([np.cos(psi), np.sin(psi)])
    unrolled = tb + radius * (np.abs(delta) - seen)
    with np.errstate(invalid="ignore", divide="ignore"):
        helix = np.column_stack([b - th, -half_width * tb / unrolled])
    on_face = np.where((np.abs(delta) <= seen)[:, None], direct, helix)
    out: np.ndarray = np.where(over[:, None], on_face, rim)
    return out


def blade_turn(into_eye: np.ndarray, into_fabric: np.ndarray) -> np.ndarray:
    """(N,) rad: how far the thread turns at the blade point between the loop's two legs, given
    the directions each reaches it in over the front face (:func:`leg_and_arrival`): the eye's
    leg passes the front face, the fabric's the back one (its direction mirrored in z). pi
    where both reach it from one direction (a hairpin), less where they meet it at an angle."""
    # Exact at a hairpin (:func:`_angle`), where arccos of the cosine is not.
    return _angle(into_eye, -into_fabric * np.array([1.0, 1.0, -1.0]))


def held_loop(mech: Mechanism, positions: dict[str, np.ndarray]) -> np.ndarray:
    """(N,) m: the thread below the eye of MuJoCo's thread with its loop held
    (:func:`mjlink.sim.thread.run_thread` with ``loop=True``): straight down the needle's line
    from the eye to the underside of the needle's hole, round the bobbin case's rim (the
    planar loop) to the hook's blade point and back to the hole's underside, where it is held.
    Not a stitch (the hook holds the loop all stitch long) but the same physics in both models,
    which checks MuJoCo's tension through a tendon that wraps the case. ``positions`` the
    head's points over the stitch ((N, 3) m each, :class:`.timing.HeadTiming`'s)."""
    tm, bal = mech.timing, mech.balance
    assert tm is not None and bal is not None
    eye, blade = positions[tm.roles["needle_eye"]], positions[tm.roles["hook_point"]][:, :2]
    hole = np.column_stack([positions[tm.roles["needle_point"]][:, 0], np.full(len(eye), tm.plate)])
    centre = positions[hook_crank(mech).pivot][0, :2]
    leg = case_leg(hole, blade, centre, bal.bobbin_case / 2.0, bal.bobbin_case_width / 2.0, faces=False)
    out: np.ndarray = np.abs(eye[:, 1] - tm.plate) + 2.0 * leg
    return out


__all__ = [
    "NEWTON_STEPS",
    "around_rim",
    "blade_turn",
    "case_leg",
    "case_turn",
    "crossing",
    "held_loop",
    "leg_and_arrival",
    "over_face",
    "wrapped",
]
