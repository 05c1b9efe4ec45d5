"""The fabric under the presser foot in MuJoCo (mjlink.sim.feed), against closed forms.

The expected values come from outside the model: the dog's advance while its teeth are above
the plate, from the reference's path of the head's feed-dog point (the geometric stitch,
which a fabric gripped by the dog and held by the foot must follow at low speed); and the
foot's free vibration on its spring, sqrt(k / m) sqrt(1 - zeta^2) / (2 pi). The tolerances are
the issue's: 1 % for the advance and for halving the timestep, 2 % for the frequency.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from mjlink import reference
from mjlink.model import mechanism
from mjlink.model.catalogue import shipped
from mjlink.sim import feed

LOW_RPM = 300.0  # slow enough that the fabric follows the dog
ADVANCE = 0.01  # the 1 %: the low-speed advance, and the change on halving the timestep
FREQUENCY = 0.02  # the 2 %: the foot's free vibration


@pytest.fixture(scope="module")
def head():
    return mechanism.load(shipped("mechanisms") / "lockstitch_head.toml")


def geometric_advance(mech) -> float:
    """m: the dog's travel along the feed while its top is above the plate, over one turn."""
    phi = mech.phi0 + np.linspace(0.0, mech.period, 72_001)
    p = reference.solve(mech, phi).position(mech.timing.roles["feed_dog"])
    up = (p[:-1, 1] > mech.timing.plate) & (p[1:, 1] > mech.timing.plate)
    return float(np.diff(p[:, 0])[up].sum())


@pytest.fixture(scope="module")
def slow(head):
    return feed.run_feed(head, speed_rpm=LOW_RPM, stitches=3)


def test_at_low_speed_the_fabric_advances_as_the_dog_does_while_its_teeth_are_up(head, slow):
    expected = geometric_advance(head)
    assert 3.0e-3 < abs(expected) < 3.2e-3  # the shipped head's 3.07 mm stitch
    for a in slow.advance[1:]:
        assert a == pytest.approx(expected, rel=ADVANCE)
    assert slow.advance[-1] == pytest.approx(slow.advance[-2], rel=1e-4)  # periodic: two stitches alike
    # The foot rides on the fabric: it rises with the dog and never leaves the fabric.
    assert slow.lift.max() < 1e-5
    # On the fabric on the dog's top, within the stiff contacts' 0.02 mm of give.
    assert slow.foot.max() == pytest.approx(head.timing.fabric + slow.dog.max(), abs=2e-5)  # m


def test_halving_the_timestep_moves_the_advance_by_less_than_1_percent(head, slow):
    fine = feed.run_feed(head, speed_rpm=LOW_RPM, stitches=3, timestep=slow.timestep / 2)
    assert fine.advance[-1] == pytest.approx(slow.advance[-1], rel=ADVANCE)


def test_the_foots_free_vibration_is_its_spring_and_masss():
    presser = feed.Presser(rate=2500.0, mass=0.06, damping=0.05, preload=30.0)
    t, z = feed.foot_vibration(presser, seconds=0.4)
    zc = z - z[-len(z) // 2 :].mean()
    up = np.flatnonzero((zc[:-1] < 0.0) & (zc[1:] >= 0.0))
    measured = (len(up) - 1) / (t[up[-1]] - t[up[0]])
    closed = math.sqrt(2500.0 / 0.06) * math.sqrt(1 - 0.05**2) / (2 * math.pi)
    assert measured == pytest.approx(closed, rel=FREQUENCY)
    assert presser.frequency == pytest.approx(closed, rel=1e-12)
    # It vibrates about where its spring holds its weight: the preload offset less m g / k.
    # (the mean of a decaying vibration's second half lies within 5 % of its centre)
    assert z[-len(z) // 2 :].mean() == pytest.approx(-30.0 / 2500.0 - 0.06 * 9.81 / 2500.0, rel=0.05)  # decay
