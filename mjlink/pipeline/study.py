"""The ``study`` job: run a design study and write its table, summary and plots.

``<out>/NAME-study/``: ``results.csv`` and ``results.parquet`` (one row per variant: its
index, the varied parameters, every metric, feasibility with its reason, and MuJoCo's
verdict with its figures), ``summary.json`` (the study, the engine, counts, each metric's
statistics over the feasible variants, the thresholds MuJoCo was held to, timings and
versions) and the plots. Finished chunks wait in ``<out>/.NAME-study.chunks/`` until the
outputs are published, so an interrupted study resumes where it stopped.
"""

from __future__ import annotations

import platform
import shutil
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .. import __version__, compare, output
from ..study import engine
from ..study.spec import Study, load

PERCENTILES = (1, 5, 50, 95, 99)


def unit_slug(unit: str) -> str:
    """A unit as a column-name suffix: 'N*m' -> 'N_m', 'kg*m^2' -> 'kg_m2', '' -> ''."""
    return unit.replace("*", "_").replace("/", "_").replace("^", "")


def column_name(name: str, unit: str) -> str:
    """'position_error_P5' + 'um' -> 'position_error_P5_um' (the CSV convention: unit last)."""
    return f"{name}_{unit_slug(unit)}" if unit else name


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
    cols["reason"] = list(o.reason)
    cols["mujoco"] = ["" if v < 0 else ("pass" if v else "FAIL") for v in o.verified]
    cols["mujoco_position_error_um"] = o.mujoco["position_error"]
    cols["mujoco_loop_gap_um"] = o.mujoco["loop_gap"]
    cols["mujoco_thread_error_um"] = o.mujoco["thread_error"]
    cols["mujoco_reason"] = list(o.mujoco_reason)
    return cols


def _stats(x: np.ndarray) -> dict[str, float]:
    x = x[np.isfinite(x)]
    if not len(x):
        return {"count": 0}
    out = {
        "count": len(x),
        "min": float(x.min()),
        "max": float(x.max()),
        "mean": float(x.mean()),
        "std": float(x.std(ddof=1)) if len(x) > 1 else 0.0,
    }
    for q in PERCENTILES:
        out[f"p{q}"] = float(np.percentile(x, q))
    return out


def summary(o: engine.Outcome, command: str | None = None) -> dict[str, Any]:
    """What ``summary.json`` holds (see the module docstring)."""
    st = o.study
    within = np.ones(len(o.values), dtype=bool) & o.feasible
    for b in st.bounds:
        within &= b.holds(o.columns[b.column])
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
        "versions": {"mjlink": __version__, "python": platform.python_version(), **_versions()},
    }


def _versions() -> dict[str, str]:
    out = {"numpy": np.__version__}
    for mod in ("mujoco", "dask", "distributed", "scipy"):
        m = sys.modules.get(mod)
        if m is not None:
            out[mod] = str(getattr(m, "__version__", ""))
    return out


def _progress_bar() -> tuple[engine.Progress, Any]:
    """A terminal progress bar per stage (rate and ETA in variants), closed by the second value."""
    from tqdm import tqdm

    bars: dict[str, Any] = {}

    def update(stage: str, done: int, total: int) -> None:
        bar = bars.get(stage)
        if bar is None:
            label = "reference" if stage == "reference" else "MuJoCo   "
            bar = bars[stage] = tqdm(total=total, desc=label, unit="variant", file=sys.stderr, leave=True, disable=None)
        bar.update(done - bar.n)

    def close() -> None:
        for b in bars.values():
            b.close()

    return update, close


def run(
    study: Study | str | Path,
    out_root: Path | str = Path("renders"),
    *,
    scheduler: str | None = None,
    workers: int | None = None,
    client: Any = None,
    plots: bool = True,
    force: bool = False,
    progress: bool = True,
    command: str | None = None,
) -> StudyResult:
    """Run a study (a :class:`Study` or its file) and write its outputs.

    Args:
      study: the study, or a study file's path or shipped name.
      out_root: outputs go to ``out_root/NAME-study/``.
      scheduler: an existing Dask scheduler's address (see :func:`mjlink.study.engine.run`).
      workers: local cluster worker processes (default one per core; 0: in this process).
      client: a ``distributed.Client`` to use instead.
      plots: write the PNG plots.
      force: publish into an existing folder mjlink did not write for this study.
      progress: show progress bars on stderr (when it is a terminal).
      command: the command line, recorded in the summary.
    Returns:
      The :class:`StudyResult`.
    """
    st = study if isinstance(study, Study) else load(study)
    if st.optimize is not None:
        from . import optimize

        return optimize.run(  # type: ignore[return-value]
            st,
            out_root,
            scheduler=scheduler,
            workers=workers,
            client=client,
            plots=plots,
            force=force,
            progress=progress,
            command=command,
        )
    out_root = Path(out_root)
    dest = out_root / f"{st.name}-study"
    cache_dir = out_root / f".{st.name}-study.chunks"
    update, close = _progress_bar() if progress else (None, lambda: None)
    try:
        o = engine.run(st, client=client, scheduler=scheduler, workers=workers, cache_dir=cache_dir, progress=update)
    finally:
        close()
    summ = summary(o, command)
    files: list[Path] = []
    with output.staged_dir(dest, kind="study", mechanism=st.name, force=force) as stage:
        cols = table(o)
        files.append(output.write_records(stage / "results.csv", cols))
        files.append(output.write_parquet(stage / "results.parquet", cols))
        files.append(output.write_json(stage / "summary.json", summ))
        if plots:
            files += _plots(o, stage)
    shutil.rmtree(cache_dir, ignore_errors=True)  # the outputs are published: the chunks served
    return StudyResult(o, dest, [dest / f.name for f in files], summ)


def _plots(o: engine.Outcome, stage: Path) -> list[Path]:
    from ..plotting import study as sp

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
