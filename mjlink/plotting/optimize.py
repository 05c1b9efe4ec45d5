"""Figures of an optimization: convergence, the design before and after, the Pareto front.

Drawing only: every number comes computed from :mod:`mjlink.pipeline.optimize`.
"""

from __future__ import annotations

import textwrap
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..analysis import segments
from .style import figure, save, subplots, user_text

if TYPE_CHECKING:
    from ..analysis.metrics import Curve
    from ..reference.batch import Batch
    from ..study.optimize import Result
    from ..study.spec import Study
    from ..study.tasks import Verified

NOMINAL: dict[str, Any] = dict(color="0.45", lw=1.3, ls=(0, (4, 2)))
OPTIMUM: dict[str, Any] = dict(color="tab:blue", lw=2.0)
TARGET: dict[str, Any] = dict(color="k", lw=1.0, ls=":")


def _unit(u: str) -> str:
    return {"m/s^2": "m/s²", "N*m": "N·m", "kg*m^2": "kg·m²"}.get(u, u)


def _objective_unit(st: Any) -> str:
    """The unit of a study's objective: its columns' when they share one, else '-' (a weighted
    sum of different quantities)."""
    opt = st.optimize
    units = {c.unit for c in st.columns if c.name in {name for name, _ in opt.objective}}
    return _unit(units.pop()) if len(units) == 1 and "" not in units else "-"


def _title(title: str, what: str, width: int = 90) -> str:

    return "\n".join([*textwrap.wrap(user_text(title), width), *textwrap.wrap(user_text(what), width)])


def _phrases(head: str, phrases: list[str], width: int) -> list[str]:
    """``head`` and ``phrases`` in parentheses after it, comma-separated, on as few lines of at
    most ``width`` characters as they fit, a line breaking only between two of them."""
    lines: list[str] = [head]
    for k, p in enumerate(phrases):
        p = ("(" if k == 0 else "") + p + (")" if k == len(phrases) - 1 else ",")
        if lines and len(lines[-1]) + 1 + len(p) <= width:
            lines[-1] += " " + p
        else:
            lines.append(p)
    return lines


def convergence(title: str, res: Result, out_dir: Path) -> Path:
    """``convergence.png``: the best feasible objective so far against the evaluations. One
    run: its value (log scale where positive). A Pareto study's runs minimize different
    columns, so each is shown as its excess over its own final value, relative, on a log scale."""
    st = res.study
    opt = st.optimize
    assert opt is not None
    many = len(res.runs) > 1
    fig, ax = subplots(figsize=(8.4, 5.2 if many else 4.6), layout="constrained")
    sign = -1.0 if (opt.sense == "max" and not opt.pareto) else 1.0
    positive = True
    for k, r in enumerate(res.runs):
        h = np.array(r.history, dtype=float).reshape(-1, 4)
        if not len(h):
            continue
        y = sign * h[:, 2]
        if many:
            seen = y[np.isfinite(y)]
            final = seen[-1] if len(seen) else np.nan
            # Relative to the final value; a run that ends at exactly 0 (an objective that
            # reaches its floor), relative to the run's largest value instead.
            ref = abs(final) if final != 0 else (float(np.max(np.abs(seen))) or 1.0)
            y = np.maximum(np.abs(y - final) / ref, 1e-9)
        positive &= bool(np.all(y[np.isfinite(y)] > 0))
        ax.step(h[:, 1], y, where="post", lw=1.6 if k == 0 else 1.1, label=user_text(r.name), color=f"C{k % 10}")
    if many or (positive and opt.sense == "min"):
        ax.set_yscale("log")
    ax.set_xlabel("evaluations: candidates, a robust candidate counting once [-]")
    ax.set_ylabel(
        "best feasible so far:\nrelative excess over the run's final value [-]"
        if many
        else "\n".join(textwrap.wrap(user_text(f"best feasible so far: {opt.label} [{_objective_unit(st)}]"), 60))
    )
    ax.grid(True, alpha=0.3)
    # The title breaks between phrases, never inside one.
    setting = [f"{opt.population} candidates per generation", f"random seed {opt.seed}"]
    if st.robust:
        setting.insert(1, f"robust: {st.robust.samples} tolerance samples each")
    lines = [*textwrap.wrap(user_text(title), 90), *_phrases("convergence of differential evolution", setting, 90)]
    ax.set_title("\n".join(lines), fontsize=10)
    if many:
        fig.legend(*ax.get_legend_handles_labels(), loc="outside lower center", fontsize=7.5, ncol=2)
    return save(fig, out_dir, "convergence.png")


def _drawing(ax: Any, st: Study, b: Batch, row: int, style: dict[str, Any], label: str, traced: list[str]) -> None:
    mech = st.mechanism
    pos = {name: b.per_variant(b.kin.position(name))[row, :, :2] * 1e3 for name in mech.point_names}
    for k, (a, c) in enumerate(segments(mech)):
        ax.plot([pos[a][0, 0], pos[c][0, 0]], [pos[a][0, 1], pos[c][0, 1]], **style, label=label if k == 0 else None)
    for g in mech.ground:
        ax.plot(*pos[g][0], "^", color=style["color"], ms=6, mfc="none")
    for p in traced:
        path = np.vstack([pos[p], pos[p][:1]])
        ax.plot(path[:, 0], path[:, 1], color=style["color"], lw=0.9, alpha=0.8)


def before_after(
    title: str,
    st: Study,
    b: Batch,
    feasible: np.ndarray,
    curves: list[Curve],
    targets: dict[str, np.ndarray],
    points: list[str],
    res: Result,
    out_dir: Path,
) -> Path:
    """``before_after.png``: the mechanism file's design (grey, dashed) and the optimum (blue)
    drawn at phi0 with the paths of the points that matter; beside it each objective's curve
    over the cycle for both, with its target (a demand table) where it has one. ``points``
    the objective's points, whose paths are drawn (with the thread's and the targets')."""
    mech = st.mechanism
    traced = list(dict.fromkeys([*points, *targets, *[p for p in (mech.thread or ()) if p not in mech.ground]]))
    if not traced:  # the last point built that is not a centre of mass
        coms = {l.com for l in mech.links}
        traced = [next(s.point for s in reversed(mech.steps) if s.point not in coms)]
    n = max(1, len(curves))
    if curves:
        fig = figure(figsize=(12.0, max(5.0, 2.6 * n)), layout="constrained")
        gs = fig.add_gridspec(n, 2, width_ratios=[1.0, 1.25])
    else:
        fig = figure(figsize=(7.5, 6.0), layout="constrained")
        gs = fig.add_gridspec(1, 1)
    ax0 = fig.add_subplot(gs[:, 0])
    if feasible[0]:
        _drawing(ax0, st, b, 0, NOMINAL, "mechanism file (nominal)", traced)
    _drawing(ax0, st, b, 1, OPTIMUM, "optimum", traced)
    for p, t in targets.items():
        ax0.plot(t[:, 0], t[:, 1], "x", color="tab:red", ms=8, mew=2, label=f"precision points of {p}")
    ax0.set_aspect("equal", adjustable="datalim")
    ax0.set_xlabel("x [mm]")
    ax0.set_ylabel("y [mm]")
    ax0.grid(True, alpha=0.3)
    ax0.legend(fontsize=8, loc="best")
    ax0.set_title("at φ₀, with the paths of " + ", ".join(traced), fontsize=9)
    theta = np.degrees(b.theta)
    first = None
    for i, cv in enumerate(curves):
        ax = fig.add_subplot(gs[i, 1], sharex=first)  # one crank-angle axis, named at the bottom
        first = first or ax
        if feasible[0]:
            ax.plot(theta, cv.values[0], **NOMINAL, label="mechanism file (nominal)")
        ax.plot(theta, cv.values[1], **OPTIMUM, label="optimum")
        if cv.target is not None:
            ax.plot(theta, cv.target, **TARGET, label=cv.target_label)
        ax.set_ylabel(user_text(f"{cv.label} [{_unit(cv.unit) or '-'}]"), fontsize=8.5)
        ax.grid(True, alpha=0.3)
        ax.set_xlim(theta[0], theta[-1] + (theta[1] - theta[0]))
        if i == n - 1:
            ax.set_xlabel("input crank angle from φ₀ [deg]")
        ax.legend(fontsize=7.5, loc="best")
    opt = st.optimize
    assert opt is not None
    unit = "" if opt.pareto else _objective_unit(st)
    obj = "" if opt.pareto else f": {res.objective:.5g}" + (f" {unit}" if unit != "-" else "")
    nom = "" if feasible[0] else " (the mechanism file's design is infeasible here: not drawn)"
    # About 11 characters of 10-point text per inch of the figure's width.
    fig.suptitle(_title(title, f"before and after: {opt.label}{obj}{nom}", int(11 * fig.get_figwidth())), fontsize=10)
    return save(fig, out_dir, "before_after.png")


def pareto(title: str, res: Result, ver: Verified, out_dir: Path) -> Path | None:
    """``pareto.png``: every feasible candidate evaluated (grey), the front (blue line), the
    designs MuJoCo verified (green ring: agrees, red cross: missed) and the winner (the knee)."""
    st = res.study
    opt = st.optimize
    assert opt is not None and opt.pareto is not None and res.front_columns is not None
    c1, c2 = opt.pareto
    cols = {c.name: c for c in st.columns}
    a = res.archive
    ok = a.violation <= 0
    fig, ax = subplots(figsize=(8.0, 5.6), layout="constrained")
    ax.plot(a.columns[c1][ok], a.columns[c2][ok], ".", color="0.75", ms=2.5, label=f"feasible candidates ({ok.sum()})")
    f1, f2 = res.front_columns[c1], res.front_columns[c2]
    ax.plot(f1, f2, "-o", color="tab:blue", ms=5, lw=1.4, label=f"Pareto front ({len(f1)} designs)")
    passed = ver.passed[1:]
    ax.plot(f1[passed], f2[passed], "o", mfc="none", mec="tab:green", ms=11, mew=1.8, label="MuJoCo agrees")
    if (~passed).any():
        ax.plot(f1[~passed], f2[~passed], "x", color="tab:red", ms=11, mew=2, label="MuJoCo missed a threshold")
    ax.plot(res.columns[c1], res.columns[c2], "*", color="tab:orange", ms=16, mec="k", label="winner (knee)")
    for i, (x, y) in enumerate(zip(f1, f2, strict=True)):
        ax.annotate(f"{i + 1:02d}", (x, y), textcoords="offset points", xytext=(6, 4), fontsize=7)
    ax.set_xlabel(user_text(f"{cols[c1].label} [{_unit(cols[c1].unit) or '-'}]"))
    ax.set_ylabel(user_text(f"{cols[c2].label} [{_unit(cols[c2].unit) or '-'}]"))
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    bounds = "; ".join(b.text() for b in st.bounds)
    ax.set_title(
        _title(title, "Pareto front: minimize both" + (f" subject to {bounds}" if bounds else "")), fontsize=10
    )
    return save(fig, out_dir, "pareto.png")
