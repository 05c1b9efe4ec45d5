"""Crank-slider synthesis (seed 002): the paper's table, the largest lambda, and --write."""

import math

import numpy as np
import pytest

from mjlink import validation
from mjlink.errors import MjlinkError
from mjlink.model import catalogue as registry
from mjlink.model import synthesis as quartic
from mjlink.model.mechanism import Crank, Slider, parse
from mjlink.reference import synthesis

TH = math.radians(40)


def test_reproduces_the_papers_table():
    roots = synthesis.roots(0.045, 0.015, 0.35, TH)
    real = [r for r in roots if r.reason != "complex" and r.l.real > 0]
    (a, b) = sorted(real, key=lambda r: -r.l.real)
    assert (round(a.r.real * 1e3, 1), round(a.l.real * 1e3, 1), round(math.degrees(a.theta_max), 1)) == (
        21.7,
        62.1,
        36.3,
    )
    assert a.accepted and abs(a.stroke - 0.045) < 1e-12
    assert (round(b.r.real * 1e3, 1), round(b.l.real * 1e3), round(math.degrees(b.theta_max), 1)) == (9.8, 28, 62.3)
    assert not b.accepted and "theta_max 62.3 > 40" in b.reason
    assert len(roots) == 4  # the quartic's four roots, the negative pair rejected
    assert sum(r.accepted for r in roots) == 1


def test_largest_admissible_lambda_is_not_the_papers_045():
    assert synthesis.largest_ratio(0.045, 0.015, TH) == 0.37
    # The paper's claim fails its own criterion:
    assert math.degrees(synthesis.roots(0.045, 0.015, 0.45, TH)[0].theta_max) > 50


def test_registered_file_is_root_one():
    mech = validation.get("crank_slider")
    syn = mech.synthesis
    best = synthesis.best(syn.stroke, syn.offset, syn.ratio, syn.max_pressure_angle)
    crank = next(s for s in mech.steps if isinstance(s, Crank))
    slider = next(s for s in mech.steps if isinstance(s, Slider))
    assert abs(crank.length - best.r.real) < 1e-15 and abs(slider.length - best.l.real) < 1e-15
    assert abs(mech.ground[slider.guide[0]][1] + syn.offset) < 1e-15


def test_design_file_round_trips():
    base = registry.path_of("crank_slider").read_text()
    text = synthesis.design_file(base, 0.05, 0.01, 0.3, TH, "wide_stroke")
    mech = validation.validate(parse(text, "wide_stroke.toml"))
    crank = next(s for s in mech.steps if isinstance(s, Crank))
    slider = next(s for s in mech.steps if isinstance(s, Slider))
    assert abs(synthesis.stroke_of(crank.length, slider.length, 0.01) - 0.05) < 1e-12
    assert mech.name == "wide_stroke"


def test_no_admissible_design_is_an_error():
    with pytest.raises(MjlinkError, match="no admissible design"):
        synthesis.design_file(registry.path_of("crank_slider").read_text(), 0.045, 0.015, 0.6, TH, "x")


def test_the_closed_form_quartic_is_numpys_roots():
    """The synthesis quartic solved as a quadratic in l^2 against its plain twin, numpy's
    general polynomial roots, over random strokes, offsets and ratios (real and complex roots)."""
    rng = np.random.default_rng(5)
    for S, e, lam in zip(rng.uniform(0.005, 0.1, 500), rng.uniform(0.0, 0.05, 500), rng.uniform(0.01, 0.99, 500)):
        twin = np.roots([4 * lam**2 / S**2, 0.0, 2 * lam - (1 + lam) ** 2, 0.0, S**2 / 4 + e**2])
        got = quartic._quartic_roots(S, e, lam)
        for z in twin:
            assert min(abs(z - g) for g in got) <= 1e-12 * abs(z), (S, e, lam)


def test_a_studys_re_synthesis_is_its_per_variant_twin(monkeypatch):
    """A study varying the synthesis inputs: the numbers re-synthesized from r and l alone (the
    fast path of reference.batch) against each variant built whole (paths.apply, then the
    catalogue's numbers), bit for bit, with admissible, inadmissible and invalid variants and a
    plain parameter beside them; a plain parameter the synthesis sets forces the whole variant."""
    from mjlink.model import paths
    from mjlink.reference import batch

    mech = validation.get("crank_slider")
    cat = paths.catalogue(mech)
    crank_len = f"construct.{mech.input_crank.point}.length"
    params = [cat["synthesis.stroke"], cat["links.crank.mass" if "links.crank.mass" in cat else "input.speed"]]
    params += [cat["synthesis.lambda"], cat["synthesis.offset"]]
    rng = np.random.default_rng(3)
    V = 200
    values = np.column_stack(
        [
            rng.uniform(0.5, 1.5, V) * params[0].nominal,
            rng.uniform(0.5, 1.5, V) * params[1].nominal,
            rng.uniform(0.05, 0.9, V),
            rng.uniform(0.0, 30.0, V),
        ]
    )
    values[3, 0] = -1.0  # invalid: a negative stroke
    fast = batch._expanded(mech, list(params), values.copy())
    monkeypatch.setattr(batch, "_resynthesized", lambda *a: None)
    whole = batch._expanded(mech, list(params), values.copy())
    assert fast[2] == whole[2] and any(fast[2]) and "no crank-slider has stroke" in "".join(fast[2])
    assert sum(not r for r in fast[2]) >= V // 4, "too few admissible variants to compare"
    ok = np.array([not r for r in fast[2]])  # solve_batch puts the nominal into invalid rows
    got = {p.path: fast[1][ok, j] for j, p in enumerate(fast[0])}
    for j, p in enumerate(whole[0]):
        assert np.array_equal(got[p.path], whole[1][ok, j], equal_nan=True), p.path
    assert len(got) == len(whole[0]), "a parameter listed twice"
    assert {p.path for p in fast[0]} == {p.path for p in whole[0]} and crank_len in got
    monkeypatch.undo()
    plain = [cat[crank_len], cat["synthesis.lambda"]]
    assert batch._resynthesized(mech, plain, values[:, :2], [1], [0], [""] * V) is None
