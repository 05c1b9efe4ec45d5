"""The design an optimization writes: rounded to a manufacturing resolution, then held to
everything a user's file is held to, or replaced by the next-best candidate that is.

An optimum comes out of the search with every digit a float has; a drawing carries two
decimals. The winner's numbers are rounded to the study's resolution (``[optimize] resolution``,
default 0.01 mm and 0.01 deg; numbers of other units to
:data:`~mjlink.study.spec.RESOLUTION_DIGITS` significant digits), the nearest value first, and
if that design is infeasible or outside a bound, the best feasible of the designs that round one
parameter the other way. The file is then written and read back, and the design *as written*
must pass, like a user's file:

1. the mechanism file's reader and ``check`` (:func:`mjlink.validation.check`: assembly over the
   whole cycle at ``check``'s 3600 angles per turn, the dead-point limits, coincident points,
   the inertia and compile checks), which a study's sampled angles can miss between samples;
2. the study's own feasibility and bounds, evaluated by the reference on the file as read
   (its derived numbers rounded too: a re-synthesized crank and rod);
3. MuJoCo's verification at ``simulate``'s thresholds.

A candidate that fails is set aside with the reason, and the best that passes among the
distinct feasible candidates the search evaluated, in order of their objective, is found
(:func:`choose`). The result says which were set aside and why.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .. import validation
from ..errors import MjlinkError
from ..model import mechanism as _mechanism
from ..model import paths
from ..model.limits import SAMPLES_PER_TURN
from ..model.mechanism import Mechanism
from ..study import optimize as _opt
from ..study.spec import RESOLUTION_DIGITS, Optimize, Study
from ..study.tasks import Evaluated, Verified, mujoco_chunk, reference_chunk

TRIES = 16  # candidates held to the checks before the study gives up with the reasons


@dataclass(frozen=True, kw_only=True)
class Written:
    """A design as written: ``values`` (P,) the varied parameters rounded (file units), its
    file ``text`` (without the header), the mechanism read back from it (``mech``), every
    metric of the study on it (``columns``, nominal dimensions), its ``objective`` as written
    (robust: mean + k std; NaN for a Pareto study), MuJoCo's ``verified`` row, and the
    unrounded design it came from (``optimum``)."""

    values: np.ndarray
    optimum: np.ndarray
    text: str
    mech: Mechanism
    columns: dict[str, float]
    objective: float
    verified: Verified


@dataclass(frozen=True)
class Rejected:
    """A candidate set aside: its values (file units, rounded) and why."""

    values: np.ndarray
    reason: str


def rounder(opt: Optimize) -> Callable[[str, float], float]:
    """A function rounding a number in a unit to ``opt``'s resolution."""

    def to(unit: str, v: float) -> float:
        step = opt.step_of(unit)
        if step is None:
            return float(f"{v:.{RESOLUTION_DIGITS}g}")
        return float(f"{round(v / step) * step:.12g}")

    return to


def _other_way(opt: Optimize, unit: str, v: float, r: float) -> float:
    """The value one resolution step from ``r`` on ``v``'s other side."""
    step = opt.step_of(unit)
    if step is None:
        digits = RESOLUTION_DIGITS - 1 - math.floor(math.log10(abs(r))) if r else RESOLUTION_DIGITS
        step = 10.0 ** (-digits)
    return float(f"{(r - step if r > v else r + step):.12g}")


def rounded_candidates(study: Study, x: np.ndarray) -> np.ndarray:
    """(1 + P, P): ``x`` rounded to the resolution, nearest first, then each parameter rounded the
    other way; every value kept within its range."""
    opt = study.optimize
    assert opt is not None
    to = rounder(opt)
    out = []
    near = np.array([to(v.param.unit, float(xi)) for v, xi in zip(study.varied, x, strict=True)])
    out.append(near)
    for j, v in enumerate(study.varied):
        y = near.copy()
        y[j] = _other_way(opt, v.param.unit, float(x[j]), float(near[j]))
        out.append(y)
    lo = np.array([v.low for v in study.varied])
    hi = np.array([v.high for v in study.varied])
    X = np.array(out)
    # Never outside the range: the inner of the two roundings there.
    for j in range(len(study.varied)):
        for i in range(len(X)):
            if not lo[j] <= X[i, j] <= hi[j]:
                X[i, j] = near[j] if lo[j] <= near[j] <= hi[j] else min(max(X[i, j], lo[j]), hi[j])
    return X


def _nearest(study: Study, x: np.ndarray) -> np.ndarray:
    """The first row of :func:`rounded_candidates` alone (what tells two candidates apart)."""
    opt = study.optimize
    assert opt is not None
    to = rounder(opt)
    near = np.array([to(v.param.unit, float(xi)) for v, xi in zip(study.varied, x, strict=True)])
    out: np.ndarray = np.clip(near, [v.low for v in study.varied], [v.high for v in study.varied])
    return out


def _file_mechanism(st: Study) -> Mechanism:
    """The mechanism as the study read its file (before ``[set]``), never the file read again."""
    return st.file_mechanism if st.file_mechanism is not None else st.mechanism


def design_text(st: Study, x: np.ndarray, name: str, extra: dict[str, float] | None = None) -> str:
    """The mechanism file of design ``x`` (file units), without a header: the study's [set]
    values, ``x`` and ``extra`` (path -> value) written into the base file, every number the
    change moves rounded to the resolution."""
    opt = st.optimize
    assert opt is not None
    base = _file_mechanism(st)
    values: dict[paths.Param, float] = {paths.resolve(base, p): v for p, v in st.fixed}
    for p, v in zip(st.params, x, strict=True):
        values[paths.resolve(base, p.path)] = float(v)
    for p, v in (extra or {}).items():
        values[paths.resolve(base, p)] = v
    to = rounder(opt)
    return paths.file_text(base, values, "", name=name, rounding=lambda p, v: to(p.unit, v))


def as_written(st: Study, text: str, where: str) -> Mechanism:
    """The mechanism ``text`` describes, read and checked as ``check`` does; MjlinkError (one
    line, its first problem) otherwise."""
    mech = _mechanism.parse(text, where)
    validation.check(mech).raise_if_failed()
    return mech


def evaluate_written(st: Study, mech: Mechanism) -> Evaluated:
    """Every metric of the study on ``mech`` exactly as read (no parameter applied)."""
    return reference_chunk(dataclasses.replace(st, mechanism=mech, varied=()), np.zeros((1, 0)))


def _attempt(
    st: Study, here: _opt.Evaluator, name: str, x: np.ndarray, where: Path
) -> tuple[Written | None, Rejected | None, np.ndarray]:
    """Candidate ``x`` rounded and held to everything (module docstring): (written, None) or
    (None, why not); and the rounded values tried."""
    R = rounded_candidates(st, x)
    s = here.score(R, full=True)
    ok = np.flatnonzero(s.violation <= 0)
    if not len(ok):
        return None, Rejected(R[0], f"rounded to the resolution it is infeasible: {s.reason[0] or 'a bound'}"), R[0]
    j = int(ok[0]) if ok[0] == 0 else int(ok[np.argmin(s.objective[ok])])
    xr = R[j]
    text = design_text(st, xr, name)
    try:
        mech = as_written(st, text, str(where))
    except MjlinkError as e:
        hint = (
            f" (the study judges {st.per_turn} crank angles per turn, check {SAMPLES_PER_TURN}: raise [study] angles "
            "to see this in the search)"
        )
        return None, Rejected(xr, f"check refuses it: {_one_line(e)}{hint}"), xr
    ev = evaluate_written(st, mech)
    bad = [b.text() for b in st.bounds if not b.holds(ev.columns[b.column])[0]]
    if not ev.feasible[0] or bad:
        why = ev.reason[0] if not ev.feasible[0] else f"outside {bad[0]}"
        return None, Rejected(xr, f"as written (its derived numbers rounded) {why}"), xr
    ver = mujoco_chunk(dataclasses.replace(st, mechanism=mech, varied=()), np.zeros((1, 0)))
    if not ver.passed[0]:
        return None, Rejected(xr, f"MuJoCo does not agree with the reference: {ver.reason[0]}"), xr
    opt = st.optimize
    assert opt is not None
    objective = math.nan
    if opt.pareto is None:
        objective = float(s.objective[j]) * (-1.0 if opt.sense == "max" else 1.0)
    cols = {c: float(v[0]) for c, v in ev.columns.items()}
    return (
        Written(
            values=xr,
            optimum=np.asarray(x, dtype=float),
            text=text,
            mech=mech,
            columns=cols,
            objective=objective,
            verified=ver,
        ),
        None,
        xr,
    )


def choose(
    st: Study,
    res: _opt.Result,
    here: _opt.Evaluator,
    name: str,
    candidates: list[np.ndarray],
    where: Path,
) -> tuple[Written | None, list[Rejected]]:
    """The best of ``candidates`` (file units, best first) that, rounded, passes everything
    (module docstring), with the better candidates set aside and why.

    Candidates that round to a design already tried are skipped. The first candidate is tried,
    then, while they fail, the 2nd, 3rd, 5th, 9th, ... (a refusal usually holds for a stretch of
    the best candidates: a limit the search's sampling does not see); once one passes, the
    stretch between it and the last refused is halved until the best that passes is found.
    At most :data:`TRIES` candidates are held to the checks."""
    distinct: list[np.ndarray] = []
    seen: set[bytes] = set()
    for x in candidates:
        key = _nearest(st, x).tobytes()
        if key not in seen:
            seen.add(key)
            distinct.append(np.asarray(x, dtype=float))
    rejected: list[Rejected] = []
    tried: dict[int, Written | None] = {}

    def attempt(i: int) -> Written | None:
        if i not in tried:
            w, why, _ = _attempt(st, here, name, distinct[i], where)
            tried[i] = w
            if why is not None:
                rejected.append(why)
        return tried[i]

    if not distinct or attempt(0) is not None:
        return tried.get(0), rejected
    bad, step = 0, 1
    good = None
    while len(tried) < TRIES and bad + step < len(distinct):
        i = bad + step
        if attempt(i) is not None:
            good = i
            break
        bad, step = i, step * 2
    if good is None:
        return None, rejected
    while good - bad > 1 and len(tried) < TRIES:
        mid = (bad + good) // 2
        if attempt(mid) is not None:
            good = mid
        else:
            bad = mid
    return tried[good], rejected


def next_best(res: _opt.Result, first: np.ndarray) -> list[np.ndarray]:
    """``first``, then the distinct feasible candidates of the archive by objective."""
    a = res.archive
    feasible = np.flatnonzero(a.violation <= 0)
    order = feasible[np.argsort(a.objective[feasible], kind="stable")]
    out = [np.asarray(first, dtype=float)]
    seen = {np.asarray(first, dtype=float).tobytes()}
    for i in order:
        key = a.values[i].tobytes()
        if key not in seen:
            seen.add(key)
            out.append(a.values[i])
    return out


def _one_line(e: BaseException) -> str:
    return " ".join(str(e).split())
