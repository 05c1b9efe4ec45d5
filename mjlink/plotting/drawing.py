"""The mechanism drawn: its links in many crank positions with the paths of its points (the
take-up's Fig. 1b, the warp-knitting drive's Fig. 4), and the spatial thread contour of the
eyelet take-up in front and top view (its Fig. 2). Drawing only: positions from
:func:`mjlink.reference.solve`, in mm.
"""

from __future__ import annotations

import math
from pathlib import Path

import matplotlib
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.collections import LineCollection
from matplotlib.lines import Line2D
from matplotlib.patches import Polygon, Rectangle

from .. import analysis, reference
from ..analysis import segments
from ..model.mechanism import Mechanism
from ..units import to_mm
from .style import (
    curve_paths,
    darker,
    direction,
    figure,
    on_curves,
    place,
    place_clear,
    save,
    title,
)


# ----------------------------------------------------------------------------- positions (Fig. 1b)
def _angle_ticks(ax, mech: Mechanism, phi: np.ndarray, xy: np.ndarray, size: float, label_every: int) -> list:
    """Short ticks across the path ``xy`` (mm, sampled at the input angles ``phi`` over one
    period from phi0) every 30 deg of crank angle turned; returns the ticks to be labelled
    every ``label_every`` deg (0: none) as (text, point, normal) for :func:`_label_ticks`."""
    turned = np.degrees(np.abs(np.asarray(phi) - phi[0]))
    out = []
    for d in range(0, round(math.degrees(mech.period)), 30):
        i = int(np.argmin(np.abs(turned - d)))
        j0, j1 = max(i - 1, 0), min(i + 1, len(xy) - 1)
        t = xy[j1] - xy[j0]
        nrm = np.array([-t[1], t[0]]) / (np.hypot(*t) or 1.0)
        big = bool(label_every) and d % label_every == 0
        h = (0.55 if big else 0.35) * size
        ax.plot(*np.stack([xy[i] - h * nrm, xy[i] + h * nrm]).T, color="k", lw=1.1 if big else 0.8, zorder=4.5)
        if big:
            out.append((f"{d}°", xy[i], nrm))
    return out


LABEL_MARGIN = 3.0  # px between two tick names where they are placed


def _label_ticks(ax, ticks: list) -> None:
    """Name the ticks of :func:`_angle_ticks` beside the path, on either side of it; a name
    that would cover one already written or a path (where the path crosses itself, or its
    second turn or another point's path runs beside it) is left out: the tick stays."""
    r = ax.figure.canvas.get_renderer()
    taken = [t.get_window_extent(r) for t in ax.texts if t.get_text().strip()]
    curves, panel = curve_paths(ax), ax.get_window_extent(r)
    for text, xy, nrm in ticks:
        for dist, sgn in ((13, 1.0), (13, -1.0), (20, 1.0), (20, -1.0)):
            lab = ax.annotate(
                text,
                xy,
                xytext=tuple(dist * sgn * nrm),
                textcoords="offset points",
                ha="center",
                va="center",
                fontsize=7,
                color="0.2",
                zorder=7,
                bbox=dict(boxstyle="round,pad=0.05", fc="white", ec="none", alpha=0.7),
            )
            lab.set_in_layout(False)
            box = lab.get_window_extent(r)
            # Kept apart by a margin: the figure is laid out again when saved, and the panel's
            # final size (which differs between matplotlib versions) moves the ticks, not the
            # offsets of their names, so two names that only just cleared each other can meet.
            near = box.expanded(
                1.0 + 2 * LABEL_MARGIN / max(box.width, 1.0), 1.0 + 2 * LABEL_MARGIN / max(box.height, 1.0)
            )
            if not any(near.overlaps(b) for b in taken) and not on_curves(box, curves, panel, spare=-3.0):
                taken.append(box)
                break
            lab.remove()


def _rotation_arrow(ax, mech: Mechanism, size: float) -> None:
    """A curved arrow around the input crank's pivot in the sense the crank turns, named n1 in
    the legend (a name beside it would have no free room in a head's crowded centre)."""
    crank = mech.input_crank
    c = to_mm(mech.ground[crank.pivot][:2])
    r = max(2.2 * size, 0.6 * to_mm(crank.length))
    ccw = mech.speed >= 0
    a0, a1 = (200.0, 320.0) if ccw else (320.0, 200.0)
    p0 = c + r * np.array([math.cos(math.radians(a0)), math.sin(math.radians(a0))])
    p1 = c + r * np.array([math.cos(math.radians(a1)), math.sin(math.radians(a1))])
    ax.annotate(
        "",
        p1,
        xytext=p0,
        arrowprops=dict(
            arrowstyle="-|>", color="k", lw=1.4, connectionstyle=f"arc3,rad={0.45 if ccw else -0.45}", mutation_scale=12
        ),
        zorder=6,
    )
    ax.plot(
        [],
        [],
        ls="none",
        marker=r"$\circlearrowleft$" if ccw else r"$\circlearrowright$",
        ms=11,
        color="k",
        label=f"n₁: the input crank turns {direction(mech.speed)}\n(arrow round {crank.pivot})",
    )


def _place_labels(ax, mech, names, xy0, pairs, P, size, coms, pivots) -> None:
    """Name every point next to it, in free space: the direction away from the drawing around
    it first (other points, link midpoints, ground symbols, weighted by closeness), then the
    other directions and farther out, until its box meets no label or tick text already on the
    axes (a leader line joins a label set farther out to its point)."""
    fig = ax.figure
    r = fig.canvas.get_renderer()
    mids = [0.5 * (P[a][0, :2] + P[b][0, :2]) for a, b in pairs]
    feet = [to_mm(xyz[:2]) - (0.0, 0.7 * size) for g, xyz in mech.ground.items() if g in pivots]
    crowd = np.concatenate([xy0] + [np.array(v).reshape(-1, 2) for v in (mids, feet) if v])
    taken = [t.get_window_extent(r) for t in ax.texts if t.get_text().strip()]
    # Points in pixels: a label must not sit on another point's marker either, nor on a path.
    marks = ax.transData.transform(xy0)
    curves, panel = curve_paths(ax), ax.get_window_extent(r)
    order = sorted(range(len(names)), key=lambda i: names[i] in coms)  # joints first, centres of mass after
    for i in order:
        p = names[i]
        d = xy0[i] - crowd
        r2 = np.einsum("ij,ij->i", d, d)
        near = r2 > 1e-12
        push = (d[near] / r2[near, None] ** 1.5).sum(axis=0)
        base = math.atan2(push[1], push[0]) if np.hypot(*push) > 0 else math.pi / 4
        look = dict(
            ha="center",
            va="center",
            zorder=7,
            fontsize=7.5 if p in coms else 9,
            color="0.3" if p in coms else "k",
            fontweight="normal" if p in coms else "bold",
            bbox=dict(boxstyle="round,pad=0.1", fc="white", ec="none", alpha=0.7),
        )
        t = ax.annotate(p, xy0[i], xytext=(0.0, 0.0), textcoords="offset points", **look)
        t.set_in_layout(False)
        # Nearest and facing away from the crowd first; the first spot clear of every label,
        # marker and path is taken, else the one that covers the least (labels, then markers,
        # then paths).
        best: tuple[tuple[int, int, int], tuple[float, float]] | None = None
        for dist in (11.0, 17.0, 25.0, 34.0, 45.0, 58.0, 72.0, 90.0, 110.0):
            for k in (0, 1, -1, 2, -2, 3, -3, 4, -4, 5, -5, 6, -6, 7, -7, 8):
                a = base + k * math.pi / 8
                t.xyann = (dist * math.cos(a), dist * math.sin(a))
                box = t.get_window_extent(r)
                cost = (
                    sum(box.overlaps(b) for b in taken),
                    sum(box.contains(*m) for j, m in enumerate(marks) if j != i and names[j] not in coms),
                    int(on_curves(box, curves, panel, spare=-3.0)),
                )
                if best is None or cost < best[0]:
                    best = (cost, t.xyann)
                if cost == (0, 0, 0):
                    break
            if best is not None and best[0] == (0, 0, 0):
                break
        assert best is not None
        t.remove()
        far = math.hypot(*best[1]) > 11.5
        t = ax.annotate(
            p,
            xy0[i],
            xytext=best[1],
            textcoords="offset points",
            arrowprops=dict(arrowstyle="-", color="0.5", lw=0.6, shrinkA=0, shrinkB=3) if far else None,
            **look,
        )
        t.set_in_layout(False)
        taken.append(t.get_window_extent(r))


def link_colors(n: int) -> list[tuple[float, float, float]]:
    """A colour for each of ``n`` links that a reader tells apart: matplotlib's ten, then their
    light tones (a head has a dozen links)."""
    dark, light = matplotlib.color_sequences["tab10"], matplotlib.color_sequences["tab20"][1::2]
    return [(dark if k < 10 else light)[k % 10] for k in range(n)]  # type: ignore[misc]


def positions_plot(mech: Mechanism, out_dir, n: int = 24, highlight: str | None = None) -> Path:
    """``positions.png``: the mechanism in ``n`` equally spaced crank positions over one period.

    Links thin and grey, the initial position (phi0) bold in colour, ground pivots as
    hatched triangles, thread guides as open squares, the closed path of every moving
    thread point (721 angles) bold and the thread at phi0 in orange. ``highlight`` names one
    more point whose path is drawn bold; the paths of all other moving points that are not
    merely centres of mass are drawn thin in their link's colour. Axes in mm, equal aspect.
    """
    pairs = segments(mech)
    phi = mech.phi0 + mech.period * np.arange(n) / n
    kin = reference.solve(mech, phi)
    P = {k: to_mm(kin.position(k)) for k in mech.point_names}
    path_kin = reference.solve(mech, mech.phi0 + np.linspace(0.0, mech.period, 721))
    traced = [p for p in (mech.thread or ()) if p not in mech.ground]
    if highlight and highlight not in traced:
        traced.append(highlight)
    coms = analysis.mass_centres(mech)
    others = [p for p in mech.moving_points if p not in coms and p not in traced]
    paths = {p: to_mm(path_kin.position(p)[:, :2]) for p in [*traced, *others]}

    # Extent first: the figure is shaped to the drawing (the legend sits to its right) and
    # the ground symbols are sized from it.
    allxy = np.concatenate([np.concatenate([P[p][:, :2] for p in P]), *paths.values()])
    lo, hi = allxy.min(axis=0), allxy.max(axis=0)
    size = 0.035 * float(max(hi - lo))
    pad = 0.08 * float(max(hi - lo))
    aspect = (hi[1] - lo[1] + 2 * pad + size) / (hi[0] - lo[0] + 2 * pad)
    box_w, box_h = (6.4, max(2.6, 6.4 * aspect)) if aspect < 1.0 else (max(3.2, 6.4 / aspect), 6.4)
    key = highlight or (traced[0] if traced else None)
    key_xy = paths[key] if key else None
    # A key path much smaller than the drawing (warp knitting's needle: 10 x 26 mm in 300 mm)
    # would be a squiggle under the ghost positions: it gets an enlarged panel of its own.
    enlarge = key_xy is not None and float(np.max(np.ptp(key_xy, axis=0))) < 0.25 * float(max(hi - lo))
    fig = figure(figsize=(max(7.6, box_w + 3.4), max(box_h + 1.3, 7.4 if enlarge else 0.0)), layout="constrained")
    gs = fig.add_gridspec(2, 2, width_ratios=(box_w, 3.2), height_ratios=(1.0, 1.0))
    ax = fig.add_subplot(gs[:, 0])
    side = fig.add_subplot(gs[1, 1]) if enlarge else None
    # All ghost positions in one collection: one draw call instead of n * links.
    ghost = [np.stack([P[a][i, :2], P[b][i, :2]]) for i in range(1, n) for a, b in pairs]
    ax.add_collection(LineCollection(ghost, colors="0.6", linewidths=0.7, alpha=0.6, zorder=1))

    # Every other moving point's closed path, thin, in the colour of its link (of the one
    # pivoted on the ground if it is on several: a crank pin's circle is the crank's).
    colors = link_colors(len(mech.links))
    for p in others:
        carriers = [k for k, l in enumerate(mech.links) if p in l.points]
        k = next((k for k in carriers if any(g in mech.ground for g in mech.links[k].points)), carriers[0])
        ax.plot(paths[p][:, 0], paths[p][:, 1], color=colors[k], lw=0.9, alpha=0.85, zorder=1.5)
    if others:
        ax.plot([], [], color="0.3", lw=0.9, label="paths of the other points\n(in their link's colour)")
    for k, p in enumerate(traced):
        ax.plot(
            paths[p][:, 0],
            paths[p][:, 1],
            color=("#c51b7d", "#00a0a0", "#8c6d00")[k % 3],
            lw=1.8,
            zorder=2,
            label=f"path of {p}",
        )
    # Ghost positions of the traced points, so the crank-angle spacing along the path shows.
    for p in traced:
        ax.plot(P[p][1:, 0], P[p][1:, 1], "o", ms=2.5, color="0.4", zorder=2)

    if mech.thread:
        th = np.stack([P[p][0, :2] for p in mech.thread])
        ax.plot(
            th[:, 0],
            th[:, 1],
            color="orange",
            lw=2.0,
            zorder=3,
            label="thread at φ₀ (" + "–".join(mech.thread) + ")",
        )

    for k, link in enumerate(mech.links):
        segs = [np.stack([P[a][0, :2], P[b][0, :2]]) for a, b in pairs if a in link.points and b in link.points]
        c = colors[k]
        ax.add_collection(LineCollection(segs, colors=[c], linewidths=3.0, zorder=4, capstyle="round"))
        ax.plot([], [], color=c, lw=3.0, label=link.name)  # legend proxy for the collection
        pts = [p for p in link.points if p not in mech.ground and p != link.com]
        ax.plot([P[p][0, 0] for p in pts], [P[p][0, 1] for p in pts], "o", ms=5, mfc="white", mec=c, mew=1.5, zorder=5)
        if link.com is not None:
            s = P[link.com][0]
            # The centre of mass: a circle with a cross (⊕) from two plain markers.
            ax.plot(s[0], s[1], "o", ms=7, mfc="white", mec=c, mew=1.2, zorder=5)
            ax.plot(s[0], s[1], "+", ms=7, color=c, mew=1.2, zorder=5)

    pivots = {p for l in mech.links for p in l.points if p in mech.ground}
    for g, xyz in mech.ground.items():
        x, y = to_mm(xyz[0]), to_mm(xyz[1])
        if g in pivots:
            tri = [(x, y), (x - 0.6 * size, y - size), (x + 0.6 * size, y - size)]
            ax.add_patch(Polygon(tri, closed=True, fc="white", ec="k", lw=1.0, zorder=3.5))
            ax.add_patch(
                Rectangle(
                    (x - 0.9 * size, y - 1.35 * size),
                    1.8 * size,
                    0.35 * size,
                    fc="none",
                    ec="none",
                    hatch="////",
                    zorder=3.4,
                )
            )
            ax.plot([x - 0.9 * size, x + 0.9 * size], [y - size] * 2, color="k", lw=1.0, zorder=3.5)
            ax.plot(x, y, "o", ms=4.5, mfc="white", mec="k", zorder=6)
        else:
            ax.plot(x, y, "s", ms=7, mfc="white", mec="k", mew=1.2, zorder=6)

    main_ticks: list = []
    if key is not None and key_xy is not None and not enlarge:
        main_ticks = _angle_ticks(ax, mech, path_kin.phi, key_xy, size, label_every=90)
    elif key_xy is not None:
        # Where the enlarged path is on the drawing.
        (x0, y0), (x1, y1) = key_xy.min(axis=0) - size, key_xy.max(axis=0) + size
        ax.add_patch(Rectangle((x0, y0), x1 - x0, y1 - y0, fc="none", ec="0.3", lw=0.8, ls="--", zorder=4))
    _rotation_arrow(ax, mech, size)
    ax.set_xlim(lo[0] - pad, hi[0] + pad)
    ax.set_ylim(lo[1] - pad - size, hi[1] + pad)
    ax.set_aspect("equal", adjustable="box", anchor="NW")  # blank space to the right: cropped on saving
    ax.grid(True, alpha=0.25)
    ax.set_xlabel("x [mm]")
    ax.set_ylabel("y [mm]")
    ax.plot([], [], color="0.55", lw=0.7, label=f"{n} crank positions")
    ax.plot(
        [],
        [],
        "|",
        color="k",
        ms=7,
        label="crank angle every 30° along the path\n(from φ₀, labelled every 90°)",
    )
    legend = fig.legend(
        *ax.get_legend_handles_labels(),
        loc="upper left",
        bbox_to_anchor=(0.0, 1.0),
        bbox_transform=fig.add_subplot(gs[0, 1]).transAxes,
        borderaxespad=0.0,
        fontsize=8,
        framealpha=0.9,
    )
    fig.axes[-1].axis("off")
    if side is not None:
        # The legend hangs from the top of its cell, which starts below the figure's title; a
        # long one (a head's dozen links) would run into the enlarged path's title below it: its
        # row is made as tall as the title's room, the legend and the path's title are.
        tall = legend.get_window_extent().height / fig.dpi
        whole = fig.get_figheight()
        top = min(max(tall + 1.3, 0.5 * whole), whole - 3.0)
        gs.set_height_ratios([top, whole - top])
    if side is not None and key is not None and key_xy is not None:
        xy = key_xy
        side.plot(xy[:, 0], xy[:, 1], color="#c51b7d", lw=1.8)
        span = float(np.max(np.ptp(xy, axis=0)))
        side_ticks = _angle_ticks(side, mech, path_kin.phi, xy, 0.06 * span, label_every=30 if mech.period < 7 else 60)
        side.set_aspect("equal", adjustable="datalim")
        side.margins(0.18)
        side.grid(True, alpha=0.3)
        side.set_xlabel("x [mm]", fontsize=8.5)
        side.set_ylabel("y [mm]", fontsize=8.5)
        side.tick_params(labelsize=8)
        side.set_title(
            f"path of {key} enlarged: Δx {np.ptp(xy[:, 0]):.2f} mm, Δy {np.ptp(xy[:, 1]):.2f} mm\n"
            f"ticks every 30° of crank angle from φ₀, {direction(mech.speed)}",
            fontsize=8.5,
        )
    # Left-aligned: a tall drawing's axes are narrower than the title, which runs on over the legend.
    ax.set_title(
        title(mech, f"{n} positions over one period, bold: φ₀ = {math.degrees(mech.phi0):g}°"),
        fontsize=10,
        loc="left",
    )
    # Labels last, once the layout has fixed where everything is on the canvas; the layout is
    # then kept as it is (the labels were placed for it), so that saving does not run the
    # constrained layout engine again at its bounding-box pass and at its drawing.
    fig.draw_without_rendering()
    fig.set_layout_engine("none")
    _label_ticks(ax, main_ticks)
    if side is not None:
        _label_ticks(side, side_ticks)
    names = list(mech.point_names)
    _place_labels(ax, mech, names, np.array([P[p][0, :2] for p in names]), pairs, P, size, coms, pivots)
    return save(fig, out_dir, "positions.png", tight=True)


# ----------------------------------------------------------------------------- 3D contour (seed 003 Fig. 2)
def contour_plot(mech: Mechanism, out_dir, n: int = 6) -> Path | None:
    """``thread_contour.png``: the mechanism and the needle-thread contour in ``n`` crank
    positions over one period (seed 003, Fig. 2): front view (x-y) and, beside it, top view
    (x-z, seen from +y, so +z points down the page), equal aspect, mm; one colour per
    position, the thread thick and the links thin, the guides as squares, the eyelets named
    at phi0. None unless the thread is spatial (some point off z = 0)."""
    if not mech.thread or not analysis.is_spatial(mech):
        return None
    pairs = segments(mech)
    phi = mech.phi0 + math.copysign(mech.period, mech.speed) * np.arange(n) / n
    kin = reference.solve(mech, phi)
    P = {k: to_mm(kin.position(k)) for k in mech.point_names}
    path = reference.solve(mech, mech.phi0 + np.linspace(0.0, mech.period, 361))
    eyelets = [p for p in mech.thread if p not in mech.ground]
    guides = [p for p in mech.thread if p in mech.ground]
    pivots = [p for p in mech.ground if p not in guides and any(p in l.points for l in mech.links)]
    cmap = plt.get_cmap("viridis")
    cols = [cmap(0.78 * i / max(n - 1, 1)) for i in range(n)]

    allp = np.concatenate([P[p] for p in P] + [to_mm(path.position(e)) for e in eyelets])
    lo, hi = allp.min(axis=0), allp.max(axis=0)
    pad = 0.07 * float(max(hi - lo))
    fig = figure(figsize=(13.0, 6.8))
    gs = fig.add_gridspec(2, 2, width_ratios=(1.0, 1.0), height_ratios=(0.42, 0.58))
    # Fixed margins (one draw, then the crop): the suptitle and the panels' titles above, the
    # top view's x label and y label between the panels; equal axes shrink inside their cells.
    place(fig, gs, left=0.85, right=0.2, top=0.95, bottom=0.6, hgap=0.75, wgap=0.95)
    af = fig.add_subplot(gs[:, 0])
    at = fig.add_subplot(gs[0, 1], sharex=af)
    al = fig.add_subplot(gs[1, 1])
    al.axis("off")
    names: list = []  # the eyelets' names, placed clear of the thread once the panels are final
    for ax, j in ((af, 1), (at, 2)):
        for e in eyelets:
            q = to_mm(path.position(e))
            ax.plot(q[:, 0], q[:, j], color="0.7", lw=0.8, zorder=1)
        for i in reversed(range(n)):  # phi0 last, on top
            c, first = cols[i], i == 0
            segs = [np.stack([P[a][i, [0, j]], P[b][i, [0, j]]]) for a, b in pairs]
            ax.add_collection(
                LineCollection(
                    segs, colors=[c], linewidths=1.6 if first else 0.8, alpha=0.9 if first else 0.45, zorder=2 + first
                )
            )
            th = np.stack([P[p][i, [0, j]] for p in mech.thread])
            ax.plot(
                th[:, 0],
                th[:, 1],
                color=c,
                lw=2.6 if first else 1.5,
                zorder=4 + first,
                marker="o",
                ms=4 if first else 3,
                mfc="white",
                mec=c,
                label=f"φ₁ = {math.degrees(phi[i]):g}°" + (" (φ₀)" if first else ""),
            )
        for g in guides:
            ax.plot(P[g][0, 0], P[g][0, j], "s", ms=8, mfc="white", mec="k", mew=1.3, zorder=7)
            ax.annotate(
                g,
                (P[g][0, 0], P[g][0, j]),
                xytext=(8, 0),
                textcoords="offset points",
                ha="left",
                va="center",
                fontsize=9,
                fontweight="bold",
            )
        for g in pivots:
            ax.plot(P[g][0, 0], P[g][0, j], "^", ms=8, mfc="white", mec="k", zorder=7)
            ax.annotate(
                g,
                (P[g][0, 0], P[g][0, j]),
                xytext=(0, -9),
                textcoords="offset points",
                ha="center",
                va="top",
                fontsize=8,
            )
        for e in eyelets:
            names.append(
                ax.annotate(
                    e,
                    (P[e][0, 0], P[e][0, j]),
                    xytext=(7, 5),
                    textcoords="offset points",
                    fontsize=9,
                    fontweight="bold",
                    color=darker(cols[0]),
                    zorder=8,
                    bbox=dict(boxstyle="round,pad=0.1", fc="white", ec="none", alpha=0.75),
                )
            )
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
    al.legend(
        handles,
        labels,
        loc="upper center",
        ncol=2,
        fontsize=9,
        frameon=False,
        title=f"crank positions: thread {'–'.join(mech.thread)} thick, links thin",
        title_fontsize=9,
    )
    fig.suptitle(title(mech, f"needle-thread contour in {n} crank positions"), fontsize=10)
    for i, t in enumerate(names):  # the layout is fixed (place): drawn once
        place_clear(
            t, [(dx, dy) for dy in (5.0, -14.0, 16.0, -25.0) for dx in (7.0, -22.0, 16.0, -31.0)], laid_out=i > 0
        )
    return save(fig, out_dir, "thread_contour.png", tight=True)
