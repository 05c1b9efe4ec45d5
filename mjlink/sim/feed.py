"""The fabric under the presser foot, fed by the dog through MuJoCo's contacts.

A head's feed dog is a point of the linkage; the fabric is what it moves, pressed onto the dog
and the throat plate by the sprung presser foot. This model takes the dog's teeth along the
reference's path of the ``[timing] feed_dog`` point, at the head's speed, and lets MuJoCo find
what the fabric and the foot do:

* the throat plate: a fixed box whose top is ``[timing] plate``;
* the dog's teeth: a box whose top is the dog point, on two slides (along the feed and up),
  driven: its position and velocity are the reference's at every step (heavy, so that a
  step's contact impulses barely move it before it is set again);
* the fabric: its plies one on the next (one ply of ``[timing] fabric`` thickness by
  default), each a box of its thickness and its mass (the piece's area times the ply's mass
  per area) on two slides, the bottom one on the plate, each upper one seated on the one
  below by a sphere's bottom;
* the presser foot: a sphere's bottom on a vertical slide over the fabric, its spring (a rate,
  and a preload with the sole at the fabric's free top), damping and the bar's stop;
* gravity on all of them.

Each pair that touches has a contact of its own (``<pair>``, with its friction: the dog's
teeth grip, the foot and the plate slide, the plies grip each other) and elliptic friction
cones. The fabric's
compliance across its thickness is all in its contact with the foot: a spring and damper of
the plies' stiffness and damping one on the next (a soft constraint of tiny constant
impedance, its solref from the compiled model's own inverse weights, :func:`_model`), its
friction Coulomb's (:data:`HARD_FRICTION`). The teeth and the
plate are rigid: the stiffest contact MuJoCo keeps stable, a time constant of twice the
timestep, critically damped, the impedance 0.99 to 0.999 over 0.1 mm, so that the plate bears
nothing of the foot's push while the teeth are above it; the plies on each other are rigid
too, so that they stick or slide as Coulomb has it (a soft contact's friction creeps where it
should stick, the foot's too). The foot does not collide with the
dog or the plate: the fabric is always between them here.

Not modelled (docs/head.md, The fabric under the presser foot): each ply's own compression,
the dog's teeth as teeth (one box here), the fabric's bending round the teeth, the operator's
hold on the fabric, the needle in the fabric, a walking foot.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from .. import reference
from ..model.mechanism import Mechanism
from ..model.presser import FABRIC_DEFAULTS, GRAVITY, PRESSER_DEFAULTS, Fabric, Presser, feed_step, unfit
from ._mujoco import mujoco

__all__ = [
    "Fabric",
    "FeedRun",
    "FeedSweep",
    "Presser",
    "dog_advance",
    "dog_path",
    "foot_vibration",
    "ply_name",
    "run_feed",
    "sweep",
]
DOG_MASS = 1e3  # kg-equivalent (armature) of the driven dog's slides
# The teeth's box (half-sizes, m) and the foot's, in the feed's plane and across it; the
# fabric's length and width. Their sizes do not enter the answer while the fabric covers both.
DOG_HALF = (0.004, 0.003, 0.001)
FABRIC_HALF = (0.03, 0.01)
PLATE_HALF = 0.05  # the throat plate's half-length along the feed, m (at least)
# A run's piece of fabric is long enough behind the dog for its stitches at this many times the
# dog's advance ([choice]: the stitch grows as the foot leaves the fabric at speed, by 13 %
# at 6,000 stitches/min on the shipped head), and a run whose fabric fed further is refused.
FED_ALLOWANCE = 2.0
# The foot's sole is the bottom of a sphere: one contact point with the fabric, whose stiffness
# is then the fabric's (a box's face would touch at up to four points, each that stiff).
FOOT_RADIUS = 0.005
# The fabric's compliance under the foot: a soft constraint of constant impedance this small
# is a spring and damper (MuJoCo's a1 + d (b v + k r) = (1 - d) a0 with d -> 0 and d k, d b
# given as the stiffness and damping per unit of the contact's effective mass).
COMPLIANT = 1e-3
IMPEDANCE = (0.99, 0.999, 1e-4, 0.5, 2.0)  # solimp: dmin, dmax, width (m), midpoint, power
# m: the foot counts as off the fabric when its gap exceeds this, a gap no feeler gauge finds
# ([choice]). The stiff contacts give by a few um and their force flickers to zero within
# that give (the 2 g fabric between the heavy dog and the foot), which is not a separation.
SEPARATED = 1e-5
# The friction rows of a contact this many times harder than its normal (MuJoCo's impratio;
# the foot's soft contact needs it, the rigid ones barely change): the step halved then moves
# the stitch by 0.3 % or less; 1e5 is ill conditioned (3 % at 5,000 rpm).
HARD_FRICTION = 1e3
PLY_COLOURS = ([0.2, 0.45, 0.85, 0.75], [0.85, 0.3, 0.45, 0.75], [0.3, 0.7, 0.45, 0.75])


def ply_name(k: int) -> str:
    """The model's body and geom of ply ``k`` (1 the bottom one, on the dog): ``fabric``,
    ``ply2``... (its slides ``fabric_x``, ``fabric_z``, ...)."""
    return "fabric" if k == 1 else f"ply{k}"


@dataclass(frozen=True, kw_only=True)
class FeedRun:
    """The feed over ``stitches`` stitches at ``speed_rpm``, stepped at ``timestep`` s, with its
    ``presser`` and ``fabric``: ``advance`` (stitches,) m the fabric's (its bottom ply's, the
    one the dog feeds) advance in each stitch from the needle bar's top, ``ply_advance``
    (stitches, plies) every ply's, the bottom one first; ``geometric`` m the dog's own advance
    with its teeth above the plate (:func:`dog_advance`, the stitch a fabric held to the dog
    makes); over the last stitch, at every step: ``theta`` (N,) deg from the needle bar's top,
    ``dog`` (N,) m the dog's teeth above the plate and ``dog_x`` (N,) m along the feed from
    where the stitch began, ``foot`` (N,) m the foot's sole above the plate, ``fabric`` (N,) m
    the bottom ply's travel since the stitch began (``ply_x`` (N, plies) every ply's),
    ``fabric_z`` (N,) m its underside above the plate, ``top`` (N,) m the top ply's upper face
    above the plate (unpressed), ``dog_force`` and ``foot_force`` (N,) N the normal forces of
    the dog's teeth on the bottom ply and of the foot on the top one, ``foot_drag`` (N,) N the
    foot's friction on the fabric; ``thickness`` m the fabric's, every ply's."""

    speed_rpm: float
    timestep: float
    stitches: int
    presser: Presser
    fabric_table: Fabric
    advance: np.ndarray
    geometric: float
    theta: np.ndarray
    dog: np.ndarray
    dog_x: np.ndarray
    foot: np.ndarray
    fabric: np.ndarray
    fabric_z: np.ndarray
    dog_force: np.ndarray
    foot_force: np.ndarray
    foot_drag: np.ndarray
    top: np.ndarray
    ply_advance: np.ndarray
    ply_x: np.ndarray
    thickness: float
    frames: np.ndarray | None = None  # (F, nq) the model's joints at F even steps of the last stitch
    fabric_half: float = FABRIC_HALF[0]  # m: the piece's half-length along the feed

    @property
    def lift(self) -> np.ndarray:
        """(N,) m: the foot's gap above the fabric's top (0 while it presses)."""
        out: np.ndarray = np.maximum(self.foot - self.top, 0.0)
        return out

    @property
    def stitch(self) -> float:
        """m: the last stitch's advance, the stitch length at this speed."""
        return float(self.advance[-1])

    @property
    def error(self) -> float:
        """The stitch length's error against the dog's geometric advance, a fraction (signed:
        negative, a shorter stitch)."""
        return self.stitch / self.geometric - 1.0

    @property
    def shift(self) -> float:
        """m: the top ply's advance in the last stitch less the bottom one's (negative: the top
        ply lags; 0 with one ply), the ply shift of a drop feed."""
        return float(self.ply_advance[-1, -1] - self.ply_advance[-1, 0])

    @property
    def spread(self) -> float:
        """m: the largest minus the least advance of the stitches after the first (which starts
        from rest): how much the stitch varies from one to the next."""
        later = self.advance[1:] if len(self.advance) > 1 else self.advance
        return float(later.max() - later.min())

    @property
    def separated(self) -> np.ndarray:
        """(N,) bool: the foot off the fabric, by more than :data:`SEPARATED`."""
        out: np.ndarray = self.lift > SEPARATED
        return out

    @property
    def separation(self) -> tuple[float, float | None]:
        """(deg of the last stitch with the foot off the fabric, the angle from the needle
        bar's top where its longest separation begins, None if it never separates)."""
        off = self.separated
        if not off.any():
            return 0.0, None
        step = 360.0 / len(off)
        # Runs of separation on the stitch's circle: a run may wrap past the needle bar's top.
        edges = np.flatnonzero(off & ~np.roll(off, 1))
        if len(edges) == 0:  # off over the whole stitch
            return 360.0, 0.0
        best, start = 0, int(edges[0])
        for e in edges:
            n = 0
            while off[(e + n) % len(off)] and n < len(off):
                n += 1
            if n > best:
                best, start = n, int(e)
        return float(off.sum()) * step, float(self.theta[start])

    @property
    def spring(self) -> np.ndarray:
        """(N,) N: the presser spring's push on the foot: its preload with the sole at the
        fabric's free top on the plate, plus its rate times the sole's rise from there."""
        out: np.ndarray = self.presser.preload + self.presser.rate * (self.foot - self.thickness)
        return out

    @property
    def load_factor(self) -> float:
        """The presser spring's dynamic load factor: its largest push over the stitch over its
        preload."""
        return float(self.spring.max()) / self.presser.preload

    @property
    def slip(self) -> float:
        """m: how far the fabric slid on the dog's teeth over the last stitch, while they
        touched it (the summed difference of their steps along the feed)."""
        touch = self.dog_force[1:] > 0.0
        rel = np.diff(self.fabric) - np.diff(self.dog_x)
        return float(np.abs(rel[touch]).sum())

    @property
    def bounce_hz(self) -> float:
        """Hz: the foot's free vibration on the fabric (:func:`bounce`, closed form)."""
        return bounce(self.presser, self.fabric_table, self.thickness)

    def as_dict(self) -> dict[str, Any]:
        """The run's numbers for ``report.json`` (mm, deg, N; ``error`` a fraction)."""
        deg, start = self.separation
        return {
            "speed_rpm": self.speed_rpm,
            "stitches": self.stitches,
            "timestep_s": self.timestep,
            "stitch_mm": self.stitch * 1e3,
            "dog_advance_mm": self.geometric * 1e3,
            "error": self.error,
            "spread_mm": self.spread * 1e3,
            "foot_off_deg": deg,
            "foot_off_from_deg": start,
            "largest_gap_mm": float(self.lift.max()) * 1e3,
            "load_factor": self.load_factor,
            "slip_mm": self.slip * 1e3,
            "foot_force_peak_N": float(self.foot_force.max()),
            "ply_shift_mm": self.shift * 1e3,
            "ply_advance_mm": [float(x) * 1e3 for x in self.ply_advance[-1]],
            "bounce_hz": self.bounce_hz,
            "presser": {
                "preload_N": self.presser.preload,
                "rate_N_per_mm": self.presser.rate * 1e-3,
                "mass_g": self.presser.mass * 1e3,
                "damping": self.presser.damping,
                "lift_mm": self.presser.lift * 1e3,
            },
            "fabric": {
                "area_cm2": self.fabric_table.area * 1e4,
                "piece_g": self.fabric_table.piece(self.thickness) * 1e3,
                "thickness_mm": self.thickness * 1e3,
                "stiffness_N_per_mm": self.fabric_table.stiffness_of(self.thickness) * 1e-3,
                "friction_dog": self.fabric_table.dog,
                "friction_foot": self.fabric_table.foot,
                "friction_plate": self.fabric_table.plate,
                "friction_ply": self.fabric_table.ply,
                "plies": [
                    {
                        "thickness_mm": p.thickness * 1e3,
                        "mass_g_per_m2": p.mass * 1e3,
                        "stiffness_N_per_mm": p.stiffness * 1e-3,
                        "damping": p.damping,
                    }
                    for p in self.fabric_table.layers(self.thickness)
                ],
            },
        }

    def columns(self) -> tuple[list[str], list[np.ndarray]]:
        """``feed.csv``: the last stitch at every step (names with their units, columns)."""
        names = [
            "theta_deg",
            "dog_mm",
            "dog_x_mm",
            "fabric_x_mm",
            "fabric_z_mm",
            "foot_mm",
            "gap_mm",
            "dog_force_N",
            "foot_force_N",
            "foot_drag_N",
        ]
        cols = [
            self.theta,
            self.dog * 1e3,
            self.dog_x * 1e3,
            self.fabric * 1e3,
            self.fabric_z * 1e3,
            self.foot * 1e3,
            self.lift * 1e3,
            self.dog_force,
            self.foot_force,
            self.foot_drag,
        ]
        for k in range(2, self.ply_x.shape[1] + 1):
            names.append(f"ply{k}_x_mm")
            cols.append(self.ply_x[:, k - 1] * 1e3)
        return names, cols


@dataclass(frozen=True, kw_only=True)
class FeedSweep:
    """The feed of one head at several speeds (:func:`sweep`): ``runs`` in the order of
    ``speeds_rpm``."""

    runs: tuple[FeedRun, ...]

    @property
    def speeds_rpm(self) -> np.ndarray:
        return np.array([r.speed_rpm for r in self.runs])

    def first_over(self, limit: float) -> FeedRun | None:
        """The slowest run whose stitch-length error exceeds ``limit`` (a fraction) in size,
        None if none does."""
        for r in sorted(self.runs, key=lambda r: r.speed_rpm):
            if abs(r.error) > limit:
                return r
        return None


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


def _advance(pos: np.ndarray) -> float:
    """m: the dog's travel along the feed over one turn sampled at ``pos`` (samples, 2) while its
    teeth are above the plate: the path taken as straight between samples, its crossings of
    the plate interpolated (exact to the square of the step)."""
    nxt = np.roll(pos, -1, axis=0)
    h0, h1 = pos[:, 1], nxt[:, 1]
    dx = nxt[:, 0] - pos[:, 0]
    up0, up1 = h0 > 0.0, h1 > 0.0
    with np.errstate(invalid="ignore", divide="ignore"):
        f = np.where(up0 != up1, h0 / (h0 - h1), 0.0)  # where along the step the plate is crossed
    part = np.where(up0 & up1, 1.0, np.where(up0 & ~up1, f, np.where(~up0 & up1, 1.0 - f, 0.0)))
    return float((dx * part).sum())


def dog_advance(mech: Mechanism, samples: int = 3600) -> float:
    """m: the stitch a fabric held to the dog makes: the dog's travel along the feed while its
    teeth are above the plate, over one turn at ``samples`` even steps."""
    return _advance(dog_path(mech, samples)[1])


def _foot(spec: mujoco.MjSpec, presser: Presser, x: float, z: float, timestep: float) -> None:
    body = spec.worldbody.add_body(name="foot", pos=[x, 0.0, z])
    body.add_joint(
        name="foot",
        type=mujoco.mjtJoint.mjJNT_SLIDE,
        axis=[0.0, 0.0, 1.0],
        stiffness=presser.rate,
        springref=-presser.preload / presser.rate,
        damping=2.0 * presser.damping * math.sqrt(presser.rate * presser.mass),
        # The bar's stop: the sole at most `lift` above the plate, as stiff as the contacts.
        limited=mujoco.mjtLimited.mjLIMITED_TRUE,
        range=[-1.0, presser.lift - z],
        solref_limit=[2.0 * timestep, 1.0],
        solimp_limit=list(IMPEDANCE),
    )
    body.add_geom(
        name="foot",
        type=mujoco.mjtGeom.mjGEOM_SPHERE,
        size=[FOOT_RADIUS, 0.0, 0.0],
        pos=[0.0, 0.0, FOOT_RADIUS],
        mass=presser.mass,
        contype=0,
        conaffinity=0,
        group=3,  # not drawn: a video shows the sole below
    )
    # What a video shows of the foot: a flat sole (no mass, no contact).
    body.add_geom(
        name="sole",
        type=mujoco.mjtGeom.mjGEOM_BOX,
        size=[0.006, 0.004, 0.0015],
        pos=[0.0, 0.0, 0.0015],
        mass=0.0,
        contype=0,
        conaffinity=0,
        rgba=[0.35, 0.36, 0.42, 1.0],
    )


def _slides(body: mujoco.MjsBody, name: str, armature: float = 0.0) -> None:
    for axis, tag in (([1.0, 0.0, 0.0], "x"), ([0.0, 0.0, 1.0], "z")):
        body.add_joint(name=f"{name}_{tag}", type=mujoco.mjtJoint.mjJNT_SLIDE, axis=axis, armature=armature)


def _model(
    mech: Mechanism, presser: Presser, fabric: Fabric, timestep: float, x0: float, half: float = FABRIC_HALF[0]
) -> mujoco.MjModel:
    """The feed's model, the dog's path centred on ``x0`` (m) and the fabric ``half`` m long
    either side of it."""
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
        size=[max(PLATE_HALF, half + 0.02), 0.02, 0.005],
        pos=[x0, 0.0, -0.005],
        contype=0,
        conaffinity=0,
        rgba=[0.62, 0.63, 0.66, 1.0],
    )
    # For a video only: a light wall behind the plate, and a camera on its side looking along
    # +y at the dog's teeth, the feed to the right, up up (nothing collides with either).
    spec.worldbody.add_geom(
        name="backdrop",
        type=mujoco.mjtGeom.mjGEOM_BOX,
        size=[0.2, 0.001, 0.2],
        pos=[x0, 0.03, 0.0],
        contype=0,
        conaffinity=0,
        rgba=[0.86, 0.87, 0.9, 1.0],
    )
    spec.visual.headlight.ambient = [0.45, 0.45, 0.45]
    spec.visual.headlight.diffuse = [0.55, 0.55, 0.55]
    spec.worldbody.add_camera(name="side", pos=[x0, -0.07, 0.0015], xyaxes=[1.0, 0.0, 0.0, 0.0, 0.0, 1.0], fovy=11.0)
    dog = spec.worldbody.add_body(name="dog")
    _slides(dog, "dog", DOG_MASS)
    dog.add_geom(
        name="dog",
        type=mujoco.mjtGeom.mjGEOM_BOX,
        size=list(DOG_HALF),
        pos=[0.0, 0.0, -DOG_HALF[2]],
        contype=0,
        conaffinity=0,
        rgba=[0.85, 0.5, 0.12, 1.0],
    )
    # The plies one on the next, each a body of its own on two slides: the bottom one, "fabric",
    # on the dog and the plate; each upper one seated on the one below by the bottom of a
    # sphere (one contact point); the foot on the top one.
    below = 0.0
    plies = fabric.layers(thick)
    for k, ply in enumerate(plies, 1):
        body = spec.worldbody.add_body(name=ply_name(k), pos=[x0, 0.0, 0.0])
        _slides(body, ply_name(k))
        body.add_geom(
            name=ply_name(k),
            type=mujoco.mjtGeom.mjGEOM_BOX,
            size=[half, FABRIC_HALF[1], ply.thickness / 2.0],
            pos=[0.0, 0.0, below + ply.thickness / 2.0],
            mass=fabric.area * ply.mass,
            contype=0,
            conaffinity=0,
            rgba=PLY_COLOURS[(k - 1) % len(PLY_COLOURS)],
        )
        if k > 1:
            body.add_geom(
                name=f"{ply_name(k)}_seat",
                type=mujoco.mjtGeom.mjGEOM_SPHERE,
                size=[FOOT_RADIUS, 0.0, 0.0],
                pos=[0.0, 0.0, below + FOOT_RADIUS],
                mass=0.0,
                contype=0,
                conaffinity=0,
                group=3,
            )
        below += ply.thickness
    _foot(spec, presser, x0, thick, timestep)
    stiff = [2.0 * timestep, 1.0]
    for other, mu in (("dog", fabric.dog), ("plate", fabric.plate)):
        spec.add_pair(
            name=f"{other}_fabric",
            geomname1=other,
            geomname2="fabric",
            condim=3,
            friction=[mu, mu, 0.0, 0.0, 0.0],
            solref=stiff,
            solimp=list(IMPEDANCE),
        )
    # One ply on the next: rigid, so that their friction is Coulomb's (a soft contact's
    # creeps where it should stick).
    for k in range(2, len(plies) + 1):
        spec.add_pair(
            name=f"{ply_name(k)}_seat",
            geomname1=ply_name(k - 1),
            geomname2=f"{ply_name(k)}_seat",
            condim=3,
            friction=[fabric.ply, fabric.ply, 0.0, 0.0, 0.0],
            solref=stiff,
            solimp=list(IMPEDANCE),
        )
    # The fabric's compliance across its thickness, all of it under the foot: the dog's teeth,
    # the plate and the plies on each other stay rigid, so that the plate bears nothing while
    # the teeth are up. Its solref is set once compiled, from the compiled model's own inverse
    # weights.
    spec.add_pair(
        name="foot_fabric",
        geomname1="foot",
        geomname2=ply_name(len(plies)),
        condim=3,
        friction=[fabric.foot, fabric.foot, 0.0, 0.0, 0.0],
        solimp=[COMPLIANT, COMPLIANT, 1e-3, 0.5, 2.0],
    )
    # A soft contact's friction is as soft as its normal (one impedance for all of a contact's
    # rows): at the foot's it is a viscous drag, a quarter of mu N at 300 rpm. Friction rows
    # this much harder than the normal are Coulomb's (mu N while sliding) at every speed.
    spec.option.impratio = HARD_FRICTION
    m = spec.compile()
    # MuJoCo regularizes a row by (1 - d) / d times its diagonal approximation, the bodies'
    # translational inverse weights (body_invweight0) summed: a contact force k r / R with
    # k = stiffness / d is then stiffness * r / ((1 - d) A), and the fabric's spring K asks for
    # stiffness = (1 - d) K A (its damping C likewise).
    top = m.body(ply_name(len(plies))).id
    a_hat = float(m.body_invweight0[top, 0] + m.body_invweight0[m.body("foot").id, 0])
    m.pair_solref[m.pair("foot_fabric").id] = [
        -(1.0 - COMPLIANT) * fabric.stiffness_of(thick) * a_hat,
        -(1.0 - COMPLIANT) * fabric.damper_of(thick, presser.mass) * a_hat,
    ]
    return m


def run_feed(
    mech: Mechanism,
    *,
    speed_rpm: float | None = None,
    presser: Presser | None = None,
    fabric: Fabric | None = None,
    stitches: int = 6,
    timestep: float = 1e-5,
    frames: int = 0,
) -> FeedRun:
    """Feed the fabric ``stitches`` stitches at ``speed_rpm`` (default the file's speed).

    Args:
      mech: a head whose ``[timing]`` names the ``feed_dog`` and gives the plate and fabric.
      speed_rpm: the main shaft's speed, rpm (its sign ignored: the file's sense is kept).
      presser, fabric: the presser and the fabric (defaults: the file's ``[presser]`` and
        ``[fabric]`` tables, else :data:`~mjlink.model.presser.PRESSER_DEFAULTS` and
        :data:`~mjlink.model.presser.FABRIC_DEFAULTS`).
      stitches: stitches run from rest, the foot on the fabric and the dog at the needle bar's
        top.
      timestep: s, at most (and at most what the fabric's spring under the foot allows,
        :func:`~mjlink.model.presser.feed_step`): the step is the nearest that divides a
        stitch evenly.
      frames: keep the model's joint positions at this many even steps of the last stitch (for
        :func:`feed_video`).
    Returns:
      :class:`FeedRun`.
    Raises:
      ValueError: a presser and fabric that cannot be fed (:func:`~mjlink.model.presser.unfit`), a
        run that diverged, or a fabric that fed beyond its piece.
    """
    presser = presser or mech.presser or PRESSER_DEFAULTS
    fabric = fabric or mech.fabric or FABRIC_DEFAULTS
    tm = mech.timing
    if tm is None:
        raise ValueError(f"{mech.name}: the feed needs a [timing] table")
    where, why = unfit(presser, fabric, tm.fabric, default_presser=presser is PRESSER_DEFAULTS)
    if why:
        raise ValueError(f"{mech.name}: {where}: {why}")
    w = abs(speed_rpm) * math.pi / 30.0 if speed_rpm is not None else abs(mech.speed)
    # At most the given step, and short enough for the fabric's spring and damper.
    steps = max(1, math.ceil(mech.period / w / min(timestep, feed_step(presser, fabric, tm.fabric))))
    dt = mech.period / w / steps
    u, pos, rate = dog_path(mech, steps)
    x0 = float(pos[:, 0].mean())
    # The fabric must cover the dog's teeth and the foot (at x0) all run long: its piece reaches
    # beyond the teeth's furthest edge by what the stitches may feed.
    teeth = DOG_HALF[0] + float(np.abs(pos[:, 0] - x0).max())
    geometric = dog_advance(mech)
    half = max(FABRIC_HALF[0], teeth + FED_ALLOWANCE * stitches * geometric + 0.005)
    m = _model(mech, presser, fabric, dt, x0, half)
    d = mujoco.MjData(m)
    jx, jz = (m.joint(f"dog_{t}") for t in "xz")
    n = len(fabric.layers(tm.fabric))
    px = np.array([m.joint(f"{ply_name(k)}_x").qposadr[0] for k in range(1, n + 1)])
    pz = np.array([m.joint(f"{ply_name(k)}_z").qposadr[0] for k in range(1, n + 1)])
    foot_q = m.joint("foot").qposadr[0]
    # The dog's teeth touch the bottom ply, the foot the top one.
    touching = {
        frozenset((m.geom("dog").id, m.geom("fabric").id)): "dog_force",
        frozenset((m.geom("foot").id, m.geom(ply_name(n)).id)): "foot_force",
    }
    # At rest: the fabric on the plate or on the dog's teeth if they are up, the foot on it.
    up = max(float(pos[0, 1]), 0.0)
    d.qpos[pz] = up
    d.qpos[foot_q] = up
    d.qpos[jx.qposadr[0]], d.qpos[jz.qposadr[0]] = pos[0, 0], pos[0, 1]
    mujoco.mj_forward(m, d)
    starts = np.zeros((stitches + 1, n))
    N = steps
    out = {k: np.zeros(N) for k in ("dog", "dog_x", "foot", "fabric_z", "top", "dog_force", "foot_force", "foot_drag")}
    ply_x = np.zeros((N, n))
    force = np.zeros(6)
    kept = np.zeros((frames, m.nq))
    at = {round(j * N / frames): j for j in range(frames)} if frames else {}
    for s in range(stitches):
        starts[s] = d.qpos[px]
        last = s == stitches - 1
        for k in range(N):
            d.qpos[jx.qposadr[0]], d.qpos[jz.qposadr[0]] = pos[k, 0], pos[k, 1]
            d.qvel[jx.dofadr[0]], d.qvel[jz.dofadr[0]] = rate[k, 0] * w, rate[k, 1] * w
            mujoco.mj_step(m, d)
            if last:
                # Where the step left the dog, as the fabric's: their differences are the slip.
                out["dog_x"][k] = d.qpos[jx.qposadr[0]] - pos[0, 0]
                out["dog"][k] = pos[k, 1]
                out["foot"][k] = tm.fabric + d.qpos[foot_q]
                ply_x[k] = d.qpos[px] - starts[s]
                out["fabric_z"][k] = d.qpos[pz[0]]
                out["top"][k] = tm.fabric + d.qpos[pz[-1]]
                if k in at:
                    kept[at[k]] = d.qpos
                for i in range(d.ncon):
                    which = touching.get(frozenset((int(d.contact.geom1[i]), int(d.contact.geom2[i]))))
                    if which:
                        mujoco.mj_contactForce(m, d, i, force)
                        out[which][k] += force[0]
                        if which == "foot_force":
                            out["foot_drag"][k] += math.hypot(force[1], force[2])
    starts[stitches] = d.qpos[px]
    fed = float(np.abs(starts[:, 0] - starts[0, 0]).max())
    if not np.isfinite(starts).all() or not all(np.isfinite(v).all() for v in out.values()):
        raise ValueError(
            f"{mech.name}: the feed at {w * 30.0 / math.pi:.6g} rpm diverged (a value of [presser] or [fabric] "
            "the contacts cannot step)"
        )
    if fed + teeth > half:
        raise ValueError(
            f"{mech.name}: the fabric fed {fed * 1e3:.4g} mm in {stitches} stitches, more than "
            f"{FED_ALLOWANCE:g} times the dog's {geometric * 1e3:.4g} mm a stitch: it left the dog's teeth"
        )
    return FeedRun(
        speed_rpm=w * 30.0 / math.pi,
        timestep=dt,
        stitches=stitches,
        presser=presser,
        fabric_table=fabric,
        advance=np.diff(starts[:, 0]),
        ply_advance=np.diff(starts, axis=0),
        fabric=ply_x[:, 0].copy(),
        ply_x=ply_x,
        geometric=geometric,
        theta=np.degrees(u),
        thickness=tm.fabric,
        frames=kept if frames else None,
        fabric_half=half,
        **out,
    )


def sweep(
    mech: Mechanism,
    speeds_rpm: list[float],
    *,
    presser: Presser | None = None,
    fabric: Fabric | None = None,
    stitches: int = 6,
    timestep: float = 1e-5,
) -> FeedSweep:
    """:func:`run_feed` at each of ``speeds_rpm`` (the other arguments as its)."""
    return FeedSweep(
        runs=tuple(
            run_feed(mech, speed_rpm=w, presser=presser, fabric=fabric, stitches=stitches, timestep=timestep)
            for w in speeds_rpm
        )
    )


def foot_vibration(presser: Presser, *, seconds: float = 0.5, timestep: float = 1e-5) -> tuple[np.ndarray, np.ndarray]:
    """The foot alone on its spring, let go at its preloaded rest with nothing under it: its
    time (s) and height (m) at every step (it vibrates about its spring's balance with gravity)."""
    spec = mujoco.MjSpec()
    spec.option.timestep = timestep
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    spec.option.gravity = [0.0, 0.0, -GRAVITY]
    _foot(spec, presser, 0.0, 0.0, timestep)
    m = spec.compile()
    d = mujoco.MjData(m)
    n = math.ceil(seconds / timestep)
    t, z = np.zeros(n), np.zeros(n)
    for k in range(n):
        mujoco.mj_step(m, d)
        t[k], z[k] = d.time, d.qpos[0]
    return t, z


def bounce(presser: Presser, fabric: Fabric, thickness: float) -> float:
    """Hz: the foot's free vibration on the fabric (of ``thickness`` m, the ``[timing]``
    fabric's) on the plate (closed form): its mass on the presser spring and the plies' springs
    (one on the next) side by side, damped by both."""
    k = presser.rate + fabric.stiffness_of(thickness)
    c = 2.0 * presser.damping * math.sqrt(presser.rate * presser.mass) + fabric.damper_of(thickness, presser.mass)
    zeta = c / (2.0 * math.sqrt(k * presser.mass))
    return math.sqrt(k / presser.mass) * math.sqrt(max(0.0, 1.0 - zeta**2)) / (2.0 * math.pi)


def foot_on_fabric(
    mech: Mechanism,
    *,
    presser: Presser | None = None,
    fabric: Fabric | None = None,
    seconds: float = 0.02,
    timestep: float = 1e-5,
) -> tuple[np.ndarray, np.ndarray]:
    """The foot let go with its sole at the fabric's free top on the plate, the dog's teeth
    held well below the plate: its time (s) and sole's height above the plate (m) at every
    step (it bounces on the fabric and settles where the fabric holds its push)."""
    presser = presser or mech.presser or PRESSER_DEFAULTS
    fabric = fabric or mech.fabric or FABRIC_DEFAULTS
    tm = mech.timing
    if tm is None:
        raise ValueError(f"{mech.name}: the feed needs a [timing] table")
    timestep = min(timestep, feed_step(presser, fabric, tm.fabric))
    m = _model(mech, presser, fabric, timestep, 0.0)
    d = mujoco.MjData(m)
    d.qpos[m.joint("dog_z").qposadr[0]] = -0.005  # m: out of the way
    foot_q = m.joint("foot").qposadr[0]
    n = math.ceil(seconds / timestep)
    t, z = np.zeros(n), np.zeros(n)
    for k in range(n):
        mujoco.mj_step(m, d)
        t[k], z[k] = d.time, tm.fabric + d.qpos[foot_q]
    return t, z


def feed_video(
    mech: Mechanism,
    path: Any,
    *,
    speed_rpm: float | None = None,
    presser: Presser | None = None,
    fabric: Fabric | None = None,
    stitches: int = 6,
    seconds: float = 4.0,
    fps: float = 30.0,
    width: int = 640,
    height: int = 480,
    held: Any = None,
) -> FeedRun:
    """A close-up MP4 at ``path`` of the last of ``stitches`` stitches fed at ``speed_rpm``, seen
    from the side: the dog's teeth rising through the plate, the fabric (blue, translucent) and
    the presser foot's sole, ``seconds`` long at ``fps`` (the stitch slowed down), with the
    speed, the main-shaft angle and the stitch so far written on every frame. Returns the run
    the frames come from (:func:`run_feed`'s, with its ``frames``)."""
    from . import render  # here: OpenGL, for a video only

    presser = presser or mech.presser or PRESSER_DEFAULTS
    fabric = fabric or mech.fabric or FABRIC_DEFAULTS
    n = max(1, round(seconds * fps))
    run = run_feed(mech, speed_rpm=speed_rpm, presser=presser, fabric=fabric, stitches=stitches, frames=n)
    assert run.frames is not None
    x0 = float(dog_path(mech, len(run.theta))[1][:, 0].mean())
    model = _model(mech, presser, fabric, run.timestep, x0, run.fabric_half)
    k = np.round(np.arange(n) * len(run.theta) / n).astype(int)
    lines = [
        [
            f"{run.speed_rpm:.0f} rpm, slowed {seconds / (60.0 / run.speed_rpm):.0f}x: {run.theta[i]:.0f} deg "
            f"from the needle bar's top",
            f"the fabric {run.fabric[i] * 1e3:.2f} mm along"
            + (f" (the top ply {run.ply_x[i, -1] * 1e3:.2f})" if run.ply_x.shape[1] > 1 else "")
            + f", the foot {run.lift[i] * 1e3:.3f} mm off it",
        ]
        for i in k
    ]
    render.render_frames(model, run.frames, "side", path, fps=fps, width=width, height=height, lines=lines, held=held)
    return run
