"""PNG plots comparing MuJoCo runs with the vector-method reference.

The figures follow the take-up paper: crank speed and acceleration against time and against
crank angle (its Figs. 3 and 4), the mechanism drawn in many crank positions (Fig. 1b), plus
the thread length and the kinematics of one point. Inputs are :class:`mjlink.simulate.Trace`
objects in SI units; the plots show mm, um, deg, rpm, m/s, m/s^2 and rad/s^2 as labelled.

Everywhere MuJoCo is a solid line and the reference a dashed line drawn on top of it, so both
stay visible where they coincide (which is the expected case). Every file is written to a
temporary name in its folder and then renamed, so a reader never sees a half-written PNG.
"""

from __future__ import annotations

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
from matplotlib.patches import Polygon, Rectangle  # noqa: E402

from . import reference  # noqa: E402
from .errors import OutputError  # noqa: E402
from .mechanism import Attached, Crank, Dyad, Mechanism  # noqa: E402
from .simulate import Trace  # noqa: E402

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
def _save(fig, out_dir: Path | str, name: str) -> Path:
    """Write ``fig`` as ``out_dir/name`` atomically, close it, return the path."""
    out = Path(out_dir)
    path = out / name
    tmp = None
    try:
        out.mkdir(parents=True, exist_ok=True)
        # Not mkstemp: its 0600 mode would survive the rename; 'x' honours the umask instead.
        part = out / f".{name}.{os.getpid()}.{secrets.token_hex(4)}.tmp"
        with open(part, "xb") as f:
            tmp = part  # ours from here on: remove it if anything below fails
            fig.savefig(f, format="png", dpi=DPI)
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
    for name, xlabel, key in (("speed_vs_time.png", "time t [s]", "t"),
                              ("speed_vs_angle.png", "crank angle $\\varphi_1$ [deg] (unwrapped)", "phi")):
        fig, (a1, a2) = plt.subplots(2, 1, figsize=(8.0, 6.6), sharex=True, layout="constrained")

        def x(tr_t, tr_phi):
            return tr_t if key == "t" else _deg(tr_phi)

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
            _angle_ticks(a2, min(xm[0], xr[0]), max(xm[-1], xr[-1]))
            if xm[-1] - xm[0] >= 720.0:
                # Tens of turns in degrees are hard to count: name the turns on top as well.
                top = a1.secondary_xaxis("top", functions=(lambda d: d / 360.0, lambda n: n * 360.0))
                top.set_xlabel("crank turns ($\\varphi_1$ / 360°)", fontsize=9)
        for ax in (a1, a2):
            ax.grid(True, alpha=0.3)
        a1.legend(loc="lower right", fontsize=8)
        d = mech.dynamics
        fig.suptitle(_title(mech, f"run-up, $M_1$ = {d.moment:g} N·m, b = {d.damping:g} N·m·s, "
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
    thread point (721 angles) and the thread at phi0 in orange. ``highlight`` names one
    more point whose path is drawn. Axes in mm, equal aspect.
    """
    pairs = _segments(mech)
    phi = mech.phi0 + mech.period * np.arange(n) / n
    kin = reference.solve(mech, phi)
    P = {k: kin.position(k) * MM for k in mech.point_names}

    fig, ax = plt.subplots(figsize=(8.0, 7.6), layout="constrained")
    # All ghost positions in one collection: one draw call instead of n * links.
    ghost = [np.stack([P[a][i, :2], P[b][i, :2]]) for i in range(1, n) for a, b in pairs]
    ax.add_collection(LineCollection(ghost, colors="0.6", linewidths=0.7, alpha=0.6, zorder=1))

    traced = [p for p in (mech.thread or ()) if p not in mech.ground]
    if highlight and highlight not in traced:
        traced.append(highlight)
    if traced:
        path_kin = reference.solve(mech, mech.phi0 + np.linspace(0.0, mech.period, 721))
        for k, p in enumerate(traced):
            xy = path_kin.position(p)[:, :2] * MM
            ax.plot(xy[:, 0], xy[:, 1], color=("tab:purple", "tab:green", "tab:cyan")[k % 3], lw=1.4,
                    zorder=2, label=f"path of {p}")
        # Ghost positions of the traced points, so the crank-angle spacing along the path shows.
        for p in traced:
            ax.plot(P[p][1:, 0], P[p][1:, 1], "o", ms=2.5, color="0.4", zorder=2)

    if mech.thread:
        th = np.stack([P[p][0, :2] for p in mech.thread])
        ax.plot(th[:, 0], th[:, 1], color="orange", lw=2.0, zorder=3,
                label="thread at $\\varphi_0$ (" + "–".join(mech.thread) + ")")

    colors = plt.get_cmap("tab10").colors
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

    # Extent first: ground symbols are sized from it.
    allxy = np.concatenate([np.concatenate([P[p][:, :2] for p in P])]
                           + ([path_kin.position(p)[:, :2] * MM for p in traced] if traced else []))
    lo, hi = allxy.min(axis=0), allxy.max(axis=0)
    size = 0.035 * float(max(hi - lo))
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
    coms = {l.com for l in mech.links if l.com}
    names = list(mech.point_names)
    xy0 = np.array([P[p][0, :2] for p in names])
    mids = [0.5 * (P[a][0, :2] + P[b][0, :2]) for a, b in pairs]
    feet = [xyz[:2] * MM - (0.0, 0.7 * size) for g, xyz in mech.ground.items() if g in pivots]
    others = np.concatenate([xy0] + [np.array(v).reshape(-1, 2) for v in (mids, feet) if v])
    for i, p in enumerate(names):
        d = xy0[i] - others
        r2 = np.einsum("ij,ij->i", d, d)
        near = r2 > 1e-12
        push = (d[near] / r2[near, None] ** 1.5).sum(axis=0)
        push = push / (np.linalg.norm(push) or 1.0)
        ax.annotate(p, xy0[i], xytext=(11 * push[0], 11 * push[1]), textcoords="offset points",
                    ha="center", va="center", zorder=7,
                    fontsize=7.5 if p in coms else 9, color="0.3" if p in coms else "k",
                    fontweight="normal" if p in coms else "bold",
                    bbox=dict(boxstyle="round,pad=0.1", fc="white", ec="none", alpha=0.7))

    pad = 0.08 * float(max(hi - lo))
    ax.set_xlim(lo[0] - pad, hi[0] + pad)
    ax.set_ylim(lo[1] - pad - size, hi[1] + pad)
    ax.set_aspect("equal", adjustable="box")
    ax.grid(True, alpha=0.25)
    ax.set_xlabel("x [mm]")
    ax.set_ylabel("y [mm]")
    ax.plot([], [], color="0.55", lw=0.7, label=f"{n} crank positions")
    ax.legend(loc="best", fontsize=8, framealpha=0.9)
    ax.set_title(_title(mech, f"{n} positions over one period, bold: $\\varphi_0$ = "
                              f"{math.degrees(mech.phi0):g}°"), fontsize=10)
    return _save(fig, out_dir, "positions.png")


# ----------------------------------------------------------------------------- thread length
def thread_plot(mech: Mechanism, kin_mj: Trace, kin_ref: Trace, out_dir) -> Path | None:
    """``thread_length.png``: thread length (mm) against crank angle (deg) over the kinematic
    run, MuJoCo vs reference, and below their difference MuJoCo - reference (um).
    None if the mechanism has no thread."""
    if not mech.thread:
        return None
    Lm, Lr = _thread_length(mech, kin_mj), _thread_length(mech, kin_ref)
    xm, xr = _deg(kin_mj.phi), _deg(kin_ref.phi)
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
    a2.set_xlabel("crank angle $\\varphi_1$ [deg]")
    _angle_ticks(a2, min(xm[0], xr[0]), max(xm[-1], xr[-1]))
    for ax in (a1, a2):
        ax.grid(True, alpha=0.3)
    a1.set_title(_title(mech, "thread " + "–".join(mech.thread)
                        + f", max |difference| = {np.abs(diff).max():.3g} µm"), fontsize=10)
    return _save(fig, out_dir, "thread_length.png")


# ----------------------------------------------------------------------------- one point
def kinematics_plot(mech: Mechanism, kin_mj: Trace, kin_ref: Trace, out_dir, point: str) -> Path:
    """``kinematics_<point>.png``: x and y position (mm), speed |v| (m/s) and acceleration |a|
    (m/s^2) of ``point`` against crank angle (deg) over the kinematic run, MuJoCo vs reference."""
    xm, xr = _deg(kin_mj.phi), _deg(kin_ref.phi)
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
    axs[2].set_xlabel("crank angle $\\varphi_1$ [deg]")
    _angle_ticks(axs[2], min(xm[0], xr[0]), max(xm[-1], xr[-1]))
    for ax in axs:
        ax.grid(True, alpha=0.3)
    w = float(np.mean(kin_mj.omega))
    axs[0].set_title(_title(mech, f"point {point}, crank at {w:.4g} rad/s ({w * RPM:.4g} rpm)"),
                     fontsize=10)
    return _save(fig, out_dir, f"kinematics_{point}.png")


# ----------------------------------------------------------------------------- all
def key_point(mech: Mechanism) -> str:
    """The point worth a kinematics plot: the first moving thread point, else the last
    constructed point that is not a centre of mass (else the last constructed point)."""
    for p in mech.thread or ():
        if p not in mech.ground:
            return p
    coms = {l.com for l in mech.links}
    return next((s.point for s in reversed(mech.steps) if s.point not in coms), mech.steps[-1].point)


def all_plots(mech: Mechanism, kin_mj: Trace, kin_ref: Trace, dyn_mj: Trace, dyn_ref: Trace,
              out_dir, rk4: reference.Motion | None = None) -> list[Path]:
    """Every plot above into ``out_dir`` (created if missing); returns the paths written."""
    point = key_point(mech)
    paths = speed_plots(mech, dyn_mj, dyn_ref, out_dir, rk4)
    paths.append(positions_plot(mech, out_dir, highlight=None if mech.thread else point))
    th = thread_plot(mech, kin_mj, kin_ref, out_dir)
    if th is not None:
        paths.append(th)
    paths.append(kinematics_plot(mech, kin_mj, kin_ref, out_dir, point))
    return paths
