"""PNG figures comparing MuJoCo runs with the vector-method reference, as in the papers.

Take-up (seed 000): crank speed and acceleration against time and against crank angle (its
Figs. 3 and 4), the mechanism drawn in many crank positions with the paths of its points
(Fig. 1b; seed 004 Fig. 4), the thread length and the kinematics of one point. Crank-slider
(seed 002, Figs. 3-5): the slider's position, velocity and acceleration along its guide, the
harmonic content of its acceleration and its pressure angle against the synthesis limit.
Take-up with eyelets (seed 003): the needle-thread feed and the spatial thread contour in
front and top view (Fig. 2). Warp knitting (seed 004): the needle path for several settings
of the geared crank (Fig. 3) and the rotation of the swinging cylinder (Fig. 4a-b).
:func:`all_plots` draws those that apply to a mechanism.

Drawing only: the quantities shown are a trace's samples, reference positions
(:func:`mjlink.reference.solve`) or derived in :mod:`mjlink.analysis`. Inputs are
:class:`mjlink.runs.Trace` objects in SI units; the plots show mm, um, deg, rpm, m/s, m/s^2,
rad/s and rad/s^2 as labelled. The shared look and the atomic writer are :mod:`.style`'s.
"""

from __future__ import annotations

import math
from itertools import pairwise
from pathlib import Path

import matplotlib
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.collections import LineCollection
from matplotlib.lines import Line2D
from matplotlib.patches import Polygon, Rectangle

from .. import analysis, compare, palette, reference
from ..errors import AssemblyError
from ..model import blocks
from ..model.mechanism import Crank, Mechanism
from ..runs import Trace
from ..units import to_mm, to_rpm, to_um
from .style import (
    MJ_LABEL,
    MJ_STYLE,
    REF_LABEL,
    REF_STYLE,
    RK4_STYLE,
    angle_ticks,
    crank_axis,
    crank_x,
    darker,
    direction,
    figure,
    finish_x,
    pair,
    place,
    residual,
    save,
    subplots,
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
            ax_n.set_ylabel("crank speed $|n_1|$ [rpm]")
            ax_e.set_ylabel("crank acceleration $\\varepsilon_1$ [rad/s$^2$]")
            for ax in (ax_n, ax_e):
                ax.grid(True, alpha=0.3)
        # A start transient (a run-up in milliseconds, a jump of the load at t = 0) dwarfs
        # what follows: kept out of the autoscale, its extreme named on the panel.
        x0 = float(xm[0])
        start = x0 + TRANSIENT_SHARE * (float(xm[-1]) - x0)
        span = f"{1e3 * (start - x0):.3g} ms" if by_time else f"{start - x0:.3g}° of crank angle"
        early = np.asarray(xm) < start
        for ax, y, what in (
            (a_n, nm, f"run-up from {float(np.min(nm[early])):.4g} rpm in the first {span} off scale"),
            (a_e, np.asarray(dyn_mj.eps), ""),
        ):
            lim = _robust_limits(np.asarray(xm), y, start)
            if lim is None:
                continue
            ax.set_ylim(*lim)
            e_abs = float(np.max(np.abs(y[early])))
            ax.text(
                0.01,
                0.04,
                what or f"start transient off scale: |ε₁| up to {e_abs:.3g} rad/s² in the first {span}",
                transform=ax.transAxes,
                fontsize=7.5,
                color="0.25",
                zorder=6,
                bbox=dict(boxstyle="round,pad=0.15", fc="white", ec="0.7", alpha=0.9),
            )
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
        residual(a_r, xm, dyn_mj.omega - dyn_ref.omega, "rad/s", limit, what="MuJoCo − reference\n$\\omega_1$")
        a_r.set_xlabel(xlabel)
        if rk4 is not None and xk is not None:
            tight = np.interp(rk4.t[:k], dyn_ref.time, dyn_ref.omega)
            diff = np.abs(to_rpm(rk4.omega[:k])) - np.abs(to_rpm(tight))
            a_k.plot(xk, diff, **dict(RK4_STYLE, ls="-"))
            a_k.axhline(0.0, color="0.5", lw=0.6)
            rel = float(np.max(np.abs(diff)) / np.max(np.abs(to_rpm(tight))))
            a_k.set_ylabel("paper's RK4 − reference\n$|n_1|$ [rpm]", fontsize=8.5)
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
        a_n.legend(loc="lower right", fontsize=8)
        d = mech.dynamics
        motor = getattr(d, "motor", None)
        drive = (
            f"motor $M_1$ = {motor.stall_torque:g} N·m × (1 − ω / {motor.no_load_speed:g} rad/s)"
            if motor is not None
            else f"$M_1$ = {d.moment:g} N·m"
        )
        fig.suptitle(
            title(
                mech,
                f"run-up, crank turning {sense} (speeds as magnitudes), {drive}, "
                f"b = {d.damping:g} N·m·s, $\\omega_0$ = {d.omega0:g} rad/s",
            ),
            fontsize=10,
        )
        paths.append(save(fig, out_dir, name))
    return paths


# ----------------------------------------------------------------------------- positions (Fig. 1b)
def _segments(mech: Mechanism) -> list[tuple[str, str]]:
    """Point pairs to draw, one polyline per link, following how each point was built.

    Joining a point to the link point it was constructed from shows the link's real shape
    (e.g. a lever's arm from its joint, not a chord from its first point); points built
    from nothing on their own link hang off the link's first point.
    """
    built = {s.point: s for s in mech.steps}
    pairs: list[tuple[str, str]] = []
    for link in mech.links:
        pts = [p for p in link.points if p != link.com]
        if link.guide:
            # A slider body: its points in listed order; there is no pivot to radiate from.
            pairs += list(pairwise(pts))
            continue
        for p in pts[1:]:
            cand = built[p].drawn_from if p in built else ()
            parent = next((c for c in cand if c in pts and c != p), pts[0])
            pairs.append((parent, p))
    return pairs


def _angle_ticks(ax, mech: Mechanism, phi: np.ndarray, xy: np.ndarray, size: float, label_every: int) -> list:
    """Short ticks across the path ``xy`` (mm, sampled at the input angles ``phi`` over one
    period from phi0) every 30 deg of crank angle turned; returns the ticks to be labelled
    every ``label_every`` deg (0: none) as (text, point, normal) for :func:`_label_ticks`."""
    turned = np.degrees(np.abs(np.asarray(phi) - phi[0]))
    out = []
    for d in range(0, round(math.degrees(mech.period)), 30):
        i = int(np.argmin(np.abs(turned - d)))
        j0, j1 = max(i - 1, 0), min(i + 1, len(xy) - 1)
        t = xy[j1] - xy[j0]
        nrm = np.array([-t[1], t[0]]) / (np.hypot(*t) or 1.0)
        big = bool(label_every) and d % label_every == 0
        h = (0.55 if big else 0.35) * size
        ax.plot(*np.stack([xy[i] - h * nrm, xy[i] + h * nrm]).T, color="k", lw=1.1 if big else 0.8, zorder=4.5)
        if big:
            out.append((f"{d}°", xy[i], nrm))
    return out


def _label_ticks(ax, ticks: list) -> None:
    """Name the ticks of :func:`_angle_ticks` beside the path, on the side away from it; a
    name that would cover one already written (where the path crosses itself, or its second
    turn runs beside the first) is left out: the tick stays."""
    r = ax.figure.canvas.get_renderer()
    taken = [t.get_window_extent(r) for t in ax.texts if t.get_text().strip()]
    for text, xy, nrm in ticks:
        for sgn in (1.0, -1.0):
            lab = ax.annotate(
                text,
                xy,
                xytext=tuple(13 * sgn * nrm),
                textcoords="offset points",
                ha="center",
                va="center",
                fontsize=7,
                color="0.2",
                zorder=7,
                bbox=dict(boxstyle="round,pad=0.05", fc="white", ec="none", alpha=0.7),
            )
            lab.set_in_layout(False)
            box = lab.get_window_extent(r)
            if not any(box.overlaps(b) for b in taken):
                taken.append(box)
                break
            lab.remove()


def _rotation_arrow(ax, mech: Mechanism, size: float) -> None:
    """A curved arrow around the input crank's pivot in the sense the crank turns, named n1."""
    crank = mech.input_crank
    c = to_mm(mech.ground[crank.pivot][:2])
    r = max(2.2 * size, 0.6 * to_mm(crank.length))
    ccw = mech.speed >= 0
    a0, a1 = (200.0, 320.0) if ccw else (320.0, 200.0)
    p0 = c + r * np.array([math.cos(math.radians(a0)), math.sin(math.radians(a0))])
    p1 = c + r * np.array([math.cos(math.radians(a1)), math.sin(math.radians(a1))])
    ax.annotate(
        "",
        p1,
        xytext=p0,
        arrowprops=dict(
            arrowstyle="-|>", color="k", lw=1.4, connectionstyle=f"arc3,rad={0.45 if ccw else -0.45}", mutation_scale=12
        ),
        zorder=6,
    )
    t = ax.annotate(
        f"$n_1$, {direction(mech.speed)}",
        c + np.array([0.0, -1.35 * r]),
        ha="center",
        va="top",
        fontsize=8,
        zorder=7,
        bbox=dict(boxstyle="round,pad=0.1", fc="white", ec="none", alpha=0.8),
    )
    t.set_in_layout(False)


def _place_labels(ax, mech, names, xy0, pairs, P, size, coms, pivots) -> None:
    """Name every point next to it, in free space: the direction away from the drawing around
    it first (other points, link midpoints, ground symbols, weighted by closeness), then the
    other directions and farther out, until its box meets no label or tick text already on the
    axes (a leader line joins a label set farther out to its point)."""
    fig = ax.figure
    r = fig.canvas.get_renderer()
    mids = [0.5 * (P[a][0, :2] + P[b][0, :2]) for a, b in pairs]
    feet = [to_mm(xyz[:2]) - (0.0, 0.7 * size) for g, xyz in mech.ground.items() if g in pivots]
    crowd = np.concatenate([xy0] + [np.array(v).reshape(-1, 2) for v in (mids, feet) if v])
    taken = [t.get_window_extent(r) for t in ax.texts if t.get_text().strip()]
    # Points in pixels: a label must not sit on another point's marker either.
    marks = ax.transData.transform(xy0)
    order = sorted(range(len(names)), key=lambda i: names[i] in coms)  # joints first, centres of mass after
    for i in order:
        p = names[i]
        d = xy0[i] - crowd
        r2 = np.einsum("ij,ij->i", d, d)
        near = r2 > 1e-12
        push = (d[near] / r2[near, None] ** 1.5).sum(axis=0)
        base = math.atan2(push[1], push[0]) if np.hypot(*push) > 0 else math.pi / 4
        placed = None
        for dist in (11.0, 17.0, 25.0, 34.0):
            for k in (0, 1, -1, 2, -2, 3, -3, 4):
                a = base + k * math.pi / 4
                t = ax.annotate(
                    p,
                    xy0[i],
                    xytext=(dist * math.cos(a), dist * math.sin(a)),
                    textcoords="offset points",
                    ha="center",
                    va="center",
                    zorder=7,
                    fontsize=7.5 if p in coms else 9,
                    color="0.3" if p in coms else "k",
                    fontweight="normal" if p in coms else "bold",
                    bbox=dict(boxstyle="round,pad=0.1", fc="white", ec="none", alpha=0.7),
                    arrowprops=dict(arrowstyle="-", color="0.5", lw=0.6, shrinkA=0, shrinkB=3) if dist > 11 else None,
                )
                t.set_in_layout(False)
                box = t.get_window_extent(r)
                hits_mark = any(box.contains(*m) for j, m in enumerate(marks) if j != i and names[j] not in coms)
                if not any(box.overlaps(b) for b in taken) and not hits_mark:
                    placed = box
                    break
                t.remove()
            if placed is not None:
                break
        if placed is None:  # nowhere free: the first choice, overlapping, beats no name at all
            t = ax.annotate(
                p,
                xy0[i],
                xytext=(11 * math.cos(base), 11 * math.sin(base)),
                textcoords="offset points",
                ha="center",
                va="center",
                zorder=7,
                fontsize=7.5 if p in coms else 9,
            )
            placed = t.get_window_extent(r)
        taken.append(placed)


def positions_plot(mech: Mechanism, out_dir, n: int = 24, highlight: str | None = None) -> Path:
    """``positions.png``: the mechanism in ``n`` equally spaced crank positions over one period.

    Links thin and grey, the initial position (phi0) bold in colour, ground pivots as
    hatched triangles, thread guides as open squares, the closed path of every moving
    thread point (721 angles) bold and the thread at phi0 in orange. ``highlight`` names one
    more point whose path is drawn bold; the paths of all other moving points that are not
    merely centres of mass are drawn thin in their link's colour. Axes in mm, equal aspect.
    """
    pairs = _segments(mech)
    phi = mech.phi0 + mech.period * np.arange(n) / n
    kin = reference.solve(mech, phi)
    P = {k: to_mm(kin.position(k)) for k in mech.point_names}
    path_kin = reference.solve(mech, mech.phi0 + np.linspace(0.0, mech.period, 721))
    traced = [p for p in (mech.thread or ()) if p not in mech.ground]
    if highlight and highlight not in traced:
        traced.append(highlight)
    coms = analysis.mass_centres(mech)
    others = [p for p in mech.moving_points if p not in coms and p not in traced]
    paths = {p: to_mm(path_kin.position(p)[:, :2]) for p in [*traced, *others]}

    # Extent first: the figure is shaped to the drawing (the legend sits to its right) and
    # the ground symbols are sized from it.
    allxy = np.concatenate([np.concatenate([P[p][:, :2] for p in P]), *paths.values()])
    lo, hi = allxy.min(axis=0), allxy.max(axis=0)
    size = 0.035 * float(max(hi - lo))
    pad = 0.08 * float(max(hi - lo))
    aspect = (hi[1] - lo[1] + 2 * pad + size) / (hi[0] - lo[0] + 2 * pad)
    box_w, box_h = (6.4, max(2.6, 6.4 * aspect)) if aspect < 1.0 else (max(3.2, 6.4 / aspect), 6.4)
    key = highlight or (traced[0] if traced else None)
    key_xy = paths[key] if key else None
    # A key path much smaller than the drawing (warp knitting's needle: 10 x 26 mm in 300 mm)
    # would be a squiggle under the ghost positions: it gets an enlarged panel of its own.
    enlarge = key_xy is not None and float(np.max(np.ptp(key_xy, axis=0))) < 0.25 * float(max(hi - lo))
    fig = figure(figsize=(max(7.6, box_w + 3.4), max(box_h + 1.3, 7.4 if enlarge else 0.0)), layout="constrained")
    gs = fig.add_gridspec(2, 2, width_ratios=(box_w, 3.2), height_ratios=(1.0, 1.0))
    ax = fig.add_subplot(gs[:, 0])
    side = fig.add_subplot(gs[1, 1]) if enlarge else None
    # All ghost positions in one collection: one draw call instead of n * links.
    ghost = [np.stack([P[a][i, :2], P[b][i, :2]]) for i in range(1, n) for a, b in pairs]
    ax.add_collection(LineCollection(ghost, colors="0.6", linewidths=0.7, alpha=0.6, zorder=1))

    # Every other moving point's closed path, thin, in the colour of its link (of the one
    # pivoted on the ground if it is on several: a crank pin's circle is the crank's).
    colors = matplotlib.color_sequences["tab10"]
    for p in others:
        carriers = [k for k, l in enumerate(mech.links) if p in l.points]
        k = next((k for k in carriers if any(g in mech.ground for g in mech.links[k].points)), carriers[0])
        ax.plot(paths[p][:, 0], paths[p][:, 1], color=colors[k % 10], lw=0.9, alpha=0.85, zorder=1.5)
    if others:
        ax.plot([], [], color="0.3", lw=0.9, label="paths of the other points\n(in their link's colour)")
    for k, p in enumerate(traced):
        ax.plot(
            paths[p][:, 0],
            paths[p][:, 1],
            color=("#c51b7d", "#00a0a0", "#8c6d00")[k % 3],
            lw=1.8,
            zorder=2,
            label=f"path of {p}",
        )
    # Ghost positions of the traced points, so the crank-angle spacing along the path shows.
    for p in traced:
        ax.plot(P[p][1:, 0], P[p][1:, 1], "o", ms=2.5, color="0.4", zorder=2)

    if mech.thread:
        th = np.stack([P[p][0, :2] for p in mech.thread])
        ax.plot(
            th[:, 0],
            th[:, 1],
            color="orange",
            lw=2.0,
            zorder=3,
            label="thread at $\\varphi_0$ (" + "–".join(mech.thread) + ")",
        )

    for k, link in enumerate(mech.links):
        segs = [np.stack([P[a][0, :2], P[b][0, :2]]) for a, b in pairs if a in link.points and b in link.points]
        c = colors[k % 10]
        ax.add_collection(LineCollection(segs, colors=[c], linewidths=3.0, zorder=4, capstyle="round"))
        ax.plot([], [], color=c, lw=3.0, label=link.name)  # legend proxy for the collection
        pts = [p for p in link.points if p not in mech.ground and p != link.com]
        ax.plot([P[p][0, 0] for p in pts], [P[p][0, 1] for p in pts], "o", ms=5, mfc="white", mec=c, mew=1.5, zorder=5)
        if link.com is not None:
            s = P[link.com][0]
            ax.plot(s[0], s[1], marker="$\\oplus$", ms=8, color=c, zorder=5, ls="none")

    pivots = {p for l in mech.links for p in l.points if p in mech.ground}
    for g, xyz in mech.ground.items():
        x, y = to_mm(xyz[0]), to_mm(xyz[1])
        if g in pivots:
            tri = [(x, y), (x - 0.6 * size, y - size), (x + 0.6 * size, y - size)]
            ax.add_patch(Polygon(tri, closed=True, fc="white", ec="k", lw=1.0, zorder=3.5))
            ax.add_patch(
                Rectangle(
                    (x - 0.9 * size, y - 1.35 * size),
                    1.8 * size,
                    0.35 * size,
                    fc="none",
                    ec="none",
                    hatch="////",
                    zorder=3.4,
                )
            )
            ax.plot([x - 0.9 * size, x + 0.9 * size], [y - size] * 2, color="k", lw=1.0, zorder=3.5)
            ax.plot(x, y, "o", ms=4.5, mfc="white", mec="k", zorder=6)
        else:
            ax.plot(x, y, "s", ms=7, mfc="white", mec="k", mew=1.2, zorder=6)

    main_ticks: list = []
    if key is not None and key_xy is not None and not enlarge:
        main_ticks = _angle_ticks(ax, mech, path_kin.phi, key_xy, size, label_every=90)
    elif key_xy is not None:
        # Where the enlarged path is on the drawing.
        (x0, y0), (x1, y1) = key_xy.min(axis=0) - size, key_xy.max(axis=0) + size
        ax.add_patch(Rectangle((x0, y0), x1 - x0, y1 - y0, fc="none", ec="0.3", lw=0.8, ls="--", zorder=4))
    _rotation_arrow(ax, mech, size)
    ax.set_xlim(lo[0] - pad, hi[0] + pad)
    ax.set_ylim(lo[1] - pad - size, hi[1] + pad)
    ax.set_aspect("equal", adjustable="box", anchor="NW")  # blank space to the right: cropped on saving
    ax.grid(True, alpha=0.25)
    ax.set_xlabel("x [mm]")
    ax.set_ylabel("y [mm]")
    ax.plot([], [], color="0.55", lw=0.7, label=f"{n} crank positions")
    ax.plot(
        [],
        [],
        "|",
        color="k",
        ms=7,
        label="crank angle every 30° along the path\n(from $\\varphi_0$, labelled every 90°)",
    )
    fig.legend(
        *ax.get_legend_handles_labels(),
        loc="upper left",
        bbox_to_anchor=(0.0, 1.0),
        bbox_transform=fig.add_subplot(gs[0, 1]).transAxes,
        borderaxespad=0.0,
        fontsize=8,
        framealpha=0.9,
    )
    fig.axes[-1].axis("off")
    if side is not None and key is not None and key_xy is not None:
        xy = key_xy
        side.plot(xy[:, 0], xy[:, 1], color="#c51b7d", lw=1.8)
        span = float(np.max(np.ptp(xy, axis=0)))
        side_ticks = _angle_ticks(side, mech, path_kin.phi, xy, 0.06 * span, label_every=30 if mech.period < 7 else 60)
        side.set_aspect("equal", adjustable="datalim")
        side.margins(0.18)
        side.grid(True, alpha=0.3)
        side.set_xlabel("x [mm]", fontsize=8.5)
        side.set_ylabel("y [mm]", fontsize=8.5)
        side.tick_params(labelsize=8)
        side.set_title(
            f"path of {key} enlarged: Δx {np.ptp(xy[:, 0]):.2f} mm, Δy {np.ptp(xy[:, 1]):.2f} mm\n"
            f"ticks every 30° of crank angle from $\\varphi_0$, {direction(mech.speed)}",
            fontsize=8.5,
        )
    # Left-aligned: a tall drawing's axes are narrower than the title, which runs on over the legend.
    ax.set_title(
        title(mech, f"{n} positions over one period, bold: $\\varphi_0$ = {math.degrees(mech.phi0):g}°"),
        fontsize=10,
        loc="left",
    )
    # Labels last, once the layout has fixed where everything is on the canvas; the layout is
    # then kept as it is (the labels were placed for it), so that saving does not run the
    # constrained layout engine again at its bounding-box pass and at its drawing.
    fig.draw_without_rendering()
    fig.set_layout_engine("none")
    _label_ticks(ax, main_ticks)
    if side is not None:
        _label_ticks(side, side_ticks)
    names = list(mech.point_names)
    _place_labels(ax, mech, names, np.array([P[p][0, :2] for p in names]), pairs, P, size, coms, pivots)
    return save(fig, out_dir, "positions.png", tight=True)


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
            "m/s$^2$",
            "acceleration",
            lim.acceleration,
            1.0,
            "m/s$^2$",
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
            ("position $s$ along the guide [mm]", to_mm, "tab:blue"),
            ("velocity $ds/dt$ [m/s]", None, "tab:purple"),
            ("acceleration $d^2s/dt^2$ [m/s$^2$]", None, "tab:red"),
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
            place(fig, ax.get_gridspec(), left=1.0, right=0.25, top=0.75, bottom=0.6)  # one draw
            k = np.arange(1, len(ar) + 1)
            ax.bar(k - 0.2, am, width=0.4, color="tab:red", alpha=0.75, label=MJ_LABEL)
            ax.bar(k + 0.2, ar, width=0.4, color="white", edgecolor="k", hatch="////", lw=0.8, label=REF_LABEL)
            ax.set_yscale("log")
            ax.set_xticks(k)
            if turns > 1:
                ax.set_xlabel(
                    f"harmonic k of the mechanism period ({turns} turns of the input crank = "
                    f"{math.degrees(mech.period):g}°; k = {turns}: once per turn)"
                )
            else:
                ax.set_xlabel("harmonic k of the crank rotation (order)")
            ax.set_ylabel(f"amplitude of $d^2s/dt^2$ of {p} [m/s$^2$]")
            ax.grid(True, which="major", axis="y", alpha=0.3)
            ks = f"2..{len(ar)}"
            txt = (
                f"higher harmonics k = {ks} relative to the first, "
                f"$\\sqrt{{\\Sigma A_k^2}}\\,/\\,A_1$:\n"
                f"MuJoCo {100 * analysis.higher_harmonics_share(am):.1f} %, "
                f"reference {100 * analysis.higher_harmonics_share(ar):.1f} %\n"
                f"$A_2/A_1$ = {100 * ar[1] / ar[0]:.1f} %,  $A_1$ = {ar[0]:.4g} m/s$^2$ (reference)"
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
            ax.axhline(lim, color="tab:red", lw=1.5, label=f"allowed [$\\theta$] = {lim:g}°")
            ax.text(xr[0], lim, " [$\\theta$]", color="tab:red", va="bottom", fontsize=9)
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
        what="MuJoCo − ref., $P_d$",
    )
    pair(axs[0], xm, to_mm(Lm), xr, to_mm(Lr), "tab:orange")
    axs[0].set_ylabel(f"thread length $l_F$ [mm]\n{'–'.join(mech.thread)}")
    pair(axs[1], xm, to_mm(dm), xr, to_mm(dr), "tab:orange")
    axs[1].set_ylabel("$\\Delta l_F = l_F(\\varphi) - l_F(\\varphi_0)$ [mm]")
    pair(axs[2], xm, to_mm(fm), xr, to_mm(fr), "tab:red")
    axs[2].axhline(0.0, color="k", lw=0.9, zorder=0)
    axs[2].set_ylabel(f"feed $P_d = \\Delta l_F - \\Delta P$ [mm]\n($\\Delta P$ = {to_mm(dp):g} mm)")
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
            f"needle-thread feed over one turn: $P_d$ from {pd.min():+.2f} "
            f"to {pd.max():+.2f} mm (swing {np.ptp(pd):.2f} mm)",
        ),
        fontsize=10,
    )
    return save(fig, out_dir, "thread_feed.png")


# ----------------------------------------------------------------------------- 3D contour (seed 003 Fig. 2)
def contour_plot(mech: Mechanism, out_dir, n: int = 6) -> Path | None:
    """``thread_contour.png``: the mechanism and the needle-thread contour in ``n`` crank
    positions over one period (seed 003, Fig. 2): front view (x-y) and, beside it, top view
    (x-z, seen from +y, so +z points down the page), equal aspect, mm; one colour per
    position, the thread thick and the links thin, the guides as squares, the eyelets named
    at phi0. None unless the thread is spatial (some point off z = 0)."""
    if not mech.thread or not analysis.is_spatial(mech):
        return None
    pairs = _segments(mech)
    phi = mech.phi0 + math.copysign(mech.period, mech.speed) * np.arange(n) / n
    kin = reference.solve(mech, phi)
    P = {k: to_mm(kin.position(k)) for k in mech.point_names}
    path = reference.solve(mech, mech.phi0 + np.linspace(0.0, mech.period, 361))
    eyelets = [p for p in mech.thread if p not in mech.ground]
    guides = [p for p in mech.thread if p in mech.ground]
    pivots = [p for p in mech.ground if p not in guides and any(p in l.points for l in mech.links)]
    cmap = plt.get_cmap("viridis")
    cols = [cmap(0.78 * i / max(n - 1, 1)) for i in range(n)]

    allp = np.concatenate([P[p] for p in P] + [to_mm(path.position(e)) for e in eyelets])
    lo, hi = allp.min(axis=0), allp.max(axis=0)
    pad = 0.07 * float(max(hi - lo))
    fig = figure(figsize=(13.0, 6.8))
    gs = fig.add_gridspec(2, 2, width_ratios=(1.0, 1.0), height_ratios=(0.42, 0.58))
    # Fixed margins (one draw, then the crop): the suptitle and the panels' titles above, the
    # top view's x label and y label between the panels; equal axes shrink inside their cells.
    place(fig, gs, left=0.85, right=0.2, top=0.95, bottom=0.6, hgap=0.75, wgap=0.95)
    af = fig.add_subplot(gs[:, 0])
    at = fig.add_subplot(gs[0, 1], sharex=af)
    al = fig.add_subplot(gs[1, 1])
    al.axis("off")
    for ax, j in ((af, 1), (at, 2)):
        for e in eyelets:
            q = to_mm(path.position(e))
            ax.plot(q[:, 0], q[:, j], color="0.7", lw=0.8, zorder=1)
        for i in reversed(range(n)):  # phi0 last, on top
            c, first = cols[i], i == 0
            segs = [np.stack([P[a][i, [0, j]], P[b][i, [0, j]]]) for a, b in pairs]
            ax.add_collection(
                LineCollection(
                    segs, colors=[c], linewidths=1.6 if first else 0.8, alpha=0.9 if first else 0.45, zorder=2 + first
                )
            )
            th = np.stack([P[p][i, [0, j]] for p in mech.thread])
            ax.plot(
                th[:, 0],
                th[:, 1],
                color=c,
                lw=2.6 if first else 1.5,
                zorder=4 + first,
                marker="o",
                ms=4 if first else 3,
                mfc="white",
                mec=c,
                label=f"$\\varphi_1$ = {math.degrees(phi[i]):g}°" + (" ($\\varphi_0$)" if first else ""),
            )
        for g in guides:
            ax.plot(P[g][0, 0], P[g][0, j], "s", ms=8, mfc="white", mec="k", mew=1.3, zorder=7)
            ax.annotate(
                g,
                (P[g][0, 0], P[g][0, j]),
                xytext=(8, 0),
                textcoords="offset points",
                ha="left",
                va="center",
                fontsize=9,
                fontweight="bold",
            )
        for g in pivots:
            ax.plot(P[g][0, 0], P[g][0, j], "^", ms=8, mfc="white", mec="k", zorder=7)
            ax.annotate(
                g,
                (P[g][0, 0], P[g][0, j]),
                xytext=(0, -9),
                textcoords="offset points",
                ha="center",
                va="top",
                fontsize=8,
            )
        for e in eyelets:
            ax.annotate(
                e,
                (P[e][0, 0], P[e][0, j]),
                xytext=(7, 5),
                textcoords="offset points",
                fontsize=9,
                fontweight="bold",
                color=darker(cols[0]),
                zorder=8,
                bbox=dict(boxstyle="round,pad=0.1", fc="white", ec="none", alpha=0.75),
            )
        ax.grid(True, alpha=0.25)
        ax.set_xlabel("x [mm]")
    af.set_xlim(lo[0] - pad, hi[0] + pad + 0.04 * float(hi[0] - lo[0]))  # room for guide names
    af.set_ylim(lo[1] - pad, hi[1] + pad)
    at.set_ylim(hi[2] + pad, lo[2] - pad)  # seen from +y with x to the right, +z points down
    for ax in (af, at):
        ax.set_aspect("equal", adjustable="box", anchor="N")
    af.set_ylabel("y [mm]")
    at.set_ylabel("z [mm]")
    af.set_title("front view (x–y)", fontsize=10)
    at.set_title("top view (x–z), seen from +y", fontsize=10)
    handles, labels = af.get_legend_handles_labels()
    handles, labels = handles[::-1], labels[::-1]  # drawn last to first: list from phi0
    handles.append(Line2D([], [], color="0.7", lw=0.8))
    labels.append("eyelet paths over one turn")
    al.legend(
        handles,
        labels,
        loc="upper center",
        ncol=2,
        fontsize=9,
        frameon=False,
        title=f"crank positions: thread {'–'.join(mech.thread)} thick, links thin",
        title_fontsize=9,
    )
    fig.suptitle(title(mech, f"needle-thread contour in {n} crank positions"), fontsize=10)
    return save(fig, out_dir, "thread_contour.png", tight=True)


# ----------------------------------------------------------------------------- geared cranks (seed 004 Fig. 3)
def _link_number(mech: Mechanism, crank: Crank) -> int:
    """1-based index of the link carrying ``crank`` (the papers number links so: phi04 is link 4's)."""
    return 1 + [l.name for l in mech.links].index(crank.carriers(mech.links)[0])


def phase_study_plot(
    mech: Mechanism, out_dir, point: str | None = None, offsets_deg=(-90, -60, -30, 0, 30, 60, 90)
) -> Path | None:
    """``phase_study.png``: the path of ``point`` (default :func:`mjlink.analysis.key_point`)
    over one period for several mutual settings of the cranks: the geared crank's phase is its
    file's phase plus each offset (seed 004, Fig. 3). Settings that cannot assemble are
    listed, not drawn. None without a geared crank (see :func:`mjlink.analysis.geared_crank`)."""
    crank = analysis.geared_crank(mech)
    if crank is None:
        return None
    point = point or analysis.key_point(mech)
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
        lab = f"$\\varphi_{{0{i_in}}}$ = {math.degrees(mech.phi0):g}°, $\\varphi_{{0{i_g}}}$ = {math.degrees(ph):g}°"
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
    ax.plot([], [], "o", color="0.4", ms=5, label="position at $\\varphi_{01}$")
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
            f"angular velocity $\\omega$ of {link} [rad/s]",
            "tab:blue",
            "rad/s",
        ),
        (
            axs[2],
            axs[3],
            kin_mj.link_eps,
            kin_ref.link_eps,
            f"angular acceleration $\\varepsilon$ of {link} [rad/s$^2$]",
            "tab:red",
            "rad/s$^2$",
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
