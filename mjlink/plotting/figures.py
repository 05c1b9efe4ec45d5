"""PNG figures comparing MuJoCo runs with the vector-method reference, as in the papers.

Take-up (seed 000): crank speed and acceleration against time and against crank angle (its
Figs. 3 and 4), the mechanism drawn in many crank positions with the paths of its points
(Fig. 1b; seed 004 Fig. 4), the thread length and the kinematics of one point. Crank-slider
(seed 002, Figs. 3-5): the slider's position, velocity and acceleration along its guide, the
harmonic content of its acceleration and its pressure angle against the synthesis limit.
Take-up with eyelets (seed 003): the needle-thread feed and the spatial thread contour in
front and top view (Fig. 2). Warp knitting (seed 004): the needle path for several settings
of the geared crank (Fig. 3) and the rotation of the swinging cylinder (Fig. 4a-b).
:func:`all_plots` draws those that apply to a mechanism; :mod:`.drawing` and :mod:`.speed` hold the
mechanism's drawing and the run-up figures.

Drawing only: the quantities shown are a trace's samples, reference positions
(:func:`mjlink.reference.solve`) or derived in :mod:`mjlink.analysis`. Inputs are
:class:`mjlink.runs.Trace` objects in SI units; the plots show mm, um, deg, rpm, m/s, m/s^2,
rad/s and rad/s^2 as labelled. The shared look and the atomic writer are :mod:`.style`'s.
"""

from __future__ import annotations

import math
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from .. import analysis, compare, palette, reference
from ..errors import AssemblyError
from ..model import blocks
from ..model.mechanism import Crank, Mechanism
from ..runs import Trace
from ..units import to_mm, to_rpm, to_um
from .drawing import contour_plot, positions_plot, segments
from .speed import speed_plots
from .style import (
    MJ_LABEL,
    MJ_STYLE,
    REF_LABEL,
    REF_STYLE,
    angle_ticks,
    crank_x,
    direction,
    finish_x,
    pair,
    place,
    residual,
    save,
    subplots,
    subscript,
    title,
)

__all__ = [
    "all_plots",
    "contour_plot",
    "kinematic_plots",
    "kinematics_plot",
    "link_motion_plot",
    "phase_study_plot",
    "positions_plot",
    "segments",
    "slider_plots",
    "speed_plots",
    "thread_feed_plot",
    "thread_plot",
]


# ----------------------------------------------------------------------------- thread length
def thread_plot(mech: Mechanism, kin_mj: Trace, kin_ref: Trace, out_dir) -> Path | None:
    """``thread_length.png``: thread length (mm) against crank angle (deg) over the kinematic
    run, MuJoCo vs reference, and below their difference MuJoCo - reference (um).
    None if the mechanism has no thread."""
    if not mech.thread:
        return None
    Lm, Lr = analysis.thread_length(mech, kin_mj), analysis.thread_length(mech, kin_ref)
    (xm, xr), xlabel = crank_x(mech, kin_mj, kin_ref)
    fig, (a1, a2) = subplots(2, 1, figsize=(8.0, 6.2), sharex=True, gridspec_kw=dict(height_ratios=(2.2, 1)))
    place(fig, a1.get_gridspec(), left=1.05, top=0.75, bottom=0.6, hgap=0.2)
    a1.plot(xr, to_mm(Lr), label=REF_LABEL, **REF_STYLE)
    a1.plot(xm, to_mm(Lm), color=palette.THREAD, label=MJ_LABEL + ", spatial tendon", **MJ_STYLE)
    a1.set_ylabel("thread length [mm]")
    a1.legend(loc="best", fontsize=8)
    # The two runs share their time samples, so compare sample by sample on MuJoCo's angles.
    diff = to_um(Lm - np.interp(xm, xr, Lr) if len(Lm) != len(Lr) else Lm - Lr)
    residual(a2, xm, diff, "µm", compare.THREAD_UM, color=palette.THREAD)
    finish_x(a2, [xm, xr], xlabel)
    for ax in (a1, a2):
        ax.grid(True, alpha=0.3)
    a1.set_title(
        title(mech, "thread " + "–".join(mech.thread) + f", max |difference| = {np.abs(diff).max():.3g} µm"),
        fontsize=10,
    )
    return save(fig, out_dir, "thread_length.png")


# ----------------------------------------------------------------------------- one point
def kinematics_plot(mech: Mechanism, kin_mj: Trace, kin_ref: Trace, out_dir, point: str) -> Path:
    """``kinematics_<point>.png``: the motion of ``point`` against crank angle over the
    kinematic run, MuJoCo vs ``kin_ref`` (the reference at MuJoCo's own crank state,
    :func:`mjlink.compare.reference_at`). Three columns, position (mm), velocity (m/s) and
    acceleration (m/s^2); a row per component x, y, z that changes over the run, each on its
    own axes (a y swinging 24 mm is not flattened by an x of 250 mm), a row with the
    magnitudes |v| and |a| (the position column names the strokes), and a last row with the
    length of MuJoCo's error vector (um, m/s, m/s^2) against the thresholds of ``simulate``."""
    (xm, xr), xlabel = crank_x(mech, kin_mj, kin_ref)
    lim = compare.point_limits(kin_ref, point)
    series = (
        (kin_mj.points[point], kin_ref.points[point], 1e3, "mm", "position", lim.position * 1e6, 1e6, "µm"),
        (kin_mj.velocities[point], kin_ref.velocities[point], 1.0, "m/s", "velocity", lim.velocity, 1.0, "m/s"),
        (
            kin_mj.accelerations[point],
            kin_ref.accelerations[point],
            1.0,
            "m/s²",
            "acceleration",
            lim.acceleration,
            1.0,
            "m/s²",
        ),
    )
    comps = [
        j for j in range(3) if np.ptp(kin_ref.points[point][:, j]) > 1e-9 or np.ptp(kin_mj.points[point][:, j]) > 1e-9
    ]
    rows = len(comps) + 2
    fig, axs = subplots(
        rows,
        3,
        figsize=(14.0, 2.05 * rows + 1.2),
        sharex=True,
        gridspec_kw=dict(height_ratios=[1.0] * (rows - 1) + [0.8]),
    )
    place(fig, axs[0, 0].get_gridspec(), left=1.05, right=0.25, top=1.0, bottom=0.6, hgap=0.22, wgap=1.15)
    hues = ("tab:blue", "tab:green", "tab:purple")
    for c, (mj, ref, scale, unit, what, limit, rscale, runit) in enumerate(series):
        for r, j in enumerate(comps):
            ax = axs[r, c]
            pair(ax, xm, scale * mj[:, j], xr, scale * ref[:, j], hues[j])
            if what != "position":
                ax.axhline(0.0, color="0.5", lw=0.6, zorder=0)
            ax.set_ylabel(f"{what} {'xyz'[j]} [{unit}]")
            ax.grid(True, alpha=0.3)
        ax = axs[len(comps), c]
        if what == "position":
            strokes = ", ".join(f"{'xyz'[j]} {1e3 * np.ptp(ref[:, j]):.3f} mm" for j in comps)
            ax.axis("off")
            ax.text(
                0.5,
                0.5,
                f"strokes of {point} over the run:\n{strokes}\n(range max − min of each coordinate)",
                transform=ax.transAxes,
                ha="center",
                va="center",
                fontsize=9,
            )
        else:
            pair(ax, xm, analysis.magnitude(mj), xr, analysis.magnitude(ref), "tab:red")
            ax.set_ylabel(f"|{what[0]}| [{unit}]")
            ax.grid(True, alpha=0.3)
        residual(
            axs[-1, c],
            xm,
            rscale * analysis.magnitude(mj - ref),
            runit,
            limit,
            what=f"|Δ{what[0] if what != 'position' else 'P'}|, MuJoCo − ref.",
            signed=False,
        )
        axs[0, c].set_title(what, fontsize=10)
        finish_x(axs[-1, c], [xm, xr], xlabel)
    axs[0, 0].legend(loc="best", fontsize=8)
    w = float(np.mean(kin_mj.omega))
    fig.suptitle(
        title(mech, f"point {point}, crank at {to_rpm(abs(w)):.4g} rpm ({abs(w):.4g} rad/s), {direction(w)}"),
        fontsize=10,
    )
    return save(fig, out_dir, f"kinematics_{point}.png")


# ----------------------------------------------------------------------------- sliders (seed 002)
def slider_plots(mech: Mechanism, kin_mj: Trace, kin_ref: Trace, out_dir) -> list[Path]:
    """For every slider block (seed 002, Figs. 3-5), three files, MuJoCo vs reference:

    ``slider_<P>.png``: the slider's position s along its guide from n1 (mm), its velocity
    ds/dt (m/s) and acceleration d2s/dt2 (m/s^2) relative to the guide (see
    :func:`mjlink.analysis.slider_motion`) against crank angle; ``slider_<P>_spectrum.png``: amplitudes of the
    harmonics 1..12 of the crank turn (of the mechanism period if longer) in the slider
    acceleration, log scale, with the share of the higher harmonics; ``pressure_angle_<P>.png``:
    the pressure angle (deg) with the synthesis limit [theta] if the file has one.
    """
    paths = []
    (xm, xr), xlabel = crank_x(mech, kin_mj, kin_ref)
    turns = round(mech.period / (2.0 * math.pi))
    for sl in blocks.sliders(mech.steps):
        p, (n1, n2) = sl.point, sl.guide
        sm, sr = analysis.slider_motion(kin_mj, sl), analysis.slider_motion(kin_ref, sl)
        moving = analysis.guide_moves(mech, sl)
        guide = ("relative to its moving guide " if moving else "on guide ") + f"{n1}→{n2}"

        # --- s, ds/dt, d2s/dt2 and MuJoCo's error in s
        fig, axs = subplots(4, 1, figsize=(8.0, 9.6), sharex=True, gridspec_kw=dict(height_ratios=(1, 1, 1, 0.7)))
        place(fig, axs[0].get_gridspec(), left=1.05, top=0.75, bottom=0.6, hgap=0.2)
        # Velocity and acceleration reverse within a stroke: a zero line shows where.
        panels = (
            ("position s along the guide [mm]", to_mm, "tab:blue"),
            ("velocity ds/dt [m/s]", None, "tab:purple"),
            ("acceleration d²s/dt² [m/s²]", None, "tab:red"),
        )
        residual(axs[3], xm, to_um(sm[0] - sr[0]), "µm", compare.POSITION_UM, what="MuJoCo − ref., s")
        for ax, a, b, (lab, scale, c) in zip(axs[:3], sm, sr, panels):
            if scale is None:
                pair(ax, xm, a, xr, b, c)
                ax.axhline(0.0, color="0.5", lw=0.6, zorder=0)
            else:
                pair(ax, xm, scale(a), xr, scale(b), c)
            ax.set_ylabel(lab)
            ax.grid(True, alpha=0.3)
        axs[0].legend(loc="best", fontsize=8)
        stroke = float(np.ptp(sr[0]))
        syn = f" (synthesis: {to_mm(mech.synthesis.stroke):g} mm)" if mech.synthesis is not None and not moving else ""
        also = analysis.sliding_with(mech, sl)
        if also:
            syn += f" (also of {', '.join(also)})"
        for v in (sr[0].min(), sr[0].max()):
            axs[0].axhline(to_mm(v), color="0.4", lw=0.7, ls=":")
        finish_x(axs[3], [xm, xr], xlabel)
        axs[0].set_title(title(mech, f"slider {p} {guide}: stroke {to_mm(stroke):.2f} mm{syn}"), fontsize=10)
        paths.append(save(fig, out_dir, f"slider_{p}.png"))

        # --- harmonic content of the acceleration
        am, ar = analysis.harmonics(mech, kin_mj, sm[2]), analysis.harmonics(mech, kin_ref, sr[2])
        if am is not None and ar is not None:
            fig, ax = subplots(figsize=(8.0, 5.0))
            place(fig, ax.get_gridspec(), left=1.2, right=0.25, top=0.75, bottom=0.6)  # one draw
            k = np.arange(1, len(ar) + 1)
            ax.bar(k - 0.2, am, width=0.4, color="tab:red", alpha=0.75, label="MuJoCo (filled)")
            ax.bar(
                k + 0.2, ar, width=0.4, color="white", edgecolor="k", hatch="////", lw=0.8, label="reference (hatched)"
            )
            ax.set_yscale("log")
            ax.set_xticks(k)
            if turns > 1:
                ax.set_xlabel(
                    f"harmonic k of the mechanism period [-] ({turns} turns of the input crank = "
                    f"{math.degrees(mech.period):g}°; k = {turns}: once per turn)"
                )
            else:
                ax.set_xlabel("harmonic k of the crank rotation, its order [-]")
            ax.set_ylabel(f"amplitude of d²s/dt² of {p} [m/s²]")
            ax.grid(True, which="major", axis="y", alpha=0.3)
            ks = f"2..{len(ar)}"
            txt = (
                f"higher harmonics k = {ks} relative to the first, "
                f"√(ΣAₖ²) / A₁:\n"
                f"MuJoCo {100 * analysis.higher_harmonics_share(am):.1f} %, "
                f"reference {100 * analysis.higher_harmonics_share(ar):.1f} %\n"
                f"A₂/A₁ = {100 * ar[1] / ar[0]:.1f} %,  A₁ = {ar[0]:.4g} m/s² (reference)"
            )
            ax.text(
                0.98,
                0.97,
                txt,
                transform=ax.transAxes,
                ha="right",
                va="top",
                fontsize=8.5,
                bbox=dict(boxstyle="round", fc="white", ec="0.7"),
            )
            ax.legend(loc="lower left", fontsize=8)
            w = float(np.mean(np.abs(kin_mj.omega)))
            ax.set_title(
                title(mech, f"harmonics of the acceleration of slider {p}, {w:.4g} rad/s ({to_rpm(w):.4g} rpm)"),
                fontsize=10,
            )
            paths.append(save(fig, out_dir, f"slider_{p}_spectrum.png"))

        # --- pressure angle
        gm, gr = np.degrees(analysis.pressure_angle(kin_mj, sl)), np.degrees(analysis.pressure_angle(kin_ref, sl))
        fig, (ax, rax) = subplots(2, 1, figsize=(8.0, 6.0), sharex=True, gridspec_kw=dict(height_ratios=(1, 0.4)))
        place(fig, ax.get_gridspec(), left=1.15, top=0.75, bottom=0.6, hgap=0.2)
        residual(rax, xm, gm - gr, "deg", None, color="tab:green", what="MuJoCo − ref.")
        pair(ax, xm, gm, xr, gr, "tab:green")
        i = int(np.argmax(gr))
        top = float(gr[i])
        ax.plot(xr[i], top, "v", color="k", ms=7, zorder=5)
        ax.annotate(
            f"max {top:.2f}° (MuJoCo {gm.max():.2f}°)",
            (xr[i], top),
            xytext=(0, 9),
            textcoords="offset points",
            ha="center",
            fontsize=8.5,
        )
        ymax = top
        if mech.synthesis is not None:
            lim = math.degrees(mech.synthesis.max_pressure_angle)
            ax.axhline(lim, color="tab:red", lw=1.5, label=f"allowed [θ] = {lim:g}°")
            ax.text(xr[0], lim, " [θ]", color="tab:red", va="bottom", fontsize=9)
            ymax = max(ymax, lim)
        ax.set_ylim(0.0, min(90.0, 1.18 * ymax + 1.0))
        ax.set_ylabel(f"pressure angle at {p} [deg]\n(rod {sl.start}–{p} to the guide)")
        ax.grid(True, alpha=0.3)
        ax.legend(loc="lower right", fontsize=8)
        finish_x(rax, [xm, xr], xlabel)
        ax.set_title(
            title(mech, f"pressure angle of slider {p}, rod {sl.start}→{p} against guide {n1}→{n2}"), fontsize=10
        )
        paths.append(save(fig, out_dir, f"pressure_angle_{p}.png"))
    return paths


# ----------------------------------------------------------------------------- thread feed (seed 003)
def thread_feed_plot(mech: Mechanism, kin_mj: Trace, kin_ref: Trace, out_dir) -> Path | None:
    """``thread_feed.png``: over one crank turn from phi0, the thread length lF (mm), its
    increment dlF = lF(phi) - lF(phi0) (mm) and the feed Pd = dlF - dP (mm; dP the file's
    thread elongation), MuJoCo vs reference. None without a thread elongation."""
    if not mech.thread or mech.thread_elongation is None:
        return None
    (xm, xr), xlabel = crank_x(mech, kin_mj, kin_ref)
    dp = mech.thread_elongation
    Lm, dm, fm = analysis.thread_feed(mech, kin_mj)
    Lr, dr, fr = analysis.thread_feed(mech, kin_ref)
    xm, xr = xm[: len(Lm)], xr[: len(Lr)]  # the axis is cut at one turn
    fig, axs = subplots(4, 1, figsize=(8.0, 9.6), sharex=True, gridspec_kw=dict(height_ratios=(1, 1, 1, 0.7)))
    place(fig, axs[0].get_gridspec(), left=1.15, top=0.75, bottom=0.6, hgap=0.2)
    n = min(len(fm), len(fr))
    residual(
        axs[3],
        xm[:n],
        to_um(fm[:n] - fr[:n]),
        "µm",
        compare.THREAD_UM,
        color=palette.THREAD,
        what="MuJoCo − ref., Pd",
    )
    pair(axs[0], xm, to_mm(Lm), xr, to_mm(Lr), "tab:orange")
    axs[0].set_ylabel(f"thread length l_F [mm]\n{'–'.join(mech.thread)}")
    pair(axs[1], xm, to_mm(dm), xr, to_mm(dr), "tab:orange")
    axs[1].set_ylabel("Δl_F = l_F(φ) − l_F(φ₀) [mm]")
    pair(axs[2], xm, to_mm(fm), xr, to_mm(fr), "tab:red")
    axs[2].axhline(0.0, color="k", lw=0.9, zorder=0)
    axs[2].set_ylabel(f"feed Pd = Δl_F − ΔP [mm]\n(ΔP = {to_mm(dp):g} mm)")
    pd = to_mm(fr)
    for ax in axs[:3]:
        ax.grid(True, alpha=0.3)
    for v, va in ((pd.max(), "bottom"), (pd.min(), "top")):
        i = int(np.argmin(np.abs(pd - v)))
        axs[2].plot(xr[i], v, "o", color="k", ms=4, zorder=5)
        axs[2].annotate(
            f"{v:+.2f} mm",
            (xr[i], v),
            xytext=(0, 5 if va == "bottom" else -5),
            textcoords="offset points",
            ha="center",
            va=va,
            fontsize=8.5,
        )
    axs[2].margins(y=0.15)
    axs[0].legend(loc="best", fontsize=8)
    axs[3].set_xlabel(xlabel)
    angle_ticks(axs[3], float(xr[0]), float(xr[0]) + 360.0)
    axs[0].set_title(
        title(
            mech,
            f"needle-thread feed over one turn: Pd from {pd.min():+.2f} "
            f"to {pd.max():+.2f} mm (swing {np.ptp(pd):.2f} mm)",
        ),
        fontsize=10,
    )
    return save(fig, out_dir, "thread_feed.png")


# ----------------------------------------------------------------------------- geared cranks (seed 004 Fig. 3)
def _link_number(mech: Mechanism, crank: Crank) -> int:
    """1-based index of the link carrying ``crank`` (the papers number links so: phi04 is link 4's)."""
    return 1 + [l.name for l in mech.links].index(crank.carriers(mech.links)[0])


def phase_study_plot(
    mech: Mechanism, out_dir, point: str | None = None, offsets_deg=(-90, -60, -30, 0, 30, 60, 90)
) -> Path | None:
    """``phase_study.png``: the path of ``point`` (default: :func:`mjlink.analysis.phase_point`'s)
    over one period for several mutual settings of the cranks: the geared crank's phase is its
    file's phase plus each offset (seed 004, Fig. 3). Settings that cannot assemble are
    listed, not drawn. None where no point's path depends on a geared crank's setting."""
    chosen = analysis.phase_point(mech)
    if chosen is None:  # no path changes with the geared crank's setting: seven identical curves
        return None
    crank, point = chosen[0], point or chosen[1]
    i_in, i_g = _link_number(mech, mech.input_crank), _link_number(mech, crank)
    phi = mech.phi0 + math.copysign(mech.period, mech.speed) * np.linspace(0.0, 1.0, 721)
    cmap = plt.get_cmap("coolwarm")
    span = max(1.0, max(abs(o) for o in offsets_deg))
    fig, ax = subplots(figsize=(9.0, 7.6))
    # Fixed margins (one draw, then the crop): room for three title lines above, the legend
    # to the right; the equal-aspect axes shrink inside, and saving crops the rest.
    place(fig, ax.get_gridspec(), left=0.85, right=3.6, top=0.95, bottom=0.6)
    drawn = []
    for off in offsets_deg:
        ph = (crank.phase or 0.0) + math.radians(off)  # a geared crank always has its phase
        lab = f"φ{subscript(0, i_in)} = {math.degrees(mech.phi0):g}°, φ{subscript(0, i_g)} = {math.degrees(ph):g}°"
        try:
            xy = to_mm(analysis.geared_path(mech, crank, ph, point, phi)[:, :2])
        except AssemblyError:
            ax.plot([], [], " ", label=lab + ": does not assemble")
            continue
        file = off == 0
        c = "k" if file else cmap(0.5 + 0.5 * off / span)
        ax.plot(
            xy[:, 0],
            xy[:, 1],
            color=c,
            lw=2.2 if file else 1.3,
            zorder=3 if file else 2,
            label=lab + f": Δx {np.ptp(xy[:, 0]):.1f}, Δy {np.ptp(xy[:, 1]):.1f} mm" + (" (file)" if file else ""),
        )
        ax.plot(xy[0, 0], xy[0, 1], "o", color=c, ms=5, zorder=4)
        drawn.append(xy)
    if drawn:
        allxy = np.concatenate(drawn)
        lo, hi = allxy.min(axis=0), allxy.max(axis=0)
        pad = 0.08 * float(max(hi - lo))
        ax.set_xlim(lo[0] - pad, hi[0] + pad)
        ax.set_ylim(lo[1] - pad, hi[1] + pad)
    ax.plot([], [], "o", color="0.4", ms=5, label="position at φ₀₁")
    ax.set_aspect("equal", adjustable="box", anchor="NW")  # blank space to the right: cropped on saving
    ax.grid(True, alpha=0.3)
    ax.set_xlabel("x [mm]")
    ax.set_ylabel("y [mm]")
    ax.legend(loc="upper left", bbox_to_anchor=(1.02, 1.0), borderaxespad=0.0, fontsize=8, framealpha=0.9)
    ax.set_title(
        title(
            mech,
            f"path of {point} over {math.degrees(mech.period):g}° of crank {i_in}\n"
            f"for settings of the geared crank {crank.pivot}–{crank.point} "
            f"(ratio {crank.ratio:g})",
        ),
        fontsize=10,
        loc="left",
    )
    return save(fig, out_dir, "phase_study.png", tight=True)


# ----------------------------------------------------------------------------- link rotation (seed 004 Fig. 4a-b)
def link_motion_plot(mech: Mechanism, kin_mj: Trace, kin_ref: Trace, out_dir, link: str) -> Path:
    """``link_<link>.png``: angular velocity (rad/s) and angular acceleration (rad/s^2) of
    ``link`` about z against crank angle, MuJoCo (its body's) vs reference, each with MuJoCo's
    error beneath (informational: link rates are held to no threshold)."""
    (xm, xr), xlabel = crank_x(mech, kin_mj, kin_ref)
    fig, axs = subplots(4, 1, figsize=(8.0, 9.0), sharex=True, gridspec_kw=dict(height_ratios=(1, 0.55, 1, 0.55)))
    place(fig, axs[0].get_gridspec(), left=1.05, right=0.25, top=0.75, bottom=0.6, hgap=0.2)
    for ax, rax, mj, ref, lab, c, unit in (
        (
            axs[0],
            axs[1],
            kin_mj.link_omega,
            kin_ref.link_omega,
            f"angular velocity ω of {link} [rad/s]",
            "tab:blue",
            "rad/s",
        ),
        (
            axs[2],
            axs[3],
            kin_mj.link_eps,
            kin_ref.link_eps,
            f"angular acceleration ε of {link} [rad/s²]",
            "tab:red",
            "rad/s²",
        ),
    ):
        ax.plot(xr, ref[link], label=REF_LABEL, **REF_STYLE)
        if link in mj:
            ax.plot(xm, mj[link], color=c, label=MJ_LABEL, **MJ_STYLE)
            residual(rax, xm, mj[link] - ref[link], unit, None, color=c, what="MuJoCo − ref.")
        else:
            rax.axis("off")
        ax.axhline(0.0, color="0.5", lw=0.6, zorder=0)
        ax.set_ylabel(lab)
        ax.grid(True, alpha=0.3)
    axs[0].legend(loc="best", fontsize=8)
    finish_x(axs[3], [xm, xr], xlabel)
    w, e = kin_ref.link_omega[link], kin_ref.link_eps[link]
    axs[0].set_title(
        title(mech, f"rotation of link {link}: |ω| ≤ {np.abs(w).max():.4g} rad/s, |ε| ≤ {np.abs(e).max():.4g} rad/s²"),
        fontsize=10,
    )
    return save(fig, out_dir, f"link_{link}.png")


# ----------------------------------------------------------------------------- all
def kinematic_plots(mech: Mechanism, kin_mj: Trace, kin_ref: Trace, out_dir) -> list[Path]:
    """Every figure of the kinematic run that applies (see :func:`all_plots`), into ``out_dir``:
    they need nothing of the dynamic run, so they can be drawn while it runs."""
    point = analysis.key_point(mech)
    paths = [positions_plot(mech, out_dir, highlight=None if mech.thread else point)]
    paths += [
        p
        for p in (
            thread_plot(mech, kin_mj, kin_ref, out_dir),
            thread_feed_plot(mech, kin_mj, kin_ref, out_dir),
            contour_plot(mech, out_dir),
        )
        if p is not None
    ]
    paths.append(kinematics_plot(mech, kin_mj, kin_ref, out_dir, point))
    paths += slider_plots(mech, kin_mj, kin_ref, out_dir)
    paths += [link_motion_plot(mech, kin_mj, kin_ref, out_dir, l) for l in analysis.motion_links(mech)]
    ph = phase_study_plot(mech, out_dir)
    if ph is not None:
        paths.append(ph)
    return paths


def all_plots(
    mech: Mechanism,
    kin_mj: Trace,
    kin_ref: Trace,
    dyn_mj: Trace | None,
    dyn_ref: Trace | None,
    out_dir,
    rk4: reference.Motion | None = None,
) -> list[Path]:
    """Every plot above that applies into ``out_dir`` (created if missing); returns the paths.

    The speed plots need the dynamic runs (skipped if ``dyn_mj`` or ``dyn_ref`` is None); the
    slider plots a slider block, the feed a thread elongation, the contour a spatial thread,
    the phase study a geared crank. ``kin_ref`` is best the reference at MuJoCo's own crank
    state (:func:`mjlink.compare.reference_at`): the residual panels subtract it."""
    paths = []
    if dyn_mj is not None and dyn_ref is not None:
        paths += speed_plots(mech, dyn_mj, dyn_ref, out_dir, rk4)
    return paths + kinematic_plots(mech, kin_mj, kin_ref, out_dir)
