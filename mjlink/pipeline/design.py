"""The ``build`` and ``synth`` commands: a mechanism's MJCF, the metric synthesis of the offset
crank-slider and its mechanism file.
"""

from __future__ import annotations

import math
from pathlib import Path

from .. import output, validation
from ..errors import MjlinkError
from ..model import catalogue, names, synthesis
from ..model.limits import (
    MAX_LENGTH_MM,
    MAX_SYNTH_PRESSURE_DEG,
    MAX_SYNTH_RATIO,
    MIN_BAR_MM,
    above,
    below,
)
from ..model.mechanism import Mechanism, parse
from ..runs import DYNAMIC
from ..sim import builder, simulate
from ..units import DEG, MM
from .results import BuildResult, SynthResult

SYNTHESIS_PROBLEMS = ("crank_slider",)  # what synthesize knows how to solve


def build(mech: Mechanism, *, kinematic: bool = False, path: Path | None = None) -> BuildResult:
    """The MJCF of ``mech``: the dynamic model, or with ``kinematic`` the kinematic run's (a
    flywheel on the crank); written to ``path`` whole if given. Raises MjlinkError for a
    ``path`` that names a folder (or nothing), before anything is built."""
    if path is not None:
        if not str(path) or path.is_dir():
            raise MjlinkError(f"-o {str(path)!r}: is a folder, not a file: give the MJCF file's name, e.g. model.xml")
        if not path.name:
            raise MjlinkError(f"-o {str(path)!r}: names no file: give the MJCF file's name, e.g. model.xml")
    settings = simulate.kinematic_case(mech).settings if kinematic else DYNAMIC
    xml = builder.to_xml(mech, settings)
    if path is not None:
        output.write_text(path, xml)
    return BuildResult(mech.name, settings, xml, path)


def synthesize(
    problem: str,
    *,
    stroke_mm: float | None = None,
    offset_mm: float | None = None,
    ratio: float | None = None,
    max_pressure_deg: float | None = None,
) -> SynthResult:
    """Metric synthesis of the offset crank-slider for a stroke (mm), guide offset (mm), lambda =
    r / l and allowed pressure angle (deg); each None takes ``crank_slider.toml``'s [synthesis]
    value. Raises MjlinkError for an unknown ``problem``, a value outside its limits
    (mechanisms/README.md, "Limits"; messages in the option's unit) or an impossible requirement."""
    if problem not in SYNTHESIS_PROBLEMS:
        raise MjlinkError(f"unknown synthesis problem {problem!r} (valid: {', '.join(SYNTHESIS_PROBLEMS)})")
    bounds = (
        ("--stroke", stroke_mm, MIN_BAR_MM, MAX_LENGTH_MM, " mm", False),
        ("--offset", offset_mm, 0.0, MAX_LENGTH_MM, " mm", False),
        ("--lambda", ratio, 0.0, MAX_SYNTH_RATIO, "", True),
        ("--max-pressure-angle", max_pressure_deg, 0.0, MAX_SYNTH_PRESSURE_DEG, " deg", True),
    )
    for option, v, lo, hi, unit, open_interval in bounds:
        if v is None:
            continue
        if not math.isfinite(v) or below(v, lo) or above(v, hi) or (open_interval and v in (lo, hi)):
            within = f"between {lo:g} and {hi:g}{unit}" + (" (both excluded)" if open_interval else "")
            raise MjlinkError(f"{option} must be {within}, got {v:g}{unit}")
    base = validation.get("crank_slider").synthesis
    assert base is not None  # crank_slider.toml carries the seed's [synthesis] requirement
    S = stroke_mm * MM if stroke_mm is not None else base.stroke
    e = offset_mm * MM if offset_mm is not None else base.offset
    lam = ratio if ratio is not None else base.ratio
    th = max_pressure_deg * DEG if max_pressure_deg is not None else base.max_pressure_angle
    table = synthesis.format_table(S, e, lam, th)
    best = synthesis.best(S, e, lam, th)
    top = synthesis.largest_ratio(S, e, th)
    at_top = beyond = None
    if top is not None:
        at_top = synthesis.best(S, e, top, th)
        nxt = synthesis.roots(S, e, round(top + 0.01, 10), th)[0]
        beyond = None if math.isnan(nxt.theta_max) else nxt
    return SynthResult(S, e, lam, th, table, best, top, at_top, beyond)


def write_design(result: SynthResult, path: Path) -> Path:
    """Save the accepted design of ``result`` as a mechanism file at ``path`` (whole or not at
    all), named after the file's stem, after validating it. Raises MjlinkError if the stem is
    not a valid mechanism name, no root is accepted or the design does not validate."""
    name = path.stem
    if not names.is_valid(name):
        raise MjlinkError(
            f"--write: the file name '{path.name}' must make a valid mechanism name "
            "(a letter, then letters, digits or _)"
        )
    base_text = catalogue.path_of("crank_slider").read_text(encoding="utf-8")
    text = synthesis.design_file(base_text, result.stroke, result.offset, result.ratio, result.max_pressure_angle, name)
    validation.validate(parse(text, path))
    return output.write_text(path, text)
