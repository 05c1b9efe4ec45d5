"""The frame's shaking force and moment: MuJoCo's ground reactions against the reference."""

from __future__ import annotations

import pytest
from documented import THRESHOLDS as LIMIT

from mjlink import compare, validation
from mjlink.errors import MechanismFileError
from mjlink.sim import simulate


@pytest.mark.parametrize("name", ["takeup", "crank_slider", "warp_knitting", "takeup_eyelets", "lockstitch_head"])
def test_mujoco_ground_reactions_sum_to_the_reference_shaking_loads(name: str) -> None:
    """Geared ones included: the gear couplings' share of the frame's moment comes from the
    torque each geared shaft's joint carries (warp_knitting's gear -1:2, the head's belt 1:1,
    whose share is nil, and its hook's gears 2:1)."""
    mech = validation.get(name)
    trace = simulate.run(mech, simulate.kinematic_case(mech, cycles=1.0))
    loads = compare.loads(mech, trace)
    assert loads.shaking_force_rel <= LIMIT["shaking_rel"] / 5  # measured 3e-5 .. 8e-5
    assert loads.shaking_moment_rel is not None and loads.shaking_moment_rel <= LIMIT["shaking_rel"] / 5
    assert bool(trace.gear_torques) == bool(mech.geared)
    ref, got = compare.frame_reference(mech, trace), compare.frame_mujoco(mech, trace)
    assert ref.force.shape == got.force.shape == (len(trace.phi), 2)


def test_a_balancing_counterweight_cancels_the_cranks_inertia_force() -> None:
    """Takeup's crank (10 g at 5 mm opposite its pin) alone, with 20 g at 2.5 mm toward the pin:
    the crank's centre of mass sits on the pivot, so the frame feels the weight alone."""
    import numpy as np

    from mjlink import analysis, reference, study
    from mjlink.reference import batch

    mech = study.override(
        validation.get("takeup"),
        {
            "links.lever.mass": 0.0,
            "links.rocker.mass": 0.0,
            "counterweight.mass": 20.0,
            "counterweight.radius": 2.5,
            "counterweight.angle": 0.0,
        },
    )
    kin = reference.solve(mech, analysis.one_period(mech, 72))
    fl = batch.frame_loads(mech, kin, 300.0)
    assert np.allclose(fl.force, [0.0, -0.030 * 9.81], atol=1e-12)
    unbalanced = study.override(mech, {"counterweight.mass": 0.0})
    f0 = batch.frame_loads(unbalanced, reference.solve(unbalanced, kin.phi), 300.0).force
    assert np.abs(f0[:, 0]).max() > 0.4  # 10 g x 5 mm x (300 rad/s)^2 = 4.5 N without it


def test_counterweight_in_the_file_and_mujoco_agrees(tmp_path) -> None:
    from mjlink import reference
    from mjlink.model import catalogue, mechanism

    text = catalogue.path_of("crank_slider").read_text()
    mech = validation.validate(
        mechanism.parse(text + "\n[counterweight]\nmass = 40.0\nradius = 12.0\n", tmp_path / "cw.toml")
    )
    assert mech.counterweight is not None and mech.counterweight.angle == pytest.approx(3.141592653589793)
    trace = simulate.run(mech, simulate.kinematic_case(mech, cycles=1.0))
    loads = compare.loads(mech, trace)
    assert loads.failures() == []
    base = validation.get("crank_slider")
    j_cw = reference.SpectralDynamics(mech, samples=64).evaluate([mech.phi0])[0, 0]
    j0 = reference.SpectralDynamics(base, samples=64).evaluate([base.phi0])[0, 0]
    assert j_cw - j0 == pytest.approx(0.040 * 0.012**2, rel=1e-9)  # m r^2 of a point on the crank
    with pytest.raises(MechanismFileError, match=r"\[counterweight\]: unknown key 'weight'"):
        mechanism.parse(text + "\n[counterweight]\nmass = 1.0\nradius = 1.0\nweight = 2\n", tmp_path / "b.toml")
