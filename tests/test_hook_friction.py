"""The loop's turn over the hook's blade (``[tension] hook_wrap``): Euler-Eytelwein friction round
the hook, checked in closed form.

While the hook carries the loop, the thread below the eye is two stretches parted at the blade
point: the eye's leg, and the rest (the loop's leg to the needle's hole, up through it and along
the top to the last stitch's end). The thread slides over the blade only where the tension
ratio across it reaches exp(mu * hook_wrap); elsewhere the blade holds nothing and the two are
one thread. Expected values come from the capstan law and the head's geometry, not from the
model's code.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
import re

import numpy as np
import pytest
from threadchecks import tension_with

from mjlink.analysis.tension import TensionError, needle_tension, prepare
from mjlink.analysis.timing import head_timing
from mjlink.errors import MjlinkError
from mjlink.model import mechanism
from mjlink.model.catalogue import shipped
from mjlink.model.tension import DEFAULTS
from mjlink.model.timing import hook_crank

HEAD = shipped("mechanisms") / "lockstitch_head.toml"
PAPER = shipped("mechanisms") / "examples" / "lockstitch_head_paper_takeup.toml"
RATIO = 1e-6  # the contacts' states hold their bound to 1e-9 of the ratio; the tensions are rounded sums


@pytest.fixture(scope="module")
def head():
    mech = mechanism.load(HEAD)
    return mech, head_timing(mech)


def _carried(mech, timing, t):
    """(N,) bool on the tension's steps: the hook carries the loop (from the balance)."""
    every = len(timing.theta) // len(t.theta)
    return np.isfinite(timing.balance.past[::every])


def test_the_hooks_blade_holds_the_loop_within_its_capstan_bound_and_slides_at_it(head):
    """Over the whole stitch, the stretch past the blade pulls at most exp(mu beta) times the
    eye's leg and at least its inverse while the hook carries the loop, beta the blade's turn
    and the eye's leg's on the bobbin case, and exactly as hard elsewhere (one thread). Where
    the loop grows the blade draws its thread over: the ratio sits on the bound, at the
    stitch's peak too (the eye's leg just on the case there); and where the eye's leg
    wraps the case the ratio goes beyond the hairpin's bound, up to the two together."""
    mech, timing = head
    t = needle_tension(mech, timing)
    assert t.zones[-2:] == ("below NE", "past the hook's blade")
    eye, past = t.tension[-2], t.tension[-1]
    cfg = mech.tension or DEFAULTS
    bound = math.exp(cfg.friction * cfg.hook_wrap)
    assert bound == pytest.approx(math.exp(0.15 * math.pi), rel=1e-12)  # the file's friction, a hairpin
    carried = _carried(mech, timing, t)
    every = len(timing.theta) // len(t.theta)
    turn = np.minimum(np.radians(np.nan_to_num(timing.balance.blade_turn[::every])), cfg.hook_wrap)
    turn = turn + np.radians(np.nan_to_num(timing.balance.case_turn[::every]))
    taut = carried & (eye > 1e-6) & (past > 1e-6)
    ratio, most = past[taut] / eye[taut], np.exp(cfg.friction * turn[taut])
    assert (ratio <= most * (1 + RATIO)).all() and (ratio >= (1 - RATIO) / most).all()
    sliding = np.abs(ratio / bound - 1) <= RATIO
    assert sliding.sum() >= 20  # steps of a quarter degree with the thread drawn over the blade's hairpin
    on_case = (ratio > bound * 1.01) & (np.abs(ratio / most - 1) <= RATIO)
    assert on_case.sum() >= 20  # steps with the thread drawn over the blade and the case beside it
    np.testing.assert_allclose(past[~carried], eye[~carried], rtol=1e-9, atol=1e-12)
    k = int(np.argmax(past))
    # The peak, 254.25 deg, is half a degree after the eye's leg first touches the case (253.75 deg):
    # its ratio is the blade's and the case's bound together, just above the hairpin's.
    assert (
        t.peak == past[k]
        and carried[k]
        and past[k] / eye[k] == pytest.approx(math.exp(cfg.friction * turn[k]), rel=RATIO)
    )
    assert 1.0 < past[k] / eye[k] / bound < 1.01


def test_without_friction_the_blade_parts_nothing(head):
    """With no friction anywhere (one tension through the path) the two stretches below the eye
    are the one stretch of a loop free on the blade, step for step, to rounding; the thread
    per stitch and the spring's travel are the same too."""
    mech, timing = head
    free = tension_with(mech, timing, friction=0.0, hook_wrap=0.0)
    parted = tension_with(mech, timing, friction=0.0)
    assert len(parted.zones) == len(free.zones) + 1
    scale = free.peak
    np.testing.assert_allclose(parted.tension[:-1], free.tension, rtol=0, atol=1e-9 * scale)
    np.testing.assert_allclose(parted.tension[-1], free.tension[-1], rtol=0, atol=1e-9 * scale)
    assert parted.per_stitch == pytest.approx(free.per_stitch, abs=1e-12)  # m
    np.testing.assert_allclose(parted.spring, free.spring, rtol=0, atol=1e-12)  # m
    assert parted.cycles == free.cycles


def test_the_legs_turn_at_the_blade_point_is_a_hairpin_in_the_hooks_plane_and_less_over_the_faces(head):
    """Where the needle is out of the fabric both legs come from the needle's hole: in the hook's
    plane they reach the blade point along one line (a hairpin, pi), and over the case's two
    faces as mirror images, so that the thread turns by pi less twice the angle the face's
    half-width makes with each leg's last piece, from the face's edge to the blade point. The
    edge point is found here by minimising the thread over the face on its own (scipy), from
    the head's positions: at six o'clock the turn is some 62 deg (docs/head.md)."""
    from scipy.optimize import minimize

    mech, timing = head
    tm, bal, b = mech.timing, mech.balance, timing.balance
    turn = b.blade_turn
    between = np.isfinite(turn) & (timing.theta > 240.0) & (timing.theta < 280.0)
    assert np.abs(turn[between] - 180.0).max() < 1e-9  # deg: the legs on one line
    k = int(np.argmin(np.abs(timing.theta - 296.0)))
    r, w = bal.bobbin_case / 2.0, bal.bobbin_case_width / 2.0
    centre = timing.positions[hook_crank(mech).pivot][0, :2]
    hole = np.array([timing.positions[tm.roles["needle_point"]][k, 0] + b.hole[k] * 1e-3, tm.plate])
    blade = timing.positions[tm.roles["hook_point"]][k, :2]

    def edge(beta):
        return centre + r * np.array([math.cos(beta), math.sin(beta)])

    def sees(p, beta):  # the point p sees the rim's point at beta past the case's side
        v = p - centre
        return abs(math.remainder(beta - math.atan2(v[1], v[0]), math.tau)) <= math.acos(r / math.hypot(*v))

    def over(x):  # the hole to one edge point, across the face, the other to the blade point
        if not (sees(hole, x[0]) and sees(blade, x[1])):
            return math.inf
        e1, e2 = edge(x[0]), edge(x[1])
        chord = float(np.hypot(*(e2 - e1)))
        return math.hypot(float(np.hypot(*(e1 - hole))), w) + chord + math.hypot(float(np.hypot(*(blade - e2))), w)

    grid = np.linspace(-math.pi, math.pi, 361)
    start = min(((p, q) for p in grid for q in grid), key=over)
    best = minimize(over, start, method="Nelder-Mead", options={"xatol": 1e-12, "fatol": 1e-15, "maxiter": 20000})
    h = float(np.hypot(*(blade - edge(best.x[1]))))
    expected = math.degrees(math.pi - 2.0 * math.atan(w / h))
    assert turn[k] == pytest.approx(expected, abs=1e-6)  # deg: the minimiser's tolerance
    assert 60.0 < turn[k] < 65.0


def test_the_eyes_leg_at_the_pick_up_is_the_straight_thread_from_the_eye_to_the_blade_point(head):
    """At the first angle the hook carries the loop, the eye (under the plate) and the blade
    point are a few millimetres apart with nothing between them: the eye's leg is their
    distance in the head's plane, and the rest is the thread below the eye less it."""
    mech, timing = head
    b, tm = timing.balance, mech.timing
    k = int(np.nonzero(np.isfinite(b.past) & ~np.isfinite(np.roll(b.past, 1)))[0][0])
    eye = timing.positions[tm.roles["needle_eye"]][k, :2]
    blade = timing.positions[tm.roles["hook_point"]][k, :2]
    assert eye[1] < tm.plate
    straight = float(np.hypot(*(blade - eye))) * 1e3  # mm
    assert 0.5 < straight < 5.0
    assert b.below[k] - b.past[k] == pytest.approx(straight, abs=1e-9)  # mm


def test_the_blades_turn_raises_the_peak_where_the_loop_grows_and_leaves_the_draw_alone(head):
    """On the shipped head the loop past the blade, drawn over it, pulls exp(mu beta) times the
    eye's leg at the peak; the eye's leg pulls a little less than with the loop free on the
    blade (the stretch past it, pulled harder, stretches more and takes less thread from above),
    so the peak rises by less than the capstan factor. The thread drawn per stitch, the slack
    below the eye and the check spring's travel are as with the loop free on the blade."""
    mech, timing = head
    free = tension_with(mech, timing, hook_wrap=0.0)
    held = needle_tension(mech, timing)
    cfg = mech.tension or DEFAULTS
    bound = math.exp(cfg.friction * cfg.hook_wrap)
    assert free.peak < held.peak < bound * free.peak
    assert held.tension[-2].max() <= free.tension[-1].max() * (1 + 1e-12)
    assert held.per_stitch == pytest.approx(free.per_stitch, abs=1e-12)  # m
    assert held.slack.mean() == free.slack.mean()
    assert held.spring.max() == pytest.approx(free.spring.max(), abs=1e-12)  # m


def test_the_shipped_heads_peak_over_the_turns_docs_head_md_gives(head):
    """The blade's turn is capped by a choice: docs/head.md gives the shipped head's peak at 0,
    90 and 180 deg (1.55, 1.55 and 1.75 N), the thread per stitch, the slack and the spring's
    travel the same at each."""
    mech, timing = head
    runs = [tension_with(mech, timing, hook_wrap=math.radians(w)) for w in (0.0, 90.0, 180.0)]
    assert [round(t.peak, 2) for t in runs] == [1.55, 1.55, 1.75]  # N
    for t in runs[1:]:
        assert t.per_stitch == pytest.approx(runs[0].per_stitch, abs=1e-12)  # m
        assert t.slack.mean() == runs[0].slack.mean()
        assert t.spring.max() == pytest.approx(runs[0].spring.max(), abs=1e-12)  # m


def test_the_hook_wrap_is_read_in_degrees_and_a_study_may_vary_it(head):
    mech, _ = head
    text = re.sub(r"(?m)^hook_wrap = 180\.0", "hook_wrap = 90.0", HEAD.read_text())
    assert "hook_wrap = 90.0" in text
    assert mechanism.parse(text, "head.toml").tension.hook_wrap == pytest.approx(math.pi / 2, rel=1e-12)
    from mjlink import study

    assert study.override(mech, {"tension.hook_wrap": 45.0}).tension.hook_wrap == pytest.approx(math.pi / 4)


def test_a_blade_point_on_the_eye_is_refused_in_one_line(head):
    """Where the hook's blade point would meet the needle's eye the loop's turn over the blade
    has no thread between them: the tension says so, naming the angle, and how to go on."""
    mech, timing = head
    b = timing.balance
    past = np.where(np.isfinite(b.past), b.below, np.nan)  # the eye's leg of no length
    broken = dataclasses.replace(timing, balance=dataclasses.replace(b, past=past))
    with pytest.raises(TensionError, match=r"meets the needle's eye at [0-9.]+ deg.*hook_wrap = 0") as e:
        prepare(mech, broken)
    assert "\n" not in str(e.value) and isinstance(e.value, MjlinkError | ValueError)
    assert len(prepare(mech, broken, settings=dataclasses.replace(DEFAULTS, hook_wrap=0.0)).zones) == len(mech.thread)


# ------------------------------------------------------------------ the stitch drawn up
def test_the_stitch_is_set_with_the_largest_pull_below_the_eye_from_the_release_to_the_setting(head):
    """The take-up's pull on the stitch as it sets it is the largest tension of the stretch from
    the eye down over the steps from the loop's release to the stitch's setting (the angles
    taken round the stitch here, from the head's events), against the bobbin thread's tension
    read from the file ('25 gf', Duerkopp Adler's figure): on the shipped head 0.287 N, 1.17
    times the bobbin thread's 0.245 N (docs/head.md)."""
    mech, timing = head
    t = needle_tension(mech, timing)
    release = timing.events["loop released"]
    after = (t.theta - release) % 360.0
    setting = (after > 0.0) & (after < (t.set_at - release) % 360.0)
    below = t.tension[t.zones.index("below NE")]
    assert t.set_pull == pytest.approx(below[setting].max(), rel=1e-12)
    assert t.bobbin == pytest.approx(25.0 * 9.80665e-3, rel=1e-12)  # N: the file's '25 gf'
    assert (round(t.set_pull, 3), round(t.drawn_up, 2)) == (0.287, 1.17)
    d = t.as_dict()
    assert (d["set_pull_N"], d["bobbin_N"]) == (pytest.approx(t.set_pull, abs=1e-6), pytest.approx(t.bobbin, abs=1e-6))


def test_the_paper_take_up_does_not_draw_its_stitch_up_and_the_terminal_says_so():
    """The head with the paper's take-up pulls its stitch with 0.170 N as it sets it, 0.69 times
    the bobbin thread's tension (docs/head.md): the terminal's line says it is too little."""
    from mjlink.cli.text import tension_line

    mech = mechanism.load(PAPER)
    t = needle_tension(mech, head_timing(mech))
    assert (round(t.set_pull, 3), round(t.drawn_up, 2)) == (0.170, 0.69)
    assert tension_line(t).splitlines()[-1].endswith("too little to draw the bobbin thread and the interlacing up")
    looser = needle_tension(mech, head_timing(mech), settings=dataclasses.replace(mech.tension, bobbin_tension=0.1))
    assert looser.drawn_up > 1.0 and not tension_line(looser).endswith("up")


def test_a_held_thread_sets_no_stitch():
    mech = mechanism.load(HEAD)
    timing = head_timing(mech)
    path = mech.thread
    longest = sum(
        np.linalg.norm(timing.positions[b] - timing.positions[a], axis=1) for a, b in itertools.pairwise(path)
    )
    off = dataclasses.replace(DEFAULTS, friction=0.0)
    held = needle_tension(mech, timing, settings=off, anchored=float(longest.max()) - 5e-3, cycles=1)
    assert held.set_pull == 0.0 and held.drawn_up == 0.0


def _polyline_turn(a, b, centre, r, w, edges, m=4000):
    """rad: the turning of a leg's thread from ``a`` to ``b`` (2,) drawn as a polyline of its
    path (the straight thread, round the rim, or up to the face's edge points ``edges``, across
    and down, up a helix on the case's side where an end does not see its edge point), summed
    as the angles between its pieces, the last piece's turn at ``b`` left out; and its length."""

    def end(p, beta):
        """The points from p (z = 0) up to the edge point at beta (z = w)."""
        v = p - centre
        d, to = math.hypot(*v), math.atan2(v[1], v[0])
        seen = math.acos(r / d)
        delta = math.remainder(beta - to, math.tau)
        e = [*(centre + r * np.array([math.cos(beta), math.sin(beta)])), w]
        if abs(delta) <= seen:
            return [[*p, 0.0], e]
        tang, phi = math.sqrt(d * d - r * r), abs(delta) - seen
        u = tang + r * phi
        s = np.linspace(0.0, phi, m)
        ang = to + math.copysign(1.0, delta) * (seen + s)
        z = w * (tang + r * s) / u
        return [[*p, 0.0], *np.column_stack([centre[0] + r * np.cos(ang), centre[1] + r * np.sin(ang), z])]

    if edges is None:  # round the rim in the middle plane
        va, vb = a - centre, b - centre
        sense = math.copysign(1.0, va[0] * vb[1] - va[1] * vb[0])
        ta = math.atan2(va[1], va[0]) + sense * math.acos(r / math.hypot(*va))
        tb = math.atan2(vb[1], vb[0]) - sense * math.acos(r / math.hypot(*vb))
        arc = math.remainder(sense * (tb - ta), math.tau) % math.tau
        ang = ta + sense * np.linspace(0.0, arc, m)
        pts = [
            [*a, 0.0],
            *np.column_stack([centre[0] + r * np.cos(ang), centre[1] + r * np.sin(ang), 0 * ang]),
            [*b, 0.0],
        ]
    else:
        pts = end(a, edges[0]) + end(b, edges[1])[::-1]
    pts = np.array(pts, dtype=float)
    seg = np.diff(pts, axis=0)
    seg = seg[np.linalg.norm(seg, axis=1) > 1e-15]
    u = seg / np.linalg.norm(seg, axis=1, keepdims=True)
    cos = np.clip(np.einsum("ij,ij->i", u[:-1], u[1:]), -1.0, 1.0)
    sin = np.linalg.norm(np.cross(u[:-1], u[1:]), axis=1)
    return float(np.arctan2(sin, cos).sum()), float(np.linalg.norm(seg, axis=1).sum())


def _turns_checked(a, z, centre, r, w) -> dict[str, int]:
    """Each leg from ``a`` to ``z`` (N, 2): its turn on the case against its polyline's; how
    many of each kind of path were checked."""
    from mjlink.analysis.loop import _end, case_turn, leg_and_arrival, over_face

    length, _, turn = leg_and_arrival(a, z, centre, r, w)
    face, edges = over_face(a, z, centre, r, w)
    kinds = {"straight": 0, "rim": 0, "face": 0, "helix": 0}
    for i in range(len(a)):
        straight = abs(length[i] - math.hypot(*(z[i] - a[i]))) <= 1e-12
        on_face = not straight and abs(length[i] - face[i]) <= 1e-12 * face[i]
        kinds["straight" if straight else ("face" if on_face else "rim")] += 1
        if straight:
            assert turn[i] == 0.0
            continue
        if on_face:
            for p, beta in ((a[i], edges[i, 0]), (z[i], edges[i, 1])):
                to, seen, _, _ = (float(x[0]) for x in _end(p[None], centre, r))
                kinds["helix"] += abs(math.remainder(beta - to, math.tau)) > seen
        want, long = _polyline_turn(a[i], z[i], centre, r, w, edges[i] if on_face else None)
        assert long == pytest.approx(length[i], rel=1e-6)  # the polyline's chords cut its arcs short
        assert turn[i] == pytest.approx(want, abs=1e-5)  # rad: a 4,000-piece polyline of the helices
        alone = case_turn(
            a[i : i + 1], z[i : i + 1], centre, r, w, edges[i : i + 1] if on_face else np.full((1, 2), np.nan)
        )
        assert turn[i] == pytest.approx(float(alone[0]), abs=1e-12)
    return kinds


def test_the_eye_legs_turn_on_the_case_is_its_threads_turning_round_the_rim_and_over_the_face(head):
    """The capstan angle the thread slides over the bobbin case by is how far its path turns on
    the way, summed here over a fine polyline of the path itself: round the rim, the arc it
    wraps; over the face, the turns at the face's edges, and up the case's side where an end
    does not see its edge point and climbs a helix. On the shipped head's eye legs over the
    carry, on points about its case, and about a thin case (where the helices are); the
    polyline's length is the leg's, so it is the leg's own path."""
    mech, timing = head
    tm, bal, b = mech.timing, mech.balance, timing.balance
    r, w = bal.bobbin_case / 2.0, bal.bobbin_case_width / 2.0
    centre = timing.positions[hook_crank(mech).pivot][0, :2]
    carried = np.isfinite(b.past)
    hole = np.column_stack(
        [timing.positions[tm.roles["needle_point"]][:, 0] + b.hole * 1e-3, np.full(len(b.past), tm.plate)]
    )[carried][::20]
    blade = timing.positions[tm.roles["hook_point"]][carried, :2][::20]
    rng = np.random.default_rng(7)

    def about(n, lo, hi):
        ang, far = rng.uniform(0.0, math.tau, n), rng.uniform(lo, hi, n) * r
        return centre + far[:, None] * np.column_stack([np.cos(ang), np.sin(ang)])

    kinds = _turns_checked(
        np.vstack([hole, about(60, 1.05, 2.5)]), np.vstack([blade, about(60, 1.05, 2.5)]), centre, r, w
    )
    assert min(kinds[k] for k in ("straight", "rim", "face")) >= 5, kinds
    thin = _turns_checked(about(1500, 1.005, 1.3), about(1500, 1.005, 1.3), centre, r, r / 10.0)
    assert thin["helix"] >= 3, thin
