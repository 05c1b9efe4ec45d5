"""The fabric under the presser foot, fed by the dog through MuJoCo's contacts (a first part).

A head's feed dog is a point of the linkage; the fabric is what it moves, pressed onto the dog
and the throat plate by the sprung presser foot. This model takes the dog's teeth along the
reference's path of the ``[timing] feed_dog`` point, at the head's speed, and lets MuJoCo find
what the fabric and the foot do:

* the throat plate: a fixed box whose top is ``[timing] plate``;
* the dog's teeth: a box whose top is the dog point, on two slides (along the feed and up),
  driven: its position and velocity are the reference's at every step (heavy, so that a
  step's contact impulses barely move it before it is set again);
* the fabric: a box of the file's ``[timing] fabric`` thickness and a mass (the piece the dog
  carries) on two slides, resting on the plate;
* the presser foot: a box on a vertical slide over the fabric, its spring (a rate, and a
  preload with the foot on the fabric at rest) and damping;
* gravity on all of them.

Each pair that touches has a contact of its own (``<pair>``, with its friction: the dog's
teeth grip, the foot and the plate slide), elliptic friction cones, and the stiffest contact
MuJoCo keeps stable: a time constant of twice the timestep, critically damped, the impedance
0.99 to 0.999 over 0.1 mm. A softer contact lets the fabric's small mass sink into the plate
under the presser's tens of newtons (MuJoCo's contact stiffness is per unit of effective mass),
which no fabric does. The foot does not collide with the dog or the plate: the fabric is always
between them here.

Not modelled yet (docs/head.md, The fabric under the presser foot): the fabric's own
compliance and damping across its thickness, plies, the dog's teeth as teeth (one box here),
the presser bar's lift limits, the operator's hold on the fabric, the needle in the fabric.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .. import reference
from ..model.mechanism import Mechanism
from ._mujoco import mujoco

__all__ = ["Fabric", "FeedRun", "Presser", "dog_path", "foot_vibration", "run_feed"]

GRAVITY = 9.81  # m/s^2
DOG_MASS = 1e3  # kg-equivalent (armature) of the driven dog's slides
# The teeth's box (half-sizes, m) and the foot's, in the feed's plane and across it; the
# fabric's length and width. Their sizes do not enter the answer while the fabric covers both.
DOG_HALF = (0.004, 0.003, 0.001)
FOOT_HALF = (0.006, 0.004, 0.001)
FABRIC_HALF = (0.03, 0.01)
IMPEDANCE = (0.99, 0.999, 1e-4, 0.5, 2.0)  # solimp: dmin, dmax, width (m), midpoint, power


@dataclass(frozen=True, kw_only=True)
class Presser:
    """The presser bar and foot: ``preload`` N the spring's push with the foot on the fabric at
    rest (the foot's weight adds to it), ``rate`` N/m, ``mass`` kg moving with the foot (bar,
    foot and a third of the spring), ``damping`` as a ratio of critical. Defaults: [choice],
    a DDL-class head's order of magnitude (about 4 kgf on the foot), no maker's figure found."""

    preload: float = 40.0
    rate: float = 2000.0
    mass: float = 0.05
    damping: float = 0.05

    @property
    def frequency(self) -> float:
        """Hz: the foot's free vibration on its spring, damped (closed form)."""
        wn = math.sqrt(self.rate / self.mass)
        return wn * math.sqrt(1.0 - self.damping**2) / (2.0 * math.pi)


@dataclass(frozen=True, kw_only=True)
class Fabric:
    """The fabric: ``mass`` kg of the piece the dog carries and its friction coefficients
    against the dog's teeth (``dog``), the foot and the plate; its thickness is the head's
    ``[timing] fabric``. Defaults: [choice]."""

    mass: float = 0.002
    dog: float = 1.0
    foot: float = 0.2
    plate: float = 0.2


@dataclass(frozen=True, kw_only=True)
class FeedRun:
    """The feed over ``stitches`` stitches at ``speed_rpm``, stepped at ``timestep`` s:
    ``advance`` (stitches,) m the fabric's advance in each stitch, from the needle bar's top;
    over the last stitch, at every step: ``theta`` (N,) deg from the needle bar's top,
    ``dog`` (N,) m the dog's teeth above the plate, ``foot`` (N,) m the foot's sole above the
    plate, ``fabric`` (N,) m the fabric's travel since the stitch began, ``dog_force`` and
    ``foot_force`` (N,) N the normal forces of the dog's and the foot's contacts on the
    fabric (a rigid contact's: spikes where the dog meets the fabric, which the fabric's own
    compliance, not modelled yet, would spread); ``thickness`` m the fabric's."""

    speed_rpm: float
    timestep: float
    stitches: int
    advance: np.ndarray
    theta: np.ndarray
    dog: np.ndarray
    foot: np.ndarray
    fabric: np.ndarray
    dog_force: np.ndarray
    foot_force: np.ndarray
    thickness: float

    @property
    def lift(self) -> np.ndarray:
        """(N,) m: the foot's gap above the fabric's top (0 while it presses)."""
        out: np.ndarray = np.maximum(self.foot - np.maximum(self.dog, 0.0) - self.thickness, 0.0)
        return out


def dog_path(mech: Mechanism, samples: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The dog's teeth over one turn from the needle bar's top, at ``samples`` even steps:
    the input angles (rad, the crank's sense), positions (samples, 2) m along the feed and
    above the plate, and their derivatives (samples, 2) m/rad with respect to the turn."""
    tm = mech.timing
    if tm is None or not tm.has("feed_dog"):
        raise ValueError(f"{mech.name}: the feed needs a [timing] table naming the feed_dog")
    sense = 1.0 if mech.speed >= 0 else -1.0
    u = np.arange(samples) / samples * mech.period
    kin = reference.solve(mech, mech.phi0 + sense * u)
    p = kin.points[tm.roles["feed_dog"]]
    pos = np.column_stack([p.v[:, 0], p.v[:, 1] - tm.plate])
    rate = np.column_stack([p.d[:, 0], p.d[:, 1]]) * sense
    return u, pos, rate


def _foot(spec: mujoco.MjSpec, presser: Presser, x: float, z: float) -> None:
    body = spec.worldbody.add_body(name="foot", pos=[x, 0.0, z])
    body.add_joint(
        name="foot",
        type=mujoco.mjtJoint.mjJNT_SLIDE,
        axis=[0.0, 0.0, 1.0],
        stiffness=presser.rate,
        springref=-presser.preload / presser.rate,
        damping=2.0 * presser.damping * math.sqrt(presser.rate * presser.mass),
    )
    body.add_geom(
        name="foot",
        type=mujoco.mjtGeom.mjGEOM_BOX,
        size=list(FOOT_HALF),
        pos=[0.0, 0.0, FOOT_HALF[2]],
        mass=presser.mass,
        contype=0,
        conaffinity=0,
    )


def _slides(body: mujoco.MjsBody, name: str, armature: float = 0.0) -> None:
    for axis, tag in (([1.0, 0.0, 0.0], "x"), ([0.0, 0.0, 1.0], "z")):
        body.add_joint(name=f"{name}_{tag}", type=mujoco.mjtJoint.mjJNT_SLIDE, axis=axis, armature=armature)


def _model(mech: Mechanism, presser: Presser, fabric: Fabric, timestep: float, x0: float) -> mujoco.MjModel:
    tm = mech.timing
    assert tm is not None
    thick = tm.fabric
    spec = mujoco.MjSpec()
    spec.option.timestep = timestep
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    spec.option.cone = mujoco.mjtCone.mjCONE_ELLIPTIC
    spec.option.gravity = [0.0, 0.0, -GRAVITY]
    spec.worldbody.add_geom(
        name="plate",
        type=mujoco.mjtGeom.mjGEOM_BOX,
        size=[0.05, 0.02, 0.005],
        pos=[x0, 0.0, -0.005],
        contype=0,
        conaffinity=0,
    )
    dog = spec.worldbody.add_body(name="dog")
    _slides(dog, "dog", DOG_MASS)
    dog.add_geom(
        name="dog",
        type=mujoco.mjtGeom.mjGEOM_BOX,
        size=list(DOG_HALF),
        pos=[0.0, 0.0, -DOG_HALF[2]],
        contype=0,
        conaffinity=0,
    )
    cloth = spec.worldbody.add_body(name="fabric", pos=[x0, 0.0, thick / 2.0])
    _slides(cloth, "fabric")
    cloth.add_geom(
        name="fabric",
        type=mujoco.mjtGeom.mjGEOM_BOX,
        size=[*FABRIC_HALF, thick / 2.0],
        mass=fabric.mass,
        contype=0,
        conaffinity=0,
    )
    _foot(spec, presser, x0, thick)
    stiff = [2.0 * timestep, 1.0]
    for other, mu in (("dog", fabric.dog), ("foot", fabric.foot), ("plate", fabric.plate)):
        spec.add_pair(
            name=f"{other}_fabric",
            geomname1=other,
            geomname2="fabric",
            condim=3,
            friction=[mu, mu, 0.0, 0.0, 0.0],
            solref=stiff,
            solimp=list(IMPEDANCE),
        )
    return spec.compile()


def run_feed(
    mech: Mechanism,
    *,
    speed_rpm: float | None = None,
    presser: Presser | None = None,
    fabric: Fabric | None = None,
    stitches: int = 6,
    timestep: float = 1e-5,
) -> FeedRun:
    """Feed the fabric ``stitches`` stitches at ``speed_rpm`` (default the file's speed).

    Args:
      mech: a head whose ``[timing]`` names the ``feed_dog`` and gives the plate and fabric.
      speed_rpm: the main shaft's speed, rpm (its sign ignored: the file's sense is kept).
      presser, fabric: the presser and the fabric (defaults: :class:`Presser`, :class:`Fabric`).
      stitches: stitches run from rest, the foot on the fabric and the dog at the needle bar's
        top.
      timestep: s, at most: the step is the nearest that divides a stitch evenly.
    Returns:
      :class:`FeedRun`.
    """
    presser, fabric = presser or Presser(), fabric or Fabric()
    tm = mech.timing
    if tm is None:
        raise ValueError(f"{mech.name}: the feed needs a [timing] table")
    w = abs(speed_rpm) * math.pi / 30.0 if speed_rpm is not None else abs(mech.speed)
    steps = max(1, math.ceil(mech.period / w / timestep))
    dt = mech.period / w / steps
    u, pos, rate = dog_path(mech, steps)
    x0 = float(pos[:, 0].mean())
    m = _model(mech, presser, fabric, dt, x0)
    d = mujoco.MjData(m)
    jx, jz = (m.joint(f"dog_{t}") for t in "xz")
    fx = m.joint("fabric_x").qposadr[0]
    foot_q = m.joint("foot").qposadr[0]
    cloth = m.geom("fabric").id
    touching = {m.geom(g).id: g for g in ("dog", "foot")}
    # At rest: the fabric on the plate or on the dog's teeth if they are up, the foot on it.
    up = max(float(pos[0, 1]), 0.0)
    d.qpos[m.joint("fabric_z").qposadr[0]] = up
    d.qpos[foot_q] = up
    d.qpos[jx.qposadr[0]], d.qpos[jz.qposadr[0]] = pos[0, 0], pos[0, 1]
    mujoco.mj_forward(m, d)
    starts = np.zeros(stitches + 1)
    N = steps
    out = {k: np.zeros(N) for k in ("dog", "foot", "fabric", "dog_force", "foot_force")}
    force = np.zeros(6)
    for s in range(stitches):
        starts[s] = d.qpos[fx]
        last = s == stitches - 1
        for k in range(N):
            d.qpos[jx.qposadr[0]], d.qpos[jz.qposadr[0]] = pos[k, 0], pos[k, 1]
            d.qvel[jx.dofadr[0]], d.qvel[jz.dofadr[0]] = rate[k, 0] * w, rate[k, 1] * w
            mujoco.mj_step(m, d)
            if last:
                out["dog"][k] = pos[k, 1]
                out["foot"][k] = tm.fabric + d.qpos[foot_q]
                out["fabric"][k] = d.qpos[fx] - starts[s]
                for i in range(d.ncon):
                    g1, g2 = int(d.contact.geom1[i]), int(d.contact.geom2[i])
                    which = touching.get(g1 if g2 == cloth else g2 if g1 == cloth else -1)
                    if which:
                        mujoco.mj_contactForce(m, d, i, force)
                        out[f"{which}_force"][k] += force[0]
    starts[stitches] = d.qpos[fx]
    return FeedRun(
        speed_rpm=w * 30.0 / math.pi,
        timestep=dt,
        stitches=stitches,
        advance=np.diff(starts),
        theta=np.degrees(u),
        thickness=tm.fabric,
        **out,
    )


def foot_vibration(presser: Presser, *, seconds: float = 0.5, timestep: float = 1e-5) -> tuple[np.ndarray, np.ndarray]:
    """The foot alone on its spring, let go at its preloaded rest with nothing under it: its
    time (s) and height (m) at every step (it vibrates about its spring's balance with gravity)."""
    spec = mujoco.MjSpec()
    spec.option.timestep = timestep
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    spec.option.gravity = [0.0, 0.0, -GRAVITY]
    _foot(spec, presser, 0.0, 0.0)
    m = spec.compile()
    d = mujoco.MjData(m)
    n = math.ceil(seconds / timestep)
    t, z = np.zeros(n), np.zeros(n)
    for k in range(n):
        mujoco.mj_step(m, d)
        t[k], z[k] = d.time, d.qpos[0]
    return t, z
