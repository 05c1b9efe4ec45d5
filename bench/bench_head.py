"""What ``simulate lockstitch_head`` costs beside ``simulate takeup``, side by side in one run.

The head (eleven links, two gear couplings, four loops, a timing diagram) must cost at most three
times the take-up's CPU. Both commands run as a user types them (video and every figure), as
fresh processes, interleaved pair by pair so that both see the same spells of the shared
machine; the CPU of each (user + system of the process and its children) and the ratio of the
medians are printed, with the wall seconds beside them.

Run: ``python bench/bench_head.py [--repeat N]`` (default 5 pairs).
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def run(name: str, out: Path) -> tuple[float, float]:
    """CPU and wall seconds of ``python -m mjlink simulate NAME`` into ``out``."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    wall = time.perf_counter()
    subprocess.run(
        [sys.executable, "-m", "mjlink", "simulate", name, "--out", str(out), "--force"],
        cwd=ROOT,
        check=True,
        capture_output=True,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
    )
    wall = time.perf_counter() - wall
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime), wall


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5, help="pairs of runs (default 5)")
    n = ap.parse_args().repeat
    cpu: dict[str, list[float]] = {"takeup": [], "lockstitch_head": []}
    wall: dict[str, list[float]] = {"takeup": [], "lockstitch_head": []}
    with tempfile.TemporaryDirectory() as tmp:
        for name in cpu:  # a first run of each, not counted: files cached, folders made
            run(name, Path(tmp))
        for i in range(n):
            for name in cpu if i % 2 == 0 else reversed(list(cpu)):
                c, w = run(name, Path(tmp))
                cpu[name].append(c)
                wall[name].append(w)
                print(f"pair {i + 1}: {name:16s} {c:6.2f} s CPU {w:6.2f} s wall", flush=True)
    med = {k: statistics.median(v) for k, v in cpu.items()}
    medw = {k: statistics.median(v) for k, v in wall.items()}
    for k in cpu:
        print(f"median of {n}: {k:16s} {med[k]:6.2f} s CPU {medw[k]:6.2f} s wall")
    ratio = med["lockstitch_head"] / med["takeup"]
    print(f"lockstitch_head / takeup CPU: {ratio:.2f} (goal: at most 3)")


if __name__ == "__main__":
    main()
