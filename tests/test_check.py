"""``check``: the report of what a mechanism file defines, and the simulation watchdogs
(divergence, branch switch) that keep a failed run from looking like a result."""

import dataclasses
import logging
import math
import os
import subprocess
import sys
import tomllib

import numpy as np
import pytest
from conftest import ROOT, in_process

from mjlink import compare, validation
from mjlink import validation as check
from mjlink.cli import format_report
from mjlink.errors import AssemblyError, MechanismFileError, SimulationError
from mjlink.model import catalogue as registry
from mjlink.model.mechanism import parse
from mjlink.sim import builder
from mjlink.sim import simulate as S

EXAMPLE_PATH = registry.MECHANISMS_DIR / "examples" / "crank_rocker.toml"
EXAMPLE = EXAMPLE_PATH.read_text()
ENV = {**os.environ, "PYTHONPATH": str(ROOT)}


def mjlink(*args, cwd=None):
    return subprocess.run(
        [sys.executable, "-m", "mjlink", *args], capture_output=True, text=True, cwd=cwd, env=ENV, timeout=600
    )


def write(tmp_path, text, name="mine.toml"):
    f = tmp_path / name
    f.write_text(text)
    return f


ROCKER = EXAMPLE.replace("length_b = 35.0", "length_b = 15.0")  # cannot close around phi = 180
DEAD = EXAMPLE.replace("length_a = 45.0", "length_a = 32.55").replace("length_b = 35.0", "length_b = 32.55")


# ----------------------------------------------------------------------------- the report
def test_takeup_report():
    r = check.check_file("takeup")
    assert r.ok and r.error() is None
    m = r.mobility
    assert (m.moving_links, m.revolute, m.prismatic, m.gears, m.structural, m.driven) == (3, 4, 0, 0, 1, 1)
    assert [(p.point, p.parent, p.child) for p in r.loops] == [("P3", "lever", "rocker")]
    assert sum(p.role == "joint" for p in r.pairs) == 3
    assert r.full_turn and r.period_deg == 360.0
    (a,) = r.angles
    assert a.kind == "dyad" and a.label == "P2-P3-P4" and a.links == ("lever", "rocker")
    # The four-bar's transmission angle in closed form from the file's numbers: farthest from
    # 90 deg where the crank pin is farthest from the rocker's pivot, the crank pointing away
    # from it (cosine rule on the coupler, the rocker and that distance). check's samples
    # straddle it: measured 1.2e-6 deg off, at 0.009 deg of crank.
    f = tomllib.loads(registry.path_of("takeup").read_text())
    blocks = {b["point"]: b for b in f["construct"]}
    (x1, y1), (x4, y4) = f["ground"][blocks["P2"]["pivot"]][:2], f["ground"][blocks["P3"]["b"]][:2]
    crank, x4, y4 = blocks["P2"]["length"], x4 - x1, y4 - y1
    coupler, rocker = blocks["P3"]["length_a"], blocks["P3"]["length_b"]
    far = crank + math.hypot(x4, y4)
    worst = math.degrees(math.acos((coupler**2 + rocker**2 - far**2) / (2 * coupler * rocker)))
    assert abs(a.worst_deg - worst) < 1e-5 and abs(a.margin_deg - (180.0 - worst)) < 1e-5
    assert abs(a.phi_deg - (math.degrees(math.atan2(y4, x4)) + 180.0)) < 0.2
    text = format_report(r)
    for s in (
        "points (4 ground, 6 moving;",
        "links (3 moving)",
        "revolute  at P3",
        "closes a loop",
        "W = 3 n - 2 p = 3*3 - 2*4 = 1",
        "the input crank turns fully",
        "transmission angle  154.59 deg",
        "result: ok",
    ):
        assert s in text, s
    mass = {l.name: l.mass for l in r.links}
    assert mass == pytest.approx({"crank": 0.01, "lever": 0.0065, "rocker": 0.0085}, rel=1e-12)


def test_geared_mechanism_counts_the_gear():
    r = check.check_file("warp_knitting")
    m = r.mobility
    assert (m.moving_links, m.revolute, m.prismatic, m.gears, m.structural, m.driven) == (6, 7, 1, 1, 2, 1)
    assert [g.link for g in r.gears] == ["crank2"] and r.gears[0].ratio == -0.5
    assert {p.point for p in r.loops} == {"P3", "P9"}
    assert any(p.kind == "prismatic" and p.guide == ("P5", "P6") for p in r.pairs)
    assert r.period_deg == 720.0 and r.full_turn
    kinds = {a.kind: a for a in r.angles}
    assert kinds["slider"].quantity == "pressure angle" and kinds["slider"].worst_deg < 60
    assert "gear coupling: crank2 (P8) turns -0.5 times the input crank" in format_report(r)


def test_crank_slider_pressure_angle_matches_the_synthesis():
    m = validation.get("crank_slider")
    r = check.check(m)
    (a,) = r.angles
    syn = m.synthesis
    crank = m.input_crank.length
    rod = next(s for s in m.steps if s.point == "C").length
    # theta_max = asin((r + e) / l) at phi = 90 deg (seed 002), one of the angles check samples:
    # measured equal to rounding.
    assert abs(a.worst_deg - math.degrees(math.asin((crank + syn.offset) / rod))) < 1e-9
    assert abs(a.phi_deg - 90.0) < 1e-9


@pytest.mark.parametrize("name", registry.names())
def test_check_agrees_with_validate(name):
    r = check.check_file(name)
    assert r.ok and validation.problems(validation.get(name)) == []


def test_unassemblable_file_is_still_reported(tmp_path):
    f = write(tmp_path, ROCKER)
    r = check.check_file(f)
    assert not r.full_turn and not r.ok
    assert r.assembly_ranges == "0.0..125.6, 234.4..360.0"
    (a,) = r.angles
    assert not a.closes and a.fails_deg == "125.7..234.3"
    text = format_report(r)
    assert "NOT over a full turn; assembles only for input angles 0.0..125.6, 234.4..360.0 deg" in text
    assert "dyad B-C-D cannot close for input angles 125.7..234.3 deg" in text
    assert "result: cannot be simulated faithfully" in text
    with pytest.raises(AssemblyError, match="cannot turn fully") as e:
        r.raise_if_failed()
    assert str(f) in str(e.value) and "\n" not in str(e.value)
    # the CLI's loading for check: the file loads without the full-turn requirement
    assert validation.get(f, full_turn=False).name == "crank_rocker"


def test_dead_point_is_reported_not_only_raised(tmp_path):
    r = check.check_file(write(tmp_path, DEAD))
    (a,) = r.angles
    assert not a.ok and a.margin_deg < 10
    assert "TOO CLOSE" in format_report(r)
    assert r.problems[0][0] == "AssemblyError" and "dead point" in r.problems[0][1]


def test_structural_problem_is_reported_with_the_count(tmp_path):
    text = EXAMPLE + '\n[links.coupler2]\npoints = ["B", "C"]\nmass = 1.0\ncom = "C"\n'
    r = check.check_file(write(tmp_path, text))
    assert r.mobility.driven == 0 and not r.ok
    assert "<-- must be 1" in format_report(r)
    with pytest.raises(MechanismFileError, match="over-constrain"):
        r.raise_if_failed()


def test_file_errors_are_raised_before_any_report(tmp_path):
    with pytest.raises(MechanismFileError, match="TOML syntax error"):
        check.check_file(write(tmp_path, "[mechanism\n"))


def test_speed_note(tmp_path):
    r = check.check_file(write(tmp_path, EXAMPLE.replace("speed = 100.0", "speed = 600.0")))
    assert r.ok and any("600 rad/s is above 150 rad/s" in n and "scaled by 0.25" in n for n in r.notes)
    # The scaled run is the one at 150 rad/s: its crank-pin acceleration, 338 m/s^2, is verified.
    assert not any("errors grow" in n for n in r.notes)
    r = check.check_file(write(tmp_path, EXAMPLE.replace("speed = 100.0", "speed = 20.0")))
    assert r.ok and any("6 m/s^2" in n and "gravity" in n for n in r.notes)
    assert check.check_file(EXAMPLE_PATH).notes == ()


# ----------------------------------------------------------------------------- watchdogs
def test_huge_timestep_diverges_into_a_simulation_error():
    m = validation.get(EXAMPLE_PATH)
    for dt in (0.02, 0.5):
        case = S.kinematic_case(m, settings=builder.Settings(timestep=dt))
        with pytest.raises(SimulationError, match=r"diverged") as e:
            S.run(m, case)
        assert "\n" not in str(e.value)


def test_a_diverging_run_leaves_no_mujoco_log_in_the_users_folder(tmp_path, monkeypatch, caplog):
    """MuJoCo's own handler would append its warning to MUJOCO_LOG.TXT in the current folder
    (and print it): mjlink's handler passes it to the logger mjlink.mujoco at DEBUG
    instead (docs/api.md), for a run stepped here and for rollout's threads (batch)."""
    from mjlink.sim import batch

    monkeypatch.chdir(tmp_path)
    m = validation.get(EXAMPLE_PATH)
    case = S.kinematic_case(m, settings=builder.Settings(timestep=0.5))
    with caplog.at_level(logging.DEBUG, logger="mjlink.mujoco"), pytest.raises(SimulationError, match="diverged"):
        S.run(m, case)
    assert any("MuJoCo: Nan, Inf or huge value" in r.getMessage() for r in caplog.records), caplog.records
    with np.errstate(all="ignore"):
        runs = batch.verify([m, m], threads=2, settings=builder.Settings(timestep=0.5))
    assert all("diverged" in v.reason for v in runs)
    assert sorted(p.name for p in tmp_path.iterdir()) == []


@pytest.fixture(scope="module")
def example_run():
    m = validation.get(EXAMPLE_PATH)
    return m, S.run(m, S.kinematic_case(m))


def test_faithful_runs_stay_on_their_branch(example_run):
    m, tr = example_run
    assert compare.branch_switch(m, tr) is None
    assert compare.agreement(m, tr).failures() == []


def _switched(mech, tr, flipped, k):
    """``tr`` with every moving point from sample k on taken from ``flipped`` (the other branch)."""
    from mjlink import reference

    other = reference.solve(flipped, tr.phi)
    pts = {
        n: np.where((np.arange(len(tr.time)) >= k)[:, None], other.position(n), v) if n in mech.moving_points else v
        for n, v in tr.points.items()
    }
    return dataclasses.replace(tr, points=pts)


def test_branch_switch_of_a_dyad_is_named(example_run):
    m, tr = example_run
    flipped = parse(EXAMPLE.replace("sign = 1 ", "sign = -1 "), EXAMPLE_PATH)
    k = len(tr.time) // 3
    msg = compare.branch_switch(m, _switched(m, tr, flipped, k))
    t, phi = tr.time[k], math.degrees(tr.phi[k])
    assert msg is not None and "\n" not in msg
    assert f"at C (dyad B-C-D) at t = {t:.6g} s, input angle {phi:.2f} deg" in msg
    assert "follows the other branch (sign -1 instead of +1)" in msg


def test_branch_switch_of_a_slider_is_named():
    m = validation.get("crank_slider")
    tr = S.run(m, S.kinematic_case(m, cycles=0.25))
    flipped = dataclasses.replace(
        m, steps=tuple(dataclasses.replace(s, toward="G1") if s.point == "C" else s for s in m.steps)
    )
    msg = compare.branch_switch(m, _switched(m, tr, flipped, 10))
    assert "at C (slider B-C)" in msg and "toward G1 instead of G2" in msg


def test_drift_and_nan_are_not_called_a_branch(example_run):
    m, tr = example_run
    pts = dict(tr.points)
    pts["E"] = pts["E"] + np.array([0.0, 1e-3, 0.0])  # 1 mm off, on no other branch
    msg = compare.branch_switch(m, dataclasses.replace(tr, points=pts))
    assert "left the reference's solution at E at t = 0 s" in msg
    pts = dict(tr.points)
    pts["C"] = pts["C"].copy()
    pts["C"][5:] = np.nan
    msg = compare.branch_switch(m, dataclasses.replace(tr, points=pts))
    assert "MuJoCo's point C became non-finite" in msg


# ----------------------------------------------------------------------------- command line
def test_example_simulates_within_the_thresholds(tmp_path):
    r = in_process("simulate", str(EXAMPLE_PATH), "--strict", "--no-video", "--no-plots", "--out", str(tmp_path))
    assert r.returncode == 0, r.stdout + r.stderr
    assert (tmp_path / "crank_rocker" / "report.json").is_file()
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]


def test_simulate_refuses_a_dead_point_in_one_line(tmp_path):
    f = write(tmp_path, DEAD, "near dead.toml")
    r = mjlink("simulate", str(f), "--no-video", "--out", str(tmp_path / "out"))
    assert r.returncode == 1 and "Traceback" not in r.stderr
    assert r.stderr.strip().count("\n") == 0 and "passes within" in r.stderr and str(f) in r.stderr
    assert not (tmp_path / "out").exists() or not any((tmp_path / "out").iterdir())


def test_check_command(tmp_path):
    r = mjlink("check", "takeup")
    assert r.returncode == 0 and "result: ok" in r.stdout, r.stderr
    f = write(tmp_path, ROCKER)
    r = mjlink("check", str(f))
    assert r.returncode == 1 and "Traceback" not in r.stderr
    assert "assembles only for input angles 0.0..125.6, 234.4..360.0 deg" in r.stdout
    assert r.stderr.strip().count("\n") == 0 and "cannot turn fully" in r.stderr


def test_dyad_sign_convention_as_documented():
    """mechanisms/README.md: sign = 1 puts C counterclockwise of A as seen from B (left of B->A)."""
    from mjlink.model import jet
    from mjlink.model.blocks import Dyad

    a, b = jet.vconst([1.0, 0.0, 0.0], 1), jet.vconst([0.0, 0.0, 0.0], 1)
    phi = jet.S(np.zeros(1), np.ones(1), np.zeros(1))
    up = Dyad("C", "a", "b", 1.0, 1.0, 1).solve({"a": a, "b": b}, phi, 0.0).point
    down = Dyad("C", "a", "b", 1.0, 1.0, -1).solve({"a": a, "b": b}, phi, 0.0).point
    np.testing.assert_allclose(up.v[0], [0.5, math.sqrt(3) / 2, 0.0], atol=1e-15)
    np.testing.assert_allclose(down.v[0], [0.5, -math.sqrt(3) / 2, 0.0], atol=1e-15)
    # the example: a = B (crank pin), b = D (rocker pivot to the right), sign 1: C below A-D
    m = validation.get(EXAMPLE_PATH)
    from mjlink import reference as R

    assert (R.solve(m, validation.cycle_angles(m)).position("C")[:, 1] < 0).all()


def test_angle_ranges_lie_within_one_period_in_order_whatever_the_start():
    """mjlink.reference.angle_ranges with the period: the same bad angles read the same from any
    starting angle, a range through the start is one range, one through 0 its two parts."""
    from mjlink.reference import angle_ranges

    def bad_at(start: float) -> tuple[np.ndarray, np.ndarray]:
        deg = start + np.linspace(0.0, 360.0, 3601)
        w = deg % 360.0
        return np.radians(deg), (w >= 234.35) | (w <= 125.65)

    for start in (0.0, 101.0, 200.0, -90.0):
        phi, bad = bad_at(start)
        assert angle_ranges(phi, bad, 2 * math.pi) == "0.0..125.6, 234.4..360.0", start
    deg = 101.0 + np.linspace(0.0, 360.0, 3601)
    bad = (deg % 360.0 >= 60.05) & (deg % 360.0 <= 329.95)
    assert angle_ranges(np.radians(deg), bad, 2 * math.pi) == "60.1..329.9"
    assert angle_ranges(np.radians(deg), bad) == "101.0..329.9, 420.1..461.0"  # as sampled, no period
