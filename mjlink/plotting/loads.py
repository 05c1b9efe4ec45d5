"""PNG figures of the dynamics studies: driving torque, pair reactions, steady motion.

Drawing only, in the look of :mod:`.style` (axes with units, MuJoCo solid and wide, the
reference dashed on top, atomic writes); the quantities come from the traces,
:mod:`mjlink.reference` and :mod:`mjlink.analysis`.
"""

from __future__ import annotations

import math
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from .. import analysis, compare, palette, reference
from ..model.mechanism import Mechanism, SteadyCase
from ..model.names import GROUND
from ..reference.batch import FrameLoads
from ..runs import SteadyRun, Trace
from ..units import to_rpm
from .style import (
    MJ_LABEL,
    MJ_STYLE,
    REF_LABEL,
    REF_STYLE,
    RESIDUAL_GID,
    crank_axis,
    crank_x,
    darker,
    direction,
    figure,
    finish_x,
    place,
    residual,
    save,
    subplots,
    title,
)


def torque_plot(mech: Mechanism, kin_mj: Trace, rx: reference.Reactions, out_dir) -> Path:
    """``torque.png``, what a drive and its flywheel are sized from, against crank angle: the
    driving torque (N*m) MuJoCo vs kinetostatics with its peak, RMS and mean power over one
    period named; MuJoCo minus the reference (N*m, with the threshold); the drive power (W);
    and the energy fluctuation E = integral of (T - T_mean) dphi (J) over one period with its
    swing and the classical flywheel estimate J = dE / (delta omega^2) for the file's target
    delta. ``kin_mj`` must have recorded its loads (:attr:`mjlink.runs.Case.loads`)."""
    torque = kin_mj.torque
    if torque is None:
        raise ValueError(f"{mech.name}: the torque plot needs a run that recorded its driving torque")
    (x,), label = crank_x(mech, kin_mj)
    f_angle, _ = crank_axis(mech, kin_mj.phi)
    w = float(np.mean(kin_mj.omega))
    cycle = analysis.torque_cycle(mech, w)
    fig, (a1, ar, a2, a3) = subplots(
        4,
        1,
        figsize=(11.5, 10.8),
        sharex=True,
        gridspec_kw=dict(height_ratios=(1.3, 0.6, 0.9, 1.0)),
    )
    place(fig, a1.get_gridspec(), left=1.1, right=3.3, top=0.75, bottom=0.6, hgap=0.6)
    a1.plot(x, rx.torque, label=REF_LABEL + ", kinetostatics", **REF_STYLE)
    a1.plot(x, torque, label=MJ_LABEL, color=palette.MUJOCO, **MJ_STYLE)
    a1.axhline(0, color="0.6", lw=0.8)
    i = int(np.argmax(np.abs(rx.torque)))
    a1.plot(x[i], rx.torque[i], "v" if rx.torque[i] >= 0 else "^", color="k", ms=7, zorder=5)
    a1.axhline(cycle.mean, color="tab:red", lw=1.0, ls="-.", label=f"mean {cycle.mean:.4g} N·m")
    a1.plot([], [], " ", label=f"peak |M₁| {cycle.peak:.4g} N·m (triangle)")
    a1.plot([], [], " ", label=f"RMS {cycle.rms:.4g} N·m")
    a1.plot([], [], " ", label=f"mean power {cycle.power:.4g} W")
    a1.set_ylabel("driving torque M₁ [N·m]")
    a1.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8, title="over one period", title_fontsize=8)
    residual(ar, x, torque - rx.torque, "N·m", compare.torque_limit(rx.torque), what="MuJoCo − ref.")
    power_ref = analysis.drive_power(rx.torque, kin_mj.omega)
    a2.plot(x, power_ref, label=REF_LABEL, **REF_STYLE)
    a2.plot(x, analysis.drive_power(torque, kin_mj.omega), color="tab:orange", label=MJ_LABEL, **MJ_STYLE)
    a2.axhline(cycle.power, color="tab:red", lw=1, ls="-.", label=f"mean {cycle.power:.3g} W")
    a2.axhline(0, color="0.6", lw=0.8)
    a2.set_ylabel("drive power [W]")
    a2.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8)
    phi_e, energy = analysis.energy_cycle(mech, w)
    xe = f_angle(phi_e)
    target = mech.steady.target_delta if mech.steady else SteadyCase.target_delta
    j_fly = analysis.flywheel_estimate(cycle.energy, w, target)
    a3.plot(xe, energy, color="tab:purple", lw=1.6)
    lo, hi = int(np.argmin(energy)), int(np.argmax(energy))
    for k, _va in ((lo, "top"), (hi, "bottom")):
        a3.plot(xe[k], energy[k], "o", color="k", ms=4, zorder=5)
    a3.annotate(
        "",
        (xe[hi], energy[hi]),
        xytext=(xe[hi], energy[lo]),
        arrowprops=dict(arrowstyle="<->", color="0.3", lw=1.0),
    )
    a3.axhline(energy[lo], color="0.6", lw=0.6, ls=":")
    a3.axhline(0.0, color="0.5", lw=0.6)
    a3.set_ylabel("energy fluctuation\n∫ (M₁ − mean M₁) dφ [J]")
    a3.set_title(
        f"energy swing ΔE = {cycle.energy:.4g} J over one period (arrow): a flywheel of J = ΔE / (δ ω²) = "
        f"{j_fly:.3g} kg·m²\n(all rotating inertia reduced to the crank) keeps δ = {target:g} at {abs(w):.4g} rad/s",
        fontsize=8.5,
    )
    a3.margins(y=0.12)
    for ax in (a1, a2, a3):
        ax.grid(True, alpha=0.3)
    finish_x(a3, [x, xe], label)
    a1.set_title(
        title(mech, f"torque to turn the crank at {to_rpm(abs(w)):.0f} rpm, {direction(w)} (inverse dynamics)"),
        fontsize=10,
    )
    return save(fig, out_dir, "torque.png")


def reactions_plot(mech: Mechanism, kin_mj: Trace, rx: reference.Reactions, out_dir) -> list[Path]:
    """The loads in the kinematic pairs over the kinematic run, two files.

    ``reactions.png``: small multiples, one panel per pair: the force magnitude |F| (N)
    against crank angle, MuJoCo vs kinetostatics, the peak marked and named, and MuJoCo's
    error as a thin line against the pair's threshold on a second axis.
    ``reaction_polar.png``: the polar load diagram of every revolute pair: the force on the
    pair's child, resolved in the frame of the link that carries the bearing (the parent;
    fixed axes for a frame pivot), as the bearing sees it over a cycle (N, equal axes), the
    start and the peak marked (reference; the direction of travel by an arrow).
    """
    (x,), label = crank_x(mech, kin_mj)
    labels = list(rx.forces)
    n = len(labels)
    cols = 2 if n > 1 else 1
    rows = math.ceil(n / cols)
    fig = figure(figsize=(12.0, 3.1 * rows + 1.1))
    gs = fig.add_gridspec(2 * rows, cols, height_ratios=[1.0, 0.42] * rows)
    place(fig, gs, left=0.85, right=0.2, top=1.0, bottom=0.85, hgap=0.32, wgap=0.85)
    first = None
    for k, lab in enumerate(labels):
        r, c = divmod(k, cols)
        ax = fig.add_subplot(gs[2 * r, c], sharex=first)
        first = first or ax
        rax = fig.add_subplot(gs[2 * r + 1, c], sharex=first)
        f_ref, f_mj = analysis.magnitude(rx.forces[lab]), analysis.magnitude(kin_mj.reactions[lab])
        ax.plot(x, f_ref, **REF_STYLE)
        ax.plot(x, f_mj, color=palette.link(k), **MJ_STYLE)
        i = int(np.argmax(f_ref))
        ax.plot(x[i], f_ref[i], "v", color="k", ms=6, zorder=5)
        ax.annotate(
            f"peak {f_ref[i]:.4g} N",
            (x[i], f_ref[i]),
            xytext=(0, 4),
            textcoords="offset points",
            ha="center",
            va="bottom",
            fontsize=8,
        )
        ax.set_ylim(0.0, 1.3 * float(f_ref.max()) or 1.0)
        ax.set_ylabel("|F| [N]")
        ax.set_title(lab, fontsize=9)
        ax.grid(True, alpha=0.3)
        ax.tick_params(labelbottom=False)
        err = analysis.magnitude(kin_mj.reactions[lab] - rx.forces[lab])
        residual(
            rax, x, err, "N", compare.force_limit(rx.forces[lab]), color=palette.link(k), what="|ΔF|", signed=False
        )
        if r == rows - 1 or k + cols >= n:
            finish_x(rax, [x], label)
        else:
            rax.tick_params(labelbottom=False)
    handles = [
        plt.Line2D([], [], **REF_STYLE, label=REF_LABEL + ", kinetostatics"),
        plt.Line2D([], [], color="0.3", **MJ_STYLE, label=MJ_LABEL + " (in the pair's colour)"),
    ]
    fig.legend(handles=handles, loc="lower center", ncol=2, fontsize=8.5, bbox_to_anchor=(0.5, 0.0))
    w = float(np.mean(kin_mj.omega))
    fig.suptitle(
        title(mech, f"force in every kinematic pair at {to_rpm(abs(w)):.0f} rpm, {direction(w)}; peak marked"),
        fontsize=10,
        # A fixed 0.12 in from the top, clear of the 1 in margin above the panels, however many
        # pairs make the figure tall (a fraction of its height would sink into them).
        y=1.0 - 0.12 / fig.get_figheight(),
        va="top",
    )
    paths = [save(fig, out_dir, "reactions.png")]

    loads = analysis.pair_loads(mech, rx)
    if loads:
        cols = min(4, len(loads))
        rows = math.ceil(len(loads) / cols)
        fig, axs = subplots(rows, cols, figsize=(3.4 * cols + 0.6, 3.6 * rows + 0.9), squeeze=False)
        # Fixed margins (one draw): three lines of suptitle, two of each panel's title, the
        # force ticks and labels; equal axes shrink to a square inside each cell.
        place(fig, axs[0, 0].get_gridspec(), left=0.95, right=0.15, top=1.25, bottom=0.55, hgap=1.05, wgap=0.75)
        for k, pl in enumerate(loads):
            ax = axs[k // cols, k % cols]
            f = pl.force
            c = palette.link(labels.index(pl.label))
            ax.plot(f[:, 0], f[:, 1], color=c, lw=1.6)
            ax.plot([0, f[0, 0]], [0, f[0, 1]], color="0.5", lw=0.8)
            ax.plot(*f[0], "s", color="k", ms=4.5, zorder=5)
            i = int(np.argmax(pl.magnitude))
            ax.plot([0, f[i, 0]], [0, f[i, 1]], color="k", lw=1.0)
            ax.plot(*f[i], "v", color="k", ms=6, zorder=5)
            j = min(len(f) - 1, max(1, len(f) // 8))
            ax.annotate("", f[j], xytext=f[j - 1], arrowprops=dict(arrowstyle="-|>", color=c, lw=1.4))
            r = 1.15 * float(pl.magnitude.max()) or 1.0
            ax.set_xlim(-r, r)
            ax.set_ylim(-r, r)
            ax.set_aspect("equal")
            ax.axhline(0, color="0.6", lw=0.6)
            ax.axvline(0, color="0.6", lw=0.6)
            ax.grid(True, alpha=0.3)
            frame = "fixed axes (frame pivot)" if pl.frame == GROUND else f"axes of {pl.frame}"
            ax.set_title(f"{pl.label}\npeak {pl.magnitude[i]:.4g} N; {frame}", fontsize=8.5)
            ax.set_xlabel("Fx [N]", fontsize=8.5)
            ax.set_ylabel("Fy [N]", fontsize=8.5)
        for k in range(len(loads), rows * cols):
            axs[k // cols, k % cols].axis("off")
        fig.suptitle(
            title(
                mech,
                "polar load diagrams: force on each pair's child in the frame of the link carrying the bearing\n"
                "(x along the link's first two points; square: start, triangle: peak; reference, one cycle)",
            ),
            fontsize=10,
        )
        paths.append(save(fig, out_dir, "reaction_polar.png"))
    return paths


def steady_plot(
    mech: Mechanism, plain: reference.Steady, fly: reference.Steady, runs: tuple[SteadyRun, SteadyRun], out_dir
) -> Path:
    """``steady.png``: crank speed (rpm, magnitude) over one period of steady motion, without
    and with the flywheel, MuJoCo's last period vs the reference's orbit; beneath, MuJoCo minus
    the reference at the same angle turned (rpm; the rule is on delta, not on this curve)."""
    fig, (ax, rax) = subplots(2, 1, figsize=(9, 7.0), sharex=True, gridspec_kw=dict(height_ratios=(1, 0.45)))
    place(fig, ax.get_gridspec(), left=1.25, top=0.75, bottom=0.95, hgap=0.2)
    for st, run, color, what in (
        (plain, runs[0], "tab:blue", "no flywheel"),
        (fly, runs[1], "tab:green", f"flywheel {fly.extra_inertia:.3g} kg·m²"),
    ):
        # MuJoCo's run spans several periods to settle: only its last, lined up with the
        # reference's orbit by the crank angle turned from phi0 within the period.
        a, omega, at = analysis.last_period_at(mech, run.trace, st.t[-1], st.phi, st.omega)
        ar = analysis.period_angle(mech, st.phi)
        k = np.argsort(ar)
        ax.plot(
            np.degrees(ar[k]),
            np.abs(to_rpm(st.omega[k])),
            label=f"{what}: reference, δ = {st.delta:.4f}",
            **dict(REF_STYLE, color=darker(color)),  # each case's reference in its own hue
        )
        ax.plot(
            np.degrees(a), np.abs(to_rpm(omega)), color=color, label=f"{what}: MuJoCo, δ = {run.delta:.4f}", **MJ_STYLE
        )
        rax.plot(np.degrees(a), np.abs(to_rpm(omega)) - np.abs(to_rpm(at)), color=color, lw=1.0, label=what)
    rax.axhline(0.0, color="0.5", lw=0.6)
    rax.set_gid(RESIDUAL_GID)
    rax.set_ylabel("MuJoCo − ref.\n|n₁| [rpm]", fontsize=8.5)
    rax.grid(True, alpha=0.3)
    rax.legend(loc="best", fontsize=7.5)
    rax.set_xlabel(f"crank angle turned from φ₀₁ = {math.degrees(mech.phi0):g}° within the period [deg]")
    ax.set_ylabel("crank speed |n₁| [rpm]")
    ax.grid(True, alpha=0.3)
    ax.legend(loc="best", fontsize=8)
    # The two flywheel figures a run reports, tied together: torque.png's classical estimate is
    # the whole rotating inertia at constant speed; this one is what is added to the links'.
    if mech.steady is not None:
        w = abs(fly.omega_mean)
        classical = analysis.flywheel_estimate(analysis.torque_cycle(mech, w).energy, w, mech.steady.target_delta)
        fig.text(
            0.02,
            0.012,
            f"The flywheel added here, {fly.extra_inertia:.3g} kg·m², is found under the motor's characteristic on top "
            "of the links' own inertia.\nThe classical estimate on torque.png, J = ΔE / (δ ω²) = "
            f"{classical:.3g} kg·m² at this mean speed, is the whole rotating inertia reduced to the crank at constant "
            "speed.",
            fontsize=7.5,
            va="bottom",
        )
    ax.set_title(title(mech, f"steady motion under the motor characteristic, {direction(fly.omega_mean)}"), fontsize=10)
    return save(fig, out_dir, "steady.png")


def shaking_plot(mech: Mechanism, kin_mj: Trace, ref: FrameLoads, got: FrameLoads, out_dir) -> Path:
    """``shaking.png``: the force on the frame as a hodograph (Fy against Fx, N, equal axes, the
    start marked: the shaking force of the inertia, the gravity load and the point forces
    together, what the ground pairs carry) and the moment on the frame about the input crank's
    pivot (N*m) against crank angle; the reference as a line, MuJoCo as markers (they coincide
    where they agree)."""
    (x,), label = crank_x(mech, kin_mj)
    fig = figure(figsize=(11, 6.4))
    gs = fig.add_gridspec(2, 2, width_ratios=(1, 1.4), height_ratios=(1, 0.45))
    place(fig, gs, left=0.85, right=0.2, top=0.75, bottom=0.6, hgap=0.2, wgap=1.2)
    a1 = fig.add_subplot(gs[:, 0])
    a2 = fig.add_subplot(gs[0, 1])
    a3 = fig.add_subplot(gs[1, 1], sharex=a2)
    a2.tick_params(labelbottom=False)
    every = max(1, len(x) // 60)
    a1.plot(ref.force[:, 0], ref.force[:, 1], label=REF_LABEL, **REF_STYLE)
    a1.plot(
        got.force[::every, 0],
        got.force[::every, 1],
        "o",
        ms=3.5,
        mfc="none",
        color="tab:blue",
        label="MuJoCo (circles)",
    )
    a1.plot(*ref.force[0], "s", color="tab:red", ms=6, label="start (phi01)")
    a1.plot(0, 0, "+", color="0.4", ms=10)
    a1.set_aspect("equal", adjustable="datalim")
    a1.set_xlabel("Fx on the frame [N]")
    a1.set_ylabel("Fy on the frame [N]")
    a1.legend(loc="best", fontsize=8)
    a1.grid(alpha=0.3)
    a1.set_title("force on the frame: shaking (inertia) + gravity + forces", fontsize=9)
    a2.plot(x, ref.moment, label=REF_LABEL, **REF_STYLE)
    if got.moment is not None and (kin_mj.gear_torques or not mech.geared):
        a2.plot(x[::every], got.moment[::every], "o", ms=3.5, mfc="none", color="tab:blue", label="MuJoCo (circles)")
    a2.axhline(0, color="0.6", lw=0.8)
    a2.set_ylabel("moment on the frame\nabout the crank pivot [N·m]")
    a2.legend(loc="best", fontsize=8)
    df = analysis.magnitude(got.force - ref.force)
    residual(
        a3,
        x,
        df,
        "N",
        compare.shaking_force_limit(ref.force),
        what="|ΔF| on the frame",
        signed=False,
    )
    finish_x(a3, [x], label)
    w = float(np.mean(kin_mj.omega))
    fig.suptitle(title(mech, f"loads on the frame at {to_rpm(abs(w)):.0f} rpm (inertia, gravity, forces)"), fontsize=10)
    return save(fig, out_dir, "shaking.png")
