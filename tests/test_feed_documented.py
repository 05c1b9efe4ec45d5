"""docs/head.md's figures for the fabric under the presser foot that come from runs beyond the
speed sweep (tests/test_feed.py holds that): the heavier pieces, the foot's friction and the
pressing force against the Kaunas papers, the plies' lags, the presser map and the presser
spring's optimization. Each figure is held to the digits the page prints it with (within half
its last digit), so a change to the model that moves a printed figure fails here until the
page is corrected too.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from mjlink import study
from mjlink.model import mechanism
from mjlink.model.catalogue import shipped
from mjlink.model.presser import FABRIC_DEFAULTS, PRESSER_DEFAULTS
from mjlink.sim import feed
from mjlink.study import engine, optimize, spec

HEAD_TEXT = (shipped("mechanisms") / "lockstitch_head.toml").read_text()
# Two plies of 0.75 mm, 260 N/mm each: the page's "Plies" paragraph.
TWO = "[[fabric.ply]]\nthickness = 0.75\nstiffness = 260.0\n[[fabric.ply]]\nthickness = 0.75\nstiffness = 260.0\n"


@pytest.fixture(scope="module")
def head():
    return mechanism.load(shipped("mechanisms") / "lockstitch_head.toml")


def _percent(run: feed.FeedRun) -> float:
    return run.error * 100.0


def test_heavier_pieces_grow_with_the_foot_on_them_or_nearly(head):
    """The page (Against the published record), 8 stitches as bench/bench_feed.py runs them: a
    20 g piece +0.5 % at 4,000 rpm with the foot on it and +23.4 % at 6,000, the foot off it
    for 10 deg by 0.017 mm; a 100 g piece +1.3 % at 3,000, -6.4 % at 4,000 and +9.0 % at 6,000,
    the foot on it throughout."""
    runs = {}
    for grams in (20, 100):
        fabric = dataclasses.replace(FABRIC_DEFAULTS, mass=grams * 1e-3 / FABRIC_DEFAULTS.area)
        for rpm in (3000, 4000, 6000):
            runs[grams, rpm] = feed.run_feed(head, speed_rpm=rpm, stitches=8, fabric=fabric)
    assert round(_percent(runs[20, 4000]), 1) == 0.5 and runs[20, 4000].separation[0] == 0.0
    light = runs[20, 6000]
    assert round(_percent(light), 1) == 23.4
    assert round(light.separation[0]) == 10 and round(light.lift.max() * 1e3, 3) == 0.017  # deg, mm
    assert [round(_percent(runs[100, w]), 1) for w in (3000, 4000, 6000)] == [1.3, -6.4, 9.0]
    assert all(runs[100, w].separation[0] == 0.0 for w in (3000, 4000, 6000))


def test_a_quarter_of_the_foots_friction_lengthens_the_stitch_as_the_page_says(head):
    """The page (The foot's friction): 0.05 against 0.2 lengthens the stitch by 0.01 % at 1,600
    rpm, 0.24 % at 2,600, 0.26 % at 5,000 and 1.9 % at 6,000 (6 stitches): some fifty times
    less than the Kaunas paper's 10 to 20 %, which the model does not reproduce."""
    smooth = dataclasses.replace(FABRIC_DEFAULTS, foot=0.05)
    longer = {
        rpm: (feed.run_feed(head, speed_rpm=rpm, fabric=smooth).stitch / feed.run_feed(head, speed_rpm=rpm).stitch - 1)
        * 100
        for rpm in (1600, 2600, 5000, 6000)
    }
    assert [round(longer[w], 2) for w in (1600, 2600, 5000)] == [0.01, 0.24, 0.26]  # %
    assert round(longer[6000], 1) == 1.9  # %


def test_the_stitch_stays_within_028_percent_at_every_preload_and_hardly_shortens(head):
    """The page (The pressing force): at 600, 1,600 and 2,600 rpm (6 stitches from rest) the
    stitch stays within 0.28 % of the dog's advance at every preload from 20 to 80 N, under a
    foot's friction of 0.2 or 0.05. From 20 to 80 N it moves by 0.21 % at most; it lengthens at
    1,600 and 2,600 rpm and shortens only at 600, by 0.0003 % under the 0.2 foot and 0.0018 %
    under the 0.05 one."""
    worst, moved, shorter = 0.0, 0.0, {}
    for friction in (FABRIC_DEFAULTS.foot, 0.05):
        fabric = dataclasses.replace(FABRIC_DEFAULTS, foot=friction)
        for rpm in (600, 1600, 2600):
            stitch = []
            for preload in (20.0, 40.0, 60.0, 80.0):  # N
                presser = dataclasses.replace(PRESSER_DEFAULTS, preload=preload)
                run = feed.run_feed(head, speed_rpm=rpm, presser=presser, fabric=fabric)
                worst = max(worst, abs(run.advance[-1] / run.geometric - 1))
                stitch.append(run.advance[-1])
            change = (stitch[-1] / stitch[0] - 1) * 100  # %, from 20 to 80 N
            moved = max(moved, abs(change))
            if rpm == 600:
                shorter[friction] = -change
            else:
                assert change > 0.0
    assert round(worst * 100, 2) <= 0.28 and round(moved, 2) == 0.21  # %
    assert (round(shorter[FABRIC_DEFAULTS.foot], 4), round(shorter[0.05], 4)) == (0.0003, 0.0018)  # %


@pytest.mark.parametrize("grip", [0.5, 0.22, 0.1])
def test_the_plies_lags_are_the_pages(grip):
    """The page (Plies): two plies of 0.75 mm at 260 N/mm each, 6 stitches, at 20, 40 and 80 N
    of preload and 3,000 and 5,000 rpm. Gripping each other at 0.5 they never shift (within 2
    um); at 0.22 the top ply lags 0.11, 0.013 and 0.006 mm a stitch at 3,000 rpm and 0.86,
    0.08 and 0.02 mm at 5,000; at 0.1 the foot holds it (a lag of 2.8 to 4.0 mm). With MuJoCo
    3.8.1 the 0.86 is 0.83 and the 4.0 is 3.9."""
    lag = {}
    for preload in (20, 40, 80):
        mech = mechanism.parse(
            f"{HEAD_TEXT}\n[presser]\npreload = {preload}.0\n[fabric]\nfriction_ply = {grip}\n{TWO}", "head.toml"
        )
        for rpm in (3000, 5000):
            lag[preload, rpm] = -feed.run_feed(mech, speed_rpm=rpm).shift * 1e3  # mm
    if grip == 0.5:
        assert max(abs(v) for v in lag.values()) < 2e-3  # mm
    elif grip == 0.22:
        assert [round(lag[p, 3000], d) for p, d in ((20, 2), (40, 3), (80, 3))] == [0.11, 0.013, 0.006]
        # The light grip at 20 N and 5,000 rpm is the run most sensitive to the engine: the page
        # prints 0.86 mm (MuJoCo 4.0) and 0.83 (3.8.1, the lowest supported).
        assert round(lag[20, 5000], 2) in (0.83, 0.86)
        assert [round(lag[p, 5000], 2) for p in (40, 80)] == [0.08, 0.02]
    else:
        assert round(min(lag.values()), 1) == 2.8 and round(max(lag.values()), 1) in (3.9, 4.0)  # 3.8.1, 4.0


def test_the_presser_map_is_the_pages():
    """The page (A study of the presser), from the shipped study run here: 14 of 15 heads
    feasible, the one that is not the 80 N preload on the 50 N/mm fabric (pressed 1.55 mm,
    through its 1.5 mm); 4 hold the 2 % bound (60 N on the two softer fabrics, 80 N on the two
    stiffer); at 20 N the foot off the fabric for up to 125 deg and the stitch up to +68 %; at
    40 N +8 %, +13 % and -16 % on the soft, the default and the stiff fabric, off it 1, 18 and 23
    deg; at 60 and 80 N the fabrics that hold within -0.45 %; the load factor 1.00 to 1.15."""
    out = engine.run(spec.load("lockstitch_head_presser"))
    values, cols = out.values, out.columns
    at = {(round(p), round(k)): i for i, (p, k) in enumerate(values)}
    off = [i for i, ok in enumerate(out.feasible) if not ok]
    assert off == [at[80, 50]] and "presses the 1.5 mm fabric by 1.55 mm" in out.reason[off[0]]
    error = cols["feed_error_max"]
    holds = sorted(i for i in range(len(values)) if out.feasible[i] and abs(error[i]) <= 2.0)
    assert holds == sorted([at[60, 50], at[60, 130], at[80, 130], at[80, 500]])
    low = [at[20, k] for k in (50, 130, 500)]
    assert round(cols["feed_foot_off_max"][low].max()) == 125 and round(error[low].max()) == 68  # deg, %
    default = [at[40, k] for k in (50, 130, 500)]
    assert [round(error[i]) for i in default] == [8, 13, -16]  # %
    assert [round(cols["feed_foot_off_max"][i]) for i in default] == [1, 18, 23]  # deg
    assert round(error[holds].min(), 2) == -0.45 and error[holds].max() < 0  # %
    factors = cols["feed_load_factor_max"][out.feasible]
    assert (round(factors.min(), 2), round(factors.max(), 2)) == (1.00, 1.15)


def test_the_presser_springs_optimization_is_the_pages(head):
    """The page (An optimization of the presser spring), from the shipped study run here: it
    settles in 79 heads; its winner 26.0 N and 8.96 N/mm, the stitch within 0.30 % at 3,000 to
    5,000 rpm, the foot's push at most 75 N, its load factor 1.31; the file's spring errs by
    0.35 % with 86 N. The winner at half the timestep: 0.11 %, 0.06 % and 0.22 %; at 6,000 rpm
    the foot off the fabric for 36 deg and the stitch 23 % longer."""
    r = optimize.run(spec.load("lockstitch_head_presser_spring"))
    assert r.converged and r.evaluations == 79
    preload, rate = r.winner
    assert (round(preload, 1), round(rate, 2)) == (26.0, 8.96)  # N, N/mm
    c, f = r.columns, r.file_columns
    assert round(c["feed_error_size"], 2) == 0.30 and round(c["feed_foot_force_max"]) == 75  # %, N
    assert round(c["feed_load_factor_max"], 2) == 1.31
    assert round(f["feed_error_size"], 2) == 0.35 and round(f["feed_foot_force_max"]) == 86  # %, N
    winner = study.override(head, {"presser.preload": float(preload), "presser.rate": float(rate)})
    fine = []
    for rpm in (3000, 4000, 5000):
        step = feed.run_feed(winner, speed_rpm=rpm, stitches=1).timestep
        fine.append(abs(_percent(feed.run_feed(winner, speed_rpm=rpm, stitches=4, timestep=step / 2))))
    assert np.round(fine, 2).tolist() == [0.11, 0.06, 0.22]  # %
    fast = feed.run_feed(winner, speed_rpm=6000, stitches=4)
    assert round(fast.separation[0]) == 36 and round(_percent(fast)) == 23  # deg, %
