"""How long the kinematic run's clock runs, without MuJoCo: its timestep, its steps, and what a
verified variant records per step.

One home for the step count, so that what runs and what is planned before it runs agree:
:func:`mjlink.sim.simulate.kinematic_case` (``simulate``, ``traces``), the batched
verification of a study's variants (:func:`mjlink.sim.batch.verify`) and a study's plan
(:mod:`mjlink.study.plan`) all count steps through :func:`kinematic_clock`. Nothing here
imports mujoco: a plan sizes a study before any model is built.
"""

from __future__ import annotations

import dataclasses

from ..model.limits import VERIFIED_SPEED
from ..model.mechanism import Mechanism
from ..model.topology import topology
from ..runs import KINEMATIC, Case, Settings
from ..units import RunKind


def kinematic_settings(speed: float) -> Settings:
    """The kinematic run's default settings at ``speed`` (rad/s): ``KINEMATIC``, with the
    timestep and the loops' time constant scaled by ``VERIFIED_SPEED / |speed|`` above it
    (:func:`mjlink.sim.simulate.kinematic_case`)."""
    k = min(1.0, VERIFIED_SPEED / abs(speed)) if speed else 1.0
    if k == 1.0:
        return KINEMATIC
    return dataclasses.replace(
        KINEMATIC, timestep=KINEMATIC.timestep * k, solref=(KINEMATIC.solref[0] * k, KINEMATIC.solref[1])
    )


def kinematic_clock(period: float, speed: float, cycles: float, settings: Settings | None = None) -> Case:
    """The constant-speed case's clock: ``cycles`` periods (``period`` rad of input) at ``speed``
    rad/s with ``settings`` (None: :func:`kinematic_settings` at that speed). Its ``steps`` and
    ``samples`` are the run's; the flywheel that holds the speed is sized on top of it
    (:func:`mjlink.sim.simulate.kinematic_case`). Raises ZeroDivisionError for a speed of 0."""
    return Case(RunKind.KINEMATICS, cycles * period / abs(speed), speed, settings or kinematic_settings(speed), 1, True)


def verify_steps(period: float, speed: float, settings: Settings | None = None) -> int:
    """MuJoCo steps of one variant's batched verification (:func:`mjlink.sim.batch.verify`): one
    period at its own ``speed`` (rad/s), the initial sample's step included, as rollout steps it."""
    return kinematic_clock(period, speed, 1.0, settings).steps + 1


def verify_values(mech: Mechanism) -> int:
    """Sensor values a verified variant's model records per step (its ``nsensordata``;
    :func:`mjlink.sim.builder.make_batch`): position and velocity of every moving point, the
    thread's length, the crank's angle and speed, and both anchors of every loop pin."""
    return 6 * len(mech.moving_points) + (1 if mech.thread else 0) + 2 + 6 * len(topology(mech).loops)
