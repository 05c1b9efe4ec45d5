"""The frame's shaking force and moment: MuJoCo's ground reactions against the reference."""

from __future__ import annotations

import pytest

from mjlink import compare, validation
from mjlink.sim import simulate


@pytest.mark.parametrize("name", ["takeup", "crank_slider", "warp_knitting", "takeup_eyelets"])
def test_mujoco_ground_reactions_sum_to_the_reference_shaking_loads(name: str) -> None:
    mech = validation.get(name)
    trace = simulate.run(mech, simulate.kinematic_case(mech, cycles=1.0))
    loads = compare.loads(mech, trace)
    assert loads.shaking_force_rel <= compare.SHAKING_REL / 5  # measured 3e-5 .. 8e-5
    if mech.geared:  # no gear-equality torque is recorded: the moment is not compared
        assert loads.shaking_moment_rel is None
    else:
        assert loads.shaking_moment_rel is not None and loads.shaking_moment_rel <= compare.SHAKING_REL / 5
    ref, got = compare.frame_reference(mech, trace), compare.frame_mujoco(mech, trace)
    assert ref.force.shape == got.force.shape == (len(trace.phi), 2)
