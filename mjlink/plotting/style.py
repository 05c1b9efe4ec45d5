"""The look every figure shares, and the one way a figure is written to disk.

Line styles (MuJoCo solid, wide and translucent; the reference dashed on top in black or a
darker tone of the same hue, so both stay visible where they coincide, which is the expected
case; the paper's RK4 dotted), legend labels, titles, crank-angle axes and :func:`save`.

Crank angles are plotted in degrees, unwrapped from the traces; a crank turning clockwise is
plotted against the angle turned from phi0 (the axis label says so), so every angle axis
runs left to right with time.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import matplotlib.colors
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.typing import ColorType

from ..errors import OutputError
from ..model.mechanism import Mechanism
from ..output import atomic_path
from ..runs import Trace

DPI = 120

MJ_STYLE: dict[str, Any] = dict(lw=2.2, alpha=0.75, solid_capstyle="butt")
REF_STYLE: dict[str, Any] = dict(lw=1.1, ls=(0, (4, 3)), color="k")
RK4_STYLE: dict[str, Any] = dict(lw=1.0, ls=":", color="tab:red")

MJ_LABEL = "MuJoCo"
REF_LABEL = "reference (vector method)"


def save(fig: Figure, out_dir: Path | str, name: str, tight: bool = False) -> Path:
    """Write ``fig`` as the PNG ``out_dir/name`` (folder created if missing) atomically, close
    it, return the path; a failure to write is a one-line OutputError.

    ``tight``: crop (or grow) the canvas to what is drawn, for equal-aspect drawings whose
    axes box the layout engine cannot size exactly."""
    out = Path(out_dir)
    path = out / name
    try:
        try:
            out.mkdir(parents=True, exist_ok=True)
        except OSError as e:
            raise OutputError(f"{path}: cannot write plot: {e.strerror or e}") from None
        crop: dict[str, Any] = dict(bbox_inches="tight", pad_inches=0.12) if tight else {}
        with atomic_path(path, suffix=".png") as tmp:
            fig.savefig(tmp, format="png", dpi=DPI, **crop)
    finally:
        plt.close(fig)
    return path


def deg(phi: Any) -> np.ndarray:
    """Degrees from radians (scalar or array)."""
    return np.degrees(np.asarray(phi, dtype=float))


def user_text(text: str) -> str:
    """Text from a mechanism file (or any user) made safe to draw: every ``$`` escaped, so that
    matplotlib's mathtext never parses it (a title like 'a $5 part, $x^$' would crash the
    figure), and control characters shown as escapes. Every style helper that draws user text
    passes it through here; mathtext that mjlink writes itself (``$\\omega_0$``) stays as is."""
    shown = "".join(c if c.isprintable() else ascii(c)[1:-1] for c in text)
    return shown.replace("$", r"\$")


def title(mech: Mechanism, what: str) -> str:
    """A figure title: the mechanism's name, what the figure shows (mjlink's own text, which may
    hold mathtext), and the mechanism's title from its file (drawn literally: :func:`user_text`)."""
    return f"{mech.name}: {what}\n{user_text(mech.title)}"


def angle_ticks(ax: Axes, lo: float, hi: float) -> None:
    """Crank-angle ticks (deg) on round fractions or multiples of a turn, so cycles read at a
    glance; the x range set to ``lo``..``hi``."""
    span = hi - lo
    step = next((s for s in (30, 45, 90, 180, 360, 720, 1800, 3600, 7200, 18000) if span / s <= 9), 36000)
    ax.set_xticks(np.arange(math.ceil(lo / step) * step, hi + 1e-9, step))
    ax.set_xlim(lo, hi)


def darker(color: ColorType) -> tuple[float, float, float]:
    """A darker tone of ``color``: the reference's line beside MuJoCo's in that colour."""
    r, g, b = matplotlib.colors.to_rgb(color)
    return (0.55 * r, 0.55 * g, 0.55 * b)


def pair(ax: Axes, x_mj: Any, y_mj: Any, x_ref: Any, y_ref: Any, color: str, what: str = "") -> None:
    """MuJoCo solid (wide, translucent) with the reference dashed on top in a darker tone."""
    sep = " " if what else ""
    ax.plot(x_mj, y_mj, color=color, label=f"{what}{sep}{MJ_LABEL}", **MJ_STYLE)
    style = dict(REF_STYLE)
    if what:
        # Several quantities share the panel: keep the hue so each dashed line finds its twin.
        style["color"] = darker(color)
    ax.plot(x_ref, y_ref, label=f"{what}{sep}reference", **style)


def crank_axis(mech: Mechanism, phi: np.ndarray) -> tuple[Callable[[Any], np.ndarray], str]:
    """How to plot the crank angles of a run whose input angles are ``phi`` (rad): a function
    from input angles (rad) to abscissae (deg) and the axis label that says which they are.

    A crank turning counter-clockwise is plotted against its unwrapped angle phi1. One turning
    clockwise (phi1 decreasing, as the needle-bar drives) is plotted against the angle turned
    from phi01, phi01 - phi1, so the axis still runs left to right with time from 0.
    """
    phi = np.asarray(phi)
    if phi[-1] >= phi[0]:
        return deg, "crank angle $\\varphi_1$ [deg]"
    return (
        lambda p: deg(mech.phi0 - np.asarray(p, dtype=float)),
        "crank angle turned clockwise, $\\varphi_{01} - \\varphi_1$ [deg] "
        f"($\\varphi_{{01}}$ = {math.degrees(mech.phi0):g}°)",
    )


def crank_x(mech: Mechanism, *traces: Trace) -> tuple[list[np.ndarray], str]:
    """Crank-angle abscissae (deg) of ``traces``, all as the first one's (see :func:`crank_axis`),
    and the axis label."""
    f, label = crank_axis(mech, traces[0].phi)
    return [f(t.phi) for t in traces], label


def finish_x(ax: Axes, xs: list[np.ndarray], label: str) -> None:
    """Label a crank-angle axis and tick it over the range of all abscissae ``xs`` (deg)."""
    ax.set_xlabel(label)
    angle_ticks(ax, min(float(np.min(x)) for x in xs), max(float(np.max(x)) for x in xs))
