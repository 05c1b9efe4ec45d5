"""MuJoCo against the vector-method reference, for every mechanism file, at the issue's thresholds."""

import numpy as np
import pytest
from documented import THRESHOLDS as LIMIT

from mjlink import compare, pipeline, validation
from mjlink import reference as R
from mjlink.model import catalogue as registry
from mjlink.sim import simulate as S


@pytest.fixture(scope="module", params=registry.names())
def mech(request):
    return validation.get(request.param)


def test_kinematic_run_agrees(mech):
    a = compare.agreement(mech, S.run(mech, S.kinematic_case(mech)))
    assert a.position_um <= LIMIT["position_um"]
    assert a.velocity_rel <= LIMIT["velocity_rel"]
    assert a.acceleration_rel <= LIMIT["acceleration_rel"]
    assert a.loop_um <= LIMIT["loop_um"]
    if a.thread_um is not None:
        assert a.thread_um <= LIMIT["thread_um"]
    assert a.failures() == []


# takeup_eyelets' dynamic run takes about 8 s (a force table applied at every RK4 stage).
@pytest.mark.parametrize(
    "name",
    [
        pytest.param(n, marks=pytest.mark.slow) if n == "takeup_eyelets" else n
        for n in registry.names()
        if pipeline.has_masses(validation.get(n))
    ],
)
def test_dynamic_run_agrees(name):
    mech = validation.get(name)
    tr = S.run(mech, S.dynamic_case(mech))
    motion = R.forward_dynamics(mech, tr.time)
    a = compare.agreement(mech, tr, motion)
    assert a.omega_rel <= LIMIT["omega_rel"]
    assert a.failures() == []


def test_kinematic_crank_turns_at_constant_speed(takeup):
    tr = S.run(takeup, S.kinematic_case(takeup))
    assert np.ptp(tr.omega) < 1e-8 * takeup.speed
    assert tr.phi[-1] - tr.phi[0] >= 2 * np.pi * takeup.cycles - takeup.speed * 1e-4
