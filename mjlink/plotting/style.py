"""The look every figure shares, and the one way a figure is written to disk.

Line styles: the reference a thin solid line (black, or a darker tone of the quantity's hue
where several share a panel), MuJoCo coloured dashes on top of it, so both stay visible
where they coincide, which is the expected case; the paper's RK4 dotted red. Residual panels
(:func:`residual`: MuJoCo minus the reference with the agreement threshold drawn), legend
labels, titles, crank-angle axes, :func:`text_overlaps` (the figure tests' check) and
:func:`save`. Colours of links, thread and key point are :mod:`mjlink.palette`'s, shared
with the video.

Crank angles are plotted in degrees as the angle the input crank has turned from its setting
phi01 (the file's phi0), unwrapped, in either sense of rotation, so every angle axis starts at
0 at the setting and runs left to right with time (:func:`crank_axis`; the axis label says so).
"""

from __future__ import annotations

import io
import itertools
import math
import re
import weakref
from collections.abc import Callable
from pathlib import Path
from typing import Any

import matplotlib
import matplotlib.artist
import matplotlib.axis
import matplotlib.cbook
import matplotlib.colors
import matplotlib.lines
import matplotlib.patches
import matplotlib.pyplot as plt
import matplotlib.text
import matplotlib.transforms
import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.typing import ColorType

from .. import palette
from ..errors import OutputError
from ..files import atomic_path
from ..model.mechanism import Mechanism
from ..runs import Trace

DPI = 120
TIGHT: dict[str, Any] = dict(bbox_inches="tight", pad_inches=0.12)  # savefig's cropping for save(tight=True)

MJ_STYLE: dict[str, Any] = dict(lw=2.0, ls=(0, (3.0, 2.4)), alpha=0.95, dash_capstyle="butt", zorder=3)
REF_STYLE: dict[str, Any] = dict(lw=1.0, color=palette.REFERENCE, zorder=2.5)
RK4_STYLE: dict[str, Any] = dict(lw=1.3, ls=(0, (1.0, 1.6)), color=palette.RK4, zorder=2.8)

MJ_LABEL = "MuJoCo (dashed)"
REF_LABEL = "reference, vector method (solid)"
RESIDUAL_GID = "residual"  # every residual panel's Axes carries this gid (the figure tests look for it)

# The open examine(): its function and what it found, by file name.
_EXAMINE: tuple[Callable[[str, Figure], Any], list[tuple[str, Any]]] | None = None
_SAVED_TIGHT: weakref.WeakSet[Figure] = weakref.WeakSet()  # figures save() cropped to their drawing
# Figures save() has just drawn at DPI uncropped, being examined: their texts and ticks are
# laid out as written, so the checks read them without laying them out again. A cropped one
# is laid out again: its layout after the crop is not the one written.
_SAVED_AS_DRAWN: weakref.WeakSet[Figure] = weakref.WeakSet()


class examine:
    """Within ``with examine(fn) as found:``, :func:`save` calls ``fn(file name, Figure)`` on
    every figure right after writing it, laid out as written, and appends ``(file name, what
    fn returned)`` to ``found``: what a figure shows (its axes, labels, texts) can be checked,
    not only that the file exists.

    The figures are examined where they are drawn: a run's forked plot workers
    (:mod:`mjlink.runtime.workers`) call ``fn`` themselves, and what it returned (plain data:
    it travels pickled) reaches ``found`` once the run has waited for the worker. The checks
    of the figures as a reader sees them (tests/test_figures.py, .ci/check_figures.py) so hold
    the very figures a command writes, drawn the way it draws them."""

    def __init__(self, fn: Callable[[str, Figure], Any]) -> None:
        self.fn = fn

    def __enter__(self) -> list[tuple[str, Any]]:
        global _EXAMINE
        self._before = _EXAMINE
        _EXAMINE = (self.fn, [])
        return _EXAMINE[1]

    def __exit__(self, *exc: object) -> None:
        global _EXAMINE
        _EXAMINE = self._before


def examined() -> list[tuple[str, Any]] | None:
    """The list the open :class:`examine` gathers into (None outside one): a plot worker sends
    what it added, and the run adds it to its own."""
    return None if _EXAMINE is None else _EXAMINE[1]


def warm() -> None:
    """Draw a small figure with text into memory once, so that the processes forked afterwards
    to draw the real figures inherit matplotlib's loaded fonts and glyph caches rather than
    each paying for them at its first figure."""

    fig, ax = subplots(figsize=(2.0, 1.5))
    ax.plot([0.0, 1.0], [0.0, 1.0])
    ax.set_title("crank ω₁ [rad/s²]", fontsize=9)
    ax.set_xlabel("φ [deg]")
    fig.savefig(io.BytesIO(), format="png", dpi=DPI, pil_kwargs=PNG_OPTIONS)
    plt.close(fig)


_SUBSCRIPT = str.maketrans("0123456789", "₀₁₂₃₄₅₆₇₈₉")


def subscript(*parts: object) -> str:
    """``parts`` joined as Unicode subscript digits: ``subscript(0, 4)`` is '₀₄' (phi04). The
    figures write symbols as plain Unicode text (φ₀₁, ω₁, m/s²) rather than mathtext, which
    matplotlib parses anew for every label."""
    return "".join(str(p) for p in parts).translate(_SUBSCRIPT)


def figure(**kwargs: Any) -> Figure:
    """``plt.figure`` for mjlink's figures."""
    return plt.figure(**kwargs)


def subplots(*args: Any, **kwargs: Any) -> Any:
    """``plt.subplots`` for mjlink's figures."""
    return plt.subplots(*args, **kwargs)


# PNGs are deflated at zlib level 1 (Pillow's ``compress_level``, through savefig's public
# ``pil_kwargs``): a figure is mostly flat background, where the files come within a few
# percent of the default level's size in a fraction of its time.
PNG_OPTIONS: dict[str, Any] = {"compress_level": 1}


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
        crop = TIGHT if tight else {}
        if tight:
            _SAVED_TIGHT.add(fig)
        with atomic_path(path, suffix=".png") as tmp:
            fig.savefig(tmp, format="png", dpi=DPI, pil_kwargs=PNG_OPTIONS, **crop)
        if _EXAMINE is not None:
            fn, found = _EXAMINE
            if not tight:
                _SAVED_AS_DRAWN.add(fig)
            found.append((name, fn(name, fig)))
    finally:
        plt.close(fig)
    return path


def place(
    fig: Figure,
    gs: Any,
    *,
    left: float = 1.0,
    right: float = 0.2,
    top: float = 0.75,
    bottom: float = 0.6,
    hgap: float = 0.45,
    wgap: float = 1.1,
) -> None:
    """Lay out the grid ``gs`` of ``fig`` with fixed margins and gaps, in inches: room for two
    lines of title on top, a y label with its ticks on the left, an x label below and a
    residual panel's two-line label between columns. A fixed layout costs one draw; the
    constrained layout engine measures every tick label first (a second full pass, 40 % of a
    figure's time). The figures that use it have labels of known length."""
    w, h = fig.get_size_inches()
    rows, cols = gs.get_geometry()
    avg_h = (h - top - bottom - (rows - 1) * hgap) / rows
    avg_w = (w - left - right - (cols - 1) * wgap) / cols
    gs.update(
        left=left / w,
        right=1.0 - right / w,
        top=1.0 - top / h,
        bottom=bottom / h,
        hspace=hgap / avg_h,  # matplotlib's gaps are fractions of the mean axes size
        wspace=wgap / avg_w,
    )


def deg(phi: Any) -> np.ndarray:
    """Degrees from radians (scalar or array)."""
    out: np.ndarray = np.degrees(np.asarray(phi, dtype=float))
    return out


def user_text(text: str) -> str:
    """Text from a mechanism file (or any user) made safe to draw: every ``$`` escaped, so that
    matplotlib's mathtext never parses it (a title like 'a $5 part, $x^$' would crash the
    figure), and control characters shown as escapes. Every style helper that draws user text
    passes it through here."""
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
    """The reference as a thin solid line, MuJoCo as coloured dashes on top of it."""
    sep = " " if what else ""
    style = dict(REF_STYLE)
    if what:
        # Several quantities share the panel: keep the hue so each line finds its twin.
        style["color"] = darker(color)
    ax.plot(x_ref, y_ref, label=f"{what}{sep}reference" if what else REF_LABEL, **style)
    ax.plot(x_mj, y_mj, color=color, label=f"{what}{sep}MuJoCo" if what else MJ_LABEL, **MJ_STYLE)


def _num(v: float) -> str:
    return f"{v:.3g}"


def residual(
    ax: Axes,
    x: Any,
    diff: Any,
    unit: str,
    limit: float | None,
    *,
    color: str = palette.MUJOCO,
    what: str = "MuJoCo − reference",
    signed: bool = True,
) -> None:
    """A residual panel: ``diff`` (MuJoCo minus the reference, or the length of that difference
    when not ``signed``) in ``unit`` against ``x``, the agreement threshold ``limit`` (same unit;
    None: held to none) as red dashed lines and the worst value in words.

    A threshold far above the residual (more than 25 times) would flatten it to a line at zero:
    the axis then fits the residual and the threshold is named in the text, with the worst
    value as a share of it."""
    d = np.asarray(diff, dtype=float)
    worst = float(np.nanmax(np.abs(d))) if d.size else 0.0
    top = worst if worst > 0 else 1.0
    text = f"max |Δ| {_num(worst)} {unit}"
    drawn = limit is not None and limit > 0 and worst * 25 >= limit
    if limit is not None and limit > 0:
        text += f" = {100 * worst / limit:.2g} % of threshold {_num(limit)} {unit}"
        text += " (red)" if drawn else " (off scale)"
        top = max(top, limit) if drawn else top
    # A residual of 1e-6 deg would get matplotlib's offset label ("1e-6") over the panel above:
    # the power of ten goes into the axis' unit instead, the tick labels stay short.
    power = math.floor(math.log10(top))
    scale = 10.0**power if power <= -3 or power >= 4 else 1.0
    shown = unit if scale == 1.0 else f"×10{_superscript(power)} {unit}"  # as the study figures write it
    ax.plot(x, d / scale, color=color, lw=1.0, zorder=3)
    ax.axhline(0.0, color="0.5", lw=0.6, zorder=1)
    ax.set_gid(RESIDUAL_GID)
    ax.set_ylabel(f"{what}\n[{shown}]", fontsize=8.5)
    ax.grid(True, alpha=0.3)
    if drawn:
        assert limit is not None
        for sgn in (1.0, -1.0) if signed else (1.0,):
            ax.axhline(sgn * limit / scale, color=palette.THRESHOLD, lw=1.0, ls=(0, (5, 3)), zorder=2)
    ax.set_ylim((-1.3 * top if signed else 0.0) / scale, 1.45 * top / scale)
    ax.text(
        0.005,
        0.96,
        text,
        transform=ax.transAxes,
        ha="left",
        va="top",
        fontsize=7.5,
        zorder=6,
        bbox=dict(boxstyle="round,pad=0.15", fc="white", ec="none", alpha=0.8),
    )


def _superscript(n: int) -> str:
    return str(n).translate(str.maketrans("-0123456789", "⁻⁰¹²³⁴⁵⁶⁷⁸⁹"))


def direction(omega: Any) -> str:
    """'counter-clockwise' or 'clockwise': the sense of a crank speed (rad/s, CCW positive)."""
    return "counter-clockwise" if float(np.mean(omega)) >= 0 else "clockwise"


def text_overlaps(fig: Figure, pad: float = 0.0) -> list[tuple[str, str]]:
    """Pairs of drawn texts of ``fig`` whose boxes overlap on the canvas: titles, axis labels,
    annotations, free texts and legends (a legend counts as one box); tick labels are laid out
    by matplotlib and not checked; an annotation's leader line is not its box (a thin line, not
    a block of ink). Empty when nothing collides. ``pad`` pixels shrink every
    box before testing (touching is not overlapping). The figure is laid out as it is drawn,
    without rasterizing it (matplotlib's ``draw_without_rendering``), unless :func:`save` has
    just written it uncropped and is examining it (:class:`examine`): then it is read at DPI as
    written (tests/test_figures.py lays each shipped mechanism's busiest figures out again and
    finds every box, axes and tick where it was)."""
    if fig in _SAVED_AS_DRAWN:
        fig.set_dpi(DPI)
    else:
        fig.draw_without_rendering()
    r = fig.canvas.get_renderer()  # type: ignore[attr-defined]
    boxes = []
    legends = [lg for ax in fig.axes if (lg := ax.get_legend()) is not None] + list(fig.legends)
    inside = {id(t) for lg in legends for t in lg.get_texts()} | {id(lg.get_title()) for lg in legends}
    found = fig.findobj(matplotlib.text.Text)  # first: see _tick_labels
    ticks = {
        id(t) for ax in fig.axes for axis in (ax.xaxis, ax.yaxis) for t in [*_tick_labels(axis), axis.get_offset_text()]
    }
    for t in found:
        if id(t) in inside or id(t) in ticks or not t.get_visible() or not t.get_text().strip():
            continue
        boxes.append((t.get_text(), text_box(t, r)))
    for lg in legends:
        if lg.get_visible():
            boxes.append(("legend", lg.get_window_extent(r)))
    out = []
    for i in range(len(boxes)):
        for j in range(i + 1, len(boxes)):
            a, b = boxes[i][1], boxes[j][1]
            if min(a.x1, b.x1) - max(a.x0, b.x0) > 2 * pad + 0.5 and min(a.y1, b.y1) - max(a.y0, b.y0) > 2 * pad + 0.5:
                out.append((boxes[i][0], boxes[j][0]))
    return out


UNIT = re.compile(r"\[[^\]]+\]")  # an axis label's unit: "crank angle [deg]", "ratio [-]"


def _tick_labels(axis: matplotlib.axis.Axis) -> list[matplotlib.text.Text]:
    """Every tick label Text ``axis`` holds, drawn or not, read from its ``majorTicks`` and
    ``minorTicks`` lists as they are (after the figure's texts were found, which makes any
    tick the view lacks): ``get_ticklabels`` would run the locator and formatter again for
    every axis of the figure."""
    return [t for tick in [*axis.majorTicks, *axis.minorTicks] for t in (tick.label1, tick.label2)]


def _has_data(ax: Axes) -> bool:
    return bool(ax.lines or ax.collections or ax.images or ax.patches)


def _shown_tick_labels(axis: matplotlib.axis.Axis) -> list[matplotlib.text.Text]:
    """The tick labels ``axis`` draws: those of its ticks inside the view interval (the axis
    keeps Text objects for ticks outside it too, and does not draw them)."""
    scale = axis.get_transform()  # compared on the axis' scale (a log axis spans decades)
    lo, hi = sorted(float(v) for v in scale.transform(np.asarray(axis.get_view_interval(), dtype=float)))
    eps = 1e-9 * (hi - lo)
    out = []
    for tick in [*axis.get_major_ticks(), *axis.get_minor_ticks()]:
        loc = tick.get_loc()
        if loc is None or not lo - eps <= float(scale.transform(np.asarray([loc], dtype=float))[0]) <= hi + eps:
            continue
        out += [t for t in (tick.label1, tick.label2) if t.get_visible() and t.get_text().strip()]
    return out


def _on_white(color: Any) -> np.ndarray:
    """``color`` as it shows on the white page: RGB with its alpha blended over white."""
    rgba = np.asarray(matplotlib.colors.to_rgba(color), dtype=float)
    out: np.ndarray = rgba[:3] * rgba[3] + (1.0 - rgba[3])
    return out


def _look(handle: matplotlib.artist.Artist) -> tuple[Any, ...] | None:
    """How a legend entry's key looks (colours as seen on white, rounded to what an eye tells
    apart), or None for a kind of key not compared."""

    def q(c: Any) -> tuple[int, ...]:  # twelve steps a channel
        return tuple(int(v) for v in np.round(_on_white(c) * 12))

    if isinstance(handle, matplotlib.lines.Line2D):
        marker = handle.get_marker() if handle.get_marker() not in ("", " ", "None", None) else None
        style = handle.get_linestyle() if handle.get_linestyle() not in ("", " ", "None") else None
        return ("line", q(handle.get_color()), style, marker, q(handle.get_markerfacecolor()) if marker else None)
    if isinstance(handle, matplotlib.patches.Patch):
        edge = q(handle.get_edgecolor()) if handle.get_linewidth() > 0 else None
        return ("patch", q(handle.get_facecolor()), edge, handle.get_hatch() or None, handle.get_linestyle())
    return None


# Words a legend label may use to describe its key, and what the key must then be.
# A line's own dash pattern is not public: "dashed" and "dotted" both ask for a broken line.
_BROKEN = ("--", "-.", ":")
_STYLE_WORDS: dict[str, Callable[[matplotlib.artist.Artist], bool]] = {
    "dashed": lambda h: h.get_linestyle() in _BROKEN,  # type: ignore[attr-defined]
    "dotted": lambda h: h.get_linestyle() in _BROKEN,  # type: ignore[attr-defined]
    "solid": lambda h: isinstance(h, matplotlib.lines.Line2D) and h.get_linestyle() == "-",
    "hatched": lambda h: isinstance(h, matplotlib.patches.Patch) and bool(h.get_hatch()),
    "filled": lambda h: isinstance(h, matplotlib.patches.Patch) and not h.get_hatch(),
}


def legend_defects(fig: Figure) -> list[str]:
    """Legends a reader cannot read: two entries with different labels whose keys look the same
    on the page (colour over white, line style, marker, hatch), and a label that describes its
    key in words the key contradicts ("dashed" on a filled bar)."""
    out = []
    legends = [lg for ax in fig.axes if (lg := ax.get_legend()) is not None] + list(fig.legends)
    for lg in legends:
        if not lg.get_visible():
            continue
        entries = [(t.get_text(), h) for t, h in zip(lg.get_texts(), lg.legend_handles, strict=False) if h is not None]
        seen: dict[tuple[Any, ...], str] = {}
        for text, h in entries:
            look = _look(h)
            if look is not None and look in seen and seen[look] != text:
                out.append(f"legend entries look alike: {seen[look]!r} and {text!r}")
            elif look is not None:
                seen[look] = text
            for word, holds in _STYLE_WORDS.items():
                if re.search(rf"\b{word}\b", text) and not holds(h):
                    out.append(f"legend entry {text!r} says {word!r} of a key that is not")
    return out


def labels_on_curves(fig: Figure) -> list[tuple[str, str]]:
    """Texts placed in a panel (annotations and free texts, not titles or axis labels) that a
    curve of the same panel runs through, as (text, curve label): a label over a curve hides it
    and is read as its value. A curve is a drawn line of three points or more (a reference line
    across the panel is not); only the part of a text inside the panel is tested (the rest is
    where no curve is drawn)."""
    if fig in _SAVED_AS_DRAWN:  # as text_overlaps: laid out as written
        fig.set_dpi(DPI)
    else:
        fig.draw_without_rendering()
    return _labels_on_curves(fig, fig.canvas.get_renderer())  # type: ignore[attr-defined]


def _curves(ax: Axes) -> list[matplotlib.lines.Line2D]:
    """``ax``'s curves: its drawn lines of three points or more (a reference line across the
    panel has two)."""
    return [
        ln
        for ln in ax.lines
        if ln.get_visible() and ln.get_linestyle() not in ("", " ", "None") and np.shape(ln.get_xydata())[0] >= 3
    ]


def curve_paths(ax: Axes) -> list[Any]:
    """``ax``'s curves as :func:`labels_on_curves` counts them, as paths on the canvas
    (pixels): valid while the panel's place and limits hold."""
    return [ln.get_transform().transform_path(ln.get_path()) for ln in _curves(ax)]


def on_curves(box: Any, paths: list[Any], panel: Any, spare: float = 1.0) -> bool:
    """Whether one of ``paths`` (:func:`curve_paths`) runs through the part of the canvas box
    ``box`` inside the panel box ``panel``, ``spare`` pixels at each edge spared (touching is
    not crossing); a negative ``spare`` asks for that much clearance around the box (a label
    placed for one resolution stays clear at another, where its text is hinted differently)."""
    x0, y0 = max(box.x0 + spare, panel.x0), max(box.y0 + spare, panel.y0)
    x1, y1 = min(box.x1 - spare, panel.x1), min(box.y1 - spare, panel.y1)
    if x1 <= x0 or y1 <= y0:
        return False
    inner = matplotlib.transforms.Bbox([[x0, y0], [x1, y1]])
    return any(p.intersects_bbox(inner, filled=False) for p in paths)


def text_box(t: matplotlib.text.Text, r: Any) -> Any:
    """The canvas box of the text itself (an annotation's leader line or arrow left out)."""
    box = t.get_window_extent(r)  # an annotation places its text here
    return matplotlib.text.Text.get_window_extent(t, r) if isinstance(t, matplotlib.text.Annotation) else box


def place_clear(t: matplotlib.text.Text, spots: list[tuple[float, float]], *, laid_out: bool = False) -> None:
    """Moves the text ``t`` to the first of ``spots`` (positions as ``t.set_position`` takes
    them: an annotation's offset, a text's coordinates) where it covers no other text or legend
    of its panel and no curve runs through it (:func:`on_curves`, with 3 pixels of clearance);
    where none is clear, to the one that covers the fewest (texts first). The figure is laid out
    first, so that its panels and limits are final, unless the caller has (``laid_out``: it
    places several texts on a figure whose layout is fixed, which moving a text leaves as is)."""
    ax = t.axes
    assert isinstance(ax, Axes)
    fig = ax.figure
    assert isinstance(fig, Figure)
    if not laid_out:
        fig.draw_without_rendering()
    r = fig.canvas.get_renderer()  # type: ignore[attr-defined]
    others = [text_box(o, r) for o in ax.texts if o is not t and o.get_visible() and o.get_text().strip()]
    if (lg := ax.get_legend()) is not None:
        others.append(lg.get_window_extent(r))
    curves, panel = curve_paths(ax), ax.get_window_extent(r)
    best: tuple[tuple[int, int], tuple[float, float]] | None = None
    for xy in spots:
        t.set_position(xy)
        box = text_box(t, r)
        cost = (sum(box.overlaps(o) for o in others), int(on_curves(box, curves, panel, spare=-3.0)))
        if best is None or cost < best[0]:
            best = (cost, xy)
        if cost == (0, 0):
            return
    assert best is not None
    t.set_position(best[1])


def _labels_on_curves(fig: Figure, r: Any) -> list[tuple[str, str]]:
    out = []
    for ax in fig.axes:
        if not ax.get_visible():
            continue
        curves = _curves(ax)
        paths = curve_paths(ax)
        panel = ax.get_window_extent(r)
        for t in ax.texts:
            if not t.get_visible() or not t.get_text().strip():
                continue
            box = text_box(t, r)
            for ln, path in zip(curves, paths, strict=True):
                if on_curves(box, [path], panel):
                    out.append((t.get_text(), str(ln.get_label())))
                    break
    return out


def _offsets_in_other_panels(fig: Figure, r: Any) -> list[str]:
    """An axis' offset or power label ("1e-6" above a panel) that runs into another panel."""
    panels = [(ax, ax.get_window_extent(r)) for ax in fig.axes if ax.get_visible() and ax.axison]
    out = []
    for ax, _ in panels:
        for axis in (ax.xaxis, ax.yaxis):
            off = axis.get_offset_text()
            if not (axis.get_visible() and off.get_visible() and off.get_text().strip()):
                continue
            b = off.get_window_extent(r)
            for other, o in panels:
                if (
                    other is not ax
                    and min(b.x1, o.x1) - max(b.x0, o.x0) > 0.5
                    and min(b.y1, o.y1) - max(b.y0, o.y0) > 0.5
                ):
                    out.append(f"the offset label {off.get_text()!r} of {ax.get_title()!r} runs into another panel")
                    break
    return out


def figure_defects(fig: Figure) -> list[str]:
    """What is wrong with a figure as a reader sees it, in words (empty when nothing is):

    * an axis that shows data and numbered ticks without a label naming its unit in brackets
      (``y [mm]``; ``[-]`` for a ratio), the figure-wide convention;
    * texts that overlap (:func:`text_overlaps`);
    * tick labels of one axis that overlap each other;
    * a text that leaves the canvas (a figure :func:`save` crops to its drawing cannot lose one);
    * a text in a panel that a curve runs through (:func:`labels_on_curves`);
    * a legend whose entries cannot be told apart or whose words contradict a key
      (:func:`legend_defects`);
    * an axis' offset label ("1e-6") that runs into another panel.

    Laid out as :func:`save` draws it (at its resolution), without rasterizing."""
    fig.set_dpi(DPI)
    out = [f"labels overlap: {a!r} and {b!r}" for a, b in text_overlaps(fig)]
    r = fig.canvas.get_renderer()  # type: ignore[attr-defined]
    out += [f"a curve ({c!r}) runs through the label {t!r}" for t, c in _labels_on_curves(fig, r)]
    out += legend_defects(fig)
    out += _offsets_in_other_panels(fig, r)
    texts = []
    ticks: set[int] = set()
    hidden = [ax for ax in fig.axes if not ax.get_visible()]
    for ax in fig.axes:
        for axis in (ax.xaxis, ax.yaxis):
            ticks |= {
                id(t) for tick in [*axis.get_major_ticks(), *axis.get_minor_ticks()] for t in (tick.label1, tick.label2)
            }
            shown = _shown_tick_labels(axis) if ax.get_visible() and ax.axison and axis.get_visible() else []
            texts += shown
            if not shown or not _has_data(ax):
                continue
            name = axis.axis_name
            # A row or column of panels sharing an axis names it once (on its outer panel).
            shared = ax.get_shared_x_axes() if name == "x" else ax.get_shared_y_axes()
            labels = [getattr(a, f"get_{name}label")() for a in shared.get_siblings(ax)]
            label = axis.get_label_text()
            if not any(UNIT.search(lb) for lb in [label, *labels]):
                out.append(f"{name} axis {label!r} of {ax.get_title()!r} names no unit in brackets")
            boxes = sorted((t.get_window_extent(r) for t in shown), key=lambda b: (b.x0, b.y0))
            for a, b in itertools.pairwise(boxes):
                if min(a.x1, b.x1) - max(a.x0, b.x0) > 0.5 and min(a.y1, b.y1) - max(a.y0, b.y0) > 0.5:
                    out.append(f"{name} tick labels overlap on {ax.get_title()!r} ({label!r})")
                    break
    if fig not in _SAVED_TIGHT:
        texts += [
            t
            for t in fig.findobj(matplotlib.text.Text)
            if id(t) not in ticks and t.get_visible() and t.get_text().strip() and t.axes not in hidden
        ]
        canvas = fig.bbox
        for t in texts:
            b = t.get_window_extent(r)
            if b.x0 < canvas.x0 - 1 or b.y0 < canvas.y0 - 1 or b.x1 > canvas.x1 + 1 or b.y1 > canvas.y1 + 1:
                out.append(f"text leaves the canvas: {t.get_text()!r}")
    return out


def crank_axis(mech: Mechanism, phi: np.ndarray) -> tuple[Callable[[Any], np.ndarray], str]:
    """How to plot the crank angles of a run whose input angles are ``phi`` (rad): a function
    from input angles (rad) to abscissae (deg) and the axis label that says which they are.

    Every crank-angle axis is the one convention: the angle the input crank has turned from its
    setting phi01 (the file's phi0), in degrees, 0 at the setting and growing with time in
    either sense of rotation (a clockwise crank, as the needle-bar drives, turns phi01 - phi1).
    """
    phi = np.asarray(phi)
    sense = 1.0 if phi[-1] >= phi[0] else -1.0
    clockwise = "" if sense > 0 else " clockwise"
    return (
        lambda p: deg(sense * (np.asarray(p, dtype=float) - mech.phi0)),
        f"crank angle turned{clockwise} from φ₀₁ = {math.degrees(mech.phi0):g}° [deg]",
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
