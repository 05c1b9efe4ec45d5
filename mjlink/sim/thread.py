"""The needle thread under tension in MuJoCo: the thread a tendon that only pulls, the check spring
a sprung slide joint with its stops (a hinge on its stud where its hook swings), the head
turned at its speed.

The kinematic model of the head (:mod:`.builder`) is changed in three places: the check spring's
thread hook (the ``[balance] check_spring`` point, a ground site) moves onto a body of its own on
a slide joint along the bisector of the thread's turn there at the needle bar's top (or a
hinge on the axis through ``[balance] check_spring_pivot`` normal to the face, the hook on its
arm), limited to the spring's travel, with its stiffness, damping and mass and a spring reference that presses
it against its rest stop with its force at rest; the thread's tendon gets the thread's
stiffness ``EA / M`` and a dead band ``springlength = [0, M]``, ``M`` the thread it holds (so
it pulls only when longer, with ``EA`` times the strain on the thread's own length: the
reference's law). The thread is held at both ends (the discs and
the eye) and slides over every site without friction: the reference's ``anchored`` case
(:func:`mjlink.analysis.tension.needle_tension`), where both model the same physics.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from .. import reference
from ..model import names
from ..model.mechanism import Mechanism
from ..model.tension import DEFAULTS, ThreadTension
from ..model.timing import hook_crank, spring_stroke
from ..runs import Case
from . import builder
from ._mujoco import mujoco, rollout
from .simulate import kinematic_case

__all__ = ["CASE", "LOOP_ABOVE", "LOOP_UNDER", "SPRING", "LoopRun", "ThreadRun", "run_loop", "run_thread"]

SPRING = "check_spring"  # the spring's body and slide joint
CASE = "bobbin_case"  # the cylinder the loop's legs wrap
LOOP_UNDER = "loop_eye_under_plate"  # the loop's tendon while the eye is under the plate
LOOP_ABOVE = "loop_eye_above_fabric"  # and while the eye is above the fabric


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


def run_thread(
    mech: Mechanism, material: float, *, settings: ThreadTension | None = None, cycles: int = 3, loop: bool = False
) -> ThreadRun:
    """Turn the head ``cycles`` stitches at its speed from the needle bar's top, the tendon
    holding ``material`` m of thread, and sample it and the check spring over the last.

    Args:
      mech: a head with a ``[thread]`` path and a ``[balance]`` table whose check spring's
        neighbours on the path are ground points (its travel is a fixed line).
      material: the thread the tendon holds, m (unstretched).
      settings: the thread and the spring; ``mech.tension`` or the defaults when None.
      cycles: stitches to run.
      loop: the thread goes on below the eye, straight down the needle's line to the underside
        of the needle's hole, round the bobbin case to the hook's blade point and back to the
        hole's underside, where it is held: the loop held all stitch long, not a stitch, the
        reference's ``needle_tension(..., below=loop.held_loop(...))``.
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
    pivot = None if bal.check_spring_pivot is None else mech.ground[bal.check_spring_pivot]
    stroke = spring_stroke(np.asarray(up), np.asarray(hook), np.asarray(down), pivot, bal.check_spring_travel)
    case = kinematic_case(mech, cycles=cycles)
    spec = builder.build_spec(mech, case.settings)

    # The spring's hook on its own body, sliding towards the thread's line, or swinging round
    # its pivot: a hinge on the axis normal to the face, the hook's mass on its arm, its rate,
    # damping and force at rest as torques (times the arm), its travel as an angle (over it).
    spec.delete(spec.site(bal.check_spring))
    damping = 2.0 * cfg.spring_damping * math.sqrt(cfg.spring_rate * cfg.spring_mass)
    if stroke.swings:
        arm = stroke.arm
        axle = np.asarray(hook, dtype=float) - stroke.radial
        body = spec.worldbody.add_body(name=SPRING, pos=axle.tolist())
        sense = float(np.cross(stroke.radial, stroke.pull)[2])
        axis = [0.0, 0.0, math.copysign(1.0, sense)]
        joint = body.add_joint(name=SPRING, type=mujoco.mjtJoint.mjJNT_HINGE, axis=axis)
        scale = arm  # m of the hook's travel per radian
        body.ipos = stroke.radial.tolist()
        at = stroke.radial.tolist()
    else:
        body = spec.worldbody.add_body(name=SPRING, pos=np.asarray(hook, dtype=float).tolist())
        joint = body.add_joint(name=SPRING, type=mujoco.mjtJoint.mjJNT_SLIDE, axis=stroke.pull.tolist())
        scale = 1.0
        at = [0.0, 0.0, 0.0]
    body.mass = cfg.spring_mass
    body.inertia = [1e-12, 1e-12, 1e-12]  # a point mass at the hook: the arm weighs it, the slide has no turn
    joint.limited = mujoco.mjtLimited.mjLIMITED_TRUE
    joint.range = [0.0, bal.check_spring_travel / scale]
    joint.damping = _first(joint.damping, damping * scale * scale)
    joint.stiffness = _first(joint.stiffness, cfg.spring_rate * scale * scale)
    joint.springref = -cfg.spring_force / cfg.spring_rate / scale
    # The stops as stiff as the loops' closures: inelastic within a few timesteps.
    joint.solref_limit = list(case.settings.solref)
    joint.solimp_limit = list(case.settings.solimp)
    body.add_site(name=bal.check_spring, pos=at)
    pos_sensor = spec.add_sensor(
        name=names.sensor(SPRING, "pos"),
        type=mujoco.mjtSensor.mjSENS_JOINTPOS,
        objtype=mujoco.mjtObj.mjOBJ_JOINT,
        objname=SPRING,
    )
    tendon = spec.tendon(names.THREAD)
    if loop:
        assert mech.timing is not None
        _bobbin_case(spec, mech)
        tendon.wrap_site("hole_under_a")
        _round_case(tendon, mech.timing.roles["hook_point"])
    stiffness = cfg.stiffness / material
    tendon.stiffness = _first(tendon.stiffness, stiffness)
    tendon.springlength = [0.0, material]

    theta, column = _turned(spec, mech, case, cycles)
    length = column(names.sensor(names.THREAD, "length"))
    return ThreadRun(
        theta=theta,
        length=length,
        spring=column(pos_sensor.name) * scale,
        tension=stiffness * np.maximum(length - material, 0.0),
        material=material,
        stiffness=stiffness,
        timestep=case.settings.timestep,
        cycles=cycles,
    )


def _turned(
    spec: mujoco.MjSpec, mech: Mechanism, case: Case, cycles: int
) -> tuple[np.ndarray, Callable[[str], np.ndarray]]:
    """Compile ``spec``, turn it ``case.steps`` steps at the case's speed and return the last of
    ``cycles`` stitches: its angles (deg from the needle bar's top) and a sensor's readings over
    them by the sensor's name ((N,) or (N, dim))."""
    model = spec.compile()
    data = mujoco.MjData(model)
    input_joint = next(j for j in range(model.njnt) if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_HINGE)
    dof = int(model.jnt_dofadr[input_joint])
    data.qvel[:] = builder.consistent_velocity(model, data, dof, case.settings.imposed_speed or mech.speed)
    state = np.empty(mujoco.mj_stateSize(model, mujoco.mjtState.mjSTATE_FULLPHYSICS))
    mujoco.mj_getState(model, data, state, mujoco.mjtState.mjSTATE_FULLPHYSICS)
    _, sd = rollout.rollout(model, data, state, nstep=case.steps + 1)
    sd = sd[0]

    def readings(sensor: str) -> np.ndarray:
        i = model.sensor(sensor).id
        a, n = int(model.sensor_adr[i]), int(model.sensor_dim[i])
        return sd[:, a] if n == 1 else sd[:, a : a + n]

    angle = next(model.sensor(i).name for i in range(model.nsensor) if model.sensor(i).name.endswith("_angle"))
    turn = np.degrees(np.sign(mech.speed) * readings(angle))
    last = (turn >= 360.0 * (cycles - 1)) & (turn < 360.0 * cycles)

    def column(sensor: str) -> np.ndarray:
        out: np.ndarray = readings(sensor)[last]
        return out

    return turn[last] - 360.0 * (cycles - 1), column


def _first(current: object, value: float) -> object:
    """``value`` where MuJoCo keeps a scalar, or as the first of the coefficients it keeps."""
    if isinstance(current, int | float):
        return value
    out = list(np.asarray(current, dtype=float))
    out[0] = value
    return out


@dataclass(frozen=True, kw_only=True)
class LoopRun:
    """MuJoCo's loop round the bobbin case over the last stitch run (:func:`run_loop`): ``theta``
    (N,) deg from the needle bar's top; ``eye`` and ``blade`` (N, 3) m MuJoCo's sites of the
    needle's eye and the hook's blade point; ``under`` (N,) m the tendon from the eye round the
    case to the blade point and back round it to the underside of the needle's hole, the
    loop's length while the eye is under the plate; ``above`` (N,) m the tendon from the eye
    to the top of the needle's hole, through the fabric, and both legs from the hole's
    underside, the length while the eye is above the fabric; ``centre`` (2,) m, ``radius`` m
    the case's; ``hole`` (2,) m the hole's underside, ``top`` m the fabric's top."""

    theta: np.ndarray
    eye: np.ndarray
    blade: np.ndarray
    under: np.ndarray
    above: np.ndarray
    centre: np.ndarray
    radius: float
    hole: np.ndarray
    top: float


def run_loop(mech: Mechanism, *, cycles: int = 1) -> LoopRun:
    """Turn the head ``cycles`` stitches at its speed with the needle thread's loop as tendons
    wrapping the bobbin case, a cylinder on the hook shaft normal to the head's plane, and
    sample them over the last stitch.

    MuJoCo wraps a tendon round a cylinder in the plane normal to its axis (and along it on a
    helix); it has no finite cylinder whose faces a thread can cross. Its loop is therefore the
    planar one, round the rim in the hook's plane, the reference's
    :func:`mjlink.analysis.loop.case_leg` with ``faces=False``; the loop over the faces, the
    reference's own, is up to a few mm shorter (docs/head.md, The thread under tension). Each
    tendon's path holds for a part of the hook's carry only (the eye under the plate, or above
    the fabric): a tendon's path is fixed, the thread's is not. The needle's hole is on the
    needle's line while the hook carries the loop (the feed carries it only once the feed dog
    rises, after the loop's release).

    Args:
      mech: a lockstitch head with ``[timing]`` (its needle's eye and hook point named) and
        ``[balance]`` (the bobbin case's diameter).
      cycles: stitches to run.
    Returns:
      :class:`LoopRun`.
    """
    tm, bal = mech.timing, mech.balance
    assert tm is not None and bal is not None
    eye, blade = tm.roles["needle_eye"], tm.roles["hook_point"]
    case = kinematic_case(mech, cycles=cycles)
    spec = builder.build_spec(mech, case.settings)
    bc = _bobbin_case(spec, mech)
    for tendon, first in ((LOOP_UNDER, [eye]), (LOOP_ABOVE, [eye, "hole_top", "hole_under_a"])):
        t = spec.add_tendon(name=tendon)
        for site in first:
            t.wrap_site(site)
        _round_case(t, blade)
        spec.add_sensor(
            name=names.sensor(tendon, "length"),
            type=mujoco.mjtSensor.mjSENS_TENDONPOS,
            objtype=mujoco.mjtObj.mjOBJ_TENDON,
            objname=tendon,
        )
    for site in (eye, blade):
        spec.add_sensor(
            name=names.sensor(site, "loop_pos"),
            type=mujoco.mjtSensor.mjSENS_FRAMEPOS,
            objtype=mujoco.mjtObj.mjOBJ_SITE,
            objname=site,
        )
    theta, column = _turned(spec, mech, case, cycles)
    return LoopRun(
        theta=theta,
        eye=column(names.sensor(eye, "loop_pos")),
        blade=column(names.sensor(blade, "loop_pos")),
        under=column(names.sensor(LOOP_UNDER, "length")),
        above=column(names.sensor(LOOP_ABOVE, "length")),
        centre=bc.centre,
        radius=bc.radius,
        hole=bc.hole,
        top=bc.top,
    )


@dataclass(frozen=True)
class _Case:
    centre: np.ndarray  # (2,) m
    radius: float
    hole: np.ndarray  # (2,) m: the needle's hole's underside
    top: float  # m: the fabric's top


def _bobbin_case(spec: mujoco.MjSpec, mech: Mechanism) -> _Case:
    """Add the bobbin case (a cylinder on the hook shaft, normal to the head's plane, that
    nothing collides with) and the needle's hole (sites at its top and, twice, its underside:
    a tendon passes each site once) to ``spec``. The hole is on the needle's line: the feed
    carries it only once the feed dog rises, after the loop's release."""
    tm, bal = mech.timing, mech.balance
    assert tm is not None and bal is not None
    centre = np.asarray(mech.ground[hook_crank(mech).pivot], dtype=float)[:2]
    x = _needle_x(mech, tm.roles["needle_point"])
    top = tm.plate + tm.fabric
    radius = bal.bobbin_case / 2.0
    spec.worldbody.add_geom(
        name=CASE,
        type=mujoco.mjtGeom.mjGEOM_CYLINDER,
        size=[radius, bal.bobbin_case_width / 2.0, 0.0],
        pos=[*centre.tolist(), 0.0],
        contype=0,
        conaffinity=0,
        rgba=[0.6, 0.6, 0.65, 0.5],
    )
    for name, y in (("hole_top", top), ("hole_under_a", tm.plate), ("hole_under_b", tm.plate)):
        spec.worldbody.add_site(name=name, pos=[x, y, 0.0])
    return _Case(centre=centre, radius=radius, hole=np.array([x, tm.plate]), top=top)


def _round_case(tendon: mujoco.MjsTendon, blade: str) -> None:
    """Continue ``tendon`` round the bobbin case to the hook's blade point and back round it to
    the underside of the needle's hole, the shorter way each (no side site)."""
    tendon.wrap_geom(CASE, "")
    tendon.wrap_site(blade)
    tendon.wrap_geom(CASE, "")
    tendon.wrap_site("hole_under_b")


def _needle_x(mech: Mechanism, point: str) -> float:
    """The needle's line: the x its point keeps (a needle bar slides on a vertical line)."""
    kin = reference.solve(mech, mech.phi0 + np.array([0.0, math.pi / 2.0]))
    return float(kin.position(point)[0, 0])
