"""Plots of the dynamics studies: driving torque, pair reactions, steady motion.

Same conventions as :mod:`mjlink.plots` (whose helpers it uses): PNG, axes with units,
MuJoCo solid and wide, the reference dashed on top, atomic writes.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from .. import reference
from ..model.mechanism import Mechanism
from ..runs import SteadyRun, Trace
from .figures import MJ_LABEL, MJ_STYLE, REF_LABEL, REF_STYLE, _crank_x, _finish_x, _save, _title, plt

RPM = 30.0 / math.pi


def torque_plot(mech: Mechanism, kin_mj: Trace, rx: reference.Reactions, out_dir) -> Path:
    """``torque.png``: driving torque (N*m) and drive power (W) against crank angle."""
    (x,), label = _crank_x(mech, kin_mj)
    fig, (a1, a2) = plt.subplots(2, 1, figsize=(8, 6.4), sharex=True, layout="constrained")
    a1.plot(x, kin_mj.torque, label=MJ_LABEL, color="tab:blue", **MJ_STYLE)
    a1.plot(x, rx.torque, label=REF_LABEL + ", kinetostatics", **REF_STYLE)
    a1.axhline(0, color="0.6", lw=0.8)
    a1.set_ylabel("driving torque $M_1$ [N·m]")
    a1.legend(loc="best", fontsize=8)
    a2.plot(x, kin_mj.torque * kin_mj.omega, color="tab:orange", label=MJ_LABEL, **MJ_STYLE)
    a2.plot(x, rx.torque * kin_mj.omega, label=REF_LABEL, **REF_STYLE)
    a2.axhline(float(np.mean(rx.torque * kin_mj.omega)), color="tab:red", lw=1, ls="-.",
               label=f"mean {np.mean(rx.torque * kin_mj.omega):.3g} W")
    a2.set_ylabel("drive power [W]")
    a2.legend(loc="best", fontsize=8)
    _finish_x(a2, [x], label)
    w = float(np.mean(kin_mj.omega))
    a1.set_title(_title(mech, f"torque to turn the crank at {abs(w) * RPM:.0f} rpm (inverse dynamics)"), fontsize=10)
    return _save(fig, out_dir, "torque.png")


def reactions_plot(mech: Mechanism, kin_mj: Trace, rx: reference.Reactions, out_dir) -> Path:
    """``reactions.png``: the force magnitude (N) in every kinematic pair against crank angle."""
    (x,), label = _crank_x(mech, kin_mj)
    fig, ax = plt.subplots(figsize=(9, 5.6), layout="constrained")
    colors = plt.get_cmap("tab10")
    for i, (lab, f_ref) in enumerate(rx.forces.items()):
        c = colors(i % 10)
        ax.plot(x, np.linalg.norm(kin_mj.reactions[lab], axis=1), color=c, label=lab, **MJ_STYLE)
        ax.plot(x, np.linalg.norm(f_ref, axis=1), color="k", lw=0.9, ls=(0, (4, 3)))
    ax.plot([], [], label="dashed: " + REF_LABEL, **REF_STYLE)
    ax.set_ylabel("force in the pair |F| [N]")
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8, title="pair (MuJoCo, solid)")
    _finish_x(ax, [x], label)
    w = float(np.mean(kin_mj.omega))
    ax.set_title(_title(mech, f"reactions in the kinematic pairs at {abs(w) * RPM:.0f} rpm"), fontsize=10)
    return _save(fig, out_dir, "reactions.png")


def steady_plot(mech: Mechanism, plain: reference.Steady, fly: reference.Steady,
                runs: tuple[SteadyRun, SteadyRun], out_dir) -> Path:
    """``steady.png``: crank speed over one period of steady motion, without and with the flywheel."""
    fig, ax = plt.subplots(figsize=(8, 5), layout="constrained")
    for st, run, color, what in ((plain, runs[0], "tab:blue", "no flywheel"),
                                 (fly, runs[1], "tab:green", f"flywheel {fly.extra_inertia:.3g} kg·m²")):
        tr = run.trace
        last = tr.time >= tr.time[-1] - abs(st.t[-1])
        x_mj = np.degrees(np.abs(tr.phi[last] - tr.phi[last][0]))
        ax.plot(x_mj, tr.omega[last] * RPM, color=color, label=f"{what}: {MJ_LABEL}, δ = {run.delta:.4f}", **MJ_STYLE)
        ax.plot(np.degrees(np.abs(st.phi - st.phi[0])), st.omega * RPM, label=f"{what}: reference, δ = {st.delta:.4f}",
                **REF_STYLE)
    ax.set_xlabel("crank angle turned in the period [deg]")
    ax.set_ylabel("crank speed $n_1$ [rpm]")
    ax.legend(loc="best", fontsize=8)
    ax.set_title(_title(mech, "steady motion under the motor characteristic"), fontsize=10)
    return _save(fig, out_dir, "steady.png")
