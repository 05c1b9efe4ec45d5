"""The run-up figures: crank speed and acceleration against time and against crank angle,
MuJoCo against the reference's solution of the equation of motion and the paper's RK4 (the
take-up's Figs. 3 and 4).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.ticker import MaxNLocator

from .. import compare, palette, reference
from ..model.mechanism import Mechanism
from ..runs import Trace
from ..units import to_rpm
from .style import (
    MJ_LABEL,
    MJ_STYLE,
    REF_LABEL,
    REF_STYLE,
    RK4_STYLE,
    angle_ticks,
    crank_axis,
    direction,
    figure,
    place,
    residual,
    save,
    title,
)

# ----------------------------------------------------------------------------- speed (Figs. 3, 4)
ZOOM_TURNS = 2  # the speed plots' right column: the last turns of the run
TRANSIENT_SHARE = 0.02  # the share of the run whose start transient is kept out of the eps autoscale


def _robust_limits(x: np.ndarray, y: np.ndarray, start: float) -> tuple[float, float] | None:
    """y limits that fit ``y`` where ``x >= start`` (a start transient left out), padded;
    None if that leaves nothing or the transient fits anyway."""
    keep = x >= start
    if keep.sum() < 2 or keep.all():
        return None
    lo, hi = float(np.min(y[keep])), float(np.max(y[keep]))
    if np.min(y) >= lo - 0.25 * (hi - lo) and np.max(y) <= hi + 0.25 * (hi - lo):
        return None
    pad = 0.08 * (hi - lo or abs(hi) or 1.0)
    return lo - pad, hi + pad


def speed_plots(
    mech: Mechanism, dyn_mj: Trace, dyn_ref: Trace, out_dir, rk4: reference.Motion | None = None
) -> list[Path]:
    """The run-up of the forward-dynamics case, as the paper's Figs. 3 and 4.

    ``speed_vs_time.png`` against time (s), ``speed_vs_angle.png`` against the unwrapped crank
    angle (deg). Left, the whole run: the crank speed |n1| (rpm, its sense in the title), the
    crank acceleration eps1 (rad/s^2; a start transient shorter than 2 % of the run is kept
    out of the autoscale and its extreme named) and MuJoCo minus the reference (rad/s, with
    the omega threshold). Right, the last :data:`ZOOM_TURNS` turns, where the speed's
    oscillation within a turn shows, and, where the paper integrated with RK4 (``rk4``, a
    :class:`reference.Motion` in SI units), the paper's RK4 minus the reference (rpm) over
    the whole run. ``dyn_ref`` is the reference's tight ODE solution at MuJoCo's times.
    Returns both paths.
    """
    paths = []
    angle, angle_label = crank_axis(mech, dyn_mj.phi)
    sense = direction(dyn_mj.omega)
    limit = compare.omega_limit(dyn_ref.omega)
    t_end = float(max(dyn_mj.time[-1], dyn_ref.time[-1]))
    k = int(np.searchsorted(rk4.t, t_end * (1 + 1e-9), "right")) if rk4 is not None else 0
    for name, xlabel, by_time in (
        ("speed_vs_time.png", "time t [s]", True),
        ("speed_vs_angle.png", angle_label + " (unwrapped)", False),
    ):
        fig = figure(figsize=(13.0, 9.4))
        gs = fig.add_gridspec(3, 2, width_ratios=(1.75, 1.0), height_ratios=(1.0, 1.0, 0.72))
        place(fig, gs, left=1.05, right=0.4, top=0.95 if by_time else 1.25, bottom=0.6, hgap=0.62, wgap=1.05)
        a_n = fig.add_subplot(gs[0, 0])
        a_e = fig.add_subplot(gs[1, 0], sharex=a_n)
        a_r = fig.add_subplot(gs[2, 0], sharex=a_n)
        z_n = fig.add_subplot(gs[0, 1])
        z_e = fig.add_subplot(gs[1, 1], sharex=z_n)
        a_k = fig.add_subplot(gs[2, 1])
        xm = dyn_mj.time if by_time else angle(dyn_mj.phi)
        xr = dyn_ref.time if by_time else angle(dyn_ref.phi)
        nm, nr = np.abs(to_rpm(dyn_mj.omega)), np.abs(to_rpm(dyn_ref.omega))
        xk: np.ndarray | None = None
        nk = ek = np.empty(0)
        if rk4 is not None:
            # Only the span of the runs shown: samples beyond would stretch the autoscale.
            xk = rk4.t[:k] if by_time else angle(rk4.phi[:k])
            nk, ek = np.abs(to_rpm(rk4.omega[:k])), rk4.eps[:k]
        rk4_label = (
            f"paper's RK4, {len(rk4.t) - 1} steps of {rk4.t[1] - rk4.t[0]:.3g} s (dotted)" if rk4 is not None else ""
        )
        for ax_n, ax_e in ((a_n, a_e), (z_n, z_e)):
            ax_n.plot(xr, nr, label=REF_LABEL + ", ODE solved tightly", **REF_STYLE)
            ax_n.plot(xm, nm, color=palette.MUJOCO, label=MJ_LABEL, **MJ_STYLE)
            ax_e.plot(xr, dyn_ref.eps, label=REF_LABEL, **REF_STYLE)
            ax_e.plot(xm, dyn_mj.eps, color=palette.MUJOCO, label=MJ_LABEL, **MJ_STYLE)
            if xk is not None:
                ax_n.plot(xk, nk, label=rk4_label, **RK4_STYLE)
                ax_e.plot(xk, ek, **RK4_STYLE)
            ax_n.set_ylabel("crank speed |n₁| [rpm]")
            ax_e.set_ylabel("crank acceleration ε₁ [rad/s²]")
            for ax in (ax_n, ax_e):
                ax.grid(True, alpha=0.3)
        # A start transient (a run-up in milliseconds, a jump of the load at t = 0) dwarfs
        # what follows: kept out of the autoscale, its extreme named on the panel.
        x0 = float(xm[0])
        start = x0 + TRANSIENT_SHARE * (float(xm[-1]) - x0)
        span = f"{1e3 * (start - x0):.3g} ms" if by_time else f"{start - x0:.3g}° of crank angle"
        early = np.asarray(xm) < start
        notes: dict[Any, str] = {}
        for ax, y, what in (
            (a_n, nm, f"run-up from {float(np.min(nm[early])):.4g} rpm in the first {span} off scale"),
            (a_e, np.asarray(dyn_mj.eps), ""),
        ):
            lim = _robust_limits(np.asarray(xm), y, start)
            if lim is None:
                continue
            ax.set_ylim(*lim)
            e_abs = float(np.max(np.abs(y[early])))
            # Not inside the panel, whose curves fill it from end to end: the speed panel's as its
            # legend's title (its top edge carries the crank turns), the acceleration's above it.
            notes[ax] = what or f"start transient off scale: |ε₁| up to {e_abs:.3g} rad/s² in the first {span}"
            if ax is a_e:
                ax.set_title(notes[ax], loc="left", fontsize=7.5, color="0.25")
        # Zoom: the last turns of the crank, MuJoCo's and the reference's and RK4's.
        turned = np.abs(dyn_mj.phi - dyn_mj.phi[-1])
        z0 = float(np.asarray(xm)[turned <= ZOOM_TURNS * 2.0 * math.pi][0])
        z1 = float(np.asarray(xm)[-1])
        z_n.set_xlim(z0, z1)
        for ax, xs, ys in ((z_n, [xm, xr], [nm, nr]), (z_e, [xm, xr], [dyn_mj.eps, dyn_ref.eps])):
            vals = np.concatenate(
                [np.asarray(y)[(np.asarray(x) >= z0) & (np.asarray(x) <= z1)] for x, y in zip(xs, ys)]
            )
            if xk is not None and ax is z_n:
                sel = (np.asarray(xk) >= z0) & (np.asarray(xk) <= z1)
                vals = np.concatenate([vals, nk[sel]])
            if vals.size:
                lo, hi = float(vals.min()), float(vals.max())
                pad = 0.1 * (hi - lo or abs(hi) or 1.0)
                ax.set_ylim(lo - pad, hi + pad)
        z_n.set_title(f"zoom: the last {ZOOM_TURNS} turns", fontsize=9)
        short = "time t [s]" if by_time else "crank angle, as on the left [deg]"
        z_e.set_xlabel(short)
        # The zoom spans a few turns of a long run: its ticks are long numbers, five at most.
        z_e.xaxis.set_major_locator(MaxNLocator(5))
        residual(a_r, xm, dyn_mj.omega - dyn_ref.omega, "rad/s", limit, what="MuJoCo − ref. ω₁")
        a_r.set_xlabel(xlabel)
        if rk4 is not None and xk is not None:
            tight = np.interp(rk4.t[:k], dyn_ref.time, dyn_ref.omega)
            diff = np.abs(to_rpm(rk4.omega[:k])) - np.abs(to_rpm(tight))
            a_k.plot(xk, diff, **dict(RK4_STYLE, ls="-"))
            a_k.axhline(0.0, color="0.5", lw=0.6)
            rel = float(np.max(np.abs(diff)) / np.max(np.abs(to_rpm(tight))))
            a_k.set_ylabel("paper's RK4 − reference\n|n₁| [rpm]", fontsize=8.5)
            a_k.text(
                0.005,
                0.96,
                f"the paper's RK4 is off by up to {100 * rel:.3g} % of the top speed",
                transform=a_k.transAxes,
                ha="left",
                va="top",
                fontsize=7.5,
                bbox=dict(boxstyle="round,pad=0.15", fc="white", ec="none", alpha=0.8),
            )
            a_k.margins(y=0.25)
            a_k.grid(True, alpha=0.3)
            a_k.set_xlabel(short)
            a_k.set_gid("rk4-residual")  # the paper's method against the reference, not MuJoCo
        else:
            # No RK4 in this paper: the zoom's residual instead, where the scale is that of a turn.
            sel = np.asarray(xm) >= z0
            residual(
                a_k, np.asarray(xm)[sel], (dyn_mj.omega - dyn_ref.omega)[sel], "rad/s", limit, what="MuJoCo − reference"
            )
            a_k.set_xlabel(short)
        if by_time:
            a_r.set_xlim(0.0, t_end)
            if rk4 is not None:
                a_k.set_xlim(0.0, t_end)
        else:
            angle_ticks(a_r, float(min(np.min(xm), np.min(xr))), float(max(np.max(xm), np.max(xr))))
            if np.ptp(xm) >= 720.0:
                # Tens of turns in degrees are hard to count: name the turns on top as well.
                top = a_n.secondary_xaxis(
                    "top", functions=(lambda d: np.asarray(d) / 360.0, lambda k: np.asarray(k) * 360.0)
                )
                top.set_xlabel("crank turns (angle / 360°)", fontsize=9)
        for ax in (a_n, a_e):
            ax.tick_params(labelbottom=False)
        z_n.tick_params(labelbottom=False)
        a_n.legend(loc="lower right", fontsize=8, title=notes.get(a_n), title_fontsize=7.5)
        d = mech.dynamics
        motor = getattr(d, "motor", None)
        drive = (
            f"motor M₁ = {motor.stall_torque:g} N·m × (1 − ω / {motor.no_load_speed:g} rad/s)"
            if motor is not None
            else f"M₁ = {d.moment:g} N·m"
        )
        fig.suptitle(
            title(
                mech,
                f"run-up, crank turning {sense} (speeds as magnitudes), {drive}, "
                f"b = {d.damping:g} N·m·s, ω₀ = {d.omega0:g} rad/s",
            ),
            fontsize=10,
        )
        paths.append(save(fig, out_dir, name))
    return paths
