"""The ``study`` job for an ``[optimize]`` study: search, verify in MuJoCo, write the winner.

``<out>/NAME-study/``:

* ``winner.toml``: the optimum as a mechanism file (``check`` accepts it, ``simulate`` runs it),
  its leading comment saying which study produced it, with what objective and verdict;
  for a Pareto study also ``pareto-NN.toml``, one per front design (01 = lowest first column);
* ``results.csv`` / ``results.parquet``: every candidate evaluated (run, generation, the
  parameters, every metric, the objective, the constraint violation and its reason);
* ``front.csv`` (Pareto): the front's designs, their metrics and MuJoCo's verdict;
* ``summary.json``: the study, the optimizer's settings, the winner (parameters, objective,
  metrics at nominal dimensions and, robust, mean + k std), MuJoCo's figures, the flywheel,
  runs, evaluations, timings and versions;
* ``convergence.png``, ``before_after.png`` and (Pareto) ``pareto.png``.
"""

from __future__ import annotations

import datetime
import os
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .. import __version__, compare, output
from ..model import paths
from ..study import engine
from ..study import optimize as _opt
from ..study.spec import Study
from ..study.tasks import Verified, mujoco_chunk


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


@dataclass(frozen=True)
class OptimizeResult:
    """A finished optimization: the optimizer's :class:`~mjlink.study.optimize.Result`, the
    MuJoCo check of the winner (``verified``; row 0) and of the front (rows 1..F), the flywheel,
    the folder and files written, and the summary (as in ``summary.json``)."""

    result: _opt.Result
    verified: Verified
    flywheel: Flywheel | None
    out_dir: Path
    winner_file: Path
    files: list[Path] = field(default_factory=list)
    summary: dict[str, Any] = field(default_factory=dict)

    @property
    def failures(self) -> list[str]:
        """Designs MuJoCo verified that missed a threshold, one line each."""
        names = ["winner"] + [f"pareto-{i + 1:02d}" for i in range(len(self.verified.passed) - 1)]
        return [f"{n}: {r}" for n, p, r in zip(names, self.verified.passed, self.verified.reason, strict=True) if not p]


def _progress_bar(st: Study) -> tuple[_opt.Progress, Any]:
    """One terminal bar per run (generations), with the best feasible value so far."""
    from tqdm import tqdm

    bars: dict[str, Any] = {}
    opt = st.optimize
    assert opt is not None
    sign = -1.0 if opt.sense == "max" and not opt.pareto else 1.0

    def update(name: str, gen: int, total: int, best: float) -> None:
        bar = bars.get(name)
        if bar is None:
            for b in bars.values():
                b.close()
            bar = bars[name] = tqdm(total=total, desc=name[:40], unit="gen", file=sys.stderr, leave=True, disable=None)
        bar.update(max(0, min(gen, total) - bar.n))
        bar.set_postfix_str(f"best {sign * best:.6g}" if np.isfinite(best) else "no feasible design yet")

    def close() -> None:
        for b in bars.values():
            b.close()

    return update, close


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
    """Run an ``[optimize]`` study and write its outputs (arguments as
    :func:`mjlink.pipeline.study.run`)."""
    opt = st.optimize
    assert opt is not None
    dest = Path(out_root) / f"{st.name}-study"
    update, close = _progress_bar(st) if progress else (None, lambda: None)
    try:
        if client is not None:
            res, ver = _search(st, client, "the given Dask client", update)
        else:
            with engine.client_for(scheduler, workers) as (c, what):
                res, ver = _search(st, c, what, update)
    finally:
        close()
    fly = _flywheel(st, res.winner) if opt.flywheel_delta > 0 else None
    summ = summary(res, ver, fly, command)
    files: list[Path] = []
    with output.staged_dir(dest, kind="study", mechanism=st.name, force=force) as stage:
        files.append(
            output.write_text(stage / "winner.toml", winner_text(st, res, res.winner, ver, 0, fly), in_stage=True)
        )
        if res.front is not None:
            for i, x in enumerate(res.front):
                files.append(
                    output.write_text(
                        stage / f"pareto-{i + 1:02d}.toml", winner_text(st, res, x, ver, i + 1, None), in_stage=True
                    )
                )
            files.append(output.write_records(stage / "front.csv", front_table(res, ver)))
        cols = archive_table(res)
        files.append(output.write_records(stage / "results.csv", cols))
        files.append(output.write_parquet(stage / "results.parquet", cols))
        files.append(output.write_json(stage / "summary.json", summ))
        if plots:
            files += _plots(res, ver, stage)
    return OptimizeResult(res, ver, fly, dest, dest / "winner.toml", [dest / f.name for f in files], summ)


def _search(st: Study, client: Any, what: str, update: _opt.Progress | None) -> tuple[_opt.Result, Verified]:
    workers = 1
    if client is not None:
        workers = max(1, len(client.scheduler_info()["workers"]))
    res = _opt.run(st, client=client, workers=workers, engine=what, progress=update)
    designs = res.winner[None] if res.front is None else np.vstack([res.winner[None], res.front])
    threads = os.cpu_count() or 1
    if client is not None:
        ver = client.submit(mujoco_chunk, st, designs, threads=1, pure=False).result()
    else:
        ver = mujoco_chunk(st, designs, threads=threads)
    return res, ver


def _file_mechanism(st: Study) -> Any:
    from ..validation import get

    assert st.mechanism.path is not None
    return get(st.mechanism.path)


def _crank_link(mech: Any) -> str:
    c = mech.input_crank
    return next(l.name for l in mech.links if c.pivot in l.points and c.point in l.points)


def _flywheel(st: Study, x: np.ndarray) -> Flywheel:
    from ..reference import batch
    from ..reference.dynamics import flywheel_for, steady_motion, steady_variant

    opt = st.optimize
    assert opt is not None
    mech = batch.variant(st.mechanism, st.params, [float(v) for v in x])
    if mech.steady is not None:  # its [steady] motor, as the speed_fluctuation metric uses
        mech = steady_variant(mech)
    before = steady_motion(mech)
    J, after = flywheel_for(mech, opt.flywheel_delta)
    return Flywheel(_crank_link(mech), float(J), opt.flywheel_delta, before.delta, after.delta, after.omega_mean)


def winner_text(st: Study, res: _opt.Result, x: np.ndarray, ver: Verified, row: int, fly: Flywheel | None) -> str:
    """The mechanism file of design ``x`` (the winner, or a front design), with a header
    saying which study produced it and how it fared."""
    opt = st.optimize
    assert opt is not None
    base = _file_mechanism(st)
    values: dict[paths.Param, float] = {paths.resolve(base, p): v for p, v in st.fixed}
    for p, v in zip(st.params, x, strict=True):
        values[paths.resolve(base, p.path)] = float(v)
    if fly is not None and fly.inertia > 0:
        inertia = paths.resolve(base, f"links.{fly.link}.inertia")
        values[inertia] = values.get(inertia, inertia.nominal) + fly.inertia
    what = "winner" if row == 0 else f"Pareto design {row} of {len(res.front) if res.front is not None else 0}"
    verdict = (
        f"MuJoCo agrees (position {ver.position_error[row]:.3g} um, loop gap {ver.loop_gap[row]:.3g} um)"
        if ver.passed[row]
        else f"MuJoCo check FAILED: {ver.reason[row]}"
    )
    lines = [
        f"{what} of the optimization study '{st.name}' ({st.path or 'Python API'}, digest {st.digest}),",
        f"written by mjlink {__version__} on {datetime.date.today().isoformat()} from {st.mechanism.path}.",
        f"Objective: {opt.label}"
        + (f" (robust: mean + {st.robust.k:g} std over {st.robust.samples} tolerance samples)" if st.robust else "")
        + ".",
    ]
    sc = _columns_of(res, x)
    lines.append("Metrics: " + ", ".join(f"{c.name} = {sc[c.name]:.6g} {c.unit}".rstrip() for c in st.columns) + ".")
    if st.fixed:
        lines.append("Set by the study: " + ", ".join(f"{p} = {v:g}" for p, v in st.fixed) + ".")
    lines.append(
        "Optimized: "
        + ", ".join(f"{p.path} = {v:.6g} {p.unit}".rstrip() for p, v in zip(st.params, x, strict=True))
        + "."
    )
    if fly is not None:
        lines.append(
            f"Flywheel for delta = {fly.target:g}: {fly.inertia:.4g} kg*m^2 added to links.{fly.link}.inertia "
            f"(delta {fly.delta_before:.4g} without it, at {fly.omega_mean:.4g} rad/s mean)."
        )
    lines.append(verdict + ".")
    lines.append("Units: lengths mm, angles deg, masses g, inertias kg*m^2, speeds rad/s. The base file's comments")
    lines.append("are not carried over: see it for the [choice]s behind each number.")
    # A mechanism name has at most 32 characters: the study's name is cut to leave room.
    tail = "_winner" if row == 0 else f"_pareto_{row:02d}"
    name = st.name[: 32 - len(tail)].rstrip("_") + tail
    return paths.file_text(base, values, "\n".join(lines), name=name)


def _columns_of(res: _opt.Result, x: np.ndarray) -> dict[str, float]:
    """The metric columns of a design the optimizer evaluated (the winner's are at hand)."""
    if np.array_equal(x, res.winner):
        return res.columns
    assert res.front is not None and res.front_columns is not None
    i = int(np.flatnonzero((res.front == x).all(axis=1))[0])
    return {c: float(v[i]) for c, v in res.front_columns.items()}


def archive_table(res: _opt.Result) -> dict[str, Any]:
    """The results table: every candidate evaluated, in order."""
    from .study import column_name

    st, a = res.study, res.archive
    cols: dict[str, Any] = {"run": a.run, "generation": a.generation}
    for j, p in enumerate(st.params):
        cols[column_name(p.path, p.unit)] = a.values[:, j]
    for c in st.columns:
        cols[column_name(c.name, c.unit)] = a.columns[c.name]
    cols["minimized"] = a.objective
    cols["violation"] = a.violation
    cols["feasible"] = (a.violation <= 0).astype(np.int8)
    cols["reason"] = list(a.reason)
    return cols


def front_table(res: _opt.Result, ver: Verified) -> dict[str, Any]:
    """The Pareto front's designs with MuJoCo's verdicts."""
    from .study import column_name

    st = res.study
    assert res.front is not None and res.front_columns is not None
    cols: dict[str, Any] = {"design": [f"pareto-{i + 1:02d}" for i in range(len(res.front))]}
    for j, p in enumerate(st.params):
        cols[column_name(p.path, p.unit)] = res.front[:, j]
    for c in st.columns:
        cols[column_name(c.name, c.unit)] = res.front_columns[c.name]
    cols["winner"] = [int(np.array_equal(x, res.winner)) for x in res.front]
    cols["mujoco"] = ["pass" if p else "FAIL" for p in ver.passed[1:]]
    cols["mujoco_position_error_um"] = ver.position_error[1:]
    cols["mujoco_loop_gap_um"] = ver.loop_gap[1:]
    cols["mujoco_thread_error_um"] = ver.thread_error[1:]
    return cols


def summary(res: _opt.Result, ver: Verified, fly: Flywheel | None, command: str | None = None) -> dict[str, Any]:
    """What ``summary.json`` holds (see the module docstring)."""
    from .study import _versions

    st = res.study
    opt = st.optimize
    assert opt is not None
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
    return {
        "study": st.name,
        "title": st.title,
        "file": str(st.path) if st.path else None,
        "mechanism": st.mechanism.name,
        "mechanism_file": str(st.mechanism.path) if st.mechanism.path else None,
        "digest": st.digest,
        "method": "optimize",
        "optimizer": {
            "algorithm": "scipy.optimize.differential_evolution (vectorized, deferred updating, no polish)",
            "objective": opt.label,
            "pareto": list(opt.pareto) if opt.pareto else None,
            "pareto_points": opt.points if opt.pareto else None,
            "population": opt.population,
            "max_generations": opt.generations,
            "seed": opt.seed,
            "tol": opt.tol,
            "atol": opt.atol,
            "init": opt.init,
        },
        "robust": {"samples": st.robust.samples, "k": st.robust.k, "seed": st.robust.seed} if st.robust else None,
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
            }
            for v, x in zip(st.varied, res.winner, strict=True)
        ],
        "nominal_in_range": bool(
            np.all((nominal >= [v.low for v in st.varied]) & (nominal <= [v.high for v in st.varied]))
        ),
        "mechanism_file_design": {
            "objective": None if opt.pareto or not np.isfinite(res.file_objective) else res.file_objective,
            "metrics": {c.name: res.file_columns[c.name] for c in st.columns},
        },
        "winner": {
            "objective": None if opt.pareto else res.objective,
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
            for r in res.runs
        ],
        "evaluations": res.evaluations,
        "mujoco_thresholds_um": {
            "position_error": th["position_um"],
            "loop_gap": th["loop_um"],
            "thread_error": th["thread_um"],
        },
        "engine": res.engine,
        "timing_s": res.timing,
        "command": command,
        "versions": {"mjlink": __version__, **_versions()},
    }


def _plots(res: _opt.Result, ver: Verified, stage: Path) -> list[Path]:
    from ..analysis import metrics as _metrics
    from ..plotting import optimize as po
    from ..reference import batch

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
    if res.front is not None:
        out.append(po.pareto(title, res, ver, stage))
    return [p for p in out if p is not None]
