"""Batched MuJoCo verification of design variants: one rollout, the same judgement as simulate."""

import dataclasses

import mujoco
import numpy as np
import pytest
from documented import THRESHOLDS as LIMIT

from mjlink import compare, validation
from mjlink.errors import MjlinkError
from mjlink.model import names
from mjlink.runs import KINEMATIC
from mjlink.sim import batch, builder, simulate

TOL = 0.02e-3  # m


def variants(mech, n, seed=0):
    """``n`` variants of ``mech``: every nonzero block length and every ground point's x, y
    moved uniformly within +-0.02 mm."""
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(n):
        steps = [
            dataclasses.replace(
                b,
                **{
                    f.name: getattr(b, f.name) + rng.uniform(-TOL, TOL)
                    for f in dataclasses.fields(b)
                    if f.name in ("length", "length_a", "length_b") and getattr(b, f.name)
                },
            )
            for b in mech.steps
        ]
        ground = {k: v + np.array([*rng.uniform(-TOL, TOL, 2), 0.0]) for k, v in mech.ground.items()}
        out.append(dataclasses.replace(mech, steps=tuple(steps), ground=ground))
    return out


def initial_state(b):
    """The full physics state of a built model's keyframe ``initial``."""
    d = mujoco.MjData(b.model)
    mujoco.mj_resetDataKeyframe(b.model, d, mujoco.mj_name2id(b.model, mujoco.mjtObj.mjOBJ_KEY, "initial"))
    s = np.empty(mujoco.mj_stateSize(b.model, mujoco.mjtState.mjSTATE_FULLPHYSICS))
    mujoco.mj_getState(b.model, d, s, mujoco.mjtState.mjSTATE_FULLPHYSICS)
    return s


@pytest.mark.parametrize(("name", "n"), [("takeup", 3), ("warp_knitting", 2), ("takeup_eyelets", 2)])
def test_variants_pass_in_one_batch(name, n):
    mech = validation.get(name)
    mechs = [mech, *variants(mech, n)]
    res, timing = batch.verify_timed(mechs, threads=2)
    steps = simulate.kinematic_case(mech, cycles=1.0).steps
    assert timing.steps == len(mechs) * (steps + 1)  # one period each, one group
    for v in res:
        assert v.reason == "" and v.failures == () and v.passed, v
        assert v.samples == steps + 1
        assert 0 < v.position_error <= LIMIT["position_um"] * 1e-6
        assert 0 < v.loop_gap <= LIMIT["loop_um"] * 1e-6
        assert 0 < v.velocity_error <= LIMIT["velocity_rel"]
        assert v.speed_error <= LIMIT["speed_held_rel"]
        assert (0 < v.thread_error <= LIMIT["thread_um"] * 1e-6) if mech.thread else np.isnan(v.thread_error)
    # The variants really differ from the nominal mechanism, and so do their errors.
    assert len({v.position_error for v in res}) == len(res)


@pytest.mark.parametrize("name", ["takeup", "takeup_eyelets"])
def test_nominal_equals_simulate_kinematic_agreement(name):
    """The batch judges a run as simulate does: same samples, same errors (takeup_eyelets'
    point force, applied open loop here and per Runge-Kutta stage there, changes nothing
    at the thresholds' scale)."""
    mech = validation.get(name)
    a = compare.agreement(mech, simulate.run(mech, simulate.kinematic_case(mech, cycles=1.0)))
    (v,) = batch.verify([mech])
    rel = 1e-9 if name == "takeup" else 1e-5
    assert v.samples == a.samples
    assert v.position_error == pytest.approx(a.position_um * 1e-6, rel=rel)
    assert v.velocity_error == pytest.approx(a.velocity_rel, rel=rel)
    assert v.loop_gap == pytest.approx(a.loop_um * 1e-6, rel=rel)
    assert v.thread_error == pytest.approx(a.thread_um * 1e-6, rel=rel)
    assert v.speed_error == pytest.approx(a.speed_rel, rel=rel)


@pytest.mark.parametrize("name", ["takeup_eyelets", "warp_knitting"])
def test_fast_model_is_a_twin_of_make(name):
    """make_batch's model (one compile, no skybox, no acceleration-stage sensors) steps exactly as
    make's and its sensors read as make's."""
    mech = validation.get(name)
    s = simulate.kinematic_case(mech, cycles=1.0).settings
    fast, plain = builder.make_batch(mech, s), builder.make(mech, s)
    np.testing.assert_array_equal(initial_state(fast), initial_state(plain))
    np.testing.assert_array_equal(fast.model.key_qvel, plain.model.key_qvel)
    datas = []
    for b in (fast, plain):
        d = mujoco.MjData(b.model)
        mujoco.mj_resetDataKeyframe(b.model, d, 0)
        mujoco.mj_step(b.model, d, nstep=200)
        datas.append(d)
    np.testing.assert_array_equal(datas[0].qpos, datas[1].qpos)
    np.testing.assert_array_equal(datas[0].qvel, datas[1].qvel)
    # make_batch carries the sensors verification compares, each equal to make's.
    assert set(fast.sensors) < set(plain.sensors)
    for key, adr in fast.sensors.items():
        a, b = int(fast.model.sensor_dim[np.searchsorted(fast.model.sensor_adr, adr)]), plain.sensors[key]
        np.testing.assert_array_equal(datas[0].sensordata[adr : adr + a], datas[1].sensordata[b : b + a])
    assert not any(q in ("acc", "force", "torque", "comacc") for q, _ in fast.sensors)


@pytest.mark.parametrize(("name", "threads"), [("takeup", 1), ("takeup_eyelets", 2), ("warp_knitting", 2)])
def test_rollout_rows_equal_a_plain_step_loop(name, threads):
    """Row k of rollout's sensordata is the sensors of the state before step k+1 (t = k dt),
    exactly as a Python loop of mj_step records them; the loop-anchor sensors give the gap
    simulate's probe computes from the connect equality."""
    mech = validation.get(name)
    mechs = [mech, *variants(mech, 1)]
    built = [builder.make_batch(m, simulate.kinematic_case(m, cycles=1.0).settings) for m in mechs]
    n = 150
    control = np.array([batch.external_forces(m, b, n) for m, b in zip(mechs, built)])
    sd = batch.rollout(
        [b.model for b in built], np.array([initial_state(b) for b in built]), n, control=control, threads=threads
    )
    assert sd.shape == (2, n, built[0].model.nsensordata)
    for b, rows, xfrc in zip(built, sd, control, strict=True):
        model, d = b.model, mujoco.MjData(b.model)
        mujoco.mj_resetDataKeyframe(model, d, 0)
        d.xfrc_applied[:] = xfrc[0].reshape(-1, 6)  # the load sensors of row 0 see step 1's forces
        mujoco.mj_forward(model, d)
        np.testing.assert_array_equal(rows[0], d.sensordata)  # row 0: the initial state
        gaps = [_equality_gaps(b, d).max()]
        plain = []
        for k in range(n):
            d.xfrc_applied[:] = xfrc[k].reshape(-1, 6)
            mujoco.mj_step(model, d)
            plain.append(d.sensordata.copy())
            mujoco.mj_forward(model, d)
            gaps.append(_equality_gaps(b, d).max())
        np.testing.assert_array_equal(rows, np.array(plain))
        gap = np.zeros(n)
        for pr, _ in b.loops:
            a, c = (anchor(model, rows, names.loop_anchor(pr.pin, link)) for link in (pr.child, pr.parent))
            gap = np.maximum(gap, np.linalg.norm(a - c, axis=1))
        np.testing.assert_allclose(gap, gaps[:n], rtol=1e-6, atol=1e-15)


def _equality_gaps(built, data):
    """Distance (m) between the two anchors of every loop's connect equality, from its data."""
    model = built.model
    gaps = []
    for _, i in built.loops:
        b1, b2 = model.eq_obj1id[i], model.eq_obj2id[i]
        p1 = data.xpos[b1] + data.xmat[b1].reshape(3, 3) @ model.eq_data[i, 0:3]
        p2 = data.xpos[b2] + data.xmat[b2].reshape(3, 3) @ model.eq_data[i, 3:6]
        gaps.append(np.linalg.norm(p1 - p2))
    return np.array(gaps)


def anchor(model, rows, site):
    """(n, 3) positions of a loop-anchor site from its position sensor."""
    i = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SENSOR, names.sensor(site, "pos"))
    return rows[:, model.sensor_adr[i] : model.sensor_adr[i] + 3]


def test_other_topology_is_refused_in_one_line(takeup):
    with pytest.raises(MjlinkError) as e:
        batch.verify([takeup, *variants(takeup, 1), validation.get("crank_slider")])
    msg = str(e.value)
    assert "\n" not in msg
    assert "variant 2 (crank_slider)" in msg and "nsensordata" in msg and "one mechanism" in msg


def test_missed_thresholds_are_flagged_not_dropped(takeup):
    """A loop closure ten times softer misses the position threshold: every variant comes
    back, flagged, in order; one that cannot be built, or a run that diverges, has its reason."""
    soft = dataclasses.replace(KINEMATIC, solref=(2e-3, 1.0))
    cannot = dataclasses.replace(
        takeup,
        steps=tuple(dataclasses.replace(b, length_a=1e-3) if hasattr(b, "length_a") else b for b in takeup.steps),
    )
    with np.errstate(all="ignore"):
        res = batch.verify([takeup, cannot, *variants(takeup, 1)], settings=soft)
    assert len(res) == 3
    for v in (res[0], res[2]):
        assert not v.passed and v.reason == ""
        assert v.position_error > LIMIT["position_um"] * 1e-6
        assert any("point position error" in f and "exceeds 0.1" in f for f in v.failures)
    assert not res[1].passed and res[1].reason.startswith("model not built: ") and "cannot close" in res[1].reason
    assert "\n" not in res[1].reason and np.isnan(res[1].position_error)

    (v,) = batch.verify([takeup], settings=dataclasses.replace(KINEMATIC, timestep=1e-3))
    assert not v.passed and "diverged" in v.reason and np.isnan(v.position_error)


def test_a_faster_variant_runs_in_its_own_rollout(takeup):
    """Another speed is another number of steps: such a variant is verified too (its own
    rollout). At ten times the speed, above the verified speed, its clock is scaled
    (``simulate.kinematic_case``) and it holds the thresholds as the verified run does."""
    fast = dataclasses.replace(takeup, speed=10 * takeup.speed)
    res, timing = batch.verify_timed([takeup, fast])
    assert res[0].passed and res[1].passed and res[1].reason == ""
    assert res[1].samples != res[0].samples
    assert res[1].samples == simulate.kinematic_case(fast, cycles=1.0).steps + 1
    assert timing.steps == res[0].samples + res[1].samples


def test_threads_must_be_positive(takeup):
    with pytest.raises(MjlinkError, match="threads"):
        batch.verify([takeup], threads=0)
