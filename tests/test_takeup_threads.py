"""The take-up judged over the needle tensions and the threads a head is set for (docs/head.md,
The shipped take-up, sized for the head's loop: Over the threads as well): the crossed study's
file, its winner's score recomputed from plain evaluations of the documented samples, and the
page's table of the three designs at the four corners of the conditions' box."""

from __future__ import annotations

import itertools
import tomllib

import numpy as np
import pytest

from mjlink import study
from mjlink.model import mechanism, paths
from mjlink.model.catalogue import shipped
from mjlink.study import optimize, spec

HEAD = shipped("mechanisms") / "lockstitch_head.toml"
BAND_HEAD = shipped("mechanisms") / "examples" / "lockstitch_head_band.toml"
THREADS = shipped("studies") / "lockstitch_head_takeup_threads.toml"
BAND_300 = tomllib.loads((shipped("studies") / "lockstitch_head_takeup_band_300.toml").read_text())
TENSION = [{"kind": "tension"}]

# docs/head.md: the crossed study's winner (not shipped), as its run wrote it (mm, deg).
WINNER = {
    "construct.P2.angle": -15.55,
    "construct.P2.length": 26.05,
    "construct.P3.length_a": 62.52,
    "construct.P3.length_b": 77.68,
    "ground.P4.x": -52.62,
    "ground.P4.y": 68.52,
    "construct.P5.length": 68.95,
    "construct.P5.angle": 32.72,
}
# docs/head.md: the conditions' levels, the tension study's band and the file's source's band of
# elongation at break ([MH], 10-15 %).
LEVELS = ((1.0, 1.4, 1.8, 2.2), (0.10, 0.125, 0.15))
# docs/head.md, at the design's own dimensions (peak N, 2 digits; loop slack deg, at the study's
# 720 steps) at 1.0 N and 2.2 N, each with a thread of 10 % and of 15 %.
CORNERS = ((1.0, 0.10), (1.0, 0.15), (2.2, 0.10), (2.2, 0.15))
TABLE = {
    "shipped": [(0.49, 292.5), (0.57, 268.5), (3.48, 228.5), (2.78, 210.5)],
    "winner": [(0.50, 303.0), (0.57, 273.0), (3.29, 228.0), (2.62, 214.0)],
    "example": [(0.44, 308.0), (0.44, 294.5), (2.12, 234.0), (1.76, 222.0)],
}


def _dims(which: str) -> dict[str, float]:
    head = paths.nominal_values(mechanism.load(HEAD))
    if which == "example":
        return paths.nominal_values(mechanism.load(BAND_HEAD))
    return {**head, **WINNER} if which == "winner" else head


def test_the_study_is_the_300_deg_band_study_with_the_thread_crossed_in():
    raw = tomllib.loads(THREADS.read_text())
    for key in ("metric", "bound"):
        assert raw[key] == BAND_300[key], key
    assert [p for p in raw["parameter"] if "range" in p] == [p for p in BAND_300["parameter"] if "range" in p]
    assert [p for p in raw["parameter"] if "range" not in p] == [
        {"path": "tension.needle_tension", "tolerance": 0.6, "levels": 4},
        {"path": "tension.elongation_at_break", "tolerance": 0.025, "levels": 3},
    ]
    st = spec.load(THREADS)
    assert st.robust is not None and st.robust.samples == 12 and st.optimize.xtol == 1e-3
    held = st.mechanism.tension
    grid = list(itertools.product(*LEVELS))
    got = [v.param.nominal for v in st.conditions] + optimize.deviations(st)[:, len(st.varied) :]
    assert np.allclose(got, grid, rtol=0, atol=1e-12)
    assert (held.needle_tension, held.elongation_at_break) == (1.6, 0.125)
    # The elongation's band moves the thread's stiffness EA = breaking load / elongation by
    # -17 % to +25 % (docs/head.md).
    ea = [held.breaking_load / e for e in LEVELS[1]]
    assert [round((x / held.stiffness - 1) * 100) for x in ea] == [25, 0, -17]
    grid_study = tomllib.loads((shipped("studies") / "lockstitch_head_tension.toml").read_text())
    band = next(p["values"] for p in grid_study["parameter"] if p["path"] == "tension.needle_tension")
    assert (min(band), max(band)) == (LEVELS[0][0], LEVELS[0][-1])


def _samples(which: str) -> dict[str, np.ndarray]:
    """The study's 12 rows for a design, written out from the documented sampling: the eight
    dimensions each +-0.02 uniform from PCG64 seeded with the robust seed (the optimizer's, 11),
    the conditions crossed, the tension slowest."""
    st = spec.load(THREADS)
    dims = _dims(which)
    dev = np.random.Generator(np.random.PCG64(11)).uniform(-1.0, 1.0, size=(12, 8)) * 0.02
    rows = {v.param.path: dims[v.param.path] + dev[:, j] for j, v in enumerate(st.varied)}
    grid = np.array(list(itertools.product(*LEVELS)))
    rows["tension.needle_tension"], rows["tension.elongation_at_break"] = grid[:, 0], grid[:, 1]
    return rows


@pytest.mark.parametrize(("which", "score"), [("shipped", 3.908), ("winner", 3.646), ("example", 2.526)])
def test_the_scores_the_page_gives_from_plain_evaluations_of_each_sample(which, score):
    """mean + 2 std of the peak over the 12 samples: the shipped head 3.908, the winner 3.646
    (6.7 % below); the band example 2.526, its loop slack for more than 300 deg at the stiff
    thread's lowest tension, so out of this study's bound."""
    e = study.evaluate(mechanism.load(HEAD), _samples(which), TENSION, per_turn=720)
    peak, slack = e.columns["tension_peak"], e.columns["tension_slack"]
    assert round(float(peak.mean() + 2.0 * peak.std(ddof=1)), 3) == score
    assert (slack.max() <= 300.0) == (which != "example")
    if which == "example":
        assert float(slack[0]) > 300.0  # 1.0 N, 10 %
    st = spec.load(THREADS)
    with optimize.Evaluator(st) as ev:
        s = ev.score(np.array([[_dims(which)[v.param.path] for v in st.varied]]))
    assert s.objective[0] == pytest.approx(peak.mean() + 2.0 * peak.std(ddof=1), rel=1e-12)
    assert (s.violation[0] == 0) == (which != "example")


@pytest.mark.parametrize("which", list(TABLE))
def test_the_pages_table_at_the_corners(which):
    t, el = zip(*CORNERS, strict=True)
    rows = {**{k: [v] * 4 for k, v in _dims(which).items() if k in WINNER}}
    rows["tension.needle_tension"], rows["tension.elongation_at_break"] = list(t), list(el)
    e = study.evaluate(mechanism.load(HEAD), rows, TENSION, per_turn=720)
    got = [
        (round(float(p), 2), round(float(s), 6))
        for p, s in zip(e.columns["tension_peak"], e.columns["tension_slack"], strict=True)
    ]
    assert got == TABLE[which]
    # At its own dimensions the winner's loop is slack 3 deg beyond the bound with the stiff
    # thread at 1.0 N: the study judged that corner only with its sample's deviations.
    if which == "winner":
        assert got[0][1] > 300.0


def test_the_winners_caveat_names_the_corner_it_misses_at_its_own_dimensions():
    """The caveat 'at its own dimensions': of the 12 conditions the samples hold, the winner as
    written misses the loop's bound only with the stiff thread at the lowest tension, by the
    page's 3 deg; the shipped head misses none."""
    from mjlink.study import caveats

    st = spec.load(THREADS)
    with optimize.Evaluator(st) as ev:
        own = {
            w: caveats._own(st, ev, np.array([_dims(w)[v.param.path] for v in st.varied]))
            for w in ("winner", "shipped")
        }
    assert own == {
        "winner": [
            "with tension.needle_tension = 1 N, tension.elongation_at_break = 0.1: misses tension_slack <= 300 "
            "(tension_slack = 303)"
        ],
        "shipped": [],
    }
