"""Design-study figures: valid PNGs for ordinary and degenerate tables, what they show, legible
text (rendered extents of neighbouring panels' texts apart) and the drawing time of a large study."""

from __future__ import annotations

import itertools
import statistics
import warnings
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.contour import ContourSet
from matplotlib.figure import Figure
from matplotlib.text import Text
from matplotlib.transforms import Bbox

from mjlink.plotting import study as sp

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"
NASTY = "a $5 part, $x^$ \x07"  # mathtext would fail on it; a control character


@pytest.fixture
def figures(monkeypatch: pytest.MonkeyPatch) -> list[Figure]:
    """The figures the module writes, kept (still written by the real writer) for inspection."""
    kept: list[Figure] = []
    real = sp.save

    def keep(fig: Figure, out_dir: Any, name: str, **kw: Any) -> Path:
        kept.append(fig)
        return real(fig, out_dir, name, **kw)

    monkeypatch.setattr(sp, "save", keep)
    return kept


def _png(p: Path | None) -> tuple[int, int]:
    """(width, height) in pixels of the PNG at ``p``, checked to be one of a readable size."""
    assert p is not None and p.is_file()
    data = p.read_bytes()
    assert data.startswith(PNG_MAGIC) and data[12:16] == b"IHDR"
    size = (int.from_bytes(data[16:20], "big"), int.from_bytes(data[20:24], "big"))
    assert size[0] > 400 and size[1] > 200, size
    return size


def _study(V: int, P: int = 3, M: int = 3, seed: int = 0) -> tuple[list[sp.Column], list[sp.Column], np.ndarray]:
    """P tolerance-like parameters (mm), M metrics (one with NaNs among the feasible), ~10 %
    infeasible variants (NaN metrics)."""
    rng = np.random.default_rng(seed)
    params = [
        sp.Column(
            f"construct.P{i}.length_a", f"l{i}_{i + 1} (construct.P{i}.length_a)", "mm", 20 + 0.05 * rng.normal(size=V)
        )
        for i in range(P)
    ]
    feasible = rng.random(V) > 0.1
    units = ["mm", "deg", "um", "N*m", "W", ""]
    metrics = []
    for k in range(M):
        v = 40 + 2 * (params[k % P].values - 20) + 0.01 * rng.normal(size=V)
        if k == 1:
            v[rng.random(V) < 0.05] = np.nan  # not computed for some feasible variants
        metrics.append(
            sp.Column(f"metric_{k}", f"metric {k} of P5", units[k % len(units)], np.where(feasible, v, np.nan))
        )
    return params, metrics, feasible


# ----------------------------------------------------------------------------- legibility
def _extent(t: Text, r: Any) -> Bbox | None:
    if not (t.get_visible() and t.get_text().strip()):
        return None
    return t.get_window_extent(r)


def _ticklabels(ax: Any) -> list[Text]:
    """The tick labels drawn: those of ticks inside the view."""
    out = []
    for axis in (ax.xaxis, ax.yaxis):
        lo, hi = sorted(axis.get_view_interval())
        tol = 1e-9 * max(1.0, abs(lo), abs(hi))
        for tick, loc in zip(axis.get_major_ticks(), axis.get_majorticklocs()):
            if lo - tol <= loc <= hi + tol:
                out += [tick.label1, tick.label2]
    return out


def assert_legible(fig: Figure) -> None:
    """No text of one panel (title, axis labels, tick labels, offsets) overlaps a text or the
    frame of another panel (colour bars included) or the figure's title and legends; the tick
    labels of one axis are apart; every text lies inside the figure."""
    # The writer closed the figure (leaving it a bare canvas): lay it out again on a fresh one,
    # without painting (the positions of the ticks and texts are what is checked).
    canvas = FigureCanvasAgg(fig)
    fig.draw_without_rendering()
    r = canvas.get_renderer()
    page = fig.bbox.padded(1.0)
    owners: list[tuple[int, Bbox, str]] = []
    frames = []
    for k, ax in enumerate(fig.axes):
        if not ax.get_visible():
            continue
        frames.append((k, ax.get_window_extent(r)))
        texts = [ax.title, ax._left_title, ax._right_title, ax.xaxis.label, ax.yaxis.label]
        texts += [ax.xaxis.get_offset_text(), ax.yaxis.get_offset_text()]
        ticks = [b for t in _ticklabels(ax) if (b := _extent(t, r)) is not None]
        for a, b in itertools.combinations(ticks, 2):
            assert not a.overlaps(b), f"tick labels of one axis overlap in panel {k}"
        owners += [(k, b, t.get_text()) for t in texts if (b := _extent(t, r)) is not None]
        owners += [(k, b, "tick") for b in ticks]
    for t in [fig._suptitle] if fig._suptitle is not None else []:
        owners += [(-1, b, t.get_text()) for b in [_extent(t, r)] if b is not None]
    for leg in fig.legends:
        owners += [(-2, b, t.get_text()) for t in leg.get_texts() if (b := _extent(t, r)) is not None]
    for _, box, text in owners:
        assert page.contains(box.x0, box.y0) and page.contains(box.x1, box.y1), f"{text!r} leaves the figure"
    for (k1, b1, t1), (k2, b2, t2) in itertools.combinations(owners, 2):
        if k1 != k2:
            assert not b1.overlaps(b2), f"{t1!r} overlaps {t2!r}"
    for k, box, text in owners:
        for kf, frame in frames:
            if kf != k:
                assert not box.overlaps(frame), f"{text!r} overlaps panel {kf}"


# ----------------------------------------------------------------------------- scatter matrix
def test_scatter_matrix_of_10000_variants_is_complete_and_legible(tmp_path: Path, figures: list[Figure]) -> None:
    V = 10_000
    params, metrics, feasible = _study(V, P=7, M=7)
    verified = np.full(V, -1, dtype=np.int8)
    verified[:60:2] = 1
    verified[1:12:2] = 0
    nominal = {c.name: 20.0 for c in params} | {"metric_0": 40.0}
    # Its speed goal is measured by bench/bench_study.py (bench_scatter), not here.
    path = sp.scatter_matrix(NASTY, params, metrics, feasible, verified, tmp_path, nominal=nominal)
    _png(path)
    (fig,) = figures
    axes = [ax for ax in fig.axes if ax.get_visible()]
    assert len(axes) == 36  # truncated to 6 x 6 ...
    # ... and names what it left out
    assert "not shown (in results.csv): construct.P6.length_a, metric_6" in fig._suptitle.get_text()
    assert "\\$5" in fig._suptitle.get_text()
    ax = axes[0]  # metric 0 against parameter 0
    (rug,) = [ln for ln in ax.lines if ln.get_marker() == "x"]
    assert len(rug.get_xdata()) == (~feasible).sum()  # every infeasible variant marked
    failed = [ln for ln in ax.lines if ln.get_markeredgecolor() == sp.FAILED_COLOR]
    assert sum(len(ln.get_xdata()) for ln in failed) == 6  # every failed check is ringed
    assert all(ln.get_rasterized() for ln in ax.lines if len(ln.get_xdata()) > 1000)
    assert_legible(fig)


@pytest.mark.parametrize("case", ["one variant", "all infeasible", "constant and never computed columns"])
def test_scatter_matrix_degenerate_tables(tmp_path: Path, case: str) -> None:
    V = 1 if case == "one variant" else 30
    params, metrics, feasible = _study(V, P=2, M=1)
    if case == "all infeasible":
        feasible[:] = False
        metrics = [sp.Column(m.name, m.label, m.unit, np.full(V, np.nan)) for m in metrics]
    else:
        params[1] = sp.Column("p", "fixed", "deg", np.full(V, 3.0))
        metrics.append(sp.Column("c", "constant", "W", np.full(V, 12.5)))
        metrics.append(sp.Column("none", "never computed", "N", np.full(V, np.nan)))
    _png(sp.scatter_matrix(case, params, metrics, feasible, np.zeros(V, dtype=np.int8), tmp_path, "s.png"))


def test_scatter_matrix_rings_failed_checks_but_not_a_crowd_of_passed_ones(
    tmp_path: Path, figures: list[Figure]
) -> None:
    V = 2500
    params, metrics, feasible = _study(V, P=1, M=1)
    verified = np.ones(V, dtype=np.int8)  # every variant checked, as mujoco = "all" does
    verified[:3] = 0
    sp.scatter_matrix("all checked", params, metrics, feasible, verified, tmp_path)
    (fig,) = figures
    rings = [ln for ln in fig.axes[0].lines if ln.get_marker() == "o" and ln.get_markerfacecolor() == "none"]
    assert not any(ln.get_markeredgecolor() == sp.PASSED_COLOR for ln in rings)
    assert sum(len(ln.get_xdata()) for ln in rings if ln.get_markeredgecolor() == sp.FAILED_COLOR) == 3
    legend = [t.get_text() for t in fig.legends[0].get_texts()]
    assert "MuJoCo check passed (2,497), not ringed: too many" in legend
    assert "MuJoCo check failed (3)" in legend


def test_extreme_magnitudes_are_scaled_in_the_axis_labels(tmp_path: Path, figures: list[Figure]) -> None:
    """Tick numbers of metres (1e-6) or newtons (1e9) are divided by a power of ten the label
    names, not printed as a factor at the axis's end, where it runs into the next panel."""
    rng = np.random.default_rng(3)
    V = 200
    params = [
        sp.Column("a", "clearance", "m", 1e-6 * (1 + 0.01 * rng.normal(size=V))),
        sp.Column("b", "preload", "N", 1e9 * (1 + 0.001 * rng.normal(size=V))),
    ]
    feasible = rng.random(V) > 0.2
    metrics = [
        sp.Column("m1", "power", "W", np.where(feasible, 3e8 + 1e6 * rng.normal(size=V), np.nan)),
        sp.Column("m2", "error", "um", np.where(feasible, 1e-7 * rng.random(V), np.nan)),
    ]
    _png(sp.scatter_matrix("magnitudes", params, metrics, feasible, None, tmp_path))
    (fig,) = figures
    labels = [ax.get_xlabel() for ax in fig.axes] + [ax.get_ylabel() for ax in fig.axes]
    for label in ("clearance [×10⁻⁶ m]", "preload [×10⁹ N]", "power [×10⁶ W]", "error [×10⁻⁹ µm]"):
        assert label in labels
    assert not any(ax.xaxis.get_offset_text().get_visible() for ax in fig.axes)
    assert_legible(fig)


def test_scatter_matrix_has_nothing_to_draw(tmp_path: Path) -> None:
    params, metrics, feasible = _study(5, P=1, M=1)
    assert sp.scatter_matrix("t", [], metrics, feasible, None, tmp_path) is None
    assert sp.scatter_matrix("t", params, [], feasible, None, tmp_path) is None
    with pytest.raises(ValueError, match=r"'construct\.P0\.length_a' has 5 values, expected 3"):
        sp.scatter_matrix("t", params, metrics, feasible[:3], None, tmp_path)
    assert list(tmp_path.iterdir()) == []


# ----------------------------------------------------------------------------- histograms
def test_histograms_list_percentiles_mean_and_spread(tmp_path: Path, figures: list[Figure]) -> None:
    V = 1001
    feasible = np.ones(V, dtype=bool)
    feasible[-1] = False
    values = np.where(feasible, np.linspace(0.0, 100.0, V), np.nan)
    _, metrics, _ = _study(V, M=2)
    metrics = [sp.Column("stroke_P5", "stroke of P5", "mm", values), metrics[1]]
    metrics.append(sp.Column("torque_peak", "peak torque", "N*m", np.where(feasible, 0.5, np.nan)))
    metrics.append(sp.Column("none", NASTY, "", np.full(V, np.nan)))
    path = sp.histograms(NASTY, metrics, feasible, tmp_path, nominal={"stroke_P5": 45.0})
    _png(path)
    (fig,) = figures
    leg = fig.axes[0].get_legend()
    texts = [t.get_text() for t in leg.get_texts()]
    q1, q50, q99 = np.percentile(values[:-1], [1, 50, 99])
    assert texts[:4] == [
        f"1st percentile {q1:.1f} mm",
        f"median {q50:.1f} mm",
        f"99th percentile {q99:.1f} mm",
        "nominal 45.0 mm",
    ]
    head = leg.get_title().get_text()
    assert f"mean {np.mean(values[:-1]):.1f} mm, σ {np.std(values[:-1], ddof=1):.1f} mm" in head
    assert "1,000 variants" in head
    assert "N·m" in fig.axes[2].get_legend().get_title().get_text()  # units as printed
    assert "1,000 of 1,001 variants that assemble" in fig._suptitle.get_text()
    assert_legible(fig)


def test_a_histogram_of_values_near_the_floats_range_states_their_spread(tmp_path: Path, figures: list[Figure]) -> None:
    """A thread under next to no tension has a margin to its breaking load of some 1e301: the
    spread is still stated (as Python's statistics module finds it in exact fractions), with no
    overflow warning."""
    v = np.array([0.5639, 1.6198e301, 1.6198e301 / 2])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        _png(sp.histograms("huge", [sp.Column("margin", "margin", "", v)], np.ones(3, dtype=bool), tmp_path))
    (fig,) = figures
    spread = statistics.stdev(v.tolist())  # in exact fractions
    assert f"σ {spread:.1e}" in fig.axes[0].get_legend().get_title().get_text()


def test_histograms_edge_cases(tmp_path: Path) -> None:
    _, metrics, feasible = _study(40, M=2)
    assert sp.histograms("t", metrics, np.zeros(40, dtype=bool), tmp_path) is None  # nothing assembles
    assert sp.histograms("t", [], feasible, tmp_path) is None
    one = [sp.Column("m", "one", "mm", np.array([2.0])), sp.Column("n", "none", "mm", np.array([np.nan]))]
    _png(sp.histograms("one variant", one, np.array([True]), tmp_path, "one.png", percentiles=(2.5, 50, 97.5)))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["one.png"]


# ----------------------------------------------------------------------------- feasible region
def _grid(
    nx: int = 21, ny: int = 16
) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[sp.Column], sp.Column, sp.Column]:
    gx, gy = np.linspace(10.0, 30.0, nx), np.linspace(0.2, 0.5, ny)
    X, Y = np.meshgrid(gx, gy)
    feasible = (X - 10) / 20 + (Y - 0.2) / 0.3 < 1.5
    theta = 20 + 60 * (Y - 0.2) + X
    metrics = [
        sp.Column("pressure_max", "maximum pressure angle", "deg", np.where(feasible, theta, np.nan)),
        sp.Column("stroke_P5", "stroke of P5", "mm", np.where(feasible, 30 + 0.5 * X, np.nan).ravel()),
        sp.Column("delta", "constant", "", np.where(feasible, 0.02, np.nan)),
        sp.Column("never", "never computed", "N", np.full(X.shape, np.nan)),
    ]
    x = sp.Column("synthesis.offset", "synthesis.offset", "mm", X.ravel())
    y = sp.Column("synthesis.lambda", NASTY, "", Y.ravel())
    return gx, gy, feasible, metrics, x, y


def test_feasible_region_hatches_infeasible_cells_and_draws_the_limit(tmp_path: Path, figures: list[Figure]) -> None:
    gx, gy, feasible, metrics, x, y = _grid()
    limits: dict[str, tuple[float | None, float | None]] = {"pressure_max": (None, 40.0), "unknown": (1.0, None)}
    nominal = {x.name: 18.0, y.name: 0.3}
    # metrics: with a limit, without, constant, never computed
    _png(sp.feasible_region(NASTY, x, y, gx, gy, feasible, metrics, limits, tmp_path, nominal=nominal))
    (fig,) = figures
    panels = [ax for ax in fig.axes if ax.get_visible() and ax.get_label() != "<colorbar>"]
    assert len(panels) == 5  # the admissible region, then one per metric
    theta = metrics[0].values
    n_ok = int((feasible & (theta <= 40.0)).sum())
    assert f"{n_ok:,} of {feasible.size:,} variants" in panels[0].get_title()
    levels = [list(c.levels) for c in panels[1].collections if isinstance(c, ContourSet) and not c.filled]
    assert levels == [[40.0]]  # the bound, drawn as a contour
    legend = [t.get_text() for t in fig.legends[0].get_texts()]
    assert f"cannot assemble / dead point ({int((~feasible).sum())})" in legend
    assert "nominal" in legend
    assert_legible(fig)


def test_feasible_region_grid_order_does_not_matter(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A grid listed in descending order draws the same cells and contours as in ascending."""
    kept: list[Figure] = []
    monkeypatch.setattr(sp, "save", lambda fig, out_dir, name, **kw: kept.append(fig) or Path(out_dir) / name)
    gx, gy, feasible, metrics, x, y = _grid(6, 5)
    metrics = metrics[:1]
    sp.feasible_region("t", x, y, gx, gy, feasible, metrics, None, tmp_path)
    flipped = [sp.Column(m.name, m.label, m.unit, np.asarray(m.values)[::-1, ::-1]) for m in metrics]
    sp.feasible_region("t", x, y, gx[::-1], gy[::-1], feasible[::-1, ::-1], flipped, None, tmp_path)

    def drawn(fig: Figure) -> list[np.ndarray]:
        ax = fig.axes[0]
        paths = [patch.get_path() for patch in ax.patches]
        paths += [path for coll in ax.collections for path in coll.get_paths()]
        return [path.vertices for path in paths]

    a, b = (drawn(fig) for fig in kept)
    assert len(a) == len(b) > 1
    assert all(np.array_equal(u, v) for u, v in zip(a, b))


@pytest.mark.parametrize("case", ["one column", "one cell", "all infeasible", "no metrics", "all feasible, no key"])
def test_feasible_region_degenerate_grids(tmp_path: Path, case: str) -> None:
    gx, gy, feasible, metrics, x, y = _grid(4, 3)
    metrics = metrics[:1]
    limits: dict[str, tuple[float | None, float | None]] = {"pressure_max": (None, 40.0)}
    if case == "one column":
        gx, feasible = gx[:1], feasible[:, :1]
        metrics = [sp.Column(m.name, m.label, m.unit, np.asarray(m.values).reshape(3, 4)[:, :1]) for m in metrics]
    elif case == "one cell":
        gx, gy, feasible = gx[:1], gy[:1], np.ones((1, 1), dtype=bool)
        metrics = [sp.Column("pressure_max", "p", "deg", np.array([[45.0]]))]
    elif case == "all infeasible":
        feasible = np.zeros_like(feasible)
        metrics = [sp.Column(m.name, m.label, m.unit, np.full(12, np.nan)) for m in metrics]
    elif case == "no metrics":
        metrics, limits = [], {}
    else:
        feasible = np.ones_like(feasible)
        metrics, limits = [sp.Column("s", "stroke", "mm", np.arange(12.0))], {}
    _png(sp.feasible_region(case, x, y, gx, gy, feasible, metrics, limits, tmp_path, "r.png"))


def test_feasible_region_rejects_a_misshapen_metric(tmp_path: Path) -> None:
    gx, gy, feasible, _, x, y = _grid(4, 3)
    bad = sp.Column("m", "m", "mm", np.zeros(5))
    with pytest.raises(ValueError, match="'m' has 5 values, expected 3 x 4"):
        sp.feasible_region("t", x, y, gx, gy, feasible, [bad], None, tmp_path)
    assert sp.feasible_region("t", x, y, gx[:0], gy, feasible[:, :0], [], None, tmp_path) is None
