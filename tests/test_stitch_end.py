"""The stitch's end, one convention for both stitch types (docs/head.md, The thread balance):
the hole the needle left is at the needle's line until the needle point leaves the fabric, then
moves with the feed; in closed form on a head drawn by hand, the same curve from the lockstitch
and the chain-stitch heads, and the demand it gives while the needle is in the fabric."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mjlink.analysis.timing import head_timing
from mjlink.model import mechanism
from mjlink.model.catalogue import shipped

HEAD = shipped("mechanisms") / "lockstitch_head.toml"
CHAIN = shipped("mechanisms") / "examples" / "chainstitch_head.toml"


@pytest.fixture(scope="module")
def head():
    return mechanism.load(HEAD)


@pytest.fixture(scope="module")
def chain():
    return mechanism.load(CHAIN)


def _linear_feed_head(up: tuple[float, float]):
    """A head drawn by hand on a 0.05 deg grid: the needle point at 15 cos(theta) + 4 mm above
    the plate, the feed dog above the plate from ``up[0]`` to ``up[1]`` deg (round the turn),
    advancing 3.35 mm linearly in the angle while it is up and going back while it is down."""
    from mjlink.analysis.timing import HeadTiming

    th = np.arange(7200) * 0.05
    lo, w = up[0], (up[1] - up[0]) % 360.0
    rel = (th - lo) % 360.0
    height = np.where(rel < w, 0.8 * np.sin(np.pi * rel / w), -2.0 * np.sin(np.pi * (rel - w) / (360.0 - w)))
    advance = np.where(rel < w, 3.35 * rel / w, 3.35 * (1.0 - (rel - w) / (360.0 - w)))
    curves = {"needle point": 15.0 * np.cos(np.radians(th)) + 4.0, "dog height": height, "dog advance": advance}
    return HeadTiming(theta=th, curves=curves, events={}, rows=(), target="hand")


@pytest.mark.parametrize("up", [(230.0, 90.0), (340.0, 100.0), (300.0, 60.0)])
@pytest.mark.parametrize("stitch", ["301", "101"])
def test_the_stitch_end_moves_with_the_feed_from_the_needle_leaving_in_closed_form(up, stitch):
    """The one convention of both stitch types (docs/head.md, The thread balance): the hole the
    needle left stays at the needle's line until the point leaves the fabric, rising, then moves
    with the feed: at each angle, the stitch length times the fraction of the turn's feed done
    since the needle left. With the feed linear in the angle while the dog is up, that fraction
    is the dog's time up since the needle left over its time up in a turn. While the needle is in
    the fabric the thread goes to its own hole (at the needle's line); from its entry until the
    loop's release (a lockstitch's release after the needle leaves, a chain stitch's cast-off at
    the pick-up, before) the last stitch's end is the hole it left, carried on. Feed windows
    with the dog still up as the needle leaves, rising after it, and up while the needle is in
    the fabric."""
    from mjlink.analysis.timing import stitch_end

    head = _linear_feed_head(up)
    s, fabric = 3.0, 1.5  # mm
    release = 340.0 if stitch == "301" else 206.0
    at = stitch_end(head, fabric * 1e-3, s * 1e-3, release)
    enters = math.degrees(math.acos((fabric - 4.0) / 15.0))  # 15 cos + 4 = fabric, descending
    leaves = 360.0 - enters
    lo, w = up[0], (up[1] - up[0]) % 360.0

    def fed(a, b):  # the dog's time up between the angles a <= b (unwrapped), over a turn's
        return sum(max(0.0, min(b, lo + w + 360 * k) - max(a, lo + 360 * k)) for k in range(-2, 3)) / w

    # The crossings are placed linearly between samples of the cosine: the angle is off by at
    # most (h^2 / 8) |f''| / |f'| there (h the grid's step), and the hole by that much feed.
    h = math.radians(0.05)
    off = math.degrees(h * h / 8.0 * abs(math.cos(math.radians(leaves)) / math.sin(math.radians(leaves))))
    tol = s * 1e-3 * off / w
    assert at.enters == pytest.approx(enters, abs=off) and at.leaves == pytest.approx(leaves, abs=off)
    for a in np.arange(0.0, 360.0, 7.35):
        k = round(a / 0.05)
        since = s * fed(leaves - 360.0 if a < leaves else leaves, a)
        inside = enters < a < leaves
        unset = (a - enters) % 360.0 < (release - enters) % 360.0
        hole = 0.0 if inside else since
        end = (since if inside else since + s) if unset else hole
        assert at.hole[k] == pytest.approx(hole * 1e-3, abs=tol), a
        assert at.end[k] == pytest.approx(end * 1e-3, abs=tol), a
    # The hole the needle left is a stitch length on when it enters again, less the feed done
    # with the needle in the fabric.
    k = int(enters / 0.05)
    assert at.hole[k] == pytest.approx(s * 1e-3 * (1.0 - fed(enters, leaves)), abs=tol + s * 1e-3 * 0.05 / w)


def _fed_since_the_needle_left(t, tm, s):
    """From the traced points alone: the stitch length times the fraction of the dog's forward
    travel above the plate (summed over the samples where it is above at both ends) done since
    the needle point left the fabric, rising; and the most one sample's travel moves it."""
    P = t.positions
    tip = P[tm.roles["needle_point"]][:, 1] - tm.plate
    a = np.nonzero((tip - tm.fabric < 0) & (np.roll(tip, -1) - tm.fabric >= 0))[0][0]
    dog = P[tm.roles["feed_dog"]]
    hi = int(np.argmax(dog[:, 1]))
    dx = np.diff(np.append(dog[:, 0], dog[0, 0])) * np.sign(np.gradient(dog[:, 0])[hi])
    above = (dog[:, 1] > tm.plate) & (np.roll(dog[:, 1], -1) > tm.plate)
    step = np.where(above & (dx > 0), dx, 0.0)
    moved = np.roll(np.cumsum(np.roll(step, -(a + 1))), a + 1)
    return s * moved / step.sum(), 2.0 * s * step.max() / step.sum()


def test_both_stitch_types_put_the_stitch_end_where_the_feed_has_carried_it_since_the_needle_left(head, chain):
    """The lockstitch head and the chain-stitch head have the same needle bar and feed: the
    needle's hole follows the same curve in both, and outside the needle's time in the fabric
    it is where the feed has carried it since the needle left (measured here from the traced
    dog). Where neither stitch is still being set, the last stitch's end is that hole in both."""
    lock, ch = head_timing(head), head_timing(chain)
    np.testing.assert_array_equal(lock.theta, ch.theta)
    np.testing.assert_allclose(lock.balance.hole, ch.balance.hole, atol=1e-12)
    s, tm = head.balance.stitch_length, head.timing
    fed, tol = _fed_since_the_needle_left(lock, tm, s)
    out = lock.positions[tm.roles["needle_point"]][:, 1] - tm.plate > tm.fabric  # the needle out of the fabric
    assert out.sum() > 3000 and (lock.balance.hole[out] > 0).any() and (lock.balance.hole[~out] == 0).all()
    np.testing.assert_allclose(lock.balance.hole[out] * 1e-3, fed[out], atol=tol)
    enters = lock.balance.phases["needle in the fabric"][0]
    both_set = (lock.theta - enters) % 360 > (lock.events["loop released"] - enters) % 360
    assert both_set.sum() > 1000
    np.testing.assert_allclose(lock.balance.end[both_set], ch.balance.end[both_set], atol=1e-12)
    np.testing.assert_allclose(lock.balance.end[both_set], lock.balance.hole[both_set], atol=0)


def thread_at_setting(t, tm):
    """The thread below the eye when the stitch was set (the take-up's longest path, at the
    needle's entry for the shipped head): straight from the eye to the last stitch's end, m;
    and how far that can be from the program's value, which takes the thread's length linear
    between the two samples either side of the setting (the hypot's curvature over one step)."""
    b, P, th = t.balance, t.positions, t.theta
    top = tm.plate + tm.fabric
    drawn = b.phases["needle descending"][0]
    exact = math.hypot(np.interp(drawn, th, b.end) * 1e-3, np.interp(drawn, th, P["NE"][:, 1]) - top)
    k = int(np.searchsorted(th, drawn)) - 1
    ends = [math.hypot(b.end[j] * 1e-3, P["NE"][j, 1] - top) for j in (k, k + 1)]
    return exact, abs(np.interp(drawn, th[k : k + 2], ends) - exact) + 1e-12


def test_the_demand_in_the_fabric_counts_the_last_stitch_a_stitch_length_back(head):
    """From the needle's entry until the hook takes the loop the thread runs from the eye up the
    needle and along the fabric's top to the last stitch's end, a stitch length behind once the
    feed is done; when the stitch was set (at the entry here) it ran straight from the eye, 2.3
    mm above the point, to that end where the feed had carried it: demand = depth of the eye +
    s - hypot(end at the setting, eye's height then), for a 1, 3 and 5 mm stitch."""
    tm = head.timing
    for s in (1e-3, 3e-3, 5e-3):
        own = mechanism.parse(HEAD.read_text().replace("stitch_length = 3.0 ", f"stitch_length = {s * 1e3} "), HEAD)
        t = head_timing(own)
        b, P = t.balance, t.positions
        depth = tm.plate + tm.fabric - P["NE"][:, 1]
        dog_down = t.events["dog flush, descending"]  # the feed is done
        i = np.nonzero((t.theta > dog_down) & (t.theta < t.events["hook picks the loop"]) & (depth > 0))[0]
        assert len(i) > 1000
        at_setting, tol = thread_at_setting(t, tm)
        np.testing.assert_allclose(b.demand[i] * 1e-3, depth[i] + s - at_setting, atol=tol)


# ------------------------------------------------ the thread the check spring's travel holds
def _held(up, rest, down, travel):
    from mjlink.analysis.stitch import spring_holds

    return float(spring_holds(np.array([up], float), np.array([rest], float), np.array([down], float), travel)[0])


def test_a_check_spring_holds_the_paths_length_its_hook_takes_out_not_its_travel():
    """The thread a check spring holds is what its hook, moved from rest along the bisector of
    the thread's turn, takes out of the path, not its travel: in closed form for a symmetric V
    (legs of half-width w and height h: 2 sqrt(w^2 + h^2) - 2 sqrt(w^2 + (h - d)^2), and no
    more than 2 sqrt(w^2 + h^2) - 2 w once the hook reaches the straight thread), for a thread
    turning back round the hook (twice the travel, up to twice the shorter leg), and against the
    path's least length found along the hook's line, 1e-6 mm apart, for a head's own turn."""
    w, h = 0.004, 0.006
    for d in (0.001, 0.003, 0.0059):
        expected = 2 * math.hypot(w, h) - 2 * math.hypot(w, h - d)
        assert _held((-w, h, 0), (0, 0, 0), (w, h, 0), d) == pytest.approx(expected, abs=1e-12)
    for d in (0.006, 0.01):
        assert _held((-w, h, 0), (0, 0, 0), (w, h, 0), d) == pytest.approx(2 * math.hypot(w, h) - 2 * w, abs=1e-12)
    # Turning back: both legs up, the shorter 5 mm long.
    assert _held((0, 0.005, 0), (0, 0, 0), (0, 0.05, 0), 0.003) == pytest.approx(0.006, abs=1e-12)
    assert _held((0, 0.005, 0), (0, 0, 0), (0, 0.05, 0), 0.007) == pytest.approx(0.010, abs=1e-12)
    # A general turn in space, against a dense search along the hook's line.
    up, rest, down = np.array([0.012, 0.004, 0.002]), np.zeros(3), np.array([-0.003, 0.051, -0.001])
    e = (up - rest) / np.linalg.norm(up - rest) + (down - rest) / np.linalg.norm(down - rest)
    line = np.linspace(0.0, 0.007, 700_001)[:, None] * (e / np.linalg.norm(e))
    length = np.linalg.norm(up - line, axis=1) + np.linalg.norm(down - line, axis=1)
    assert _held(up, rest, down, 0.007) == pytest.approx(length[0] - length.min(), abs=1e-9)


def test_the_slack_row_is_held_against_the_thread_the_spring_holds(head):
    """The balance's slack row's window is the thread the file's check spring holds (written out
    here from its hook, its neighbours on the path and its travel), and the spare row is that
    less the slack."""
    t = head_timing(head)
    rows = {r.key: r for r in t.rows}
    path = head.thread
    k = path.index(head.balance.check_spring)
    up, rest, down = (t.positions[path[k + i]][0] for i in (-1, 0, 1))
    travel = head.balance.check_spring_travel
    e = (up - rest) / np.linalg.norm(up - rest) + (down - rest) / np.linalg.norm(down - rest)
    line = np.linspace(0.0, travel, 200_001)[:, None] * (e / np.linalg.norm(e))
    length = rest + line
    held = np.linalg.norm(up - length, axis=1) + np.linalg.norm(down - length, axis=1)
    held = held[0] - held.min()
    assert rows["thread_slack"].window.hi == pytest.approx(held, abs=1e-9)
    assert rows["spring_spare"].value == pytest.approx(held - rows["thread_slack"].value, abs=1e-9)
    assert not rows["spring_spare"].counts and not rows["thread_slack"].counts
