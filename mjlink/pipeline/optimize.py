"""The ``study`` job for an ``[optimize]`` study: search, write the winner as a checked file.

``<out>/NAME-study/``:

* ``winner.toml``: the winner as a mechanism file, its numbers rounded to the study's
  manufacturing resolution, and only after the design *as written* passed ``check``, the
  study's feasibility and bounds and MuJoCo's verification (:mod:`.winner`; a candidate that
  fails is set aside with the reason and the next-best is written); its leading comment says
  which study produced it, with what objective, whether the search converged, the caveats and
  the verdict; for a Pareto study also ``pareto-NN.toml``, one per front design (01 = lowest
  first column) that passes the same;
* ``results.csv`` / ``results.parquet``: every candidate evaluated (run, generation, the
  parameters, the metrics the search needs (the others are empty but for the designs
  reported), the objective, the constraint violation and its reason);
* ``front.csv`` (Pareto): the front's designs, their metrics and MuJoCo's verdict;
* ``summary.json``: the study, the optimizer's settings, ``converged`` with its ``criterion``
  and what kept it from converging, the ``caveats``, the winner as written (parameters,
  objective, metrics at nominal dimensions and, robust, mean + k std; MuJoCo's figures) and
  the unrounded optimum it came from, the candidates set aside, the flywheel, the runs,
  evaluations, timings and versions;
* ``index.html``: the summary as a page (converged or not, the caveats, the winner, the figures);
* ``convergence.png``, ``before_after.png`` and (Pareto) ``pareto.png``.
"""

from __future__ import annotations

import dataclasses
import datetime
import html
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .. import compare
from ..analysis import metrics as _metrics
from ..files import write_json, write_parquet, write_records, write_text
from ..model.mechanism import Mechanism
from ..reference import batch
from ..reference.dynamics import flywheel_for, steady_motion, steady_variant
from ..runtime import cluster, staging
from ..runtime.progress import optimize_progress
from ..study import engine
from ..study import optimize as _opt
from ..study.spec import Study
from ..study.tasks import Verified
from ..version import __version__
from . import winner as _winner
from .columns import column_name, versions


@dataclass(frozen=True)
class Flywheel:
    """The flywheel the winner needs: ``inertia`` kg*m^2 added on ``link`` (the input crank's)
    for the steady-motion delta ``target``; ``delta_before`` without it; ``omega_mean`` rad/s."""

    link: str
    inertia: float
    target: float
    delta_before: float
    delta_after: float
    omega_mean: float


@dataclass(frozen=True, kw_only=True)
class OptimizeResult:
    """A finished optimization: the optimizer's :class:`~mjlink.study.optimize.Result` (its
    ``winner`` and ``front`` the designs as written), the MuJoCo check of the winner
    (``verified``; row 0) and of the front (rows 1..F), the flywheel, the folder and files
    written, and the summary (as in ``summary.json``); ``optimum`` the unrounded winner the
    search found, ``rejected`` the candidates set aside before the winner (values, reason)."""

    result: _opt.Result
    verified: Verified
    flywheel: Flywheel | None
    out_dir: Path
    winner_file: Path
    files: list[Path] = field(default_factory=list)
    summary: dict[str, Any] = field(default_factory=dict)
    optimum: np.ndarray | None = None
    rejected: tuple[_winner.Rejected, ...] = ()

    @property
    def failures(self) -> list[str]:
        """Designs MuJoCo verified that missed a threshold, one line each."""
        names = ["winner"] + [f"pareto-{i + 1:02d}" for i in range(len(self.verified.passed) - 1)]
        return [f"{n}: {r}" for n, p, r in zip(names, self.verified.passed, self.verified.reason, strict=True) if not p]


def run(
    st: Study,
    out_root: Path | str = Path("renders"),
    *,
    scheduler: str | None = None,
    workers: int | None = None,
    client: Any = None,
    plots: bool = True,
    force: bool = False,
    progress: bool = True,
    command: str | None = None,
) -> OptimizeResult:
    """Run an ``[optimize]`` study and write its outputs into ``out_root/NAME-study/``
    (arguments as :func:`mjlink.pipeline.study.run`, which checks them before any work)."""
    opt = st.optimize
    assert opt is not None
    dest = Path(out_root) / f"{st.name}-study"
    sign = -1.0 if opt.sense == "max" and not opt.pareto else 1.0
    update, close = optimize_progress(f"study {st.name}", sign) if progress else (None, lambda: None)
    try:
        if client is not None:
            with staging.staged_dir(dest, kind="study", mechanism=st.name, force=force, command=command) as stage:
                return _run(st, dest, stage, client, "the given Dask client", update, plots, command)
        with cluster.client_for(scheduler, workers) as (c, what):
            with staging.staged_dir(dest, kind="study", mechanism=st.name, force=force, command=command) as stage:
                return _run(st, dest, stage, c, what, update, plots, command)
    finally:
        close()


def _run(
    st: Study,
    dest: Path,
    stage: Path,
    client: Any,
    what: str,
    update: Any,
    plots: bool,
    command: str | None,
) -> OptimizeResult:
    opt = st.optimize
    assert opt is not None
    workers = engine.workers_of(client)
    res = _opt.run(st, client=client, workers=workers, engine=what, progress=update)
    with _opt.Evaluator(st) as here:
        won, rejected = _winner.choose(st, res, here, _name(st, 0), _candidates(st, res), dest / "winner.toml")
        if won is None:
            reasons = "; ".join(f"{_values_text(st, r.values)}: {r.reason}" for r in rejected[:3])
            raise _opt.OptimizeError(
                f"{st.name}: no candidate passes as written (rounded to the resolution, check, MuJoCo): {reasons}"
            )
        front: list[_winner.Written] = []
        if res.front is not None:
            for i, x in enumerate(res.front):
                w, _ = _winner.choose(st, res, here, _name(st, i + 1), [x], dest / f"pareto-{i + 1:02d}.toml")
                if w is not None:
                    front.append(w)
    fly = _flywheel(st, won) if opt.flywheel_delta > 0 else None
    written = _as_result(res, won, front)
    ver = _verified([won, *front])
    summ = summary(written, ver, fly, command, won, rejected, res)
    files: list[Path] = []
    files.append(write_text(stage / "winner.toml", _file(st, written, won, 0, ver, fly, summ), in_stage=True))
    for i, w in enumerate(front):
        files.append(
            write_text(stage / f"pareto-{i + 1:02d}.toml", _file(st, written, w, i + 1, ver, None, summ), in_stage=True)
        )
    if front:
        files.append(write_records(stage / "front.csv", front_table(written, ver)))
    cols = archive_table(res)
    files.append(write_records(stage / "results.csv", cols))
    files.append(write_parquet(stage / "results.parquet", cols))
    files.append(write_json(stage / "summary.json", summ))
    if plots:
        files += _plots(written, ver, stage)
    names = [f.name for f in files] + ["index.html"]
    files.append(write_text(stage / "index.html", page(summ, names), in_stage=True))
    return OptimizeResult(
        result=written,
        verified=ver,
        flywheel=fly,
        out_dir=dest,
        winner_file=dest / "winner.toml",
        files=[dest / f.name for f in files],
        summary=summ,
        optimum=res.winner,
        rejected=tuple(rejected),
    )


def _name(st: Study, row: int) -> str:
    """The written file's mechanism name (at most 32 characters: the study's name is cut)."""
    tail = "_winner" if row == 0 else f"_pareto_{row:02d}"
    return st.name[: 32 - len(tail)].rstrip("_") + tail


def _candidates(st: Study, res: _opt.Result) -> list[np.ndarray]:
    """The winner, then what stands in for it if it is refused: the next-best feasible
    candidates (one objective), or the front's designs nearest the knee (Pareto)."""
    if res.front is None:
        return _winner.next_best(res, res.winner)
    order = np.argsort([np.linalg.norm(x - res.winner) for x in res.front], kind="stable")
    return [res.winner] + [res.front[i] for i in order if not np.array_equal(res.front[i], res.winner)]


def _as_result(res: _opt.Result, won: _winner.Written, front: list[_winner.Written]) -> _opt.Result:
    """The optimizer's result with the designs as written in place of the unrounded ones."""
    opt = res.study.optimize
    assert opt is not None
    fr = fc = None
    if res.front is not None:
        fr = np.array([w.values for w in front]) if front else np.zeros((0, len(res.winner)))
        fc = {c: np.array([w.columns[c] for w in front]) for c in won.columns}
    return dataclasses.replace(
        res,
        winner=won.values,
        objective=won.objective if opt.pareto is None else math.nan,
        columns=_robust_columns(res, won),
        nominal_columns=dict(won.columns),
        front=fr,
        front_columns=fc,
    )


def conditions(st: Study) -> list[dict[str, Any]]:
    """The study's operating conditions as ``summary.json`` records them, with the value each
    robust sample holds (in the samples' order: the deviations' rows)."""
    held = _opt.deviations(st)[:, len(st.varied) :]
    return [
        {
            "path": v.param.path,
            "unit": v.param.unit,
            "nominal": v.param.nominal,
            "tolerance": v.tolerance,
            "distribution": v.distribution,
            "levels": v.levels or None,
            "samples": (v.param.nominal + held[:, j]).tolist(),
        }
        for j, v in enumerate(st.conditions)
    ]


def conditions_text(rows: list[dict[str, Any]]) -> str:
    """Operating conditions (:func:`conditions`) as a sentence's list: 'path = nominal +- tolerance unit'."""
    return ", ".join(
        f"{c['path']} = {c['nominal']:g} +- {c['tolerance']:g} {c['unit']}".rstrip()
        + (
            f" ({c['levels']} levels, ends included, crossed)"
            if c.get("levels")
            else {"normal": " (normal, 3 sigma)", "even": " (evenly spaced, ends included)"}.get(c["distribution"], "")
        )
        for c in rows
    )


def _robust_columns(res: _opt.Result, won: _winner.Written) -> dict[str, float]:
    """The written winner's columns as the optimizer scores them (robust: over the samples)."""
    with _opt.Evaluator(res.study) as here:
        s = here.score(won.values[None], full=True)
    return {c: float(v[0]) for c, v in s.columns.items()}


def _verified(designs: list[_winner.Written]) -> Verified:
    rows = [d.verified for d in designs]
    return Verified(
        np.concatenate([r.passed for r in rows]),
        np.concatenate([r.position_error for r in rows]),
        np.concatenate([r.loop_gap for r in rows]),
        np.concatenate([r.thread_error for r in rows]),
        tuple(x for r in rows for x in r.reason),
    )


def _crank_link(mech: Mechanism) -> str:
    c = mech.input_crank
    return next(l.name for l in mech.links if c.pivot in l.points and c.point in l.points)


def _flywheel(st: Study, won: _winner.Written) -> Flywheel:
    opt = st.optimize
    assert opt is not None
    mech = won.mech
    if mech.steady is not None:  # its [steady] motor, as the speed_fluctuation metric uses
        mech = steady_variant(mech)
    before = steady_motion(mech)
    J, after = flywheel_for(mech, opt.flywheel_delta)
    return Flywheel(_crank_link(mech), float(J), opt.flywheel_delta, before.delta, after.delta, after.omega_mean)


def _values_text(st: Study, x: np.ndarray) -> str:
    return ", ".join(f"{p.path} = {v:g}" for p, v in zip(st.params, x, strict=True))


def _file(
    st: Study,
    res: _opt.Result,
    w: _winner.Written,
    row: int,
    ver: Verified,
    fly: Flywheel | None,
    summ: dict[str, Any],
) -> str:
    """The mechanism file of a written design with its header (and the flywheel, for the winner)."""
    text = w.text
    if fly is not None and fly.inertia > 0:
        inertia = f"links.{fly.link}.inertia"
        base = float(w.mech.link(fly.link).inertia)
        text = _winner.design_text(st, w.values, _name(st, row), {inertia: base + fly.inertia})
        _winner.as_written(st, text, "winner.toml")  # the flywheel changes no check; held to it all the same
    return _header(st, res, w, row, ver, fly, summ) + "\n" + text


def _header(
    st: Study,
    res: _opt.Result,
    w: _winner.Written,
    row: int,
    ver: Verified,
    fly: Flywheel | None,
    summ: dict[str, Any],
) -> str:
    opt = st.optimize
    assert opt is not None
    what = "winner" if row == 0 else f"Pareto design {row} of {len(res.front) if res.front is not None else 0}"
    verdict = (
        f"MuJoCo agrees (position {ver.position_error[row]:.3g} µm, loop gap {ver.loop_gap[row]:.3g} µm)"
        if ver.passed[row]
        else f"MuJoCo check FAILED: {ver.reason[row]}"
    )
    conv = summ["convergence"]
    lines = [
        f"{what} of the optimization study '{st.name}' ({st.path or 'Python API'}, digest {st.digest}),",
        f"written by mjlink {__version__} on {datetime.date.today().isoformat()} from {st.mechanism.path}.",
        f"Objective: {opt.label}"
        + (f" (robust: mean + {st.robust.k:g} std over {st.robust.samples} tolerance samples)" if st.robust else "")
        + ".",
        "Search: " + ("converged" if conv["converged"] else "NOT CONVERGED: " + "; ".join(conv["not_converged"])) + ".",
        "Metrics as written: "
        + ", ".join(f"{c.name} = {w.columns[c.name]:.6g} {c.unit}".rstrip() for c in st.columns)
        + ".",
    ]
    if st.fixed:
        lines.append("Set by the study: " + ", ".join(f"{p} = {v:g}" for p, v in st.fixed) + ".")
    if st.conditions:
        lines.append("Operating conditions over the samples: " + conditions_text(conditions(st)) + ".")
    res_text = ", ".join(f"{u} {s:g}" for u, s in opt.resolution)
    lines.append(
        "Optimized (rounded to "
        + res_text
        + "): "
        + ", ".join(f"{p.path} = {v:.10g} {p.unit}".rstrip() for p, v in zip(st.params, w.values, strict=True))
        + "."
    )
    for c in summ["caveats_text"] if row == 0 else ():
        lines.append(f"Caveat: {c}.")
    for c in summ["findings_text"] if row == 0 else ():
        lines.append(f"Found: {c}.")
    if fly is not None:
        lines.append(
            f"Flywheel for a speed fluctuation delta = (w_max - w_min) / w_mean of {fly.target:g} "
            f"({100 * fly.target:.3g} %): {fly.inertia:.4g} kg*m^2 added to links.{fly.link}.inertia "
            f"(delta {fly.delta_before:.4g}, {100 * fly.delta_before:.3g} %, without it, at {fly.omega_mean:.4g} rad/s mean)."
        )
    rpm = summ.get("objective_speed_rpm")
    if rpm is not None:
        lines.append(
            f"Optimized at {rpm:.4g} rpm; this file keeps its own speed, {st.mechanism.speed * 30.0 / math.pi:.4g} rpm: "
            f"simulate it with {speed_option(rpm)} to see its loads there."
        )
    lines.append(verdict + ".")
    lines.append("Units: lengths mm, angles deg, masses g, inertias kg*m^2, speeds rad/s. The base file's comments")
    lines.append("are not carried over: see it for the [choice]s behind each number.")
    return "\n".join(f"# {x}" for x in lines)


def archive_table(res: _opt.Result) -> dict[str, Any]:
    """The results table: every candidate evaluated, in order."""
    st, a = res.study, res.archive
    cols: dict[str, Any] = {"run": a.run, "generation": a.generation}
    cols |= _design_columns(st, a.values, a.columns)
    cols["minimized"] = a.objective
    cols["violation"] = a.violation
    cols["feasible"] = (a.violation <= 0).astype(np.int8)
    cols["reason"] = list(a.reason)
    return cols


def _design_columns(st: Study, values: np.ndarray, metrics: dict[str, np.ndarray]) -> dict[str, Any]:
    """Designs as table columns: each parameter and metric, its unit in its name."""
    cols: dict[str, Any] = {column_name(p.path, p.unit): values[:, j] for j, p in enumerate(st.params)}
    cols |= {column_name(c.name, c.unit): metrics[c.name] for c in st.columns}
    return cols


def front_table(res: _opt.Result, ver: Verified) -> dict[str, Any]:
    """The Pareto front's designs (as written) with MuJoCo's verdicts."""
    st = res.study
    assert res.front is not None and res.front_columns is not None
    cols: dict[str, Any] = {"design": [f"pareto-{i + 1:02d}" for i in range(len(res.front))]}
    cols |= _design_columns(st, res.front, res.front_columns)
    cols["winner"] = [int(np.array_equal(x, res.winner)) for x in res.front]
    cols["mujoco"] = ["pass" if p else "FAIL" for p in ver.passed[1:]]
    cols["mujoco_position_error_um"] = ver.position_error[1:]
    cols["mujoco_loop_gap_um"] = ver.loop_gap[1:]
    cols["mujoco_thread_error_um"] = ver.thread_error[1:]
    return cols


def speed_option(rpm: float) -> str:
    """The command line's option for a crank speed in rpm (a clockwise one with '=', which a
    leading minus sign needs)."""
    return f"--speed={rpm:.4g}rpm" if rpm < 0 else f"--speed {rpm:.4g}rpm"


def objective_speed_rpm(st: Study) -> float | None:
    """The crank speed (rpm, signed) the objective is taken at where it is not the file's own (a
    shaking force at 5,000 rpm of a file run at 955 rpm), else None: the winner's file keeps
    its own speed, and ``simulate`` shows its loads at the objective's with ``--speed``."""
    opt = st.optimize
    assert opt is not None
    names = {c for c, _ in opt.objective} | set(opt.pareto or ())
    for m in st.metrics:
        speed = getattr(m, "speed", None)
        if isinstance(speed, int | float) and speed != st.mechanism.speed and names & {c.name for c in m.columns()}:
            return speed * 30.0 / math.pi
    return None


def summary(
    res: _opt.Result,
    ver: Verified,
    fly: Flywheel | None,
    command: str | None = None,
    won: _winner.Written | None = None,
    rejected: list[_winner.Rejected] | tuple[_winner.Rejected, ...] = (),
    found: _opt.Result | None = None,
) -> dict[str, Any]:
    """What ``summary.json`` holds (see the module docstring). ``res`` holds the designs as
    written, ``found`` the optimizer's own (unrounded) result."""
    st = res.study
    opt = st.optimize
    assert opt is not None
    found = found or res
    th = compare.thresholds()

    def mj(i: int) -> dict[str, Any]:
        return {
            "passed": bool(ver.passed[i]),
            "position_error_um": float(ver.position_error[i]),
            "loop_gap_um": float(ver.loop_gap[i]),
            "thread_error_um": float(ver.thread_error[i]),
            "reason": ver.reason[i],
        }

    nominal = np.array([p.nominal for p in st.params])
    caveats = found.caveats
    return {
        "study": st.name,
        "title": st.title,
        "file": str(st.path) if st.path else None,
        "mechanism": st.mechanism.name,
        "mechanism_file": str(st.mechanism.path) if st.mechanism.path else None,
        "digest": st.digest,
        "method": "optimize",
        "objective_speed_rpm": objective_speed_rpm(st),
        "converged": found.converged,
        "convergence": {
            "converged": found.converged,
            "criterion": found.criterion,
            "not_converged": list(found.not_converged),
            "runs": [
                {
                    "name": r.name,
                    "seed": r.seed,
                    "generations": r.search_generations,
                    "stopped_by": r.stopped_by,
                    "best_before_polish": r.polish.f0 if r.polish else r.f,
                    "polish": None
                    if r.polish is None
                    else {
                        "evaluations": r.polish.evaluations,
                        "converged": r.polish.converged,
                        "stopped_by": r.polish.stopped_by,
                        "step_of_range": r.polish.step,
                    },
                    "converged": r.converged,
                    "best_minimized": r.f,
                }
                for r in found.runs
            ],
        },
        "caveats": caveats.as_dict(),
        "caveats_text": caveats.lines(),
        "findings_text": caveats.findings(),
        "optimizer": {
            "algorithm": "scipy.optimize.differential_evolution (vectorized, deferred updating), then a local CMA-ES polish",
            "objective": opt.label,
            "pareto": list(opt.pareto) if opt.pareto else None,
            "pareto_points": opt.points if opt.pareto else None,
            "knee": "the front design nearest the ideal point on the front normalized by its ends (its own run)"
            if opt.pareto
            else None,
            "population": opt.population,
            "max_generations": opt.generations,
            "seed": opt.seed,
            "seeds": opt.seeds,
            "stall": opt.stall,
            "tol": opt.tol,
            "atol": opt.atol,
            "ftol": opt.ftol,
            "xtol": opt.xtol,
            "polish_evaluations": opt.polish_evaluations,
            "init": opt.init,
            "resolution": dict(opt.resolution),
        },
        "robust": {"samples": st.robust.samples, "k": st.robust.k, "seed": st.robust.seed} if st.robust else None,
        "conditions": conditions(st),
        "set": dict(st.fixed),
        "bounds": [b.text() for b in st.bounds],
        "parameters": [
            {
                "path": v.param.path,
                "unit": v.param.unit,
                "low": v.low,
                "high": v.high,
                "nominal": v.param.nominal,
                "tolerance": v.tolerance if st.robust else None,
                "winner": float(x),
                "optimum": float(y),
            }
            for v, x, y in zip(st.varied, res.winner, found.winner, strict=True)
        ],
        "nominal_in_range": bool(
            np.all((nominal >= [v.low for v in st.varied]) & (nominal <= [v.high for v in st.varied]))
        ),
        "mechanism_file_design": {
            "objective": None if opt.pareto or not np.isfinite(found.file_objective) else found.file_objective,
            "metrics": {c.name: found.file_columns[c.name] for c in st.columns},
        },
        "winner": {
            "objective": None if opt.pareto else res.objective,
            "objective_unrounded": None if opt.pareto else found.objective,
            "metrics": {
                c.name: {
                    "unit": c.unit,
                    "value": res.columns[c.name],
                    "nominal_dimensions": res.nominal_columns[c.name],
                }
                for c in st.columns
            },
            "mujoco": mj(0),
        },
        "rejected": [
            {
                "parameters": dict(zip([p.path for p in st.params], map(float, r.values), strict=True)),
                "reason": r.reason,
            }
            for r in rejected
        ],
        "front": None
        if res.front is None or res.front_columns is None
        else [
            {
                "design": f"pareto-{i + 1:02d}",
                "parameters": dict(zip([p.path for p in st.params], map(float, x), strict=True)),
                "metrics": {c: float(v[i]) for c, v in res.front_columns.items()},
                "mujoco": mj(i + 1),
            }
            for i, x in enumerate(res.front)
        ],
        "flywheel": None
        if fly is None
        else {
            "link": fly.link,
            "inertia_kg_m2": fly.inertia,
            "target_delta": fly.target,
            "delta_without": fly.delta_before,
            "delta_with": fly.delta_after,
            "omega_mean_rad_s": fly.omega_mean,
        },
        "runs": [
            {
                "name": r.name,
                "generations": r.generations,
                "evaluations": r.evaluations,
                "converged": r.converged,
                "best_minimized": r.f,
            }
            for r in found.runs
        ],
        "evaluations": found.evaluations,
        "mujoco_thresholds_um": {
            "position_error": th["position_um"],
            "loop_gap": th["loop_um"],
            "thread_error": th["thread_um"],
        },
        "engine": found.engine,
        "timing_s": found.timing,
        "command": command,
        "versions": {"mjlink": __version__, **versions()},
    }


def page(summ: dict[str, Any], files: list[str]) -> str:
    """``index.html``: the optimization's summary as a page: whether it converged (and why
    not), the caveats, the winner as written, the candidates set aside, the figures."""
    e = html.escape
    conv = summ["convergence"]
    ok = conv["converged"]
    w = summ["winner"]
    head = (
        "<p class='ok'>Converged.</p>"
        if ok
        else "<p class='bad'>NOT CONVERGED: " + "; ".join(e(x) for x in conv["not_converged"]) + "</p>"
    )
    rows = "".join(
        f"<tr><td>{e(p['path'])}</td><td>{p['winner']:.10g} {e(p['unit'])}</td><td>{p['optimum']:.10g}</td>"
        f"<td>{p['low']:g} .. {p['high']:g}</td><td>{p['nominal']:.6g}</td></tr>"
        for p in summ["parameters"]
    )
    mets = "".join(f"<tr><td>{e(k)}</td><td>{m['value']:.6g} {e(m['unit'])}</td></tr>" for k, m in w["metrics"].items())
    caveats = "".join(f"<li>{e(c)}</li>" for c in summ["caveats_text"]) or "<li>none</li>"
    found = "".join(f"<li>{e(c)}</li>" for c in summ["findings_text"])
    rejected = "".join(f"<li>{e(r['reason'])}</li>" for r in summ["rejected"])
    figs = "".join(f"<figure><img src='{e(f)}' alt='{e(f)}'></figure>" for f in files if f.endswith(".png"))
    links = " ".join(f"<a href='{e(f)}'>{e(f)}</a>" for f in files if not f.endswith(".png") and f != "index.html")
    objective = "" if w["objective"] is None else f"<p>Objective as written: <b>{w['objective']:.8g}</b></p>"
    held = conditions_text(summ.get("conditions") or [])
    if held:
        objective += f"<p>Operating conditions, held at the file's values and deviated over the samples: {e(held)}</p>"
    rpm = summ.get("objective_speed_rpm")
    if rpm is not None:
        objective += (
            f"<p>Optimized at {rpm:.4g} rpm; winner.toml keeps its file's speed: "
            f"<code>python -m mjlink simulate winner.toml {e(speed_option(rpm))}</code> shows its loads there.</p>"
        )
    return (
        "<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'>"
        f"<title>{e(summ['study'])}</title><style>body{{font-family:sans-serif;max-width:1100px;margin:auto;padding:1em}}"
        ".ok{color:#1a7f37;font-weight:bold}.bad{color:#b42318;font-weight:bold}"
        "table{border-collapse:collapse}td,th{border:1px solid #ccc;padding:2px 6px}img{max-width:100%}</style>"
        f"</head><body><h1>{e(summ['study'])}: {e(summ['title'] or summ['mechanism'])}</h1>"
        f"<p>{e(summ['optimizer']['objective'])}</p>{head}"
        f"<p class='criterion'>Criterion: {e(conv['criterion'])}</p>{objective}"
        f"<h2>Caveats</h2><ul>{caveats}</ul>"
        + (f"<h2>In the winner's favour</h2><ul>{found}</ul>" if found else "")
        + "<h2>Winner (rounded to the resolution, as written in winner.toml)</h2><table><tr><th>parameter</th>"
        f"<th>winner</th><th>optimum found</th><th>range</th><th>file</th></tr>{rows}</table>"
        f"<table><tr><th>metric</th><th>as written</th></tr>{mets}</table>"
        + (f"<h2>Candidates set aside</h2><ul>{rejected}</ul>" if rejected else "")
        + f"<h2>Files</h2><p>{links}</p>{figs}</body></html>"
    )


def _plots(res: _opt.Result, ver: Verified, stage: Path) -> list[Path]:
    from ..plotting import optimize as po  # here: matplotlib, not for --no-plots

    st = res.study
    opt = st.optimize
    assert opt is not None
    nominal = np.array([p.nominal for p in st.params])
    b = batch.solve_batch(st.mechanism, st.params, np.stack([nominal, res.winner]), st.per_turn)
    feas = _metrics.feasibility(b).feasible
    loads = _metrics.Loads()
    names = [c for c, _ in opt.objective] + list(opt.pareto or ())
    curves = []
    traced: list[str] = []  # the points the objective is about, their paths drawn
    with np.errstate(all="ignore"):
        for m in st.metrics:
            if any(c.name in names for c in m.columns()):
                cv = m.curve(b, loads)
                if cv is not None:
                    curves.append(cv)
                traced += [p for p in (m.point, *getattr(m, "pair", ())) if p and p not in st.mechanism.ground]
    targets = {m.point: m.targets * 1e3 for m in st.metrics if hasattr(m, "targets")}
    title = f"{st.name}: {st.title or st.mechanism.title}"
    out: list[Path | None] = [
        po.convergence(title, res, stage),
        po.before_after(title, st, b, feas, curves, targets, traced, res, stage),
    ]
    if res.front is not None and len(res.front):
        out.append(po.pareto(title, res, ver, stage))
    return [p for p in out if p is not None]
