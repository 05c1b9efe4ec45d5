"""The ``build``, ``design`` and ``synth`` commands: a mechanism's MJCF, its drag-to-design
page, the metric synthesis of the offset crank-slider and its mechanism file.

A file the user names (``build -o``, ``design -o``, ``synth --write``) is claimed before any
work (:func:`mjlink.files.claim_outputs`: kept if it exists unless ``force``, never the file the
command reads) and written whole (:func:`mjlink.files.write_files`).
"""

from __future__ import annotations

import math
import os
import shutil
from collections.abc import Sequence
from pathlib import Path

from .. import validation
from ..errors import MjlinkError
from ..files import claim_outputs, write_files, write_text
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
from ..pages import design
from ..runs import DYNAMIC
from ..runtime import staging
from ..runtime.markers import read_marker
from ..sim import builder, simulate
from ..units import DEG, MM
from .results import BuildResult, SynthResult

SYNTHESIS_PROBLEMS = ("crank_slider",)  # what synthesize knows how to solve


def build(mech: Mechanism, *, kinematic: bool = False, path: Path | None = None, force: bool = False) -> BuildResult:
    """The MJCF of ``mech``: the dynamic model, or with ``kinematic`` the kinematic run's (a
    flywheel on the crank); written to ``path`` whole if given. Raises OutputError for a
    ``path`` that cannot be claimed (:func:`~mjlink.files.claim_outputs`: a folder, the
    mechanism's own file, an existing file without ``force``), before anything is built."""
    target = claim_outputs({"-o": path}, [mech.path], force=force).get("-o")
    settings = simulate.kinematic_case(mech).settings if kinematic else DYNAMIC
    xml = builder.to_xml(mech, settings)
    if target is not None:
        write_files([(target, xml)], force=force)
    return BuildResult(mech.name, settings, xml, path)


def design_page(
    mech: Mechanism,
    path: Path | None = None,
    *,
    out_root: Path | str = "renders",
    force: bool = False,
    command: Sequence[str] = (),
) -> Path:
    """Write ``mech``'s drag-to-design page (:func:`mjlink.pages.design.design_html`, from the
    text ``mech`` was read from); returns where.

    ``path`` None: at ``OUT_ROOT/NAME/design.html``, where ``simulate`` puts it, in the same
    output folder and under the same rules (:func:`mjlink.runtime.staging.staged_dir`, kind
    ``simulate``: the root is created, a folder mjlink did not write is refused unless
    ``force``); the other files of a ``simulate`` output there are kept and stay that output's.
    ``path`` given: that file, claimed first (:func:`~mjlink.files.claim_outputs`).
    """
    target = claim_outputs({"-o": path}, [mech.path], force=force).get("-o")
    if mech.text is None:
        raise MjlinkError(
            f"{mech.name}: the page edits the text of a mechanism file, and this one was not read from one"
        )
    html = design.design_html(mech, mech.text)
    if path is not None and target is not None:
        write_files([(target, html)], force=force)
        return path
    dest = Path(out_root) / mech.name
    with staging.staged_dir(dest, kind="simulate", force=force, mechanism=mech.name, command=command) as stage:
        write_text(stage / "design.html", html, in_stage=True)
        marker = read_marker(dest) if dest.is_dir() else None
        if marker is not None and marker["kind"] == "simulate" and marker.get("mechanism") == mech.name:
            for name in marker["files"]:  # the run's other files stay in its output, as they were
                if name != "design.html" and os.path.lexists(dest / name):
                    _link_into(dest / name, stage / name)
    return dest / "design.html"


def _link_into(src: Path, dst: Path) -> None:
    """``src`` at ``dst`` as hard links (a folder as a tree of them): the same files, not copies."""
    if src.is_dir() and not src.is_symlink():
        shutil.copytree(src, dst, symlinks=True, copy_function=os.link)
    else:
        os.link(src, dst, follow_symlinks=False)


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
    return SynthResult(
        stroke=S,
        offset=e,
        ratio=lam,
        max_pressure_angle=th,
        table=table,
        best=best,
        largest_ratio=top,
        at_largest=at_top,
        beyond_largest=beyond,
    )


def write_design(result: SynthResult, path: Path, *, force: bool = False) -> Path:
    """Save the accepted design of ``result`` as a mechanism file at ``path`` (whole or not at
    all), named after the file's stem, after validating it. Raises MjlinkError if the stem is
    not a valid mechanism name, no root is accepted or the design does not validate, and
    OutputError for a ``path`` that cannot be claimed (:func:`~mjlink.files.claim_outputs`: an
    existing file without ``force``, the shipped file the design starts from)."""
    name = path.stem
    if not names.is_valid(name):
        raise MjlinkError(
            f"--write: the file name '{path.name}' must make a valid mechanism name "
            "(a letter, then letters, digits or _)"
        )
    base = catalogue.path_of("crank_slider")
    target = claim_outputs({"--write": path}, [base], force=force)["--write"]
    base_text = base.read_text(encoding="utf-8")
    text = synthesis.design_file(base_text, result.stroke, result.offset, result.ratio, result.max_pressure_angle, name)
    validation.validate(parse(text, path))
    write_files([(target, text)], force=force)
    return path
