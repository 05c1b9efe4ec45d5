"""The ``study`` job: run a design study and write its table, summary and plots.

``<out>/NAME-study/``: ``results.csv`` and ``results.parquet`` (one row per variant: its
index, the varied parameters, every metric, feasibility with its reason, and MuJoCo's
verdict with its figures), ``summary.json`` (the study, the engine, counts, each metric's
statistics over the feasible variants, the thresholds MuJoCo was held to, timings and
versions) and the plots. Finished chunks wait in ``<out>/.NAME-study.chunks/`` until the
outputs are published, so an interrupted study resumes where it stopped.
"""

from __future__ import annotations

import os
import platform
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from .. import compare
from ..errors import InputError, OutputError
from ..files import write_json, write_parquet, write_records
from ..notes import note
from ..runtime import cluster, staging
from ..runtime.progress import study_progress
from ..study import cache, engine, plan
from ..study.plan import Plan
from ..study.sampling import sample_std
from ..study.spec import Study, load
from ..version import __version__
from . import optimize
from .columns import column_name, versions

if TYPE_CHECKING:
    from .optimize import OptimizeResult

PERCENTILES = (1, 5, 50, 95, 99)


@dataclass(frozen=True)
class StudyResult:
    """A finished study: the engine's :class:`~mjlink.study.engine.Outcome`, the folder and
    files written, and the summary (as in ``summary.json``)."""

    outcome: engine.Outcome
    out_dir: Path
    files: list[Path] = field(default_factory=list)
    summary: dict[str, Any] = field(default_factory=dict)

    @property
    def failures(self) -> list[str]:
        """Variants MuJoCo verified that missed a threshold, one line each."""
        o = self.outcome
        return [f"variant {i}: {o.mujoco_reason[i]}" for i in np.flatnonzero(o.verified == 0)]


def table(o: engine.Outcome) -> dict[str, Any]:
    """The results table's columns, by name (units in the names), one row per variant."""
    st = o.study
    cols: dict[str, Any] = {"variant": np.arange(len(o.values))}
    for j, p in enumerate(st.params):
        cols[column_name(p.path, p.unit)] = o.values[:, j]
    for c in st.columns:
        cols[column_name(c.name, c.unit)] = o.columns[c.name]
    cols["feasible"] = o.feasible.astype(np.int8)
    cols["within_bounds"] = within_bounds(o).astype(np.int8)
    cols["reason"] = list(o.reason)
    cols["mujoco"] = ["" if v < 0 else ("pass" if v else "FAIL") for v in o.verified]
    cols["mujoco_position_error_um"] = o.mujoco["position_error"]
    cols["mujoco_loop_gap_um"] = o.mujoco["loop_gap"]
    cols["mujoco_thread_error_um"] = o.mujoco["thread_error"]
    cols["mujoco_reason"] = list(o.mujoco_reason)
    return cols


def within_bounds(o: engine.Outcome) -> np.ndarray:
    """(V,) bool: the variant is feasible and holds every [[bound]] (all feasible ones without)."""
    within = o.feasible.copy()
    for b in o.study.bounds:
        within &= b.holds(o.columns[b.column])
    return within


def _stats(x: np.ndarray) -> dict[str, float]:
    x = x[np.isfinite(x)]
    if not len(x):
        return {"count": 0}
    out = {
        "count": len(x),
        "min": float(x.min()),
        "max": float(x.max()),
        "mean": float(x.mean()),
        "std": sample_std(x),
    }
    for q in PERCENTILES:
        out[f"p{q}"] = float(np.percentile(x, q))
    return out


def sensitivity(o: engine.Outcome, top: int = 5) -> dict[str, dict[str, Any]]:
    """The parameters that move each metric most, for a sampled study (tolerance or random).

    A least-squares plane through the feasible variants: metric = c + sum_j b_j (p_j - mean).
    Each parameter's share of the metric's variance is its term b_j^2 var(p_j) of the plane's,
    the terms scaled to add up to ``r2``, the part of the variance the plane explains: for a
    response linear over the sampled band and independent parameters (a tolerance study's),
    the first-order variance shares. Metrics with at most two distinct
    values (pass/fail flags) and constant ones are left out.

    Returns:
      metric -> {"r2": float, "ranked": [{"parameter", "unit", "share", "slope"}] (largest share
      first, at most ``top``)}; ``slope`` in the metric's unit per parameter unit.
    """
    st = o.study
    if st.method == "grid" or not st.varied:
        return {}
    out: dict[str, dict[str, Any]] = {}
    P = np.asarray(o.values, dtype=float)
    for c in st.columns:
        y = np.asarray(o.columns[c.name], dtype=float)
        ok = o.feasible & np.isfinite(y) & np.isfinite(P).all(axis=1)
        if ok.sum() < P.shape[1] + 2 or len(np.unique(y[ok])) <= 2:
            continue
        X = P[ok] - P[ok].mean(axis=0)
        yc = y[ok] - y[ok].mean()
        vy = float(yc @ yc)
        if vy <= 0.0:
            continue
        b, *_ = np.linalg.lstsq(X, yc, rcond=None)
        fit = X @ b
        r2 = float(1.0 - ((yc - fit) @ (yc - fit)) / vy)
        part = b**2 * (X**2).sum(axis=0)
        # Shares of the explained variance, scaled to sum to R^2: a finite sample's parameters
        # are never exactly uncorrelated, and the raw terms would not add up.
        share = part / part.sum() * r2 if part.sum() > 0 else part
        order = np.argsort(-share)[:top]
        out[c.name] = {
            "r2": r2,
            "ranked": [
                {
                    "parameter": st.varied[j].param.path,
                    "unit": st.varied[j].param.unit,
                    "share": float(share[j]),
                    "slope": float(b[j]),
                }
                for j in order
            ],
        }
    return out


def summary(o: engine.Outcome, command: str | None = None) -> dict[str, Any]:
    """What ``summary.json`` holds (see the module docstring)."""
    st = o.study
    within = within_bounds(o)
    verified = o.verified >= 0
    worst = {k: float(np.max(v[np.isfinite(v)])) if np.isfinite(v).any() else None for k, v in o.mujoco.items()}
    thresholds = compare.thresholds()
    return {
        "study": st.name,
        "title": st.title,
        "file": str(st.path) if st.path else None,
        "mechanism": st.mechanism.name,
        "mechanism_file": str(st.mechanism.path) if st.mechanism.path else None,
        "digest": st.digest,
        "method": st.method,
        "seed": st.seed if st.method != "grid" else None,
        "variants": len(o.values),
        "angles_per_turn": st.per_turn,
        "parameters": [{"path": v.param.path, "unit": v.param.unit, "nominal": v.param.nominal} for v in st.varied],
        "metrics": {c.name: {"unit": c.unit, "label": c.label, **_stats(o.columns[c.name])} for c in st.columns},
        "feasible": int(o.feasible.sum()),
        "infeasible": int((~o.feasible).sum()),
        "bounds": [b.text() for b in st.bounds],
        "within_bounds": int(within.sum()) if st.bounds else None,
        "sensitivity": sensitivity(o),
        "mujoco": {
            "verify": st.verify,
            "verified": int(verified.sum()),
            "passed": int((o.verified == 1).sum()),
            "failed": int((o.verified == 0).sum()),
            "worst_um": worst,
            "thresholds_um": {
                "position_error": thresholds["position_um"],
                "loop_gap": thresholds["loop_um"],
                "thread_error": thresholds["thread_um"],
            },
        },
        "engine": o.engine,
        "chunks": o.chunks,
        "resumed_chunks": o.resumed,
        "timing_s": o.timing,
        "command": command,
        "versions": {"mjlink": __version__, "python": platform.python_version(), **versions()},
    }


@dataclass(frozen=True)
class Prepared:
    """A study checked and sized before any work: the ``study``, where its outputs go
    (``dest``) and its resume cache (``cache_dir``), the local cluster's ``workers`` (0: in
    this process; None: an existing cluster's), the scheduler's address, and the ``plan``."""

    study: Study
    dest: Path
    cache_dir: Path
    workers: int | None
    scheduler: str | None
    plan: Plan


def prepare(
    study: Study | str | Path,
    out_root: Path | str = Path("renders"),
    *,
    scheduler: str | None = None,
    workers: int | None = None,
    client: Any = None,
    force: bool = False,
    max_memory: float | None = None,
) -> Prepared:
    """Everything checked before any work (each a one-line error, exit status 2 for input
    beyond a limit or that cannot be used; nothing is created): the study file; the output
    folder (absent, or mjlink's output of this study, or ``force``; not a file, FIFO or device;
    writable); the resume cache's place (absent or mjlink's); the scheduler's address; the
    workers (more than the cores are clamped, with a note); the cost (:mod:`mjlink.study.plan`:
    refused past the memory bound, ``max_memory`` bytes or the machine's)."""
    st = study if isinstance(study, Study) else load(study)
    out_root = Path(out_root)
    dest = out_root / f"{st.name}-study"
    cache_dir = out_root / f".{st.name}-study.chunks"
    try:
        staging.check_destination(dest, kind="study", mechanism=st.name, force=force)
    except OutputError as e:
        raise InputError(str(e)) from None
    if st.optimize is None:
        cache.check(cache_dir)
    address = scheduler or os.environ.get("DASK_SCHEDULER_ADDRESS") if client is None else None
    if address:
        cluster.check_reachable(engine.check_address(address))
    if workers is not None and workers < 0:
        raise InputError(f"--workers must be 0 or more, got {workers}")
    local: int | None
    if client is not None or address:
        local = None
    elif workers == 0:
        local = 0
    else:
        local = cluster.local_workers(workers)
    lanes = local if local is not None else (len(client.scheduler_info()["workers"]) if client is not None else 1)
    p = plan.estimate(st, workers=lanes, limit=max_memory, cluster=bool(local))
    if workers is None and local and plan.small(p, st):
        # Less work than a local cluster costs to start (a sampled study) or than its round
        # trips cost per generation (an optimization): this process is faster.
        local = 0
        p = plan.estimate(
            st, workers=0, limit=max_memory, calibration=p.calibration, bowl=p.bowl, rehearsal=p.rehearsal
        )
    return Prepared(st, dest, cache_dir, local, address, p)


def run(
    study: Study | str | Path | Prepared,
    out_root: Path | str = Path("renders"),
    *,
    scheduler: str | None = None,
    workers: int | None = None,
    client: Any = None,
    plots: bool = True,
    force: bool = False,
    progress: bool = True,
    command: str | None = None,
    max_memory: float | None = None,
) -> StudyResult | OptimizeResult:
    """Run a study (a :class:`Study`, its file, or what :func:`prepare` made of it) and write its
    outputs; an ``[optimize]`` study returns an :class:`~.optimize.OptimizeResult`.

    Args:
      study: the study, a study file's path or shipped name, or a :class:`Prepared` one.
      out_root: outputs go to ``out_root/NAME-study/``.
      scheduler: an existing Dask scheduler's address (see :func:`mjlink.runtime.cluster.client_for`).
      workers: local cluster worker processes (default: one per core, or this process for a study
        too small to gain from a cluster, :func:`mjlink.study.plan.small`; 0: in this process).
      client: a ``distributed.Client`` to use instead.
      plots: write the PNG plots.
      force: publish into an existing folder mjlink did not write for this study.
      progress: show progress on stderr (a bar on a terminal, else a line every 10 s).
      command: the command line, recorded in the summary and the folder's marker.
      max_memory: the memory bound in bytes (default: the machine's, :mod:`mjlink.study.plan`).
    Returns:
      The :class:`StudyResult` (or OptimizeResult).
    Raises:
      InputError: the study refused before any work (:func:`prepare`).
    """
    pre = (
        study
        if isinstance(study, Prepared)
        else prepare(
            study, out_root, scheduler=scheduler, workers=workers, client=client, force=force, max_memory=max_memory
        )
    )
    pre.plan.check()
    st = pre.study
    if st.optimize is not None:
        return optimize.run(
            st,
            pre.dest.parent,
            scheduler=pre.scheduler,
            workers=pre.workers,
            client=client,
            plots=plots,
            force=force,
            progress=progress,
            command=command,
        )
    update, close = study_progress(f"study {st.name}") if progress else (None, lambda: None)
    t = time.perf_counter()
    try:
        with _client(client, pre.scheduler, pre.workers) as (c, what):
            started = time.perf_counter() - t
            with staging.staged_dir(pre.dest, kind="study", mechanism=st.name, force=force, command=command) as stage:
                try:
                    o = engine.run(st, client=c, what=what, cache_dir=pre.cache_dir, progress=update)
                except KeyboardInterrupt:
                    _kept(pre.cache_dir)
                    raise
                if client is None and pre.workers != 0:
                    o.timing["cluster start"] = started
                summ = summary(o, command)
                files: list[Path] = []
                cols = table(o)
                files.append(write_records(stage / "results.csv", cols))
                files.append(write_parquet(stage / "results.parquet", cols))
                files.append(write_json(stage / "summary.json", summ))
                if plots:
                    files += _plots(o, stage)
    finally:
        close()
    cache.remove(pre.cache_dir)  # the outputs are published: the chunks served
    return StudyResult(o, pre.dest, [pre.dest / f.name for f in files], summ)


def _kept(cache_dir: Path) -> None:
    """Say where an interrupted study's finished chunks wait (one line)."""
    n = sum(1 for _ in cache_dir.glob("*.npz")) if cache_dir.is_dir() else 0
    if n:
        note(f"{n} finished chunk(s) kept in {cache_dir}: the same command resumes from them")


@contextmanager
def _client(client: Any, scheduler: str | None, workers: int | None) -> Iterator[tuple[Any, str]]:
    """The given client, or one for the scheduler, a local cluster or this process."""
    if client is not None:
        yield client, "the given Dask client"
        return
    with cluster.client_for(scheduler, workers) as got:
        yield got


def _plots(o: engine.Outcome, stage: Path) -> list[Path]:
    from ..plotting import study as sp  # here: matplotlib, not for --no-plots

    st = o.study
    title = f"{st.name}: {st.title or st.mechanism.title}"
    params = [sp.Column(p.path, p.path, p.unit, o.values[:, j]) for j, p in enumerate(st.params)]
    mets = [sp.Column(c.name, c.label, c.unit, o.columns[c.name]) for c in st.columns]
    nominal = {p.path: p.nominal for p in st.params}
    out: list[Path | None] = [sp.scatter_matrix(title, params, mets, o.feasible, o.verified, stage, nominal=nominal)]
    if st.method == "tolerance":
        out.append(sp.histograms(title, mets, o.feasible, stage))
    shape = st.grid_shape
    if shape is not None and len(shape) == 2:
        gx, gy = np.array(st.varied[1].values), np.array(st.varied[0].values)
        grid = [sp.Column(m.name, m.label, m.unit, m.values.reshape(shape)) for m in mets]
        limits: dict[str, tuple[float | None, float | None]] = {b.column: (b.low, b.high) for b in st.bounds}
        out.append(
            sp.feasible_region(title, params[1], params[0], gx, gy, o.feasible.reshape(shape), grid, limits, stage)
        )
    return [p for p in out if p is not None]
