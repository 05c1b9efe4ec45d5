"""A robust optimization's operating conditions: a [[parameter]] with a tolerance and no range
is held at the file's value, deviated over the robust samples and never searched (docs/studies.md,
Robust designs). The expected values are computed here from the documented sampling (numpy's
PCG64, a stream of the conditions' own) and from plain evaluations of each sample's design."""

from __future__ import annotations

import json
import tomllib
from pathlib import Path

import numpy as np
import pytest

from mjlink import study as api
from mjlink.study import optimize
from mjlink.study.spec import StudyFileError, parse

ROOT = Path(__file__).resolve().parent.parent
CRANK_ROCKER = ROOT / "mechanisms" / "examples" / "crank_rocker.toml"

# The crank pin's miss of a target on its circle, the crank's length searched; the crank's
# pivot, moved along x by up to 0.5 mm, is a condition the design must meet.
BODY = """
[optimize]
objective = "path_error_B"
population = 8
generations = 4
seed = 3
polish_evaluations = 0
[robust]
samples = 6
k = 2.0
seed = 21
[[parameter]]
path = "construct.B.length"
range = [8.0, 20.0]
tolerance = 0.05
[[parameter]]
path = "ground.A.x"
tolerance = 0.5
[[metric]]
kind = "path_error"
point = "B"
targets = [[6.0, 10.392304845413264]]
"""


def _study(body: str = BODY):
    return parse(f'[study]\nmechanism = "{CRANK_ROCKER}"\nname = "t"\nangles = 72\n' + body)


def test_a_parameter_with_a_tolerance_and_no_range_is_a_condition_not_searched():
    st = _study()
    assert [v.param.path for v in st.varied] == ["construct.B.length"]
    assert [v.param.path for v in st.conditions] == ["ground.A.x"]
    assert st.conditions[0].param.nominal == 0.0 and st.conditions[0].tolerance == 0.5


def test_the_conditions_are_drawn_from_a_stream_of_their_own():
    """Adding a condition leaves the searched parameters' deviations as they were; the
    condition's are uniform over +-tolerance from PCG64 seeded by SeedSequence([seed, 1])."""
    st = _study()
    alone = _study(BODY.replace('[[parameter]]\npath = "ground.A.x"\ntolerance = 0.5\n', ""))
    assert alone.conditions == ()
    dev = optimize.deviations(st)
    assert dev.shape == (6, 2)
    assert np.array_equal(dev[:, :1], optimize.deviations(alone))
    rng = np.random.Generator(np.random.PCG64(np.random.SeedSequence([21, 1])))
    assert np.array_equal(dev[:, 1], rng.uniform(-1.0, 1.0, size=(6, 1))[:, 0] * 0.5)
    # The searched parameter's own draw: PCG64 from the robust seed itself.
    assert np.array_equal(dev[:, 0], np.random.Generator(np.random.PCG64(21)).uniform(-1, 1, (6, 1))[:, 0] * 0.05)


def test_a_candidate_is_scored_over_the_condition_as_plain_evaluations_of_each_sample():
    st = _study()
    x = np.array([[12.0], [12.4]])
    dev = optimize.deviations(st)
    with optimize.Evaluator(st) as ev:
        s = ev.score(x)
        nominal = ev.score(x, robust=False)
    mets = [{"kind": "path_error", "point": "B", "targets": [[6.0, 10.392304845413264]]}]
    mech = api.mechanism(CRANK_ROCKER)
    for i, r in enumerate(x[:, 0]):
        got = api.evaluate(
            mech, {"construct.B.length": r + dev[:, 0], "ground.A.x": 0.0 + dev[:, 1]}, mets, per_turn=72
        )
        e = got.columns["path_error_B"]
        assert s.objective[i] == pytest.approx(e.mean() + 2.0 * e.std(ddof=1), rel=1e-12, abs=1e-15)
        plain = api.evaluate(mech, {"construct.B.length": [r]}, mets, per_turn=72).columns["path_error_B"][0]
        assert nominal.objective[i] == pytest.approx(plain, rel=1e-12, abs=1e-15)
    # The pivot's shift is felt: 12 mm misses nothing at the file's pivot, but not over the samples.
    assert nominal.objective[0] == pytest.approx(0.0, abs=1e-9) and s.objective[0] > 0.1


def test_the_winner_keeps_the_condition_at_the_files_value_and_the_report_names_it(tmp_path):
    from mjlink.pipeline import optimize as pipe

    out = pipe.run(_study(), tmp_path, workers=0, plots=False, progress=False)
    raw = tomllib.loads(Path(out.winner_file).read_text())
    assert raw["ground"]["A"] == [0.0, 0.0]
    assert len(out.result.winner) == 1
    summary = json.loads((out.out_dir / "summary.json").read_text())
    (held,) = summary["conditions"]
    assert held.pop("samples") == (0.0 + optimize.deviations(out.result.study)[:, 1]).tolist()
    assert held == {
        "path": "ground.A.x",
        "unit": "mm",
        "nominal": 0.0,
        "tolerance": 0.5,
        "distribution": "uniform",
        "levels": None,
    }
    assert [p["path"] for p in summary["parameters"]] == ["construct.B.length"]
    said = "ground.A.x = 0 +- 0.5 mm"
    assert said in (out.out_dir / "index.html").read_text()
    assert said in Path(out.winner_file).read_text().split("[mechanism]")[0]
    from mjlink.cli import text

    assert said in text.optimization(out)


@pytest.mark.parametrize(
    ("change", "match"),
    [
        # Without [robust] nothing deviates.
        (("[robust]\nsamples = 6\nk = 2.0\nseed = 21\n", ""), "tolerance: applies to a robust optimization"),
        (
            ('path = "ground.A.x"\ntolerance = 0.5\n', 'path = "ground.A.x"\n'),
            "or, in a robust optimization, only a 'tolerance'",
        ),
        (
            ('[[parameter]]\npath = "construct.B.length"\nrange = [8.0, 20.0]\ntolerance = 0.05\n', ""),
            "at least one \\[\\[parameter\\]\\] with a 'range'",
        ),
    ],
)
def test_conditions_misused_are_one_line_errors(change, match):
    with pytest.raises(StudyFileError, match=match) as e:
        _study(BODY.replace(*change))
    assert "\n" not in str(e.value)


def test_an_even_condition_takes_every_sample_evenly_over_its_band_ends_included():
    """distribution = "even": the samples' values are -tol, ..., +tol evenly spaced, each once,
    in an order drawn from the conditions' stream; the uniform draws before it stay as they were."""
    st = _study(BODY.replace("tolerance = 0.5\n", 'tolerance = 0.5\ndistribution = "even"\n'))
    dev = optimize.deviations(st)
    assert np.array_equal(np.sort(dev[:, 1]), np.linspace(-0.5, 0.5, 6))
    assert not np.array_equal(dev[:, 1], np.linspace(-0.5, 0.5, 6))  # in a drawn order, not sorted
    assert np.array_equal(dev[:, 0], optimize.deviations(_study())[:, 0])
    rng = np.random.Generator(np.random.PCG64(np.random.SeedSequence([21, 1])))
    rng.uniform(-1.0, 1.0, size=(6, 1)), rng.standard_normal(size=(6, 1))
    assert np.array_equal(dev[:, 1], rng.permutation(np.linspace(-1.0, 1.0, 6)) * 0.5)


CROSSED = BODY.replace(
    'path = "ground.A.x"\ntolerance = 0.5\n',
    'path = "ground.A.x"\ntolerance = 0.5\nlevels = 3\n[[parameter]]\npath = "ground.A.y"\ntolerance = 0.2\nlevels = 2\n',
).replace("samples = 6", "samples = 12")


def test_conditions_with_levels_are_crossed_every_combination_a_sample():
    """levels: each condition's values evenly over its band, ends included, every combination
    once (the first condition slowest), repeated whole to the samples; nothing drawn for them,
    and the searched parameter's draws are those of the study without the conditions."""
    st = _study(CROSSED)
    assert [(v.param.path, v.levels, v.distribution) for v in st.conditions] == [
        ("ground.A.x", 3, "even"),
        ("ground.A.y", 2, "even"),
    ]
    dev = optimize.deviations(st)
    once = [[x, y] for x in (-0.5, 0.0, 0.5) for y in (-0.2, 0.2)]
    assert np.allclose(dev[:, 1:], np.array(once + once), rtol=0, atol=1e-15)
    alone = _study(BODY.replace('[[parameter]]\npath = "ground.A.x"\ntolerance = 0.5\n', "").replace("= 6", "= 12"))
    assert np.array_equal(dev[:, :1], optimize.deviations(alone))


def test_crossed_conditions_are_named_with_their_levels(tmp_path):
    from mjlink.pipeline import optimize as pipe

    rows = pipe.conditions(_study(CROSSED))
    assert [r["levels"] for r in rows] == [3, 2]
    assert rows[1]["samples"] == [-0.2, 0.2] * 6
    assert pipe.conditions_text(rows) == (
        "ground.A.x = 0 +- 0.5 mm (3 levels, ends included, crossed), "
        "ground.A.y = 0 +- 0.2 mm (2 levels, ends included, crossed)"
    )


@pytest.mark.parametrize(
    ("change", "match"),
    [
        (("samples = 12", "samples = 8"), r"samples: must be a multiple of the conditions' 3 x 2 = 6 combinations"),
        (("levels = 2\n", ""), r"\(ground.A.y\): needs 'levels' as well"),
        (("levels = 3\n", 'levels = 3\ndistribution = "normal"\n'), "levels: spaces the values evenly"),
        (("levels = 3\n", "levels = 1\n"), "levels: must be an integer from 2"),
        (("tolerance = 0.05\n", "tolerance = 0.05\nlevels = 2\n"), "levels: applies to an operating condition"),
    ],
)
def test_levels_misused_are_one_line_errors(change, match):
    assert change[0] in CROSSED
    with pytest.raises(StudyFileError, match=match) as e:
        _study(CROSSED.replace(*change, 1))
    assert "\n" not in str(e.value)


def test_the_shipped_tension_study_takes_the_needle_tensions_the_head_is_set_to():
    """studies/lockstitch_head_takeup_band.toml: the needle tension a condition over the
    tension study's 1.0, 1.6 and 2.2 N band, evenly, its ends included; the dimensions searched
    are the slack-bounded study's eight."""
    from mjlink.model.catalogue import shipped

    st = api.spec.load(shipped("studies") / "lockstitch_head_takeup_band.toml")
    grid = tomllib.loads((shipped("studies") / "lockstitch_head_tension.toml").read_text())
    band = next(p["values"] for p in grid["parameter"] if p["path"] == "tension.needle_tension")
    (c,) = st.conditions
    assert c.param.path == "tension.needle_tension" and c.distribution == "even"
    tensions = np.sort(c.param.nominal + optimize.deviations(st)[:, -1])
    assert tensions[0] == pytest.approx(min(band), abs=1e-12) and tensions[-1] == pytest.approx(max(band), abs=1e-12)
    assert c.param.nominal == pytest.approx(float(np.median(band)), abs=1e-12)
    loop = api.spec.load(shipped("studies") / "lockstitch_head_takeup_peak_loop.toml")
    assert [v.param.path for v in st.varied] == [v.param.path for v in loop.varied]


def test_a_condition_set_by_the_study_is_held_at_the_set_value():
    st = _study('[set]\n"ground.A.x" = 0.3\n' + BODY)
    assert st.conditions[0].param.nominal == 0.3
    with optimize.Evaluator(st) as ev:
        rows = ev.samples(np.array([[12.0]]))
    assert np.array_equal(rows[:, 1], 0.3 + optimize.deviations(st)[:, 1])


def test_a_pareto_front_is_judged_over_the_condition():
    """A two-objective study with a condition: each front design's columns are the mean + k std
    of plain evaluations at its values and each sample's deviations, the condition's included."""
    body = """
[optimize]
pareto = ["stroke_E", "transmission_min"]
points = 3
population = 8
generations = 3
seed = 2
polish_evaluations = 0
[robust]
samples = 4
[[parameter]]
path = "construct.B.length"
range = [12.0, 16.0]
tolerance = 0.05
[[parameter]]
path = "ground.A.x"
tolerance = 0.5
distribution = "even"
[[metric]]
kind = "stroke"
point = "E"
[[metric]]
kind = "transmission_min"
"""
    st = _study(body)
    res = optimize.run(st)
    assert res.front is not None and res.front_columns is not None
    dev = optimize.deviations(st)
    mets = [{"kind": "stroke", "point": "E"}, {"kind": "transmission_min"}]
    mech = api.mechanism(CRANK_ROCKER)
    for i, x in enumerate(res.front):
        e = api.evaluate(mech, {"construct.B.length": x[0] + dev[:, 0], "ground.A.x": dev[:, 1]}, mets, per_turn=72)
        for c in ("stroke_E", "transmission_min"):
            a = e.columns[c]
            assert res.front_columns[c][i] == pytest.approx(a.mean() + 2.0 * a.std(ddof=1), rel=1e-12)
