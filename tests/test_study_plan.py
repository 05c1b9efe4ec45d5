"""A study's plan against the run it plans: MuJoCo's models and steps, and the memory bound.

The plan counts the steps of every verified model before anything runs; the run is counted by
wrapping the rollout that steps the models (every step MuJoCo takes in a verification goes
through it). The expected counts are the closed form of the kinematic run's clock
(mechanisms/README.md, docs/performance.md): one crank turn at 50 us steps, the clock scaled by
150 / |speed| above 150 rad/s (the same crank angle per step), plus the initial sample's step.
"""

from __future__ import annotations

import dataclasses
import math
import tracemalloc

import numpy as np
import pytest

from mjlink import validation
from mjlink.sim import batch, builder, simulate
from mjlink.sim import steps as clock
from mjlink.study import engine, plan, spec

DT = 50e-6  # s, the kinematic run's timestep (mechanisms/README.md)
VERIFIED = 150.0  # rad/s, above which the clock is scaled

SPEEDS = """
[study]
mechanism = "takeup"
angles = 36

[sampling]
method = "grid"

[[parameter]]
path = "input.speed"
values = [5.0, 40.0, 100.0]

[[metric]]
kind = "stroke"
point = "P5"
axis = "y"

[verify]
mujoco = "all"
"""

HEAD = """
[study]
mechanism = "lockstitch_head"
angles = 36

[sampling]
method = "grid"

[[parameter]]
path = "input.speed"
values = [100.0, 523.5987755982989]

[[metric]]
kind = "stroke"
point = "NT"
axis = "y"

[verify]
mujoco = "all"
"""


def _turn_steps(speed: float) -> int:
    """One crank turn's rollout steps at ``speed`` rad/s (the module docstring's closed form)."""
    dt = DT * min(1.0, VERIFIED / abs(speed))
    return math.ceil(2 * math.pi / abs(speed) / dt - 1e-9) + 1


@pytest.fixture
def counted(monkeypatch):
    """Every model the verification rolls out and its steps."""
    seen: list[int] = []
    real = batch.rollout

    def rollout(models, states, nstep, **kw):
        seen.extend([nstep] * len(models))
        return real(models, states, nstep, **kw)

    monkeypatch.setattr(batch, "rollout", rollout)
    return seen


@pytest.mark.parametrize(
    ("text", "speeds"), [(SPEEDS, (5.0, 40.0, 100.0)), (HEAD, (100.0, 523.5987755982989))], ids=["slow", "head"]
)
def test_the_plan_counts_the_steps_the_verification_takes_and_bounds_its_memory(tmp_path, counted, text, speeds):
    """The planned models and steps are the run's; the plan's memory (without the
    interpreter's own) bounds the peak of every array the study allocates while it runs in
    this process (traced: numpy's and Python's)."""
    f = tmp_path / "s.toml"
    f.write_text(text)
    st = spec.load(f)
    p = plan.estimate(st, workers=0, limit=1e12)
    tracemalloc.start()
    try:
        o = engine.run(st)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert (o.verified == 1).all()  # every variant verified, so the plan's count is the run's
    expected = sorted(_turn_steps(w) for w in speeds)
    assert sorted(counted) == expected
    assert p.mujoco_models == len(counted) == len(speeds)
    assert p.mujoco_steps == sum(counted)
    assert plan.clock(st).most == max(expected)
    assert peak <= p.memory - plan.PROCESS_BYTES, (peak, p.memory - plan.PROCESS_BYTES)


def test_a_verified_models_recorded_values_are_counted_before_it_is_built():
    for name in ("crank_slider", "takeup", "takeup_eyelets", "warp_knitting", "lockstitch_head"):
        mech = validation.get(name)
        built = builder.make_batch(mech, simulate.kinematic_case(mech, cycles=1.0).settings)
        assert clock.verify_values(mech) == built.physics.nsensordata, name


def test_every_kinematic_run_counts_its_steps_on_one_clock():
    mech = validation.get("takeup")
    for speed in (-1.0, 7.0, 150.0, 523.6, 1e4):
        case = simulate.kinematic_case(mech, speed=speed, cycles=1.0)
        assert case.steps + 1 == clock.verify_steps(mech.period, speed) == _turn_steps(speed)
    v = batch.verify([mech])[0]
    assert v.samples == _turn_steps(mech.speed)


def test_a_sampled_studys_clock_counts_its_slowest_variant():
    # The take-up's 100 rad/s +- 97: the slowest variant's clock at 50 us, the fastest's scaled.
    body = SPEEDS.replace('method = "grid"', 'method = "tolerance"\nsamples = 3000\nseed = 1').replace(
        "values = [5.0, 40.0, 100.0]", "tolerance = 97.0"
    )
    st = spec.parse(body, "r.toml")
    c = plan.clock(st)
    slowest = float(np.abs(st.values()[:, 0]).min())
    assert c.most == _turn_steps(slowest)
    assert _turn_steps(197.0) < c.mean < c.most


def test_a_study_of_costly_variants_calibrates_on_as_few_as_fit_its_budget(tmp_path, monkeypatch):
    """The calibration evaluates a task's worth of variants (at least 16, or the study's own
    where it has fewer) unless the first one shows that they would not fit
    plan.CALIBRATION_SECONDS: then as many as fit, at least one (here a budget of none: one
    variant a batch), and the plan still estimates the study."""
    path = tmp_path / "speeds.toml"
    path.write_text(SPEEDS.replace('mujoco = "all"', 'mujoco = "none"'))
    study = spec.load(path)
    sizes: list[int] = []
    real = plan.reference_chunk

    def chunk(st, values):
        sizes.append(len(values))
        return real(st, values)

    monkeypatch.setattr(plan, "reference_chunk", chunk)
    full = plan.calibrate(study)
    assert set(sizes[1:]) == {min(plan.CALIBRATION_VARIANTS, len(study.values()))}
    sizes.clear()
    monkeypatch.setattr(plan, "CALIBRATION_SECONDS", 0.0)
    one = plan.calibrate(study)
    assert set(sizes) == {1}
    assert math.isfinite(one.row_seconds) and one.row_seconds > 0 and math.isfinite(full.row_seconds)


# The goal for an optimization's plan (issue: a study's cost is known before the work): its
# estimate within 2x of what the run takes, either way. The time's rates are compared by
# bench/bench_study.py --plan; here the count of evaluations, which the seeds make exact.
WITHIN = 2.0


def plan_holds(st: spec.Study, made: int) -> None:
    """The plan's expected evaluations within WITHIN of the ``made`` ones, never above its budget."""
    p = plan.estimate(st, workers=0)
    assert made <= p.variants, (made, p.variants)
    assert 1 / WITHIN <= p.expected_variants / made <= WITHIN, (st.name, p.expected_variants, made)
    assert p.seconds_least <= p.seconds <= p.seconds_most


# takeup_eyelets_demand: an ill-conditioned fit whose runs take their whole budget where the
# bowl settles in a sixth of it (the bowl's bound alone planned 0.42 of its evaluations).
@pytest.mark.parametrize("name", ["takeup_counterweight", "crank_slider_pareto", "takeup_eyelets_demand"])
def test_an_optimizations_plan_expects_its_evaluations_within_2x(name):
    from mjlink.study import optimize

    st = spec.load(name)
    plan_holds(st, optimize.run(st).evaluations)


def test_a_search_too_large_to_try_on_the_bowl_is_planned_at_its_whole_budget(monkeypatch):
    """The bowl is tried within settle.SECONDS of CPU and up to settle.POPULATION candidates a
    generation (scipy's own work per generation grows with the population's square); beyond
    either the plan's estimate is the whole budget, and it says so."""
    from mjlink.study import settle

    st = spec.load("takeup_counterweight")
    assert settle.on_bowl(st).complete
    monkeypatch.setattr(settle, "SECONDS", 0.0)
    assert not settle.on_bowl(st).complete
    monkeypatch.undo()
    big = dataclasses.replace(st, optimize=dataclasses.replace(st.optimize, population=settle.POPULATION + 1))
    p = plan.estimate(big, workers=0)
    assert not p.bowl.complete and p.seconds == p.seconds_least == p.seconds_most
    assert "for its whole budget (too large a search to try on a smooth bowl first)" in p.describe()


def test_a_rehearsal_that_settles_sets_the_estimate_and_one_that_does_not_raises_its_least(monkeypatch):
    """Bounds more than settle.WIDE apart are narrowed by rehearsing the first run: one that
    ends within its time gives every run's evaluations; one cut short gives a lower bound, and
    after more generations than the stall test waits, every run's whole budget."""
    from mjlink.study import optimize, settle

    st = spec.load("takeup_counterweight")
    b = optimize.budget(st)
    p = plan.estimate(st, workers=0)
    r = p.rehearsal
    assert r is not None and r.complete and r.angles < st.per_turn
    assert p.expected_variants == b.runs * (r.search + r.polish)
    assert f"settled in {r.search + r.polish:,} evaluations" in p.describe()
    monkeypatch.setattr(settle, "REHEARSAL_SECONDS", 0.0)
    cut = plan.estimate(st, workers=0, calibration=p.calibration, bowl=p.bowl)
    r = cut.rehearsal
    assert r is not None and not r.complete and r.search >= 1 and r.polish == 0  # its first batch, cut short
    assert "had not settled after" in cut.describe()
    assert cut.seconds_least < cut.seconds < cut.seconds_most  # too few generations to tell
    # Cut short after more generations than the stall test waits: every run to its budget.
    long = settle.Rehearsed(search=b.population * st.optimize.stall, polish=0, angles=r.angles, complete=False)
    on = plan.estimate(st, workers=0, calibration=p.calibration, bowl=p.bowl, rehearsal=long)
    assert on.seconds == on.seconds_most and on.expected_variants == b.candidates * b.samples
    short = dataclasses.replace(long, search=b.population * st.optimize.stall - 1)
    assert plan.estimate(st, workers=0, calibration=p.calibration, bowl=p.bowl, rehearsal=short).seconds < on.seconds
    monkeypatch.setattr(settle, "REHEARSAL_SECONDS", 2.0)
    monkeypatch.setattr(plan, "WIDE", math.inf)  # bounds never too far apart: no rehearsal
    assert plan.estimate(st, workers=0, calibration=p.calibration, bowl=p.bowl).rehearsal is None
