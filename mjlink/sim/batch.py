"""MuJoCo's check of many variants at once: one ``mujoco.rollout`` over all their models.

Each variant (a mechanism of the same topology, other numbers) gets its own model, compiled
from ``MjSpec`` by the builder with the kinematic run's settings (RK4, the flywheel sized for
that variant, the speed servo) and the instrumentation of batched runs: position sensors of
every moving point, the thread's length, the crank's angle and speed, and both anchors of
every loop pin. All models have the same size signature, so one call of
``mujoco.rollout.rollout`` steps them together on its C++ thread pool for one period at the
file's speed; no Python runs per step, and traces come back through the sensors alone.

Row k of rollout's sensordata holds the sensors of the state before step k+1 (MuJoCo computes
sensors in the step's forward pass), i.e. at t = k dt, so the rows are samples 0..n-1 of the
run. Each variant is compared with the reference at MuJoCo's own crank angles, as
``simulate`` compares its kinematic run, and held to the same thresholds
(:mod:`mjlink.compare`): point positions, loop gaps, thread length and the held speed.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import mujoco
import mujoco.rollout
import numpy as np

from .. import compare, reference
from ..errors import MjlinkError
from ..model import names
from ..model.mechanism import Mechanism
from ..runs import Settings
from . import builder, simulate


@dataclass(frozen=True)
class Verification:
    """One variant's batched MuJoCo run against the reference.

    ``position_error`` the largest distance of any moving point from the reference over the
    run, m; ``loop_gap`` the largest gap of any loop pin, m; ``thread_error`` the largest
    thread-length difference, m (NaN without a thread); ``speed_error`` the crank speed's
    largest relative deviation from the imposed one; ``samples`` the run's samples;
    ``passed`` every threshold held; ``failures`` the thresholds missed, one line each;
    ``reason`` why the variant could not be run ('' if it ran).
    """

    position_error: float
    loop_gap: float
    thread_error: float
    speed_error: float
    samples: int
    passed: bool
    failures: tuple[str, ...] = ()
    reason: str = ""


def _failed(reason: str) -> Verification:
    nan = math.nan
    return Verification(nan, nan, nan, nan, 0, False, (), reason)


def signature(model: mujoco.MjModel) -> tuple[int, ...]:
    """What rollout needs equal across the models of one call."""
    return (
        model.nq,
        model.nv,
        model.nu,
        model.na,
        model.nsensordata,
        mujoco.mj_stateSize(model, mujoco.mjtState.mjSTATE_FULLPHYSICS),
    )


def settings_for(mech: Mechanism) -> tuple[Settings, int]:
    """The kinematic run's settings for ``mech`` (flywheel and servo sized for it) and the
    steps of one period at its speed."""
    case = simulate.kinematic_case(mech, cycles=1.0)
    return case.settings, case.steps


def verify(mechs: Sequence[Mechanism], *, threads: int = 1) -> list[Verification]:
    """Build every variant, run them in one rollout, compare each with the reference.

    Args:
      mechs: the variants (same topology; a variant whose model cannot be built or whose run
        diverges is reported as failed with its reason, not raised).
      threads: rollout's worker threads.
    Returns:
      One :class:`Verification` per variant, in order.
    Raises:
      MjlinkError: the variants' models differ in size (not variants of one mechanism), or
        their speeds differ in the number of steps a period takes.
    """
    out: list[Verification | None] = [None] * len(mechs)
    built: list[tuple[int, builder.BatchModel]] = []
    steps = None
    for i, m in enumerate(mechs):
        try:
            s, n = settings_for(m)
            bm = builder.make_batch(m, s)
        except (MjlinkError, ValueError) as e:
            out[i] = _failed(f"model not built: {e}")
            continue
        if steps is None:
            steps = n
        elif n != steps:
            raise MjlinkError(
                f"variant {i} of {m.name} needs {n} steps for a period, variant {built[0][0]} {steps}: "
                "verify variants of one speed and period together"
            )
        if built and signature(bm.model) != signature(built[0][1].model):
            raise MjlinkError(
                f"variant {i} of {m.name} has a model of another size than variant {built[0][0]} "
                f"({signature(bm.model)} vs {signature(built[0][1].model)}): only variants of one topology "
                "are verified together"
            )
        built.append((i, bm))
    if built:
        assert steps is not None
        models = [bm.model for _, bm in built]
        datas = [mujoco.MjData(models[0]) for _ in range(max(1, threads))]
        x0 = np.array([bm.state for _, bm in built])
        _, sensordata = mujoco.rollout.rollout(models, datas, x0, nstep=steps + 1)
        for (i, bm), sd in zip(built, sensordata, strict=True):
            out[i] = compare_run(mechs[i], bm, sd)
    return [v if v is not None else _failed("not run") for v in out]


def compare_run(mech: Mechanism, bm: builder.BatchModel, sd: np.ndarray) -> Verification:
    """One variant's sensordata (n, nsensordata) against the reference at its crank angles."""
    if not np.isfinite(sd).all():
        return _failed("MuJoCo diverged (non-finite sensor values)")
    s = bm.sensors
    crank = mech.input_link.name
    angle = sd[:, s[names.sensor(crank, "angle")]][:, 0]
    speed = sd[:, s[names.sensor(crank, "speed")]][:, 0]
    phi = mech.phi0 + angle
    kin = reference.solve(mech, phi, check=False)
    pos = 0.0
    for p in mech.moving_points:
        d = sd[:, s[names.sensor(p, "pos")]] - kin.points[p].v
        pos = max(pos, float(np.sqrt((d * d).sum(axis=1)).max()))
    gap = 0.0
    for a, b in bm.loops:
        d = sd[:, s[a]] - sd[:, s[b]]
        gap = max(gap, float(np.sqrt((d * d).sum(axis=1)).max()))
    thread = math.nan
    key = names.sensor(names.THREAD, "length")
    lf = kin.thread_length()
    if key in s and lf is not None:
        thread = float(np.abs(sd[:, s[key]][:, 0] - lf.v).max())
    w0 = mech.speed
    speed_err = float(np.abs(speed - w0).max() / abs(w0))
    fails = []
    if pos * 1e6 > compare.POSITION_UM:
        fails.append(f"point position {pos * 1e6:.4g} um > {compare.POSITION_UM:g} um")
    if gap * 1e6 > compare.LOOP_UM:
        fails.append(f"loop gap {gap * 1e6:.4g} um > {compare.LOOP_UM:g} um")
    if math.isfinite(thread) and thread * 1e6 > compare.THREAD_UM:
        fails.append(f"thread length {thread * 1e6:.4g} um > {compare.THREAD_UM:g} um")
    if speed_err > compare.SPEED_REL:
        fails.append(f"crank speed held to {speed_err:.2e} > {compare.SPEED_REL:g}")
    if len(phi) < compare.MIN_SAMPLES:
        fails.append(f"{len(phi)} samples < {compare.MIN_SAMPLES}")
    return Verification(pos, gap, thread, speed_err, len(phi), not fails, tuple(fails))
