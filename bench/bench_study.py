"""Speed of design studies. Run: ``python bench/bench_study.py [--quick]``.

Sections (each a function returning table rows), side by side in one run:

* :func:`bench_reference`: the reference's variant-angles per second, vectorized across
  variants (the study's chunks) against one variant at a time; and 10,000 take-up variants x
  360 crank angles with every metric on 2 cores (a Dask LocalCluster of 2 worker processes)
  and in one process.
* :func:`bench_study`: the shipped 1000-variant take-up tolerance study, MuJoCo verification of
  every variant included, in this process and on a Dask LocalCluster of 2 workers (the
  cluster's start counted): Dask's overhead.

* :func:`bench_rollout`: MuJoCo steps per second of the take-up's kinematic model (RK4,
  50 us, the kinematic run's flywheel and servo) through ``mujoco.rollout`` with 1 and 2
  threads, against a plain C loop ``mj_step(m, d, nstep=N)`` on the same models, side by side
  in one run: wall and CPU seconds, and the ratios that matter (rollout per thread against
  the C loop; 2 threads against 1).
* :func:`bench_scatter`: the study's scatter matrix of 10,000 variants of 7 parameters and 7
  metrics (6 x 6 panels drawn, about a tenth infeasible), written as its PNG: its goal is
  3 s of CPU.
* :func:`bench_plan` (``--plan``, alone): ``study NAME --dry-run``'s time against the study's
  measured time, on the shipped studies whose plan says at most ``--plan-limit`` seconds.
* :func:`bench_verify`: :func:`mjlink.sim.batch.verify` of take-up tolerance variants (every
  block's ``length``, ``length_a``, ``length_b`` and the x, y of the ground pivots P1 and P4
  deviating uniformly within +-0.02 mm), building and compiling included, with its time split.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import multiprocessing
import os
import re
import resource
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

import mujoco  # noqa: E402

from mjlink import validation  # noqa: E402
from mjlink.model.mechanism import Mechanism  # noqa: E402
from mjlink.runtime import cluster  # noqa: E402
from mjlink.sim import batch, builder, simulate  # noqa: E402
from mjlink.study import engine, spec, tasks  # noqa: E402

TOLERANCE = 0.02e-3  # m, +- on every varied length and pivot coordinate
LENGTHS = ("length", "length_a", "length_b")
PIVOTS = ("P1", "P4")

Row = tuple[str, str, str, str]  # what, wall, CPU, note


def tolerance_variants(mech: Mechanism, n: int, tol: float = TOLERANCE, seed: int = 0) -> list[Mechanism]:
    """``n`` variants of ``mech`` with every nonzero block length and the x, y of the ground
    pivots ``PIVOTS`` moved by independent uniform deviations within +-``tol`` (m)."""
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(n):
        steps = []
        for b in mech.steps:
            change = {
                f.name: getattr(b, f.name) + rng.uniform(-tol, tol)
                for f in dataclasses.fields(b)
                if f.name in LENGTHS and getattr(b, f.name)
            }
            steps.append(dataclasses.replace(b, **change))
        ground = {
            k: v + np.array([*rng.uniform(-tol, tol, 2), 0.0]) if k in PIVOTS else v for k, v in mech.ground.items()
        }
        out.append(dataclasses.replace(mech, steps=tuple(steps), ground=ground))
    return out


def _on_cluster(st: spec.Study, workers: int) -> engine.Outcome:
    """The study on a local cluster of ``workers`` processes (0: in this process), the cluster's
    start included, as the command line runs it."""
    start = time.perf_counter()
    with cluster.client_for(workers=workers) as (client, what):
        started = time.perf_counter() - start
        out = engine.run(st, client=client, what=what)
    if client is not None:
        out.timing["cluster start"] = started
    return out


def _timed(f: Callable[[], object]) -> tuple[float, float]:
    """Wall and CPU (all threads of the process) seconds of ``f()``."""
    w, c = time.perf_counter(), time.process_time()
    f()
    return time.perf_counter() - w, time.process_time() - c


def _in_processes(parts: list[Callable[[], object]]) -> tuple[float, float]:
    """Wall and CPU seconds of running ``parts`` at once, each in its own forked process
    (started together at a barrier; the wall time is the slowest part's)."""
    ctx = multiprocessing.get_context("fork")  # the children inherit the compiled models
    barrier, queue = ctx.Barrier(len(parts)), ctx.SimpleQueue()

    def child(f: Callable[[], object]) -> None:
        barrier.wait()
        queue.put(_timed(f))

    procs = [ctx.Process(target=child, args=(f,)) for f in parts]
    for p in procs:
        p.start()
    got = [queue.get() for _ in procs]
    for p in procs:
        p.join()
    return max(w for w, _ in got), sum(c for _, c in got)


def bench_rollout(variants: int = 200, repeat: int = 3) -> list[Row]:
    """MuJoCo steps per second: rollout with 1 and 2 threads vs a plain C loop.

    The plain C loop ``mj_step(m, d, nstep=N)`` runs each model from its keyframe; run in two
    processes at once (half the models each) it shows what two cores of this machine give
    with no thread pool at all, the ceiling for rollout's 2 threads.

    Args:
      variants: take-up variants in the batch, each run for one crank turn.
      repeat: runs of each, interleaved; the fastest counts.
    Returns:
      Table rows.
    """
    mech = validation.get("takeup")
    mechs = tolerance_variants(mech, variants, seed=1)
    built, states, steps = [], [], 0
    for m in mechs:
        case = simulate.kinematic_case(m, cycles=1.0)
        b = builder.make_batch(m, case.settings)
        d = mujoco.MjData(b.model)
        mujoco.mj_resetDataKeyframe(b.model, d, 0)
        s = np.empty(mujoco.mj_stateSize(b.model, mujoco.mjtState.mjSTATE_FULLPHYSICS))
        mujoco.mj_getState(b.model, d, s, mujoco.mjtState.mjSTATE_FULLPHYSICS)
        built.append(b)
        states.append(s)
        steps = case.steps + 1
    models, x0 = [b.model for b in built], np.array(states)
    total = len(models) * steps
    datas = [mujoco.MjData(m) for m in models]

    def c_loop(part: slice = slice(None)) -> Callable[[], None]:
        def run() -> None:
            for m, d in zip(models[part], datas[part], strict=True):
                mujoco.mj_resetDataKeyframe(m, d, 0)
                mujoco.mj_step(m, d, nstep=steps)

        return run

    def roll(threads: int) -> Callable[[], tuple[float, float]]:
        return lambda: _timed(lambda: batch.rollout(models, x0, steps, threads=threads))

    half = len(models) // 2
    loop, procs, one, two = (
        "C loop mj_step(nstep)",
        "C loop, 2 processes (ceiling)",
        "rollout, 1 thread",
        "rollout, 2 threads",
    )
    runs: dict[str, Callable[[], tuple[float, float]]] = {
        loop: lambda: _timed(c_loop()),
        procs: lambda: _in_processes([c_loop(slice(0, half)), c_loop(slice(half, None))]),
        one: roll(1),
        two: roll(2),
    }
    best: dict[str, tuple[float, float]] = {}
    for _ in range(repeat):  # interleaved, so that a busy spell of a shared machine hits all alike
        for k, f in runs.items():
            w, c = f()
            if k not in best or w < best[k][0]:
                best[k] = (w, c)
    rate = {k: total / w for k, (w, _) in best.items()}
    c1, c2, r1, r2 = rate[loop], rate[procs], rate[one], rate[two]
    # Steps per CPU second show what each thread did even when another process holds a core.
    per_cpu = total / best[two][1]
    notes = {
        loop: f"{c1:,.0f} steps/s",
        procs: f"{c2:,.0f} steps/s = {c2 / c1:.2f} x 1 process",
        one: f"{r1:,.0f} steps/s = {r1 / c1:.2f} x C loop",
        two: f"{r2:,.0f} steps/s = {r2 / r1:.2f} x 1 thread, {r2 / c2:.2f} x 2 processes; per thread "
        f"{r2 / 2 / c1:.2f} x C loop (wall), {per_cpu / c1:.2f} x (CPU)",
    }
    head = f"{len(models)} take-up models x {steps} steps"
    return [(f"{k} ({head})", f"{w:.2f}", f"{c:.2f}", notes[k]) for k, (w, c) in best.items()]


def bench_verify(variants: int = 1000, threads: int = 2) -> list[Row]:
    """``batch.verify`` of take-up tolerance variants, building and compiling included.

    Args:
      variants: the number of variants.
      threads: rollout's threads.
    Returns:
      Table rows: the total, then each stage.
    """
    mech = validation.get("takeup")
    mechs = tolerance_variants(mech, variants)
    w, c = time.perf_counter(), time.process_time()
    res, t = batch.verify_timed(mechs, threads=threads)
    w, c = time.perf_counter() - w, time.process_time() - c
    passed = sum(r.passed for r in res)
    worst = max(r.position_error for r in res) * 1e6
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024  # Linux: KiB
    rows: list[Row] = [
        (
            f"verify {variants} take-up variants (+-{TOLERANCE * 1e3:g} mm), {threads} threads",
            f"{w:.2f}",
            f"{c:.2f}",
            f"{passed} passed, worst position error {worst:.4f} um; peak memory {peak:,.0f} MiB",
        )
    ]
    what = {
        "settings": "kinematic case (flywheel from the reference)",
        "spec": "MjSpec build",
        "compile": "compile",
        "keyframe": "keyframe: consistent velocity, initial state",
        "forces": "open-loop external forces",
        "rollout": f"rollout ({t.steps / t.rollout:,.0f} steps/s)" if t.rollout > 0 else "rollout",
        "compare": "reference and comparison",
    }
    for k, label in what.items():
        s = getattr(t, k)
        rows.append((f"  {label}", f"{s:.2f}", "", f"{1e3 * s / variants:.2f} ms per variant, {100 * s / w:.0f} %"))
    return rows


# Every metric a take-up variant has (the shaking metrics included when the mechanism has them).
ALL_METRICS = """
[[metric]]
kind = "stroke"
point = "P5"
[[metric]]
kind = "extremes"
point = "P5"
[[metric]]
kind = "position_error"
point = "P5"
[[metric]]
kind = "thread_range"
[[metric]]
kind = "thread_feed"
[[metric]]
kind = "feed_deviation"
angles = [0.0, 90.0, 180.0, 270.0]
values = [0.0, 40.0, 80.0, 20.0]
[[metric]]
kind = "transmission_min"
[[metric]]
kind = "torque_peak"
[[metric]]
kind = "torque_rms"
[[metric]]
kind = "power_mean"
[[metric]]
kind = "reaction_peak"
[[metric]]
kind = "speed_fluctuation"
"""


def takeup_study(samples: int, verify: str = "none", metrics: str | None = None) -> spec.Study:
    """The shipped take-up tolerance study with ``samples`` variants, ``metrics`` (default all)."""
    text = (ROOT / "studies" / "takeup_tolerance.toml").read_text()
    head = text.partition("[[metric]]")[0]
    head = head.replace("samples = 1000", f"samples = {samples}")
    from mjlink.analysis.metrics import Metric

    extra = "".join(
        f'\n[[metric]]\nkind = "{k}"\n' for k in ("shaking_force_peak", "shaking_moment_peak") if k in Metric.types
    )
    body = (metrics if metrics is not None else ALL_METRICS) + extra
    return spec.parse(head + body + f'\n[verify]\nmujoco = "{verify}"\n', ROOT / "studies" / "bench.toml")


def bench_reference(variants: int = 10_000, single: int = 100) -> list[Row]:
    """Reference throughput: vectorized across variants against one variant at a time, and
    the 10,000-variant run with every metric on 2 cores and in one process."""
    st = takeup_study(variants)
    values = st.values()
    a = st.per_turn
    tasks.reference_chunk(st, values[:8])  # imports and caches out of the timing
    w1, c1 = _timed(lambda: [tasks.reference_chunk(st, values[i : i + 1]) for i in range(single)])
    n = min(variants, 1024)
    wv, cv = _timed(lambda: [tasks.reference_chunk(st, values[i : i + 256]) for i in range(0, n, 256)])
    rows: list[Row] = [
        (
            f"reference, one variant at a time ({single} variants x {a} angles, all metrics)",
            f"{w1:.2f}",
            f"{c1:.2f}",
            f"{single * a / c1:,.0f} variant-angles per CPU s",
        ),
        (
            f"reference, 256 variants per batch ({n} variants x {a} angles)",
            f"{wv:.2f}",
            f"{cv:.2f}",
            f"{n * a / cv:,.0f} variant-angles per CPU s = {(n * a / cv) / (single * a / c1):.1f} x one at a time",
        ),
    ]
    box: dict[str, object] = {}
    wi, ci = _timed(lambda: box.setdefault("in", engine.run(st)))
    wd, _ = _timed(lambda: box.setdefault("dask", _on_cluster(st, 2)))
    o_in, o_d = box["in"], box["dask"]
    assert isinstance(o_in, engine.Outcome) and isinstance(o_d, engine.Outcome)
    same = all(np.array_equal(o_in.columns[k], o_d.columns[k], equal_nan=True) for k in o_in.columns)
    ref = o_d.timing["reference"]
    rows += [
        (
            f"{variants} variants x {a} angles, {len(st.columns)} metric columns, in process",
            f"{wi:.2f}",
            f"{ci:.2f}",
            f"{variants * a / wi:,.0f} variant-angles/s",
        ),
        (
            f"{variants} variants x {a} angles, {len(st.columns)} metric columns, Dask 2 workers",
            f"{wd:.2f}",
            "",
            f"reference stage {ref:.2f} s after the cluster's start ({o_d.timing['cluster start']:.2f} s); "
            f"{'bit-identical' if same else 'DIFFERENT'} to in process",
        ),
    ]
    return rows


def bench_study(samples: int = 1000, repeat: int = 2) -> list[Row]:
    """The shipped tolerance study (MuJoCo verifies every variant): in process vs Dask,
    interleaved ``repeat`` times (the fastest of each counts: a shared machine's busy spell
    then hits both alike rather than whichever ran second)."""
    st = spec.load(ROOT / "studies" / "takeup_tolerance.toml")
    if samples != st.samples:
        st = dataclasses.replace(st, samples=samples)
    best: dict[str, tuple[float, float, engine.Outcome]] = {}
    for _ in range(repeat):
        for key, workers in (("in", 0), ("dask", 2)):
            box: list[engine.Outcome] = []
            w, c = _timed(lambda workers=workers, box=box: box.append(_on_cluster(st, workers)))
            if key not in best or w < best[key][0]:
                best[key] = (w, c, box[0])
    wi, ci, o_in = best["in"]
    wd, _, o_d = best["dask"]
    same = all(np.array_equal(o_in.columns[k], o_d.columns[k], equal_nan=True) for k in o_in.columns)
    mj = max(abs(np.nanmax(o_in.mujoco[k]) - np.nanmax(o_d.mujoco[k])) for k in ("position_error", "loop_gap"))

    def note(o: engine.Outcome) -> str:
        t = o.timing
        return (
            f"{int((o.verified == 1).sum())}/{len(o.values)} agree; reference {t['reference']:.1f} s, "
            f"MuJoCo {t['mujoco']:.1f} s"
        )

    return [
        (f"tolerance study, {samples} variants, MuJoCo on all, in process", f"{wi:.2f}", f"{ci:.2f}", note(o_in)),
        (
            f"tolerance study, {samples} variants, MuJoCo on all, Dask 2 workers",
            f"{wd:.2f}",
            "",
            note(o_d) + f"; {wd / wi:.2f} x in process (cluster start {o_d.timing['cluster start']:.1f} s); "
            f"reference {'bit-identical' if same else 'DIFFERENT'}, MuJoCo worst within {mj * 1e3:.1g} nm",
        ),
    ]


PLAN_LIMIT_S = 120.0  # shipped studies whose plan says more are only planned, not run


def _command(args: list[str], out: Path) -> tuple[float, float, str]:
    """Wall and CPU seconds (the command's process and its children: a local cluster's
    workers) of ``python -m mjlink ARGS --out OUT``, and its stderr."""
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t = time.perf_counter()
    done = subprocess.run(
        [sys.executable, "-m", "mjlink", *args, "--out", str(out)], capture_output=True, text=True, env=env
    )
    wall = time.perf_counter() - t
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if done.returncode:
        raise RuntimeError(f"mjlink {' '.join(args)}: exit {done.returncode}: {done.stderr.strip()[-400:]}")
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu, done.stderr


def _planned_seconds(stderr: str) -> float:
    """The seconds of a plan's 'time about 45 s' ('about 3 min', '2.9 h')."""
    m = re.search(r"time about ([0-9.]+) (s|min|h|days)\b", stderr)
    if m is None:
        raise RuntimeError(f"no time in the plan: {stderr.strip()[:300]}")
    return float(m.group(1)) * {"s": 1.0, "min": 60.0, "h": 3600.0, "days": 86400.0}[m.group(2)]


def bench_plan(limit: float = PLAN_LIMIT_S, names: list[str] | None = None) -> list[Row]:
    """``study NAME --dry-run``'s time against the study's own, on the shipped studies.

    Each study is planned (``--dry-run``), and run (``--no-plots``) when its plan says at most
    ``limit`` seconds. The study's measured time is its own clock (summary.json's ``timing_s``:
    its work and a local cluster's start, what the plan estimates); the run's wall time less the
    dry run's is given beside it (both import, read the study and calibrate, but their
    calibrations may differ by seconds). The ratio is planned / measured: within 2x either way
    is the goal. An optimization's estimate lies between its whole budget and its runs on a smooth bowl
    (mjlink/study/settle.py): the row also gives the evaluations made (the summary's) against
    the plan's expected ones, which tells the plan's rates apart from the search's length."""
    rows: list[Row] = []
    for f in sorted((ROOT / "studies").glob("*.toml")):
        name = f.stem
        if names and name not in names:
            continue
        with tempfile.TemporaryDirectory() as tmp:
            dw, _, err = _command(["study", name, "--dry-run"], Path(tmp) / "dry")
            planned = _planned_seconds(err)
            if planned > limit:
                rows.append((f"plan of {name}", "", "", f"planned {planned:.3g} s: not run (above {limit:g} s)"))
                continue
            rw, rc, _ = _command(["study", name, "--no-plots"], Path(tmp) / "run")
            summary = json.loads((Path(tmp) / "run" / f"{name}-study" / "summary.json").read_text())
        # The run's own clock from its plan's end (summary.json): the wall time less the dry
        # run's also holds the difference of the two plans' calibrations, which vary with the
        # variants they happen to time.
        clock = summary.get("timing_s", {})
        own = clock["total"] + clock.get("cluster start", 0.0) if "total" in clock else None
        measured = max(own if own else rw - dw, 1e-3)
        note = (
            f"planned {planned:.3g} s, measured {measured:.3g} s (the run's own total; run {rw:.3g} - dry run "
            f"{dw:.3g} = {rw - dw:.3g}): ratio {planned / measured:.2f}"
        )
        expected = re.search(r"for about ([0-9,]+) variants", err)
        if "evaluations" in summary and expected:  # an optimization: an estimate within a bracket
            done, guess = summary["evaluations"], int(expected.group(1).replace(",", ""))
            note += (
                f"; {done:,} evaluations made, {guess:,} expected (ratio {guess / done:.2f}): at the plan's rate "
                f"{planned * done / guess:.3g} s, ratio {planned * done / guess / measured:.2f}"
            )
        rows.append((f"plan of {name}", f"{rw:.2f}", f"{rc:.2f}", note))
    return rows


SCATTER_GOAL_S = 3.0  # CPU seconds for the scatter matrix of 10,000 variants


def bench_scatter(variants: int = 10_000, repeat: int = 3) -> list[Row]:
    """The study's scatter matrix of ``variants`` variants (7 parameters, 7 metrics: 6 x 6
    panels drawn), drawn and written ``repeat`` times after one warm-up: the best wall and CPU
    seconds against its goal."""
    import tempfile

    from mjlink.plotting import study as sp

    rng = np.random.default_rng(0)
    params = [
        sp.Column(
            f"construct.P{i}.length_a", f"l{i} (construct.P{i}.length_a)", "mm", 20 + 0.05 * rng.normal(size=variants)
        )
        for i in range(7)
    ]
    feasible = rng.random(variants) > 0.1
    metrics = [
        sp.Column(f"metric_{k}", f"metric {k}", "mm", np.where(feasible, 40 + 2 * (params[k].values - 20), np.nan))
        for k in range(7)
    ]
    verified = np.full(variants, -1, dtype=np.int8)
    verified[:60:2] = 1
    times = []
    with tempfile.TemporaryDirectory() as tmp:
        for _ in range(repeat + 1):
            times.append(_timed(lambda: sp.scatter_matrix("bench", params, metrics, feasible, verified, Path(tmp))))
    wall, cpu = min(t[0] for t in times[1:]), min(t[1] for t in times[1:])
    verdict = "within" if cpu <= SCATTER_GOAL_S else "OVER"
    return [
        (
            f"scatter matrix, {variants} variants (6 x 6 panels)",
            f"{wall:.2f}",
            f"{cpu:.2f}",
            f"best of {repeat}; {verdict} the {SCATTER_GOAL_S:g} s goal",
        )
    ]


def main(argv: list[str] | None = None) -> None:
    """Run every section and print one table."""
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--quick", action="store_true", help="a small run (40 variants) to check that it works")
    p.add_argument("--variants", type=int, help="variants to verify (default 1000, --quick 40)")
    p.add_argument("--threads", type=int, default=2, help="rollout's threads for the verification (default 2)")
    p.add_argument(
        "--plan",
        nargs="*",
        metavar="STUDY",
        help=f"only the plans against the runs (bench_plan): the shipped studies named, or every one planned "
        f"at most --plan-limit s (default {PLAN_LIMIT_S:g})",
    )
    p.add_argument("--plan-limit", type=float, default=PLAN_LIMIT_S, help="seconds above which a study is not run")
    a = p.parse_args(argv)
    n = a.variants or (40 if a.quick else 1000)
    # The machine may be shared: a busy core halves a 2-thread rate without any fault of its own.
    load = os.getloadavg()[0]
    if a.plan is not None:
        _table(load, bench_plan(a.plan_limit, a.plan or None))
        return
    rows = bench_reference(500 if a.quick else 10_000, single=20 if a.quick else 100)
    rows += bench_rollout(20 if a.quick else 200, repeat=1 if a.quick else 3)
    rows += bench_verify(n, a.threads)
    rows += bench_study(40 if a.quick else 1000, repeat=1 if a.quick else 2)
    rows += bench_scatter(repeat=1 if a.quick else 3)
    _table(load, rows)


def _table(load: float, rows: list[Row]) -> None:
    width = max(len(r[0]) for r in rows)
    print(f"load average before the runs: {load:.2f} on {os.cpu_count()} cores")
    print(f"{'':<{width}}  {'wall s':>8}  {'CPU s':>8}  note")
    for what, wall, cpu, note in rows:
        print(f"{what:<{width}}  {wall:>8}  {cpu:>8}  {note}")


if __name__ == "__main__":
    main()
