"""``index.html``: one page per run with the agreement table, every figure and the video.

Presentation only, like the figures: the page is built from a finished
:class:`mjlink.pipeline.SimulateResult` and the names of the files beside it. Links are
relative (the folder can be moved or served as is) and the page loads nothing from the
network: no fonts, scripts or styles from elsewhere. A small inline script records on
``<body>`` how many images loaded (``data-images="loaded/total"``) and whether the video
could be decoded (``data-video``), so a headless browser can check the page.
"""

from __future__ import annotations

import html
from collections.abc import Iterable
from typing import Any

_CSS = """
body { font-family: sans-serif; margin: 1.5em auto; max-width: 1400px; color: #222; }
h1 { font-size: 1.4em; margin-bottom: 0.1em; } h2 { font-size: 1.15em; margin-top: 1.6em; }
.sub { color: #555; margin-top: 0; }
table { border-collapse: collapse; font-size: 0.9em; }
th, td { border: 1px solid #ccc; padding: 0.25em 0.6em; text-align: left; }
td.num { text-align: right; font-family: monospace; }
.pass { color: #1a7f37; font-weight: bold; } .fail { color: #c62828; font-weight: bold; }
.info { color: #666; }
figure { margin: 1em 0 2em 0; } figure img { max-width: 100%; border: 1px solid #ddd; }
figcaption { color: #555; font-size: 0.9em; }
video { max-width: 100%; border: 1px solid #ddd; }
"""

_SCRIPT = """
window.addEventListener('load', function () {
  var imgs = Array.prototype.slice.call(document.images);
  var ok = imgs.filter(function (i) { return i.complete && i.naturalWidth > 0; }).length;
  document.body.setAttribute('data-images', ok + '/' + imgs.length);
});
var v = document.querySelector('video');
if (v) {
  v.addEventListener('loadeddata', function () { document.body.setAttribute('data-video', 'loaded'); });
  v.addEventListener('error', function () { document.body.setAttribute('data-video', 'error'); }, true);
}
"""

_MARK = {"pass": ("✓ pass", "pass"), "FAIL": ("✗ FAIL", "fail"), "informational": ("–", "info")}


def _caption(name: str) -> str:
    """What a figure file shows, in words, from its name."""
    stem = name.rsplit(".", 1)[0]
    known = {
        "speed_vs_time": "crank speed and acceleration of the run-up against time, zoom and residuals",
        "speed_vs_angle": "the run-up against crank angle",
        "positions": "the mechanism in 24 positions, paths, rotation and crank-angle ticks",
        "thread_length": "thread length, MuJoCo against the reference, and the difference",
        "thread_feed": "needle-thread feed Pd over one turn",
        "thread_contour": "spatial thread contour, front and top view",
        "torque": "driving torque, power and energy fluctuation with the flywheel estimate",
        "reactions": "force in every pair, small multiples with the peaks",
        "reaction_polar": "polar load diagrams of the bearings",
        "shaking": "loads on the frame (shaking force, gravity, forces): hodograph and moment",
        "steady": "steady motion without and with the flywheel",
        "phase_study": "paths for several settings of the geared crank",
        "cyclogram": "timing diagram of the head over one stitch, with the makers' windows",
        "thread_balance": "needle thread balance over one stitch: supply, demand, slack and shortfall",
    }
    if stem in known:
        return known[stem]
    for prefix, words in (
        ("kinematics_", "motion of point {}: components, magnitudes, residuals"),
        ("slider_", "slider {}: position, velocity, acceleration"),
        ("pressure_angle_", "pressure angle at {}"),
        ("link_", "rotation of link {}"),
    ):
        if stem.startswith(prefix):
            rest = stem[len(prefix) :]
            if rest.endswith("_spectrum"):
                return f"harmonics of the acceleration of slider {rest[: -len('_spectrum')]}"
            return words.format(rest)
    return stem


# Figures in the order an engineer reads a run: the mechanism, its motion, then its loads.
_ORDER = (
    "positions",
    "cyclogram",
    "thread_balance",
    "speed_vs_time",
    "speed_vs_angle",
    "kinematics_",
    "thread_length",
    "thread_feed",
    "thread_contour",
    "slider_",
    "pressure_angle_",
    "link_",
    "phase_study",
    "torque",
    "reactions",
    "reaction_polar",
    "shaking",
    "steady",
)


def _rank(name: str) -> tuple[int, str]:
    return next((i for i, p in enumerate(_ORDER) if name.startswith(p)), len(_ORDER)), name


def _num(v: Any, unit: str) -> str:
    if v is None:
        return "–"
    if unit == "um":
        return f"{v:.4f}"
    return f"{v:.0f}" if unit == "" else f"{v:.3g}"


def index_html(result: Any, files: Iterable[str]) -> str:
    """The page for ``result`` (a :class:`mjlink.pipeline.SimulateResult`) in the folder that
    holds ``files`` (names): title, the verdict, the agreement table with a pass or fail mark
    on every thresholded row, the video and every PNG with a caption, the data files."""
    e = html.escape
    names = sorted(files)
    pngs = sorted((n for n in names if n.endswith(".png")), key=_rank)
    videos = [n for n in names if n.endswith(".mp4")]
    data = [n for n in names if n.endswith((".csv", ".json", ".xml"))]
    rows = []
    for a in result.agreements:
        for c in a.checks():
            text, cls = _MARK[c.result]
            limit = "–" if c.limit is None else (f"≥ {c.limit:g}" if c.at_least else f"{c.limit:g}")
            rows.append(
                f"<tr><td>{e(c.run)}</td><td>{e(c.quantity)}</td><td class='num'>{_num(c.value, c.unit)}</td>"
                f"<td>{e(c.unit)}</td><td class='num'>{e(limit)}</td><td class='{cls}'>{text}</td></tr>"
            )
    verdict = (
        "<p class='pass'>✓ every threshold holds</p>"
        if not result.failures
        else "<p class='fail'>✗ thresholds missed:</p><ul>"
        + "".join(f"<li>{e(f)}</li>" for f in result.failures)
        + "</ul>"
    )
    parts = [
        "<!DOCTYPE html>",
        "<html lang='en'><head><meta charset='utf-8'>",
        f"<title>{e(result.mechanism)}: mjlink simulate</title>",
        f"<style>{_CSS}</style></head><body>",
        f"<h1>{e(result.mechanism)}</h1><p class='sub'>{e(result.title)}</p>",
        f"<p class='sub'>MuJoCo {e(str(result.mujoco_version))}; mechanism file {e(str(result.source))}</p>",
        "<h2>Agreement of MuJoCo with the vector-method reference</h2>",
        verdict,
        "<table><thead><tr><th>run</th><th>quantity</th><th>measured</th><th>unit</th>"
        "<th>threshold</th><th>result</th></tr></thead><tbody>",
        *rows,
        "</tbody></table>",
    ]
    head = getattr(result, "timing", None)
    if head is not None:
        parts += [
            f"<h2>Timing over one stitch</h2><p class='sub'>built to the {e(head.target)} settings; the other "
            "makers' rows show which of their windows the head also meets</p>",
            "<table><thead><tr><th>settings</th><th>check</th><th>measured</th><th>window</th><th>unit</th>"
            "<th>result</th></tr></thead><tbody>",
        ]
        for r in head.rows:
            text, cls = _MARK[r.verdict] if r.counts else (r.verdict, "info")
            parts.append(
                f"<tr><td>{e(r.maker or 'every head')}</td><td title='{e(r.what)}'>{e(r.label)}</td>"
                f"<td class='num'>{e(r.shown(r.value))}</td><td class='num'>{e(r.window_text())}</td>"
                f"<td>{e(r.unit)}</td><td class='{cls}'>{e(text)}</td></tr>"
            )
        parts.append("</tbody></table>")
    for v in videos:
        parts += [
            "<h2>Video</h2>",
            f"<video controls loop muted preload='auto' src='{e(v)}'></video>",
            f"<p class='sub'><a href='{e(v)}'>{e(v)}</a></p>",
        ]
    if pngs:
        parts.append("<h2>Figures</h2>")
    for p in pngs:
        parts.append(
            f"<figure id='{e(p)}'><a href='{e(p)}'><img src='{e(p)}' alt='{e(_caption(p))}' loading='eager'></a>"
            f"<figcaption>{e(p)}: {e(_caption(p))}</figcaption></figure>"
        )
    if data:
        parts.append("<h2>Data</h2><ul>" + "".join(f"<li><a href='{e(d)}'>{e(d)}</a></li>" for d in data) + "</ul>")
    parts += [f"<script>{_SCRIPT}</script>", "</body></html>"]
    return "\n".join(parts) + "\n"
