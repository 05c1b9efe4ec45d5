"""``design.html``: drag-to-design, one self-contained offline page per mechanism.

The page draws the mechanism at a crank angle with the paths of its moving points and lets a
designer drag its ground pivots and edit every dimension (the numbers of the file's ``[ground]``
and ``[[construct]]`` blocks and ``input.phi0``, each an ``<input data-param="<study path>">``);
while they do, the paths, the thread length over the cycle, the key point's stroke and
extremes, the thread feed per turn and the worst transmission and pressure angles
(``data-metric="<study metric>"``, in the metric's unit) follow. A design ``check`` would refuse
is said to be infeasible with the reason: a number the file's reader refuses (a length not
positive, a coordinate beyond the limits), a block that does not close, two points that define a
direction or a guide meeting, a link that is not rigid, two points of a link almost coinciding, a
dead point, judged at ``check``'s own input angles; while it is, the page keeps the last feasible
design's drawing and numbers, greyed and marked as stale. "Save as TOML" writes the file as it
was read with the numbers the designer changed, and nothing else, rewritten in place (its
comments, order and spelling kept; :func:`save_edits`), a dragged pivot's coordinates rounded to
0.001 mm; ``check`` passes it whenever the page calls the design feasible.

The computation in the browser is ``design.js``: a port of the reference's closed-form position
analysis (:mod:`mjlink.model.blocks`), one function per block type, in the file's units; the
page embeds it and the mechanism as JSON (:func:`script_json`: no text of the file can end the
script element or change how the page parses), and loads nothing from the network.
"""

from __future__ import annotations

import dataclasses
import html
import importlib.resources
import json
import math
import tomllib
from typing import Any

from .. import analysis
from ..analysis import link_segments, summary
from ..model import limits, tomledit
from ..model.blocks import Attached, Crank, Dyad, Slider
from ..model.mechanism import Mechanism
from ..units import shown

# A colour per link, as positions.png gives them (mjlink.plotting.drawing.link_colors): matplotlib's
# ten, then their light tones (a head has a dozen links).
COLORS = (
    *("#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f", "#bcbd22", "#17becf"),
    *("#aec7e8", "#ffbb78", "#98df8a", "#ff9896", "#c5b0d5", "#c49c94", "#f7b6d2", "#c7c7c7", "#dbdb8d", "#9edae5"),
)


def model(mech: Mechanism) -> dict[str, Any]:
    """``mech`` as design.js reads it: file units (mm, deg), one entry per block with its
    fields as the block's dataclass names them, each number in the unit its ``numbers`` says."""
    steps: list[dict[str, Any]] = []
    for s in mech.steps:
        if not isinstance(s, Crank | Dyad | Attached | Slider):  # no port: refuse, never draw another
            raise TypeError(f"design.js has no port of the {type(s).__name__} block")
        entry: dict[str, Any] = {"kind": s.kind}
        for f in dataclasses.fields(s):
            v = getattr(s, f.name)
            if f.name in s.numbers and v is not None:
                v = v / s.numbers[f.name][0]  # SI to the file's unit
            entry[f.name] = list(v) if isinstance(v, tuple) else v
        steps.append(entry)
    return {
        "name": mech.name,
        "phi0": math.degrees(mech.phi0),
        "turns": round(mech.period / (2.0 * math.pi)),
        "ground": {k: [float(v) * 1e3 for v in p] for k, p in mech.ground.items()},
        "steps": steps,
        "thread": list(mech.thread) if mech.thread else None,
        "key": analysis.key_point(mech),
        "links": [{"name": l.name, "points": list(l.points), "guide": l.guide and list(l.guide)} for l in mech.links],
        "limits": {
            "transmission_min": limits.MIN_TRANSMISSION_DEG,
            "pressure_max": limits.MAX_PRESSURE_DEG,
            "direction_min": limits.MIN_DIRECTION_M * 1e3,
            "distinct_min": limits.MIN_DISTINCT_M * 1e3,
            "per_turn": limits.SAMPLES_PER_TURN,
            "values": {p: _number_rule(mech, p, u) for p, _, u in summary.dimensions(mech)},
        },
    }


# What the file's reader (mjlink.model.reader.Reader.number and .vector) holds each number the
# page edits to, as the blocks' ``read`` and the mechanism's reader call it: > 0, >= 0, and the
# least and largest magnitude, in the file's units. The page refuses an edit that breaks one as
# ``check`` refuses the file (tests/test_design_page.py holds every rule to the reader).
_BAR = {"positive": True, "lo": limits.MIN_BAR_MM, "hi": limits.MAX_LENGTH_MM}
_ANGLE = {"hi": limits.MAX_ANGLE_DEG}
_COORDINATE = {"hi": limits.MAX_LENGTH_MM}
_BLOCK_RULES: dict[tuple[str, str], dict[str, Any]] = {
    ("crank", "length"): _BAR,
    ("crank", "phase"): _ANGLE,
    ("dyad", "length_a"): _BAR,
    ("dyad", "length_b"): _BAR,
    ("attached", "angle"): _ANGLE,
    ("attached", "length"): {"nonneg": True, "hi": limits.MAX_LENGTH_MM},
    ("attached", "z"): _COORDINATE,
    ("slider", "length"): _BAR,
}


def _number_rule(mech: Mechanism, path: str, unit: str) -> dict[str, Any]:
    """The reader's rule on the number at study ``path`` of ``mech`` (see ``_BLOCK_RULES``),
    with its ``unit``; a number the page may edit but knows no rule for is refused here, never
    left unchecked."""
    section, name, *rest = path.split(".")
    if section == "ground":
        rule = _COORDINATE
    elif path == "input.phi0":
        rule = _ANGLE
    elif section == "construct":
        kind = next(s.kind for s in mech.steps if s.point == name)
        if (kind, rest[0]) not in _BLOCK_RULES:
            raise TypeError(f"design.js has no rule for the {kind} block's {rest[0]}")
        rule = _BLOCK_RULES[kind, rest[0]]
    else:
        raise TypeError(f"design.js edits no number {path}")
    return {"unit": unit, **rule}


def _raw_path(raw: dict[str, Any], path: str) -> tomledit.Path | None:
    """Where the number at study ``path`` is written in the file read as ``raw``."""
    section, name, *rest = path.split(".")
    if section == "ground":
        return ("ground", name, "xyz".index(rest[0]))
    if section == "construct":
        index = next((i for i, c in enumerate(raw.get("construct", ())) if c.get("point") == name), None)
        return None if index is None else ("construct", index, rest[0])
    return ("input", "phi0") if path == "input.phi0" else None


def save_edits(mech: Mechanism, text: str) -> dict[str, dict[str, Any]]:
    """For every number the page may edit (the file's dimensions and every ground coordinate), by
    study path, how "Save as TOML" writes it into ``text`` in place: the UTF-16 offsets (a
    JavaScript string's) of the text ``[start, end)`` replaced by ``before`` + the number +
    ``after`` (:class:`mjlink.model.tomledit.Edit`, each checked against tomllib). A number the
    text gives no place for is left out, and the page does not let it be edited."""
    raw = tomllib.loads(text)
    try:
        where = tomledit.layout(text)
    except ValueError:  # a spelling the scanner does not follow: nothing is edited in place
        return {}
    astral = [i for i, c in enumerate(text) if ord(c) > 0xFFFF]  # two UTF-16 units each

    def utf16(i: int) -> int:
        return i + sum(1 for a in astral if a < i)

    paths = [p for p, _, _ in summary.dimensions(mech)]
    paths += [f"ground.{g}.{ax}" for g in mech.ground for ax in "xyz" if f"ground.{g}.{ax}" not in paths]
    out = {}
    for path in paths:
        at = _raw_path(raw, path)
        e = tomledit.edit(text, where, at, raw) if at is not None else None
        if e is not None:
            out[path] = {"start": utf16(e.start), "end": utf16(e.end), "before": e.before, "after": e.after}
    return out


def script_json(data: Any) -> str:
    """``data`` as JSON to sit inside a ``<script>`` element whatever its strings hold: every
    ``<``, ``>`` and ``&`` written as a ``\\u`` escape, so that no text can end the element or
    open a comment or a tag in it, and every other character beyond ASCII too (U+2028 and
    U+2029 among them). ``JSON.parse`` of the element's text gives ``data`` back; a non-finite
    number, which JSON cannot hold, raises ValueError."""
    text = json.dumps(data, ensure_ascii=True, allow_nan=False)
    return text.replace("<", "\\u003c").replace(">", "\\u003e").replace("&", "\\u0026")


def _script() -> str:
    return importlib.resources.files("mjlink.pages").joinpath("design.js").read_text(encoding="utf-8")


_CSS = """
:root { color-scheme: light dark; --fg: #222; --bg: #fff; --muted: #555; --line: #ccc; }
@media (prefers-color-scheme: dark) { :root { --fg: #e6e6e6; --bg: #16181b; --muted: #a8a8a8; --line: #444; } }
* { box-sizing: border-box; }
body { font-family: sans-serif; margin: 1em auto; padding: 0 1em; max-width: 1240px; color: var(--fg); background: var(--bg); }
h1 { font-size: 1.3em; margin: 0; } .sub { color: var(--muted); margin: 0.2em 0 0.8em 0; }
.grid { display: grid; grid-template-columns: minmax(0, 3fr) minmax(0, 2fr); gap: 1.2em; align-items: start; }
#drawing { width: 100%; height: 560px; border: 1px solid var(--line); background: #fff; touch-action: none; }
#feed { width: 100%; height: 90px; border: 1px solid var(--line); background: #fff; }
.pivot { cursor: grab; }
table { border-collapse: collapse; font-size: 0.88em; width: 100%; }
th, td { border: 1px solid var(--line); padding: 0.15em 0.4em; text-align: left; }
td.num { text-align: right; font-family: monospace; }
td.unit { white-space: nowrap; }
input[type=number] { width: 7.5em; font-family: monospace; }
.stale { color: var(--muted); font-style: italic; }
#drawing g.stale, #feed.stale { opacity: 0.4; filter: grayscale(1); }
#status.ok { color: #1a7f37; } #status.bad { color: #c62828; font-weight: bold; }
.params { max-height: 420px; overflow-y: auto; }
textarea { width: 100%; height: 6em; font-family: monospace; font-size: 0.8em; }
@media (max-width: 900px) { .grid { grid-template-columns: minmax(0, 1fr); } }
"""


def design_html(mech: Mechanism, text: str) -> str:
    """The page for ``mech``, whose file's text is ``text`` (what "Save as TOML" edits)."""
    e = html.escape
    m = model(mech)
    coms = analysis.mass_centres(mech)
    index = {link.name: i for i, link in enumerate(mech.links)}
    drawn = link_segments(mech)
    pairs = [(a, b) for _, a, b in drawn]
    colors = [COLORS[index[link] % len(COLORS)] for link, _, _ in drawn]
    data = {
        "model": m,
        "text": text,
        "edits": save_edits(mech, text),
        "segments": [list(p) for p in pairs],
        "colors": colors,
        "coms": sorted(coms),
        "moving": [p for p in mech.moving_points if p not in coms],
    }
    loads = {"torque_peak", "torque_rms", "power_mean", "shaking_force_peak"}  # need masses and speed: not here
    rows = [r for r in summary.design_summary(mech) if r.metric not in loads]
    metric_rows = "".join(
        f"<tr><td>{e(r.label)}</td><td class='num' data-metric='{e(r.metric)}'></td><td class='unit'>{e(shown(r.unit))}</td></tr>"
        for r in rows
    )
    params = "".join(
        f"<tr><td>{e(p)}</td><td><input type='number' step='any' data-param='{e(p)}' value='{v:.10g}'></td>"
        f"<td class='unit'>{e(shown(u))}</td></tr>"
        for p, v, u in summary.dimensions(mech)
    )
    period = 360 * m["turns"]
    start = m["phi0"] % period  # the slider's angles lie within one period from 0, as the reasons'
    thread = (
        "<h3>Thread length over the cycle</h3><svg id='feed' preserveAspectRatio='none'></svg>"
        "<p class='sub' id='feed-range'></p>"
        if mech.thread
        else ""
    )
    return "\n".join(
        [
            "<!DOCTYPE html>",
            "<html lang='en'><head><meta charset='utf-8'>",
            "<meta name='viewport' content='width=device-width, initial-scale=1'>",
            f"<title>{e(mech.name)}: mjlink design</title><style>{_CSS}</style></head><body>",
            f"<h1>{e(mech.name)}: drag to design</h1>",
            f"<p class='sub'>{e(mech.title)}. Drag a blue ground pivot or edit a number; units mm and deg as in "
            "the file. Computed here, offline, with the reference's closed-form kinematics.</p>",
            "<p id='status'></p><p id='stale-note' class='sub stale'></p>",
            "<div class='grid'><div>",
            "<svg id='drawing' xmlns='http://www.w3.org/2000/svg'></svg>",
            f"<label>input crank angle <input id='angle' type='range' min='0' max='{period}' step='1' "
            f"value='{start:.6g}'></label> <span id='angle-value'>{start:g} deg</span>",
            thread,
            "</div><div>",
            "<h3>What the design does</h3><table><thead><tr><th>metric</th><th>value</th><th>unit</th></tr></thead>"
            f"<tbody>{metric_rows}</tbody></table>",
            "<h3>Dimensions</h3><div class='params'><table><thead><tr><th>parameter</th><th>value</th><th>unit</th>"
            f"</tr></thead><tbody>{params}</tbody></table></div>",
            "<p><button id='save' type='button'>Save as TOML</button></p>",
            "<textarea id='toml' readonly placeholder='the saved file appears here too'></textarea>",
            "</div></div>",
            f"<script type='application/json' id='mechanism-data'>{script_json(data)}</script>",
            f"<script>{_script()}</script>",
            "</body></html>",
        ]
    )
