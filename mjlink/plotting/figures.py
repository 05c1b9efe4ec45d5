"""PNG plots comparing MuJoCo runs with the vector-method reference.

The figures follow the papers. Take-up (seed 000): crank speed and acceleration against time
and against crank angle (its Figs. 3 and 4), the mechanism drawn in many crank positions with
the paths of its points (Fig. 1b; seed 004 Fig. 4), the thread length and the kinematics of
one point. Crank-slider (seed 002, Figs. 3-5): the slider's position, velocity and
acceleration along its guide, the harmonic content of its acceleration and its pressure
angle against the synthesis limit. Take-up with eyelets (seed 003): the needle-thread feed
and the spatial thread contour in front and top view (Fig. 2). Warp knitting (seed 004):
the needle path for several settings of the geared crank (Fig. 3) and the rotation of the
swinging cylinder (Fig. 4a-b). :func:`all_plots` draws those that apply to a mechanism.

Inputs are :class:`mjlink.simulate.Trace` objects in SI units; the plots show mm, um, deg,
rpm, m/s, m/s^2, rad/s and rad/s^2 as labelled. Crank angles are degrees, unwrapped from the
traces; a crank turning clockwise is plotted against the angle turned from phi0 (the axis
label says so), so every angle axis runs left to right with time.

Everywhere MuJoCo is a solid line and the reference a dashed line drawn on top of it, so both
stay visible where they coincide (which is the expected case). Every file is written to a
temporary name in its folder and then renamed, so a reader never sees a half-written PNG.
"""

from __future__ import annotations

import dataclasses
import math
import os
import secrets
from pathlib import Path

import matplotlib

# Headless: the CLI and tests run without a display; select before pyplot is imported.
matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.collections import LineCollection  # noqa: E402
from matplotlib.lines import Line2D  # noqa: E402
from matplotlib.patches import Polygon, Rectangle  # noqa: E402

from .. import reference  # noqa: E402
from ..errors import AssemblyError, OutputError  # noqa: E402
from ..model.mechanism import Attached, Crank, Dyad, Mechanism, Slider  # noqa: E402
from ..runs import Trace  # noqa: E402

DPI = 120
RPM = 30.0 / math.pi  # (rev/min) per (rad/s)
MM = 1e3  # mm per m
UM = 1e6  # um per m

MJ_STYLE = dict(lw=2.2, alpha=0.75, solid_capstyle="butt")
REF_STYLE = dict(lw=1.1, ls=(0, (4, 3)), color="k")
RK4_STYLE = dict(lw=1.0, ls=":", color="tab:red")

MJ_LABEL = "MuJoCo"
REF_LABEL = "reference (vector method)"


# ----------------------------------------------------------------------------- helpers
def _save(fig, out_dir: Path | str, name: str, tight: bool = False) -> Path:
    """Write ``fig`` as ``out_dir/name`` atomically, close it, return the path.

    ``tight``: crop (or grow) the canvas to what is drawn, for equal-aspect drawings whose
    axes box the layout engine cannot size exactly."""
    out = Path(out_dir)
    path = out / name
    tmp = None
    try:
        out.mkdir(parents=True, exist_ok=True)
        # Not mkstemp: its 0600 mode would survive the rename; 'x' honours the umask instead.
        part = out / f".{name}.{os.getpid()}.{secrets.token_hex(4)}.tmp"
        with open(part, "xb") as f:
            tmp = part  # ours from here on: remove it if anything below fails
            fig.savefig(f, format="png", dpi=DPI, **(dict(bbox_inches="tight", pad_inches=0.12) if tight else {}))
        os.replace(tmp, path)
        tmp = None
    except OSError as e:
        raise OutputError(f"{path}: cannot write plot: {e}") from None
    finally:
        plt.close(fig)
        if tmp is not None:
            try:
                os.unlink(tmp)
            except OSError:
                pass
    return path


def _deg(phi) -> np.ndarray:
    return np.degrees(np.asarray(phi, dtype=float))


def _title(mech: Mechanism, what: str) -> str:
    return f"{mech.name}: {what}\n{mech.title}"


def _angle_ticks(ax, lo: float, hi: float) -> None:
    """Crank-angle ticks on round fractions or multiples of a turn, so cycles read at a glance."""
    span = hi - lo
    step = next((s for s in (30, 45, 90, 180, 360, 720, 1800, 3600, 7200, 18000) if span / s <= 9), 36000)
    ax.set_xticks(np.arange(math.ceil(lo / step) * step, hi + 1e-9, step))
    ax.set_xlim(lo, hi)


def _pair(ax, x_mj, y_mj, x_ref, y_ref, color: str, what: str = "") -> None:
    """MuJoCo solid (wide, translucent) with the reference dashed on top in a darker tone."""
    sep = " " if what else ""
    ax.plot(x_mj, y_mj, color=color, label=f"{what}{sep}{MJ_LABEL}", **MJ_STYLE)
    style = dict(REF_STYLE)
    if what:
        # Several quantities share the panel: keep the hue so each dashed line finds its twin.
        style["color"] = _darker(color)
    ax.plot(x_ref, y_ref, label=f"{what}{sep}reference", **style)


def _darker(color: str) -> tuple:
    r, g, b = matplotlib.colors.to_rgb(color)
    return (0.55 * r, 0.55 * g, 0.55 * b)


def _thread_length(mech: Mechanism, trace: Trace) -> np.ndarray:
    """Thread length (m) of a trace; summed from its points if the run did not record it."""
    if trace.thread_length is not None:
        return np.asarray(trace.thread_length)
    path = mech.thread
    return sum(np.linalg.norm(trace.points[b] - trace.points[a], axis=1) for a, b in zip(path[:-1], path[1:]))


def _crank_axis(mech: Mechanism, phi) -> tuple:
    """How to plot the crank angles of a run whose input angles are ``phi`` (rad): a function
    from input angles to abscissae (deg) and the axis label that says which they are.

    A crank turning counter-clockwise is plotted against its unwrapped angle phi1. One turning
    clockwise (phi1 decreasing, as the needle-bar drives) is plotted against the angle turned
    from phi01, phi01 - phi1, so the axis still runs left to right with time from 0.
    """
    phi = np.asarray(phi)
    if phi[-1] >= phi[0]:
        return _deg, "crank angle $\\varphi_1$ [deg]"
    return (lambda p: _deg(mech.phi0 - np.asarray(p, dtype=float)),
            "crank angle turned clockwise, $\\varphi_{01} - \\varphi_1$ [deg] "
            f"($\\varphi_{{01}}$ = {math.degrees(mech.phi0):g}°)")


def _crank_x(mech: Mechanism, *traces: Trace) -> tuple[list[np.ndarray], str]:
    """Crank-angle abscissae (deg) of ``traces``, all as the first one's (see :func:`_crank_axis`),
    and the axis label."""
    f, label = _crank_axis(mech, traces[0].phi)
    return [f(t.phi) for t in traces], label


def _finish_x(ax, xs: list[np.ndarray], label: str) -> None:
    ax.set_xlabel(label)
    _angle_ticks(ax, min(float(np.min(x)) for x in xs), max(float(np.max(x)) for x in xs))


def _dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.einsum("ij,ij->i", a, b)


# ----------------------------------------------------------------------------- speed (Figs. 3, 4)
def speed_plots(mech: Mechanism, dyn_mj: Trace, dyn_ref: Trace, out_dir,
                rk4: reference.Motion | None = None) -> list[Path]:
    """The run-up of the forward-dynamics case, as the paper's Figs. 3 and 4.

    ``speed_vs_time.png``: crank speed n1 (rpm) and angular acceleration eps1 (rad/s^2)
    against time (s); ``speed_vs_angle.png``: the same against the unwrapped crank angle
    phi1 (deg). Overlays MuJoCo, the reference (tight ODE) and, if given, the paper's
    fixed-step RK4 ``rk4`` (a :class:`reference.Motion`, SI units). Returns both paths.
    """
    paths = []
    angle, angle_label = _crank_axis(mech, dyn_mj.phi)
    for name, xlabel, key in (("speed_vs_time.png", "time t [s]", "t"),
                              ("speed_vs_angle.png", angle_label + " (unwrapped)", "phi")):
        fig, (a1, a2) = plt.subplots(2, 1, figsize=(8.0, 6.6), sharex=True, layout="constrained")

        def x(tr_t, tr_phi):
            return tr_t if key == "t" else angle(tr_phi)

        xm, xr = x(dyn_mj.time, dyn_mj.phi), x(dyn_ref.time, dyn_ref.phi)
        # Dozens of speed oscillations: a narrower MuJoCo line keeps neighbouring ones apart.
        mj = dict(MJ_STYLE, lw=1.7)
        a1.plot(xm, dyn_mj.omega * RPM, color="tab:blue", label=MJ_LABEL, **mj)
        a1.plot(xr, dyn_ref.omega * RPM, label=REF_LABEL + ", DOP853 ODE", **REF_STYLE)
        a2.plot(xm, dyn_mj.eps, color="tab:blue", label=MJ_LABEL, **mj)
        a2.plot(xr, dyn_ref.eps, label=REF_LABEL + ", DOP853 ODE", **REF_STYLE)
        if rk4 is not None:
            # Only the span of the runs shown: samples beyond would stretch the y autoscale.
            k = int(np.searchsorted(rk4.t, max(dyn_mj.time[-1], dyn_ref.time[-1]) * (1 + 1e-9), "right"))
            xk = x(rk4.t[:k], rk4.phi[:k])
            lab = f"paper's RK4, {len(rk4.t) - 1} steps of {rk4.t[1] - rk4.t[0]:.3g} s"
            a1.plot(xk, rk4.omega[:k] * RPM, label=lab, **RK4_STYLE)
            a2.plot(xk, rk4.eps[:k], label=lab, **RK4_STYLE)
        a1.set_ylabel("crank speed $n_1$ [rpm]")
        a2.set_ylabel("crank acceleration $\\varepsilon_1$ [rad/s$^2$]")
        a2.set_xlabel(xlabel)
        if key == "t":
            a2.set_xlim(0.0, max(xm[-1], xr[-1]))
        else:
            _angle_ticks(a2, min(xm.min(), xr.min()), max(xm.max(), xr.max()))
            if np.ptp(xm) >= 720.0:
                # Tens of turns in degrees are hard to count: name the turns on top as well.
                top = a1.secondary_xaxis("top", functions=(lambda d: d / 360.0, lambda n: n * 360.0))
                top.set_xlabel("crank turns (angle / 360°)", fontsize=9)
        for ax in (a1, a2):
            ax.grid(True, alpha=0.3)
        # A run-up leaves the corner on the side of zero speed free: below if it turns CCW.
        a1.legend(loc="lower right" if np.mean(dyn_mj.omega) >= 0 else "upper right", fontsize=8)
        d = mech.dynamics
        motor = getattr(d, "motor", None)
        drive = (f"motor $M_1$ = {motor.stall_torque:g} N·m × (1 − ω / {motor.no_load_speed:g} rad/s)"
                 if motor is not None else f"$M_1$ = {d.moment:g} N·m")
        fig.suptitle(_title(mech, f"run-up, {drive}, b = {d.damping:g} N·m·s, "
                                  f"$\\omega_0$ = {d.omega0:g} rad/s"), fontsize=10)
        paths.append(_save(fig, out_dir, name))
    return paths


# ----------------------------------------------------------------------------- positions (Fig. 1b)
def _segments(mech: Mechanism) -> list[tuple[str, str]]:
    """Point pairs to draw, one polyline per link, following how each point was built.

    Joining a point to the link point it was constructed from shows the link's real shape
    (e.g. a lever's arm from its joint, not a chord from its first point); points built
    from nothing on their own link hang off the link's first point.
    """
    built = {s.point: s for s in mech.steps}
    pairs = []
    for link in mech.links:
        pts = [p for p in link.points if p != link.com]
        if link.guide:
            # A slider body: its points in listed order; there is no pivot to radiate from.
            pairs += list(zip(pts[:-1], pts[1:]))
            continue
        for p in pts[1:]:
            s = built.get(p)
            if isinstance(s, Crank):
                cand = (s.pivot,)
            elif isinstance(s, Dyad):
                cand = (s.a, s.b)
            elif isinstance(s, Attached):
                cand = (s.origin, s.toward)
            else:
                cand = ()
            parent = next((c for c in cand if c in pts and c != p), pts[0])
            pairs.append((parent, p))
    return pairs


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
    P = {k: kin.position(k) * MM for k in mech.point_names}
    path_kin = reference.solve(mech, mech.phi0 + np.linspace(0.0, mech.period, 721))
    traced = [p for p in (mech.thread or ()) if p not in mech.ground]
    if highlight and highlight not in traced:
        traced.append(highlight)
    coms = _mass_centres(mech)
    others = [p for p in mech.moving_points if p not in coms and p not in traced]
    paths = {p: path_kin.position(p)[:, :2] * MM for p in traced + others}

    # Extent first: the figure is shaped to the drawing (the legend sits to its right) and
    # the ground symbols are sized from it.
    allxy = np.concatenate([np.concatenate([P[p][:, :2] for p in P])] + list(paths.values()))
    lo, hi = allxy.min(axis=0), allxy.max(axis=0)
    size = 0.035 * float(max(hi - lo))
    pad = 0.08 * float(max(hi - lo))
    aspect = (hi[1] - lo[1] + 2 * pad + size) / (hi[0] - lo[0] + 2 * pad)
    box_w, box_h = (6.4, max(2.6, 6.4 * aspect)) if aspect < 1.0 else (max(3.2, 6.4 / aspect), 6.4)
    fig, ax = plt.subplots(figsize=(max(7.6, box_w + 3.4), box_h + 1.3), layout="constrained")
    # All ghost positions in one collection: one draw call instead of n * links.
    ghost = [np.stack([P[a][i, :2], P[b][i, :2]]) for i in range(1, n) for a, b in pairs]
    ax.add_collection(LineCollection(ghost, colors="0.6", linewidths=0.7, alpha=0.6, zorder=1))

    # Every other moving point's closed path, thin, in the colour of its link (of the one
    # pivoted on the ground if it is on several: a crank pin's circle is the crank's).
    colors = plt.get_cmap("tab10").colors
    for p in others:
        carriers = [k for k, l in enumerate(mech.links) if p in l.points]
        k = next((k for k in carriers if any(g in mech.ground for g in mech.links[k].points)), carriers[0])
        ax.plot(paths[p][:, 0], paths[p][:, 1], color=colors[k % 10], lw=0.9, alpha=0.85, zorder=1.5)
    if others:
        ax.plot([], [], color="0.3", lw=0.9, label="paths of the other points\n(in their link's colour)")
    for k, p in enumerate(traced):
        ax.plot(paths[p][:, 0], paths[p][:, 1], color=("#c51b7d", "#00a0a0", "#8c6d00")[k % 3], lw=1.8,
                zorder=2, label=f"path of {p}")
    # Ghost positions of the traced points, so the crank-angle spacing along the path shows.
    for p in traced:
        ax.plot(P[p][1:, 0], P[p][1:, 1], "o", ms=2.5, color="0.4", zorder=2)

    if mech.thread:
        th = np.stack([P[p][0, :2] for p in mech.thread])
        ax.plot(th[:, 0], th[:, 1], color="orange", lw=2.0, zorder=3,
                label="thread at $\\varphi_0$ (" + "–".join(mech.thread) + ")")

    for k, link in enumerate(mech.links):
        segs = [np.stack([P[a][0, :2], P[b][0, :2]]) for a, b in pairs if a in link.points and b in link.points]
        c = colors[k % 10]
        ax.add_collection(LineCollection(segs, colors=[c], linewidths=3.0, zorder=4, capstyle="round"))
        ax.plot([], [], color=c, lw=3.0, label=link.name)  # legend proxy for the collection
        pts = [p for p in link.points if p not in mech.ground and p != link.com]
        ax.plot([P[p][0, 0] for p in pts], [P[p][0, 1] for p in pts], "o", ms=5, mfc="white",
                mec=c, mew=1.5, zorder=5)
        if link.com is not None:
            s = P[link.com][0]
            ax.plot(s[0], s[1], marker="$\\oplus$", ms=8, color=c, zorder=5, ls="none")

    pivots = {p for l in mech.links for p in l.points if p in mech.ground}
    for g, xyz in mech.ground.items():
        x, y = xyz[0] * MM, xyz[1] * MM
        if g in pivots:
            tri = [(x, y), (x - 0.6 * size, y - size), (x + 0.6 * size, y - size)]
            ax.add_patch(Polygon(tri, closed=True, fc="white", ec="k", lw=1.0, zorder=3.5))
            ax.add_patch(Rectangle((x - 0.9 * size, y - 1.35 * size), 1.8 * size, 0.35 * size,
                                   fc="none", ec="none", hatch="////", zorder=3.4))
            ax.plot([x - 0.9 * size, x + 0.9 * size], [y - size] * 2, color="k", lw=1.0, zorder=3.5)
            ax.plot(x, y, "o", ms=4.5, mfc="white", mec="k", zorder=6)
        else:
            ax.plot(x, y, "s", ms=7, mfc="white", mec="k", mew=1.2, zorder=6)

    # Each label is pushed away from the drawing around its point (other points, link
    # midpoints, ground symbols), weighted by closeness, so it lands in free space.
    names = list(mech.point_names)
    xy0 = np.array([P[p][0, :2] for p in names])
    mids = [0.5 * (P[a][0, :2] + P[b][0, :2]) for a, b in pairs]
    feet = [xyz[:2] * MM - (0.0, 0.7 * size) for g, xyz in mech.ground.items() if g in pivots]
    crowd = np.concatenate([xy0] + [np.array(v).reshape(-1, 2) for v in (mids, feet) if v])
    for i, p in enumerate(names):
        d = xy0[i] - crowd
        r2 = np.einsum("ij,ij->i", d, d)
        near = r2 > 1e-12
        push = (d[near] / r2[near, None] ** 1.5).sum(axis=0)
        push = push / (np.linalg.norm(push) or 1.0)
        ax.annotate(p, xy0[i], xytext=(11 * push[0], 11 * push[1]), textcoords="offset points",
                    ha="center", va="center", zorder=7,
                    fontsize=7.5 if p in coms else 9, color="0.3" if p in coms else "k",
                    fontweight="normal" if p in coms else "bold",
                    bbox=dict(boxstyle="round,pad=0.1", fc="white", ec="none", alpha=0.7))

    ax.set_xlim(lo[0] - pad, hi[0] + pad)
    ax.set_ylim(lo[1] - pad - size, hi[1] + pad)
    ax.set_aspect("equal", adjustable="box", anchor="NW")  # blank space to the right: cropped on saving
    ax.grid(True, alpha=0.25)
    ax.set_xlabel("x [mm]")
    ax.set_ylabel("y [mm]")
    ax.plot([], [], color="0.55", lw=0.7, label=f"{n} crank positions")
    ax.legend(loc="upper left", bbox_to_anchor=(1.02, 1.0), borderaxespad=0.0, fontsize=8, framealpha=0.9)
    # Left-aligned: a tall drawing's axes are narrower than the title, which runs on over the legend.
    ax.set_title(_title(mech, f"{n} positions over one period, bold: $\\varphi_0$ = "
                              f"{math.degrees(mech.phi0):g}°"), fontsize=10, loc="left")
    return _save(fig, out_dir, "positions.png", tight=True)


# ----------------------------------------------------------------------------- thread length
def thread_plot(mech: Mechanism, kin_mj: Trace, kin_ref: Trace, out_dir) -> Path | None:
    """``thread_length.png``: thread length (mm) against crank angle (deg) over the kinematic
    run, MuJoCo vs reference, and below their difference MuJoCo - reference (um).
    None if the mechanism has no thread."""
    if not mech.thread:
        return None
    Lm, Lr = _thread_length(mech, kin_mj), _thread_length(mech, kin_ref)
    (xm, xr), xlabel = _crank_x(mech, kin_mj, kin_ref)
    fig, (a1, a2) = plt.subplots(2, 1, figsize=(8.0, 6.2), sharex=True, layout="constrained",
                                 gridspec_kw=dict(height_ratios=(2.2, 1)))
    a1.plot(xm, Lm * MM, color="tab:orange", label=MJ_LABEL + " (spatial tendon)", **MJ_STYLE)
    a1.plot(xr, Lr * MM, label=REF_LABEL, **REF_STYLE)
    a1.set_ylabel("thread length [mm]")
    a1.legend(loc="best", fontsize=8)
    # The two runs share their time samples, so compare sample by sample on MuJoCo's angles.
    diff = (Lm - np.interp(xm, xr, Lr)) * UM if len(Lm) != len(Lr) else (Lm - Lr) * UM
    a2.plot(xm, diff, color="tab:orange", lw=1.2)
    a2.axhline(0.0, color="0.5", lw=0.8)
    a2.set_ylabel("MuJoCo − reference [µm]")
    _finish_x(a2, [xm, xr], xlabel)
    for ax in (a1, a2):
        ax.grid(True, alpha=0.3)
    a1.set_title(_title(mech, "thread " + "–".join(mech.thread)
                        + f", max |difference| = {np.abs(diff).max():.3g} µm"), fontsize=10)
    return _save(fig, out_dir, "thread_length.png")


# ----------------------------------------------------------------------------- one point
def kinematics_plot(mech: Mechanism, kin_mj: Trace, kin_ref: Trace, out_dir, point: str) -> Path:
    """``kinematics_<point>.png``: x and y position (mm), speed |v| (m/s) and acceleration |a|
    (m/s^2) of ``point`` against crank angle (deg) over the kinematic run, MuJoCo vs reference."""
    (xm, xr), xlabel = _crank_x(mech, kin_mj, kin_ref)
    fig, axs = plt.subplots(3, 1, figsize=(8.0, 8.0), sharex=True, layout="constrained")
    pm, pr = kin_mj.points[point] * MM, kin_ref.points[point] * MM
    _pair(axs[0], xm, pm[:, 0], xr, pr[:, 0], "tab:blue", "x")
    _pair(axs[0], xm, pm[:, 1], xr, pr[:, 1], "tab:green", "y")
    axs[0].set_ylabel(f"position of {point} [mm]")
    axs[0].legend(loc="best", fontsize=8, ncol=2)
    _pair(axs[1], xm, np.linalg.norm(kin_mj.velocities[point], axis=1),
          xr, np.linalg.norm(kin_ref.velocities[point], axis=1), "tab:purple")
    axs[1].set_ylabel(f"speed |v| of {point} [m/s]")
    axs[1].legend(loc="best", fontsize=8)
    _pair(axs[2], xm, np.linalg.norm(kin_mj.accelerations[point], axis=1),
          xr, np.linalg.norm(kin_ref.accelerations[point], axis=1), "tab:red")
    axs[2].set_ylabel(f"acceleration |a| of {point} [m/s$^2$]")
    axs[2].legend(loc="best", fontsize=8)
    _finish_x(axs[2], [xm, xr], xlabel)
    for ax in axs:
        ax.grid(True, alpha=0.3)
    w = float(np.mean(kin_mj.omega))
    axs[0].set_title(_title(mech, f"point {point}, crank at {w:.4g} rad/s ({w * RPM:.4g} rpm)"),
                     fontsize=10)
    return _save(fig, out_dir, f"kinematics_{point}.png")


# ----------------------------------------------------------------------------- sliders (seed 002)
def slider_motion(trace: Trace, slider: Slider) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The slider point's motion along its guide, relative to the guide (which may move).

    ``s = (P - n1) . u`` with ``u = (n2 - n1) / L`` and L = |n2 - n1| constant (the guide's
    points are on one rigid link), so ``u' = (v_n2 - v_n1) / L`` and ``u'' = (a_n2 - a_n1) / L``
    exactly, and ``s' = (v_P - v_n1) . u + (P - n1) . u'``,
    ``s'' = (a_P - a_n1) . u + 2 (v_P - v_n1) . u' + (P - n1) . u''``. Planar components, as
    the slider block. Returns s (m), ds/dt (m/s), d2s/dt2 (m/s^2), each (N,).
    """
    n1, n2 = slider.guide
    P, V, A = trace.points, trace.velocities, trace.accelerations
    g = P[n2][:, :2] - P[n1][:, :2]
    L = np.linalg.norm(g, axis=1, keepdims=True)
    u = g / L
    ud = (V[n2][:, :2] - V[n1][:, :2]) / L
    udd = (A[n2][:, :2] - A[n1][:, :2]) / L
    r = P[slider.point][:, :2] - P[n1][:, :2]
    rd = V[slider.point][:, :2] - V[n1][:, :2]
    rdd = A[slider.point][:, :2] - A[n1][:, :2]
    return _dot(r, u), _dot(rd, u) + _dot(r, ud), _dot(rdd, u) + 2.0 * _dot(rd, ud) + _dot(r, udd)


def pressure_angle(trace: Trace, slider: Slider) -> np.ndarray:
    """Angle (rad, in [0, pi/2]) between the rod start->point that pushes the slider and its
    guide: the pressure angle of the prismatic pair (0: the rod pushes along the guide)."""
    n1, n2 = slider.guide
    g = trace.points[n2][:, :2] - trace.points[n1][:, :2]
    d = trace.points[slider.point][:, :2] - trace.points[slider.start][:, :2]
    c = np.abs(_dot(d, g)) / (np.linalg.norm(d, axis=1) * np.linalg.norm(g, axis=1))
    return np.arccos(np.clip(c, 0.0, 1.0))


def harmonics(mech: Mechanism, trace: Trace, y: np.ndarray, kmax: int = 12) -> np.ndarray | None:
    """Amplitudes of the harmonics k = 1..kmax of the mechanism period (mech.period of the
    input angle) in the samples ``y`` of ``trace``, over one period from its first sample.

    The samples are resampled uniformly in the input angle (linear interpolation of the
    trace, whose steps are ~0.3 deg), so a crank speed that is not quite constant does not
    smear the lines. None if the trace covers less than one period or does not turn steadily.
    """
    turned = np.abs(np.asarray(trace.phi) - trace.phi[0])
    if turned[-1] < mech.period * (1.0 - 1e-9) or not np.all(np.diff(turned) > 0):
        return None
    m = 2048 * max(1, round(mech.period / (2.0 * math.pi)))
    grid = mech.period * np.arange(m) / m
    c = np.fft.rfft(np.interp(grid, turned, y)) / m
    return 2.0 * np.abs(c[1:kmax + 1])


def _sliders(mech: Mechanism) -> list[Slider]:
    return [s for s in mech.steps if isinstance(s, Slider)]


def _higher_share(amp: np.ndarray) -> float:
    """The higher harmonics (k >= 2) against the first: sqrt(sum A_k^2) / A_1, as a fraction."""
    return float(np.sqrt(np.sum(amp[1:] ** 2)) / amp[0])


def slider_plots(mech: Mechanism, kin_mj: Trace, kin_ref: Trace, out_dir) -> list[Path]:
    """For every slider block (seed 002, Figs. 3-5), three files, MuJoCo vs reference:

    ``slider_<P>.png``: the slider's position s along its guide from n1 (mm), its velocity
    ds/dt (m/s) and acceleration d2s/dt2 (m/s^2) relative to the guide (see
    :func:`slider_motion`) against crank angle; ``slider_<P>_spectrum.png``: amplitudes of the
    harmonics 1..12 of the crank turn (of the mechanism period if longer) in the slider
    acceleration, log scale, with the share of the higher harmonics; ``pressure_angle_<P>.png``:
    the pressure angle (deg) with the synthesis limit [theta] if the file has one.
    """
    paths = []
    (xm, xr), xlabel = _crank_x(mech, kin_mj, kin_ref)
    turns = round(mech.period / (2.0 * math.pi))
    for sl in _sliders(mech):
        p, (n1, n2) = sl.point, sl.guide
        sm, sr = slider_motion(kin_mj, sl), slider_motion(kin_ref, sl)
        moving = not (n1 in mech.ground and n2 in mech.ground)
        guide = ("relative to its moving guide " if moving else "on guide ") + f"{n1}→{n2}"

        # --- s, ds/dt, d2s/dt2
        fig, axs = plt.subplots(3, 1, figsize=(8.0, 8.0), sharex=True, layout="constrained")
        units = (("position $s$ along the guide [mm]", MM, "tab:blue"),
                 ("velocity $ds/dt$ [m/s]", 1.0, "tab:purple"),
                 ("acceleration $d^2s/dt^2$ [m/s$^2$]", 1.0, "tab:red"))
        for ax, a, b, (lab, k, c) in zip(axs, sm, sr, units):
            _pair(ax, xm, a * k, xr, b * k, c)
            ax.set_ylabel(lab)
            if k == 1.0:
                ax.axhline(0.0, color="0.5", lw=0.6, zorder=0)
            ax.grid(True, alpha=0.3)
        axs[0].legend(loc="best", fontsize=8)
        stroke = float(np.ptp(sr[0]))
        syn = (f" (synthesis: {mech.synthesis.stroke * MM:g} mm)"
               if mech.synthesis is not None and not moving else "")
        # Every point of the sliding link moves along the guide by the same s (plus a constant).
        body = next((l for l in mech.links if p in l.points and l.guide == sl.guide), None)
        also = [q for q in (body.points if body else ()) if q != p and q not in _mass_centres(mech)]
        if also:
            syn += f" (also of {', '.join(also)})"
        for v in (sr[0].min(), sr[0].max()):
            axs[0].axhline(v * MM, color="0.4", lw=0.7, ls=":")
        _finish_x(axs[2], [xm, xr], xlabel)
        axs[0].set_title(_title(mech, f"slider {p} {guide}: stroke {stroke * MM:.2f} mm{syn}"),
                         fontsize=10)
        paths.append(_save(fig, out_dir, f"slider_{p}.png"))

        # --- harmonic content of the acceleration
        am, ar = harmonics(mech, kin_mj, sm[2]), harmonics(mech, kin_ref, sr[2])
        if am is not None and ar is not None:
            fig, ax = plt.subplots(figsize=(8.0, 5.0), layout="constrained")
            k = np.arange(1, len(ar) + 1)
            ax.bar(k - 0.2, am, width=0.4, color="tab:red", alpha=0.75, label=MJ_LABEL)
            ax.bar(k + 0.2, ar, width=0.4, color="white", edgecolor="k", hatch="////", lw=0.8,
                   label=REF_LABEL)
            ax.set_yscale("log")
            ax.set_xticks(k)
            if turns > 1:
                ax.set_xlabel(f"harmonic k of the mechanism period ({turns} turns of the input crank = "
                              f"{math.degrees(mech.period):g}°; k = {turns}: once per turn)")
            else:
                ax.set_xlabel("harmonic k of the crank rotation (order)")
            ax.set_ylabel(f"amplitude of $d^2s/dt^2$ of {p} [m/s$^2$]")
            ax.grid(True, which="major", axis="y", alpha=0.3)
            ks = f"2..{len(ar)}"
            txt = (f"higher harmonics k = {ks} relative to the first, "
                   f"$\\sqrt{{\\Sigma A_k^2}}\\,/\\,A_1$:\n"
                   f"MuJoCo {100 * _higher_share(am):.1f} %, reference {100 * _higher_share(ar):.1f} %\n"
                   f"$A_2/A_1$ = {100 * ar[1] / ar[0]:.1f} %,  $A_1$ = {ar[0]:.4g} m/s$^2$ (reference)")
            ax.text(0.98, 0.97, txt, transform=ax.transAxes, ha="right", va="top", fontsize=8.5,
                    bbox=dict(boxstyle="round", fc="white", ec="0.7"))
            ax.legend(loc="lower left", fontsize=8)
            w = float(np.mean(np.abs(kin_mj.omega)))
            ax.set_title(_title(mech, f"harmonics of the acceleration of slider {p}, "
                                      f"{w:.4g} rad/s ({w * RPM:.4g} rpm)"), fontsize=10)
            paths.append(_save(fig, out_dir, f"slider_{p}_spectrum.png"))

        # --- pressure angle
        gm, gr = np.degrees(pressure_angle(kin_mj, sl)), np.degrees(pressure_angle(kin_ref, sl))
        fig, ax = plt.subplots(figsize=(8.0, 4.6), layout="constrained")
        _pair(ax, xm, gm, xr, gr, "tab:green")
        i = int(np.argmax(gr))
        top = float(gr[i])
        ax.plot(xr[i], top, "v", color="k", ms=7, zorder=5)
        ax.annotate(f"max {top:.2f}° (MuJoCo {gm.max():.2f}°)", (xr[i], top), xytext=(0, 9),
                    textcoords="offset points", ha="center", fontsize=8.5)
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
        _finish_x(ax, [xm, xr], xlabel)
        ax.set_title(_title(mech, f"pressure angle of slider {p}, rod {sl.start}→{p} against "
                                  f"guide {n1}→{n2}"), fontsize=10)
        paths.append(_save(fig, out_dir, f"pressure_angle_{p}.png"))
    return paths


# ----------------------------------------------------------------------------- thread feed (seed 003)
def thread_feed_plot(mech: Mechanism, kin_mj: Trace, kin_ref: Trace, out_dir) -> Path | None:
    """``thread_feed.png``: over one crank turn from phi0, the thread length lF (mm), its
    increment dlF = lF(phi) - lF(phi0) (mm) and the feed Pd = dlF - dP (mm; dP the file's
    thread elongation), MuJoCo vs reference. None without a thread elongation."""
    if not mech.thread or mech.thread_elongation is None:
        return None
    (xm, xr), xlabel = _crank_x(mech, kin_mj, kin_ref)
    dp = mech.thread_elongation

    def one_turn(tr, x):
        # Up to and including the first sample at or past a full turn: the axis is cut at 360°.
        turned = np.abs(np.asarray(tr.phi) - tr.phi[0])
        k = min(int(np.searchsorted(turned, 2.0 * math.pi * (1.0 - 1e-9))) + 1, len(turned))
        L = _thread_length(mech, tr)[:k]
        return x[:k], L, L - L[0]

    xm, Lm, dm = one_turn(kin_mj, xm)
    xr, Lr, dr = one_turn(kin_ref, xr)
    fig, axs = plt.subplots(3, 1, figsize=(8.0, 8.0), sharex=True, layout="constrained")
    _pair(axs[0], xm, Lm * MM, xr, Lr * MM, "tab:orange")
    axs[0].set_ylabel(f"thread length $l_F$ [mm]\n{'–'.join(mech.thread)}")
    _pair(axs[1], xm, dm * MM, xr, dr * MM, "tab:orange")
    axs[1].set_ylabel("$\\Delta l_F = l_F(\\varphi) - l_F(\\varphi_0)$ [mm]")
    _pair(axs[2], xm, (dm - dp) * MM, xr, (dr - dp) * MM, "tab:red")
    axs[2].axhline(0.0, color="k", lw=0.9, zorder=0)
    axs[2].set_ylabel(f"feed $P_d = \\Delta l_F - \\Delta P$ [mm]\n($\\Delta P$ = {dp * MM:g} mm)")
    pd = (dr - dp) * MM
    for ax in axs:
        ax.grid(True, alpha=0.3)
    for v, va in ((pd.max(), "bottom"), (pd.min(), "top")):
        i = int(np.argmin(np.abs(pd - v)))
        axs[2].plot(xr[i], v, "o", color="k", ms=4, zorder=5)
        axs[2].annotate(f"{v:+.2f} mm", (xr[i], v), xytext=(0, 5 if va == "bottom" else -5),
                        textcoords="offset points", ha="center", va=va, fontsize=8.5)
    axs[2].margins(y=0.15)
    axs[0].legend(loc="best", fontsize=8)
    axs[2].set_xlabel(xlabel)
    _angle_ticks(axs[2], float(xr[0]), float(xr[0]) + 360.0)
    axs[0].set_title(_title(mech, f"needle-thread feed over one turn: $P_d$ from {pd.min():+.2f} "
                                  f"to {pd.max():+.2f} mm (swing {np.ptp(pd):.2f} mm)"), fontsize=10)
    return _save(fig, out_dir, "thread_feed.png")


# ----------------------------------------------------------------------------- 3D contour (seed 003 Fig. 2)
def _is_spatial(mech: Mechanism) -> bool:
    kin = reference.solve(mech, [mech.phi0])
    return any(abs(float(kin.position(p)[0, 2])) > 1e-12 for p in mech.point_names)


def contour_plot(mech: Mechanism, out_dir, n: int = 6) -> Path | None:
    """``thread_contour.png``: the mechanism and the needle-thread contour in ``n`` crank
    positions over one period (seed 003, Fig. 2): front view (x-y) and, beside it, top view
    (x-z, seen from +y, so +z points down the page), equal aspect, mm; one colour per
    position, the thread thick and the links thin, the guides as squares, the eyelets named
    at phi0. None unless the thread is spatial (some point off z = 0)."""
    if not mech.thread or not _is_spatial(mech):
        return None
    pairs = _segments(mech)
    phi = mech.phi0 + math.copysign(mech.period, mech.speed) * np.arange(n) / n
    kin = reference.solve(mech, phi)
    P = {k: kin.position(k) * MM for k in mech.point_names}
    path = reference.solve(mech, mech.phi0 + np.linspace(0.0, mech.period, 361))
    eyelets = [p for p in mech.thread if p not in mech.ground]
    guides = [p for p in mech.thread if p in mech.ground]
    pivots = [p for p in mech.ground if p not in guides
              and any(p in l.points for l in mech.links)]
    cmap = plt.get_cmap("viridis")
    cols = [cmap(0.78 * i / max(n - 1, 1)) for i in range(n)]

    allp = np.concatenate([P[p] for p in P] + [path.position(e) * MM for e in eyelets])
    lo, hi = allp.min(axis=0), allp.max(axis=0)
    pad = 0.07 * float(max(hi - lo))
    fig = plt.figure(figsize=(13.0, 6.8), layout="constrained")
    gs = fig.add_gridspec(2, 2, width_ratios=(1.0, 1.0), height_ratios=(0.42, 0.58))
    af = fig.add_subplot(gs[:, 0])
    at = fig.add_subplot(gs[0, 1], sharex=af)
    al = fig.add_subplot(gs[1, 1])
    al.axis("off")
    for ax, j in ((af, 1), (at, 2)):
        for e in eyelets:
            q = path.position(e) * MM
            ax.plot(q[:, 0], q[:, j], color="0.7", lw=0.8, zorder=1)
        for i in reversed(range(n)):  # phi0 last, on top
            c, first = cols[i], i == 0
            segs = [np.stack([P[a][i, [0, j]], P[b][i, [0, j]]]) for a, b in pairs]
            ax.add_collection(LineCollection(segs, colors=[c], linewidths=1.6 if first else 0.8,
                                             alpha=0.9 if first else 0.45, zorder=2 + first))
            th = np.stack([P[p][i, [0, j]] for p in mech.thread])
            ax.plot(th[:, 0], th[:, 1], color=c, lw=2.6 if first else 1.5, zorder=4 + first,
                    marker="o", ms=4 if first else 3, mfc="white", mec=c,
                    label=f"$\\varphi_1$ = {math.degrees(phi[i]):g}°" + (" ($\\varphi_0$)" if first else ""))
        for g in guides:
            ax.plot(P[g][0, 0], P[g][0, j], "s", ms=8, mfc="white", mec="k", mew=1.3, zorder=7)
            ax.annotate(g, (P[g][0, 0], P[g][0, j]), xytext=(8, 0), textcoords="offset points",
                        ha="left", va="center", fontsize=9, fontweight="bold")
        for g in pivots:
            ax.plot(P[g][0, 0], P[g][0, j], "^", ms=8, mfc="white", mec="k", zorder=7)
            ax.annotate(g, (P[g][0, 0], P[g][0, j]), xytext=(0, -9), textcoords="offset points",
                        ha="center", va="top", fontsize=8)
        for e in eyelets:
            ax.annotate(e, (P[e][0, 0], P[e][0, j]), xytext=(7, 5), textcoords="offset points",
                        fontsize=9, fontweight="bold", color=_darker(cols[0]), zorder=8,
                        bbox=dict(boxstyle="round,pad=0.1", fc="white", ec="none", alpha=0.75))
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
    al.legend(handles, labels, loc="upper center", ncol=2, fontsize=9, frameon=False,
              title=f"crank positions: thread {'–'.join(mech.thread)} thick, links thin",
              title_fontsize=9)
    fig.suptitle(_title(mech, f"needle-thread contour in {n} crank positions"), fontsize=10)
    return _save(fig, out_dir, "thread_contour.png", tight=True)


# ----------------------------------------------------------------------------- geared cranks (seed 004 Fig. 3)
def _geared_crank(mech: Mechanism) -> Crank | None:
    return next((s for s in mech.steps if isinstance(s, Crank) and s.ratio != 1.0), None)


def _link_number(mech: Mechanism, crank: Crank) -> int:
    """1-based index of the link carrying ``crank`` (the papers number links so: phi04 is link 4's)."""
    return 1 + next(i for i, l in enumerate(mech.links) if crank.pivot in l.points and crank.point in l.points)


def phase_study_plot(mech: Mechanism, out_dir, point: str | None = None,
                     offsets_deg=(-90, -60, -30, 0, 30, 60, 90)) -> Path | None:
    """``phase_study.png``: the path of ``point`` (default :func:`key_point`) over one period
    for several mutual settings of the cranks: the geared crank's phase is its file's phase
    plus each offset (seed 004, Fig. 3). Settings that cannot assemble are listed, not drawn.
    None without a geared crank (a crank with ratio != 1)."""
    crank = _geared_crank(mech)
    if crank is None:
        return None
    point = point or key_point(mech)
    i_in, i_g = _link_number(mech, mech.input_crank), _link_number(mech, crank)
    phi = mech.phi0 + math.copysign(mech.period, mech.speed) * np.linspace(0.0, 1.0, 721)
    cmap = plt.get_cmap("coolwarm")
    span = max(1.0, max(abs(o) for o in offsets_deg))
    fig, ax = plt.subplots(figsize=(9.0, 7.6), layout="constrained")
    drawn = []
    for off in offsets_deg:
        ph = crank.phase + math.radians(off)
        steps = tuple(dataclasses.replace(s, phase=ph) if s is crank else s for s in mech.steps)
        lab = (f"$\\varphi_{{0{i_in}}}$ = {math.degrees(mech.phi0):g}°, "
               f"$\\varphi_{{0{i_g}}}$ = {math.degrees(ph):g}°")
        try:
            xy = reference.solve(dataclasses.replace(mech, steps=steps), phi).position(point)[:, :2] * MM
        except AssemblyError:
            ax.plot([], [], " ", label=lab + ": does not assemble")
            continue
        file = off == 0
        c = "k" if file else cmap(0.5 + 0.5 * off / span)
        ax.plot(xy[:, 0], xy[:, 1], color=c, lw=2.2 if file else 1.3, zorder=3 if file else 2,
                label=lab + f": Δx {np.ptp(xy[:, 0]):.1f}, Δy {np.ptp(xy[:, 1]):.1f} mm" + (" (file)" if file else ""))
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
    ax.set_title(_title(mech, f"path of {point} over {math.degrees(mech.period):g}° of crank {i_in}\n"
                              f"for settings of the geared crank {crank.pivot}–{crank.point} "
                              f"(ratio {crank.ratio:g})"), fontsize=10, loc="left")
    return _save(fig, out_dir, "phase_study.png", tight=True)


# ----------------------------------------------------------------------------- link rotation (seed 004 Fig. 4a-b)
def link_motion_plot(mech: Mechanism, kin_mj: Trace, kin_ref: Trace, out_dir, link: str) -> Path:
    """``link_<link>.png``: angular velocity (rad/s) and angular acceleration (rad/s^2) of
    ``link`` about z against crank angle, MuJoCo (its body's) vs reference."""
    (xm, xr), xlabel = _crank_x(mech, kin_mj, kin_ref)
    fig, (a1, a2) = plt.subplots(2, 1, figsize=(8.0, 6.4), sharex=True, layout="constrained")
    for ax, mj, ref, lab, c in ((a1, kin_mj.link_omega, kin_ref.link_omega,
                                 f"angular velocity $\\omega$ of {link} [rad/s]", "tab:blue"),
                                (a2, kin_mj.link_eps, kin_ref.link_eps,
                                 f"angular acceleration $\\varepsilon$ of {link} [rad/s$^2$]", "tab:red")):
        if link in mj:
            ax.plot(xm, mj[link], color=c, label=MJ_LABEL, **MJ_STYLE)
        ax.plot(xr, ref[link], label=REF_LABEL, **REF_STYLE)
        ax.axhline(0.0, color="0.5", lw=0.6, zorder=0)
        ax.set_ylabel(lab)
        ax.grid(True, alpha=0.3)
    a1.legend(loc="best", fontsize=8)
    _finish_x(a2, [xm, xr], xlabel)
    w, e = kin_ref.link_omega[link], kin_ref.link_eps[link]
    a1.set_title(_title(mech, f"rotation of link {link}: |ω| ≤ {np.abs(w).max():.4g} rad/s, "
                              f"|ε| ≤ {np.abs(e).max():.4g} rad/s²"), fontsize=10)
    return _save(fig, out_dir, f"link_{link}.png")


def motion_links(mech: Mechanism) -> list[str]:
    """Links worth a rotation plot: every moving link carrying a slider's guide (both its
    points); else the link carrying the key point that is neither a crank nor a slider
    translating on a fixed guide; else none."""
    out = []
    for s in _sliders(mech):
        n1, n2 = s.guide
        if n1 in mech.ground and n2 in mech.ground:
            continue
        l = next((l for l in mech.links if n1 in l.points and n2 in l.points), None)
        if l is not None and l.name not in out:
            out.append(l.name)
    if out:
        return out
    cranks = [(c.pivot, c.point) for c in mech.steps if isinstance(c, Crank)]
    p = key_point(mech)
    for l in mech.links:
        if p not in l.points or any(a in l.points and b in l.points for a, b in cranks):
            continue
        if l.guide and all(g in mech.ground for g in l.guide):
            continue  # translates: no rotation to show
        return [l.name]
    return []


# ----------------------------------------------------------------------------- all
def key_point(mech: Mechanism) -> str:
    """The point worth a kinematics plot: the first moving thread point, else the last
    constructed point that is not merely a centre of mass (see :func:`_mass_centres`; a
    slider joint that is also its link's centre of mass counts), else the last constructed."""
    for p in mech.thread or ():
        if p not in mech.ground:
            return p
    coms = _mass_centres(mech)
    return next((s.point for s in reversed(mech.steps) if s.point not in coms), mech.steps[-1].point)


def _mass_centres(mech: Mechanism) -> set[str]:
    """Points that are a link's centre of mass and nothing else: no block builds from them and
    no other link carries them (the needle-bar joint C of the crank-slider is its centre of
    mass too, but the rod's centre is built from it, so it stays a point of the mechanism)."""
    used = {p for s in mech.steps for p in s.inputs}
    return {l.com for l in mech.links if l.com is not None and l.com not in used
            and sum(l.com in k.points for k in mech.links) == 1}


def all_plots(mech: Mechanism, kin_mj: Trace, kin_ref: Trace, dyn_mj: Trace | None, dyn_ref: Trace | None,
              out_dir, rk4: reference.Motion | None = None) -> list[Path]:
    """Every plot above that applies into ``out_dir`` (created if missing); returns the paths.

    The speed plots need the dynamic runs (skipped if ``dyn_mj`` or ``dyn_ref`` is None); the
    slider plots a slider block, the feed a thread elongation, the contour a spatial thread,
    the phase study a geared crank."""
    point = key_point(mech)
    paths = []
    if dyn_mj is not None and dyn_ref is not None:
        paths += speed_plots(mech, dyn_mj, dyn_ref, out_dir, rk4)
    paths.append(positions_plot(mech, out_dir, highlight=None if mech.thread else point))
    paths += [p for p in (thread_plot(mech, kin_mj, kin_ref, out_dir),
                          thread_feed_plot(mech, kin_mj, kin_ref, out_dir),
                          contour_plot(mech, out_dir)) if p is not None]
    paths.append(kinematics_plot(mech, kin_mj, kin_ref, out_dir, point))
    paths += slider_plots(mech, kin_mj, kin_ref, out_dir)
    paths += [link_motion_plot(mech, kin_mj, kin_ref, out_dir, l) for l in motion_links(mech)]
    ph = phase_study_plot(mech, out_dir)
    if ph is not None:
        paths.append(ph)
    return paths
