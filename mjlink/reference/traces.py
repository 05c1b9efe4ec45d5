"""The reference's traces: the vector method sampled along a crank motion, as run data."""

from __future__ import annotations

from ..model.mechanism import Mechanism
from ..runs import Trace
from ..units import RunKind, Source
from .dynamics import Motion
from .kinematics import Kinematics, solve


def reference_trace(mech: Mechanism, motion: Motion, kind: RunKind, *, kin: Kinematics | None = None) -> Trace:
    """The reference's trace for a given crank motion (vectorized over all samples). ``kin``:
    the kinematics at ``motion.phi`` if the caller has them (not solved again)."""
    kin = kin if kin is not None else solve(mech, motion.phi)
    names = list(mech.point_names)
    th = kin.thread_length()
    return Trace(
        source=Source.REFERENCE,
        kind=kind,
        time=motion.t,
        phi=motion.phi,
        omega=motion.omega,
        eps=motion.eps,
        points={n: kin.position(n) for n in names},
        velocities={n: kin.velocity(n, motion.omega) for n in names},
        accelerations={n: kin.acceleration(n, motion.omega, motion.eps) for n in names},
        thread_length=None if th is None else th.v,
        loop_gap=None,
        qpos=None,
        link_omega={l: kin.angles[l].d * motion.omega for l in kin.angles},
        link_eps={l: kin.angles[l].dd * motion.omega**2 + kin.angles[l].d * motion.eps for l in kin.angles},
    )
