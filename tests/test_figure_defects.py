"""What :func:`mjlink.plotting.style.figure_defects` finds, each class on a small figure made
to have it and on its clean twin: a label a curve runs through, legend entries a reader cannot
tell apart, a legend's words that contradict its key, an offset label running into the panel
above. The shipped figures are held to the same function by .ci/check_figures.py and
tests/test_figures.py, so the next figure with one of these defects fails CI."""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np
import pytest
from matplotlib.lines import Line2D
from matplotlib.patches import Patch

from mjlink.plotting import style

X = np.linspace(0.0, 10.0, 400)


def _panel():
    fig, ax = plt.subplots(figsize=(6.0, 4.0))
    fig.subplots_adjust(left=0.15, bottom=0.15)  # every label on the canvas, in every matplotlib
    ax.plot(X, np.sin(X), label="sin")
    ax.set_xlabel("x [mm]")
    ax.set_ylabel("y [mm]")
    ax.set_ylim(-1.5, 1.5)
    return fig, ax


@pytest.fixture(autouse=True)
def _close():
    yield
    plt.close("all")


def test_a_label_a_curve_runs_through_is_found_and_one_beside_it_is_not():
    fig, ax = _panel()
    ax.text(np.pi, 0.0, "on the curve", ha="center", va="center")
    found = style.figure_defects(fig)
    assert any("runs through the label 'on the curve'" in d for d in found), found
    fig, ax = _panel()
    ax.text(np.pi, 1.3, "above the curve", ha="center", va="center")
    assert style.figure_defects(fig) == []


def test_a_reference_line_across_the_panel_is_not_a_curve():
    """A zero line or a threshold (two points) may pass a label: it is not read as data."""
    fig, ax = _panel()
    ax.axhline(1.3, color="0.5")
    ax.text(np.pi, 1.3, "threshold", ha="center", va="center")
    assert style.figure_defects(fig) == []


def test_an_annotations_leader_line_is_not_its_text():
    fig, ax = _panel()
    ax.annotate("peak", (np.pi / 2, 1.0), xytext=(np.pi / 2, 1.35), arrowprops=dict(arrowstyle="-"), ha="center")
    assert style.figure_defects(fig) == []


@pytest.mark.parametrize(
    ("handles", "alike"),
    [
        ([Patch(fc="white", ec="0.6", label="a"), Patch(fc=(1, 1, 1, 0.62), ec="0.6", label="b")], True),
        ([Line2D([], [], color="k", label="a"), Line2D([], [], color="k", label="b")], True),
        ([Line2D([], [], color="k", label="a"), Line2D([], [], color="k", ls="--", label="b")], False),
        ([Patch(fc="white", ec="0.6", label="a"), Patch(fc="#9fd0cc", ec="0.6", label="b")], False),
        ([Patch(fc="white", ec="k", label="a"), Patch(fc="white", ec="k", hatch="///", label="b")], False),
    ],
)
def test_legend_entries_that_look_alike_are_found(handles, alike):
    fig, ax = _panel()
    ax.legend(handles=handles, loc="lower left")
    found = [d for d in style.figure_defects(fig) if "look alike" in d]
    assert bool(found) == alike, found


@pytest.mark.parametrize(
    ("handle", "wrong"),
    [
        (Patch(fc="tab:red", label="MuJoCo (dashed)"), True),
        (Patch(fc="white", ec="k", hatch="///", label="reference (solid)"), True),
        (Line2D([], [], color="k", label="reference (hatched)"), True),
        (Line2D([], [], color="k", ls=(0, (1, 1.6)), label="RK4 (dotted)"), False),
        (Patch(fc="white", ec="k", hatch="///", label="reference (hatched)"), False),
        (Line2D([], [], color="k", label="reference (solid)"), False),
    ],
)
def test_a_legend_word_that_contradicts_its_key_is_found(handle, wrong):
    fig, ax = _panel()
    ax.legend(handles=[handle], loc="lower left")
    found = [d for d in style.figure_defects(fig) if "of a key that is not" in d]
    assert bool(found) == wrong, found


def test_an_offset_label_in_the_panel_above_is_found_and_a_power_in_the_unit_is_not(tmp_path):
    """Residuals of 1e-6 deg: matplotlib's offset label would sit in the panel above; the
    residual panel puts the power of ten in its unit instead."""
    fig, (ax, rax) = plt.subplots(2, 1, figsize=(6.0, 4.0), sharex=True)
    fig.subplots_adjust(left=0.18, bottom=0.15, hspace=0.02)
    ax.plot(X, np.sin(X))
    ax.set_ylabel("y [deg]")
    rax.plot(X, 1e-6 * np.cos(X) + 1.0)
    rax.set_ylabel("Δ [deg]")
    rax.set_xlabel("x [deg]")
    found = style.figure_defects(fig)
    assert any("offset label" in d for d in found), found
    fig, (ax, rax) = plt.subplots(2, 1, figsize=(6.0, 4.0), sharex=True)
    fig.subplots_adjust(left=0.18, bottom=0.15, hspace=0.02)
    ax.plot(X, np.sin(X))
    ax.set_ylabel("y [deg]")
    style.residual(rax, X, 1e-6 * np.cos(X), "deg", None)
    rax.set_xlabel("x [deg]")
    assert not any("offset label" in d for d in style.figure_defects(fig))
    assert rax.get_ylabel().endswith("[×10⁻⁶ deg]")


def test_every_link_of_a_head_has_a_colour_of_its_own_in_the_drawing_and_on_the_page():
    """The head's eleven links (and up to twenty) in colours a reader tells apart, the same in
    positions.png and design.html."""
    import matplotlib.colors

    from mjlink.pages import design as design_page
    from mjlink.plotting import drawing

    drawn = [matplotlib.colors.to_hex(c) for c in drawing.link_colors(20)]
    assert len(set(drawn)) == 20
    assert drawn == list(design_page.COLORS)
