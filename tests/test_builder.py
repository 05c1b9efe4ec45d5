"""The MJCF builder: the model has the expected elements and loads as plain MJCF."""

import mujoco
import numpy as np
import pytest

from mjlink import reference as R
from mjlink import validation
from mjlink.model import catalogue as registry
from mjlink.sim import builder


def test_takeup_model_elements(takeup):
    model = builder.build(takeup)
    names = lambda kind, n: {mujoco.mj_id2name(model, kind, i) for i in range(n)}  # noqa: E731
    assert names(mujoco.mjtObj.mjOBJ_BODY, model.nbody) == {"world", "crank", "lever", "rocker"}
    assert model.njnt == 3 and all(t == mujoco.mjtJoint.mjJNT_HINGE for t in model.jnt_type)
    assert model.neq == 1 and model.eq_type[0] == mujoco.mjtEq.mjEQ_CONNECT
    assert {"P1", "P2", "P3", "P4", "P5", "S1", "S2", "S3", "N1", "N2"} <= names(mujoco.mjtObj.mjOBJ_SITE, model.nsite)
    assert model.ntendon == 1 and model.nu == 1
    np.testing.assert_allclose(sorted(model.body_mass[1:]), [0.0065, 0.0085, 0.01])
    np.testing.assert_allclose(model.opt.gravity, [0, -9.81, 0])
    assert model.opt.integrator == mujoco.mjtIntegrator.mjINT_RK4


def test_initial_pose_and_thread_equal_reference(takeup):
    model = builder.build(takeup)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    k = R.solve(takeup, [takeup.phi0])
    for name in takeup.point_names:
        sid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, name)
        np.testing.assert_allclose(data.site_xpos[sid], k.position(name)[0], atol=1e-12)
    assert abs(data.ten_length[0] - k.thread_length().v[0]) < 1e-12


@pytest.mark.parametrize("name", registry.names())
def test_xml_round_trip(name, tmp_path):
    mech = validation.get(name)
    path = tmp_path / f"{name}.xml"
    path.write_text(builder.to_xml(mech))
    model = mujoco.MjModel.from_xml_path(str(path))
    assert model.nbody == len(mech.links) + 1
    assert model.nsite >= len(mech.point_names)
