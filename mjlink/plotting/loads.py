"""PNG figures of the dynamics studies: driving torque, pair reactions, steady motion.

Drawing only, in the look of :mod:`.style` (axes with units, MuJoCo solid and wide, the
reference dashed on top, atomic writes); the quantities come from the traces,
:mod:`mjlink.reference` and :mod:`mjlink.analysis`.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from .. import analysis, reference
from ..model.mechanism import Mechanism
from ..reference.batch import FrameLoads
from ..runs import SteadyRun, Trace
from ..units import to_rpm
from .style import MJ_LABEL, MJ_STYLE, REF_LABEL, REF_STYLE, crank_x, finish_x, save, title


def torque_plot(mech: Mechanism, kin_mj: Trace, rx: reference.Reactions, out_dir) -> Path:
    """``torque.png``: driving torque (N*m) and drive power (W) against crank angle; ``kin_mj``
    must have recorded its loads (:attr:`mjlink.runs.Case.loads`)."""
    torque = kin_mj.torque
    if torque is None:
        raise ValueError(f"{mech.name}: the torque plot needs a run that recorded its driving torque")
    (x,), label = crank_x(mech, kin_mj)
    fig, (a1, a2) = plt.subplots(2, 1, figsize=(8, 6.4), sharex=True, layout="constrained")
    a1.plot(x, torque, label=MJ_LABEL, color="tab:blue", **MJ_STYLE)
    a1.plot(x, rx.torque, label=REF_LABEL + ", kinetostatics", **REF_STYLE)
    a1.axhline(0, color="0.6", lw=0.8)
    a1.set_ylabel("driving torque $M_1$ [N·m]")
    a1.legend(loc="best", fontsize=8)
    power_ref = analysis.drive_power(rx.torque, kin_mj.omega)
    a2.plot(x, analysis.drive_power(torque, kin_mj.omega), color="tab:orange", label=MJ_LABEL, **MJ_STYLE)
    a2.plot(x, power_ref, label=REF_LABEL, **REF_STYLE)
    a2.axhline(float(np.mean(power_ref)), color="tab:red", lw=1, ls="-.", label=f"mean {np.mean(power_ref):.3g} W")
    a2.set_ylabel("drive power [W]")
    a2.legend(loc="best", fontsize=8)
    finish_x(a2, [x], label)
    w = float(np.mean(kin_mj.omega))
    a1.set_title(title(mech, f"torque to turn the crank at {to_rpm(abs(w)):.0f} rpm (inverse dynamics)"), fontsize=10)
    return save(fig, out_dir, "torque.png")


def reactions_plot(mech: Mechanism, kin_mj: Trace, rx: reference.Reactions, out_dir) -> Path:
    """``reactions.png``: the force magnitude (N) in every kinematic pair against crank angle."""
    (x,), label = crank_x(mech, kin_mj)
    fig, ax = plt.subplots(figsize=(9, 5.6), layout="constrained")
    colors = plt.get_cmap("tab10")
    for i, (lab, f_ref) in enumerate(rx.forces.items()):
        c = colors(i % 10)
        ax.plot(x, analysis.magnitude(kin_mj.reactions[lab]), color=c, label=lab, **MJ_STYLE)
        ax.plot(x, analysis.magnitude(f_ref), color="k", lw=0.9, ls=(0, (4, 3)))
    ax.plot([], [], label="dashed: " + REF_LABEL, **REF_STYLE)
    ax.set_ylabel("force in the pair |F| [N]")
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8, title="pair (MuJoCo, solid)")
    finish_x(ax, [x], label)
    w = float(np.mean(kin_mj.omega))
    ax.set_title(title(mech, f"reactions in the kinematic pairs at {to_rpm(abs(w)):.0f} rpm"), fontsize=10)
    return save(fig, out_dir, "reactions.png")


def steady_plot(
    mech: Mechanism, plain: reference.Steady, fly: reference.Steady, runs: tuple[SteadyRun, SteadyRun], out_dir
) -> Path:
    """``steady.png``: crank speed over one period of steady motion, without and with the flywheel."""
    fig, ax = plt.subplots(figsize=(8, 5), layout="constrained")
    for st, run, color, what in (
        (plain, runs[0], "tab:blue", "no flywheel"),
        (fly, runs[1], "tab:green", f"flywheel {fly.extra_inertia:.3g} kg·m²"),
    ):
        # MuJoCo's run spans several periods to settle: only its last, as long as the reference's.
        turned, omega = analysis.last_period(run.trace, st.t[-1])
        ax.plot(
            np.degrees(turned), to_rpm(omega), color=color, label=f"{what}: {MJ_LABEL}, δ = {run.delta:.4f}", **MJ_STYLE
        )
        ax.plot(
            np.degrees(analysis.angle_turned(st.phi)),
            to_rpm(st.omega),
            label=f"{what}: reference, δ = {st.delta:.4f}",
            **REF_STYLE,
        )
    ax.set_xlabel("crank angle turned in the period [deg]")
    ax.set_ylabel("crank speed $n_1$ [rpm]")
    ax.legend(loc="best", fontsize=8)
    ax.set_title(title(mech, "steady motion under the motor characteristic"), fontsize=10)
    return save(fig, out_dir, "steady.png")


def shaking_plot(mech: Mechanism, kin_mj: Trace, ref: FrameLoads, got: FrameLoads, out_dir) -> Path:
    """``shaking.png``: the frame's shaking force as a hodograph (Fy against Fx, N, equal axes,
    the start marked) and the shaking moment about the input crank's pivot (N*m) against crank
    angle; the reference as a line, MuJoCo as markers (they coincide where they agree)."""
    (x,), label = crank_x(mech, kin_mj)
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(11, 4.8), layout="constrained", width_ratios=(1, 1.4))
    every = max(1, len(x) // 60)
    a1.plot(ref.force[:, 0], ref.force[:, 1], label=REF_LABEL, **REF_STYLE)
    a1.plot(got.force[::every, 0], got.force[::every, 1], "o", ms=3.5, mfc="none", color="tab:blue", label=MJ_LABEL)
    a1.plot(*ref.force[0], "s", color="tab:red", ms=6, label="start (phi01)")
    a1.plot(0, 0, "+", color="0.4", ms=10)
    a1.set_aspect("equal", adjustable="datalim")
    a1.set_xlabel("$F_x$ on the frame [N]")
    a1.set_ylabel("$F_y$ on the frame [N]")
    a1.legend(loc="best", fontsize=8)
    a1.grid(alpha=0.3)
    a1.set_title("shaking force hodograph", fontsize=9)
    a2.plot(x, ref.moment, label=REF_LABEL, **REF_STYLE)
    if got.moment is not None and not mech.geared:
        a2.plot(x[::every], got.moment[::every], "o", ms=3.5, mfc="none", color="tab:blue", label=MJ_LABEL)
    a2.axhline(0, color="0.6", lw=0.8)
    a2.set_ylabel("shaking moment about the crank pivot [N·m]")
    a2.legend(loc="best", fontsize=8)
    finish_x(a2, [x], label)
    w = float(np.mean(kin_mj.omega))
    fig.suptitle(title(mech, f"loads on the frame at {to_rpm(abs(w)):.0f} rpm (inertia, gravity, forces)"), fontsize=10)
    return save(fig, out_dir, "shaking.png")
