"""Inverse dynamics and kinetostatics at a given crank motion (torque, forces in every pair).

Units N, N*m; angles rad, speeds rad/s, accelerations rad/s^2.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import MechanismFileError
from ..model.jet import norms
from ..model.mechanism import COUNTERWEIGHT, Mechanism
from ..model.topology import Pair, pairs
from . import linalg as _linalg
from .dynamics import load_points, reduced
from .kinematics import Kinematics, solve


def driving_torque(mech: Mechanism, phi, omega, eps=0.0) -> np.ndarray:
    """Torque (N*m) the drive must apply to the input crank for the motion (phi, omega, eps).

    ``tau = J eps + 1/2 J' omega^2 + b omega - Q``: inverse dynamics of the reduced equation
    (the file's driving moment and motor are not counted: this is what they must supply).
    """
    phi = np.atleast_1d(np.asarray(phi, dtype=float))
    red = reduced(mech, solve(mech, phi, only=load_points(mech)))
    w = np.broadcast_to(np.asarray(omega, dtype=float), phi.shape)
    e = np.broadcast_to(np.asarray(eps, dtype=float), phi.shape)
    return red.J * e + 0.5 * red.dJ * w**2 + mech.dynamics.damping * w - red.Q


@dataclass(frozen=True)
class Reactions:
    """Forces in every kinematic pair over input angles (kinetostatics).

    ``forces[label]`` (N, 3) N: the force on the pair's child link from its parent (the ground
    for a pivot), world frame; for a prismatic pair the force normal to the guide, applied at
    the sliding link's first point, with the pair's moment in ``moments[label]`` (N,) N*m.
    ``torque`` (N,) N*m on the input crank; ``gear[label]`` (N,) N*m on each geared crank.
    Labels: ``P3:lever-rocker`` (point:parent-child), ``slide:cylinder-plunger``.
    """

    phi: np.ndarray
    forces: dict[str, np.ndarray]
    moments: dict[str, np.ndarray]
    torque: np.ndarray
    gear: dict[str, np.ndarray]


def pair_label(pr: Pair) -> str:
    """Readable label of a kinematic pair (see :class:`Reactions`)."""
    return pr.label


def reactions(mech: Mechanism, phi, omega, eps=0.0, *, kin: Kinematics | None = None) -> Reactions:
    """Kinetostatic analysis: Newton-Euler for every moving link, one linear solve per angle.

    Unknowns: two force components per revolute pair, the normal force and moment of each
    prismatic pair, the driving torque and one torque per gear coupling (the input crank
    takes ``-ratio`` times it: ideal gears transmit power without loss). With W = 1 these are
    exactly 3 per moving link. Units N, N*m; rad, rad/s, rad/s^2 in. ``kin``: the kinematics
    at ``phi`` if the caller has them (a design study's batch), not solved again.
    """
    phi = np.atleast_1d(np.asarray(phi, dtype=float))
    n = len(phi)
    w = np.broadcast_to(np.asarray(omega, dtype=float), (n,))
    e = np.broadcast_to(np.asarray(eps, dtype=float), (n,))
    prs = [p for _, p in pairs(mech)]
    # The points read below: the pairs', the links' origins, the masses' and the forces'.
    used = {x for pr in prs for x in ((pr.pin,) if pr.revolute else pr.rail)}
    used |= load_points(mech) | {l.points[0] for l in mech.links}
    kin = kin if kin is not None else solve(mech, phi, only=used)
    P = {k: kin.points[k].v for k in used}
    links = [l.name for l in mech.links]
    row = {name: 3 * i for i, name in enumerate(links)}
    geared = mech.geared
    nu = 2 * len(prs) + 1 + len(geared)
    if nu != 3 * len(links):
        raise MechanismFileError(
            f"{mech.path or mech.name}: kinetostatics needs a mechanism with one degree of freedom as driven "
            f"({len(prs)} pairs, {len(geared)} gears and {len(links)} links give {nu} unknowns for "
            f"{3 * len(links)} equations)"
        )
    # Systems stacked last, (equations, unknowns, rows): every entry written and read below is
    # one contiguous row of n values.
    A = np.zeros((3 * len(links), nu, n))
    b = np.zeros((3 * len(links), n))
    origin = {l.name: P[l.points[0]] for l in mech.links}

    col = 0
    for pr in prs:
        if pr.revolute:
            at = P[pr.pin]
            for link, sgn in ((pr.child, 1.0), (pr.parent, -1.0)):
                if link is None:
                    continue
                r0, d = row[link], at - origin[link]
                A[r0, col] += sgn
                A[r0 + 1, col + 1] += sgn
                A[r0 + 2, col] += -sgn * d[:, 1]  # moment of (Fx, 0): -dy Fx
                A[r0 + 2, col + 1] += sgn * d[:, 0]  # moment of (0, Fy): dx Fy
        else:
            g = (P[pr.rail[1]] - P[pr.rail[0]])[:, :2]
            u = g / norms(g)[:, None]
            nrm = np.column_stack([-u[:, 1], u[:, 0]])
            at = origin[pr.child]
            for link, sgn in ((pr.child, 1.0), (pr.parent, -1.0)):
                if link is None:
                    continue
                r0, d = row[link], at - origin[link]
                A[r0, col] += sgn * nrm[:, 0]
                A[r0 + 1, col] += sgn * nrm[:, 1]
                A[r0 + 2, col] += sgn * (d[:, 0] * nrm[:, 1] - d[:, 1] * nrm[:, 0])
                A[r0 + 2, col + 1] += sgn
        col += 2
    A[row[mech.input_link.name] + 2, col] = 1.0
    col_tau = col
    col += 1
    gear_cols = {}
    for s in geared:
        gl = mech.carrier(s)
        A[row[gl.name] + 2, col] += 1.0
        A[row[mech.input_link.name] + 2, col] += -s.ratio  # ideal gears: no power lost
        gear_cols[gl.name] = col
        col += 1

    grav = np.zeros((n, 2))
    grav[:, 1] = -np.asarray(mech.dynamics.gravity)  # along -Y; one value per row in a study
    for l in mech.links:
        r0 = row[l.name]
        th = kin.angles[l.name]
        alpha = th.dd * w**2 + th.d * e
        rhs_f = np.zeros((n, 2))
        rhs_m = l.inertia * alpha
        if l.com is not None and np.any(np.asarray(l.mass) > 0):
            s = kin.points[l.com]
            a = (s.dd * w[:, None] ** 2 + s.d * e[:, None])[:, :2]
            d = (s.v - origin[l.name])[:, :2]
            # Inertial force minus gravity, what the pairs must supply; the mass may be one per
            # row (a design study's variants), hence the explicit broadcast.
            f_net = np.asarray(l.mass)[..., None] * (a - grav)
            rhs_f += f_net
            rhs_m = rhs_m + d[:, 0] * f_net[:, 1] - d[:, 1] * f_net[:, 0]
        b[r0 : r0 + 2] = rhs_f.T
        b[r0 + 2] = rhs_m
    cw = mech.counterweight
    if cw is not None:  # a point mass on the input crank: its inertia and weight load the crank
        c = kin.points[COUNTERWEIGHT]
        a = (c.dd * w[:, None] ** 2 + c.d * e[:, None])[:, :2]
        f_net = np.asarray(cw.mass)[..., None] * (a - grav)
        link = mech.input_link.name
        d = (c.v - origin[link])[:, :2]
        r0 = row[link]
        b[r0 : r0 + 2] += f_net.T
        b[r0 + 2] += d[:, 0] * f_net[:, 1] - d[:, 1] * f_net[:, 0]
    for f in mech.dynamics.forces:
        owner = mech.link_of(f.point)
        if owner is None:
            continue
        F = f.at(phi, mech.period)[:, :2]
        d = (P[f.point] - origin[owner.name])[:, :2]
        r0 = row[owner.name]
        b[r0 : r0 + 2] -= F.T
        b[r0 + 2] -= d[:, 0] * F[:, 1] - d[:, 1] * F[:, 0]
    # Damping acts on the input crank joint like a torque -b omega.
    b[row[mech.input_link.name] + 2] += mech.dynamics.damping * w

    x = _linalg.solve_stacked(A, b)
    forces, moments = {}, {}
    col = 0
    for pr in prs:
        lab = pr.label
        if pr.revolute:
            forces[lab] = np.column_stack([x[col], x[col + 1], np.zeros(n)])
        else:
            g = (P[pr.rail[1]] - P[pr.rail[0]])[:, :2]
            u = g / norms(g)[:, None]
            forces[lab] = np.column_stack([-u[:, 1] * x[col], u[:, 0] * x[col], np.zeros(n)])
            moments[lab] = x[col + 1]
        col += 2
    return Reactions(phi, forces, moments, x[col_tau], {k: x[c] for k, c in gear_cols.items()})
