"""The needle thread under tension on the shipped lockstitch head: its published comparisons and
its cost beside ``simulate takeup``.

Prints, with the shipped head's file and the published defaults, the shipped head's column of
docs/head.md's table of published measurements (The shipped take-up, sized for the head's
loop): the peak and where it is, the local
peaks of the stitch, the hook point's upper points and where the check spring leaves its rest, the peak and the local
peaks without the check spring, with 1.5x the needle tension, with twice
the thread's elongation at break, with the last stitch giving 0.05, 0.1 and 0.2 mm/N into the
fabric, with 2, 3 and 4 mm stitches, with 3 mm more spring travel, and
the peak on a step 2.5x finer; then MuJoCo's thread (a tendon that only pulls, the spring a
sprung slide) against the reference's anchored thread with friction off, and the reference with
friction beside it. Then the cost: the CPU of the tension of one stitch (to its
periodic state; the head's timing measured once, before), as the median of ``--repeat`` runs,
and the CPU of ``python -m mjlink simulate takeup --no-video --no-plots`` in a fresh process,
interleaved with them, and their ratio.

With ``--study``, only a 1,000-variant tension study (needle tension x check-spring rate x
speed, on the 2 workers of a local cluster), its wall time against ``simulate takeup``'s CPU,
interleaved, and the periods its heads settled in.

With ``--vs REV`` too, the same study from a git worktree of that revision, alternately with
this checkout, their wall times' ratio and their results' largest differences.

With ``--head FILE``, the comparisons are that head's (the head with the paper's take-up:
``mechanisms/examples/lockstitch_head_paper_takeup.toml``).

Run: ``python bench/bench_tension.py [--repeat N] [--head FILE] [--study [--vs REV]]`` (default 5).
"""

from __future__ import annotations

import argparse
import collections
import csv
import dataclasses
import itertools
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from mjlink.analysis.tension import NeedleTension, needle_tension
from mjlink.analysis.timing import head_timing
from mjlink.model import mechanism
from mjlink.model.catalogue import shipped
from mjlink.model.tension import DEFAULTS, GF

ROOT = Path(__file__).resolve().parent.parent


def _peaks(t: NeedleTension) -> list[tuple[float, float]]:
    """(deg, gf) of the stitch's local peaks of the largest tension, above 5 gf."""
    top = t.tension.max(axis=0)
    n = len(top)
    return [
        (float(t.theta[i]), float(top[i] / GF))
        for i in range(n)
        if top[i] > top[i - 1] and top[i] >= top[(i + 1) % n] and top[i] > 5 * GF
    ]


def _row(label: str, t: NeedleTension) -> str:
    zone, at = t.peak_at
    return (
        f"{label:34s} peak {t.peak:6.4f} N ({t.peak / GF:5.1f} gf) in {zone} at {at:6.2f} deg; "
        f"per stitch {t.per_stitch * 1e3:.5f} mm; spring up to {t.spring.max() * 1e3:4.2f} mm; "
        f"{t.cycles} stitches{'' if t.converged else ' NOT periodic'}"
    )


def comparisons(path: Path | None = None) -> None:
    """The head's column of docs/head.md's table of published measurements: the shipped head,
    or the head file at ``path`` (the head with the paper's take-up)."""
    mech = mechanism.load(path or shipped("mechanisms") / "lockstitch_head.toml")
    head = head_timing(mech)
    base = needle_tension(mech, head)
    print(_row("shipped head, defaults" if path is None else f"{mech.name}, defaults", base))
    for z, T in zip(base.zones, base.tension, strict=True):
        print(f"    {z:12s} up to {T.max() / GF:6.1f} gf at {base.theta[int(np.argmax(T))]:6.2f} deg")
    print("    local peaks (deg, gf): " + ", ".join(f"({a:.1f}, {g:.0f})" for a, g in _peaks(base)))
    assert mech.timing is not None
    hp = head.positions[mech.timing.roles["hook_point"]][:, 1]
    n = len(hp)
    tops = [float(head.theta[i]) for i in range(n) if hp[i] >= hp[i - 1] and hp[i] >= hp[(i + 1) % n]]
    x = base.spring
    starts = [float(base.theta[i]) for i in range(len(x)) if x[i] > 0.0 and x[i - 1] == 0.0]
    ends = [float(base.theta[i]) for i in range(len(x)) if x[i] == 0.0 and x[i - 1] > 0.0]
    print(
        "    the hook point's upper point at (deg): "
        + ", ".join(f"{a:.2f}" for a in tops)
        + "; the check spring leaves its rest at (deg): "
        + ", ".join(f"{a:.2f}" for a in starts)
        + "; comes back to it at (deg): "
        + ", ".join(f"{a:.2f}" for a in ends)
    )
    eye = head.positions[mech.timing.roles["needle_eye"]][:, 1]
    top = mech.timing.plate + mech.timing.fabric
    into = [float(head.theta[i]) for i in range(1, n) if eye[i - 1] > top >= eye[i]]
    print(
        f"    the needle point reaches the fabric at {head.events['needle point into the fabric, down']:.2f} deg, "
        "its eye at " + ", ".join(f"{a:.2f}" for a in into) + " deg"
    )
    bare = needle_tension(mech, head, spring=False)
    print(_row("without the check spring", bare))
    print("    local peaks (deg, gf): " + ", ".join(f"({a:.1f}, {g:.0f})" for a, g in _peaks(bare)))
    s = dataclasses.replace(DEFAULTS, needle_tension=1.5 * DEFAULTS.needle_tension)
    print(_row("1.5x the needle tension", needle_tension(mech, head, settings=s)))
    s = dataclasses.replace(DEFAULTS, elongation_at_break=2 * DEFAULTS.elongation_at_break)
    print(_row("twice the elongation at break", needle_tension(mech, head, settings=s)))
    for give in (0.05, 0.1, 0.2):
        s = dataclasses.replace(DEFAULTS, fabric_give=give * 1e-3)
        print(_row(f"the fabric giving {give:g} mm/N", needle_tension(mech, head, settings=s)))
    assert mech.balance is not None
    for mm in (2.0, 3.0, 4.0):
        m = dataclasses.replace(mech, balance=dataclasses.replace(mech.balance, stitch_length=mm * 1e-3))
        print(_row(f"{mm:g} mm stitch", needle_tension(m, head_timing(m))))
    m = dataclasses.replace(
        mech, balance=dataclasses.replace(mech.balance, check_spring_travel=mech.balance.check_spring_travel + 3e-3)
    )
    print(_row("3 mm more check-spring travel", needle_tension(m, head_timing(m))))
    print(_row("a step 2.5x finer (3,600 a stitch)", needle_tension(mech, head, samples=3600)))


def mujoco_comparison() -> None:
    """MuJoCo's tendon and sprung check spring against the reference's anchored thread, friction
    off (tests/test_tension.py holds it), and the reference with the file's friction beside."""
    from mjlink.sim.thread import run_thread

    mech = mechanism.load(shipped("mechanisms") / "lockstitch_head.toml")
    head = head_timing(mech)
    assert mech.thread is not None
    path = mech.thread
    L = sum(np.linalg.norm(head.positions[b] - head.positions[a], axis=1) for a, b in itertools.pairwise(path))
    held = float(L.max()) - 5e-3
    off = dataclasses.replace(DEFAULTS, friction=0.0)
    c0 = _cpu()
    mj = run_thread(mech, held, settings=off, cycles=3)
    print(
        f"MuJoCo, friction off: {_cpu() - c0:.2f} s CPU, timestep {mj.timestep:.3g} s, {len(mj.theta)} samples a stitch"
    )
    # The thread turns back round the spring's hook, which moves fast: the reference converges
    # only on fine steps (tests/test_tension.py holds 14,400).
    for samples in (1440, 7200, 14400, 57600):
        own = head if samples <= len(head.theta) else head_timing(mech, samples)
        ref = needle_tension(mech, own, settings=off, anchored=held, cycles=3, samples=samples)
        T = np.interp(mj.theta, ref.theta, ref.tension[0])
        x = np.interp(mj.theta, ref.theta, ref.spring)
        away = (x > 2e-4) & (mj.spring > 2e-4)
        print(
            f"  reference on {samples} steps a stitch: peak {ref.peak:.5f} N against MuJoCo's {mj.tension.max():.5f}; "
            f"tension within {np.abs(T - mj.tension).max() / mj.tension.max():.2%} of the peak; spring travel up to "
            f"{ref.spring.max() * 1e3:.3f} mm against {mj.spring.max() * 1e3:.3f}, within "
            f"{np.abs(x - mj.spring)[away].max() * 1e3:.3f} mm off its rest stop, {np.abs(x - mj.spring).max() * 1e3:.3f} mm "
            f"in all (MuJoCo's least {mj.spring.min() * 1e3:.3f} mm)"
        )
    on = needle_tension(mech, head, anchored=held, cycles=3)
    zone, at = on.peak_at
    print(
        f"  with the file's friction ({DEFAULTS.friction:g}): peak {on.peak:.4f} N in {zone} at {at:.1f} deg, the spring up to "
        f"{on.spring.max() * 1e3:.2f} mm"
    )


def _cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def _simulate_takeup(out: Path) -> float:
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    subprocess.run(
        [
            sys.executable,
            "-m",
            "mjlink",
            "simulate",
            "takeup",
            "--out",
            str(out),
            "--force",
            "--no-video",
            "--no-plots",
        ],
        cwd=ROOT,
        check=True,
        capture_output=True,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
    )
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def cost(repeat: int) -> None:
    mech = mechanism.load(shipped("mechanisms") / "lockstitch_head.toml")
    head = head_timing(mech)
    needle_tension(mech, head)  # warm: imports, caches
    one: list[float] = []
    takeup: list[float] = []
    with tempfile.TemporaryDirectory() as tmp:
        _simulate_takeup(Path(tmp))
        for _ in range(repeat):
            c0, w0 = _cpu(), time.perf_counter()
            t = needle_tension(mech, head)
            one.append(_cpu() - c0)
            print(
                f"tension: {one[-1]:.3f} s CPU ({time.perf_counter() - w0:.3f} s wall), {t.cycles} stitches", flush=True
            )
            takeup.append(_simulate_takeup(Path(tmp)))
            print(f"simulate takeup --no-video --no-plots: {takeup[-1]:.2f} s CPU", flush=True)
    a, b = statistics.median(one), statistics.median(takeup)
    print(f"median of {repeat}: tension {a:.3f} s CPU to its periodic state ({a / t.cycles:.3f} s a stitch); ")
    print(f"simulate takeup {b:.2f} s CPU; tension / simulate takeup: {a / b:.3f}")


STUDY = """[study]
mechanism = "lockstitch_head"
title = "1,000 heads: needle tension x check-spring rate x speed"
angles = 720

[sampling]
method = "grid"

[verify]
mujoco = "none"

[[parameter]]
path = "tension.needle_tension"
values = [1.0, 1.2, 1.4, 1.6, 1.8, 2.0, 2.2, 2.4, 2.6, 2.8]
[[parameter]]
path = "tension.spring_rate"
values = [0.01, 0.015, 0.02, 0.025, 0.03, 0.035, 0.04, 0.045, 0.05, 0.06]
[[parameter]]
path = "input.speed"
values = [157.08, 209.44, 261.8, 314.159, 366.52, 418.879, 471.24, 523.599, 575.96, 628.32]

[[metric]]
kind = "tension"
"""


def _study_run(tree: Path, f: Path, out: Path) -> tuple[float, Path]:
    """The wall time of ``mjlink study f`` run from the checkout ``tree``, and its results; the
    plan's estimate of its time is printed."""
    w0 = time.perf_counter()
    r = subprocess.run(
        [sys.executable, "-m", "mjlink", "study", str(f), "--out", str(out), "--no-plots"],
        cwd=tree,
        check=True,
        capture_output=True,
        text=True,
        env={**os.environ, "PYTHONPATH": str(tree)},
    )
    wall = time.perf_counter() - w0
    planned = next(
        (line.split("time about ")[1].split(";")[0] for line in r.stderr.splitlines() if "time about" in line), "?"
    )
    print(f"    its plan estimated {planned}", flush=True)
    return wall, out / "tension_1000-study" / "results.csv"


def _rows(results: Path) -> list[dict[str, str]]:
    return list(csv.DictReader(line for line in results.open() if not line.startswith("#")))


def study(repeat: int, vs: str | None) -> None:
    """A 1,000-variant tension study (the grid above: 1,500 to 6,000 stitches/min) on a local
    cluster of one worker a core, its wall time against ``simulate takeup``'s CPU, interleaved,
    and how its heads settled (their periods); with ``vs`` (a git revision), the same study
    from a worktree of that revision alternately, and how far their results lie apart."""
    walls: list[float] = []
    theirs: list[float] = []
    takeup: list[float] = []
    with tempfile.TemporaryDirectory() as tmp:
        f = Path(tmp) / "tension_1000.toml"
        f.write_text(STUDY)
        base = Path(tmp) / "base"
        if vs is not None:
            subprocess.run(
                ["git", "worktree", "add", "--detach", str(base), vs], cwd=ROOT, check=True, capture_output=True
            )
        try:
            _simulate_takeup(Path(tmp))
            for i in range(repeat):
                wall, results = _study_run(ROOT, f, Path(tmp) / f"out{i}")
                walls.append(wall)
                print(f"1,000-variant tension study: {wall:.1f} s wall", flush=True)
                if vs is not None:
                    wall, other = _study_run(base, f, Path(tmp) / f"base{i}")
                    theirs.append(wall)
                    print(f"the same from {vs}: {wall:.1f} s wall", flush=True)
                takeup.append(_simulate_takeup(Path(tmp)))
                print(f"simulate takeup --no-video --no-plots: {takeup[-1]:.2f} s CPU", flush=True)
            rows = _rows(results)
            if vs is not None:
                old = _rows(other)
                for col in ("tension_peak_N", "tension_per_stitch_mm", "tension_period"):
                    d = max(abs(float(x[col]) - float(y[col])) for x, y in zip(rows, old, strict=True))
                    print(f"largest difference of {col} from {vs}: {d:.3g}")
        finally:
            if vs is not None:
                subprocess.run(["git", "worktree", "remove", "--force", str(base)], cwd=ROOT, check=True)
    periods = collections.Counter(int(float(r["tension_period"])) for r in rows)
    a, b = statistics.median(walls), statistics.median(takeup)
    print(f"periods of the 1,000 heads (0: none in 80 stitches): {dict(sorted(periods.items()))}")
    print(
        f"median of {repeat}: study {a:.1f} s wall; simulate takeup {b:.2f} s CPU; study / simulate takeup: {a / b:.1f}"
    )
    if vs is not None:
        c = statistics.median(theirs)
        print(f"median of {repeat}: {vs} {c:.1f} s wall; {vs} / this checkout: {c / a:.2f}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5, help="runs of each for the cost (default 5)")
    ap.add_argument("--no-cost", action="store_true", help="only the comparisons")
    ap.add_argument("--study", action="store_true", help="only the 1,000-variant tension study's time")
    ap.add_argument("--vs", help="with --study: the same study from this git revision, alternately")
    ap.add_argument("--head", type=Path, help="the comparisons of this head file instead of the shipped head's")
    a = ap.parse_args()
    if a.study:
        study(a.repeat, a.vs)
        return
    comparisons(a.head)
    mujoco_comparison()
    if not a.no_cost:
        cost(a.repeat)


if __name__ == "__main__":
    main()
