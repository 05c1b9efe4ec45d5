"""Optimal synthesis (``[optimize]`` studies): known optima, constraints, determinism, robust
mode, the Pareto front, the winner file's round trip through check and simulate."""

from __future__ import annotations

import math
import tomllib
from pathlib import Path

import numpy as np
import pytest
from documented import THRESHOLDS as LIMIT

from mjlink import study as api
from mjlink import validation
from mjlink.model import paths
from mjlink.reference import synthesis
from mjlink.study import optimize, spec
from mjlink.study.spec import StudyFileError, parse

ROOT = Path(__file__).resolve().parent.parent
CRANK_ROCKER = ROOT / "mechanisms" / "examples" / "crank_rocker.toml"


def _study(body: str, mechanism: str | Path = CRANK_ROCKER, angles: int = 72):
    return parse(f'[study]\nmechanism = "{mechanism}"\nname = "t"\nangles = {angles}\n' + body)


# A target on the crank pin's circle (radius 12 mm, at a sampled crank angle): the crank length
# that puts the pin's path through it is 12 mm exactly, with a miss of 0; the rocker pivot's x
# does not move the pin and must not disturb the search.
CIRCLE = """
[optimize]
objective = "path_error_B"
population = 20
generations = 120
seed = 7
tol = 0
atol = 1e-10
[[parameter]]
path = "construct.B.length"
range = [8.0, 20.0]
[[parameter]]
path = "ground.D.x"
range = [46.0, 54.0]
[[metric]]
kind = "path_error"
point = "B"
targets = [[6.0, 10.392304845413264]]
"""


def test_known_optimum_is_found():
    res = optimize.run(_study(CIRCLE))
    # The circle's radius to the target, 12 mm, and no miss: measured within 1e-13 mm of both.
    assert res.winner[0] == pytest.approx(12.0, abs=1e-9)
    assert res.objective == pytest.approx(0.0, abs=1e-9)
    assert res.runs[0].history[-1][2] == pytest.approx(res.objective)


# A short search and polish where the property is how the result is reached (the same bits
# from the same seed, on any engine, into any file), not how close it comes to the optimum.
SHORT = {"generations = 120": "generations = 15", "[optimize]\n": "[optimize]\npolish_evaluations = 60\n"}


def _short(body: str, **more: str) -> str:
    for a, b in {**SHORT, **more}.items():
        body = body.replace(a, b)
    return body


def test_seeded_runs_are_identical_and_engine_independent():
    st = _study(_short(CIRCLE))
    a, b = optimize.run(st), optimize.run(st)
    assert np.array_equal(a.winner, b.winner)
    assert np.array_equal(a.archive.values, b.archive.values)
    assert np.array_equal(a.archive.objective, b.archive.objective)
    # Cut into other chunks (as on a cluster of 3 workers): the same bits.
    c = optimize.run(st, workers=3)
    assert np.array_equal(a.winner, c.winner) and np.array_equal(a.archive.objective, c.archive.objective)
    other = optimize.run(_study(_short(CIRCLE, **{"seed = 7": "seed = 8"})))
    assert not np.array_equal(a.archive.values, other.archive.values)


# The head height (A to the needle-bar joint C) falls as lambda = r/l grows; the pressure-angle
# limit caps lambda at what synth finds: the constrained optimum sits on the limit.


def largest_admissible_ratio(stroke: float, offset: float, limit_deg: float) -> float:
    """The crank-slider's lambda = r/l at which its largest pressure angle asin((r + e) / l)
    reaches ``limit_deg`` for the stroke S = sqrt((l + r)^2 - e^2) - sqrt((l - r)^2 - e^2), in
    closed form and plain root finding (the textbook relations; nothing of mjlink)."""
    from scipy.optimize import brentq

    def angle(lam: float) -> float:
        def miss(r: float) -> float:
            l = r / lam
            return math.sqrt((l + r) ** 2 - offset**2) - math.sqrt((l - r) ** 2 - offset**2) - stroke

        r = brentq(miss, offset / (1 / lam - 1) * (1 + 1e-9), 10 * stroke, xtol=1e-15)
        return math.degrees(math.asin((r + offset) / (r / lam)))

    return brentq(lambda lam: angle(lam) - limit_deg, 0.2, 0.5, xtol=1e-14)


# The crank_slider's synthesis: stroke 45 mm, offset 15 mm, [theta] = 40 deg (docs/mechanisms.md).
LAMBDA_40 = largest_admissible_ratio(45.0, 15.0, 40.0)
HEAD = """
[optimize]
objective = "distance_A_C"
population = 16
generations = 80
seed = 1
tol = 0
atol = 1e-9
[[parameter]]
path = "synthesis.lambda"
range = [0.2, 0.6]
[[metric]]
kind = "distance"
points = ["A", "C"]
[[metric]]
kind = "pressure_max"
[[bound]]
metric = "pressure_max"
max = 40.0
"""


def test_constraint_is_active_and_never_violated():
    st = _study(HEAD, "crank_slider", 360)
    res = optimize.run(st)
    lam = res.winner[0]
    assert res.columns["pressure_max"] <= 40.0
    # On the limit: the closed form's bound, measured within 1e-8 in lambda, 5e-10 deg.
    assert res.columns["pressure_max"] == pytest.approx(40.0, abs=1e-6)
    assert lam == pytest.approx(LAMBDA_40, abs=1e-6)
    # synth's largest admissible lambda on its 0.01 grid is the closed form's, rounded down
    # (docs/mechanisms.md: 0.37), and on a 0.001 grid the same.
    assert synthesis.largest_ratio(0.045, 0.015, math.radians(40.0)) == math.floor(LAMBDA_40 * 100) / 100 == 0.37
    assert synthesis.largest_ratio(0.045, 0.015, math.radians(40.0), step=1e-3) == pytest.approx(
        math.floor(LAMBDA_40 * 1000) / 1000, abs=1e-12
    )
    feasible = res.archive.violation <= 0
    assert res.objective == pytest.approx(res.archive.objective[feasible].min())
    assert res.objective > np.nanmin(res.archive.objective[~feasible])  # infeasible ones went lower


def test_nothing_feasible_is_an_error_not_a_design():
    st = _study(
        HEAD.replace("max = 40.0", "max = 5.0").replace("generations = 80", "generations = 3"), "crank_slider", 72
    )
    with pytest.raises(optimize.OptimizeError, match=r"no feasible design.*pressure_max <= 5"):
        optimize.run(st)


def test_robust_winner_keeps_a_margin_the_nominal_one_lacks():
    robust = HEAD.replace("range = [0.2, 0.6]", "range = [0.2, 0.6]\ntolerance = 0.01").replace(
        "[[parameter]]", "[robust]\nsamples = 8\nk = 2.0\n\n[[parameter]]", 1
    )
    # A shorter search and polish than HEAD's: the margin asked (0.002 in lambda) is far above
    # what they leave unsettled (the winners move by less than 1e-7 between the two budgets).
    short = {"generations = 80": "generations = 40", "[optimize]\n": "[optimize]\npolish_evaluations = 100\n"}
    nominal_st = _study(_short(HEAD, **short), "crank_slider", 72)
    robust_st = _study(_short(robust, **short), "crank_slider", 72)
    nom, rob = optimize.run(nominal_st), optimize.run(robust_st)
    assert rob.winner[0] < nom.winner[0] - 0.002
    # Judged under the tolerances, the nominal optimum fails the bound; the robust one holds it.
    ev = optimize.Evaluator(robust_st)
    s = ev.score(np.stack([nom.winner, rob.winner]))
    assert s.violation[0] > 0 and s.violation[1] == 0


def test_pareto_front_of_the_crank_slider():
    body = """
[optimize]
pareto = ["accel_peak_C", "distance_A_C"]
points = 4
population = 12
generations = 25
seed = 2
polish_evaluations = 100
[[parameter]]
path = "synthesis.lambda"
range = [0.15, 0.5]
[[metric]]
kind = "acceleration_peak"
point = "C"
[[metric]]
kind = "distance"
points = ["A", "C"]
[[metric]]
kind = "pressure_max"
[[bound]]
metric = "pressure_max"
max = 40.0
"""
    res = optimize.run(_study(body, "crank_slider", 180))
    assert res.front is not None and res.front_columns is not None
    a, d = res.front_columns["accel_peak_C"], res.front_columns["distance_A_C"]
    assert len(a) >= 3 and np.all(np.diff(a) > 0) and np.all(np.diff(d) < 0)  # a trade-off, sorted
    assert np.all(res.front_columns["pressure_max"] <= 40.0)
    assert any(np.array_equal(res.winner, x) for x in res.front)
    # The low-head end is the pressure-angle limit: lambda there is the closed form's bound
    # (measured within 1e-7).
    assert res.front[-1, 0] == pytest.approx(LAMBDA_40, abs=1e-6)


def test_winner_file_round_trips_through_check_and_simulate(tmp_path):
    from mjlink import pipeline
    from mjlink.pipeline import optimize as pipe

    st = _study(_short(CIRCLE))
    out = pipe.run(st, tmp_path, workers=0, plots=False, progress=False)
    assert out.verified.passed.all()
    text = out.winner_file.read_text()
    assert text.startswith("# winner of the optimization study 't'")
    # The winner judged by the circle itself, from the file's own numbers (tomllib): its
    # crank's pin misses the target by |AT - r| (the target at a sampled crank angle), as the
    # optimizer reported, and the short search comes within 2e-5 mm (measured 1.1e-5).
    raw = tomllib.loads(text)
    r = next(b["length"] for b in raw["construct"] if b["point"] == "B")
    miss = abs(math.dist(raw["ground"]["A"][:2], (6.0, 10.392304845413264)) - r)
    assert miss <= 2e-5 and out.result.objective == pytest.approx(miss, rel=1e-9)
    assert 46.0 <= raw["ground"]["D"][0] <= 54.0
    mech = validation.get(out.winner_file)
    assert mech.name == "t_winner"
    assert mech.input_crank.length == pytest.approx(r * 1e-3, rel=1e-15)
    report = validation.check(mech)
    assert report.ok
    res = pipeline.run(mech, tmp_path / "sim", pipeline.Options(dynamics=True, plots=False, video=False, loads=True))
    assert not res.failures
    assert res.agreements[0].position_um <= LIMIT["position_um"]  # the kinematic run: as the nominal file


def test_file_text_writes_every_kind_of_path(tmp_path):
    mech = api.mechanism("takeup_eyelets")
    values = {
        "ground.P4.x": -36.5,
        "ground.P1.z": 1.5,  # a 2-D point gains a z
        "construct.P5.angle": 185.0,
        "construct.P6.z": -7.0,
        "links.coupler.mass": 13.0,
        "input.phi0": 12.0,
        "thread.elongation": 5.0,
        "dynamics.motor.stall_torque": 0.07,
        "dynamics.force.P5.scale": 2.0,
        "counterweight.mass": 3.0,
        "counterweight.angle": 170.0,
    }
    vals = {paths.resolve(mech, k): v for k, v in values.items()}
    f = tmp_path / "w.toml"
    f.write_text(paths.file_text(mech, vals, "a test", name="w"))
    got = validation.get(f, full_turn=False)
    want = paths.apply(mech, vals)
    cat_got, cat_want = paths.catalogue(got), paths.catalogue(want)
    for k in cat_want:
        if not k.startswith("dynamics.force"):
            assert cat_got[k].nominal == pytest.approx(cat_want[k].nominal, rel=1e-14, abs=1e-14), k
    raw = tomllib.loads(f.read_text())
    assert raw["dynamics"]["force"][0]["values"][1] == [0.0, -4.0, 0.0]
    assert got.name == "w"


@pytest.mark.parametrize(
    ("body", "match"),
    [
        ("[sampling]\nmethod = 'grid'\n[optimize]\nobjective = 'path_error_B'\n", "no \\[sampling\\]"),
        ("[optimize]\nobjective = 'path_eror_B'\n", "did you mean 'path_error_B'"),
        ("[optimize]\nobjective = 'path_error_B'\npareto = ['a', 'b']\n", "either 'objective'"),
        ("[optimize]\nobjective = 'path_error_B'\n[robust]\nsamples = 4\n", "needs a 'tolerance'"),
        ("[robust]\nsamples = 4\n", "add an \\[optimize\\] table"),
        ("[optimize]\nobjective = 'path_error_B'\nsense = 'down'\n", "'min' or 'max'"),
        ("[optimize]\nobjective = 'path_error_B'\n[verify]\nmujoco = 'all'\n", "verifies its winner"),
        ("[set]\n'ground.Q.x' = 1.0\n[optimize]\nobjective = 'path_error_B'\n", "unknown parameter path"),
        ("[optimize]\nobjective = 'path_error_B'\nstart = 'middle'\n", "start: must be one of sample, file"),
        (
            "[set]\n'construct.B.length' = 7.0\n[optimize]\nobjective = 'path_error_B'\nstart = 'file'\n",
            "construct.B.length is 7 there, outside its range \\[8, 20\\]",
        ),
    ],
)
def test_bad_optimize_tables_are_one_line_errors(body, match):
    rest = """
[[parameter]]
path = "construct.B.length"
range = [8.0, 20.0]
[[metric]]
kind = "path_error"
point = "B"
targets = [[6.0, 10.0]]
"""
    with pytest.raises(StudyFileError, match=match) as e:
        _study(body + rest)
    assert "\n" not in str(e.value)


def test_optimize_needs_ranges():
    with pytest.raises(StudyFileError, match="needs 'range'"):
        _study(
            "[optimize]\nobjective = 'path_error_B'\n[[parameter]]\npath = 'construct.B.length'\n"
            "[[metric]]\nkind = 'path_error'\npoint = 'B'\ntargets = [[6.0, 10.0]]\n"
        )


def test_infeasible_rows_do_not_touch_feasible_ones():
    """Kinematic metrics are computed on the batch as it is (no safe stand-in for the rows that
    do not assemble): a feasible variant's numbers are the same bits as on its own."""
    mech = api.mechanism(CRANK_ROCKER)
    lengths = np.array([15.0, 30.0, 14.0, 40.0, 16.0])  # a crank of 30 or 40 mm cannot turn
    mets = [
        {"kind": "stroke", "point": "E"},
        {"kind": "dwell", "point": "E", "within": 0.5},
        {"kind": "transmission_min"},
    ]
    all_rows = api.evaluate(mech, {"construct.B.length": lengths}, mets)
    assert list(all_rows.feasible) == [True, False, True, False, True]
    alone = api.evaluate(mech, {"construct.B.length": lengths[all_rows.feasible]}, mets)
    for c, v in all_rows.columns.items():
        assert np.array_equal(v[all_rows.feasible], alone.columns[c]), c
        assert np.all(np.isnan(v[~all_rows.feasible]))


def test_winner_name_of_a_long_study_name_is_valid(tmp_path):
    from mjlink.pipeline import optimize as pipe

    body = _short(CIRCLE, **{"generations = 120": "generations = 3"})
    st = parse(
        f'[study]\nmechanism = "{CRANK_ROCKER}"\nname = "a_rather_long_study_name_for_sur"\nangles = 72\n' + body
    )
    out = pipe.run(st, tmp_path, workers=0, plots=False, progress=False)
    assert validation.get(out.winner_file).name == "a_rather_long_study_name_winner"


def test_the_winners_duplicate_key_is_the_first_rounding():
    """choose() tells candidates apart by their nearest rounding alone (winner._nearest): the
    first row of the full set of roundings (rounded_candidates), inside and outside the ranges."""
    from mjlink.pipeline import winner

    st = spec.load("known_feed_takeup_eyelets")
    lo, hi = np.array([v.low for v in st.varied]), np.array([v.high for v in st.varied])
    for x in lo + (hi - lo) * np.random.default_rng(1).uniform(-0.05, 1.05, (500, len(lo))):
        assert np.array_equal(winner._nearest(st, x), winner.rounded_candidates(st, x)[0])


def test_an_objective_at_another_speed_than_the_files_is_named_with_the_command_that_shows_it():
    """studies/takeup_counterweight.toml minimizes the shaking at 5,000 rpm of a file run at
    955 rpm: the summary names that speed, and the command line's option for it (a clockwise
    speed written with '=', which its minus sign needs); a study whose objective is at the
    file's speed names none."""
    from mjlink.pipeline.optimize import objective_speed_rpm, speed_option
    from mjlink.study import spec

    root = Path(__file__).resolve().parent.parent / "studies"
    # rel 1e-4: the study writes 523.6 rad/s, which is 5,000 rpm to four digits (4999.99)
    assert objective_speed_rpm(spec.load(root / "takeup_counterweight.toml")) == pytest.approx(5000.0, rel=1e-4)
    assert objective_speed_rpm(spec.load(root / "known_path_crank_rocker.toml")) is None
    assert speed_option(5000.0) == "--speed 5000rpm"
    assert speed_option(-5000.0) == "--speed=-5000rpm"


def test_a_front_drops_a_design_equal_but_for_rounding_in_one_objective_and_worse_in_the_other():
    """The robust NBTTL study's case: the lever's velocity ratio does not depend on the needle's
    link, so two designs differing only there have ratios equal but for rounding (1e-16) and
    different jerks: the one with more jerk is dominated, not a second front point."""
    jerk = np.array([2.779e6, 2.801e6, 2.70e6, 2.779e6])
    ratio = np.array([1.193145288500862, 1.193145288500862 - 2e-16, 1.30, 1.193145288500862])
    keep = optimize._nondominated(jerk, ratio)
    assert keep.tolist() == [True, False, True, False]  # the exact duplicate (last) keeps its first


def test_a_search_started_from_the_file_holds_its_design_first_and_reports_nothing_worse():
    """start = 'file': each run's first candidate is the mechanism file's design, the rest its
    sample. Here the target lies on the file's own crank-pin circle (15 mm, at 60 deg): the
    file's design misses it by nothing. On a budget too small to find it from a sample, the
    search from the sample alone reports a worse design; the one started from the file keeps
    it."""
    body = _short(
        CIRCLE,
        **{
            "population = 20": "population = 5",
            "generations = 120": "generations = 1",
            "[optimize]\n": "[optimize]\npolish_evaluations = 0\nseeds = 2\n",
            "targets = [[6.0, 10.392304845413264]]": "targets = [[7.5, 12.99038105676658]]",
        },
    )
    sampled = optimize.run(_study(body))
    started = optimize.run(_study(body.replace("[optimize]\n", "[optimize]\nstart = 'file'\n")))
    file_design = np.array([15.0, 50.0])  # mechanisms/examples/crank_rocker.toml: B's length, D's x
    for run in (0, 1):
        first = np.flatnonzero((started.archive.run == run) & (started.archive.generation == 0))[0]
        assert np.array_equal(started.archive.values[first], file_design)
    assert not np.any(np.all(sampled.archive.values == file_design, axis=1))
    assert started.file_objective == pytest.approx(0.0, abs=1e-9)  # mm
    assert started.objective <= started.file_objective
    assert np.array_equal(started.winner, file_design)
    assert sampled.objective > 0.01  # mm: the sample alone found worse
