"""The sensor route of :mod:`mjlink.sim.simulate` against a plain twin.

The twin samples the same runs the way MuJoCo's API reads a state one at a time: a Python
loop of ``mj_step``, and at every sample ``mj_forward`` then point velocities ``J qvel`` and
accelerations ``J qacc + Jdot qvel`` from the site Jacobians, tree pair forces and the guides'
moments from ``cfrc_int``, loop pair forces from the connect equalities' ``efc_force``, the driving torque
from the crank's row of the equation of motion. The fast route (compiled rollout chunks,
everything from sensordata, loop forces by Newton's law per link) must give the same numbers
to rounding.
"""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from mjlink import validation
from mjlink.runs import Case
from mjlink.sim import builder, simulate

MECHANISMS = ("takeup", "crank_slider", "takeup_eyelets", "warp_knitting")


def plain_run(mech, case: Case) -> dict[str, np.ndarray]:
    """The twin: per-sample probes on a plain mj_step loop (forces as the fast route sets them)."""
    built = builder.make(mech, case.settings)
    model, data = built.model, mujoco.MjData(built.model)
    data.qvel[:] = builder.consistent_velocity(model, data, built.input_dof, case.omega0)
    forces = simulate.Forces(mech, built)
    jp, jr, jd, jrd = (np.zeros((3, model.nv)) for _ in range(4))
    out: dict[str, list] = {}

    def put(key, value):
        out.setdefault(key, []).append(np.array(value, dtype=float))

    for step in range(case.steps + 1):
        if step % case.sample_every == 0:
            mujoco.mj_kinematics(model, data)
            forces.apply(model, data)
            mujoco.mj_forward(model, data)
            mujoco.mj_rnePostConstraint(model, data)
            c = built.input_dof
            put("phi", mech.phi0 + data.qpos[built.input_qpos])
            put("omega", data.qvel[c])
            put("eps", data.qacc[c])
            for name in mech.moving_points:
                sid = built.sites[name]
                mujoco.mj_jacSite(model, data, jp, jr, sid)
                mujoco.mj_jacDot(model, data, jd, jrd, data.site_xpos[sid], int(model.site_bodyid[sid]))
                put(f"P {name}", data.site_xpos[sid])
                put(f"V {name}", jp @ data.qvel)
                put(f"A {name}", jp @ data.qacc + jd @ data.qvel)
            for link, b in built.bodies.items():
                mujoco.mj_jacBody(model, data, jp, jr, b)
                mujoco.mj_jacDot(model, data, jd, jrd, data.xpos[b], b)
                put(f"LW {link}", (jr @ data.qvel)[2])
                put(f"LE {link}", (jr @ data.qacc + jrd @ data.qvel)[2])
            if built.thread >= 0:
                put("thread", data.ten_length[built.thread])
            if case.loads:
                mq = np.zeros(model.nv)
                mujoco.mj_mulM(model, data, mq, data.qacc)
                applied = np.zeros(model.nv)
                for b in range(1, model.nbody):
                    f = data.xfrc_applied[b]
                    mujoco.mj_applyFT(model, data, f[:3].copy(), f[3:].copy(), data.xipos[b].copy(), b, applied)
                put(
                    "torque",
                    mq[c]
                    - model.dof_armature[c] * data.qacc[c]
                    + data.qfrc_bias[c]
                    - data.qfrc_passive[c]
                    - data.qfrc_constraint[c]
                    - applied[c],
                )
                for pr, j in built.tree:
                    b = built.bodies[pr.child]
                    f = data.cfrc_int[b, 3:6]
                    if not pr.revolute:
                        u = data.xmat[b].reshape(3, 3) @ model.jnt_axis[j]
                        n = np.array([-u[1], u[0], 0.0])
                        # The guide's moment about the body origin: cfrc_int's is about the
                        # subtree's centre of mass.
                        c = data.subtree_com[model.body_rootid[b]]
                        put(f"RM {pr.label}", data.cfrc_int[b, 2] + np.cross(c - data.xpos[b], f)[2])
                        f = (f @ n) * n
                    put(f"RF {pr.label}", f)
                for pr, i in built.loops:
                    rows = (data.efc_type[: data.nefc] == mujoco.mjtConstraint.mjCNSTR_EQUALITY) & (
                        data.efc_id[: data.nefc] == i
                    )
                    put(f"RF {pr.label}", data.efc_force[: data.nefc][rows])
        if step < case.steps:
            forces.hold(model, data)
            mujoco.mj_step(model, data)
    return {k: np.array(v) for k, v in out.items()}


def fast_arrays(mech, trace) -> dict[str, np.ndarray]:
    got = {"phi": trace.phi, "omega": trace.omega, "eps": trace.eps}
    for name in mech.moving_points:
        got[f"P {name}"] = trace.points[name]
        got[f"V {name}"] = trace.velocities[name]
        got[f"A {name}"] = trace.accelerations[name]
    for link in trace.link_omega:
        got[f"LW {link}"] = trace.link_omega[link]
        got[f"LE {link}"] = trace.link_eps[link]
    if trace.thread_length is not None:
        got["thread"] = trace.thread_length
    if trace.torque is not None:
        got["torque"] = trace.torque
        for label, f in trace.reactions.items():
            got[f"RF {label}"] = f
        for label, m in trace.moments.items():
            got[f"RM {label}"] = m
    return got


def _short(case: Case, seconds: float) -> Case:
    return Case(case.kind, seconds, case.omega0, case.settings, case.sample_every, case.loads)


@pytest.mark.parametrize("name", MECHANISMS)
def test_sensor_traces_equal_the_plain_twin(name):
    """Kinematic run (every step, with loads) and the first 0.1 s of the dynamic run: every
    trace equal to the twin's within 1e-9 of its range (rounding; the driving torque comes as
    the drive's output minus the flywheel's share, so it carries the flywheel's rounding)."""
    mech = validation.get(name)
    for case in (_short(simulate.kinematic_case(mech), 0.02), _short(simulate.dynamic_case(mech), 0.1)):
        want = plain_run(mech, case)
        got = fast_arrays(mech, simulate.run(mech, case))
        assert set(got) == set(want)
        for key, w in want.items():
            g = got[key]
            assert g.shape == w.shape, key
            span = max(float(np.ptp(w)), float(np.abs(w).max()) * 1e-6, 1e-12)
            assert np.abs(g - w).max() <= 1e-9 * span, (key, np.abs(g - w).max(), span)


def test_rollout_chunks_join_exactly(monkeypatch):
    """A run stepped in many small rollout chunks is bit-identical to one in a single chunk:
    each chunk starts from the previous one's state and solver warm start."""
    mech = validation.get("takeup")
    case = _short(simulate.dynamic_case(mech), 0.05)
    whole = simulate.run(mech, case)
    monkeypatch.setattr(simulate, "CHUNK_STEPS", 7)
    pieces = simulate.run(mech, case)
    np.testing.assert_array_equal(whole.time, pieces.time)
    np.testing.assert_array_equal(whole.qpos, pieces.qpos)
    np.testing.assert_array_equal(whole.points["P5"], pieces.points["P5"])


@pytest.mark.parametrize("name", ["takeup", "takeup_eyelets"])  # rollout chunks; Python steps (point forces)
def test_a_divergent_run_is_named_at_its_time(name):
    """A loop that opens is reported with its equality and time, from the sensors."""
    mech = validation.get(name)
    case = simulate.kinematic_case(mech)
    built = builder.make(mech, case.settings)
    built.physics.eq_solref[:, 0] = 1.0  # a loop so soft that the run pulls it apart
    built.physics.opt.timestep = 5e-4
    with pytest.raises(simulate.SimulationError, match=r"loop constraint loop_\w+ opened to .* mm at t = "):
        simulate.run(mech, _short(case, 2.0), built=built)


@pytest.mark.parametrize("name", ["takeup", "takeup_eyelets"])  # rollout chunks; Python steps (point forces)
def test_a_run_steps_the_model_without_what_is_only_drawn_to_the_same_bits(name):
    """A run steps ``Built.physics``: the model without its geoms and skybox (no mass, no
    contact), with the same ids. Its traces equal, bit for bit, those of the drawn model."""
    mech = validation.get(name)
    case = _short(simulate.dynamic_case(mech), 0.05)
    built = builder.make(mech, case.settings)
    lean, drawn = built.physics, built.model
    assert lean.ngeom == 0 < drawn.ngeom and lean.ntex == 0 < drawn.ntex
    for n in ("nbody", "njnt", "nsite", "neq", "ntendon", "nu", "nsensor", "nsensordata", "nkey"):
        assert getattr(lean, n) == getattr(drawn, n), n
    np.testing.assert_array_equal(lean.key_qvel, drawn.key_qvel)
    np.testing.assert_array_equal(lean.key_qpos, drawn.key_qpos)
    import dataclasses

    a = simulate.run(mech, case, built=built)
    b = simulate.run(mech, case, built=dataclasses.replace(built, physics=drawn))
    for key in ("time", "phi", "omega", "eps", "qpos", "torque"):
        np.testing.assert_array_equal(getattr(a, key), getattr(b, key), err_msg=key)
    for p in mech.moving_points:
        for field in ("points", "velocities", "accelerations"):
            np.testing.assert_array_equal(getattr(a, field)[p], getattr(b, field)[p], err_msg=f"{field} {p}")
