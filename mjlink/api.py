"""mjlink's public Python API: the functions :mod:`mjlink` exports (``import mjlink``).

Six entry points, the command line's work from a script::

    mech = mjlink.load("takeup")                # or a path to your own .toml
    xml = mjlink.mjcf(mech)                     # the MJCF MuJoCo runs, as text
    tr = mjlink.traces(mech)                    # one turn at the file's speed, in memory
    tr["P5_y_mm"], tr["phi1_deg"]               # arrays, the unit in every name
    res = mjlink.simulate(mech, "renders")      # what `mjlink simulate` writes, and its report
    st = mjlink.run_study("crank_slider_grid", "renders", workers=0)
    tab = mjlink.read_study(st.out_dir)         # its table, by column, and its summary

Units: the arrays of :class:`Traces` and :class:`StudyTable` are in the unit their name ends
with (``_mm``, ``_deg``, ``_rad_s``, ``_N_m``...), as in the CSV files; a mechanism object
(:class:`~mjlink.model.Mechanism`) holds SI values (m, rad, kg, s). Errors are
:class:`~mjlink.errors.MjlinkError` subclasses with a one-line message, the same the command
line prints; an argument of the wrong type or beyond the command line's limits is refused before
any work, the message naming the function and the argument. docs/api.md shows a complete
script.
"""

from __future__ import annotations

import math
import numbers
import os
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal, TypeVar

import numpy as np

from . import files, validation
from .errors import ArgumentError, InputError, MjlinkError
from .files import claim_outputs
from .model import catalogue
from .model.mechanism import Mechanism
from .model.reader import shown
from .pipeline import (
    BuildResult,
    FeedResult,
    LoadsResult,
    Options,
    SimulateResult,
    SteadyResult,
    SynthResult,
    build,
    estimate,
    synthesize,
    write_design,
)
from .pipeline import feed as _pipeline_feed
from .pipeline import loads as _pipeline_loads
from .pipeline import run as _simulate_run
from .pipeline import steady as _pipeline_steady
from .pipeline.cost import enough_samples
from .pipeline.export import ExportResult
from .pipeline.optimize import OptimizeResult
from .pipeline.options import check_duration
from .pipeline.study import StudyResult
from .pipeline.study import run as _study_run
from .reference import constant_speed, reference_trace
from .sim import simulate as _sim
from .sim.steps import kinematic_clock
from .study.spec import load as _study_load
from .units import RunKind
from .validation import CheckReport

__all__ = [
    "CheckReport",
    "ExportResult",
    "FeedResult",
    "LoadsResult",
    "OptimizeResult",
    "SimulateResult",
    "SteadyResult",
    "StudyResult",
    "StudyTable",
    "SynthResult",
    "Traces",
    "check",
    "design",
    "export",
    "feed",
    "load",
    "loads",
    "mjcf",
    "read_study",
    "read_traces",
    "run_study",
    "simulate",
    "steady",
    "synth",
    "traces",
]

PathLike = str | os.PathLike[str]
T = TypeVar("T")

# ----------------------------------------------------------------------------- arguments
# Every public function checks its arguments here first: a wrong type or a value out of its
# range is one ArgumentError naming the function and the argument, never an internal
# TypeError. The bounds are the command line's own checks (speed, cycles, duration and a run's
# cost: mjlink.pipeline.estimate), called with the arguments' names.


def _refuse(fn: str, arg: str, value: object, what: str) -> ArgumentError:
    got = "None" if value is None else f"{shown(value)} ({type(value).__name__})"
    return ArgumentError(f"{fn}({arg}=...): must be {what}, got {got}")


def _path(fn: str, arg: str, value: object, what: str = "a path (str or os.PathLike)") -> str | Path:
    if isinstance(value, os.PathLike):
        text = os.fspath(value)
    elif isinstance(value, str):
        text = value
    else:
        raise _refuse(fn, arg, value, what)
    if not isinstance(text, str) or not text or "\x00" in text:
        raise _refuse(fn, arg, value, what + ", not empty, without NUL characters")
    try:
        os.stat(text)
    except (FileNotFoundError, NotADirectoryError):
        pass  # what is missing, each function says in its own words
    except OSError as e:  # a name too long for this system, a folder it may not enter...
        raise _refuse(fn, arg, value, f"{what} this system can look up ({e.strerror or type(e).__name__})") from None
    return value if isinstance(value, Path) else text


def _flag(fn: str, arg: str, value: object) -> bool:
    if not isinstance(value, bool | np.bool_):
        raise _refuse(fn, arg, value, "True or False")
    return bool(value)


def _number(fn: str, arg: str, value: object, unit: str) -> float | None:
    """None, or a finite real number (not a bool) as a float."""
    if value is None:
        return None
    if isinstance(value, bool | np.bool_) or not isinstance(value, numbers.Real):
        raise _refuse(fn, arg, value, f"a number ({unit}) or None")
    try:
        x = float(value)
    except (OverflowError, ValueError, TypeError):  # an int too large for a float
        raise _refuse(fn, arg, value, f"a finite number ({unit})") from None
    if not math.isfinite(x):
        raise _refuse(fn, arg, value, f"a finite number ({unit})")
    return x


def _checked(fn: str, check: Callable[[], T]) -> T:
    """``check()``, its MjlinkError (the command line's check, worded with the arguments'
    names) as this function's ArgumentError."""
    try:
        return check()
    except ArgumentError:
        raise
    except MjlinkError as e:
        raise ArgumentError(f"{fn}(): {e}") from None


def _mechanism(fn: str, mechanism: object) -> Mechanism:
    if isinstance(mechanism, Mechanism):
        return mechanism
    _path(fn, "mechanism", mechanism, "a Mechanism, a shipped mechanism's name or a path (str or os.PathLike)")
    return load(mechanism)  # type: ignore[arg-type]


def _speed(fn: str, speed_rpm: object) -> float | None:
    rpm = _number(fn, "speed_rpm", speed_rpm, "rpm")
    return None if rpm is None else rpm * 2.0 * math.pi / 60.0


_NAMES = {"--speed": "speed_rpm", "--cycles": "cycles", "--duration": "duration"}


def load(name_or_path: PathLike) -> Mechanism:
    """Read and validate a mechanism: a shipped one by name (``'takeup'``; ``python -m mjlink
    list`` names them) or a mechanism file by path.

    Args:
      name_or_path: a shipped mechanism's name, or a ``.toml`` file's path (a
        :class:`pathlib.Path` is always a path).
    Returns:
      The mechanism, checked as ``python -m mjlink check`` checks it (it assembles over the
      whole turn).
    Raises:
      MjlinkError: unknown name, missing file, or a file ``check`` refuses (one line naming
        the file, the line and the value).
    """
    p = _path("load", "name_or_path", name_or_path, "a shipped mechanism's name or a path (str or os.PathLike)")
    return validation.get(p)


def mjcf(mechanism: Mechanism | PathLike, *, kinematic: bool = False) -> str:
    """The mechanism's MuJoCo model as MJCF text (what ``python -m mjlink build`` writes).

    Args:
      mechanism: a :class:`Mechanism` or a name or path for :func:`load`.
      kinematic: the kinematic run's model (a heavy flywheel holds the crank's speed) instead
        of the dynamic one.
    Returns:
      The XML; ``mujoco.MjModel.from_xml_string`` loads it as it is.
    """
    mech = _mechanism("mjcf", mechanism)
    result: BuildResult = build(mech, kinematic=_flag("mjcf", "kinematic", kinematic))
    return result.xml


@dataclass(frozen=True)
class Traces(Mapping[str, np.ndarray]):
    """A run's traces by column name, each an array of shape (N,) in the unit its name ends
    with: the columns of ``kinematics.csv`` (``time_s``, ``phi1_deg``, ``omega1_rad_s``,
    ``n1_rpm``, ``P5_x_mm``, ``P5_vy_mm_s``, ``P5_ax_mm_s2``, ``thread_length_mm``...).

    ``mechanism`` names the mechanism, ``source`` says who computed it: ``'mujoco'`` or
    ``'reference'`` (the vector method), or ``'file'`` for traces read back from a CSV.
    """

    mechanism: str
    source: str
    columns: dict[str, np.ndarray] = field(repr=False)

    def __getitem__(self, name: str) -> np.ndarray:
        try:
            return self.columns[name]
        except KeyError:
            raise KeyError(f"no trace {name!r} (names: {', '.join(self.columns)})") from None

    def __iter__(self) -> Iterator[str]:
        return iter(self.columns)

    def __len__(self) -> int:
        return len(self.columns)


def traces(
    mechanism: Mechanism | PathLike,
    *,
    source: Literal["mujoco", "reference"] = "mujoco",
    cycles: float | None = None,
    speed_rpm: float | None = None,
) -> Traces:
    """The constant-speed kinematic run of a mechanism, in memory (nothing is written).

    Args:
      mechanism: a :class:`Mechanism` or a name or path for :func:`load`.
      source: ``'mujoco'``, the MuJoCo model sampled through its sensors, or ``'reference'``,
        the vector-method analysis at the same instants.
      cycles: crank periods to run (default: the file's ``[input] cycles``).
      speed_rpm: crank speed, rpm, signed as in the file (default: the file's).
    Returns:
      :class:`Traces` with N samples per column (N grows with ``cycles``).
    Raises:
      MjlinkError: a speed, cycle count or run size the command line refuses (before the run),
        or a MuJoCo run that leaves the reference's assembly branch or diverges.
    """
    mech = _mechanism("traces", mechanism)
    if not (isinstance(source, str) and source in ("mujoco", "reference")):
        raise _refuse("traces", "source", source, "'mujoco' or 'reference'")
    speed = _speed("traces", speed_rpm)
    n = _number("traces", "cycles", cycles, "crank periods")
    # What `simulate` would refuse for its kinematic run (a speed, a cycle count or a size
    # beyond the limits) is refused here, before the run allocates anything.
    _checked(
        "traces", lambda: estimate(mech, Options(speed=speed, cycles=n, dynamics=False, video=False), names=_NAMES)
    )
    case = _sim.kinematic_case(mech, speed=speed, cycles=n)
    trace = _sim.run(mech, case)
    if source == "reference":
        trace = reference_trace(mech, constant_speed(mech, trace.time, case.omega0), RunKind.KINEMATICS)
    names, blocks = files.columns(mech, trace)
    cols: dict[str, np.ndarray] = {}
    i = 0
    for values, factor in blocks:
        block = np.asarray(values, dtype=float) * factor
        for col in block.reshape(len(block), -1).T:
            cols[names[i]] = col
            i += 1
    return Traces(mech.name, source, cols)


def read_traces(path: PathLike) -> Traces:
    """Traces read back from a CSV that ``simulate`` wrote (``kinematics.csv``,
    ``reference_kinematics.csv``, ``dynamics.csv``, ``loads.csv``...), by column name.

    Raises:
      MjlinkError: no such file, or one that is not such a table (one line naming the file and,
        where there is one, the line and the column at fault).
    """
    p = Path(_path("read_traces", "path", path))
    return Traces(p.parent.name, "file", files.read_csv(p))


def simulate(
    mechanism: Mechanism | PathLike,
    out: PathLike = "renders",
    *,
    video: bool = False,
    plots: bool = True,
    dynamics: bool = True,
    loads: bool = True,
    speed_rpm: float | None = None,
    cycles: float | None = None,
    duration: float | None = None,
    force: bool = False,
) -> SimulateResult:
    """What ``python -m mjlink simulate`` does, into ``out/NAME/``: the kinematic run and its
    agreement with the reference, the forward dynamics, loads, figures, ``index.html``,
    ``report.json`` and the traces as CSV (:func:`read_traces` reads them).

    Args:
      mechanism: a :class:`Mechanism` or a name or path for :func:`load`.
      out: the output root; the folder ``out/NAME/`` is written whole or not at all.
      video: also render the MP4 (needs a working OpenGL backend; off by default here, on for
        the command).
      plots, dynamics, loads: the PNG figures, the forward-dynamics run, the driving torque
        and pair reactions (each where the file has what it needs).
      speed_rpm: crank speed, rpm (default: the file's); cycles: crank periods of the
        kinematic run; duration: s of the dynamic run (defaults: the file's).
      force: publish into an existing folder mjlink did not write (your files are kept).
    Returns:
      The run's :class:`~mjlink.pipeline.SimulateResult`: ``failures`` lists every threshold
      missed (empty when MuJoCo agrees with the reference), ``as_dict()`` is ``report.json``,
      ``out_dir`` the folder.
    """
    fn = "simulate"
    mech = _mechanism(fn, mechanism)
    root = Path(_path(fn, "out", out))
    flags = {k: _flag(fn, k, v) for k, v in (("video", video), ("plots", plots), ("dynamics", dynamics))}
    flags |= {k: _flag(fn, k, v) for k, v in (("loads", loads), ("force", force))}
    speed = _speed(fn, speed_rpm)
    n = _number(fn, "cycles", cycles, "crank periods")
    d = _number(fn, "duration", duration, "s")
    if d is not None:  # refused as --duration is, whether or not the dynamic run is made
        _checked(fn, lambda: check_duration(d, "duration"))
    opts = Options(
        speed=speed,
        cycles=n,
        duration=d,
        dynamics=flags["dynamics"],
        plots=flags["plots"],
        video=flags["video"],
        loads=flags["loads"],
    )
    _checked(fn, lambda: estimate(mech, opts, names=_NAMES))
    clock = kinematic_clock(mech.period, mech.speed if speed is None else speed, mech.cycles if n is None else n)
    _checked(fn, lambda: enough_samples(mech, clock, "cycles"))
    return _simulate_run(mech, root, opts, force=flags["force"])


def run_study(
    study: PathLike,
    out: PathLike = "renders",
    *,
    workers: int | None = None,
    scheduler: str | None = None,
    plots: bool = True,
    force: bool = False,
    progress: bool = False,
    metrics: Mapping[str, Callable[[Mapping[str, np.ndarray]], Any] | tuple[Callable[..., Any], str]] | None = None,
) -> StudyResult | OptimizeResult:
    """What ``python -m mjlink study`` does, into ``out/NAME-study/``: a sweep, tolerance
    study or optimization of a study file (studies/README.md).

    Args:
      study: a shipped study's name (``'crank_slider_grid'``) or a study file's path.
      out: the output root.
      workers: processes of a local Dask cluster (default: one per core, or this process for
        a small study; 0: this process, no Dask).
      scheduler: an existing Dask scheduler's address ``tcp://HOST:PORT`` instead.
      plots: write the PNG figures.
      force: publish into an existing folder mjlink did not write (your files are kept).
      progress: report progress on stderr.
      metrics: the designer's own metrics, column name -> function (or (function, unit)): each
        gets the variants' traces by column name (the names of ``kinematics.csv``), arrays of
        shape (V, A) (V variants, A crank angles over one period), and returns shape (V,).
        The study file's bounds, objective and ``[verify] by`` may name their columns
        (docs/api.md, Your own metric in Python).
    Returns:
      A :class:`~mjlink.pipeline.study.StudyResult` (``out_dir``, ``summary``), or for an
      ``[optimize]`` study an :class:`~mjlink.pipeline.optimize.OptimizeResult` (its
      ``winner_file`` and ``summary``, whose ``converged`` says whether the search settled).
    Raises:
      MjlinkError: a study refused before any work (one line naming the file and line).
    """
    fn = "run_study"
    spec = _path(fn, "study", study, "a shipped study's name or a path (str or os.PathLike)")
    root = Path(_path(fn, "out", out))
    if workers is not None and (
        isinstance(workers, bool | np.bool_) or not isinstance(workers, numbers.Integral) or workers < 0
    ):
        raise _refuse(fn, "workers", workers, "a whole number >= 0 or None")
    if scheduler is not None and not isinstance(scheduler, str):
        raise _refuse(fn, "scheduler", scheduler, "a Dask scheduler's address 'tcp://HOST:PORT' or None")
    flags = {k: _flag(fn, k, v) for k, v in (("plots", plots), ("force", force), ("progress", progress))}
    if metrics is not None and not isinstance(metrics, Mapping):
        raise _refuse(fn, "metrics", metrics, "a mapping of column name to function, or None")
    return _study_run(
        _study_load(spec, metrics) if metrics else spec,
        root,
        workers=None if workers is None else int(workers),
        scheduler=scheduler,
        plots=flags["plots"],
        force=flags["force"],
        progress=flags["progress"],
    )


@dataclass(frozen=True)
class StudyTable(Mapping[str, np.ndarray]):
    """A finished study's results, a mapping like :class:`Traces`: its table by column name
    (``results.parquet``: one row per variant; numbers as float arrays in the unit the name
    ends with, text as object arrays; ``keys()`` the names), ``rows`` the number of variants,
    ``summary`` its ``summary.json`` (for an optimization: ``converged``, the ``winner``,
    ``caveats``...), ``out_dir`` the folder."""

    out_dir: Path
    columns: dict[str, np.ndarray] = field(repr=False)
    summary: dict[str, Any] = field(repr=False)

    def __getitem__(self, name: str) -> np.ndarray:
        try:
            return self.columns[name]
        except KeyError:
            raise KeyError(f"no column {name!r} (names: {', '.join(self.columns)})") from None

    def __iter__(self) -> Iterator[str]:
        return iter(self.columns)

    def __len__(self) -> int:
        """The number of columns, as for any mapping (``rows`` is the number of variants)."""
        return len(self.columns)

    @property
    def rows(self) -> int:
        """The number of rows (variants)."""
        return len(next(iter(self.columns.values()))) if self.columns else 0


def read_study(folder: PathLike) -> StudyTable:
    """Read a study's results folder (``OUT/NAME-study/``, as :func:`run_study` returns it).

    Raises:
      MjlinkError: no such folder, or one without a study's readable ``results.parquet`` and
        ``summary.json``.
    """
    d = Path(_path("read_study", "folder", folder))
    table, summ = d / "results.parquet", d / "summary.json"
    if not d.is_dir():
        raise InputError(f"{d}: no such study folder")
    if not (table.is_file() and summ.is_file()):
        raise InputError(f"{d}: not a study's results (no results.parquet and summary.json)")
    summary = files.read_json(summ)
    if not isinstance(summary, dict):
        raise InputError(f"{summ}: not a readable study summary")
    return StudyTable(d, files.read_parquet(table), summary)


# ----------------------------------------------------------------------------- the other commands
def check(mechanism: Mechanism | PathLike) -> CheckReport:
    """What ``python -m mjlink check`` finds: the points (each moving one where it is at the
    crank's setting), links, pairs, degrees of freedom, assembly, dead points, a head's timing,
    the notes and warnings, and every problem. Never raises for the geometry: a file that
    cannot be simulated faithfully has its ``problems`` (``ok`` False, ``error()`` the first as
    the error :func:`load` would raise).

    Args:
      mechanism: a :class:`Mechanism`, or a shipped mechanism's name or a file's path.
    Raises:
      MjlinkError: an unknown name, a missing file, or a file that cannot be read into a
        mechanism at all (one line).
    """
    if isinstance(mechanism, Mechanism):
        return validation.check(mechanism)
    p = _path("check", "mechanism", mechanism, "a Mechanism, a shipped mechanism's name or a path (str or os.PathLike)")
    return validation.check_file(p)


def export(
    mechanism: Mechanism | PathLike,
    *,
    dxf: PathLike | None = None,
    points: PathLike | None = None,
    angle_deg: float | None = None,
    force: bool = False,
) -> ExportResult:
    """What ``python -m mjlink export`` writes: the mechanism at one crank angle as a DXF (mm,
    a layer per link and per path, pivots, guides, the thread) and its points as CSV or JSON
    (by the extension), both or neither (docs/outputs.md).

    Args:
      mechanism: a :class:`Mechanism` or a name or path for :func:`load`.
      dxf, points: the files to write (at least one).
      angle_deg: the input crank's angle, deg (default: the file's setting ``phi0``).
      force: replace files that exist (never the mechanism's own file).
    Returns:
      :class:`~mjlink.pipeline.export.ExportResult`: ``points`` name -> (x, y, z) mm.
    """
    from .pipeline import export as _export  # here: ezdxf, only for this function

    fn = "export"
    mech = _mechanism(fn, mechanism)
    targets = [None if v is None else Path(_path(fn, k, v)) for k, v in (("dxf", dxf), ("points", points))]
    angle = _number(fn, "angle_deg", angle_deg, "deg")
    if angle is not None:
        _checked(fn, lambda: validation.check_angle("angle_deg", angle))
    return _export.export(mech, angle, targets[0], targets[1], force=_flag(fn, "force", force))


def design(
    mechanism: Mechanism | PathLike, output: PathLike | None = None, *, out: PathLike = "renders", force: bool = False
) -> Path:
    """What ``python -m mjlink design`` writes: the drag-to-design page, at ``out/NAME/design.html``
    (where ``simulate`` puts it, the run's other files kept) or at ``output``.

    Returns:
      The page's path.
    """
    from .pipeline import design as _design

    fn = "design"
    mech = _mechanism(fn, mechanism)
    page = None if output is None else Path(_path(fn, "output", output))
    root = Path(_path(fn, "out", out))
    return _design.design_page(mech, page, out_root=root, force=_flag(fn, "force", force))


def loads(
    mechanism: Mechanism | PathLike,
    out: PathLike = "renders",
    *,
    speed_rpm: float | None = None,
    plots: bool = True,
    force: bool = False,
) -> LoadsResult:
    """What ``python -m mjlink torque`` and ``reactions`` compute, into ``out/NAME_loads/``: the
    driving torque and every pair's reaction at constant crank speed, MuJoCo's against the
    kinetostatic reference.

    Args:
      speed_rpm: crank speed, rpm, signed (default: the file's).
    Returns:
      :class:`~mjlink.pipeline.LoadsResult` (``loads`` the numbers, ``failures``).
    """
    fn = "loads"
    mech = _mechanism(fn, mechanism)
    root = Path(_path(fn, "out", out))
    speed = _speed(fn, speed_rpm)
    flags = {k: _flag(fn, k, v) for k, v in (("plots", plots), ("force", force))}
    _checked(fn, lambda: estimate(mech, Options(speed=speed, dynamics=False, video=False), names=_NAMES))
    return _pipeline_loads(mech, root, speed=speed, plots=flags["plots"], force=flags["force"])


def steady(
    mechanism: Mechanism | PathLike, out: PathLike = "renders", *, plots: bool = True, force: bool = False
) -> SteadyResult:
    """What ``python -m mjlink steady`` computes with the file's drive (``[steady]``, else
    ``[dynamics.motor]``), into ``out/NAME_steady/``: the periodic steady motion, the coefficient
    of speed fluctuation, the flywheel for the target and MuJoCo on both orbits. (The command's
    drive options have no counterpart here: give the drive in the file.)

    Returns:
      :class:`~mjlink.pipeline.SteadyResult`.
    """
    fn = "steady"
    mech = _mechanism(fn, mechanism)
    root = Path(_path(fn, "out", out))
    flags = {k: _flag(fn, k, v) for k, v in (("plots", plots), ("force", force))}
    return _pipeline_steady(mech, root, plots=flags["plots"], force=flags["force"])


def synth(
    *,
    stroke_mm: float | None = None,
    offset_mm: float | None = None,
    ratio: float | None = None,
    max_pressure_deg: float | None = None,
    write: PathLike | None = None,
    force: bool = False,
) -> SynthResult:
    """What ``python -m mjlink synth crank_slider`` does: the offset crank-slider's metric
    synthesis for a stroke, guide offset, lambda = r / l and allowed pressure angle (each None
    takes ``crank_slider.toml``'s), and with ``write`` the accepted design saved as a mechanism
    file (never over an existing one unless ``force``).

    Returns:
      :class:`~mjlink.pipeline.SynthResult`.
    """
    fn = "synth"
    values = {
        k: _number(fn, k, v, u)
        for k, v, u in (
            ("stroke_mm", stroke_mm, "mm"),
            ("offset_mm", offset_mm, "mm"),
            ("ratio", ratio, "-"),
            ("max_pressure_deg", max_pressure_deg, "deg"),
        )
    }
    target = None if write is None else Path(_path(fn, "write", write))
    again = _flag(fn, "force", force)
    if target is not None:  # refused before any work
        claim_outputs({"write": target}, [catalogue.path_of("crank_slider")], force=again)
    names = {
        "--stroke": "stroke_mm",
        "--offset": "offset_mm",
        "--lambda": "ratio",
        "--max-pressure-angle": "max_pressure_deg",
    }

    def run() -> SynthResult:
        try:
            return synthesize("crank_slider", **values)
        except MjlinkError as e:  # the command's check, in the arguments' names
            text = str(e)
            for option, name in names.items():
                if text.startswith(option + " "):
                    raise ArgumentError(f"{fn}(): {name}{text[len(option) :]}") from None
            raise

    res = run()
    if target is not None:
        write_design(res, target, force=again)
    return res


def feed(
    mechanism: Mechanism | PathLike,
    out: PathLike = "renders",
    *,
    speed_rpm: float | None = None,
    sweep: bool = False,
    stitches: int = 6,
    plots: bool = True,
    video: bool = False,
    force: bool = False,
) -> FeedResult:
    """What ``python -m mjlink feed`` computes: the fabric fed by the head's dog under its sprung
    presser foot through MuJoCo's contacts, at ``speed_rpm`` (default the file's; its sign is
    ignored, the file's sense kept) or with ``sweep`` every 500 rpm from 500 to 6,000,
    ``stitches`` (2 to 50) from rest at each speed, into ``out/NAME_feed/`` as the command
    writes it.

    Returns:
      :class:`~mjlink.pipeline.FeedResult`: per speed a :class:`mjlink.sim.feed.FeedRun`
      (``stitch``, ``error``, ``spread``, ``separation``, ``load_factor``, ``slip``, the traces
      of the last stitch), and over a sweep ``first_over`` the slowest beyond 2 %.
    """
    fn = "feed"
    mech = _mechanism(fn, mechanism)
    root = Path(_path(fn, "out", out))
    rpm = _number(fn, "speed_rpm", speed_rpm, "rpm")
    flags = {k: _flag(fn, k, v) for k, v in (("sweep", sweep), ("plots", plots), ("video", video), ("force", force))}
    if isinstance(stitches, bool | np.bool_) or not isinstance(stitches, numbers.Integral):
        raise _refuse(fn, "stitches", stitches, "a whole number")
    names = {"--speed": "speed_rpm", "--sweep": "sweep", "--stitches": "stitches"}
    try:
        return _pipeline_feed(
            mech,
            root,
            speed_rpm=rpm,
            sweep=flags["sweep"],
            stitches=int(stitches),
            plots=flags["plots"],
            video=flags["video"],
            force=flags["force"],
        )
    except InputError as e:  # the command's check, in the arguments' names
        text = str(e)
        for option, name in names.items():
            text = text.replace(option, name)
        raise ArgumentError(f"{fn}(): {text}") from None
