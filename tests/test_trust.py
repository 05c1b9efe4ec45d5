"""Runs that must not pass silently: an imposed speed that is not held, a run too short to
judge, quantities reported without a threshold (each either checked or marked informational)."""

import dataclasses

import pytest
from documented import THRESHOLDS as LIMIT

from mjlink import compare, pipeline, reference
from mjlink.errors import SimulationError
from mjlink.model.mechanism import Force
from mjlink.runs import Case
from mjlink.sim import simulate


def _loaded(mech, damping, force):
    dyn = dataclasses.replace(mech.dynamics, damping=damping, forces=(Force("P5", force),))
    return dataclasses.replace(mech, dynamics=dyn)


def test_imposed_speed_is_held_whatever_the_loads(takeup):
    """Heavy damping (5000 times the file's) and a force on the eyelet: the crank still turns
    at the file's speed, and the run agrees."""
    mech = _loaded(takeup, damping=0.05, force=(0.0, -20.0, 0.0))
    trace = simulate.run(mech, simulate.kinematic_case(mech))
    a = compare.agreement(mech, trace)
    assert a.speed_rel is not None and a.speed_rel <= LIMIT["speed_held_rel"]
    assert a.failures() == []


def test_a_speed_not_held_fails_the_run(takeup):
    """The same loads on a flywheel far too small to hold them: the run is reported failed."""
    mech = _loaded(takeup, damping=0.05, force=(0.0, -20.0, 0.0))
    case = simulate.kinematic_case(mech)
    weak = Case(case.kind, case.duration, case.omega0, dataclasses.replace(case.settings, flywheel=1e-6))
    a = compare.agreement(mech, simulate.run(mech, weak))
    assert a.speed_rel > LIMIT["speed_held_rel"]
    assert any("crank speed held" in f for f in a.failures())


def test_a_run_too_short_is_refused_and_never_passes(takeup, tmp_path):
    with pytest.raises(SimulationError, match=r"only 1 sample .* give --cycles of at least"):
        pipeline.run(takeup, tmp_path, pipeline.Options(cycles=1e-300, video=False, plots=False))
    assert not (tmp_path / "takeup").exists()
    short = simulate.run(takeup, simulate.kinematic_case(takeup, cycles=0.005))
    failures = compare.agreement(takeup, short).failures()
    assert len(short.time) < LIMIT["min_samples"] and any("samples" in f for f in failures)


def test_every_reported_quantity_is_checked_or_informational(takeup):
    trace = simulate.run(takeup, simulate.dynamic_case(takeup, duration=0.05))
    a = compare.agreement(takeup, trace, reference.forward_dynamics(takeup, trace.time))
    by_name = {c.quantity: c for c in a.checks()}
    assert by_name["crank speed omega"].limit == LIMIT["omega_rel"]
    assert by_name["point position"].limit is None and by_name["point position"].result == "informational"
    text = compare.table([a])
    assert "informational" in text and "pass" in text
    assert {c["result"] for c in a.as_dict()["checks"]} <= {"pass", "FAIL", "informational"}


def test_report_records_versions_command_and_settings(takeup, tmp_path):
    import json

    import mujoco

    from mjlink import __version__

    pipeline.run(
        takeup,
        tmp_path,
        pipeline.Options(video=False, plots=False, dynamics=False, loads=False),
        command=("python", "-m", "mjlink", "simulate", "takeup", "--out", str(tmp_path)),
    )
    rep = json.loads((tmp_path / "takeup" / "report.json").read_text())
    prov = rep["provenance"]
    assert prov["versions"]["mjlink"] == __version__ and prov["versions"]["mujoco"] == mujoco.__version__
    assert prov["versions"]["python"].count(".") == 2
    assert prov["command"].startswith("python -m mjlink simulate takeup --out ")
    assert prov["options"]["video"] is False and prov["options"]["speed"] is None
    assert rep["kinematics"]["settings"]["integrator"] == "RK4" and rep["kinematics"]["settings"]["timestep_s"] == 5e-5


def test_long_runs_report_progress(takeup, monkeypatch):
    monkeypatch.setattr(simulate, "PROGRESS_EVERY", 0.0)
    seen: list[float] = []
    simulate.run(takeup, simulate.kinematic_case(takeup, cycles=2.0), progress=seen.append)
    assert len(seen) >= 2 and seen == sorted(seen) and seen[-1] == 1.0 and seen[0] < 1.0
