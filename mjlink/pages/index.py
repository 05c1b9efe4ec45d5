"""``index.html``: one page per run, led by the design (the drawing at the crank's setting, the
headline numbers with their units, the dimensions and a head's timing), then the contents, the
agreement table, the strokes of every point, every figure and the video.

Presentation only, like the figures: the page is built from a finished
:class:`mjlink.pipeline.SimulateResult` and the names of the files beside it. Links are
relative (the folder can be moved or served as is) and the page loads nothing from the
network: no fonts, scripts or styles from elsewhere. A small inline script records on
``<body>`` how many images loaded (``data-images="loaded/total"``) and whether the video
could be decoded (``data-video``), so a headless browser can check the page.
"""

from __future__ import annotations

import html
import math
from collections.abc import Iterable
from typing import Any

from ..units import shown

_CSS = """
:root { color-scheme: light dark; --fg: #222; --bg: #fff; --muted: #555; --line: #ccc; --ok: #1a7f37; --bad: #c62828; }
#timing th, #timing td:not(:nth-child(2)) { white-space: nowrap; }
#timing td small { color: var(--muted); }
td.unit { white-space: nowrap; overflow-wrap: normal; }
@media (prefers-color-scheme: dark) {
  :root { --fg: #e6e6e6; --bg: #16181b; --muted: #a8a8a8; --line: #444; --ok: #4ccb6c; --bad: #ff6b6b; }
  img { background: #fff; }
}
* { box-sizing: border-box; }
body { font-family: sans-serif; margin: 1em auto; padding: 0 1em; max-width: 1240px; color: var(--fg);
       background: var(--bg); overflow-wrap: anywhere; }
h1 { font-size: 1.4em; margin: 0 0 0.1em 0; } h2 { font-size: 1.15em; margin-top: 1.6em; }
h3 { font-size: 1em; margin: 1em 0 0.3em 0; }
.sub { color: var(--muted); margin-top: 0; } caption { text-align: left; padding-bottom: 0.3em; }
table { border-collapse: collapse; font-size: 0.9em; max-width: 100%; }
th, td { border: 1px solid var(--line); padding: 0.2em 0.5em; text-align: left; vertical-align: top; }
td.num { text-align: right; font-family: monospace; white-space: nowrap; }
.pass { color: var(--ok); font-weight: bold; } .fail { color: var(--bad); font-weight: bold; }
.info { color: var(--muted); }
.wide { overflow-x: auto; max-width: 100%; }
.design { display: grid; grid-template-columns: minmax(0, 3fr) minmax(0, 2fr); gap: 1.2em; align-items: start; }
.design img { width: 100%; border: 1px solid var(--line); }
.columns { columns: 2 18em; column-gap: 1.5em; } .columns table { width: 100%; }
nav ol { columns: 3 14em; margin: 0.3em 0; padding-left: 1.4em; }
figure { margin: 1em 0 2em 0; } figure img { max-width: 100%; border: 1px solid var(--line); }
figcaption { color: var(--muted); font-size: 0.9em; }
video { max-width: 100%; border: 1px solid var(--line); }
@media (max-width: 900px) { .design { grid-template-columns: minmax(0, 1fr); } }
@media print {
  :root { --fg: #000; --bg: #fff; --muted: #333; --line: #999; }
  nav, video { display: none; } body { max-width: none; margin: 0; }
  figure, table, .design { break-inside: avoid; } a { color: inherit; text-decoration: none; }
}
"""

_SCRIPT = """
window.addEventListener('load', function () {
  var imgs = Array.prototype.slice.call(document.images);
  var ok = imgs.filter(function (i) { return i.complete && i.naturalWidth > 0; }).length;
  var b = document.body, root = document.documentElement;
  b.setAttribute('data-images', ok + '/' + imgs.length);
  b.setAttribute('data-overflow-px', String(Math.max(0, root.scrollWidth - root.clientWidth)));
  var s = document.getElementById('summary');
  if (s) { b.setAttribute('data-summary-bottom-px', String(Math.round(s.getBoundingClientRect().bottom + window.scrollY))); }
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
        "thread_tension": "needle thread tension over one stitch in each stretch, the check spring, the discs",
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
    "thread_tension",
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


def _value(v: float) -> str:
    return f"{v:.4g}" if abs(v) < 1e4 else f"{v:.0f}"


def _metric_rows(rows: Iterable[Any]) -> str:
    """Table rows of summary rows: words, the value on an element naming its study metric, unit."""
    e = html.escape
    return "".join(
        f"<tr><td>{e(r.label)}</td><td class='num' data-metric='{e(r.metric)}'>{_value(r.value)}</td>"
        f"<td class='unit'>{e(shown(r.unit))}</td></tr>"
        for r in rows
    )


def _design(result: Any, pngs: list[str], names: list[str]) -> list[str]:
    """The first screen: the drawing at the crank's setting, the headline numbers and the file's
    dimensions (each value on an element naming its study metric or parameter path)."""
    e = html.escape
    d = result.design
    rpm = abs(d.speed) * 60.0 / (2.0 * math.pi)
    sense = "counter-clockwise" if d.speed > 0 else "clockwise"
    lead = getattr(d, "lead", 0)
    rows = _metric_rows(d.headline[:lead])
    head = getattr(result, "timing", None)
    if head is not None:  # a sewing head: its timing at a glance after its stroke and feed, the table below
        counted = [r for r in head.rows if r.counts]
        met = sum(r.ok for r in counted)
        ok = int(met == len(counted))
        which = f"{e(head.target)} settings and the general ones" if head.target else "the general ones"
        rows += (
            f"<tr><td><a href='#timing'>timing checks met</a> ({which}; 1 when all are)</td>"
            f"<td class='num' data-metric='timing_ok'>{ok}</td><td>{met} of {len(counted)}</td></tr>"
        )
    rows += _metric_rows(d.headline[lead:])
    dims = _dimensions(getattr(d, "members", {}), d.dimensions)
    left = (
        f"<a href='positions.png'><img src='positions.png' alt='{e(_caption('positions.png'))}' loading='eager'></a>"
        f"<p class='sub'>bold: the design at the crank's setting φ0 = {d.phi0_deg:g}°; grey: 23 more positions "
        "over the period</p>"
        if "positions.png" in pngs
        else f"<p class='sub'>the crank's setting φ0 = {d.phi0_deg:g}° (no drawing: run without --no-plots)</p>"
    )
    drag = (
        "<p><a href='design.html'>Drag to design</a>: move the pivots and change the dimensions in your "
        "browser, watch the paths and these numbers follow, save the edited file.</p>"
        if "design.html" in names
        else ""
    )
    return [
        "<section id='design'><h2>Design</h2>",
        drag,
        "<div class='design'>",
        f"<div>{left}</div><div>",
        f"<table id='summary'><caption class='sub'>at {rpm:.0f} rpm ({abs(d.speed):.4g} rad/s), {sense}; "
        "strokes along the axis the point moves most</caption>",
        "<thead><tr><th>what the design does</th><th>value</th><th>unit</th></tr></thead><tbody>",
        rows,
        "</tbody></table>",
        "<h3>Dimensions (the file's, by study path)</h3>",
        dims,
        "</div></div></section>",
    ]


def _dimensions(members: dict[str, str], dims: Iterable[tuple[str, float, str]]) -> str:
    """The file's dimensions, one folded table per member of the mechanism (the frame, each
    link, the input: :func:`mjlink.analysis.summary.members`), every value on an element naming
    its study path."""
    e = html.escape
    groups: dict[str, list[tuple[str, float, str]]] = {}
    for p, v, u in dims:
        groups.setdefault(members.get(p, "dimensions"), []).append((p, v, u))
    out = ["<div id='dimensions'>"]
    for member, rows in groups.items():
        body = "".join(
            f"<tr><td>{e(p)}</td><td class='num' data-param='{e(p)}'>{_value(v)}</td><td>{e(u)}</td></tr>"
            for p, v, u in rows
        )
        out.append(
            f"<details><summary>{e(member)} ({len(rows)})</summary><table><thead><tr><th>parameter</th>"
            f"<th>value</th><th>unit</th></tr></thead><tbody>{body}</tbody></table></details>"
        )
    out.append("</div>")
    return "".join(out)


def _strokes(result: Any) -> list[str]:
    rows = _metric_rows(result.design.points)
    return [
        "<section id='strokes'><h2>Strokes of the moving points</h2><div class='columns'>",
        "<table><thead><tr><th>point</th><th>value</th><th>unit</th></tr></thead><tbody>",
        rows,
        "</tbody></table></div></section>",
    ]


def _contents(entries: list[tuple[str, str]]) -> str:
    e = html.escape
    items = "".join(f"<li><a href='#{e(i)}'>{e(t)}</a></li>" for i, t in entries)
    return f"<nav id='contents'><h2>Contents</h2><ol>{items}</ol></nav>"


def index_html(result: Any, files: Iterable[str]) -> str:
    """The page for ``result`` (a :class:`mjlink.pipeline.SimulateResult`) in the folder that
    holds ``files`` (names). First the design: the drawing at the crank's setting, the headline
    numbers and the dimensions, and a head's timing table; then the contents; then the
    verification (the agreement table with a pass or fail mark on every thresholded row), the
    strokes of every point, the video, every PNG with a caption and the data files."""
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
                f"<td class='unit'>{e(shown(c.unit))}</td><td class='num'>{e(limit)}</td><td class='{cls}'>{text}</td></tr>"
            )
    verdict = (
        "<p class='pass'>✓ MuJoCo agrees with the vector-method reference: every threshold holds "
        "(<a href='#agreement'>agreement</a>)</p>"
        if not result.failures
        else "<p class='fail'>✗ thresholds missed:</p><ul>"
        + "".join(f"<li>{e(f)}</li>" for f in result.failures)
        + "</ul>"
    )
    design = getattr(result, "design", None)
    head = getattr(result, "timing", None)
    contents: list[tuple[str, str]] = []
    parts = [
        "<!DOCTYPE html>",
        "<html lang='en'><head><meta charset='utf-8'>",
        "<meta name='viewport' content='width=device-width, initial-scale=1'>",
        f"<title>{e(result.mechanism)}: mjlink simulate</title>",
        f"<style>{_CSS}</style></head><body>",
        f"<h1>{e(result.mechanism)}</h1><p class='sub'>{e(result.title)}</p>",
        verdict,
    ]
    if design is not None:
        parts += _design(result, pngs, names)
        contents.append(("design", "Design"))
    if head is not None:
        built = (
            f"built to the {e(head.target)} settings; the other makers' rows show which of their windows the head "
            "also meets"
            if head.target
            else "no maker's settings: the general checks of the parts named"
        )
        parts += [
            f"<section id='timing'><h2>Timing over one stitch</h2><p class='sub'>{built}; angles from "
            f"{e(head.origin)}</p>",
            "<div class='wide'><table><thead><tr><th>settings</th><th>check</th><th>measured</th><th>window</th>"
            "<th>unit</th><th>result</th></tr></thead><tbody>",
        ]
        for r in head.rows:
            text, cls = _MARK[r.verdict] if r.counts else (r.verdict, "info")
            parts.append(
                f"<tr><td>{e(r.maker or 'every head')}</td><td>{e(r.label)}<br><small>{e(r.what)}</small></td>"
                f"<td class='num' data-metric='timing_{e(r.key)}'>{e(r.shown(r.value))}</td>"
                f"<td class='num'>{e(r.window_text())}</td><td class='unit'>{e(shown(r.unit))}</td><td class='{cls}'>{e(text)}</td></tr>"
            )
        parts.append("</tbody></table></div>")
        if head.values:
            parts.append(
                "<p>"
                + "; ".join(f"{e(k)} {v:.4g} {e(u)}" for k, (v, u) in head.values.items())
                + " (measured, for information)</p>"
            )
        parts.append("</section>")
        contents.append(("timing", "Timing over one stitch"))
    later = [
        "<section id='agreement'><h2>Agreement of MuJoCo with the vector-method reference</h2>",
        f"<p class='sub'>MuJoCo {e(str(result.mujoco_version))}; mechanism file {e(str(result.source))}</p>",
        "<div class='wide'><table><thead><tr><th>run</th><th>quantity</th><th>measured</th><th>unit</th>"
        "<th>threshold</th><th>result</th></tr></thead><tbody>",
        *rows,
        "</tbody></table></div></section>",
    ]
    contents.append(("agreement", "Agreement of MuJoCo with the reference"))
    if design is not None and design.points:
        later += _strokes(result)
        contents.append(("strokes", "Strokes of the moving points"))
    for v in videos:
        later += [
            "<section id='video'><h2>Video</h2>",
            f"<video controls loop muted preload='auto' src='{e(v)}'></video>",
            f"<p class='sub'><a href='{e(v)}'>{e(v)}</a></p></section>",
        ]
        contents.append(("video", "Video"))
    # The drawing leads the design section: not again among the figures.
    figures = [p for p in pngs if not (design is not None and p == "positions.png")]
    if figures:
        later.append("<section id='figures'><h2>Figures</h2>")
        contents.append(("figures", "Figures"))
        for p in figures:
            later.append(
                f"<figure id='{e(p)}'><a href='{e(p)}'><img src='{e(p)}' alt='{e(_caption(p))}' loading='eager'></a>"
                f"<figcaption>{e(p)}: {e(_caption(p))}</figcaption></figure>"
            )
        later.append("</section>")
    if data:
        later.append(
            "<section id='data'><h2>Data</h2><ul>"
            + "".join(f"<li><a href='{e(d)}'>{e(d)}</a></li>" for d in data)
            + "</ul></section>"
        )
        contents.append(("data", "Data"))
    parts += [_contents(contents), *later, f"<script>{_SCRIPT}</script>", "</body></html>"]
    return "\n".join(parts) + "\n"
