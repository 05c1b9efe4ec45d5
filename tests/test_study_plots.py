"""Study figures: valid PNGs for ordinary and degenerate tables, text that does not collide."""

from __future__ import annotations

from pathlib import Path

import matplotlib.image
import numpy as np
import pytest

from mjlink.plotting import study as sp


def _cols(n: int, seed: int = 0) -> tuple[list[sp.Column], list[sp.Column], np.ndarray]:
    rng = np.random.default_rng(seed)
    params = [
        sp.Column(f"construct.P{i}.length", f"construct.P{i}.length", "mm", 20 + rng.normal(size=n)) for i in range(3)
    ]
    feasible = rng.random(n) > 0.1
    m1 = params[0].values * 2 + rng.normal(size=n)
    m2 = np.where(feasible, rng.random(n), np.nan)
    metrics = [sp.Column("stroke_P5", "stroke of P5", "mm", m1), sp.Column("torque_peak", "peak torque", "N*m", m2)]
    return params, metrics, feasible


def _png(p: Path | None) -> np.ndarray:
    assert p is not None and p.is_file()
    return matplotlib.image.imread(p)


@pytest.mark.parametrize("n", [1, 7, 3000])
def test_each_figure_is_written(tmp_path: Path, n: int) -> None:
    params, metrics, feasible = _cols(n)
    verified = np.where(np.arange(n) % 3 == 0, 1, -1).astype(np.int8)
    verified[-1] = 0
    img = _png(
        sp.scatter_matrix("t $x$", params, metrics, feasible, verified, tmp_path, nominal={params[0].name: 20.0})
    )
    assert img.shape[0] > 200
    _png(sp.histograms("t", metrics, feasible, tmp_path))


def test_degenerate_tables_draw_without_error(tmp_path: Path) -> None:
    params, metrics, _ = _cols(50)
    none = np.zeros(50, dtype=bool)
    _png(sp.scatter_matrix("all infeasible", params, metrics, none, np.full(50, -1, np.int8), tmp_path, "a.png"))
    _png(sp.histograms("all infeasible", metrics, none, tmp_path, "b.png"))
    flat = [sp.Column("c", "constant", "mm", np.full(50, 45.0)), sp.Column("n", "all NaN", "", np.full(50, np.nan))]
    _png(sp.histograms("flat", flat, np.ones(50, bool), tmp_path, "c.png"))
    assert sp.scatter_matrix("none", [], metrics, none, none.astype(np.int8), tmp_path) is None


def test_region_marks_infeasible_cells_and_the_bound(tmp_path: Path) -> None:
    gx, gy = np.linspace(0, 25, 26), np.linspace(0.2, 0.5, 31)
    X, Y = np.meshgrid(gx, gy)
    theta = 20 + 60 * (Y - 0.2) + X
    feasible = theta < 75
    metrics = [
        sp.Column("pressure_max", "maximum pressure angle", "deg", np.where(feasible, theta, np.nan)),
        sp.Column("stroke", "stroke", "mm", np.full(X.shape, 45.0) + 1e-9 * X),
    ]
    x = sp.Column("synthesis.offset", "synthesis.offset", "mm", X.ravel())
    y = sp.Column("synthesis.lambda", "synthesis.lambda", "", Y.ravel())
    p = sp.feasible_region("grid", x, y, gx, gy, feasible, metrics, {"pressure_max": (None, 40.0)}, tmp_path)
    _png(p)


def test_panel_texts_do_not_overlap(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Titles and axis labels of neighbouring panels stay apart (rendered extents)."""
    import matplotlib.pyplot as plt

    figs = []
    monkeypatch.setattr(sp, "save", lambda fig, out, name, **kw: figs.append(fig) or Path(out) / name)
    params, metrics, feasible = _cols(200)
    sp.histograms("h", metrics * 3, feasible, tmp_path)
    sp.scatter_matrix("s", params, metrics, feasible, np.full(200, -1, np.int8), tmp_path)
    for fig in figs:
        fig.canvas.draw()
        r = fig.canvas.get_renderer()
        boxes = []
        for ax in fig.axes:
            for t in (ax.title, ax.xaxis.label, ax.yaxis.label):
                if t.get_text() and t.get_visible():
                    boxes.append(t.get_window_extent(r))
        for i, a in enumerate(boxes):
            for b in boxes[i + 1 :]:
                assert not a.overlaps(b), "two panels' texts overlap"
        plt.close(fig)
