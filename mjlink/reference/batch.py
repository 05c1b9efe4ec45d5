"""The reference over many variants at once: variants x crank angles as rows of one array.

A design study varies some numbers of a mechanism (:mod:`mjlink.model.paths`). Here the V
variants' values are repeated over A crank angles each and put into the mechanism as arrays of
shape (V*A,), one value per row, variant-major; the blocks then solve every row in one pass on
jets, with the exact derivatives of the single-variant reference. Every operation is
elementwise along the rows, so a variant's result is the same bit for bit whatever other
variants share its batch (the study engine relies on it to chunk freely).

Units SI (m, rad).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..errors import MjlinkError
from ..model import paths
from ..model import synthesis as synth
from ..model.mechanism import COUNTERWEIGHT, Mechanism
from ..units import MM
from .dynamics import reduced
from .kinematics import Kinematics, solve


def angle_grid(mech: Mechanism, per_turn: int) -> np.ndarray:
    """Crank angles from phi0 over exactly one period, the end excluded (rad): (A,) with
    A = per_turn x the period's input turns; add phi0 for the absolute angle."""
    turns = max(1, round(mech.period / (2.0 * math.pi)))
    n = per_turn * turns
    return mech.period * np.arange(n) / n


@dataclass(frozen=True)
class Batch:
    """The reference of V variants over A crank angles each.

    ``mechanism`` holds the varied numbers as (V*A,) arrays (rows variant-major);
    ``kin`` the kinematics on those rows (``kin.phi`` (V*A,) rad, absolute); ``theta`` (A,)
    rad the angles from each variant's phi0.
    """

    mechanism: Mechanism
    variants: int
    theta: np.ndarray
    kin: Kinematics
    invalid: tuple[str, ...]  # per variant: why its values make no mechanism ('' if they do)

    @property
    def angles(self) -> int:
        return len(self.theta)

    def per_variant(self, x: np.ndarray) -> np.ndarray:
        """(V*A, ...) rows as (V, A, ...)."""
        return x.reshape(self.variants, self.angles, *x.shape[1:])

    def rows(self, x: np.ndarray) -> np.ndarray:
        """(V,) per-variant values repeated over the angles: (V*A,)."""
        return np.repeat(np.asarray(x, dtype=float), self.angles)


def rows_mechanism(mech: Mechanism, params: Sequence[paths.Param], values: np.ndarray, angles: int) -> Mechanism:
    """``mech`` with the varied numbers as row arrays.

    Args:
      mech: the nominal mechanism.
      params: the P varied parameters.
      values: (V, P) their values, file units.
      angles: A, rows per variant.
    Returns:
      A mechanism whose varied numbers are (V*A,) SI arrays.
    """
    return paths.apply(mech, {p: np.repeat(values[:, j], angles) for j, p in enumerate(params)})


def solve_batch(mech: Mechanism, params: Sequence[paths.Param], values: np.ndarray, per_turn: int) -> Batch:
    """Positions with exact derivatives of V variants over one period each.

    Args:
      mech: the nominal mechanism (a variant differs only in ``params``).
      params: the P varied parameters.
      values: (V, P) their values, file units.
      per_turn: crank angles per input turn.
    Returns:
      The :class:`Batch`. A variant whose values make no mechanism (``invalid``) is solved
      with the nominal values instead, so that its rows hold numbers; blocks that cannot close
      leave clipped values and a negative margin (``kin.margins``), judged by the caller.
    """
    values = np.array(values, dtype=float).reshape(len(values), len(params))
    params, values, invalid = _expanded(mech, list(params), values)
    for j, p in enumerate(params):
        bad = np.array([bool(r) for r in invalid])
        values[bad, j] = p.nominal
    theta = angle_grid(mech, per_turn)
    rows = rows_mechanism(mech, params, values, len(theta))
    phi = rows.phi0 + np.tile(theta, len(values))
    return Batch(rows, len(values), theta, solve(rows, phi, check=False), tuple(invalid))


def _expanded(
    mech: Mechanism, params: list[paths.Param], values: np.ndarray
) -> tuple[list[paths.Param], np.ndarray, list[str]]:
    """Parameters that act through a whole-variant rule (a synthesis input re-synthesizes the
    crank-slider) replaced by the plain numbers they set in each variant (:func:`_resynthesized`,
    else variant by variant); the rest are kept. Returns the plain parameters, their (V, P')
    values and each variant's invalidity."""
    invalid = paths.invalid(params, values, mech)
    whole = [j for j, p in enumerate(params) if p.section == "synthesis"]
    if not whole:
        return params, values, invalid
    nominal = paths.catalogue(mech)
    keep = [j for j in range(len(params)) if j not in whole]
    found = _resynthesized(mech, params, values, whole, keep, invalid)
    if found is None:  # a plain parameter moves what the synthesis sets: variant by variant
        found = []
        for i, row in enumerate(values):
            if invalid[i]:
                found.append({})
                continue
            try:
                v = variant(mech, params, row)
            except paths.PathError as e:
                invalid[i] = str(e)
                found.append({})
                continue
            found.append(paths.nominal_values(v))
    kept = {params[j].path for j in keep}
    set_by_any = set().union(*found)
    changed = [
        k
        for k, p in nominal.items()
        if k in set_by_any
        and k not in kept
        and k.split(".", 1)[0] != "synthesis"
        and any(f and not _same(f.get(k, p.nominal), p.nominal) for f in found)
    ]
    plain = [params[j] for j in keep] + [nominal[k] for k in changed]
    out = np.column_stack(
        [values[:, keep]] + [np.array([f.get(k, nominal[k].nominal) for f in found])[:, None] for k in changed]
    )
    return plain, out, invalid


def _resynthesized(
    mech: Mechanism,
    params: list[paths.Param],
    values: np.ndarray,
    whole: list[int],
    keep: list[int],
    invalid: list[str],
) -> list[dict[str, float]] | None:
    """The numbers a re-synthesis sets in each variant (file units, by path; ``{}`` for an
    invalid variant, and a variant without an admissible design made invalid), computed from
    the synthesis's r and l alone: the same numbers as ``paths.nominal_values(variant(...))``
    (tested against it), without building each variant's mechanism. None when a plain
    parameter (``keep``) moves a number the synthesis reads or sets: then only the whole
    variant is right."""
    rs = synth.resized(mech)
    touched = {f"construct.{s.point}.length" for s in (rs.crank, rs.slider, *rs.along_crank, *rs.along_rod)}
    if any(
        params[j].path in touched or params[j].path.split(".")[:2] in [["ground", g] for g in rs.guide] for j in keep
    ):
        return None
    sy = mech.synthesis
    assert sy is not None
    given = {params[j].path.split(".", 1)[1]: (params[j].scale, j) for j in whole}
    crank = f"construct.{rs.crank.point}.length"
    rod = f"construct.{rs.slider.point}.length"
    out: list[dict[str, float]] = []
    for i, row in enumerate(values):
        if invalid[i]:
            out.append({})
            continue
        # As paths.apply converts a file value to SI, so that the numbers are the same bits.
        si = {k: float(row[j]) * scale for k, (scale, j) in given.items()}
        e = si.get("offset", sy.offset)
        try:
            r, l = synth.lengths(si.get("stroke", sy.stroke), e, si.get("lambda", sy.ratio))
        except MjlinkError as err:
            invalid[i] = str(err)
            out.append({})
            continue
        f = {crank: r / MM, rod: l / MM}
        f.update({f"ground.{g}.y": float(-e) / MM for g in rs.guide})
        f.update({f"construct.{s.point}.length": s.length * (r / rs.crank.length) / MM for s in rs.along_crank})
        f.update({f"construct.{s.point}.length": s.length * (l / rs.slider.length) / MM for s in rs.along_rod})
        out.append(f)
    return out


def _same(a: float, b: float) -> bool:
    return a == b or (math.isnan(a) and math.isnan(b))


def variant(mech: Mechanism, params: Sequence[paths.Param], values: Sequence[float]) -> Mechanism:
    """One variant as a plain mechanism (SI floats), e.g. to build its MuJoCo model."""
    return paths.apply(mech, {p: float(v) for p, v in zip(params, values, strict=True)})


def steady_delta(b: Batch, iterations: int = 12) -> np.ndarray:
    """Coefficient of speed fluctuation of every variant's periodic steady motion under its
    steady-motion motor (the file's ``[steady]``, else ``[dynamics.motor]``, alone, with the
    file's damping): (omega_max - omega_min) / |omega_mean|, omega_mean the time average.

    The equation of motion in the crank angle, ``d(omega)/d(phi) = phi'' / omega`` with
    ``dt/dphi = 1 / omega``, is integrated by classical RK4 over one period with a step of two
    sample spacings (the odd samples are the stages' midpoints, so J, J' and Q are the exact
    reference values everywhere), for all variants at once; the speed at phi0 that returns
    after a period is found by a secant iteration vectorized over the variants (the same
    shooting as :func:`mjlink.reference.dynamics.steady_motion`, which integrates each
    variant by DOP853; the two agree within about 1e-5 of delta at 360 samples per turn).
    The extremes are refined between samples with the ODE's own derivative. NaN where no
    periodic motion is found.

    Args:
      b: the batch (an even number of angles per period).
      iterations: secant steps at most.
    Returns:
      (V,) delta, dimensionless.
    """
    mech = b.mechanism
    motor = mech.steady.motor if mech.steady is not None else mech.dynamics.motor
    if motor is None:
        raise ValueError(f"{mech.name}: no motor characteristic ([steady] or [dynamics.motor])")
    if b.angles % 2:
        raise ValueError("steady_delta needs an even number of angles per period")
    red = reduced(mech, b.kin)
    shape = (b.variants, b.angles)

    def per(x: object) -> np.ndarray:
        return np.broadcast_to(np.asarray(x, dtype=float), (b.variants * b.angles,)).reshape(shape)

    J, dJ, Q = per(red.J), per(red.dJ), per(red.Q)
    s0, w0 = per(motor.stall_torque)[:, 0], per(motor.no_load_speed)[:, 0]
    c = s0 / w0 + per(mech.dynamics.damping)[:, 0]
    sign = np.sign(w0)
    # A clockwise drive meets the angles in the reverse order: phi0, phi0 - h, ...
    order = np.arange(b.angles)
    if np.all(sign < 0):
        order = (-order) % b.angles
    elif not np.all(sign > 0):
        raise ValueError("steady_delta: variants turn in different directions")
    J, dJ, Q = (x[:, order].T.copy() for x in (J, dJ, Q))  # (A, V): one row per angle
    h = 2.0 * mech.period / b.angles * sign[0]
    drive = s0 + Q  # (A, V)
    half_dj = 0.5 * dJ
    inv_j = 1.0 / J

    def f(k: int, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """omega' at sample k and 1 / omega (the time integrand), few array passes: this runs
        4 times per step for every variant."""
        k %= b.angles
        r = 1.0 / u
        return (drive[k] - u * (c + half_dj[k] * u)) * inv_j[k] * r, r

    def period(u0: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Speeds at the even samples (A/2, V), their derivatives, time of a period, end speed."""
        u, t = u0.copy(), np.zeros_like(u0)
        us, ds = [], []
        half = 0.5 * h
        for k in range(0, b.angles, 2):
            k1, r1 = f(k, u)
            us.append(u)
            ds.append(k1)
            k2, r2 = f(k + 1, u + half * k1)
            k3, r3 = f(k + 1, u + half * k2)
            k4, r4 = f(k + 2, u + h * k3)
            t = t + h / 6.0 * (r1 + 2.0 * (r2 + r3) + r4)
            u = u + h / 6.0 * (k1 + 2.0 * (k2 + k3) + k4)
        return np.array(us), np.array(ds), t, u

    with np.errstate(all="ignore"):
        x0 = (s0 + Q.mean(axis=0)) / c  # where the motor balances damping and the mean load
        x1 = x0 * 1.001
        f0 = period(x0)[3] - x0
        last = None
        for _ in range(iterations):
            last = period(x1)
            f1 = last[3] - x1
            step = np.where(f1 != f0, f1 * (x1 - x0) / (f1 - f0), 0.0)
            x0, f0, x1 = x1, f1, x1 - step
            if np.all(~np.isfinite(x1) | (np.abs(step) <= 1e-13 * np.abs(x1))):
                break
        else:
            last = None
        if last is None:
            us, ds, t, end = period(x1)
            start = x1
        else:
            # Converged: the last period, from a start within 1e-13 of x1, is the orbit (one
            # integration fewer; the difference is far below the samples' own accuracy).
            us, ds, t, end = last
            start = x0
        closed = np.abs(end - start) <= 1e-9 * np.abs(start)
        # Refine the extremes between samples: u'' from the change of u' across a sample.
        dd = (np.roll(ds, -1, axis=0) - np.roll(ds, 1, axis=0)) / (2.0 * h)
        hi = _refined(us.T, ds.T * h, dd.T * h * h, True)
        lo = _refined(us.T, ds.T * h, dd.T * h * h, False)
        mean = np.abs(mech.period / t)
        delta = (hi - lo) / mean
    ok = closed & np.all(np.isfinite(us) & (us * sign > 0), axis=0)
    return np.where(ok, delta, np.nan)


def _refined(x: np.ndarray, d: np.ndarray, dd: np.ndarray, high: bool) -> np.ndarray:
    """Row extremes of (V, n) samples refined by the local parabola (d, dd per sample step)."""
    j = np.argmax(x, axis=1) if high else np.argmin(x, axis=1)
    r = np.arange(len(x))
    xv, dv, ddv = x[r, j], d[r, j], dd[r, j]
    h = -dv / ddv
    ok = (np.abs(h) <= 1.0) & ((ddv < 0) if high else (ddv > 0))
    return np.where(ok, xv - dv * dv / (2.0 * ddv), xv)


@dataclass(frozen=True)
class FrameLoads:
    """What the mechanism puts on the frame at constant crank speed.

    ``force`` (N, 2) N: the resultant force on the frame, F = sum_i m_i (g - a_Si) + the file's
    point forces: every ground pair's reaction on the frame together (what the frame's mounts
    carry); ``moment`` (N,) N*m about the input crank's pivot, counter-clockwise positive: M =
    sum_i [r_Si x m_i (g - a_Si) - J_Si alpha_i] + sum_k r_k x F_k, which includes the drive's
    reaction on the frame its motor is mounted on (the moment balance of the whole moving
    system, so gears and guides need no special case).

    Their parts: ``inertia_force`` = -sum_i m_i a_Si, the **shaking force** (the inertia
    forces' resultant: what balancing removes, zero for a balanced mechanism at any speed);
    ``inertia_moment`` = sum_i [r_Si x (-m_i a_Si) - J_Si alpha_i], the shaking moment;
    ``gravity_force`` = sum_i m_i g, the **gravity load** (the same at every angle for a
    mechanism, per row for a study's variants); the point forces are the rest. (N, 2), (N,) and
    (N, 2); None where not computed (MuJoCo's side gives the resultants only).
    """

    force: np.ndarray
    moment: np.ndarray
    inertia_force: np.ndarray | None = None
    inertia_moment: np.ndarray | None = None
    gravity_force: np.ndarray | None = None


def frame_loads(mech: Mechanism, kin: Kinematics, omega, eps=0.0) -> FrameLoads:
    """The loads on the frame over the rows of ``kin`` for the crank motion ``omega`` (rad/s)
    and ``eps`` (rad/s^2), scalars or one per row, with their inertial and gravity parts.

    Masses, inertias and gravity may be one per row (a study's variants). The links' sum here
    is checked against the ground pairs' reactions of the kinetostatic solution (tests) and
    against MuJoCo's (``simulate``, :func:`mjlink.compare.loads`).
    """
    n = len(kin.phi)
    w = np.broadcast_to(np.asarray(omega, dtype=float), (n,))
    e = np.broadcast_to(np.asarray(eps, dtype=float), (n,))
    w2 = w * w
    g = -np.asarray(mech.dynamics.gravity)  # along Y
    pivot = kin.points[mech.input_crank.pivot].v[:, :2]
    inertia = np.zeros((n, 2))
    inertia_m = np.zeros(n)
    weight = np.zeros((n, 2))
    weight_m = np.zeros(n)
    bodies = [
        (np.asarray(l.mass), kin.points[l.com])
        for l in mech.links
        if l.com is not None and np.any(np.asarray(l.mass) > 0)
    ]
    for l in mech.links:
        th = kin.angles[l.name]
        inertia_m -= np.asarray(l.inertia) * (th.dd * w2 + th.d * e)
    cw = mech.counterweight
    if cw is not None:
        bodies.append((np.asarray(cw.mass), kin.points[COUNTERWEIGHT]))
    for m, s in bodies:
        f = -m[..., None] * (s.dd[:, :2] * w2[:, None] + s.d[:, :2] * e[:, None])
        r = s.v[:, :2] - pivot
        inertia += f
        inertia_m += r[:, 0] * f[:, 1] - r[:, 1] * f[:, 0]
        fy = np.broadcast_to(m * g, (n,))
        weight[:, 1] += fy
        weight_m += r[:, 0] * fy
    force = inertia + weight
    moment = inertia_m + weight_m
    for fo in mech.dynamics.forces:
        F = fo.at(kin.phi, mech.period)[:, :2]
        r = kin.points[fo.point].v[:, :2] - pivot
        force = force + F
        moment = moment + r[:, 0] * F[:, 1] - r[:, 1] * F[:, 0]
    return FrameLoads(force, moment, inertia, inertia_m, weight)
