"""Many heads' needle threads stepped at once (mjlink.analysis.tension_many) against the plain
twin that steps one (mjlink.analysis.tension.step), and the states that repeat only every few
stitches: the check spring striking its stop."""

from __future__ import annotations

import dataclasses
import itertools

import numpy as np
import pytest
from threadchecks import hook_stiffness_checked, stepped_alike

from mjlink.analysis import tension, tension_many
from mjlink.analysis.tension import prepare, step
from mjlink.analysis.tension_many import TOGETHER, step_many
from mjlink.analysis.tension_state import hardest, periodic
from mjlink.analysis.timing import head_timing
from mjlink.model import mechanism
from mjlink.model.catalogue import shipped
from mjlink.model.tension import DEFAULTS
from mjlink.study.engine import REFERENCE_CHUNK, chunking, reference_chunks
from mjlink.study.spec import load

HEAD = shipped("mechanisms") / "lockstitch_head.toml"
# The head with the paper's take-up, whose check spring strikes its stop: the stitches that
# alternate are found on it.
PAPER = shipped("mechanisms") / "examples" / "lockstitch_head_paper_takeup.toml"
# The stitch that alternates: found on the head with the paper's take-up at 720 steps a stitch
# by a random search of needle tension (N) and check-spring rate (N/m); the tests below check it
# from outside the detection.
# Found with the loop sliding freely round the hook's blade (hook_wrap 0): the blade's friction
# holds the loop's leg past it and moves the head off that state.
ALTERNATING = {"needle_tension": 2.2415538907306627, "spring_rate": 30.459956818458064, "hook_wrap": 0.0}
# A grid study of the shipped head without MuJoCo, its parameters and metrics to follow.
GRID = """[study]
mechanism = "lockstitch_head"
title = "t"
angles = {angles}
[sampling]
method = "grid"
[verify]
mujoco = "none"
"""


@pytest.fixture(scope="module")
def head():
    mech = mechanism.load(PAPER)
    return mech, head_timing(mech, samples=720)


def _problem(mech, timing, *, speed=None, spring=True, **tension):
    cfg = dataclasses.replace(mech.tension or DEFAULTS, **tension)
    own = dataclasses.replace(mech, speed=speed) if speed is not None else mech
    return prepare(own, timing, settings=cfg, samples=360, spring=spring)


@pytest.mark.parametrize("blade", [0.0, DEFAULTS.hook_wrap])
def test_the_array_step_gives_what_the_twin_gives_each_head(head, monkeypatch, blade):
    """Needle tensions, spring rates and speeds over the range a study varies, a head without
    its check spring and stitches that alternate: each one's periodic state, its period, the
    stitches run, every zone's tension, the spring's travel and the thread drawn agree with the
    twin's to rounding (the same arithmetic in another order). The arrays step until only a
    few heads are left, whatever the handoff's tuning. With the loop sliding freely round the
    hook's blade (its wrap nought: one stretch below the eye) and held there by friction (the
    default: the stretch past the blade apart)."""
    monkeypatch.setattr(tension_many, "ALONE", 4)
    mech, timing = head
    problems = [
        _problem(mech, timing, speed=w, needle_tension=nt, spring_rate=k, hook_wrap=blade)
        for nt, k, w in itertools.product((1.0, 1.9, 2.8), (10.0, 30.0, 60.0), (157.08, 366.52, 628.32))
    ]
    # Two that alternate at 360 steps a stitch with the loop free on the blade (found as
    # ALTERNATING was).
    problems += [
        _problem(mech, timing, speed=418.879, needle_tension=2.4, spring_rate=20.0, hook_wrap=blade),
        _problem(mech, timing, speed=523.599, needle_tension=2.8, spring_rate=20.0, hook_wrap=blade),
        _problem(mech, timing, spring=False, hook_wrap=blade),
    ]
    problems += [
        _problem(mech, timing, needle_tension=1.0 + 0.1 * i, spring_rate=20.0 + 2.0 * i, hook_wrap=blade)
        for i in range(20)
    ]
    assert len(problems) >= TOGETHER  # stepped as arrays, the last few handed to the twin
    assert len(problems[0].zones) == len(mech.thread) + (blade > 0.0)  # the path's, below the eye, past the blade
    periods = {t.period for t in stepped_alike(problems)}
    assert periods >= ({1, 2} if blade == 0.0 else {1})


def test_a_fixed_number_of_stitches_is_the_twins(head, monkeypatch):
    monkeypatch.setattr(tension_many, "ALONE", 4)  # the arrays step both stitches
    mech, timing = head
    problems = [_problem(mech, timing, needle_tension=1.0 + 0.03 * i) for i in range(TOGETHER)]
    for p, b in zip(problems, step_many(problems, cycles=2), strict=True):
        a = step(p, cycles=2)
        assert b.cycles == a.cycles == 2
        np.testing.assert_allclose(b.tension, a.tension, rtol=0, atol=1e-9 * a.peak)


def test_problems_of_different_paths_are_stepped_apart_each_as_its_own(head):
    """A study whose variants differ in their path's shape (one stretch fewer below the eye
    with the hook's wrap at nought; here another number of steps) steps each kind apart."""
    mech, timing = head
    problems = [_problem(mech, timing, needle_tension=1.0 + 0.03 * i) for i in range(TOGETHER)]
    odd = prepare(mech, timing, samples=720)
    together = step_many([*problems, odd], cycles=1)
    np.testing.assert_array_equal(together[-1].tension, step(odd, cycles=1).tension)
    for a, b in zip(together[:-1], step_many(problems, cycles=1), strict=True):
        np.testing.assert_array_equal(a.tension, b.tension)


@pytest.mark.parametrize(
    ("feds", "period"),
    [
        ([4.0, 4.5, 4.49, 4.49], 1),
        ([4.49, 4.5, 4.49, 4.5], 2),
        ([4.0, 4.49, 4.5, 4.49, 4.5], 2),
        ([4.1, 4.2, 4.3, 4.1, 4.2, 4.3], 3),
        ([4.1, 4.2, 4.3, 4.1, 4.2], 0),  # not yet twice over
        ([4.0, 4.1, 4.2, 4.3], 0),
        ([4.0], 0),
    ],
)
def test_a_state_repeats_after_the_least_period_seen_twice_over(feds, period):
    held = [100e-3] * len(feds)  # m: the same thread in the path after every stitch
    assert periodic([f * 1e-3 for f in feds], held) == period


def test_equal_draws_are_no_state_while_the_thread_in_the_path_still_changes():
    """A thread that starts with slack draws nothing through the discs while the stitches use
    the slack up: two stitches alike in their draw, 4.5 mm less thread in the path after each."""
    assert periodic([0.0, 0.0, 0.0], [0.120, 0.1155, 0.111]) == 0
    assert periodic([4.5e-3, 4.5e-3], [0.111, 0.111]) == 1


def test_a_head_can_alternate_its_stitches(head):
    """Checked by stepping a fixed number of stitches from the start, outside the detection:
    the stitch a period on is the reported one again, the one in between is not."""
    mech, timing = head
    settings = dataclasses.replace(mech.tension or DEFAULTS, **ALTERNATING)
    pb = prepare(mech, timing, settings=settings, samples=720)
    t = step(pb)
    assert t.period == 2 and t.converged
    again = step(pb, cycles=t.cycles + 2)
    between = step(pb, cycles=t.cycles + 1)
    np.testing.assert_allclose(again.tension, t.tension, rtol=0, atol=1e-6 * t.peak)
    assert again.drawn[pb.order[-1]] == pytest.approx(t.drawn[pb.order[-1]], abs=1e-8)  # m: the periodic test's
    assert abs(between.drawn[pb.order[-1]] - t.drawn[pb.order[-1]]) > 1e-6  # m: the two stitches differ
    # Reported: the harder pulled of the two, and the mean draw of the pair.
    assert t.peak >= between.peak
    pair = (t.drawn[pb.order[-1]] + between.drawn[pb.order[-1]]) / 2
    assert t.per_stitch == pytest.approx(pair, abs=1e-8)  # m: the periodic test's


def test_a_tension_study_steps_its_variants_in_large_tasks(tmp_path):
    """A study whose metric steps its variants at once cuts them into tasks of up to that
    many, two at least and one a worker where there are enough; others keep about sixteen."""
    body = (
        GRID.format(angles=720)
        + """[[parameter]]
path = "tension.needle_tension"
values = [{values}]
[[metric]]
kind = "{kind}"
"""
    )
    cases = (
        (1000, "tension", 1, 2),
        (1000, "tension", 2, 2),
        (1000, "tension", 3, 3),
        (1200, "tension", 2, 3),  # 512 at most a task
        (27, "tension", 2, 2),
        (8, "tension", 2, 1),
        (1000, "timing", 2, 16),
    )
    for n, kind, lanes, tasks in cases:
        f = tmp_path / f"{kind}{n}.toml"
        f.write_text(body.format(values=", ".join(str(1.0 + i * 1e-3) for i in range(n)), kind=kind))
        study = load(f)
        cut = reference_chunks(study, n, lanes)
        most = max(max(m.together for m in study.metrics), 1) if kind == "tension" else REFERENCE_CHUNK[1]
        assert len(cut) == tasks, (n, kind, lanes, cut)
        assert cut[0][0] == 0 and cut[-1][1] == n and all(b - a <= most for a, b in cut)
        # The cache records the cut: another number of workers, another cut, for these alone.
        assert (chunking(study, 2) == chunking(study, 3)) == (kind == "timing")


def test_the_hook_stiffness_is_the_derivative_of_the_threads_pull_in_every_state(head):
    """The check spring's Newton steps take the thread's stiffness at the hook: here it is
    compared with the pull's central difference over the hook's place (its contacts' states
    held), where the thread holds on the hook and where it slides over it either way, in the
    twin and in the array step (tests/threadchecks.py; tests/test_spring_arc.py on an arc)."""
    mech, timing = head
    pb = _problem(mech, timing, needle_tension=2.8, spring_rate=10.0)
    checked, _ = hook_stiffness_checked(pb, 40, (-1, 0, 1))
    assert checked >= 60


def test_a_tension_studys_tasks_each_take_a_share_of_the_whole_study_and_give_each_variant_its_own(tmp_path):
    """The few large tasks of a study stepped together are dealt blocks of variants from
    across the study (their costs alike where they follow a parameter), and each variant's
    row is still its own: what needle_tension gives the head with its numbers."""
    from mjlink.analysis.tension import needle_tension
    from mjlink.api import read_study, run_study
    from mjlink.study.engine import reference_order

    f = tmp_path / "t.toml"
    f.write_text(
        GRID.format(angles=180)
        + """[[parameter]]
path = "tension.needle_tension"
values = [1.0, 1.3, 1.6, 1.9, 2.2, 2.5]
[[parameter]]
path = "input.speed"
values = [209.44, 314.159, 418.879, 523.599]
[[metric]]
kind = "tension"
"""
    )
    study = load(f)
    n = len(study.values())
    cut, order = reference_chunks(study, n), reference_order(study, n)
    assert len(cut) >= 2 and order is not None
    assert sorted(order.tolist()) == list(range(n))
    for a, b in cut:
        held = order[a:b]
        assert held.min() < n // 3 and held.max() >= n - n // 3, (a, b, held)  # from across the study
    run_study(f, tmp_path / "out", workers=0, plots=False)
    table = read_study(tmp_path / "out" / "t-study")
    base = mechanism.load(HEAD)
    for i in range(n):
        nt, w = float(table["tension.needle_tension_N"][i]), float(table["input.speed_rad_s"][i])
        own = dataclasses.replace(base, speed=w, tension=dataclasses.replace(DEFAULTS, needle_tension=nt))
        expected = needle_tension(own, head_timing(own, samples=180), samples=180)
        assert float(table["tension_period"][i]) == expected.period
        if expected.period == 0:
            # No state in 80 stitches (one head on these coarse steps): both say so; its last
            # stitches, stepped in another order, drift apart by more than rounding.
            continue
        assert float(table["tension_peak_N"][i]) == pytest.approx(expected.peak, rel=1e-6)


def test_a_tension_studys_calibration_traces_one_stitch_and_measures_what_the_whole_stepping_holds(tmp_path):
    """The calibration traces a head's memory on one stitch (probing), not on the stitches to
    its periodic state, whose every float tracing would cost many times the stepping: the
    probe's traced bytes are the whole stepping's within 1 %, and only within probing does the
    head stop after one stitch."""
    import tracemalloc

    from mjlink.analysis.metric_base import probed, probing
    from mjlink.study.tasks import reference_chunk

    f = tmp_path / "t.toml"
    f.write_text(
        GRID.format(angles=180)
        + """[[parameter]]
path = "tension.needle_tension"
values = [1.0, 1.9, 2.8]
[[metric]]
kind = "tension"
"""
    )
    study = load(f)

    def traced(run):
        tracemalloc.start()
        try:
            out = run()
            return out, tracemalloc.get_traced_memory()[1]
        finally:
            tracemalloc.stop()

    rows = study.values()[1:2]
    reference_chunk(study, rows)  # first-call costs out of both
    full, full_bytes = traced(lambda: reference_chunk(study, rows))
    with probing():
        assert probed()
        probe, probe_bytes = traced(lambda: reference_chunk(study, rows))
    assert not probed()
    # One stitch from the start draws other thread than the periodic state's.
    drawn = probe.columns["tension_per_stitch"][0], full.columns["tension_per_stitch"][0]
    assert abs(drawn[0] - drawn[1]) > 0.1, drawn  # mm
    assert probe_bytes == pytest.approx(full_bytes, rel=0.01)


def test_a_tension_studys_plan_scales_its_calibration_to_the_arrays_of_its_tasks(tmp_path, monkeypatch):
    """The calibration steps a few heads one by one; the tasks step hundreds at once, each
    head's stitch at a fraction of the cost (tension_many.share: bench/bench_tension.py measures
    it). The plan's time is the calibration's scaled by that fraction for its tasks' size, and
    nothing else changes."""
    from mjlink.analysis.metric_base import Metric
    from mjlink.analysis.tension_metric import TensionMetric
    from mjlink.study import plan

    assert tension_many.share(TOGETHER - 1) == 1.0 > tension_many.share(TOGETHER)
    sizes = [TOGETHER, 96, 192, 384, 512]
    assert all(tension_many.share(a) > tension_many.share(b) for a, b in itertools.pairwise(sizes))
    f = tmp_path / "t.toml"
    f.write_text(
        GRID.format(angles=720)
        + '[[parameter]]\npath = "tension.needle_tension"\nvalues = ['
        + ", ".join(str(1.0 + i * 1e-3) for i in range(1000))
        + ']\n[[metric]]\nkind = "tension"\n'
    )
    study = load(f)
    cal = plan.Calibration(row_seconds=1e-4, row_bytes=1e3, model_seconds=float("nan"), variants=4)
    scaled = plan.estimate(study, workers=2, limit=1e12, calibration=cal)
    monkeypatch.setattr(TensionMetric, "share", Metric.share)
    alone = plan.estimate(study, workers=2, limit=1e12, calibration=cal)
    assert scaled.tasks == alone.tasks == 2
    assert scaled.seconds == pytest.approx(alone.seconds * tension_many.share(500), rel=1e-12)
    assert scaled.memory == alone.memory


def test_a_tension_optimizations_plan_scales_to_the_tasks_its_generations_are_cut_into(monkeypatch):
    """An optimization's generation is cut into a multiple of the workers: 60 candidates on 2
    workers make tasks of 30 heads, stepped one by one (no scaling); with 8 tolerance samples
    each, tasks of 120 heads at once, which the plan scales down."""
    from mjlink.analysis.metric_base import Metric
    from mjlink.analysis.tension_metric import TensionMetric
    from mjlink.study import plan
    from mjlink.study.spec import parse

    body = (
        GRID.format(angles=720).replace('[sampling]\nmethod = "grid"\n', "")
        + '[optimize]\nobjective = "tension_peak"\npopulation = 60\ngenerations = 5\nseeds = 1\npolish_evaluations = 0\n'
        + '[[parameter]]\npath = "tension.needle_tension"\nrange = [1.0, 2.8]\n{tolerance}[[metric]]\nkind = "tension"\n'
    ).replace('[verify]\nmujoco = "none"\n', "")
    cal = plan.Calibration(row_seconds=1e-4, row_bytes=1e3, model_seconds=float("nan"), variants=4)
    robust = "[robust]\nsamples = 8\n"

    plain = parse(body.format(tolerance=""), "o.toml")
    tolerant = parse(body.replace("[optimize]", robust + "[optimize]").format(tolerance="tolerance = 0.01\n"), "r.toml")
    scaled = [plan.estimate(st, workers=2, limit=1e12, calibration=cal) for st in (plain, tolerant)]
    monkeypatch.setattr(TensionMetric, "share", Metric.share)
    # The same runs on the bowl (timed: they would differ by the clock's noise).
    alone = [
        plan.estimate(st, workers=2, limit=1e12, calibration=cal, bowl=p.bowl, rehearsal=p.rehearsal)
        for st, p in zip((plain, tolerant), scaled, strict=True)
    ]
    assert scaled[0].seconds == alone[0].seconds
    assert scaled[1].seconds < alone[1].seconds * (1 + tension_many.share(120)) / 2


def test_a_period_shows_its_hardest_pulled_stitch(head):
    """A state that repeats every 3 stitches (the head with the paper's take-up at 3,500
    stitches/min, 2.6 N and 0.01 N/mm, 360 steps a stitch): the stitch reported is the period's
    hardest pulled, checked by stepping the two before it from the start. Before, the run went
    on to the stitch a period on from the wrong one of three (the count was reversed) and
    reported a softer stitch."""
    assert [hardest(10, t) for t in ([3.0, 1.0, 2.0], [1.0, 3.0, 2.0], [1.0, 2.0, 3.0])] == [11, 12, 10]
    mech, timing = head
    pb = _problem(mech, timing, speed=366.52, needle_tension=2.6, spring_rate=10.0)
    t = step(pb)
    assert t.converged and t.period == 3
    others = [step(pb, cycles=t.cycles - k).peak for k in (1, 2)]
    assert t.peak >= max(others) and t.peak - min(others) > 1e-6 * t.peak  # not all alike


def test_a_long_period_is_found_once_seen_twice_over():
    """The draws of the shipped head at 3,000 stitches/min, 2.4 N at the discs and a spring of
    0.06 N/mm (mm, rounded), which repeat every 12 stitches: four alike in a row twice in each
    period, while the thread in the path changes after each (m)."""
    draws = [4.4984, 4.4941, 4.4986, *[4.4961] * 4, 4.4985, *[4.4961] * 4]
    run = draws * 3
    held = [0.3767 + 1e-7 * (k % 12) for k in range(len(run))]
    got = [periodic([f * 1e-3 for f in run[a:b]], held[a:b]) for a, b in ((0, 24), (1, 24), (0, 25), (0, 36))]
    assert got == [12, 0, 12, 12]  # the second: not yet twice over
    # The draws alone: four alike in a row would pass for one stitch repeating itself.
    assert periodic([f * 1e-3 for f in run[:7]], [0.3767] * 7) == 1


def test_a_head_whose_check_spring_repeats_every_sixteen_stitches_is_periodic(monkeypatch):
    """The shipped head at 3,500 stitches/min with 2.8 N at the discs and a spring of 0.01
    N/mm, 360 steps a stitch: its check spring strikes its stop and the stitches repeat every
    16 (before, only periods up to 8 were looked for, and a head like it ran 80 stitches to no
    state).
    Checked by stepping a fixed number of stitches from the start, outside the detection: the
    stitch a period on is the reported one again, one half a period before is not; the draw
    reported is the mean of the period's draws, which differ. A state found on the last stitch
    allowed still runs on to its hardest pulled stitch, in the twin and the array step alike."""
    mech = mechanism.load(HEAD)
    timing = head_timing(mech, samples=720)
    # Found with the loop free on the hook's blade (its turn there moves the state).
    cfg = dataclasses.replace(mech.tension or DEFAULTS, needle_tension=2.8, spring_rate=10.0, hook_wrap=0.0)
    pb = prepare(dataclasses.replace(mech, speed=366.52), timing, settings=cfg, samples=360)
    seen: list[tuple[list[float], int]] = []  # each stitch's draws as the stepping hands them over, the period found
    monkeypatch.setattr(tension, "periodic", lambda f, h: seen.append((list(f), periodic(f, h))) or seen[-1][1])
    t = step(pb)
    n = 16
    assert t.converged and t.period == n and t.cycles < 80
    again = step(pb, cycles=t.cycles + n)
    np.testing.assert_allclose(again.tension, t.tension, rtol=0, atol=1e-6 * t.peak)
    assert again.drawn[pb.order[-1]] == pytest.approx(t.drawn[pb.order[-1]], abs=1e-8)  # m: the periodic test's
    half = step(pb, cycles=t.cycles - n // 2)
    # Another stitch of the period: a hundred times further from it than the one a period on.
    assert np.abs(half.tension - t.tension).max() > 1e-4 * t.peak and t.peak >= half.peak  # the hardest pulled
    draws, found = next((f[-n:], len(f)) for f, p in seen if p)
    assert max(draws) - min(draws) > 1e-6  # m: the stitches of the period differ
    assert t.per_stitch == pytest.approx(sum(draws) / n, abs=1e-8)  # m: the periodic test's
    assert found < t.cycles  # it ran on to the period's hardest pulled stitch
    monkeypatch.setattr(tension_many, "TOGETHER", 1)  # the arrays step it, and one more
    monkeypatch.setattr(tension_many, "ALONE", 0)
    for b in (step(pb, most_cycles=found), step_many([pb, _problem(mech, timing)], most_cycles=found)[0]):
        assert (b.cycles, b.period) == (t.cycles, t.period)
        np.testing.assert_allclose(b.tension, t.tension, rtol=0, atol=1e-9 * t.peak)


def test_a_head_that_starts_with_slack_is_not_periodic_until_it_draws_its_stitch():
    """The shipped head at 1,500 stitches/min with 2.8 N at the discs starts with slack in its
    path and draws nothing through the discs for its first two stitches: alike in their draw,
    yet not its periodic state. Found there, the state draws the thread the stitch formula
    locks (the thread's stretch aside: within 1 %), as the twin and the array step both say."""
    mech = mechanism.load(HEAD)
    timing = head_timing(mech, samples=720)
    cfg = dataclasses.replace(mech.tension or DEFAULTS, needle_tension=2.8, spring_rate=30.0)
    pb = prepare(dataclasses.replace(mech, speed=157.08), timing, settings=cfg, samples=720)
    assert step(pb, cycles=1).per_stitch == 0.0 and step(pb, cycles=2).per_stitch == 0.0
    t = step(pb)
    assert t.converged and t.cycles > 2
    # The stitch locks the thread stretched: its strain, some 0.2 %, is what differs.
    assert t.per_stitch == pytest.approx(pb.formula, rel=0.01)
    many = step_many([pb] * TOGETHER)[0]
    assert (many.cycles, many.period) == (t.cycles, t.period)
    assert many.per_stitch == pytest.approx(t.per_stitch, rel=1e-12)
