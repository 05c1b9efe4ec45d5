"""The timing diagram (cyclogram) of a sewing head: every member's motion against the main-shaft
angle over one stitch, with the events and the windows of the head's target settings."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.axes import Axes

from ..analysis.tension import NeedleTension
from ..analysis.timing import HeadTiming
from ..model.mechanism import Mechanism
from ..model.tension import GF
from ..units import MM
from .style import angle_ticks, place, place_clear, save, subplots, title

# Events drawn as vertical lines, each with its short tag on the top panel.
_EVENTS = {
    "needle bar bottom": "BDC",
    "hook picks the loop": "hook",
    "loop released": "release",
    "take-up top": "take-up top",
    "dog flush, descending": "dog down",
}


def _label(ax: Axes, text: str, x: float, *, dx: float = 0.0, dy: float = -2.0, **style: Any) -> Any:
    """``text`` hanging from the top of ``ax`` at main-shaft angle ``x`` (offset in points)."""
    return ax.annotate(
        text,
        (x, 1.0),
        xycoords=("data", "axes fraction"),
        xytext=(dx, dy),
        textcoords="offset points",
        va="top",
        **style,
    )


def _rise_band(head: HeadTiming, lo: float, hi: float) -> tuple[float, float] | None:
    """Main-shaft angles (deg) over which the needle bar, rising from its bottom, is between
    ``lo`` and ``hi`` mm above it."""
    theta, rise = head.theta, head.curves["needle bar rise"]
    bdc = head.events["needle bar bottom"]
    up = (theta >= bdc) & (theta <= bdc + 90.0)
    t, r = theta[up], rise[up]
    if len(t) < 2:
        return None
    return float(np.interp(lo, r, t)), float(np.interp(hi, r, t))


def cyclogram_plot(mech: Mechanism, head: HeadTiming, out_dir: Path | str) -> Path:
    """``cyclogram.png``: needle point and eye, take-up eyelet, hook angle, feed dog height and
    advance over one stitch (the panels of the parts the ``[timing]`` table names); the events as
    vertical lines; the target maker's windows shaded (the hook timing as the band of main-shaft
    angles its needle-bar rise allows, the dog's height as a band of heights)."""
    assert mech.timing is not None
    maker = mech.timing.maker(head.target) if head.target else None
    th, c = head.theta, head.curves
    panels = [k for k in ("needle point", "take-up eyelet", "hook angle", "dog height", "dog advance") if k in c]
    # A strip above the panels names the events: tags inside a panel would sit on its curves.
    fig, axes = subplots(
        len(panels) + 1,
        1,
        figsize=(10.0, 1.8 + 1.9 * len(panels)),
        sharex=True,
        squeeze=False,
        height_ratios=[0.6, *[1.9] * len(panels)],
    )
    strip, axes = axes[0, 0], axes[1:, 0]
    strip.axis("off")
    place(fig, strip.get_gridspec(), left=1.0, right=0.3, top=0.95, bottom=0.6, hgap=0.25)
    band = None
    if maker is not None and "hook_rise" in maker.windows:
        w = maker.windows["hook_rise"]
        band = _rise_band(head, (w.lo or 0.0) / MM, (w.hi or 0.0) / MM)
    fabric = mech.timing.fabric / MM
    ax_of = dict(zip(panels, axes, strict=True))

    if "needle point" in ax_of:
        ax = ax_of["needle point"]
        ax.plot(th, c["needle point"], color="C0", label="needle point")
        if "needle eye" in c:
            ax.plot(th, c["needle eye"], color="C0", ls="--", lw=1.0, label="top of the eye")
        low = c["needle point"].min()
        if "hook point height" in c:
            ax.plot(th, c["hook point height"], color="C3", lw=0.8, alpha=0.6, label="hook point")
            low = min(low, c["hook point height"].min())
        ax.axhline(0.0, color="0.3", lw=1.0)
        ax.axhline(fabric, color="0.5", lw=0.8, ls=":")
        ax.set_ylabel("height above\nthe plate [mm]")
        ax.set_ylim(low - 0.45 * (c["needle point"].max() - low), c["needle point"].max() + 4)
        ax.legend(loc="lower center", fontsize=8, ncols=3, framealpha=0.9)

    if "take-up eyelet" in ax_of:
        ax = ax_of["take-up eyelet"]
        ax.plot(th, c["take-up eyelet"], color="C2")
        ax.set_ylabel("take-up eyelet above\nits lowest [mm]")

    if "hook angle" in ax_of:
        ax = ax_of["hook angle"]
        hook = np.where(np.abs(np.diff(c["hook angle"], append=c["hook angle"][0])) > 180.0, np.nan, c["hook angle"])
        ax.plot(th, hook, color="C3")
        ax.set_yticks([0, 90, 180, 270, 360])
        ax.set_ylim(-10, 370)
        ax.set_ylabel("hook angle [deg]")

    if "dog height" in ax_of:
        ax = ax_of["dog height"]
        ax.plot(th, c["dog height"], color="C1")
        ax.axhline(0.0, color="0.3", lw=1.0)
        if maker is not None and "dog_height" in maker.windows:
            w = maker.windows["dog_height"]
            ax.axhspan((w.lo or 0.0) / MM, (w.hi or 0.0) / MM, color="C1", alpha=0.2, lw=0)
        ax.set_ylabel("feed dog above\nthe plate [mm]")

    if "dog advance" in ax_of:
        ax = ax_of["dog advance"]
        ax.plot(th, c["dog advance"], color="C4")
        ax.set_ylabel("feed dog\nadvance [mm]")
    axes[-1].set_xlabel(f"main-shaft angle from {head.origin} [deg]")
    angle_ticks(axes[-1], 0.0, 360.0)

    for a in axes:
        if band is not None:
            a.axvspan(*band, color="C3", alpha=0.15, lw=0)
        for key in _EVENTS:
            x = head.events.get(key)
            if x is not None and np.isfinite(x):
                a.axvline(x, color="0.45", lw=0.8, ls="--")
        a.grid(alpha=0.3)
    # Events at one angle share one tag (a chain stitch's loop is released as the next is picked).
    tags: dict[float, list[str]] = {}
    for key, tag in _EVENTS.items():
        x = head.events.get(key)
        if x is not None and np.isfinite(x):
            at = next((a for a in tags if abs(a - x) < 0.5), x)
            tags.setdefault(at, []).append(tag)
    for i, (x, names) in enumerate(sorted(tags.items())):
        strip.plot([x, x], [0.0, 0.08], color="0.45", lw=0.8, ls="--", transform=strip.get_xaxis_transform())
        t = strip.text(x, 0.06, " / ".join(names), ha="center", va="bottom", fontsize=8, color="0.3")
        t.set_transform(strip.get_xaxis_transform())
        # Staggered: near events' tags take the next row up.
        place_clear(t, [(x, y) for y in (0.06, 0.38, 0.7)], laid_out=i > 0)  # the layout is fixed: drawn once
    shaded = f"; shaded: the {head.target} settings' windows" if maker is not None else ""
    fig.suptitle(title(mech, f"timing diagram over one stitch{shaded}"), fontsize=11)
    return save(fig, out_dir, "cyclogram.png")


def balance_plot(mech: Mechanism, head: HeadTiming, out_dir: Path | str) -> Path:
    """``thread_balance.png``: the needle thread over one stitch: what the take-up and guides
    give out (supply) and what the needle, the fabric and the hook's loop take (demand) since
    the stitch was set, their difference (slack above zero, shortfall below), the check
    spring's travel as a band, and the phases named."""
    assert head.balance is not None and mech.balance is not None
    b = head.balance
    fig, (ax, bx) = subplots(2, 1, figsize=(10.0, 8.6), sharex=True, height_ratios=[1.4, 1.0])
    place(fig, ax.get_gridspec(), left=1.0, right=0.3, top=1.25, bottom=1.4, hgap=0.3)
    forming = np.isfinite(b.balance)
    ax.plot(b.theta, np.where(forming, b.supply, np.nan), color="C2", label="supply: take-up and guides")
    ax.plot(b.theta, np.where(forming, b.demand, np.nan), color="C3", label="demand: needle, fabric and loop")
    ax.plot(b.theta, np.where(forming, np.nan, b.supply), color="C2", lw=0.8, ls=":")
    ax.set_ylabel("thread since the\nstitch was set [mm]")
    # Headroom for the phases' names, which hang from the top.
    lo, hi = ax.get_ylim()
    ax.set_ylim(lo, hi + 0.12 * (hi - lo))
    # Above the panel: inside it, some head's curves or phase names would run through it.
    ax.legend(loc="lower left", bbox_to_anchor=(0.0, 1.0), ncol=2, fontsize=8, frameon=False)
    slack = next(r for r in head.rows if r.key == "thread_slack")
    # The spring's hook, over its travel, takes this much thread out of the path.
    holds = (slack.window.hi or 0.0) / MM
    bx.axhspan(0.0, holds, color="C0", alpha=0.12, lw=0)
    bx.plot(b.theta, b.balance, color="C0")
    bx.axhline(0.0, color="0.3", lw=1.0)
    bx.set_ylabel("supply - demand [mm]\n(slack > 0 > shortfall)")
    bx.set_xlabel("main-shaft angle from the needle bar's top dead centre [deg]")
    angle_ticks(bx, 0.0, 360.0)
    shades = ("0.93", "0.86")
    for k, (name, (lo, hi)) in enumerate(b.phases.items()):
        spans = [(lo, hi)] if hi >= lo else [(lo, 360.0), (0.0, hi)]
        for a0, a1 in spans:
            for a in (ax, bx):
                a.axvspan(a0, a1, color=shades[k % 2], lw=0, zorder=0)
        # A phase that wraps past 0 deg is named over its longer part, inside the axes.
        a0, a1 = max(spans, key=lambda sp: sp[1] - sp[0])
        mid = (a0 + a1) / 2.0
        rotation = 90 if (hi - lo) % 360.0 < 60.0 else 0
        _label(ax, name, mid, dy=-4, ha="center", fontsize=7.5, rotation=rotation, color="0.25")
    short = next(r for r in head.rows if r.key == "thread_shortfall")
    # The figures in words under the panels: inside, the curves would run through them.
    fig.text(
        0.5,
        0.012,
        f"largest shortfall {short.value / MM:.2f} mm ({'within' if short.ok else 'FAIL: beyond'} the thread's "
        f"stretch, {(short.window.hi or 0.0) / MM:.2f} mm)\nlargest slack {slack.value / MM:.2f} mm (the check spring's "
        f"{mech.balance.check_spring_travel / MM:g} mm travel holds {holds:.2f} mm, shaded below)\na stitch holds {b.per_stitch:.2f} mm of needle thread"
        + (
            f"; the loop takes up to {b.most_under:.1f} mm below the material,\nthe blade point "
            + (f"{round(b.most_under_at):+d} deg from six o'clock" if round(b.most_under_at) else "at six o'clock")
            + " (Union Special's 301 manual: about 89 mm)"
            if math.isfinite(b.most_under)
            else ""
        ),
        ha="center",
        va="bottom",
        fontsize=8,
    )
    for a in (ax, bx):
        a.grid(alpha=0.3)
    fig.suptitle(title(mech, "needle thread balance over one stitch"), fontsize=11)
    return save(fig, out_dir, "thread_balance.png")


def tension_plot(mech: Mechanism, head: HeadTiming, t: NeedleTension, out_dir: Path | str) -> Path:
    """``thread_tension.png``: the needle thread's tension over one stitch in each stretch from
    the discs to below the eye, with the cycle's events; below, the check spring's travel and
    the thread drawn through the discs since the stitch was set."""
    assert mech.balance is not None
    fig, (ax, bx) = subplots(2, 1, figsize=(10.0, 7.5), sharex=True, height_ratios=[1.6, 1.0])
    place(fig, ax.get_gridspec(), left=1.0, right=1.0, top=0.95, bottom=0.6, hgap=0.3)
    for k, (zone, T) in enumerate(zip(t.zones, t.tension, strict=True)):
        ax.plot(t.theta, T, color=f"C{k % 10}", lw=1.6 if k == len(t.zones) - 1 else 1.0, label=zone)
    ax.set_ylabel("tension [N]")
    gf = ax.secondary_yaxis("right", functions=(lambda n: n / GF, lambda g: g * GF))
    gf.set_ylabel("[gf]")
    ax.legend(loc="upper left", fontsize=7.5, ncols=3, framealpha=0.9, title="stretch", title_fontsize=7.5)
    zone, at = t.peak_at
    ax.set_title(
        f"peak {t.peak:.3g} N ({t.peak / GF:.0f} gf) in {zone} at {at:.1f} deg: breaking load "
        f"{t.breaking_load:.3g} N, margin {t.margin:.3g}; discs' hold {t.hold:.3g} N\n"
        f"a stitch draws {t.per_stitch / MM:.3f} mm through the discs (stitch formula {t.formula / MM:.2f} mm)"
        + t.repeats,
        fontsize=8.5,
        pad=16,
    )
    bx.plot(t.theta, t.spring / MM, color="C0", label="check spring's travel from rest")
    bx.axhline(mech.balance.check_spring_travel / MM, color="C0", lw=0.8, ls=":")
    bx.plot(t.theta, t.drawn / MM, color="C3", label="thread drawn through the discs since the stitch was set")
    bx.set_ylabel("[mm]")
    bx.legend(loc="upper left", fontsize=7.5, framealpha=0.9)
    bx.set_xlabel("main-shaft angle from the needle bar's top dead centre [deg]")
    angle_ticks(bx, 0.0, 360.0)
    # Events in the angle's order, their tags at two heights so that near ones stay apart.
    shown = sorted((head.events[name], tag) for name, tag in _EVENTS.items() if name in head.events)
    tags = []
    for i, (angle, tag) in enumerate(shown):
        for a in (ax, bx):
            a.axvline(angle, color="0.5", lw=0.8, ls="--", zorder=0)
        tags.append(_label(ax, tag, angle, dx=2, dy=-2.0 - 11.0 * (i % 2), ha="left", fontsize=7, color="0.35"))
    for i, t in enumerate(tags):  # beside its line, as high as the curves and the other tags leave room
        spots = [(dx, -dy) for dy in (2.0, 13.0, 24.0, 35.0, 46.0, 57.0, 68.0) for dx in (2.0, -30.0)]
        place_clear(t, spots, laid_out=i > 0)  # the layout is fixed: drawn once
    for a in (ax, bx):
        a.grid(alpha=0.3)
    fig.suptitle(title(mech, "needle thread tension over one stitch"), fontsize=11, y=0.995)
    return save(fig, out_dir, "thread_tension.png")
