"""PNG figures of design studies: many variants of one mechanism, their parameters and metrics.

:func:`scatter_matrix` (metrics against parameters, any sampling), :func:`histograms` (the
spread of each metric, for tolerance studies) and :func:`feasible_region` (metrics over a grid
of two parameters, with the region that assembles and the one within the design limits).

Drawing only, from plain :class:`Column` data (no dependency on the study engine). Values are
in each column's own unit (the file's: mm, deg, um, N, N*m, W ...) and are NaN where a variant
is infeasible (it cannot assemble over the whole cycle or does not pass a dead point) or the
metric was not computed. Every function returns the written path, or None when there is
nothing to draw. Text from users (titles, labels, units) is drawn literally
(:func:`.style.user_text`); the shared look and the atomic writer are :mod:`.style`'s.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import matplotlib
import matplotlib.colors
import numpy as np
from matplotlib.axes import Axes
from matplotlib.axis import Axis
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Patch, PathPatch
from matplotlib.path import Path as MplPath
from matplotlib.ticker import MaxNLocator

from ..study.sampling import sample_std
from .study_base import (
    ADMISSIBLE_FACE,
    FAILED_COLOR,
    FEASIBLE_COLOR,
    HATCH_FACE,
    HATCH_LINES,
    INFEASIBLE,
    INFEASIBLE_COLOR,
    LIMIT_STYLE,
    MAX_PANELS,
    MAX_RINGED,
    NO_VALUE_FACE,
    NOMINAL_STYLE,
    PASSED_COLOR,
    TEXT_BOX,
    VEIL,
    Column,
    _as_1d,
    _chars,
    _count,
    _fmt,
    _grid,
    _hide_unused,
    _ordinal,
    _shown_unit,
    _span,
    _tidy,
    _times,
    _unit,
    _with_unit,
    _wrap,
)
from .style import figure, save, subplots

__all__ = ["Column", "feasible_region", "histograms", "save", "scatter_matrix"]


# ----------------------------------------------------------------------------- scatter matrix
def scatter_matrix(
    title: str,
    params: Sequence[Column],
    metrics: Sequence[Column],
    feasible: np.ndarray,
    verified: np.ndarray | None,
    out_dir: Path | str,
    name: str = "scatter.png",
    nominal: Mapping[str, float] | None = None,
) -> Path | None:
    """``name``: every metric (rows) against every parameter (columns), one point per variant.

    Args:
      title: the study's title (drawn literally).
      params, metrics: columns of V values each; only the first :data:`MAX_PANELS` of each are
        drawn (the figure says so).
      feasible: (V,) bool; infeasible variants have no metric: their parameter values are
        marked by grey crosses along the bottom of each panel.
      verified: (V,) int8, -1 not checked in MuJoCo, 0 failed the agreement check (ringed red),
        1 passed (ringed green while they are at most :data:`MAX_RINGED` or 5 % of the
        variants, else only counted in the legend); None: none checked.
      nominal: column name -> nominal value (the column's unit): a thin dashed line across
        the panels of that parameter (vertical) or metric (horizontal); NaN values skipped.
    Returns the path, or None without parameters, metrics or variants.

    Each panel gives r, the linear correlation of the feasible values, so the parameters that
    drive a metric show at a glance. Points are rasterised: 10,000 variants in 6 x 6 panels
    draw in under two seconds.
    """
    if not params or not metrics:
        return None
    feas = np.asarray(feasible, dtype=bool).ravel()
    V = feas.size
    if V == 0:
        return None
    ver = np.full(V, -1, dtype=np.int8) if verified is None else np.asarray(verified).ravel()
    if ver.size != V:
        raise ValueError(f"verified has {ver.size} values, expected {V}")
    nominal = nominal or {}
    for c in params[:MAX_PANELS]:
        _as_1d(c, V)  # a column of another size is refused before anything is drawn
    # A metric the same on every feasible variant (a stroke the study synthesizes) has no
    # relation to the parameters to show: said in the title, not drawn or correlated.
    constant = [(c, _constant(np.where(feas, _as_1d(c, V), np.nan))) for c in metrics]
    fixed = [(c, v) for c, v in constant if v is not None]
    metrics = [c for c, v in constant if v is None]
    if not metrics:
        return None
    ps, ms = list(params[:MAX_PANELS]), list(metrics[:MAX_PANELS])
    X = [_as_1d(c, V) for c in ps]
    # Infeasible variants have no metric, whatever the column holds.
    Y = [np.where(feas, _as_1d(c, V), np.nan) for c in ms]
    P, M = len(ps), len(ms)

    n_feas, n_inf = int(feas.sum()), int((~feas).sum())
    failed, passed = ver == 0, ver == 1
    # Rings on a few checked variants show where the checks were; on most of them they would
    # bury the points. Failures are always ringed: they are what the reader looks for.
    ring_passed = int(passed.sum()) <= max(MAX_RINGED, 0.05 * V)
    # Thousands of points: small and translucent, so density shows; a few: plain dots.
    ms_pt = 4.0 if V <= 200 else 2.6 if V <= 2000 else 1.8
    alpha = float(np.clip(25.0 / math.sqrt(V), 0.2, 0.9))
    # Fixed jitter: the crosses of many infeasible variants spread into a band, as a rug.
    rug_y = 0.015 + 0.05 * np.random.default_rng(0).random(V)

    # The layout is computed here rather than by matplotlib's layout engine, which measures
    # every tick of 36 panels twice and would double the drawing time. Sizes in inches.
    fig = figure()
    gs = fig.add_gridspec(M, P)
    axs = np.empty((M, P), dtype=object)
    for i in range(M):
        for j in range(P):
            axs[i, j] = fig.add_subplot(gs[i, j], sharex=axs[0, j] if i else None, sharey=axs[i, 0] if j else None)
    # The nominal design is in range: it is what the variants are read against.
    for j, (pc, x) in enumerate(zip(ps, X)):
        x_lo, x_hi = _span(np.append(x, nominal.get(pc.name, math.nan)))
        pad = 0.04 * (x_hi - x_lo)
        axs[0, j].set_xlim(x_lo - pad, x_hi + pad)
    for i, (mc, y) in enumerate(zip(ms, Y)):
        y_lo, y_hi = _span(np.append(y, nominal.get(mc.name, math.nan)) if np.isfinite(y).any() else y)
        # Room below the lowest point for the infeasible variants' crosses, if any.
        below = 0.17 if n_inf else 0.06
        axs[i, 0].set_ylim(y_lo - below * (y_hi - y_lo), y_hi + 0.06 * (y_hi - y_lo))
        if not np.isfinite(y).any():
            axs[i, 0].set_yticks([])
    x_scale, y_scale = [0] * P, [0] * M
    for i, (mc, y) in enumerate(zip(ms, Y)):
        no_value = not np.isfinite(y).any()
        for j, (pc, x) in enumerate(zip(ps, X)):
            ax = axs[i, j]
            ok = np.isfinite(x) & np.isfinite(y)
            ax.plot(x[ok], y[ok], "o", ms=ms_pt, mew=0, alpha=alpha, color=FEASIBLE_COLOR, rasterized=True, zorder=2)
            bad = ~feas & np.isfinite(x)
            if bad.any():
                ax.plot(
                    x[bad],
                    rug_y[bad],
                    "x",
                    ms=3.5,
                    mew=0.7,
                    alpha=min(0.9, 2 * alpha),
                    color=INFEASIBLE_COLOR,
                    transform=ax.get_xaxis_transform(),
                    rasterized=True,
                    zorder=2,
                )
            for sel, color, size in ((passed & ring_passed, PASSED_COLOR, 5.0), (failed, FAILED_COLOR, 7.0)):
                for on, tr in ((sel & ok, ax.transData), (sel & bad, ax.get_xaxis_transform())):
                    # A checked variant without a metric value rings its cross at the bottom.
                    if on.any():
                        yy = y[on] if tr is ax.transData else rug_y[on]
                        ax.plot(x[on], yy, "o", mfc="none", mec=color, ms=size, mew=1.0, transform=tr, zorder=4)
            if math.isfinite(nominal.get(pc.name, math.nan)):
                ax.axvline(nominal[pc.name], zorder=3, **NOMINAL_STYLE)
            if math.isfinite(nominal.get(mc.name, math.nan)):
                ax.axhline(nominal[mc.name], zorder=3, **NOMINAL_STYLE)
            missing = int((feas & np.isfinite(x) & ~np.isfinite(y)).sum())
            note = _panel_note(x[ok], y[ok], missing, n_feas, no_value)
            if note:
                ax.text(
                    0.03, 0.97, note, transform=ax.transAxes, ha="left", va="top", fontsize=7, bbox=TEXT_BOX, zorder=5
                )
            ax.grid(True, alpha=0.3, lw=0.5)
            ax.tick_params(labelsize=7, labelbottom=i == M - 1, labelleft=j == 0)
            if i == 0:
                x_scale[j] = _tidy(ax.xaxis, inset=0.07)
            if j == 0 and np.isfinite(y).any():
                y_scale[i] = _tidy(ax.yaxis, inset=0.03)

    handles = [
        Line2D([], [], ls="none", marker="o", ms=4, mew=0, color=FEASIBLE_COLOR, label=f"feasible ({n_feas:,})"),
        Line2D(
            [],
            [],
            ls="none",
            marker="x",
            ms=5,
            mew=1,
            color=INFEASIBLE_COLOR,
            label=f"{INFEASIBLE} ({n_inf:,}): its parameter values at the bottom" if n_inf else f"{INFEASIBLE}: none",
        ),
    ]
    for sel, color, size, what in ((passed, PASSED_COLOR, 6, "passed"), (failed, FAILED_COLOR, 7, "failed")):
        if sel.any():
            label = f"MuJoCo check {what} ({int(sel.sum()):,})"
            if sel is passed and not ring_passed:
                label += ", not ringed: too many"
                color = "none"
            handles.append(Line2D([], [], ls="none", marker="o", mfc="none", mec=color, ms=size, label=label))
    if any(math.isfinite(nominal.get(c.name, math.nan)) for c in (*ps, *ms)):
        handles.append(Line2D([], [], label="nominal", **NOMINAL_STYLE))

    # Margins from what they hold: wrapped axis labels (0.14 in a line at 8 pt), the widest
    # y tick label (0.06 in a character at 7 pt), title lines, legend rows.
    panel_w, panel_h, gap = 2.3, 1.9, 0.12
    ylabels = [_wrap(_with_unit(mc, e), _chars(panel_h - 0.15, 8)) for mc, e in zip(ms, y_scale)]
    ticks = max(_tick_chars(axs[i, 0].yaxis) for i in range(M))
    left = 0.15 + 0.14 * max(lab.count("\n") + 1 for lab in ylabels) + 0.1 + 0.06 * ticks + 0.1
    right = 0.3  # the last x tick label may reach half its width past the panel
    fig_w = max(8.0, left + P * panel_w + (P - 1) * gap + right)
    panel_w = (fig_w - left - right - (P - 1) * gap) / P
    xlabels = [_wrap(_with_unit(pc, e), _chars(panel_w - 0.1, 8)) for pc, e in zip(ps, x_scale)]
    ncol, rows = _legend_shape([str(h.get_label()) for h in handles], fig_w - 0.4, 8)
    bottom = 0.12 + 0.22 * rows + 0.1 + 0.14 * max(lab.count("\n") + 1 for lab in xlabels) + 0.08 + 0.25
    what = f"metrics (rows) against parameters (columns) of {_count(V, 'variant')}; r: linear correlation"
    if fixed:
        what += "\n" + _wrap(
            "the same on every feasible variant (not drawn): "
            + ", ".join(f"{c.name} = {v:.6g} {_shown_unit(c.unit)}".rstrip() for c, v in fixed),
            _chars(fig_w - 0.4, 10),
            2,
        )
    left_out = [c.name for c in [*params[P:], *metrics[M:]]]
    if left_out:
        what += "\n" + _wrap("not shown (in results.csv): " + ", ".join(left_out), _chars(fig_w - 0.4, 10), 3)
    head = _wrap(title, _chars(fig_w - 0.4, 10), 2) + "\n" + what
    top = 0.15 + 0.19 * (head.count("\n") + 1) + 0.15
    fig_h = top + M * panel_h + (M - 1) * gap + bottom
    fig.set_size_inches(fig_w, fig_h)
    gs.update(
        left=left / fig_w,
        right=1 - right / fig_w,
        bottom=bottom / fig_h,
        top=1 - top / fig_h,
        wspace=gap / panel_w,
        hspace=gap / panel_h,
    )
    for i in range(M):
        axs[i, 0].set_ylabel(ylabels[i], fontsize=8)
    for j in range(P):
        axs[M - 1, j].set_xlabel(xlabels[j], fontsize=8)
    fig.legend(
        handles=handles, loc="lower center", bbox_to_anchor=(0.5, 0.12 / fig_h), ncol=ncol, fontsize=8, frameon=False
    )
    fig.suptitle(head, fontsize=10, y=1 - 0.12 / fig_h, va="top")
    return _write(fig, out_dir, name)


_PERCENTILE_COLORS = ["tab:orange", "tab:purple", "tab:olive", "tab:cyan", "tab:pink", "tab:brown"]


def _constant(y: np.ndarray) -> float | None:
    """The value of a metric that is the same on every variant with a value (to 1e-9 of its
    size: rounding), else None (also with fewer than two values)."""
    v = y[np.isfinite(y)]
    if v.size < 2:
        return None
    lo, hi = float(v.min()), float(v.max())
    return 0.5 * (lo + hi) if hi - lo <= 1e-9 * max(abs(lo), abs(hi)) else None


def _tick_chars(axis: Axis) -> int:
    """The most characters of a tick label of ``axis`` as it will be drawn."""
    locs = [
        v for v in axis.get_major_locator()() if min(axis.get_view_interval()) <= v <= max(axis.get_view_interval())
    ]
    labels = axis.get_major_formatter().format_ticks(locs)
    return max((len(s) for s in labels), default=1)


def _legend_shape(labels: list[str], width_in: float, fontsize: float) -> tuple[int, int]:
    """(columns, rows) of a figure legend of ``labels`` that fits in ``width_in`` inches."""
    widths = [0.5 + len(s) * 0.6 * fontsize / 72.0 for s in labels]
    for ncol in range(len(labels), 0, -1):
        rows = math.ceil(len(labels) / ncol)
        # Legend columns are as wide as their widest entry.
        cols = [max(widths[c * rows : (c + 1) * rows], default=0.0) for c in range(ncol)]
        if sum(cols) <= width_in or ncol == 1:
            return ncol, rows
    return 1, len(labels)


def _panel_note(x: np.ndarray, y: np.ndarray, missing: int, n_feas: int, no_value: bool) -> str:
    """The note in a scatter panel's corner: the correlation, or why there is nothing."""
    if n_feas == 0:
        return "no variant assembles"
    if no_value:
        return "no value"
    lines = []
    if x.size >= 3 and np.ptp(x) > 0 and np.ptp(y) > 0:
        r = float(np.corrcoef(x, y)[0, 1])
        lines.append(f"r = {r:+.2f}" if abs(r) >= 0.005 else "r = 0.00")
    if missing:
        lines.append(f"{missing:,} without value")
    return "\n".join(lines)


# ----------------------------------------------------------------------------- histograms
def histograms(
    title: str,
    metrics: Sequence[Column],
    feasible: np.ndarray,
    out_dir: Path | str,
    name: str = "histograms.png",
    percentiles: Sequence[float] = (1, 50, 99),
    nominal: Mapping[str, float] | None = None,
) -> Path | None:
    """``name``: the distribution of each metric over the feasible variants, one panel each.

    Args:
      title: the study's title (drawn literally).
      metrics: columns of V values each.
      feasible: (V,) bool; only feasible variants with a value are counted.
      percentiles: in %, drawn as vertical lines and listed with their values (the median's
        solid, the others dashed); mean and sample standard deviation listed with them.
      nominal: metric name -> nominal value (the column's unit): a red dash-dotted line.
    Returns the path, or None when no metric has a value for a feasible variant (every
    variant infeasible, or no metrics).
    """
    feas = np.asarray(feasible, dtype=bool).ravel()
    V = feas.size
    nominal = nominal or {}
    vals = [np.where(feas, _as_1d(c, V), np.nan) for c in metrics]
    if not any(np.isfinite(v).any() for v in vals):
        return None
    pcts = sorted(float(p) for p in percentiles)
    n = len(metrics)
    rows, cols = _grid(n, 3 if n <= 9 else 4)
    panel_w, panel_h = 3.7, 2.7
    fig_w = max(7.0, panel_w * cols + 0.5)
    fig, axs = subplots(rows, cols, figsize=(fig_w, 1.0 + panel_h * rows), squeeze=False, layout="constrained")
    _hide_unused(axs, n)
    n_feas = int(feas.sum())
    for k, (col, v) in enumerate(zip(metrics, vals)):
        ax = axs.flat[k]
        scale = _histogram(ax, col, v[np.isfinite(v)], n_feas, pcts, nominal.get(col.name, math.nan), panel_h)
        ax.set_xlabel(_wrap(_with_unit(col, scale), _chars(panel_w - 0.3, 8.5)), fontsize=8.5)
        ax.set_ylabel("variants [-]", fontsize=8.5)
    what = (
        f"spread of the metrics over the {n_feas:,} of {_count(V, 'variant')} that assemble ({V - n_feas:,} {INFEASIBLE})"
        if n_feas < V
        else f"spread of the metrics over all {_count(V, 'variant')} (every one assembles)"
        if V > 1
        else "the metrics of the one variant"
    )
    fig.suptitle(_wrap(title, _chars(fig_w - 0.4, 10), 2) + "\n" + what, fontsize=10)
    return _write(fig, out_dir, name)


def _histogram(ax: Axes, col: Column, v: np.ndarray, n_feas: int, pcts: list[float], nom: float, panel_h: float) -> int:
    """One histogram panel: the bars, the percentile and nominal lines and their legend.
    Returns the power of ten its tick numbers are divided by (:func:`_tidy`)."""
    ax.tick_params(labelsize=7.5)
    ax.grid(True, axis="y", alpha=0.3, lw=0.5)
    unit = _unit(col.unit)
    if v.size == 0:
        ax.text(
            0.5, 0.5, "no value for any feasible variant", transform=ax.transAxes, ha="center", va="center", fontsize=8
        )
        ax.set_xticks([])
        ax.set_yticks([])
        return 0
    lo, hi = _span(v)
    if math.isfinite(nom):
        lo, hi = min(lo, nom), max(hi, nom)
    pad = 0.06 * (hi - lo)
    spread = float(np.ptp(v))
    if spread > 0:
        bins = np.linspace(float(v.min()), float(v.max()), _bin_count(v) + 1)
    else:
        # One value: one bar, 4 % of the axis wide, so it shows beside a distant nominal.
        bins = float(v[0]) + 0.02 * (hi - lo + 2 * pad) * np.array([-1.0, 1.0])
    counts, _, _ = ax.hist(v, bins=bins.tolist(), color=FEASIBLE_COLOR, alpha=0.75, edgecolor="white", lw=0.3)
    q = np.percentile(v, pcts)
    scale = float(q[-1] - q[0]) if q[-1] > q[0] else spread
    sep = " " if unit else ""
    handles = []
    others = iter(_PERCENTILE_COLORS * len(pcts))  # each outer percentile a hue of its own: told apart
    for p, val in zip(pcts, q):
        median = p == 50
        line: dict[str, Any] = dict(
            color="k" if median else next(others), lw=1.3 if median else 1.1, ls="-" if median else (0, (4, 2))
        )
        ax.axvline(float(val), **line)
        handles.append(Line2D([], [], label=f"{_ordinal(p)} {_fmt(float(val), scale)}{sep}{unit}", **line))
    if math.isfinite(nom):
        style: dict[str, Any] = dict(color=FAILED_COLOR, lw=1.2, ls="-.")
        ax.axvline(nom, **style)
        handles.append(Line2D([], [], label=f"nominal {_fmt(nom, scale)}{sep}{unit}", **style))
    std = f"{_fmt(sample_std(v), scale)}{sep}{unit}" if v.size > 1 else "–"
    head = f"mean {_fmt(float(np.mean(v)), scale)}{sep}{unit}, σ {std}\n{_count(v.size, 'variant')}"
    if v.size < n_feas:
        head += f" ({n_feas - v.size:,} without value)"
    if spread == 0:
        head += ", all equal"
    ax.set_xlim(lo - pad, hi + pad)
    scale = _tidy(ax.xaxis, 5)
    ax.yaxis.set_major_locator(MaxNLocator(nbins=4, integer=True))
    # Headroom above the bars for the legend: its lines take about 0.15 in each of the axes'
    # ~2 in, so the bars stay below it whatever the shape of the distribution.
    lines = len(handles) + head.count("\n") + 1
    frac = min(0.7, (0.15 * lines + 0.12) / (panel_h - 0.75))
    ax.set_ylim(0, max(1.0, float(np.max(counts))) / (1.0 - frac))
    ax.legend(
        handles=handles,
        title=head,
        title_fontsize=7,
        fontsize=7,
        loc="upper right",
        alignment="left",
        handlelength=1.8,
        borderaxespad=0.3,
        framealpha=0.85,
    )
    return scale


def _bin_count(v: np.ndarray) -> int:
    """Bars for the histogram of ``v`` (n,): Freedman-Diaconis (or Sturges where the
    quartiles coincide), 10 to 80, so a few outliers far out cannot ask for millions of bins."""
    q1, q3 = np.percentile(v, [25, 75])
    span = float(np.ptp(v))
    width = 2.0 * float(q3 - q1) / v.size ** (1 / 3)
    n = span / width if width > 0 else math.log2(v.size) + 1
    return int(np.clip(math.ceil(n), 10, 80))


def feasible_region(
    title: str,
    x: Column,
    y: Column,
    grid_x: np.ndarray,
    grid_y: np.ndarray,
    feasible: np.ndarray,
    metrics: Sequence[Column],
    limits: Mapping[str, tuple[float | None, float | None]] | None,
    out_dir: Path | str,
    name: str = "region.png",
    nominal: Mapping[str, float] | None = None,
) -> Path | None:
    """``name``: metrics over a grid of two parameters, one panel each, and where the design
    assembles and meets its limits.

    Args:
      title: the study's title (drawn literally).
      x, y: the two parameters (only their names, labels and units are used).
      grid_x: (nx,) values of ``x``; grid_y: (ny,) values of ``y`` (their units; any order).
      feasible: (ny, nx) bool (or (ny*nx,), row-major): infeasible cells are hatched grey.
      metrics: columns of (ny, nx) values (or (ny*nx,)), drawn as filled contours with a
        colour bar in their unit; cells without a value are pale grey.
      limits: metric name -> (low, high) admissible bounds (None: open; the metric's unit).
        The bound is drawn as a thick contour, the inadmissible side washed out, and a first
        panel shows the admissible region: the variants that assemble and meet every limit.
        Limits of metrics not drawn are ignored.
      nominal: column name -> nominal value: the nominal design (x, y) as a star.
    Returns the path, or None for an empty grid.

    Cells are the nearest-grid-point areas around each variant: the hatched region is the
    variants that failed, not an interpolation between them.
    """
    gx, gy = np.asarray(grid_x, dtype=float).ravel(), np.asarray(grid_y, dtype=float).ravel()
    nx, ny = gx.size, gy.size
    if nx == 0 or ny == 0:
        return None
    # Grids are drawn ascending whatever order the study listed them in.
    ox, oy = np.argsort(gx, kind="stable"), np.argsort(gy, kind="stable")
    gx, gy = gx[ox], gy[oy]

    def cells(values: np.ndarray, what: str) -> np.ndarray:
        a = np.asarray(values)
        if a.size != nx * ny:
            raise ValueError(f"{what} has {a.size} values, expected {ny} x {nx} = {nx * ny}")
        return a.reshape(ny, nx)[np.ix_(oy, ox)]

    feas = cells(feasible, "feasible").astype(bool)
    Z = [np.where(feas, cells(np.asarray(m.values, dtype=float), f"column {m.name!r}"), np.nan) for m in metrics]
    limits = {k: v for k, v in (limits or {}).items() if v[0] is not None or v[1] is not None}
    limited = [(m, z, limits[m.name]) for m, z in zip(metrics, Z) if m.name in limits]
    nominal = nominal or {}
    xe, ye = _edges(gx), _edges(gy)

    panels = len(metrics) + (1 if limited or not metrics else 0)
    rows, cols = _grid(panels, 3)
    panel_w, panel_h = 3.9, 3.1
    fig_w = max(7.5, panel_w * cols + 0.4)
    fig, axs = subplots(
        rows,
        cols,
        figsize=(fig_w, 1.3 + panel_h * rows),
        sharex=True,
        sharey=True,
        squeeze=False,
        layout="constrained",
    )
    _hide_unused(axs, panels)
    used = list(axs.flat[:panels])
    k = 0
    if limited or not metrics:
        ok = feas.copy()
        conds = []
        for m, z, (lo, hi) in limited:
            with np.errstate(invalid="ignore"):
                ok &= np.isfinite(z) & (z >= (-np.inf if lo is None else lo)) & (z <= (np.inf if hi is None else hi))
            conds.append(_condition(m, lo, hi))
        ax = used[0]
        _cells(ax, ok, xe, ye, fc=ADMISSIBLE_FACE)
        head = "admissible: assembles" + (" and " + ", ".join(conds) if conds else "")
        ax.set_title(
            _wrap(head, _chars(panel_w - 0.2, 9)) + f"\n{int(ok.sum()):,} of {_count(nx * ny, 'variant')}", fontsize=9
        )
        if nx * ny <= 900:
            # The grid's points, so its resolution (and a staircase edge's cause) shows.
            gxx, gyy = np.meshgrid(gx, gy)
            ax.plot(gxx.ravel(), gyy.ravel(), ".", ms=1.2, color="0.5", zorder=3)
        k = 1
    for m, z in zip(metrics, Z):
        ax = used[k]
        k += 1
        _metric_panel(fig, ax, m, z, gx, gy, xe, ye, limits.get(m.name))
        ax.set_title(_wrap(m.label or m.name, _chars(panel_w - 0.9, 9), 2), fontsize=9)
    for ax in used:
        # The hatch takes the edge colour (the edge itself is not drawn: lw 0), in every matplotlib.
        _cells(ax, ~feas, xe, ye, fc=HATCH_FACE, ec=HATCH_LINES, hatch="////", zorder=2.5)
        if math.isfinite(nominal.get(x.name, math.nan)) and math.isfinite(nominal.get(y.name, math.nan)):
            ax.plot(nominal[x.name], nominal[y.name], "*", ms=11, mfc="white", mec="k", mew=1.0, zorder=6)
        ax.set_xlim(xe[0], xe[-1])
        ax.set_ylim(ye[0], ye[-1])
        ax.tick_params(labelsize=7.5)
        # Shared axes: every panel's scale is the same.
        x_scale, y_scale = _tidy(ax.xaxis), _tidy(ax.yaxis)
    for i, ax in enumerate(axs.flat):
        c = i % cols
        # The last panel of a column shows the x axis (a short last row leaves it one row up).
        if i < panels and i + cols >= panels:
            ax.set_xlabel(_wrap(_with_unit(x, x_scale), _chars(panel_w - 0.5, 8.5)), fontsize=8.5)
            ax.xaxis.set_tick_params(labelbottom=True)
        elif i < panels:
            ax.xaxis.set_tick_params(labelbottom=False)
        if c == 0:
            ax.set_ylabel(_wrap(_with_unit(y, y_scale), _chars(panel_h - 0.5, 8.5)), fontsize=8.5)
        else:
            ax.yaxis.set_tick_params(labelleft=False)

    handles: list[Patch | Line2D] = []
    if not feas.all():
        label = f"{INFEASIBLE} ({int((~feas).sum()):,})"
        handles.append(Patch(fc=HATCH_FACE, hatch="////", ec=HATCH_LINES, lw=0, label=label))
    if any((feas & ~np.isfinite(z)).any() for z in Z):
        handles.append(Patch(fc=NO_VALUE_FACE, ec="0.7", lw=0.5, label="no value computed"))
    if limited or not metrics:
        handles.append(Patch(fc=ADMISSIBLE_FACE, label="admissible"))
    if limited:
        handles.append(Patch(fc="white", ec="0.6", lw=0.5, label="assembles, beyond a limit"))
        handles.append(Line2D([], [], color="k", lw=2.4, label="limit"))
        # The veil shown over a colour of the panels' map: on white it would be white too.
        washed = matplotlib.colors.to_rgb(matplotlib.colormaps["viridis"](0.5))
        veiled = tuple(VEIL[3] * VEIL[k] + (1.0 - VEIL[3]) * washed[k] for k in range(3))
        handles.append(Patch(fc=veiled, ec="0.6", lw=0.5, label="beyond the limit (washed out)"))
    if math.isfinite(nominal.get(x.name, math.nan)) and math.isfinite(nominal.get(y.name, math.nan)):
        handles.append(Line2D([], [], ls="none", marker="*", ms=10, mfc="white", mec="k", label="nominal"))
    if handles:  # a grid that all assembles, without limits or nominal, needs no key
        fig.legend(handles=handles, loc="outside lower center", ncol=min(len(handles), 5), fontsize=8, frameon=False)
    what = f"over a {nx} × {ny} grid of {x.name} and {y.name}"
    fig.suptitle(_wrap(title, _chars(fig_w - 0.4, 10), 2) + "\n" + _wrap(what, _chars(fig_w - 0.4, 10), 2), fontsize=10)
    return _write(fig, out_dir, name)


def _condition(m: Column, lo: float | None, hi: float | None) -> str:
    """'stroke of P5 ≤ 40 mm', '10 ≤ transmission ≤ 170 deg' (raw text)."""
    u = f" {_shown_unit(m.unit)}" if m.unit.strip() else ""
    label = m.label or m.name
    if lo is not None and hi is not None:
        return f"{lo:g} ≤ {label} ≤ {hi:g}{u}"
    return f"{label} ≥ {lo:g}{u}" if lo is not None else f"{label} ≤ {hi:g}{u}"


def _edges(g: np.ndarray) -> np.ndarray:
    """(n+1,) cell edges around the grid values ``g`` (n,): halfway between neighbours, half a
    step beyond the ends (one value: a cell of 10 % of it, or 1)."""
    if g.size == 1:
        d = 0.05 * abs(float(g[0])) or 0.5
        return np.array([g[0] - d, g[0] + d])
    mid = 0.5 * (g[1:] + g[:-1])
    return np.concatenate([[2 * g[0] - mid[0]], mid, [2 * g[-1] - mid[-1]]])


def _cells(ax: Axes, mask: np.ndarray, xe: np.ndarray, ye: np.ndarray, **patch: object) -> None:
    """The cells of ``mask`` (ny, nx) as one patch: runs of cells along a row as one rectangle
    each, all in one path, so the fill and its hatching have no seams between cells."""
    verts: list[list[tuple[float, float]]] = []
    for j in range(mask.shape[0]):
        row = np.concatenate([[False], mask[j], [False]])
        starts = np.flatnonzero(row[1:] & ~row[:-1])
        ends = np.flatnonzero(~row[1:] & row[:-1])
        for a, b in zip(starts, ends):
            x0, x1, y0, y1 = xe[a], xe[b], ye[j], ye[j + 1]
            verts.append([(x0, y0), (x1, y0), (x1, y1), (x0, y1), (x0, y0)])
    if not verts:
        return
    codes = [MplPath.MOVETO, MplPath.LINETO, MplPath.LINETO, MplPath.LINETO, MplPath.CLOSEPOLY]
    path = MplPath(np.concatenate(verts), codes * len(verts))
    ax.add_patch(PathPatch(path, lw=0, **patch))


def _metric_panel(
    fig: Figure,
    ax: Axes,
    m: Column,
    z: np.ndarray,
    gx: np.ndarray,
    gy: np.ndarray,
    xe: np.ndarray,
    ye: np.ndarray,
    limit: tuple[float | None, float | None] | None,
) -> None:
    """One metric's panel: filled contours, its limit and colour bar (the infeasible cells are
    hatched over it afterwards)."""
    have = np.isfinite(z)
    unit = _unit(m.unit)
    _cells(ax, ~have, xe, ye, fc=NO_VALUE_FACE, zorder=2.4)
    if not have.any():
        ax.text(
            0.5, 0.5, "no value", transform=ax.transAxes, ha="center", va="center", fontsize=9, bbox=TEXT_BOX, zorder=7
        )
        return
    lo, hi = float(z[have].min()), float(z[have].max())
    # A metric the design holds fixed (a synthesized stroke) varies by the solver's rounding
    # only: contours of that noise would look like structure. Within 1 ppm it is one colour.
    constant = hi - lo <= 1e-6 * max(abs(lo), abs(hi))
    mid = 0.5 * (lo + hi)
    if not constant:
        levels = MaxNLocator(nbins=10).tick_values(lo, hi)
    else:
        d = 0.05 * abs(mid) or 1.0
        levels = np.array([mid - d, mid + d])
    # Each cell takes its nearest variant's value where there is none: the colours reach the
    # cell edges, where the hatched (or pale) cells on top begin, rather than stopping one
    # half-cell short. The filled values are always covered.
    from scipy import ndimage  # here: scipy.ndimage, only for a filled grid

    idx = ndimage.distance_transform_edt(~have, return_distances=False, return_indices=True)
    zf = z[tuple(idx)]
    small = gx.size < 2 or gy.size < 2
    if small:
        # Contours need two values each way: a row or column of cells instead.
        cs = ax.pcolormesh(xe, ye, zf, cmap="viridis", vmin=levels[0], vmax=levels[-1], zorder=1)
        if limit is not None:
            # No contour to draw: the cells beyond a bound are washed out.
            beyond = np.zeros(zf.shape, dtype=bool)
            if limit[0] is not None:
                beyond |= zf < limit[0]
            if limit[1] is not None:
                beyond |= zf > limit[1]
            _cells(ax, beyond, xe, ye, fc=VEIL, zorder=1.5)
    else:
        # Contours between grid points; the outer half-cells repeat the edge values.
        xs, ys = np.concatenate([[xe[0]], gx, [xe[-1]]]), np.concatenate([[ye[0]], gy, [ye[-1]]])
        zp = np.pad(zf, 1, mode="edge")
        cs = ax.contourf(xs, ys, zp, levels=levels, cmap="viridis", extend="neither", zorder=1)
        if limit is not None:
            _limit(ax, xs, ys, zp, limit, unit)
    cb = fig.colorbar(cs, ax=ax, pad=0.02, fraction=0.08, aspect=25)
    cb.ax.tick_params(labelsize=7)
    times = _times(_tidy(cb.ax.yaxis, 6))
    cb.set_label(f"[{' '.join(t for t in (times, unit) if t)}]" if times or unit else "[-]", fontsize=8)
    if constant:
        cb.set_ticks([mid])
        spread = f" ± {0.5 * (hi - lo):.1g}" if hi > lo else ""
        ax.text(
            0.5,
            0.92,
            f"constant: {_fmt(mid, 0)}{spread} {unit}".rstrip(),
            transform=ax.transAxes,
            ha="center",
            va="top",
            fontsize=8,
            bbox=TEXT_BOX,
            zorder=7,
        )


def _limit(
    ax: Axes, xs: np.ndarray, ys: np.ndarray, z: np.ndarray, limit: tuple[float | None, float | None], unit: str
) -> None:
    """A metric's admissible bounds on its panel: each bound's contour thick and labelled, the
    side beyond it washed out."""
    zmin, zmax = float(z.min()), float(z.max())
    eps = 1e-9 * max(1.0, abs(zmin), abs(zmax))
    lo, hi = limit
    # The value ranges beyond each bound that occur (all of it if the bound is outside the range).
    beyond = []
    if lo is not None and zmin < lo:
        beyond.append((zmin - eps, min(lo, zmax + eps)))
    if hi is not None and zmax > hi:
        beyond.append((max(hi, zmin - eps), zmax + eps))
    for a, b in beyond:
        ax.contourf(xs, ys, z, levels=[a, b], colors=[VEIL], zorder=1.5)
    for bound in (lo, hi):
        if bound is not None and zmin < bound < zmax:
            cl = ax.contour(xs, ys, z, levels=[bound], zorder=2, **LIMIT_STYLE)
            # A callable, not a format string: a unit such as '%' would be read as a format.
            label = f"{bound:g} {unit}".strip()
            ax.clabel(cl, fmt=lambda _level, label=label: label, fontsize=8, inline=True, inline_spacing=3)


def _write(fig: Figure, out_dir: Path | str, name: str) -> Path:
    """:func:`.style.save`, with matplotlib's offset and exponent texts at the axes' ends
    hidden: :func:`_tidy` puts the scale in the axis label instead (showing a panel's tick
    labels turns them on again, so this is done last)."""
    for ax in fig.axes:
        ax.xaxis.get_offset_text().set_visible(False)
        ax.yaxis.get_offset_text().set_visible(False)
    return save(fig, out_dir, name)
