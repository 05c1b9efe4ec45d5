"""CPU of the test suite, as the README's test command runs it. Run:
``python bench/bench_tests.py [--runs N] [--baseline REV] [--slowest K]``.

* The suite, ``python -m pytest`` (the project's own options: one xdist worker per core),
  ``--runs`` times: the CPU seconds of every process it started (user + system, from
  ``getrusage(RUSAGE_CHILDREN)``) and the wall seconds.
* ``--baseline REV``: the same suite of another commit (a temporary ``git worktree``, its
  tests importing its own ``mjlink``), run alternately with this checkout's, run by run, so
  that both see the same spells of the shared machine; the ratio of the medians.
* ``--slowest K``: one more run of this checkout's suite in one process (no xdist, so that a
  test's CPU is its own and its children's), and the K tests that cost the most CPU. A test
  that first uses a fixture shared by several tests carries the fixture's cost.

The suite runs with Python's bytecode cache, as the command runs on any machine after its first
run: each tree is compiled first (``compileall``) and a ``PYTHONDONTWRITEBYTECODE`` of this
environment is not passed on (without the cache every process the suite starts compiles mjlink
anew, about a tenth of the suite's CPU).

The machine is shared: compare CPU seconds, and ratios measured side by side in one run.
"""

from __future__ import annotations

import argparse
import os
import resource
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PLUGIN = "_test_cpu"  # bench/_test_cpu.py, loaded with -p from this folder


def children_cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def suite(where: Path, *extra: str, env: dict[str, str] | None = None) -> tuple[float, float, str]:
    """CPU and wall seconds of one run of the suite in ``where``, and its last line."""
    base = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    subprocess.run(
        [sys.executable, "-m", "compileall", "-q", "mjlink", "tests", "bench"], cwd=where, check=True, env=base
    )
    cpu, wall = children_cpu(), time.perf_counter()
    r = subprocess.run(
        [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", *extra],
        cwd=where,
        capture_output=True,
        text=True,
        env={**base, "PYTHONPATH": str(where), **(env or {})},
    )
    cpu, wall = children_cpu() - cpu, time.perf_counter() - wall
    last = (r.stdout.strip().splitlines() or ["(no output)"])[-1]
    if r.returncode != 0:
        failed = [line for line in r.stdout.splitlines() if line.startswith(("FAILED", "ERROR"))]
        raise SystemExit(f"the suite in {where} failed: {last}\n" + "\n".join(failed))
    return cpu, wall, last


def slowest(k: int) -> list[str]:
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "tests.tsv"
        env = {"PYTHONPATH": f"{ROOT}{os.pathsep}{ROOT / 'bench'}", "MJLINK_TEST_CPU": str(out)}
        suite(ROOT, "-n0", "-p", PLUGIN, env=env)
        rows = [line.split("\t") for line in out.read_text().splitlines()]
    rows.sort(key=lambda r: -float(r[0]))
    return [f"{float(c):7.2f} {float(w):7.2f}  {name}" for c, w, name in rows[:k]]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--runs", type=int, default=1)
    ap.add_argument("--baseline", metavar="REV", help="another commit's suite, run alternately")
    ap.add_argument("--slowest", type=int, default=0, metavar="K")
    args = ap.parse_args()
    # The suites run as a terminal's foreground job runs them, whoever started this bench: a
    # shell's background job has SIGINT ignored, and the children would inherit that (the
    # tests of Ctrl-C need it at its default).
    signal.signal(signal.SIGINT, signal.default_int_handler)
    trees = {"this checkout": ROOT}
    with tempfile.TemporaryDirectory() as tmp:
        if args.baseline:
            base = Path(tmp) / "baseline"
            subprocess.run(
                ["git", "-C", str(ROOT), "worktree", "add", "-q", "--detach", str(base), args.baseline], check=True
            )
            trees[args.baseline] = base
        try:
            got: dict[str, list[tuple[float, float]]] = {name: [] for name in trees}
            for i in range(args.runs):
                for name, where in trees.items():
                    cpu, wall, last = suite(where)
                    got[name].append((cpu, wall))
                    print(f"run {i + 1} {name}: {cpu:.1f} s CPU, {wall:.1f} s wall ({last})", flush=True)
        finally:
            if args.baseline:
                subprocess.run(["git", "-C", str(ROOT), "worktree", "remove", "--force", str(trees[args.baseline])])
    med = {name: (statistics.median(c for c, _ in v), statistics.median(w for _, w in v)) for name, v in got.items()}
    for name, (cpu, wall) in med.items():
        print(f"median of {args.runs}, {name}: {cpu:.1f} s CPU, {wall:.1f} s wall")
    if args.baseline:
        here, base = med["this checkout"], med[args.baseline]
        print(f"CPU ratio, this checkout / {args.baseline}: {here[0] / base[0]:.3f}")
    if args.slowest:
        print(f"the {args.slowest} tests that cost the most CPU (s CPU, s wall), in one process:")
        print("\n".join(slowest(args.slowest)))


if __name__ == "__main__":
    main()
