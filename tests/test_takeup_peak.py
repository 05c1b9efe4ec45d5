"""The least-slack take-up's peak tension and what the take-up holds back (docs/head.md, The
shipped take-up, sized for the head's loop: the peak and the take-up's holding back; the head
shipped with this take-up before its linkage was refined for the least peak): the eyelet's arm
turned on the lever, alone, trades the thread the take-up holds back while the hook enlarges
the loop (its stretch, the peak past the hook's blade) against the slack the check spring must
hold. Each figure is held to the digits the page prints it with."""

from __future__ import annotations

import numpy as np
import pytest
from threadchecks import least_slack

from mjlink.analysis.tension import needle_tension
from mjlink.analysis.timing import head_timing
from mjlink.model import mechanism, paths
from mjlink.model.catalogue import shipped

HEAD = shipped("mechanisms") / "lockstitch_head.toml"

# docs/head.md's table: the arm's angle (deg, the file's 32.62) -> shortfall mm, slack mm, the
# spring's spare mm, the peak N and its zone, the loop slack deg of the stitch.
ROWS = {
    32.42: (2.561, 9.51, 3.113, 2.729, "past the hook's blade", 224.2),
    32.62: (1.718, 9.74, 2.888, 2.160, "past the hook's blade", 232.0),
    32.82: (0.892, 10.44, 2.185, 1.565, "past the hook's blade", 243.5),
    33.02: (0.080, 11.38, 1.250, 0.973, "below NE", 257.8),
    33.22: (0.000, 12.30, 0.324, 0.701, "P5-N2", 277.2),
    33.32: (0.000, 12.76, -0.137, 0.701, "P5-N2", 292.2),
}


def _row(head, key):
    return next(r for r in head.rows if r.key == key and r.maker is None)


@pytest.fixture(scope="module")
def swept():
    mech = least_slack(mechanism.load(HEAD))
    arm = paths.resolve(mech, "construct.P5.angle")
    assert paths.nominal_values(mech)["construct.P5.angle"] == 32.62
    out = {}
    for angle in ROWS:
        m = paths.apply(mech, {arm: angle})
        head = head_timing(m)
        out[angle] = (head, needle_tension(m, head))
    return out


def test_the_eyelets_arm_trades_the_peak_for_the_slack_as_the_pages_table(swept):
    for angle, (short, slack, spare, peak, zone, loose) in ROWS.items():
        head, t = swept[angle]
        assert round(_row(head, "thread_shortfall").value * 1e3, 3) == short
        assert round(_row(head, "thread_slack").value * 1e3, 2) == slack
        assert round(_row(head, "spring_spare").value * 1e3, 3) == spare
        assert round(t.peak, 3) == peak and t.peak_at[0] == zone
        assert round(float(t.slack.mean()) * 360.0, 1) == loose
        # Every counted timing row holds; the spring's row misses past 33.22 deg (a loose loop).
        assert all(r.ok for r in head.rows if r.counts)
        assert t.converged


def test_the_peak_past_the_blade_is_the_thread_the_take_up_holds_back_stretched(swept):
    """While the take-up holds thread back the peak is past the hook's blade and rises with the
    thread held back: 0.67 and 0.72 N/mm over the arm's 32.42 to 32.62 and 32.62 to 32.82 deg,
    where the peak's zone stays and its place moves by 1.5 deg."""
    held = [(_row(swept[a][0], "thread_shortfall").value * 1e3, swept[a][1].peak) for a in (32.42, 32.62, 32.82)]
    slopes = np.diff([p for _, p in held]) / np.diff([s for s, _ in held])
    assert np.round(slopes, 2).tolist() == [0.67, 0.72]
    # And 4.2 mm held back a degree of the arm.
    assert round((held[0][0] - held[2][0]) / 0.4, 1) == 4.2


def test_the_arm_turned_to_the_least_peak_meets_every_bound_of_the_least_peak_searches():
    """At 33.22 deg: every bound of the take-up study (studies/lockstitch_head_takeup_refine.toml,
    as its file says) and the least-peak searches' own, the spring's spare at least nought and
    the stitch periodic; at 33.32 the spring's spare is below nought."""
    import tomllib

    from mjlink import study

    spec = tomllib.loads((shipped("studies") / "lockstitch_head_takeup_refine.toml").read_text())
    bounds = [*spec["bound"], {"metric": "timing_spring_spare", "min": 0.0}, {"metric": "tension_periodic", "min": 1}]
    e = study.evaluate(
        least_slack(mechanism.load(HEAD)), {"construct.P5.angle": [33.22, 33.32]}, spec["metric"], per_turn=720
    )
    assert e.feasible.all()
    for b in bounds:
        col = e.columns[b["metric"]]
        assert col[0] >= b.get("min", -np.inf) and col[0] <= b.get("max", np.inf), b
    assert e.columns["timing_spring_spare"][1] < 0.0
    assert e.columns["tension_peak"][0] == pytest.approx(0.701, abs=5e-4)  # the table's figure, to its last digit


def test_the_peaks_rise_with_the_thread_held_back_against_the_threads_ea_over_its_path():
    """docs/head.md's figures: at the file's design the peak rises by 0.71 N per mm of the largest
    shortfall (the arm turned 0.01 deg either way); the thread's EA, 84 N, over the 383 mm from
    the discs past the blade is 0.22 N/mm; over the path weighted by each stretch's tension
    against the peak's, 125 mm, 0.67 N/mm."""
    from mjlink.analysis.tension import prepare

    mech = least_slack(mechanism.load(HEAD))
    arm = paths.resolve(mech, "construct.P5.angle")
    got = {}
    for angle in (32.61, 32.62, 32.63):
        m = paths.apply(mech, {arm: angle})
        head = head_timing(m)
        got[angle] = (_row(head, "thread_shortfall").value * 1e3, needle_tension(m, head), m, head)
    slope = (got[32.63][1].peak - got[32.61][1].peak) / (got[32.63][0] - got[32.61][0])
    _, t, m, head = got[32.62]
    pb = prepare(m, head)
    i = int(t.tension.max(axis=0).argmax())
    L, T = pb.lengths[i] * 1e3, t.tension[:, i]
    weighted = float((T * L).sum() / T.max())
    assert round(slope, 2) == 0.71
    assert round(pb.stiffness) == 84 and round(float(L.sum())) == 383
    assert round(pb.stiffness / float(L.sum()), 2) == 0.22
    assert round(weighted) == 125 and round(pb.stiffness / weighted, 2) == 0.67
    # The largest shortfall is the needle's in the fabric, at 169.55 deg; the loop's, 253 deg.
    b = head.balance
    assert b is not None
    assert round(float(b.theta[np.nanargmin(b.balance)]), 2) == 169.55
    near = np.where((b.theta > 240.0) & (b.theta < 270.0), b.balance, np.nan)
    assert round(float(b.theta[np.nanargmin(near)]), 2) == 253.0
