"""What a design does, in a few numbers: the summary a designer reads first.

The numbers are the study metrics of the file's own design (the same definitions, names and
units as a study's columns, :mod:`mjlink.analysis.metrics`), computed once from the reference
over one period: the key point's stroke and extreme positions, the thread feed per turn, the
worst transmission and pressure angles, and at the file's speed the driving torque's peak and
RMS, the mean power and the peak shaking force. :func:`point_strokes` gives every moving
point's stroke and extremes, and :func:`dimensions` the file's geometry by study path.
"""

from __future__ import annotations

import dataclasses
import math
import re
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

from ..model import paths
from ..model.mechanism import Mechanism
from ..reference import batch
from . import key_point, mass_centres, metrics
from .tension import NeedleTension
from .tension_metric import TensionMetric

PER_TURN = 360  # crank angles per input turn of the summary's reference


@dataclass(frozen=True)
class Row:
    """One number of the summary: ``metric`` its name as a study's column (``stroke_P5``),
    ``label`` in words, ``value`` in ``unit`` (the column's)."""

    metric: str
    label: str
    value: float
    unit: str

    def as_dict(self) -> dict[str, Any]:
        return {"metric": self.metric, "label": self.label, "value": self.value, "unit": self.unit}


def _rows(mech: Mechanism, tables: list[dict[str, Any]]) -> list[Row]:
    mets = [metrics.read(mech, t, i) for i, t in enumerate(tables)]
    b = batch.solve_batch(mech, [], np.zeros((1, 0)), PER_TURN)
    values = metrics.compute(mets, b, b)
    out = []
    for c in metrics.columns(mets):
        v = float(values[c.name][0])
        if math.isfinite(v):
            out.append(Row(c.name, c.label, v, c.unit))
    return out


def _loaded(mech: Mechanism) -> bool:
    return any(l.mass > 0 for l in mech.links) and bool(mech.speed)


def head_rows(mech: Mechanism) -> tuple[Row, ...]:
    """What a sewing head is read by first (its ``[timing]`` roles): the needle bar's stroke
    (along y, the needle's line in the head's convention) and the feed dog's travel along the
    plate (x), each as a study's ``stroke`` metric names it; none for another mechanism."""
    tm = mech.timing
    if tm is None:
        return ()
    tables = []
    if tm.has("needle_bar"):
        tables.append(({"kind": "stroke", "point": tm.roles["needle_bar"], "axis": "y"}, "needle bar's stroke"))
    if tm.has("feed_dog"):
        tables.append(
            ({"kind": "stroke", "point": tm.roles["feed_dog"], "axis": "x"}, "feed dog's travel along the plate")
        )
    rows = _rows(mech, [t for t, _ in tables])
    return tuple(dataclasses.replace(r, label=f"{what} ({r.label})") for r, (_, what) in zip(rows, tables, strict=True))


def design_summary(mech: Mechanism) -> tuple[Row, ...]:
    """The headline numbers of ``mech`` (see the module's docstring); a row whose metric does
    not apply (no thread, no dyad, no slider, no masses) is left out."""
    key = key_point(mech)
    tables: list[dict[str, Any]] = [{"kind": "stroke", "point": key}, {"kind": "extremes", "point": key}]
    if mech.thread:
        tables.append({"kind": "thread_feed"})
    tables += [{"kind": "transmission_min"}, {"kind": "pressure_max"}]
    if _loaded(mech):
        tables += [{"kind": k} for k in ("torque_peak", "torque_rms", "power_mean", "shaking_force_peak")]
    rows = _rows(mech, tables)
    chosen = chosen_guides(mech)
    if chosen:  # the feed depends on where the guides are: say when the file chose them
        rows = [
            dataclasses.replace(r, label=f"{r.label} (guides {', '.join(chosen)} placed by the file's [choice])")
            if r.metric == "thread_feed"
            else r
            for r in rows
        ]
    return tuple(rows)


def chosen_guides(mech: Mechanism) -> list[str]:
    """The thread's ground points whose line in the mechanism file is marked ``[choice`` (placed
    by the file's author, not taken from its source), in the thread's order."""
    if not mech.thread or mech.text is None:  # the text it was read from, not the file again
        return []
    marked = set()
    for line in mech.text.splitlines():
        m = re.match(r"\s*([A-Za-z][A-Za-z0-9_]*)\s*=\s*\[[^\]]*\]\s*#.*\[choice", line)
        if m:
            marked.add(m[1])
    return [p for p in mech.thread if p in mech.ground and p in marked]


def point_strokes(mech: Mechanism) -> tuple[Row, ...]:
    """Stroke and extreme positions (along the axis each point moves most) of every moving
    point that is not merely a link's centre of mass, in the file's order."""
    coms = mass_centres(mech)
    tables: list[dict[str, Any]] = []
    for p in mech.moving_points:
        if p not in coms:
            tables += [{"kind": "stroke", "point": p}, {"kind": "extremes", "point": p}]
    return tuple(_rows(mech, tables))


def dimensions(mech: Mechanism) -> tuple[tuple[str, float, str], ...]:
    """The file's geometry as (study path, value, unit): every ground point's coordinates (z
    only where it is not 0) and every number of every block but those placing a centre of
    mass, then the input crank's setting ``input.phi0``."""
    coms = mass_centres(mech)
    out = []
    for path, p in paths.catalogue(mech).items():
        section, *rest = path.split(".")
        if section == "ground" or (section == "construct" and rest[0] not in coms):
            if rest[-1] == "z" and p.nominal == 0.0:
                continue
            out.append((path, p.nominal, p.unit))
    out.append(("input.phi0", paths.resolve(mech, "input.phi0").nominal, "deg"))
    return tuple(out)


@dataclass(frozen=True, kw_only=True)
class Summary:
    """The design of a run at a glance: the crank's setting ``phi0_deg`` (deg) at which the
    design is drawn, the file's ``speed`` (rad/s, signed, CCW positive) at which the loads are
    taken, the ``headline`` numbers (:func:`design_summary`), every point's stroke
    (:func:`point_strokes`) and the file's ``dimensions``."""

    phi0_deg: float
    speed: float
    headline: tuple[Row, ...]
    points: tuple[Row, ...]
    dimensions: tuple[tuple[str, float, str], ...]
    lead: int = 0  # a head's: the headline rows it is read by first (stroke, feed, tension)
    members: dict[str, str] = dataclasses.field(default_factory=dict)  # dimension -> the member it shapes

    def as_dict(self) -> dict[str, Any]:
        """The report's ``design`` entry."""
        return {
            "phi0_deg": self.phi0_deg,
            "speed_rad_s": self.speed,
            "summary": [r.as_dict() for r in self.headline],
            "points": [r.as_dict() for r in self.points],
            "dimensions": [{"param": p, "value": v, "unit": u} for p, v, u in self.dimensions],
        }


def tension_rows(thread: NeedleTension) -> tuple[Row, ...]:
    """A head's needle thread in the summary, as a study's ``tension`` metric names it: the peak
    tension (N), its margin to the breaking load, the thread drawn through the discs per
    stitch (mm) and the take-up's pull on the stitch over the bobbin thread's tension, from the
    run's own tension (:func:`mjlink.analysis.tension.needle_tension`)."""
    values = {
        "tension_peak": thread.peak,
        "tension_margin": thread.margin,
        "tension_per_stitch": thread.per_stitch * 1e3,
        "tension_drawn_up": thread.drawn_up,
    }
    return tuple(Row(c.name, c.label, values[c.name], c.unit) for c in TensionMetric.COLUMNS if c.name in values)


class Fed(Protocol):
    """What the summary reads of a head's feed under its presser foot
    (:class:`mjlink.sim.feed.FeedRun`): the stitch (m), its error against the dog's advance (a
    fraction) and the foot's separation (deg, where it begins)."""

    @property
    def stitch(self) -> float: ...
    @property
    def error(self) -> float: ...
    @property
    def separation(self) -> tuple[float, float | None]: ...
    @property
    def shift(self) -> float: ...
    @property
    def ply_advance(self) -> np.ndarray: ...


def feed_rows(fed: Fed) -> tuple[Row, ...]:
    """A head's feed in the summary, from the run's feed with contact at the file's speed: the
    stitch length (mm), its error against the dog's own advance (%), the degrees of the stitch
    the presser foot is off the fabric and, with plies, the top ply's shift (mm a stitch)."""
    rows = (
        Row("feed_stitch", "stitch length with contact, at this speed", fed.stitch * 1e3, "mm"),
        Row("feed_error", "stitch length against the dog's advance", fed.error * 100.0, "%"),
        Row("feed_foot_off", "presser foot off the fabric", fed.separation[0], "deg"),
    )
    if fed.ply_advance.shape[1] > 1:
        rows += (Row("feed_ply_shift", "top ply's shift on the bottom one, a stitch", fed.shift * 1e3, "mm"),)
    return rows


def summarize(mech: Mechanism, thread: NeedleTension | None = None, fed: Fed | None = None) -> Summary:
    """:class:`Summary` of ``mech``; a head's headline ends with its needle thread's tension
    (:func:`tension_rows`) when the run's ``thread`` is given, and its feed with contact
    (:func:`feed_rows`) when the run's ``fed`` is."""
    lead = (
        head_rows(mech)
        + (tension_rows(thread) if thread is not None else ())
        + (feed_rows(fed) if fed is not None else ())
    )
    headline = lead + design_summary(mech)
    dims = dimensions(mech)
    return Summary(
        phi0_deg=math.degrees(mech.phi0),
        speed=mech.speed,
        headline=headline,
        points=point_strokes(mech),
        dimensions=dims,
        lead=len(lead),
        members=members(mech, dims),
    )


def members(mech: Mechanism, dims: tuple[tuple[str, float, str], ...]) -> dict[str, str]:
    """Each dimension's member, as a designer folds a long table: a ground point's coordinates
    the frame, a block's numbers the first link (in the file's order) that carries its point
    (the frame for a point no link carries), the input's setting the input."""
    out = {}
    for path, _, _ in dims:
        part = path.split(".")
        if part[0] == "construct":
            out[path] = next((l.name for l in mech.links if part[1] in l.points), "frame")
        else:
            out[path] = "frame" if part[0] == "ground" else part[0]
    return out


@dataclass(frozen=True, kw_only=True)
class Change:
    """One design number against a base design: ``name`` a study metric or parameter path,
    ``label``, ``value`` and ``base`` in ``unit`` (None where that design has no such number)."""

    name: str
    label: str
    value: float | None
    base: float | None
    unit: str

    @property
    def delta(self) -> float | None:
        return None if self.value is None or self.base is None else self.value - self.base


def against(summary: Summary, base: Mechanism) -> tuple[tuple[Change, ...], tuple[Change, ...]]:
    """What the design does and its dimensions beside a ``base`` design's: the headline rows
    (the base's own numbers by the same metric names; None where the base has none) and every
    dimension that differs (by study path; a number only one design has is listed too)."""
    rows = {r.metric: r for r in design_summary(base)}
    head = tuple(
        Change(
            name=r.metric,
            label=r.label,
            value=r.value,
            base=rows[r.metric].value if r.metric in rows else None,
            unit=r.unit,
        )
        for r in summary.headline
    )
    mine = {p: (v, u) for p, v, u in summary.dimensions}
    theirs = {p: (v, u) for p, v, u in dimensions(base)}
    dims = []
    for p in [*mine, *(q for q in theirs if q not in mine)]:
        v, u = mine.get(p, (None, theirs[p][1] if p in theirs else ""))
        b = theirs[p][0] if p in theirs else None
        if v is None or b is None or not math.isclose(v, b, rel_tol=1e-12, abs_tol=1e-12):
            dims.append(Change(name=p, label=p, value=v, base=b, unit=u))
    return head, tuple(dims)
