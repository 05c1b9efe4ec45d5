"""The one palette that the MJCF builder, the video and the figures share.

A link has the same colour in ``positions.png``, in every figure that names it and in the
MP4 (the builder's materials take these colours), so a reader moving from a plot to the
video finds the lever where it was. Colours are hex strings (sRGB); :func:`rgba` gives the
0..1 floats MuJoCo wants. No matplotlib and no mujoco here: both sides import this module.
"""

from __future__ import annotations

# matplotlib's "tab10": distinct on white and on the video's light grey backdrop.
LINKS = (
    "#1f77b4",
    "#ff7f0e",
    "#2ca02c",
    "#d62728",
    "#9467bd",
    "#8c564b",
    "#e377c2",
    "#7f7f7f",
    "#bcbd22",
    "#17becf",
)
GROUND = "#5a5a61"  # frame, pivots and rails
THREAD = "#ffa500"  # the needle thread (orange)
KEY_PATH = "#c51b7d"  # the key point (eyelet, needle) and the path it traces
OTHER_PATHS = ("#00a0a0", "#8c6d00")  # further traced points
MUJOCO = "#1f77b4"  # MuJoCo's curve where a figure shows one quantity
REFERENCE = "#000000"  # the vector-method reference
RK4 = "#d62728"  # the paper's fixed-step RK4
THRESHOLD = "#d62728"  # an agreement threshold on a residual panel


def link(i: int) -> str:
    """Colour of the ``i``-th link of a mechanism file (0-based, in file order)."""
    return LINKS[i % len(LINKS)]


def rgba(color: str, alpha: float = 1.0) -> tuple[float, float, float, float]:
    """``#rrggbb`` as MuJoCo's rgba floats 0..1."""
    h = color.lstrip("#")
    return (int(h[0:2], 16) / 255.0, int(h[2:4], 16) / 255.0, int(h[4:6], 16) / 255.0, alpha)
