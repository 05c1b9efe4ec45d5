"""Study files: which mechanism, which numbers vary and how, which metrics, what MuJoCo checks.

The format is documented in ``studies/README.md``. A study file is read once into a
:class:`Study`; every problem is a one-line :class:`StudyFileError` naming the file and key
(an unknown key or parameter path names the nearest valid one).

Values in a study file are in the mechanism file's units (mm, deg, g, ...), as each
parameter path's unit says (:mod:`mjlink.model.paths`).
"""

from __future__ import annotations

import hashlib
import math
import sys
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .. import validation
from ..analysis import function_metric as _functions
from ..analysis import metrics as _metrics
from ..analysis.metric_base import old_speed_name
from ..errors import InputError, MjlinkError, did_you_mean
from ..model import catalogue, paths
from ..model import names as _names
from ..model.limits import MAX_FILE_BYTES, MAX_TITLE_CHARS
from ..model.mechanism import Mechanism
from ..model.reader import digits, shown
from ..notes import note
from ..quantity import QuantityError
from ..quantity import parse as parse_quantity
from . import feed_metric as _feed_metric  # noqa: F401 (registers the 'feed' metric)
from . import sampling, values
from .errors import StudyFileError, StudyLimitError
from .varied import Varied

METHODS = ("grid", "random", "tolerance")  # sampling; an [optimize] table makes the method "optimize"
SEQUENCES = ("sobol", "lhs")
DISTRIBUTIONS = ("uniform", "normal", "even")
VERIFY = ("all", "none", "best", "worst")
SENSES = ("min", "max")
INITS = ("sobol", "lhs")
STARTS = ("sample", "file")  # an optimization's runs: from their samples alone, or the file's design among them
MAX_VARIANTS = 10_000_000
MAX_PER_TURN = 3600
STUDIES_DIR = catalogue.STUDIES_DIR


@dataclass(frozen=True)
class Bound:
    """An admissible range of a metric column (None: open), in the column's unit."""

    column: str
    low: float | None
    high: float | None

    def holds(self, x: np.ndarray) -> np.ndarray:
        ok = np.isfinite(x)
        if self.low is not None:
            ok &= x >= self.low
        if self.high is not None:
            ok &= x <= self.high
        return ok

    def text(self) -> str:
        if self.low is not None and self.high is not None:
            return f"{self.low:g} <= {self.column} <= {self.high:g}"
        return f"{self.column} >= {self.low:g}" if self.low is not None else f"{self.column} <= {self.high:g}"


# The manufacturing resolution a winner's numbers are rounded to, by unit (file units), unless
# the study file's [optimize] resolution says otherwise; numbers of other units are written to
# RESOLUTION_DIGITS significant digits.
RESOLUTION = {"mm": 0.01, "deg": 0.01}
RESOLUTION_DIGITS = 8


@dataclass(frozen=True, kw_only=True)
class Optimize:
    """An optimization's ``[optimize]`` table (see :mod:`mjlink.study.optimize`).

    ``objective`` column -> weight of a weighted sum (one column: that metric); ``sense``
    'min' or 'max'; ``pareto`` two columns (both minimized) for a Pareto front of ``points``
    designs instead; ``population`` candidates per generation; ``generations`` the most
    generations per run; ``tol``/``atol`` scipy's spread test (relative, and absolute in the
    objective's unit); ``flywheel_delta`` size a flywheel for the winner (the inertia on the
    input crank that brings the steady-motion delta down to it; 0: none).

    The convergence criterion's settings: ``stall`` generations without improvement of the best
    feasible value (by more than ``ftol`` of it) end a run as settled; ``seeds`` independent runs
    of a single objective (seeds ``seed``, ``seed + 1``, ...), whose agreement is reported;
    ``polish_evaluations`` the local polish's budget per run (0: no polish); ``xtol`` the
    polish's step, a fraction of each range, at which a run is converged. ``resolution`` unit ->
    the manufacturing resolution the winner file's numbers are rounded to. ``start`` 'file':
    each run's first generation holds the mechanism file's design (scipy's ``x0``), else
    ('sample') only its sample of the ranges.
    """

    objective: tuple[tuple[str, float], ...]
    sense: str
    pareto: tuple[str, str] | None
    points: int
    population: int
    generations: int
    seed: int
    tol: float
    atol: float
    init: str
    flywheel_delta: float
    seeds: int = 1
    stall: int = 30
    ftol: float = 1e-9
    polish_evaluations: int = 0
    xtol: float = 1e-9
    resolution: tuple[tuple[str, float], ...] = tuple(RESOLUTION.items())
    start: str = "sample"

    @property
    def label(self) -> str:
        """The objective as a formula: 'feed_deviation_max + 0.5 * feed_deviation_rms'."""
        if self.pareto:
            return f"minimize {self.pareto[0]} and {self.pareto[1]}"
        text = " + ".join(c if w == 1 else f"{w:g} * {c}" for c, w in self.objective)
        return f"{'maximize' if self.sense == 'max' else 'minimize'} {text}"

    def step_of(self, unit: str) -> float | None:
        """The resolution of numbers in ``unit`` (None: RESOLUTION_DIGITS significant digits)."""
        return dict(self.resolution).get(unit)


@dataclass(frozen=True)
class Robust:
    """A robust optimization's ``[robust]`` table: each candidate is judged over ``samples``
    tolerance deviations (the [[parameter]] tolerances; the same deviations for every
    candidate), by the mean plus ``k`` standard deviations of each objective column; bounds
    must hold for every sample."""

    samples: int
    k: float
    seed: int


@dataclass(frozen=True, kw_only=True)
class Study:
    """A validated study. ``per_turn`` crank angles per input turn; ``verify`` one of
    'all', 'none', 'best', 'worst' (``count`` variants by metric column ``by``)."""

    name: str
    title: str
    path: Path | None
    mechanism: Mechanism
    method: str
    varied: tuple[Varied, ...]
    samples: int
    seed: int
    sequence: str
    metrics: tuple[_metrics.Metric, ...]
    bounds: tuple[Bound, ...]
    per_turn: int
    verify: str
    count: int
    by: str
    digest: str  # of the study's and the mechanism's text: what a resumed run must match
    optimize: Optimize | None = None
    robust: Robust | None = None
    # A robust optimization's operating conditions: [[parameter]]s with a tolerance and no
    # range, held at the file's value and deviated over the robust samples, never searched.
    conditions: tuple[Varied, ...] = ()
    fixed: tuple[tuple[str, float], ...] = ()  # [set]: path -> value (file units), applied first
    # The mechanism as its file was read, before [set]: what a winner file is written from.
    file_mechanism: Mechanism | None = field(default=None, repr=False, compare=False)
    definition_digest: str = ""  # of the study file's text alone
    mechanism_digest: str = ""  # of the mechanism file's text alone

    @property
    def params(self) -> list[paths.Param]:
        return [v.param for v in self.varied]

    @property
    def columns(self) -> list[_metrics.Column]:
        return _metrics.columns(self.metrics)

    @property
    def grid_shape(self) -> tuple[int, ...] | None:
        """The grid's shape (one axis per parameter, in file order) for a grid study."""
        return tuple(len(v.values) for v in self.varied) if self.method == "grid" else None

    def values(self) -> np.ndarray:
        """(V, P) every variant's parameter values, file units, in a fixed order (the seed
        fixes random and tolerance samples)."""
        if self.method == "optimize":
            raise ValueError(f"{self.name}: an optimization draws its candidates itself (mjlink.study.optimize)")
        if self.method == "grid":
            return sampling.grid(self.varied)
        if self.method == "random":
            return sampling.quasi_random(self.varied, self.samples, self.seed, self.sequence)
        return sampling.tolerance(self.varied, self.samples, self.seed)


def _fail(src: object, where: str, what: str) -> StudyFileError:
    return StudyFileError(f"{src}: {where}: {what}" if where else f"{src}: {what}")


def _keys(src: object, raw: dict, where: str, required: list[str], optional: list[str]) -> None:
    allowed = required + optional
    for k in raw:
        if k not in allowed:
            hint = did_you_mean(k, allowed)
            raise _fail(src, where, f"unknown key {shown(k)} ({hint}valid: {', '.join(allowed)})")
    for k in required:
        if k not in raw:
            raise _fail(src, where, f"missing key '{k}'")


def _number(src: object, raw: dict, key: str, where: str, *, default: float | None = None, unit: str = "") -> float:
    """A finite number; with ``unit``, also a number with a unit of its kind ('12mm',
    '1.2 cm', mjlink.quantity), converted to ``unit``."""
    v = raw.get(key, default)
    if isinstance(v, str) and unit:
        try:
            v = parse_quantity(v, unit, require_unit=True)
        except QuantityError as e:
            raise _fail(src, f"{where} {key}", str(e)) from None
    if isinstance(v, bool) or not isinstance(v, int | float):
        with_unit = f" (or a string with its unit, e.g. '12{unit}')" if unit else ""
        raise _fail(src, f"{where} {key}", f"must be a finite number, got {shown(v)}{with_unit}")
    try:
        x = float(v)
    except OverflowError:  # an integer of hundreds of digits
        raise _limit(
            src, f"{where} {key}", f"must be a finite number, got an integer of {digits(int(v))} digits"
        ) from None
    if not math.isfinite(x):
        raise _fail(src, f"{where} {key}", f"must be a finite number, got {shown(v)}")
    return x


def _integer(src: object, raw: dict, key: str, where: str, lo: int, hi: int, default: int | None = None) -> int:
    if key not in raw and default is None:
        raise _fail(src, where, f"missing key '{key}' (an integer from {lo} to {hi})")
    v = raw.get(key, default)
    if isinstance(v, bool) or not isinstance(v, int) or not lo <= v <= hi:
        error = _limit if isinstance(v, int) and not isinstance(v, bool) else _fail
        raise error(src, f"{where} {key}", f"must be an integer from {lo} to {hi}, got {shown(v)}")
    return int(v)


def _limit(src: object, where: str, what: str) -> StudyLimitError:
    return StudyLimitError(f"{src}: {where}: {what}" if where else f"{src}: {what}")


def find(name_or_path: str | Path) -> Path:
    """A study file by path, or by name among the shipped ``studies/*.toml``."""
    try:
        p = Path(name_or_path).expanduser()
    except RuntimeError:  # ~user of no such user, or no home folder
        head = str(name_or_path).split("/")[0]
        raise StudyLimitError(
            f"{shown(str(name_or_path))}: cannot expand {shown(head)}: no such user or home folder"
        ) from None
    what = catalogue.what_is(p)  # first: it never raises (a name too long for the file system)
    if what is None and p.is_file():
        return p
    named = str(name_or_path)
    if "/" not in named and not named.endswith(".toml") and len(named) < 256:
        shipped = STUDIES_DIR / f"{named}.toml"
        if shipped.is_file():
            return shipped
    if what == "a folder":
        raise StudyFileError(f"{shown(str(p))}: is a folder, not a study file")
    if what is not None:
        raise StudyLimitError(f"{shown(str(p))}: is {what}, not a study file")
    known = sorted(q.stem for q in STUDIES_DIR.glob("*.toml"))
    hint = did_you_mean(str(name_or_path), known)
    raise StudyFileError(f"{shown(str(name_or_path))}: no such study file ({hint}shipped: {', '.join(known)})")


def load(name_or_path: str | Path, functions: Mapping[str, Any] | None = None) -> Study:
    """Read and validate a study file (a path, or the name of a shipped one); ``functions``
    the designer's Python metrics (:func:`parse`)."""
    p = find(name_or_path)
    try:
        size = p.stat().st_size
        if size > MAX_FILE_BYTES:
            raise StudyLimitError(
                f"{p}: {size} bytes; a study file is at most {MAX_FILE_BYTES} bytes (1 MiB): it is read whole"
            )
        text = p.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as e:
        raise StudyFileError(f"{p}: cannot read: {e}") from None
    return parse(text, p, functions)


def parse(text: str, path: Path | str = "<string>", functions: Mapping[str, Any] | None = None) -> Study:
    """Parse and validate a study file's text; the mechanism path is relative to the file.
    ``functions`` adds the designer's Python metrics after the file's, name -> function or
    (function, unit) (:mod:`mjlink.analysis.function_metric`): their columns may be bounded,
    optimized and ranked by like the file's, and their code is part of what a resumed run
    must match."""
    src = path
    if len(text) > MAX_FILE_BYTES:
        raise _limit(src, "", f"{len(text)} characters; a study file is at most {MAX_FILE_BYTES} (1 MiB)")
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise StudyFileError(f"{src}: not valid TOML: {e}") from None
    except RecursionError:
        raise _limit(src, "", "TOML nested too deeply (arrays or inline tables within each other)") from None
    except ValueError:  # an integer literal beyond Python's limit for str -> int
        raise _limit(
            src,
            "",
            f"TOML: an integer of more than {sys.get_int_max_str_digits() or 4300} digits: write a plain number",
        ) from None
    _keys(src, data, "", ["study", "parameter"], ["sampling", "metric", "bound", "verify", "optimize", "robust", "set"])
    st = data["study"]
    if not isinstance(st, dict):
        raise _fail(src, "[study]", "must be a table")
    _keys(src, st, "[study]", ["mechanism"], ["name", "title", "angles"])
    default = Path(path).stem if path != "<string>" else "study"
    name = st.get("name", default)
    if not isinstance(name, str) or not _names.is_valid(name):
        whence = "" if "name" in st else ", the file's name: set [study] name or rename the file"
        raise _fail(
            src, "[study] name", f"must be a letter, then at most 31 letters, digits or _ (got {shown(name)}{whence})"
        )
    title = st.get("title", "")
    if not isinstance(title, str) or len(title) > MAX_TITLE_CHARS or not title.isprintable():
        raise _fail(src, "[study] title", f"must be one line of printable text of at most {MAX_TITLE_CHARS} characters")
    mref = st["mechanism"]
    if not isinstance(mref, str) or not mref:
        raise _fail(src, "[study] mechanism", "must be a mechanism name or a path to its file")
    base = Path(path).parent if path != "<string>" else Path.cwd()
    target = base / mref if (mref.endswith(".toml") or "/" in mref) and not Path(mref).is_absolute() else mref
    try:
        mech = validation.get(target)
        mtext = mech.text.encode("utf-8") if mech.text is not None else b""
    except MjlinkError as e:
        error = _limit if isinstance(e, InputError) else _fail
        raise error(src, "[study] mechanism", str(e)) from None
    base = mech
    fixed = _fixed(src, mech, data.get("set", {}))
    values.check_set(src, text, base, fixed)
    if fixed:
        try:
            mech = paths.apply(mech, {paths.resolve(mech, k): v for k, v in fixed})
        except MjlinkError as e:
            raise _fail(src, "[set]", str(e)) from None
    per_turn = _integer(src, st, "angles", "[study]", 8, MAX_PER_TURN, default=360)
    if per_turn % 2:
        raise _fail(src, "[study] angles", f"must be even (the steady-motion metric steps over pairs), got {per_turn}")

    optimizing = "optimize" in data
    if optimizing and "sampling" in data:
        raise _fail(src, "[sampling]", "an [optimize] study draws its own candidates: no [sampling]")
    if "robust" in data and not optimizing:
        raise _fail(src, "[robust]", "applies to an optimization: add an [optimize] table")
    sampling = data.get("sampling", {"method": "grid"})
    if not isinstance(sampling, dict):
        raise _fail(src, "[sampling]", "must be a table")
    _keys(src, sampling, "[sampling]", ["method"], ["samples", "seed", "sequence"])
    method = sampling["method"]
    if method not in METHODS:
        raise _fail(src, "[sampling] method", f"must be one of {', '.join(METHODS)}, got {shown(method)}")
    if optimizing:
        method = "optimize"
    if method == "grid" and ("samples" in sampling or "sequence" in sampling):
        raise _fail(src, "[sampling]", "a grid takes its variants from the parameters' values: no 'samples'/'sequence'")
    samples = _integer(src, sampling, "samples", "[sampling]", 1, MAX_VARIANTS, default=1) if method != "grid" else 0
    if method not in ("grid", "optimize") and "samples" not in sampling:
        raise _fail(src, "[sampling]", f"missing key 'samples' (how many variants the {method} study draws)")
    seed = _integer(src, sampling, "seed", "[sampling]", 0, 2**63 - 1, default=0)
    sequence = sampling.get("sequence", "sobol")
    if sequence not in SEQUENCES:
        raise _fail(src, "[sampling] sequence", f"must be one of {', '.join(SEQUENCES)}, got {shown(sequence)}")

    raw_params = data["parameter"]
    if not isinstance(raw_params, list) or not raw_params:
        raise _fail(src, "[[parameter]]", "needs at least one [[parameter]] table")
    varied: list[Varied] = []
    for i, rp in enumerate(raw_params):
        where = f"[[parameter]] #{i + 1}"
        if not isinstance(rp, dict):
            raise _fail(src, where, "must be a table")
        varied.append(_varied(src, mech, rp, where, method, "robust" in data))
    seen = set()
    for v in varied:
        if v.param.path in seen:
            raise _fail(src, "[[parameter]]", f"'{v.param.path}' is varied twice")
        seen.add(v.param.path)
    if method == "grid":
        samples = math.prod(len(v.values) for v in varied)  # Python's integers: no wrap-around
        if samples > MAX_VARIANTS:
            raise _limit(src, "[[parameter]]", f"the grid has {samples} variants, at most {MAX_VARIANTS}")

    raw_metrics = data.get("metric", [])
    if not isinstance(raw_metrics, list) or not (raw_metrics or functions):
        raise _fail(src, "[[metric]]", "needs at least one [[metric]] table (what to compute for each variant)")
    try:
        own = _functions.functions(mech, functions)
        mets = tuple(_metrics.read(mech, m, i) for i, m in enumerate(raw_metrics)) + own
        cols = _metrics.columns(mets)
    except MjlinkError as e:
        raise (StudyLimitError if isinstance(e, InputError) else StudyFileError)(f"{src}: {e}") from None
    names = [c.name for c in cols]

    bounds = []
    raw_bounds = data.get("bound", [])
    if not isinstance(raw_bounds, list):
        raise _fail(src, "[[bound]]", "must be an array of tables")
    for i, rb in enumerate(raw_bounds):
        where = f"[[bound]] #{i + 1}"
        if not isinstance(rb, dict):
            raise _fail(src, where, "must be a table")
        _keys(src, rb, where, ["metric"], ["min", "max"])
        col = _column(src, rb["metric"], names, f"{where} metric")
        lo = _number(src, rb, "min", where) if "min" in rb else None
        hi = _number(src, rb, "max", where) if "max" in rb else None
        if lo is None and hi is None:
            raise _fail(src, where, "needs 'min' or 'max'")
        bounds.append(Bound(col, lo, hi))

    optimize = robust = None
    # A robust optimization's parameters without a range (their low NaN) are its conditions.
    conditions = tuple(v for v in varied if optimizing and math.isnan(v.low))
    if optimizing:
        if "verify" in data:
            raise _fail(src, "[verify]", "an optimization verifies its winner (and Pareto set) in MuJoCo: no [verify]")
        if len(conditions) == len(varied):
            raise _fail(
                src, "[[parameter]]", "an optimization needs at least one [[parameter]] with a 'range' to search"
            )
        optimize = _optimize(src, data["optimize"], names, len(varied) - len(conditions))
        if "robust" in data:
            robust = _robust(src, data["robust"], optimize.seed)
            if not any(v.tolerance > 0 for v in varied):
                raise _fail(src, "[robust]", "needs a 'tolerance' on at least one [[parameter]]")
            _crossed(src, conditions, robust.samples)
    ver = data.get("verify", {"mujoco": "none"})
    if not isinstance(ver, dict):
        raise _fail(src, "[verify]", "must be a table")
    _keys(src, ver, "[verify]", ["mujoco"], ["count", "by"])
    mode = ver["mujoco"]
    if mode not in VERIFY:
        raise _fail(src, "[verify] mujoco", f"must be one of {', '.join(VERIFY)}, got {shown(mode)}")
    count, by = 0, ""
    if mode in ("best", "worst"):
        if "count" not in ver:
            raise _fail(src, "[verify]", f"'{mode}' needs 'count' (how many of the {mode} variants to verify)")
        count = _integer(src, ver, "count", "[verify]", 1, MAX_VARIANTS)
        if "by" not in ver:
            raise _fail(src, "[verify]", f"'{mode}' needs 'by' (the metric column that ranks the variants)")
        by = _column(src, ver["by"], names, "[verify] by")
    elif "count" in ver or "by" in ver:
        raise _fail(src, "[verify]", f"'count' and 'by' apply to 'best' and 'worst', not '{mode}'")

    if optimize is not None and optimize.flywheel_delta > 0 and mech.steady is None and mech.dynamics.motor is None:
        raise _fail(
            src,
            "[optimize] flywheel_delta",
            f"sizing a flywheel needs a drive characteristic: {mech.name} has neither [steady] nor "
            "[dynamics.motor] (give one in the mechanism file, or set steady.* in [set])",
        )
    if optimize is not None and optimize.start == "file":
        for v in (v for v in varied if v not in conditions):  # a condition is always the file's value
            x = v.param.nominal
            if not (math.isfinite(x) and v.low <= x <= v.high):
                there = (
                    f"is {x:g} there, outside its range [{v.low:g}, {v.high:g}] (widen the range"
                    if math.isfinite(x)
                    else "has no value there (give it one"
                )
                raise _fail(
                    src,
                    "[optimize] start",
                    f"'file' starts each run from the mechanism file's design, but {v.param.path} {there}, "
                    "or start = 'sample')",
                )
    values.check_varied(src, text, base, fixed, varied, method, samples, seed, robust)

    code = _functions.fingerprint(own)
    digest = hashlib.sha256(text.encode() + b"\0" + mtext + code).hexdigest()[:16]
    return Study(
        name=name,
        title=title,
        path=Path(path) if path != "<string>" else None,
        mechanism=mech,
        method=method,
        varied=tuple(v for v in varied if v not in conditions),
        conditions=conditions,
        samples=samples,
        seed=seed,
        sequence=sequence,
        metrics=mets,
        bounds=tuple(bounds),
        per_turn=per_turn,
        verify=mode,
        count=count,
        by=by,
        digest=digest,
        optimize=optimize,
        robust=robust,
        fixed=fixed,
        file_mechanism=base,
        definition_digest=hashlib.sha256(text.encode() + code).hexdigest()[:16],
        mechanism_digest=hashlib.sha256(mtext).hexdigest()[:16],
    )


def _column(src: object, name: Any, names: list[str], where: str) -> str:
    if isinstance(name, str) and name in names:
        return name
    now = old_speed_name(name) if isinstance(name, str) else None
    if now is not None and now in names:  # the earlier form, in rad/s: still read, said once
        note(f"{src}: {where}: '{name}' is now named '{now}' (the speed in rpm); the old name still works")
        return now
    hint = did_you_mean(str(name), names)
    raise _fail(src, where, f"'{name}' is no metric column of this study ({hint}columns: {', '.join(names)})")


def _varied(src: object, mech: Mechanism, rp: dict, where: str, method: str, robust: bool = False) -> Varied:
    opts = {
        "grid": ["values", "range", "count", "step"],
        "random": ["range"],
        "tolerance": ["tolerance", "distribution"],
        "optimize": ["range", "tolerance", "distribution", "levels"] if robust else ["range"],
    }[method]
    if method == "optimize" and not robust and "tolerance" in rp:
        raise _fail(src, f"{where} tolerance", "applies to a robust optimization: add a [robust] table")
    _keys(src, rp, where, ["path"], opts)
    path = rp["path"]
    if not isinstance(path, str):
        raise _fail(src, f"{where} path", "must be a parameter path such as 'construct.P3.length_a'")
    try:
        p = paths.resolve(mech, path)
    except MjlinkError as e:
        raise _fail(src, f"{where} path", str(e).split(": ", 1)[-1]) from None
    where = f"{where} ({path})"
    if method == "grid":
        if ("values" in rp) == ("range" in rp):
            raise _fail(src, where, "give either 'values' (a list) or 'range' = [low, high] with 'count' or 'step'")
        if "values" in rp:
            vals = rp["values"]
            if not isinstance(vals, list) or not vals:
                raise _fail(src, f"{where} values", "must be a non-empty list of numbers")
            out = tuple(_number(src, {"v": x}, "v", f"{where} values", unit=p.unit) for x in vals)
        else:
            lo, hi = _range(src, rp, where, p.unit)
            if ("count" in rp) == ("step" in rp):
                raise _fail(src, where, "a 'range' needs either 'count' (values, ends included) or 'step'")
            if "count" in rp:
                n = _integer(src, rp, "count", where, 1, MAX_VARIANTS)
            else:
                step = _number(src, rp, "step", where, unit=p.unit)
                if step <= 0:
                    raise _fail(src, f"{where} step", f"must be positive, got {step:g}")
                with np.errstate(all="ignore"):
                    count = (hi - lo) / step * (1 + 1e-12)  # may overflow to inf: compared first
                if not count < MAX_VARIANTS:
                    raise _limit(
                        src, f"{where} step", f"{step:g} over [{lo:g}, {hi:g}] gives more than {MAX_VARIANTS} values"
                    )
                n = math.floor(count) + 1
                hi = lo + (n - 1) * step
            out = tuple(np.linspace(lo, hi, n).tolist()) if n > 1 else (lo,)
        return Varied(param=p, values=out)
    if method == "optimize" and robust and "range" not in rp and "tolerance" in rp:
        tol, dist = _tolerance(src, rp, where, p.unit)
        if not math.isfinite(p.nominal):
            raise _fail(src, where, "has no value in the mechanism file to hold as an operating condition (give one)")
        levels = 0
        if "levels" in rp:
            levels = _integer(src, rp, "levels", where, 2, 1000)
            if rp.get("distribution", "even") != "even":
                raise _fail(src, f"{where} levels", f"spaces the values evenly: drop distribution = '{dist}'")
            dist = "even"
        # An operating condition: low and high NaN.
        return Varied(param=p, tolerance=tol, distribution=dist, levels=levels)
    if method in ("random", "optimize"):
        if "levels" in rp:
            raise _fail(src, f"{where} levels", "applies to an operating condition (a 'tolerance' and no 'range')")
        if "range" not in rp:
            if method == "optimize":
                raise _fail(
                    src,
                    where,
                    "needs 'range' = [low, high] (the bounds of the search), or, in a robust optimization, "
                    "only a 'tolerance' (an operating condition held at the file's value)",
                )
            raise _fail(src, where, "needs 'range' = [low, high] (the bounds the samples fill)")
        lo, hi = _range(src, rp, where, p.unit)
        if method == "random" or "tolerance" not in rp:
            return Varied(param=p, low=lo, high=hi, tolerance=0.0 if method == "optimize" else math.nan)
        tol, dist = _tolerance(src, rp, where, p.unit)
        return Varied(param=p, low=lo, high=hi, tolerance=tol, distribution=dist)
    if "tolerance" not in rp:
        raise _fail(src, where, "needs 'tolerance' (the +- band, in the parameter's unit)")
    tol, dist = _tolerance(src, rp, where, p.unit)
    if not math.isfinite(p.nominal):
        raise _fail(src, where, "has no nominal value in the mechanism file to put a tolerance on")
    return Varied(param=p, tolerance=tol, distribution=dist)


def _crossed(src: object, conditions: tuple[Varied, ...], samples: int) -> None:
    """Conditions given ``levels`` are crossed, every combination a robust sample: all of them
    then need levels, and the samples must repeat the combinations whole."""
    with_levels = [v for v in conditions if v.levels]
    if not with_levels:
        return
    if len(with_levels) < len(conditions):
        bare = next(v for v in conditions if not v.levels)
        raise _fail(
            src,
            f"[[parameter]] ({bare.param.path})",
            "needs 'levels' as well: operating conditions with levels are crossed, every combination a sample",
        )
    combos = math.prod(v.levels for v in conditions)
    if samples % combos:
        shape = " x ".join(str(v.levels) for v in conditions)
        raise _fail(
            src,
            "[robust] samples",
            f"must be a multiple of the conditions' {shape} = {combos} combinations of levels, got {samples}",
        )


def _tolerance(src: object, rp: dict, where: str, unit: str = "") -> tuple[float, str]:
    tol = _number(src, rp, "tolerance", where, unit=unit)
    if tol < 0:
        raise _fail(src, f"{where} tolerance", f"must be >= 0, got {tol:g}")
    dist = rp.get("distribution", "uniform")
    if dist not in DISTRIBUTIONS:
        raise _fail(src, f"{where} distribution", f"must be one of {', '.join(DISTRIBUTIONS)}, got {shown(dist)}")
    return tol, dist


def _fixed(src: object, mech: Mechanism, raw: Any) -> tuple[tuple[str, float], ...]:
    """The ``[set]`` table: parameter path -> value (file units), applied before anything varies."""
    if not isinstance(raw, dict):
        raise _fail(src, "[set]", "must be a table of parameter path = value")
    out = []
    for k in raw:
        try:
            unit = paths.resolve(mech, k).unit
        except MjlinkError as e:
            raise _fail(src, "[set]", str(e).split(": ", 1)[-1]) from None
        out.append((k, _number(src, raw, k, "[set]", unit=unit)))
    return tuple(out)


def _optimize(src: object, raw: Any, names: list[str], n_params: int) -> Optimize:
    where = "[optimize]"
    if not isinstance(raw, dict):
        raise _fail(src, where, "must be a table")
    _keys(
        src,
        raw,
        where,
        [],
        [
            "objective",
            "sense",
            "pareto",
            "points",
            "population",
            "generations",
            "seed",
            "tol",
            "atol",
            "init",
            "flywheel_delta",
            "seeds",
            "stall",
            "ftol",
            "polish_evaluations",
            "xtol",
            "resolution",
            "start",
        ],
    )
    if ("objective" in raw) == ("pareto" in raw):
        raise _fail(
            src,
            where,
            "give either 'objective' (a metric column, or a table column = weight) or 'pareto' = [two columns]",
        )
    objective: tuple[tuple[str, float], ...] = ()
    pareto = None
    if "objective" in raw:
        obj = raw["objective"]
        if isinstance(obj, str):
            objective = ((_column(src, obj, names, f"{where} objective"), 1.0),)
        elif isinstance(obj, dict) and obj:
            objective = tuple(
                (_column(src, c, names, f"{where} objective"), _number(src, obj, c, f"{where} objective")) for c in obj
            )
        else:
            raise _fail(src, f"{where} objective", "must be a metric column or a table of column = weight")
    else:
        par = raw["pareto"]
        if not isinstance(par, list) or len(par) != 2:
            raise _fail(src, f"{where} pareto", "must be a list of two metric columns (both minimized)")
        c1, c2 = (_column(src, c, names, f"{where} pareto") for c in par)
        if c1 == c2:
            raise _fail(src, f"{where} pareto", f"names '{c1}' twice")
        pareto = (c1, c2)
    sense = raw.get("sense", "min")
    if sense not in SENSES or (pareto and "sense" in raw):
        raise _fail(src, f"{where} sense", f"must be 'min' or 'max' (with 'objective'), got {shown(sense)}")
    init = raw.get("init", "sobol")
    if init not in INITS:
        raise _fail(src, f"{where} init", f"must be one of {', '.join(INITS)}, got {shown(init)}")
    start = raw.get("start", "sample")
    if start not in STARTS:
        raise _fail(src, f"{where} start", f"must be one of {', '.join(STARTS)}, got {shown(start)}")
    tol = _number(src, raw, "tol", where, default=1e-3)
    atol = _number(src, raw, "atol", where, default=0.0)
    delta = _number(src, raw, "flywheel_delta", where, default=0.0)
    if tol < 0 or atol < 0 or not 0 <= delta < 1:
        raise _fail(src, where, "tol and atol must be >= 0 and flywheel_delta within [0, 1)")
    ftol = _number(src, raw, "ftol", where, default=1e-9)
    xtol = _number(src, raw, "xtol", where, default=1e-9)
    if not (0 <= ftol < 1 and 0 < xtol < 0.1):
        raise _fail(src, where, f"ftol must be within [0, 1) and xtol within (0, 0.1), got {ftol:g} and {xtol:g}")
    resolution = dict(RESOLUTION)
    if "resolution" in raw:
        res = raw["resolution"]
        if not isinstance(res, dict):
            raise _fail(src, f"{where} resolution", "must be a table of unit = step, e.g. { mm = 0.01, deg = 0.01 }")
        for unit in res:
            step = _number(src, res, unit, f"{where} resolution")
            if not 0 < step <= 10:
                raise _fail(src, f"{where} resolution {unit}", f"must be a step from 0 (excluded) to 10, got {step:g}")
            resolution[unit] = step
    seeds_default = 1 if pareto else 3
    return Optimize(
        objective=objective,
        sense=sense,
        pareto=pareto,
        points=_integer(src, raw, "points", where, 3, 64, default=7),
        population=_integer(src, raw, "population", where, 5, 100_000, default=max(16, 10 * n_params)),
        generations=_integer(src, raw, "generations", where, 1, 100_000, default=200),
        seed=_integer(src, raw, "seed", where, 0, 2**62, default=0),
        tol=tol,
        atol=atol,
        init=init,
        flywheel_delta=delta,
        seeds=_integer(src, raw, "seeds", where, 1, 32, default=seeds_default),
        stall=_integer(src, raw, "stall", where, 2, 100_000, default=30),
        ftol=ftol,
        polish_evaluations=_integer(
            src, raw, "polish_evaluations", where, 0, 10_000_000, default=2000 * max(1, n_params)
        ),
        xtol=xtol,
        resolution=tuple(sorted(resolution.items())),
        start=start,
    )


def _robust(src: object, raw: Any, seed: int) -> Robust:
    where = "[robust]"
    if not isinstance(raw, dict):
        raise _fail(src, where, "must be a table")
    _keys(src, raw, where, ["samples"], ["k", "seed"])
    k = _number(src, raw, "k", where, default=2.0)
    if k < 0:
        raise _fail(src, f"{where} k", f"must be >= 0, got {k:g}")
    return Robust(
        _integer(src, raw, "samples", where, 2, 100_000),
        k,
        _integer(src, raw, "seed", where, 0, 2**63 - 1, default=seed),
    )


def _range(src: object, rp: dict, where: str, unit: str = "") -> tuple[float, float]:
    r = rp["range"]
    if not isinstance(r, list) or len(r) != 2:
        raise _fail(src, f"{where} range", "must be [low, high]")
    lo = _number(src, {"v": r[0]}, "v", f"{where} range", unit=unit)
    hi = _number(src, {"v": r[1]}, "v", f"{where} range", unit=unit)
    if not lo < hi:
        raise _fail(src, f"{where} range", f"low must be below high, got [{lo:g}, {hi:g}]")
    return lo, hi
