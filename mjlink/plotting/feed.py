"""The fabric under the presser foot (:mod:`mjlink.sim.feed`): a stitch against the main-shaft
angle (``feed.png``) and the stitch length against speed (``feed_speed.png``)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from matplotlib.axes import Axes

from ..model.mechanism import Mechanism
from ..units import MM
from .style import angle_ticks, place, save, subplots, title

if TYPE_CHECKING:
    from ..sim.feed import FeedRun


def _shade(ax: Axes, theta: np.ndarray, mask: np.ndarray, **style: object) -> None:
    """Spans of ``theta`` (deg) where ``mask`` holds, shaded on ``ax``."""
    edges = np.flatnonzero(np.diff(np.concatenate([[0], mask.astype(np.int8), [0]])))
    step = float(theta[1] - theta[0]) if len(theta) > 1 else 1.0
    for a, b in zip(edges[::2], edges[1::2], strict=True):
        ax.axvspan(theta[a], theta[b - 1] + step, lw=0, **style)  # type: ignore[arg-type]


def feed_plot(mech: Mechanism, run: FeedRun, out_dir: Path | str) -> Path:
    """``feed.png``: the last stitch of a feed run (:class:`mjlink.sim.feed.FeedRun`) against the
    main-shaft angle. Above, heights over the throat plate: the dog's teeth, the fabric's top
    and the presser foot's sole, the foot's separations from the fabric shaded; below, along the
    feed: the dog's teeth and the fabric since the stitch began, the dog's contact with the
    fabric shaded."""
    fig, (ax, bx) = subplots(2, 1, figsize=(10.0, 7.0), sharex=True, height_ratios=[1.2, 1.0])
    place(fig, ax.get_gridspec(), left=1.0, right=0.3, top=1.1, bottom=0.6, hgap=0.3)
    th = run.theta
    ax.plot(th, run.dog / MM, color="C0", label="the dog's teeth")
    ax.plot(th, run.top / MM, color="C2", label="the fabric's top")
    ax.plot(th, run.foot / MM, color="C3", lw=1.0, ls="--", label="the presser foot's sole")
    ax.axhline(0.0, color="0.4", lw=0.8)
    _shade(ax, th, run.separated, color="C3", alpha=0.15)
    deg, start = run.separation
    off = "never off the fabric" if start is None else f"off the fabric {deg:.0f} deg (shaded), from {start:.0f} deg"
    ax.set_ylabel("above the plate [mm]")
    ax.legend(loc="upper right", fontsize=7.5, framealpha=0.9)
    ax.set_title(
        f"{run.speed_rpm:.0f} rpm: stitch {run.stitch / MM:.3f} mm, {run.error:+.2%} against the dog's "
        f"{run.geometric / MM:.3f} mm with its teeth up;\nthe foot {off}; "
        f"spring load {run.load_factor:.3f}x its {run.presser.preload:g} N",
        fontsize=8.5,
    )
    bx.plot(th, run.dog_x / MM, color="C0", label="the dog's teeth")
    plies = run.ply_x.shape[1]
    bx.plot(th, run.fabric / MM, color="C2", label="the fabric" if plies == 1 else "the bottom ply")
    if plies > 1:
        bx.plot(
            th,
            run.ply_x[:, -1] / MM,
            color="C4",
            ls="--",
            label=f"the top ply (shifts {run.shift / MM:+.3f} mm a stitch)",
        )
    _shade(bx, th, run.dog_force > 0.0, color="C0", alpha=0.12)
    bx.set_ylabel("along the feed, since the stitch began [mm]")
    bx.legend(
        loc="upper left", fontsize=7.5, framealpha=0.9, title="shaded: the teeth touch the fabric", title_fontsize=7.5
    )
    bx.set_xlabel("main-shaft angle from the needle bar's top dead centre [deg]")
    angle_ticks(bx, 0.0, 360.0)
    for a in (ax, bx):
        a.grid(alpha=0.3)
    fig.suptitle(title(mech, "the fabric fed under the presser foot (MuJoCo contacts)"), fontsize=11, y=0.995)
    return save(fig, out_dir, "feed.png")


def feed_speed_plot(mech: Mechanism, runs: tuple[FeedRun, ...], limit: float, out_dir: Path | str) -> Path:
    """``feed_speed.png``: over a sweep of speeds, the stitch length's error against the dog's
    advance with the limit either side; below, the degrees of the stitch the foot is off the
    fabric."""
    rpm = np.array([r.speed_rpm for r in runs])
    fig, (ax, bx) = subplots(2, 1, figsize=(9.0, 6.5), sharex=True, height_ratios=[1.3, 1.0])
    place(fig, ax.get_gridspec(), left=1.0, right=0.3, top=0.95, bottom=0.6, hgap=0.3)
    ax.plot(rpm, [r.error * 100.0 for r in runs], "o-", color="C0", label="stitch length against the dog's advance")
    for sign in (1.0, -1.0):
        ax.axhline(sign * limit * 100.0, color="C3", lw=0.9, ls="--", label=f"±{limit:.0%}" if sign > 0 else None)
    ax.axhline(0.0, color="0.4", lw=0.8)
    ax.set_ylabel("error [%]")
    ax.legend(loc="upper left", fontsize=7.5, framealpha=0.9)
    ax.set_title(
        f"the dog's advance with its teeth up: {runs[0].geometric / MM:.3f} mm; {runs[0].stitches} stitches a speed",
        fontsize=8.5,
    )
    bx.plot(rpm, [r.separation[0] for r in runs], "s-", color="C3", label="the foot off the fabric")
    bx.set_ylabel("of the stitch [deg]")
    bx.set_xlabel("main-shaft speed [rpm]")
    bx.legend(loc="upper left", fontsize=7.5, framealpha=0.9)
    for a in (ax, bx):
        a.grid(alpha=0.3)
    fig.suptitle(title(mech, "stitch length against speed (MuJoCo contacts)"), fontsize=11, y=0.995)
    return save(fig, out_dir, "feed_speed.png")
