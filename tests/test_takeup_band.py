"""The take-up judged over the needle tensions the head is set to (docs/head.md, The shipped
take-up, sized for the head's loop: Over the needle tensions the head is set to): the two band
studies, their winners, and the page's table of the three designs, to the digits it prints."""

from __future__ import annotations

import dataclasses
import tomllib

import numpy as np
import pytest
from threadchecks import tension_with

from mjlink import study
from mjlink.analysis.tension import needle_tension
from mjlink.analysis.timing import head_timing
from mjlink.model import mechanism, paths
from mjlink.model.catalogue import shipped
from mjlink.study import optimize, spec

HEAD = shipped("mechanisms") / "lockstitch_head.toml"
BAND_HEAD = shipped("mechanisms") / "examples" / "lockstitch_head_band.toml"
LOOP = tomllib.loads((shipped("studies") / "lockstitch_head_takeup_peak_loop.toml").read_text())
BAND = tomllib.loads((shipped("studies") / "lockstitch_head_takeup_band.toml").read_text())
BAND_300 = tomllib.loads((shipped("studies") / "lockstitch_head_takeup_band_300.toml").read_text())
BLADE = "past the hook's blade"

# docs/head.md: the winners' eight dimensions (mm, deg), as the page lists them.
EXAMPLE = {
    "construct.P2.angle": -14.99,
    "construct.P2.length": 26.09,
    "construct.P3.length_a": 62.88,
    "construct.P3.length_b": 78.53,
    "ground.P4.x": -53.30,
    "ground.P4.y": 68.57,
    "construct.P5.length": 68.90,
    "construct.P5.angle": 32.50,
}
# The band study's winner (not shipped), as its run wrote it.
BAND_WINNER = {
    "construct.P2.angle": -15.32,
    "construct.P2.length": 26.25,
    "construct.P3.length_a": 62.35,
    "construct.P3.length_b": 77.88,
    "ground.P4.x": -52.92,
    "ground.P4.y": 68.32,
    "construct.P5.length": 69.15,
    "construct.P5.angle": 32.52,
}
TENSIONS = (1.0, 1.3, 1.6, 1.9, 2.2, 2.4)  # N: the page's columns
# docs/head.md: peak (N, 2 digits); the part of the stitch the loop is slack (deg).
TABLE = {
    "shipped": [(0.54, 279.5), (1.08, 250.5), (1.75, 230.5), (2.53, 221.0), (3.03, 220.0), (3.09, 222.5)],
    "band": [(0.58, 281.0), (1.12, 253.25), (1.70, 234.5), (2.47, 222.25), (2.99, 221.5), (3.03, 224.25)],
    "example": [(0.44, 300.75), (0.92, 287.25), (1.43, 254.0), (1.83, 229.25), (1.87, 228.5), (1.93, 230.75)],
}


def test_the_band_studies_are_the_loop_study_over_the_needle_tensions_the_head_is_set_to():
    """Their files say: the loop study's metrics, bounds and budget, the needle tension a
    condition evenly over 1.0-2.2 N, the ranges +-1 deg and +-0.5 mm about the shipped head, the
    loop's bound the shipped head's slack at 1.0 N (279.5 deg), or 300 deg."""
    nominal = paths.nominal_values(mechanism.load(HEAD))
    for key in ("metric", "optimize", "robust"):
        assert BAND[key] == LOOP[key] == BAND_300[key], key
    searched = [p for p in BAND["parameter"] if "range" in p]
    assert [p["path"] for p in searched] == [p["path"] for p in LOOP["parameter"]]
    for p in searched:
        half = 1.0 if p["path"].endswith("angle") else 0.5
        assert p["range"] == pytest.approx([nominal[p["path"]] - half, nominal[p["path"]] + half], abs=1e-9)
        assert p["tolerance"] == 0.02
    assert [p for p in BAND["parameter"] if "range" not in p] == [
        {"path": "tension.needle_tension", "tolerance": 0.6, "distribution": "even"}
    ]
    assert BAND_300["parameter"] == BAND["parameter"]
    other = [b for b in LOOP["bound"] if b["metric"] != "tension_slack"]
    assert [b for b in BAND["bound"] if b["metric"] != "tension_slack"] == other
    assert [b for b in BAND_300["bound"] if b["metric"] != "tension_slack"] == other
    loop = {b["metric"]: b for b in BAND["bound"]}["tension_slack"]
    assert loop == {"metric": "tension_slack", "max": 279.5}
    assert {b["metric"]: b for b in BAND_300["bound"]}["tension_slack"] == {"metric": "tension_slack", "max": 300.0}
    # The shipped head's loop at the band's lowest tension, at the study's 720 steps.
    head = mechanism.load(HEAD)
    e = study.evaluate(head, {"tension.needle_tension": [1.0, 1.6]}, LOOP["metric"], per_turn=720)
    assert np.round(e.columns["tension_slack"], 9).tolist() == [279.5, 230.5]


def test_the_example_is_the_shipped_head_with_the_band_winners_take_up():
    head, band = paths.nominal_values(mechanism.load(HEAD)), paths.nominal_values(mechanism.load(BAND_HEAD))
    assert {k for k in head if head[k] != band[k]} == set(EXAMPLE)
    assert {k: band[k] for k in EXAMPLE} == pytest.approx(EXAMPLE, abs=1e-12)


def _design(which: str):
    head = mechanism.load(HEAD)
    if which == "shipped":
        return head
    dims = BAND_WINNER if which == "band" else EXAMPLE
    return paths.apply(head, {paths.resolve(head, k): v for k, v in dims.items()})


@pytest.fixture(scope="module")
def runs():
    out = {}
    for which in TABLE:
        m = _design(which)
        h = head_timing(m)
        out[which] = (m, h, [tension_with(m, h, needle_tension=t) for t in TENSIONS])
    return out


@pytest.mark.parametrize("which", list(TABLE))
def test_the_pages_table_over_the_band(runs, which):
    _, h, ts = runs[which]
    assert all(r.ok for r in h.rows if r.counts)
    got = [(round(t.peak, 2), round(float(t.slack.mean()) * 360.0, 2)) for t in ts]
    assert got == TABLE[which]
    assert all(t.converged for t in ts)


def test_where_the_peak_is_and_how_fast_it_grows(runs):
    """The shipped head's peak is past the hook's blade from 1.6 N up, at 251.75-254.25 deg, and
    grows 1.77 times from 1.6 to 2.4 N; the example's is below the eye at 157.25-165.75 deg from
    1.3 N up, where the take-up draws the stitch up at 1.0 N, and grows 1.35 times."""
    ship = runs["shipped"][2]
    assert all(t.peak_at[0] == BLADE for t in ship[2:])
    at = [t.peak_at[1] for t in ship[2:]]
    assert (min(at), max(at)) == (pytest.approx(251.75, abs=1e-9), pytest.approx(254.25, abs=1e-9))
    assert round(ship[-1].peak / ship[2].peak, 2) == 1.77
    band = runs["example"][2]
    assert band[0].peak_at == ("P5-N2", pytest.approx(62.75, abs=1e-9))
    assert all(t.peak_at[0] == "below NE" for t in band[1:])
    at = [t.peak_at[1] for t in band[1:]]
    assert (min(at), max(at)) == (pytest.approx(157.25, abs=1e-9), pytest.approx(165.75, abs=1e-9))
    assert round(band[-1].peak / band[2].peak, 2) == 1.35


def test_the_example_keeps_every_published_direction_and_pays_with_a_looser_loop(runs):
    m, h, ts = runs["example"]
    t = ts[2]  # the file's 1.6 N
    travel = dataclasses.replace(
        m, balance=dataclasses.replace(m.balance, check_spring_travel=m.balance.check_spring_travel + 3e-3)
    )

    def fed(length):
        f = dataclasses.replace(m, balance=dataclasses.replace(m.balance, stitch_length=length))
        return needle_tension(f, head_timing(f)).peak

    got = {
        "tighter": round(ts[-1].peak, 2),
        "travel": round(needle_tension(travel, h).peak, 2),
        "stitches": (round(fed(2e-3), 2), round(fed(4e-3), 2)),
        "stretchier": round(tension_with(m, h, elongation_at_break=0.25).peak, 2),
        "give": round(tension_with(m, h, fabric_give=0.2e-3).peak, 2),
    }
    assert got == {"tighter": 1.93, "travel": 1.71, "stitches": (0.87, 1.83), "stretchier": 1.35, "give": 1.35}
    # More pre-tension, spring travel and feed raise the peak; a stretchier thread and a fabric
    # that gives lower it (IJFTR), as on the shipped head.
    assert got["tighter"] > t.peak and got["travel"] > t.peak and got["stitches"][0] < t.peak < got["stitches"][1]
    assert got["stretchier"] < t.peak and got["give"] < t.peak
    spare = next(r for r in h.rows if r.key == "spring_spare" and r.maker is None).value
    ship = next(r for r in runs["shipped"][1].rows if r.key == "spring_spare" and r.maker is None).value
    assert (round(spare * 1e3, 2), round(ship * 1e3, 2)) == (1.47, 2.58)
    loose = [r[1] for r in TABLE["example"]]
    assert loose[2] - TABLE["shipped"][2][1] == 23.5 and loose[0] - TABLE["shipped"][0][1] == 21.25
    own = study.evaluate(m, {"construct.P5.angle": [EXAMPLE["construct.P5.angle"]]}, LOOP["metric"], per_turn=720)
    assert round(float(own.columns["eyelet_travel"][0]), 1) == 42.8
    assert round(float(own.columns["eyelet_acceleration"][0]), -1) == 10630.0


def test_the_band_objectives_the_page_gives():
    """Scored as the band studies score a design (mean + 2 std of the peak over the 8 samples):
    the shipped head 3.730, the band winner 3.628 (2.7 % below), the example 2.4689, which meets
    the 300 deg study's bounds and not the band study's loop bound."""
    band = spec.load(shipped("studies") / "lockstitch_head_takeup_band.toml")
    loose = spec.load(shipped("studies") / "lockstitch_head_takeup_band_300.toml")
    nominal = paths.nominal_values(mechanism.load(HEAD))
    rows = np.array([[{**nominal, **d}[v.param.path] for v in band.varied] for d in ({}, BAND_WINNER, EXAMPLE)])
    with optimize.Evaluator(band) as ev:
        s = ev.score(rows)
    with optimize.Evaluator(loose) as ev:
        s300 = ev.score(rows[2:])
    assert round(float(s.objective[0]), 3) == 3.730 and round(float(s.objective[1]), 3) == 3.628
    assert round(float(1 - s.objective[1] / s.objective[0]) * 100, 1) == 2.7
    assert s.violation[0] == 0 and s.violation[1] == 0 and s.violation[2] > 0
    assert round(float(s300.objective[0]), 4) == 2.4689 and s300.violation[0] == 0


# docs/head.md: the two heads over the thread's elongation at break, 10 and 15 % (peak N; loop deg).
THREADS = {
    ("shipped", 0.10): [(0.49, 293.0), (1.76, 243.0), (3.43, 228.5)],
    ("shipped", 0.15): [(0.57, 268.25), (1.74, 221.5), (2.75, 212.25)],
    ("example", 0.10): [(0.44, 308.0), (1.47, 271.0), (2.10, 234.75)],
    ("example", 0.15): [(0.44, 294.75), (1.41, 239.75), (1.74, 222.25)],
}


@pytest.mark.parametrize(("which", "elongation"), list(THREADS))
def test_the_pages_table_over_the_threads_elongation(runs, which, elongation):
    m, h, _ = runs[which]
    got = []
    for t in (1.0, 1.6, 2.2):
        r = tension_with(m, h, needle_tension=t, elongation_at_break=elongation)
        got.append((round(r.peak, 2), round(float(r.slack.mean()) * 360.0, 2)))
    assert got == THREADS[which, elongation]


def test_over_the_threads_the_example_stays_the_lower_peak_and_the_looser_loop():
    for e in (0.10, 0.15):
        ship, band = THREADS["shipped", e], THREADS["example", e]
        assert band[1][0] < ship[1][0] and band[2][0] < ship[2][0]
        assert all(b[1] > s[1] for b, s in zip(band, ship, strict=True))
    # A stiffer thread: both heads' peak at 2.2 N higher, both loops looser.
    for which in ("shipped", "example"):
        stiff, soft = THREADS[which, 0.10], THREADS[which, 0.15]
        assert stiff[2][0] > soft[2][0] and all(a[1] > b[1] for a, b in zip(stiff, soft, strict=True))


def test_both_winners_miss_their_loop_bound_at_their_own_dimensions_by_one_step():
    """docs/head.md: each winner meets its loop's bound at every sample, but at its own
    dimensions misses it at 1.0 N by one half-degree step: the caveat 'at its own dimensions'."""
    from mjlink.study import caveats

    nominal = paths.nominal_values(mechanism.load(HEAD))
    got = {}
    for name, dims in (("band", BAND_WINNER), ("band_300", EXAMPLE)):
        st = spec.load(shipped("studies") / f"lockstitch_head_takeup_{name}.toml")
        with optimize.Evaluator(st) as ev:
            got[name] = caveats._own(st, ev, np.array([{**nominal, **dims}[v.param.path] for v in st.varied]))
    assert got == {
        "band": ["with tension.needle_tension = 1 N: misses tension_slack <= 279.5 (tension_slack = 280)"],
        "band_300": ["with tension.needle_tension = 1 N: misses tension_slack <= 300 (tension_slack = 300.5)"],
    }
