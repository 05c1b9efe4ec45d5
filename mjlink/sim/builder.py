"""MJCF from a mechanism description, built with ``mujoco.MjSpec``.

Topology: one body per link. A point shared by two links (or a ground point on a link) is a
revolute pair, a link's ``guide`` a prismatic pair. A spanning tree of these pairs, rooted at
the ground, becomes MuJoCo's kinematic tree (hinges about Z, slides along the guide); every
pair left over closes a loop as a ``connect`` equality, and every geared crank is tied to the
input crank by a ``joint`` equality. Slides and crank pivots are put in the tree first, since
only revolute pairs can be closed by ``connect``.

Geometry: the model is assembled at the input angle ``phi0`` from the reference's solution,
every body frame aligned with the world there, so ``qpos = 0`` is that configuration. Every
named point is a site (ground points on the world body); the thread is a spatial tendon
through its sites, so its length is MuJoCo's ``ten_length``.

Building returns :class:`Built`: the compiled model with the ids of the elements the rest of
mjlink reads (input joint, sites, bodies, loop and gear equalities, thread tendon), so no
other module rebuilds an element name. Accuracy settings (see :class:`mjlink.runs.Settings`): RK4, small timestep, loop constraints with a short
``solref`` time constant (``refsafe`` off so it may be below two timesteps) and impedance close
to 1: soft loop closure is the main error source, and these keep it below 0.1 um.
"""

from __future__ import annotations

import functools
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from .. import palette, reference
from ..model import names
from ..model.mechanism import COUNTERWEIGHT, Mechanism
from ..model.topology import Pair, topology
from ..runs import KINEMATIC, Settings
from ..units import Integrator
from ._mujoco import mujoco

SERVO_STEPS = 100  # the kinematic drive's speed servo: time constant in timesteps

_INTEGRATORS = {
    Integrator.RK4: mujoco.mjtIntegrator.mjINT_RK4,
    Integrator.EULER: mujoco.mjtIntegrator.mjINT_EULER,
    Integrator.IMPLICIT: mujoco.mjtIntegrator.mjINT_IMPLICIT,
    Integrator.IMPLICITFAST: mujoco.mjtIntegrator.mjINT_IMPLICITFAST,
}


SENSOR_SITE_GROUP = 4  # the group of the sites that only carry sensors (not drawn in the video)


def _colors(n: int) -> list[tuple[float, float, float, float]]:
    """The links' colours, those of the figures (:mod:`mjlink.palette`)."""
    return [palette.rgba(palette.link(i)) for i in range(n)]


@dataclass(frozen=True, kw_only=True)
class Built:
    """A compiled model of a mechanism and the ids of its elements.

    ``input_joint`` the input crank's hinge (``input_dof``, ``input_qpos`` its addresses);
    ``sites[point]``, ``bodies[link]``; ``tree`` each tree pair with its joint id; ``loops``
    each loop-closing pair with its connect equality id; ``gears`` the joint equalities of
    geared cranks; ``thread`` the tendon id (-1 without a thread); ``drive`` the actuator;
    ``front`` and ``oblique`` the cameras; ``sensors[(quantity, element)]`` the address in
    ``sensordata`` of each sensor of :func:`_add_sensors` (``("pos", "P5")``,
    ``("force", "lever")``, ``("angle", "input")``, ``("output", "drive")`` ...).

    ``physics`` is the model a run steps: ``model`` without what is only drawn (its geoms,
    which carry no mass and no contact, and the skybox), compiled from the same spec before
    they are added, so every id above holds in both. MuJoCo places every geom at each
    Runge-Kutta stage of every step, for nothing a run computes. Traces, loads and states are the same
    bit for bit (tested); ``model`` (and ``spec``, the MJCF) is what is drawn and written.
    """

    spec: mujoco.MjSpec
    model: mujoco.MjModel
    physics: mujoco.MjModel
    input_joint: int
    input_dof: int
    input_qpos: int
    drive: int
    sites: dict[str, int]
    bodies: dict[str, int]
    tree: tuple[tuple[Pair, int], ...]
    loops: tuple[tuple[Pair, int], ...]
    gears: tuple[int, ...]
    thread: int
    front: int
    oblique: int
    sensors: dict[tuple[str, str], int]


@dataclass(frozen=True, kw_only=True)
class _Elements:
    input_joint: mujoco.MjsJoint
    drive: mujoco.MjsActuator
    sites: dict[str, mujoco.MjsSite]
    bodies: dict[str, mujoco.MjsBody]
    tree: tuple[tuple[Pair, mujoco.MjsJoint], ...]
    loops: tuple[tuple[Pair, mujoco.MjsEquality], ...]
    gears: tuple[mujoco.MjsEquality, ...]
    thread: mujoco.MjsTendon | None
    front: mujoco.MjsCamera
    oblique: mujoco.MjsCamera
    sensors: dict[tuple[str, str], mujoco.MjsSensor]
    drawn: tuple[Callable[[], Any], ...]  # adds what is only drawn to the spec


def build_spec(mech: Mechanism, settings: Settings = KINEMATIC) -> mujoco.MjSpec:
    """The MjSpec of ``mech`` assembled at phi0, with the given numerical settings."""
    spec, el = _spec(mech, settings)
    for add in el.drawn:
        add()
    return spec


def _spec(mech: Mechanism, settings: Settings, *, batch: bool = False) -> tuple[mujoco.MjSpec, _Elements]:
    """The spec and its elements. ``batch``: the model of batched verification
    (:mod:`mjlink.sim.batch`, see :func:`make_batch`): framed by its initial pose rather than a
    sweep over the cycle (it is never drawn)."""
    kin = reference.solve(mech, [mech.phi0])
    pos = {k: v.v[0] for k, v in kin.points.items()}
    topo = topology(mech)

    spec = mujoco.MjSpec()
    spec.modelname = mech.name
    # What is only drawn (the geoms: no mass, no contact; the skybox) is added last (see
    # :func:`make`), so that a run can step the same model without it.
    drawn: list[Callable[[], Any]] = []

    def draw(body: mujoco.MjsBody, **geom: Any) -> None:
        """A geom that is only drawn (no contact), added with the rest of what is drawn."""
        drawn.append(functools.partial(body.add_geom, contype=0, conaffinity=0, **geom))

    spec.compiler.degree = False
    opt = spec.option
    opt.timestep = settings.timestep
    opt.integrator = _INTEGRATORS[settings.integrator]
    opt.gravity = [0.0, -mech.dynamics.gravity, 0.0]
    opt.solver = mujoco.mjtSolver.mjSOL_NEWTON
    opt.iterations = 100
    opt.tolerance = settings.tolerance
    opt.jacobian = mujoco.mjtJacobian.mjJAC_DENSE  # tiny models; simulate reads efc_J as dense
    opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_REFSAFE) | int(mujoco.mjtDisableBit.mjDSBL_CONTACT)

    # Frame everything the mechanism sweeps over a cycle, not just its initial pose.
    sweep = kin if batch else reference.solve(mech, mech.phi0 + np.linspace(0.0, mech.period, 73), check=False)
    pts = np.concatenate([v.v for v in sweep.points.values()])
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    size = float(np.max(hi[:2] - lo[:2]))
    r_link = 0.012 * size
    spec.stat.extent = size
    spec.stat.center = (0.5 * (lo + hi)).tolist()
    spec.visual.global_.offwidth = 1920
    spec.visual.global_.offheight = 1080
    spec.visual.headlight.ambient = [0.35, 0.35, 0.35]
    spec.visual.headlight.diffuse = [0.5, 0.5, 0.5]

    colors = _colors(len(mech.links))
    for i, l in enumerate(mech.links):
        m = spec.add_material(name=names.material(l.name))
        m.rgba = colors[i]
        m.specular = 0.3
    # A light gradient backdrop: on black the dark guide sites and the thread ends vanish.
    drawn.append(
        functools.partial(
            spec.add_texture,
            name="sky",
            type=mujoco.mjtTexture.mjTEXTURE_SKYBOX,
            builtin=mujoco.mjtBuiltin.mjBUILTIN_GRADIENT,
            rgb1=[0.95, 0.95, 0.97],
            rgb2=[0.75, 0.78, 0.82],
            width=256,
            height=1536,
        )
    )
    spec.add_material(name="mat_ground").rgba = list(palette.rgba(palette.GROUND))
    spec.add_material(name="mat_eyelet").rgba = list(palette.rgba(palette.KEY_PATH))

    world = spec.worldbody
    world.add_light(
        name="key",
        pos=[lo[0], hi[1] + size, 2.0 * size],
        dir=[0.3, -0.4, -1.0],
        diffuse=[0.7, 0.7, 0.7],
        type=mujoco.mjtLightType.mjLIGHT_DIRECTIONAL,
        castshadow=False,
    )  # no shadows: nothing for them to fall on, and a software renderer would draw them every frame
    # Looking down -Z with Y up; far enough to hold the swept box in a 4:3 frame.
    fovy = 40.0
    half_h = 0.5 * max(hi[1] - lo[1], (hi[0] - lo[0]) * 3.0 / 4.0) + 8 * r_link
    dist = half_h / np.tan(np.radians(fovy / 2)) + hi[2]
    center = 0.5 * (lo + hi)
    front = world.add_camera(name=names.FRONT, pos=[center[0], center[1], dist], quat=[1, 0, 0, 0], fovy=fovy)
    # Oblique view from front-right-above, for mechanisms whose eyelets sit in depth.
    view = np.array([0.55, 0.35, 1.0])
    view /= np.linalg.norm(view)
    right = np.cross([0.0, 1.0, 0.0], view)
    right /= np.linalg.norm(right)
    up = np.cross(view, right)
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, np.column_stack([right, up, view]).ravel())
    oblique = world.add_camera(
        name=names.OBLIQUE, pos=(center + 1.1 * dist * view).tolist(), fovy=fovy, quat=quat.tolist()
    )

    sites: dict[str, mujoco.MjsSite] = {}
    for name, p in mech.ground.items():
        sites[name] = world.add_site(name=name, pos=p.tolist(), size=[1.0 * r_link, 0, 0], rgba=[0.15, 0.15, 0.15, 1.0])
    for pr in topo.tree + topo.loops:
        if pr.revolute and pr.parent is None:
            draw(
                world,
                type=mujoco.mjtGeom.mjGEOM_CYLINDER,
                pos=(pos[pr.pin] - [0, 0, 0.02 * size]).tolist(),
                size=[2.2 * r_link, 0.012 * size, 0],
                material="mat_ground",
            )

    # The frame (ground link) joining the input crank's pivot to every other frame pivot,
    # behind the moving links, as the ground link of a kinematic diagram.
    frame_pivots = [pr.pin for pr in topo.tree + topo.loops if pr.revolute and pr.parent is None]
    hub = mech.input_crank.pivot
    for g in dict.fromkeys(frame_pivots):
        # A pivot on the hub's axis (concentric shafts) has no bar to it: MuJoCo refuses a
        # capsule whose ends meet, as the links' bars below skip theirs.
        if g != hub and hub in pos and np.linalg.norm(pos[g] - pos[hub]) > 1e-9:
            a, c = (pos[q] - [0, 0, 0.035 * size] for q in (hub, g))
            draw(
                world,
                type=mujoco.mjtGeom.mjGEOM_CAPSULE,
                fromto=[*a, *c],
                size=[0.35 * r_link, 0, 0],
                material="mat_ground",
                rgba=list(palette.rgba(palette.GROUND, 0.55)),
            )

    for l in mech.links:  # a guide on the frame is drawn as a rail
        if l.guide and all(g in mech.ground for g in l.guide):
            a, c = (pos[g] - [0, 0, 0.03 * size] for g in l.guide)
            draw(
                world,
                type=mujoco.mjtGeom.mjGEOM_CAPSULE,
                fromto=[*a, *c],
                size=[0.5 * r_link, 0, 0],
                material="mat_ground",
            )

    bodies: dict[str | None, mujoco.MjsBody] = {None: world}
    origin: dict[str | None, np.ndarray] = {None: np.zeros(3)}
    layer = {l.name: i for i, l in enumerate(mech.links)}
    site_owner: dict[str, str] = {}
    for l in mech.links:
        for p in l.points:
            if p not in mech.ground:
                site_owner.setdefault(p, l.name)
    tree: list[tuple[Pair, mujoco.MjsJoint]] = []
    input_joint = None
    for pr in topo.tree:
        l = mech.link(pr.child)
        o = pos[topo.origin[l.name]]
        body = bodies[pr.parent].add_body(name=l.name, pos=(o - origin[pr.parent]).tolist())
        bodies[l.name], origin[l.name] = body, o
        if pr.revolute:
            j = body.add_joint(name=names.hinge_joint(l.name, pr.pin), type=mujoco.mjtJoint.mjJNT_HINGE, axis=[0, 0, 1])
        else:
            g = pos[pr.rail[1]] - pos[pr.rail[0]]
            j = body.add_joint(
                name=names.slide_joint(l.name), type=mujoco.mjtJoint.mjJNT_SLIDE, axis=(g / np.linalg.norm(g)).tolist()
            )
        tree.append((pr, j))
        if l is mech.input_link and pr.revolute and pr.point == mech.input_crank.pivot:
            input_joint = j
            _set_first(j, "damping", mech.dynamics.damping)
            j.armature = settings.flywheel
        # Inertia: mass at the centre of mass, J about Z; the X and Y moments only need to be
        # valid (planar motion never excites them).
        cw = mech.counterweight if l is mech.input_link else None
        if cw is not None and cw.mass > 0:
            # The counterweight folded in exactly: combined mass, centre of mass and moment
            # of inertia about it (parallel axes), the counterweight a point mass.
            m1 = l.mass if l.com is not None else 0.0
            s1 = pos[l.com] if l.com is not None else pos[l.points[0]]
            c = kin.points[COUNTERWEIGHT].v[0]
            total = m1 + cw.mass
            com = (m1 * s1 + cw.mass * c) / total
            jz = l.inertia + m1 * float(np.sum((s1 - com)[:2] ** 2)) + cw.mass * float(np.sum((c - com)[:2] ** 2))
            body.mass = total
            body.ipos = (com - o).tolist()
            body.inertia = [max(jz, 1e-12)] * 3
        elif l.mass > 0 and l.com is not None:  # parse requires a com with a mass
            body.mass = l.mass
            body.ipos = (pos[l.com] - o).tolist()
            jz = max(l.inertia, 1e-12)
            body.inertia = [jz, jz, jz]
        else:
            # A massless link (allowed only in files without dynamics, see mechanism.parse)
            # gets a token mass: MuJoCo's mass matrix must stay regular, and 1e-15 is its
            # own singularity threshold.
            body.mass = 1e-6
            body.ipos = [0, 0, 0]
            body.inertia = [1e-10, 1e-10, 1e-10]
        body.explicitinertial = True
        zoff = [0, 0, (layer[l.name] - 0.5 * len(mech.links)) * 0.6 * r_link]
        mat = names.material(l.name)
        for p in l.points[1:]:
            if p == l.com:
                continue
            a, b = pos[l.points[0]] - o + zoff, pos[p] - o + zoff
            if np.linalg.norm(b - a) > 1e-9:
                draw(
                    body,
                    type=mujoco.mjtGeom.mjGEOM_CAPSULE,
                    fromto=[*a, *b],
                    size=[r_link, 0, 0],
                    material=mat,
                    mass=0,
                )
        for p in l.points:
            if p == l.com:
                continue
            draw(
                body,
                type=mujoco.mjtGeom.mjGEOM_CYLINDER,
                pos=(pos[p] - o + zoff).tolist(),
                size=[1.6 * r_link, 1.2 * r_link, 0],
                material=mat,
                mass=0,
            )
        if not pr.revolute:
            g = pos[pr.rail[1]] - pos[pr.rail[0]]
            u = g / np.linalg.norm(g)
            draw(
                body,
                type=mujoco.mjtGeom.mjGEOM_BOX,
                pos=zoff,
                size=[2.5 * r_link, 1.5 * r_link, r_link],
                quat=_quat_z(np.arctan2(u[1], u[0])),
                material=mat,
                mass=0,
            )
    thread_pts = set(mech.thread or ())
    for p, owner in site_owner.items():
        eyelet = p in thread_pts
        sites[p] = bodies[owner].add_site(
            name=p,
            pos=(pos[p] - origin[owner]).tolist(),
            size=[(1.9 if eyelet else 0.5) * r_link, 0, 0],
            material="mat_eyelet" if eyelet else "",
            rgba=list(palette.rgba(palette.KEY_PATH)) if eyelet else [0.1, 0.1, 0.1, 1],
        )

    loops: list[tuple[Pair, mujoco.MjsEquality]] = []
    for pr in topo.loops:
        eq = spec.add_equality(
            name=names.loop_equality(pr.pin, pr.parent, pr.child),
            type=mujoco.mjtEq.mjEQ_CONNECT,
            objtype=mujoco.mjtObj.mjOBJ_BODY,
            name1=pr.child,
            name2=pr.parent or "world",
        )
        eq.data[0:3] = pos[pr.pin] - origin[pr.child]
        eq.solref = list(settings.solref)
        eq.solimp = list(settings.solimp)
        loops.append((pr, eq))
    assert input_joint is not None  # topology puts the input crank's pivot in the tree
    gears = []
    for s in mech.geared:
        gl = mech.carrier(s)
        eq = spec.add_equality(
            name=names.gear_equality(gl.name),
            type=mujoco.mjtEq.mjEQ_JOINT,
            objtype=mujoco.mjtObj.mjOBJ_JOINT,
            name1=names.hinge_joint(gl.name, s.pivot),
            name2=input_joint.name,
        )
        eq.data[0:5] = [0.0, s.ratio, 0.0, 0.0, 0.0]
        eq.solref = list(settings.solref)
        eq.solimp = list(settings.solimp)
        gears.append(eq)

    t = None
    if mech.thread:
        t = spec.add_tendon(name=names.THREAD, width=0.45 * r_link, rgba=list(palette.rgba(palette.THREAD)))
        for p in mech.thread:
            t.wrap_site(p)
    # The drive: ctrl is the moment plus the motor's stall torque; an affine bias in the joint
    # speed makes the torque fall linearly to zero at the no-load speed.
    act = spec.add_actuator(
        name=names.DRIVE,
        target=input_joint.name,
        trntype=mujoco.mjtTrn.mjTRN_JOINT,
        gear=[1, 0, 0, 0, 0, 0],
        ctrllimited=False,
    )
    # The drive lives in the model itself (its bias terms), so that the MJCF runs as written
    # with ctrl left at 0: torque = biasprm[0] + biasprm[2] * speed.
    act.biastype = mujoco.mjtBias.mjBIAS_AFFINE
    bias = np.zeros(len(act.biasprm))
    if settings.imposed_speed is not None:
        # A speed servo on the flywheel, kv (w - speed): its time constant flywheel / kv is
        # SERVO_STEPS timesteps, short against a crank turn yet far inside RK4's stability
        # bound; whatever the loads, the speed then stays within load / kv of the imposed one.
        kv = settings.flywheel / (SERVO_STEPS * settings.timestep)
        bias[0], bias[2] = kv * settings.imposed_speed, -kv
    else:
        motor = mech.dynamics.motor
        bias[0] = mech.dynamics.moment + (motor.stall_torque if motor else 0.0)
        if motor is not None:
            bias[2] = -motor.stall_torque / motor.no_load_speed
    act.biasprm = bias
    # Sites that only carry sensors, in their own group (SENSOR_SITE_GROUP), small and hidden
    # in the video: a site on each side of every loop pin (their positions give the loop's
    # gap) and one at each tree pair's joint, the child's body origin (its reaction).
    hidden: dict[str, Any] = dict(group=SENSOR_SITE_GROUP, size=[0.2 * r_link, 0, 0], rgba=[0.5, 0.5, 0.5, 0.5])
    for pr, _ in loops:
        for link in (pr.child, pr.parent):
            bodies[link].add_site(
                name=names.loop_anchor(pr.pin, link), pos=(pos[pr.pin] - origin[link]).tolist(), **hidden
            )
    for pr, _ in tree:
        bodies[pr.child].add_site(name=names.load_site(pr.child), pos=[0.0, 0.0, 0.0], **hidden)
    sensors = _add_sensors(spec, mech, input_joint, [pr for pr, _ in tree], [pr for pr, _ in loops], full=not batch)
    return spec, _Elements(
        input_joint=input_joint,
        drive=act,
        sites=sites,
        bodies={k: v for k, v in bodies.items() if k is not None},
        tree=tuple(tree),
        loops=tuple(loops),
        gears=tuple(gears),
        thread=t,
        front=front,
        oblique=oblique,
        sensors=sensors,
        drawn=tuple(drawn),
    )


def _set_first(obj, attr: str, value: float) -> None:
    """Set a scalar attribute that MuJoCo >= 4 holds as a vector (first entry linear)."""
    cur = getattr(obj, attr)
    if np.ndim(cur):
        arr = np.zeros(np.shape(cur))
        arr[0] = value
        setattr(obj, attr, arr)
    else:
        setattr(obj, attr, value)


def _quat_z(a: float) -> list[float]:
    return [float(np.cos(a / 2)), 0.0, 0.0, float(np.sin(a / 2))]


def _add_sensors(
    spec: mujoco.MjSpec,
    mech: Mechanism,
    input_joint: mujoco.MjsJoint,
    tree: list[Pair],
    loops: list[Pair],
    *,
    full: bool = True,
) -> dict[tuple[str, str], mujoco.MjsSensor]:
    """The sensors a run is sampled through, which also make the MJCF readable on its own
    (SI units, world frame unless said):

    * every moving point: ``P_pos`` (m), ``P_vel`` (m/s), ``P_acc`` (m/s^2; MuJoCo's frame
      acceleration counts gravity as an upward acceleration, so at rest it reads -g);
    * ``thread_length`` (m); the input crank's ``LINK_angle`` (rad from phi0) and
      ``LINK_speed`` (rad/s);
    * every link: ``LINK_angvel`` (rad/s), ``LINK_angacc`` (rad/s^2) and ``LINK_comacc``
      (its centre of mass, m/s^2, with -g as above);
    * every tree pair, at the site ``load_CHILD`` on its joint: ``CHILD_force`` (N) and
      ``CHILD_torque`` (N*m, about the joint) that the parent exerts on the child's subtree
      (loop forces included), in the site's frame, and ``CHILD_quat`` that frame's orientation;
    * ``drive_output``: the drive's torque on the crank (N*m);
    * every loop pin: ``anchor_PIN_LINK_pos`` on each of its two links (m); their distance is
      the loop's gap.

    ``full`` False (batched verification, :func:`make_batch`): only what it compares, the
    points' positions and velocities, the thread, the crank and the loop anchors. The
    acceleration-stage sensors cost a pass of ``mj_rnePostConstraint`` at every step, and
    rollout returns every sensor at every step of every variant (1000 take-up variants:
    1.7 GB with them, a quarter without).
    """
    out: dict[tuple[str, str], mujoco.MjsSensor] = {}
    site, body, xbody = mujoco.mjtObj.mjOBJ_SITE, mujoco.mjtObj.mjOBJ_BODY, mujoco.mjtObj.mjOBJ_XBODY
    sens = mujoco.mjtSensor
    for p in mech.moving_points:
        out[("pos", p)] = spec.add_sensor(
            name=names.sensor(p, "pos"), type=sens.mjSENS_FRAMEPOS, objtype=site, objname=p
        )
        out[("vel", p)] = spec.add_sensor(
            name=names.sensor(p, "vel"), type=sens.mjSENS_FRAMELINVEL, objtype=site, objname=p
        )
        if full:
            out[("acc", p)] = spec.add_sensor(
                name=names.sensor(p, "acc"), type=sens.mjSENS_FRAMELINACC, objtype=site, objname=p
            )
    if mech.thread:
        out[("length", names.THREAD)] = spec.add_sensor(
            name=names.sensor(names.THREAD, "length"),
            type=sens.mjSENS_TENDONPOS,
            objtype=mujoco.mjtObj.mjOBJ_TENDON,
            objname=names.THREAD,
        )
    joint = mujoco.mjtObj.mjOBJ_JOINT
    link = input_joint.name.rsplit("_", 1)[0] if input_joint.name else names.DRIVE
    out[("angle", "input")] = spec.add_sensor(
        name=names.sensor(link, "angle"), type=sens.mjSENS_JOINTPOS, objtype=joint, objname=input_joint.name
    )
    out[("speed", "input")] = spec.add_sensor(
        name=names.sensor(link, "speed"), type=sens.mjSENS_JOINTVEL, objtype=joint, objname=input_joint.name
    )
    if full:
        for l in mech.links:
            out[("angvel", l.name)] = spec.add_sensor(
                name=names.sensor(l.name, "angvel"), type=sens.mjSENS_FRAMEANGVEL, objtype=xbody, objname=l.name
            )
            out[("angacc", l.name)] = spec.add_sensor(
                name=names.sensor(l.name, "angacc"), type=sens.mjSENS_FRAMEANGACC, objtype=xbody, objname=l.name
            )
            out[("comacc", l.name)] = spec.add_sensor(
                name=names.sensor(l.name, "comacc"), type=sens.mjSENS_FRAMELINACC, objtype=body, objname=l.name
            )
        for pr in tree:
            s = names.load_site(pr.child)
            out[("force", pr.child)] = spec.add_sensor(
                name=names.sensor(pr.child, "force"), type=sens.mjSENS_FORCE, objtype=site, objname=s
            )
            out[("torque", pr.child)] = spec.add_sensor(
                name=names.sensor(pr.child, "torque"), type=sens.mjSENS_TORQUE, objtype=site, objname=s
            )
            out[("quat", pr.child)] = spec.add_sensor(
                name=names.sensor(pr.child, "quat"), type=sens.mjSENS_FRAMEQUAT, objtype=site, objname=s
            )
        out[("output", names.DRIVE)] = spec.add_sensor(
            name=names.sensor(names.DRIVE, "output"),
            type=sens.mjSENS_ACTUATORFRC,
            objtype=mujoco.mjtObj.mjOBJ_ACTUATOR,
            objname=names.DRIVE,
        )
    for pr in loops:
        for l in (pr.child, pr.parent):
            a = names.loop_anchor(pr.pin, l)
            out[("pos", a)] = spec.add_sensor(
                name=names.sensor(a, "pos"), type=sens.mjSENS_FRAMEPOS, objtype=site, objname=a
            )
    return out


def _equality_rows(model: mujoco.MjModel, data: mujoco.MjData) -> np.ndarray:
    """Rows of the (dense) constraint Jacobian that belong to equality constraints."""
    jac = np.asarray(data.efc_J).reshape(-1, model.nv)[: data.nefc]
    return jac[data.efc_type[: data.nefc] == mujoco.mjtConstraint.mjCNSTR_EQUALITY]


def consistent_velocity(model: mujoco.MjModel, data: mujoco.MjData, dof: int, omega: float) -> np.ndarray:
    """qvel (nv,) with ``qvel[dof] = omega`` (rad/s) that satisfies every equality constraint
    (least squares), at the configuration in ``data``."""
    data.qvel[:] = 0.0
    mujoco.mj_forward(model, data)
    E = _equality_rows(model, data)
    qvel = np.zeros(model.nv)
    qvel[dof] = omega
    if len(E):
        others = [i for i in range(model.nv) if i != dof]
        x, *_ = np.linalg.lstsq(E[:, others], -E[:, dof] * omega, rcond=None)
        qvel[others] = x
    return qvel


def make(mech: Mechanism, settings: Settings = KINEMATIC) -> Built:
    """The compiled model of ``mech`` with the ids of its elements. See :func:`build_spec`.

    The model carries the file's initial state as its keyframe ``initial``: qpos = qpos0
    (the model is assembled at phi0) and joint speeds consistent with the crank's initial
    speed (the imposed speed, or the dynamics case's omega0).
    """
    spec, el = _spec(mech, settings)
    key = spec.add_key(name=names.INITIAL)
    physics = spec.compile()  # before what is only drawn is added: cheap without the skybox
    dof = _initial_key(mech, settings, el, physics, key)
    for add in el.drawn:
        add()
    model = spec.compile()  # the keyframe comes with the spec
    return _built(spec, el, model, physics, dof)


def _built(spec: mujoco.MjSpec, el: _Elements, model: mujoco.MjModel, physics: mujoco.MjModel, dof: int) -> Built:
    """The :class:`Built` of compiled ``model`` and ``physics``: the ids of the elements ``el``."""
    return Built(
        spec=spec,
        model=model,
        physics=physics,
        input_joint=el.input_joint.id,
        input_dof=dof,
        input_qpos=int(model.jnt_qposadr[el.input_joint.id]),
        drive=el.drive.id,
        sites={k: v.id for k, v in el.sites.items()},
        bodies={k: v.id for k, v in el.bodies.items()},
        tree=tuple((p, j.id) for p, j in el.tree),
        loops=tuple((p, e.id) for p, e in el.loops),
        gears=tuple(e.id for e in el.gears),
        thread=-1 if el.thread is None else el.thread.id,
        front=el.front.id,
        oblique=el.oblique.id,
        sensors={k: int(model.sensor_adr[v.id]) for k, v in el.sensors.items()},
    )


def _initial_key(mech: Mechanism, settings: Settings, el: _Elements, model: mujoco.MjModel, key: mujoco.MjsKey) -> int:
    """Fill the keyframe ``initial`` (added before compiling, so its qpos is qpos0) with joint
    speeds consistent with the crank's initial speed, in the compiled ``model`` and in its
    spec (for the MJCF); returns the input joint's dof. The keyframe is plain data in the
    model: written there, it spares a second compile, which costs as much as the first."""
    omega = settings.imposed_speed if settings.imposed_speed is not None else mech.dynamics.omega0
    dof = int(model.jnt_dofadr[el.input_joint.id])
    qvel = consistent_velocity(model, mujoco.MjData(model), dof, omega)
    model.key_qvel[0] = qvel
    key.qpos, key.qvel = model.qpos0.tolist(), qvel.tolist()
    return dof


def make_batch(mech: Mechanism, settings: Settings = KINEMATIC, times: dict[str, float] | None = None) -> Built:
    """:func:`make`'s model of ``mech`` for batched verification (:mod:`mjlink.sim.batch`), built
    for speed: the same bodies, joints, equalities, drive, sensors and keyframe ``initial``
    (rollout's sensors give the loops' gaps through the loop anchors). Physics and
    initial state are make's (tested against it); nothing is drawn: no geoms, no skybox (its
    texture is 90 % of the compile time), sizes framed by the initial pose; ``model`` is
    ``physics``.

    ``times``, if given, accumulates the seconds spent building the spec (``spec``), compiling
    (``compile``) and finding the keyframe's joint speeds (``keyframe``).
    """
    t0 = time.perf_counter()
    spec, el = _spec(mech, settings, batch=True)  # what is only drawn is not added
    key = spec.add_key(name=names.INITIAL)
    t1 = time.perf_counter()
    model = spec.compile()
    t2 = time.perf_counter()
    dof = _initial_key(mech, settings, el, model, key)
    if times is not None:
        for k, dt in (("spec", t1 - t0), ("compile", t2 - t1), ("keyframe", time.perf_counter() - t2)):
            times[k] = times.get(k, 0.0) + dt
    return _built(spec, el, model, model, dof)


def build(mech: Mechanism, settings: Settings = KINEMATIC) -> mujoco.MjModel:
    """The compiled model of ``mech`` alone (see :func:`make` for its element ids)."""
    return make(mech, settings).model


def to_xml(mech: Mechanism, settings: Settings = KINEMATIC) -> str:
    """MJCF text of ``mech``; loads with plain ``mujoco.MjModel.from_xml_string`` and runs the
    file's case as written (drive and sensors in the model, initial state as keyframe 0)."""
    return make(mech, settings).spec.to_xml()


def mujoco_version() -> str:
    """The MuJoCo version the models are built with."""
    return str(mujoco.__version__)
