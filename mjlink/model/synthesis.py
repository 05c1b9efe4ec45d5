"""Metric synthesis of the offset crank-slider (seed 002).

Given the stroke S, the offset e of the guide and lambda = r / l, find the crank r and the rod
l from ``S = sqrt((l + r)^2 - e^2) - sqrt((l - r)^2 - e^2)``. Squaring twice gives a quartic
in l; with r = lambda l only even powers remain::

    (4 lambda^2 / S^2) l^4 + (2 lambda - (1 + lambda)^2) l^2 + S^2 / 4 + e^2 = 0

whose four roots are +-l_1 and +-l_2. A root is accepted when it is real and positive, the
slider can pass the crank (l - r > e), the stroke it actually gives equals S (squaring may
add spurious roots), and the largest pressure angle ``theta_max = asin((r + e) / l)``
(reached at phi1 = 90 deg with the guide at y = -e) is within the allowed [theta].

Lengths in m unless a name says mm; angles rad unless it says deg.
"""

from __future__ import annotations

import cmath
import dataclasses
import math
import tomllib
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, cast

import numpy as np

from ..errors import MjlinkError
from . import blocks, tomlio

if TYPE_CHECKING:
    from .mechanism import Mechanism


@dataclass(frozen=True)
class Root:
    """One root of the quartic: ``l`` and ``r`` m (nan if complex), the stroke it really
    gives m, ``theta_max`` rad, and whether it is accepted (with the reason if not)."""

    l: complex
    r: complex
    stroke: float
    theta_max: float
    accepted: bool
    reason: str


def stroke_of(r: float, l: float, e: float) -> float:
    """Stroke (m) of an offset crank-slider with crank r, rod l, offset e (all m)."""
    a, b = (l + r) ** 2 - e**2, (l - r) ** 2 - e**2
    if a < 0 or b < 0:
        return math.nan
    return math.sqrt(a) - math.sqrt(b)


def _quartic_roots(S: float, e: float, lam: float) -> list[complex]:
    """The four roots l of ``a l^4 + c l^2 + k = 0`` (a = 4 lambda^2 / S^2, c = 2 lambda -
    (1 + lambda)^2, k = S^2 / 4 + e^2): a quadratic in l^2, solved in closed form, its smaller
    root from the product of the two (no cancellation), then l = +-sqrt(l^2). The quartic has
    no odd terms, so this needs no general polynomial solver (numpy's roots, an eigenvalue
    problem per call), which a study re-synthesizing every variant would pay for each."""
    a, c, k = 4 * lam**2 / S**2, 2 * lam - (1 + lam) ** 2, S**2 / 4 + e**2
    disc = complex(c * c - 4 * a * k)
    big = (-c - math.copysign(1.0, c) * cmath.sqrt(disc)) / (2 * a)
    squares = (big, k / (a * big))
    out = []
    for q in squares:
        l = cmath.sqrt(q) if q.imag or q.real < 0 else complex(math.sqrt(q.real))
        out += [l, -l]
    return out


def roots(stroke: float, offset: float, ratio: float, max_pressure_angle: float) -> list[Root]:
    """All four roots of the synthesis quartic, each judged (see the module docstring)."""
    for name, v in (("stroke", stroke), ("lambda", ratio)):
        if not (v > 0 and math.isfinite(v)):
            raise MjlinkError(f"{name} must be a positive finite number, got {v}")
    if not (offset >= 0 and math.isfinite(offset)):
        raise MjlinkError(f"offset must be a non-negative finite number, got {offset}")
    if not (0 < max_pressure_angle < math.pi / 2):
        raise MjlinkError(f"max pressure angle must be between 0 and 90 deg, got {math.degrees(max_pressure_angle):g}")
    S, e, lam = stroke, offset, ratio
    out = []
    for l in sorted(_quartic_roots(S, e, lam), key=lambda z: (abs(z.imag) > 1e-12 * abs(z), -z.real)):
        if abs(l.imag) > 1e-9 * max(abs(l), 1e-12):
            out.append(Root(complex(l), complex(lam * l), math.nan, math.nan, False, "complex"))
            continue
        lr = float(l.real)
        r = lam * lr
        if lr <= 0:
            out.append(Root(complex(lr), complex(r), math.nan, math.nan, False, "negative length"))
            continue
        got = stroke_of(r, lr, e)
        s = (r + e) / lr
        theta = math.asin(s) if s <= 1 else math.nan
        # Every reason is listed: the paper rejects root 2 for its pressure angle alone,
        # though it does not even give the stroke asked for.
        reasons = []
        if not theta <= max_pressure_angle:
            th = "> 90" if math.isnan(theta) else f"{math.degrees(theta):.1f} >"
            reasons.append(f"theta_max {th} {math.degrees(max_pressure_angle):g} deg")
        if not (lr - r > e):
            reasons.append("rod too short: the slider cannot pass (l - r <= e)")
        elif not abs(got - S) <= 1e-9 * S:
            reasons.append(f"spurious: gives stroke {got * 1e3:.3f} mm")
        out.append(
            Root(
                complex(lr),
                complex(r),
                got,
                theta,
                not reasons,
                "rejected: " + "; ".join(reasons) if reasons else "accepted",
            )
        )
    return out


def best(stroke: float, offset: float, ratio: float, max_pressure_angle: float) -> Root | None:
    """The accepted root with the smallest pressure angle, or None."""
    ok = [r for r in roots(stroke, offset, ratio, max_pressure_angle) if r.accepted]
    return min(ok, key=lambda r: r.theta_max) if ok else None


def largest_ratio(stroke: float, offset: float, max_pressure_angle: float, step: float = 0.01) -> float | None:
    """The largest lambda on a ``step`` grid (0.01) for which some root is accepted."""
    n = round(1.0 / step)
    found = None
    for i in range(1, n):
        lam = round(i * step, 10)
        if best(stroke, offset, lam, max_pressure_angle) is not None:
            found = lam
    return found


def format_table(stroke: float, offset: float, ratio: float, max_pressure_angle: float) -> str:
    """The paper's table: every root with r, l, the stroke it gives, theta_max and the verdict."""
    rows = [
        f"S = {stroke * 1e3:g} mm, e = {offset * 1e3:g} mm, lambda = {ratio:g}, "
        f"[theta] = {math.degrees(max_pressure_angle):g} deg",
        f"{'root':>4} {'l, mm':>10} {'r, mm':>10} {'stroke, mm':>11} {'theta_max':>10}  verdict",
    ]
    for i, r in enumerate(roots(stroke, offset, ratio, max_pressure_angle), 1):
        if r.reason == "complex":
            rows.append(f"{i:>4} {np.round(r.l * 1e3, 3)!s:>21} {'':>11} {'':>10}  complex")
            continue
        st = "-" if math.isnan(r.stroke) else f"{r.stroke * 1e3:.3f}"
        th = "-" if math.isnan(r.theta_max) else f"{math.degrees(r.theta_max):.1f} deg"
        rows.append(f"{i:>4} {r.l.real * 1e3:>10.3f} {r.r.real * 1e3:>10.3f} {st:>11} {th:>10}  {r.reason}")
    return "\n".join(rows)


def design_file(
    base_text: str, stroke: float, offset: float, ratio: float, max_pressure_angle: float, name: str
) -> str:
    """A mechanism file (TOML text) for the best accepted root, from a crank-slider base file.

    The base file (``mechanisms/crank_slider.toml``) gives the structure; the synthesized r and
    l replace its crank and rod lengths, the guide moves to y = -e, the centres of mass stay at
    mid-length. Raises MjlinkError if no root is accepted.
    """

    root = best(stroke, offset, ratio, max_pressure_angle)
    if root is None:
        raise MjlinkError(
            f"no admissible design for S = {stroke * 1e3:g} mm, e = {offset * 1e3:g} mm, "
            f"lambda = {ratio:g}, [theta] = {math.degrees(max_pressure_angle):g} deg"
        )
    r_mm, l_mm = root.r.real * 1e3, root.l.real * 1e3
    d = tomllib.loads(base_text)
    d["mechanism"]["name"] = name
    d["synthesis"] = {
        "stroke": stroke * 1e3,
        "offset": offset * 1e3,
        "lambda": ratio,
        "max_pressure_angle": math.degrees(max_pressure_angle),
    }
    for step in d["construct"]:
        if step["block"] == "crank":
            step["length"] = r_mm
        elif step["block"] == "slider":
            step["length"] = l_mm
    crank = next(s for s in d["construct"] if s["block"] == "crank")
    slider = next(s for s in d["construct"] if s["block"] == "slider")
    for g in slider["guide"]:  # the guide is the line y = -e
        d["ground"][g][1] = -offset * 1e3
    for step in d["construct"]:
        if step["block"] == "attached" and step["origin"] == crank["pivot"] and step["toward"] == crank["point"]:
            step["length"] = r_mm / 2
        if step["block"] == "attached" and step["origin"] == slider["start"] and step["toward"] == slider["point"]:
            step["length"] = l_mm / 2
    header = (
        f"Crank-slider designed by 'python -m mjlink synth crank_slider': S = {stroke * 1e3:g} mm, "
        f"e = {offset * 1e3:g} mm,\nlambda = {ratio:g}, [theta] = {math.degrees(max_pressure_angle):g} deg: "
        f"r = {r_mm:.4f} mm, l = {l_mm:.4f} mm, theta_max = {math.degrees(root.theta_max):.2f} deg.\n"
        "Units: lengths mm, angles deg, masses g, inertias kg*m^2, speeds rad/s."
    )
    return tomlio.dumps(d, header)


@dataclass(frozen=True)
class Resized:
    """What a re-synthesis of a crank-slider changes: the ``crank`` and the ``slider`` (their
    lengths become r and l), the ground points of the ``guide`` (their y becomes -e), and the
    points attached along the crank or the rod (``along_crank``, ``along_rod``: their length
    scales with the crank's or the rod's, so a centre of mass stays at its fraction)."""

    crank: Any
    slider: Any
    guide: tuple[str, ...]
    along_crank: tuple[Any, ...]
    along_rod: tuple[Any, ...]


def resized(mech: Mechanism) -> Resized:
    """The steps and ground points of ``mech`` that a re-synthesis changes (see :class:`Resized`)."""
    crank = mech.input_crank
    slider = blocks.sliders(mech.steps)[0]
    attached = [s for s in mech.steps if s.kind == "attached"]
    return Resized(
        crank,
        slider,
        tuple(g for g in slider.guide if g in mech.ground),
        tuple(s for s in attached if s.inputs == (crank.pivot, crank.point)),
        tuple(s for s in attached if s.inputs == (slider.start, slider.point)),
    )


def lengths(stroke: float, offset: float, ratio: float) -> tuple[float, float]:
    """The crank r and the rod l (m) of the accepted root with the smallest pressure angle for
    stroke and offset (m) and lambda = r / l, the pressure-angle limit not applied (a design
    study shows theta_max as a metric and its limit as a bound). Raises MjlinkError if no root
    is real and gives the stroke."""
    root = best(stroke, offset, ratio, math.radians(89.99))
    if root is None:
        raise MjlinkError(
            f"no crank-slider has stroke {stroke * 1e3:g} mm with offset {offset * 1e3:g} mm and lambda {ratio:g}"
        )
    return root.r.real, root.l.real


def redesigned(mech: Mechanism, stroke: float, offset: float, ratio: float) -> Mechanism:
    """A crank-slider mechanism re-synthesized for stroke and offset (m) and lambda = r / l.

    As :func:`design_file` (``synth --write``), on the objects: the crank r and the rod l of
    :func:`lengths`, the guide moved to y = -e, and the points attached along the crank or the
    rod (their centres of mass) kept at the same fraction of its length (:func:`resized`).
    Raises MjlinkError if no root is real and gives the stroke.
    """
    r, l = lengths(stroke, offset, ratio)
    rs = resized(mech)
    ground = dict(mech.ground)
    for g in rs.guide:
        ground[g] = np.array([ground[g][0], -offset, ground[g][2]])
    factor = {id(s): r / rs.crank.length for s in rs.along_crank} | {id(s): l / rs.slider.length for s in rs.along_rod}
    steps = []
    for s in mech.steps:
        if s is rs.crank or s is rs.slider:
            s = dataclasses.replace(cast(Any, s), length=r if s is rs.crank else l)
        elif id(s) in factor:
            s = dataclasses.replace(cast(Any, s), length=cast(Any, s).length * factor[id(s)])
        steps.append(s)
    assert mech.synthesis is not None
    new = dataclasses.replace(mech.synthesis, stroke=stroke, offset=offset, ratio=ratio)
    return dataclasses.replace(mech, ground=ground, steps=tuple(steps), synthesis=new)
