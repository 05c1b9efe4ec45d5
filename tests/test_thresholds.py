"""Each threshold the program applies is the one the user guide documents: ``mjlink.compare``'s
constants and rules against docs/verification.md's table "Every threshold" (tests/documented.py
reads it), and every other place the guide states a threshold against that table. The tests
that hold runs to the thresholds take them from the same table."""

from __future__ import annotations

import re

import numpy as np
import pytest
from documented import ROOT, THRESHOLDS, VERIFICATION, first_number, row_starting

from mjlink import compare

# The table's names and the constant each is applied as.
CONSTANTS = {
    "position_um": "POSITION_UM",
    "velocity_rel": "VELOCITY_REL",
    "acceleration_rel": "ACCELERATION_REL",
    "loop_um": "LOOP_UM",
    "thread_um": "THREAD_UM",
    "speed_held_rel": "SPEED_REL",
    "omega_rel": "OMEGA_REL",
    "min_samples": "MIN_SAMPLES",
    "torque_rel": "TORQUE_REL",
    "force_rel": "FORCE_REL",
    "shaking_rel": "SHAKING_REL",
    "steady_delta_rel": "STEADY_DELTA_REL",
}


@pytest.mark.parametrize("name", sorted(CONSTANTS))
def test_each_constant_is_its_documented_threshold(name):
    assert getattr(compare, CONSTANTS[name]) == THRESHOLDS[name]


def test_the_report_records_the_documented_thresholds():
    recorded = compare.thresholds()
    assert recorded == {k: THRESHOLDS[k] for k in recorded}


def test_the_rules_apply_the_thresholds_as_documented():
    """Each rule's scale as the table words it, on made-up numbers: a rule that doubled its
    constant, or took another scale, fails here."""
    rng = np.random.default_rng(11)
    torque = rng.normal(size=50)
    force = rng.normal(size=(50, 3))
    assert compare.torque_limit(torque) == pytest.approx(THRESHOLDS["torque_rel"] * np.ptp(torque), rel=1e-15)
    largest = np.linalg.norm(force, axis=1).max()
    assert compare.force_limit(force) == pytest.approx(THRESHOLDS["force_rel"] * largest, rel=1e-15)
    shaking = rng.normal(size=(50, 2)) * [1.0, 3.0]
    assert compare.shaking_force_limit(shaking) == pytest.approx(
        THRESHOLDS["shaking_rel"] * np.ptp(shaking[:, 1]), rel=1e-15
    )
    omega = np.linspace(0.0, -700.0, 20)
    assert compare.omega_limit(omega) == pytest.approx(THRESHOLDS["omega_rel"] * 700.0, rel=1e-15)
    # Steady motion: within the threshold of the reference's delta, or of 1e-3 below it.
    step = THRESHOLDS["steady_delta_rel"]
    for ref in (0.35, 0.02, 1e-4):
        scale = max(ref, 1e-3)
        assert compare.steady_failures("x", ref + 0.99 * step * scale, ref) == []
        assert compare.steady_failures("x", ref - 1.01 * step * scale, ref) != []


def test_an_agreement_holds_each_quantity_to_its_documented_threshold():
    """The checks an agreement makes, named as in the table: the kinematic run's and the
    dynamic run's limits are the documented ones, and a value just over one fails."""
    names = {
        "point position": "position_um",
        "loop gap": "loop_um",
        "point velocity": "velocity_rel",
        "point acceleration": "acceleration_rel",
        "thread length": "thread_um",
        "crank speed held": "speed_held_rel",
        "crank speed omega": "omega_rel",
    }
    values = {k: 0.0 for k in ("position_um", "velocity_rel", "acceleration_rel", "loop_um")}
    kin = compare.Agreement(kind="kinematics", samples=100, points=(), thread_um=0.0, speed_rel=0.0, **values)
    dyn = compare.Agreement(kind="dynamics", samples=100, points=(), thread_um=0.0, omega_rel=0.0, **values)
    limits = {c.quantity: c.limit for a in (kin, dyn) for c in a.checks() if c.limit is not None}
    assert limits.pop("samples") == THRESHOLDS["min_samples"]
    assert limits == {q: THRESHOLDS[n] for q, n in names.items()}
    assert kin.failures() == [] and dyn.failures() == []
    short = compare.Agreement(kind="kinematics", samples=99, points=(), thread_um=None, **values)
    assert any("samples" in f for f in short.failures())


def test_the_guide_states_each_threshold_alike_everywhere():
    """The agreement table's threshold row (docs/verification.md), the mechanisms' table's
    (docs/mechanisms.md), the verified envelope's sentence and the frame loads' (mechanisms/README.md)
    say what the table says."""
    row = [first_number(c) for c in row_starting(VERIFICATION, "threshold")]
    assert row == [THRESHOLDS[k] for k in ("position_um", "velocity_rel", "acceleration_rel", "loop_um")] + [
        THRESHOLDS["thread_um"],
        THRESHOLDS["omega_rel"],
    ]
    cells = row_starting(ROOT / "docs" / "mechanisms.md", "threshold")
    keys = ["position_um", "velocity_rel", "acceleration_rel", "loop_um", "thread_um", "omega_rel"]
    keys += ["torque_rel", "force_rel", "steady_delta_rel"]
    assert [first_number(c) for c in cells] == [THRESHOLDS[k] for k in keys]
    readme = (ROOT / "mechanisms" / "README.md").read_text(encoding="utf-8")
    said = re.search(r"position (\S+) um, velocity (\S+) and\s+acceleration (\S+) of range, loop gap (\S+) um", readme)
    assert said, "mechanisms/README.md no longer states the verified envelope's thresholds"
    assert [float(x) for x in said.groups()] == [
        THRESHOLDS[k] for k in ("position_um", "velocity_rel", "acceleration_rel", "loop_um")
    ]
    frame = re.search(r"and they must agree within\s+(\S+) of the reference's range", readme)
    assert frame and float(frame.group(1)) == THRESHOLDS["shaking_rel"]
