"""The needle thread under tension in MuJoCo: the thread a tendon that only pulls, the check spring
a sprung slide joint with its stops, the head turned at its speed.

The kinematic model of the head (:mod:`.builder`) is changed in three places: the check spring's
thread hook (the ``[balance] check_spring`` point, a ground site) moves onto a body of its own on
a slide joint along the bisector of the thread's turn there at the needle bar's top, limited to
the spring's travel, with its stiffness, damping and mass and a spring reference that presses
it against its rest stop with its force at rest; the thread's tendon gets the thread's
stiffness ``EA / M`` and a dead band ``springlength = [0, M]``, ``M`` the thread it holds (so
it pulls only when longer, with ``EA`` times the strain on the thread's own length: the
reference's law). The thread is held at both ends (the discs and
the eye) and slides over every site without friction: the reference's ``anchored`` case
(:func:`mjlink.analysis.tension.needle_tension`), where both model the same physics.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..model import names
from ..model.mechanism import Mechanism
from ..model.tension import DEFAULTS, ThreadTension
from . import builder
from ._mujoco import mujoco, rollout
from .simulate import kinematic_case

__all__ = ["SPRING", "ThreadRun", "run_thread"]

SPRING = "check_spring"  # the spring's body and slide joint


@dataclass(frozen=True, kw_only=True)
class ThreadRun:
    """MuJoCo's thread over the last of ``cycles`` stitches: ``theta`` (N,) deg from the
    needle bar's top, ``length`` (N,) m the tendon's length, ``spring`` (N,) m the check
    spring's travel from its rest stop, ``tension`` (N,) N the tendon's pull (its stiffness
    times its length beyond ``material``, none within); ``material`` m and ``stiffness`` N/m
    the tendon's; ``timestep`` s."""

    theta: np.ndarray
    length: np.ndarray
    spring: np.ndarray
    tension: np.ndarray
    material: float
    stiffness: float
    timestep: float
    cycles: int


def _unit(v: np.ndarray) -> np.ndarray:
    out: np.ndarray = v / np.linalg.norm(v)
    return out


def run_thread(
    mech: Mechanism, material: float, *, settings: ThreadTension | None = None, cycles: int = 3
) -> ThreadRun:
    """Turn the head ``cycles`` stitches at its speed from the needle bar's top, the tendon
    holding ``material`` m of thread, and sample it and the check spring over the last.

    Args:
      mech: a head with a ``[thread]`` path and a ``[balance]`` table whose check spring's
        neighbours on the path are ground points (its travel is a fixed line).
      material: the thread the tendon holds, m (unstretched).
      settings: the thread and the spring; ``mech.tension`` or the defaults when None.
      cycles: stitches to run.
    Returns:
      :class:`ThreadRun`.
    """
    bal, path = mech.balance, mech.thread
    assert bal is not None and path
    cfg = settings or mech.tension or DEFAULTS
    cs = path.index(bal.check_spring)
    up, hook, down = (mech.ground.get(p) for p in path[cs - 1 : cs + 2])
    if up is None or hook is None or down is None:
        raise ValueError(f"{mech.name}: the check spring and its neighbours on the path must be [ground] points")
    axis = _unit(_unit(np.asarray(up) - hook) + _unit(np.asarray(down) - hook))
    case = kinematic_case(mech, cycles=cycles)
    spec = builder.build_spec(mech, case.settings)

    # The spring's hook on its own body, sliding towards the thread's line.
    spec.delete(spec.site(bal.check_spring))
    body = spec.worldbody.add_body(name=SPRING, pos=np.asarray(hook, dtype=float).tolist())
    body.mass = cfg.spring_mass
    body.inertia = [1e-12, 1e-12, 1e-12]  # a point mass: the slide has no rotation to weigh
    joint = body.add_joint(name=SPRING, type=mujoco.mjtJoint.mjJNT_SLIDE, axis=axis.tolist())
    joint.limited = mujoco.mjtLimited.mjLIMITED_TRUE
    joint.range = [0.0, bal.check_spring_travel]
    joint.damping = _first(joint.damping, 2.0 * cfg.spring_damping * math.sqrt(cfg.spring_rate * cfg.spring_mass))
    joint.stiffness = _first(joint.stiffness, cfg.spring_rate)
    joint.springref = -cfg.spring_force / cfg.spring_rate
    # The stops as stiff as the loops' closures: inelastic within a few timesteps.
    joint.solref_limit = list(case.settings.solref)
    joint.solimp_limit = list(case.settings.solimp)
    body.add_site(name=bal.check_spring, pos=[0.0, 0.0, 0.0])
    pos_sensor = spec.add_sensor(
        name=names.sensor(SPRING, "pos"),
        type=mujoco.mjtSensor.mjSENS_JOINTPOS,
        objtype=mujoco.mjtObj.mjOBJ_JOINT,
        objname=SPRING,
    )
    tendon = spec.tendon(names.THREAD)
    stiffness = cfg.stiffness / material
    tendon.stiffness = _first(tendon.stiffness, stiffness)
    tendon.springlength = [0.0, material]

    model = spec.compile()
    data = mujoco.MjData(model)
    input_joint = next(j for j in range(model.njnt) if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_HINGE)
    dof = int(model.jnt_dofadr[input_joint])
    data.qvel[:] = builder.consistent_velocity(model, data, dof, case.settings.imposed_speed or mech.speed)
    state = np.empty(mujoco.mj_stateSize(model, mujoco.mjtState.mjSTATE_FULLPHYSICS))
    mujoco.mj_getState(model, data, state, mujoco.mjtState.mjSTATE_FULLPHYSICS)
    _, sd = rollout.rollout(model, data, state, nstep=case.steps + 1)
    sd = sd[0]
    adr = {
        s: int(model.sensor_adr[model.sensor(s).id]) for s in (names.sensor(names.THREAD, "length"), pos_sensor.name)
    }
    angle_name = next(model.sensor(i).name for i in range(model.nsensor) if model.sensor(i).name.endswith("_angle"))
    angle = sd[:, int(model.sensor_adr[model.sensor(angle_name).id])]
    length = sd[:, adr[names.sensor(names.THREAD, "length")]]
    spring = sd[:, adr[pos_sensor.name]]
    # The last stitch: its angles from the needle bar's top.
    turn = np.degrees(np.sign(mech.speed) * angle)
    last = turn >= 360.0 * (cycles - 1)
    theta = turn[last] - 360.0 * (cycles - 1)
    keep = theta < 360.0
    length, spring, theta = length[last][keep], spring[last][keep], theta[keep]
    return ThreadRun(
        theta=theta,
        length=length,
        spring=spring,
        tension=stiffness * np.maximum(length - material, 0.0),
        material=material,
        stiffness=stiffness,
        timestep=case.settings.timestep,
        cycles=cycles,
    )


def _first(current: object, value: float) -> object:
    """``value`` where MuJoCo keeps a scalar, or as the first of the coefficients it keeps."""
    if isinstance(current, int | float):
        return value
    out = list(np.asarray(current, dtype=float))
    out[0] = value
    return out
