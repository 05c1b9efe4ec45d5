"""The take-up sized for the least peak needle-thread tension (docs/head.md, The shipped take-up,
sized for the head's loop: the least peak, searched near the least-slack design the head
shipped with before): the two studies, the least peak's winner shipped as an example, the
slack-bounded one's as the head, and the page's table of the three, to the digits it prints."""

from __future__ import annotations

import dataclasses
import tomllib

import numpy as np
import pytest
from threadchecks import LEAST_SLACK, least_slack, tension_with

from mjlink import study
from mjlink.analysis.tension import needle_tension
from mjlink.analysis.timing import head_timing
from mjlink.model import mechanism, paths
from mjlink.model.catalogue import shipped
from mjlink.model.tension import DEFAULTS

HEAD = shipped("mechanisms") / "lockstitch_head.toml"
LEAST = shipped("mechanisms") / "examples" / "lockstitch_head_least_peak.toml"
STUDY = tomllib.loads((shipped("studies") / "lockstitch_head_takeup_peak.toml").read_text())
REFINE = tomllib.loads((shipped("studies") / "lockstitch_head_takeup_refine.toml").read_text())

# docs/head.md: the winner's eight dimensions (mm, deg), as the page lists them.
WINNER = {
    "construct.P5.angle": 33.62,
    "construct.P5.length": 70.31,
    "construct.P2.angle": -13.79,
    "construct.P2.length": 26.65,
    "construct.P3.length_a": 62.56,
    "construct.P3.length_b": 77.27,
    "ground.P4.x": -52.21,
    "ground.P4.y": 70.0,
}
FACE_TOP = 70.0  # mm: the face's top edge, the take-up studies' bound on the rocker's pivot


def _row(head, key):
    return next(r for r in head.rows if r.key == key and r.maker is None)


def test_the_study_searches_the_linkage_near_the_shipped_design_within_the_take_up_studies_bounds():
    """Its file says: the linkage's eight dimensions within +-1 deg and +-0.5 mm of the shipped
    design (the rocker's pivot up to the face's top edge), from it, robust to +-0.02 over 8 samples, the take-up studies' bounds and metrics
    with the spring's spare and a periodic stitch added."""
    nominal = LEAST_SLACK  # the design the study started from: the head as it shipped then
    opt = STUDY["optimize"]
    assert (opt["objective"], opt["start"]) == ("tension_peak", "file")
    assert STUDY["robust"] == {"samples": 8, "k": 2.0}
    assert {p["path"] for p in STUDY["parameter"]} == set(WINNER)
    for p in STUDY["parameter"]:
        lo, hi = p["range"]
        half = 1.0 if p["path"].endswith("angle") else 0.5
        v = nominal[p["path"]]
        assert p["tolerance"] == 0.02
        assert lo == pytest.approx(v - half, abs=1e-9)
        assert hi == pytest.approx(FACE_TOP if p["path"] == "ground.P4.y" else v + half, abs=1e-9)
    added = [{"metric": "timing_spring_spare", "min": 0.0}, {"metric": "tension_periodic", "min": 1}]
    assert sorted(STUDY["bound"], key=str) == sorted(REFINE["bound"] + added, key=str)
    assert STUDY["metric"] == REFINE["metric"]


def test_the_example_is_the_shipped_head_with_the_winners_take_up():
    head, least = paths.nominal_values(mechanism.load(HEAD)), paths.nominal_values(mechanism.load(LEAST))
    assert set(head) == set(least)
    moved = {k for k in head if head[k] != least[k]}
    assert moved == set(WINNER)
    assert {k: least[k] for k in WINNER} == WINNER


@pytest.fixture(scope="module")
def both():
    out = {}
    for name, m in (("before", least_slack(mechanism.load(HEAD))), ("least", mechanism.load(LEAST))):
        h = head_timing(m)
        out[name] = (m, h, needle_tension(m, h))
    return out


def _column(m, h, t) -> dict[str, object]:
    """The page's rows for one head, rounded as printed."""

    def fed(length):
        f = dataclasses.replace(m, balance=dataclasses.replace(m.balance, stitch_length=length))
        return needle_tension(f, head_timing(f)).peak

    travel = dataclasses.replace(
        m, balance=dataclasses.replace(m.balance, check_spring_travel=m.balance.check_spring_travel + 3e-3)
    )
    tighter = needle_tension(m, h, settings=dataclasses.replace(DEFAULTS, needle_tension=2.4))
    stretchier = needle_tension(m, h, settings=dataclasses.replace(DEFAULTS, elongation_at_break=0.25))
    return {
        "held": round(_row(h, "thread_shortfall").value * 1e3, 2),
        "slack": round(_row(h, "thread_slack").value * 1e3, 2),
        "spare": round(_row(h, "spring_spare").value * 1e3, 2),
        "loose": round(float(t.slack.mean()) * 360.0, 2),
        "tighter": (round(tighter.peak, 2), tighter.peak_at[0]),
        "stretchier": (round(stretchier.peak, 2), stretchier.peak_at[0]),
        "stitches": (round(fed(2e-3), 3), round(fed(4e-3), 2)),
        "give": tension_with(m, h, fabric_give=0.2e-3).peak,
        "travel": round(needle_tension(travel, h).peak, 2),
    }


def test_the_least_peak_example_beside_the_shipped_head_is_the_pages_table(both):
    m, h, t = both["least"]
    assert round(t.peak, 3) == 0.698 and t.peak_at == ("P5-N2", pytest.approx(53.75, abs=1e-9))
    assert t.converged and t.period == 1
    assert all(r.ok for r in h.rows if r.counts)
    got = _column(m, h, t)
    blade = "past the hook's blade"
    assert got["held"] == 0.0 and got["slack"] == 12.33 and got["spare"] == 0.30
    assert got["loose"] == 286.75
    assert got["tighter"] == (2.31, blade) and got["stretchier"] == (1.05, blade)
    assert got["stitches"] == (0.699, 1.25) and got["travel"] == 0.93
    assert abs(got["give"] - t.peak) < 4e-5  # N: "the same to 4e-5 N", the page's words
    ms, hs, ts = both["before"]
    ship = _column(ms, hs, ts)
    assert (round(ts.peak, 2), ts.peak_at[0]) == (2.16, blade)
    assert (ship["held"], ship["slack"], ship["spare"], ship["loose"]) == (1.72, 9.74, 2.89, 232.0)
    assert ship["tighter"][0] == 3.31 and ship["stretchier"][0] == 1.94
    assert (
        (round(ship["stitches"][0], 2), ship["stitches"][1]) == (1.33, 2.92)
        and round(ship["give"], 2) == 1.95
        and ship["travel"] == 2.65
    )
    # Lower in every row; but the fabric's give no longer lowers its peak and a stretchier
    # thread raises it, where the shipped head follows both of IJFTR's directions.
    assert t.peak < ts.peak and got["tighter"][0] < ship["tighter"][0] and got["travel"] < ship["travel"]
    assert got["stretchier"][0] < ship["stretchier"][0] and got["stitches"][1] < ship["stitches"][1]
    assert got["stretchier"][0] > t.peak and ship["stretchier"][0] < ts.peak
    assert ship["give"] < ts.peak - 0.1
    # The loop slack 55 deg longer.
    assert round(got["loose"] - ship["loose"]) == 55
    # The balance as the loop grows (240..270 deg): 1.49 mm to spare at 252.25 deg on the least
    # peak's take-up, 1.55 mm held back at 253 deg on the shipped head's.
    for b, (mm, deg) in ((h.balance, (1.49, 252.25)), (hs.balance, (-1.55, 253.0))):
        near = np.where((b.theta > 240.0) & (b.theta < 270.0), b.balance, np.nan)
        k = int(np.nanargmin(near))
        assert (round(float(near[k]), 2), round(float(b.theta[k]), 2)) == (mm, deg)  # b.balance in mm


def test_the_thread_held_stretched_at_the_draw_up_is_what_the_loop_falls_short_by(both):
    """docs/head.md: the least peak's kinematic margin, 1.49 mm, is less than the thread the path
    holds stretched as the take-up draws the stitch up (the sum of each stretch's length times
    its tension over EA, greatest before 200 deg): 2.18 mm at 53.75 deg, 3.25 mm at 1.5 times
    the needle tension, 4.36 mm at twice the elongation at break; the loop's tension peaks at
    0.43, 2.31 and 1.05 N at 251.5 to 252 deg. The more thread held stretched, the higher."""
    from mjlink.analysis.tension import prepare

    m, h, t = both["least"]
    lengths = np.asarray(prepare(m, h).lengths)
    got = []
    for settings in (
        None,
        dataclasses.replace(DEFAULTS, needle_tension=2.4),
        dataclasses.replace(DEFAULTS, elongation_at_break=0.25),
    ):
        run = t if settings is None else needle_tension(m, h, settings=settings)
        stored = np.array([np.nansum(lengths[i] * run.tension[:, i]) for i in range(len(run.theta))]) / run.stiffness
        i = int(np.argmax(np.where(run.theta < 200.0, stored, -1.0)))
        top = run.tension.max(axis=0)
        loop = np.flatnonzero((run.theta > 240.0) & (run.theta < 270.0))
        j = loop[np.argmax(top[loop])]
        got.append((round(float(stored[i]) * 1e3, 2), round(float(top[j]), 2), round(float(run.theta[j]), 2)))
        if settings is None:
            assert round(float(run.theta[i]), 2) == 53.75  # deg: the draw-up, where the peak is
    assert got == [(2.18, 0.43, 252.0), (3.25, 2.31, 251.5), (4.36, 1.05, 251.75)]  # N, deg
    # The margin the balance gives the loop, against the least of these: 0.7 mm short.
    assert round(got[0][0] - 1.49, 1) == 0.7


def _deviated(mech, centre: dict, spec: dict):
    """The study's metrics of ``mech`` at 16 sets of deviations within each parameter's
    tolerance about ``centre``, drawn here (seed 20261201: the same sets for both studies, not
    the samples either study drew)."""
    rng = np.random.default_rng(20261201)
    values = {
        p["path"]: centre[p["path"]] + rng.uniform(-p["tolerance"], p["tolerance"], 16) for p in spec["parameter"]
    }
    return study.evaluate(mech, values, spec["metric"], per_turn=720)


def test_the_example_holds_every_bound_under_tolerances_the_study_did_not_draw():
    """16 sets of +-0.02 mm and +-0.02 deg on the eight dimensions, drawn here (not the study's
    samples): every bound of the study holds in each, the peak stays 0.6979 to 0.6981 N and the
    spring's spare 0.21 to 0.36 mm, as the page says; and the eyelet's travel and acceleration
    the page gives."""
    m = mechanism.load(LEAST)
    e = _deviated(m, paths.nominal_values(m), STUDY)
    assert e.feasible.all()
    for b in STUDY["bound"]:
        col = e.columns[b["metric"]]
        assert (col >= b.get("min", -np.inf)).all() and (col <= b.get("max", np.inf)).all(), b
    peak, spare = e.columns["tension_peak"], e.columns["timing_spring_spare"]
    assert round(float(peak.min()), 4) == 0.6979 and round(float(peak.max()), 4) == 0.6981
    assert round(float(spare.min()), 2) == 0.21 and round(float(spare.max()), 2) == 0.36
    own = study.evaluate(m, {"construct.P5.angle": [WINNER["construct.P5.angle"]]}, STUDY["metric"], per_turn=720)
    assert round(float(own.columns["eyelet_travel"][0]), 1) == 45.6
    assert round(float(own.columns["eyelet_acceleration"][0]), -1) == 11180.0


SLACK = tomllib.loads((shipped("studies") / "lockstitch_head_takeup_peak_loop.toml").read_text())
# docs/head.md: the slack-bounded study's winner, as the page lists it (mm, deg).
BOUNDED = {
    "construct.P2.angle": -15.23,
    "construct.P2.length": 25.82,
    "construct.P3.length_a": 62.40,
    "construct.P3.length_b": 78.16,
    "ground.P4.x": -52.90,
    "ground.P4.y": 68.77,
    "construct.P5.length": 69.37,
    "construct.P5.angle": 32.62,
}


def test_the_slack_bounded_study_is_the_least_peak_study_with_the_loops_bound():
    """Its file says: everything is the least-peak study's but one bound more, the loop slack for
    at most the shipped head's 230.5 deg at the study's 720 steps."""
    extra = [b for b in SLACK["bound"] if b not in STUDY["bound"]]
    assert extra == [{"metric": "tension_slack", "max": 230.5}]
    assert [b for b in SLACK["bound"] if b in STUDY["bound"]] == STUDY["bound"]
    for key in ("parameter", "metric", "optimize", "robust"):
        assert SLACK[key] == STUDY[key], key
    assert {k: v for k, v in SLACK["study"].items() if k != "title"} == {
        k: v for k, v in STUDY["study"].items() if k != "title"
    }
    before = least_slack(mechanism.load(HEAD))
    e = study.evaluate(before, {"construct.P5.angle": [32.62]}, STUDY["metric"], per_turn=720)
    assert round(float(e.columns["tension_slack"][0]), 2) == 230.5  # deg: the head's as it shipped then


@pytest.fixture(scope="module")
def bounded():
    head = mechanism.load(HEAD)
    m = paths.apply(head, {paths.resolve(head, k): v for k, v in BOUNDED.items()})
    h = head_timing(m)
    return m, h, needle_tension(m, h)


def test_the_slack_bounded_winner_is_the_pages_last_column(bounded, both):
    m, h, t = bounded
    blade = "past the hook's blade"
    assert (round(t.peak, 2), t.peak_at[0]) == (1.75, blade) and t.peak_at[1] == pytest.approx(254.25, abs=1e-9)
    assert round(t.peak / 9.80665e-3) == 178
    top = t.tension.max(axis=0)
    up = (top > np.roll(top, 1)) & (top >= np.roll(top, -1)) & (top > 5 * 9.80665e-3)
    assert [
        (round(float(a), 2), round(float(g) / 9.80665e-3, 1)) for a, g in zip(t.theta[up], top[up], strict=True)
    ] == [
        (57.75, 71.8),
        (165.0, 158.5),
        (254.25, 178.5),
    ]
    alone = needle_tension(m, h, spring=False).tension.max(axis=0)
    up = (alone > np.roll(alone, 1)) & (alone >= np.roll(alone, -1)) & (alone > 5 * 9.80665e-3)
    assert [round(float(g) / 9.80665e-3) for g in alone[up]] == [66, 62, 38]
    assert t.converged and all(r.ok for r in h.rows if r.counts)
    got = _column(m, h, t)
    assert (got["held"], got["slack"], got["spare"], got["loose"]) == (1.86, 10.05, 2.58, 230.5)
    assert got["tighter"] == (3.09, blade) and got["stretchier"] == (1.73, blade)
    assert (round(got["stitches"][0], 2), got["stitches"][1]) == (1.03, 2.54)
    assert round(got["give"], 2) == 1.59 and got["travel"] == 2.27
    # Every published direction the shipped head follows: more pre-tension, feed and spring
    # travel raise the peak; a stretchier thread and a fabric that gives lower it. And lower
    # than the shipped head's in every row, the loop slack 1.5 deg less.
    assert got["tighter"][0] > t.peak and got["travel"] > t.peak
    assert got["stitches"][0] < t.peak < got["stitches"][1]
    assert got["stretchier"][0] < t.peak and got["give"] < t.peak
    ms, hs, ts = both["before"]
    ship = _column(ms, hs, ts)
    for key in ("tighter", "stretchier"):
        assert got[key][0] < ship[key][0], key
    assert got["stitches"][0] < ship["stitches"][0] and got["stitches"][1] < ship["stitches"][1]
    assert got["give"] < ship["give"] and got["travel"] < ship["travel"] and t.peak < ts.peak
    assert ship["loose"] - got["loose"] == 1.5


def test_the_slack_bounded_winner_under_the_same_tolerances_as_the_least_peak():
    """The 16 sets of the least peak's test, about this design: every bound holds but the
    loop's, which it misses in one set by one of the study's half-degree steps; its peak, the
    shortfall, and the eyelet's travel and acceleration the page gives."""
    head = mechanism.load(HEAD)
    e = _deviated(head, BOUNDED, SLACK)
    assert e.feasible.all()
    for b in SLACK["bound"]:
        col = e.columns[b["metric"]]
        ok = (col >= b.get("min", -np.inf)) & (col <= b.get("max", np.inf))
        if b["metric"] == "tension_slack":
            assert np.round(col[~ok], 2).tolist() == [231.0]
        else:
            assert ok.all(), b
    peak = e.columns["tension_peak"]
    assert round(float(peak.min()), 2) == 1.73 and round(float(peak.max()), 2) == 1.88
    assert round(float(e.columns["timing_thread_shortfall"].max()), 2) == 1.96
    own = study.evaluate(head, {k: [v] for k, v in BOUNDED.items()}, SLACK["metric"], per_turn=720)
    assert round(float(own.columns["eyelet_travel"][0]), 1) == 43.2
    assert round(float(own.columns["eyelet_acceleration"][0]), -1) == 10590.0


def test_the_shipped_head_carries_the_slack_bounded_winner():
    nominal = paths.nominal_values(mechanism.load(HEAD))
    assert {k: nominal[k] for k in BOUNDED} == BOUNDED
