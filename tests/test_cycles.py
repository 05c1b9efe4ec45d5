"""Per-cycle statistics over exactly one period, against hand cases.

At constant crank speed the mechanism's inertia and gravity return over a cycle what they
take, and so does a constant force: the mean driving power is the damping's alone, b omega^2.
"""

import dataclasses
import math
from fractions import Fraction

import numpy as np
import pytest

from mjlink import analysis, validation
from mjlink.model import catalogue
from mjlink.model.mechanism import Force


@pytest.mark.parametrize("omega", [100.0, 955.0, -300.0])
def test_mean_power_is_the_dampings_alone(takeup, omega):
    b = takeup.dynamics.damping
    cycle = analysis.torque_cycle(takeup, omega)
    assert cycle.power == pytest.approx(b * omega**2, rel=1e-9)
    assert cycle.mean == pytest.approx(b * omega, rel=1e-9)
    assert cycle.rms >= abs(cycle.mean) and cycle.peak >= cycle.rms


def test_a_constant_load_adds_no_mean_power(takeup):
    loaded = dataclasses.replace(
        takeup, dynamics=dataclasses.replace(takeup.dynamics, forces=(Force("P5", (3.0, -2.0, 0.0)),))
    )
    omega = 100.0
    plain, cycle = analysis.torque_cycle(takeup, omega), analysis.torque_cycle(loaded, omega)
    assert cycle.power == pytest.approx(takeup.dynamics.damping * omega**2, rel=1e-9)
    assert cycle.peak != pytest.approx(plain.peak)  # the load is felt within the cycle


def test_without_damping_nothing_is_consumed(takeup):
    free = dataclasses.replace(takeup, dynamics=dataclasses.replace(takeup.dynamics, damping=0.0))
    cycle = analysis.torque_cycle(free, 955.0)
    assert abs(cycle.power) <= 1e-9 * cycle.peak * 955.0
    assert cycle.energy > 0


def test_geared_period_spans_every_turn():
    """warp_knitting's second crank turns -1/2 as fast as the input (its file's ratio): the
    mechanism repeats after two input turns, 72 samples at 36 a turn, the last short of the end."""
    mech = validation.get("warp_knitting")
    phi = analysis.one_period(mech, per_turn=36)
    assert "ratio = -0.5 " in catalogue.path_of("warp_knitting").read_text()
    turns = Fraction(-0.5).denominator
    assert len(phi) == 36 * turns and np.allclose(np.diff(phi), 2 * math.pi / 36, rtol=1e-12)
    assert phi[-1] - mech.phi0 == pytest.approx(turns * 2 * math.pi * 71 / 72, rel=1e-12)
