"""What a head study's designs cost to evaluate, this checkout against another revision, side by
side in one run.

A head study scores each design's timing and thread balance on the reference; the loop's legs
over the bobbin case (``mjlink/analysis/loop.py``) are most of that. This script scores the
first generation of a shipped head study (the designs its search starts from, robust samples
included) in fresh processes, alternately with this checkout and with ``--vs REV`` (a git
worktree of that revision in a temporary folder), and prints the CPU seconds of each and the
ratio of their medians. Both score the same designs; the scores themselves are compared too
(the largest difference of the objective, which a fix of the legs may move).

Run: ``python bench/bench_balance.py --vs REV [--study NAME] [--designs N] [--repeat K]``.
"""

from __future__ import annotations

import argparse
import json
import math
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

SCORE = """
import json, sys, time
import numpy as np
from mjlink.study import spec
from mjlink.study.optimize import Evaluator
from mjlink.study.search import first_generation
st = spec.load(sys.argv[1])
X = first_generation(st, st.optimize.seed, int(sys.argv[2]))
with Evaluator(st, None, 1) as ev:
    ev.score(X[:1])  # imports and caches outside the clock
    t = time.process_time()
    s = ev.score(X)
    cpu = time.process_time() - t
print(json.dumps({"cpu": cpu, "objective": np.asarray(s.objective, dtype=float).tolist()}))
"""


def score(tree: Path, study: str, designs: int) -> dict:
    """CPU seconds and objectives of the first ``designs`` designs of ``study`` with the code in ``tree``."""
    out = subprocess.run(
        [sys.executable, "-c", SCORE, study, str(designs)],
        cwd=tree,
        check=True,
        capture_output=True,
        text=True,
        env={"PYTHONPATH": str(tree), "PATH": "/usr/bin:/bin", "HOME": str(Path.home())},
    )
    result: dict = json.loads(out.stdout.strip().splitlines()[-1])
    return result


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--vs", required=True, help="the revision to compare with (a git revision)")
    ap.add_argument("--study", default="lockstitch_head_eyelets", help="a shipped head study")
    ap.add_argument("--designs", type=int, default=16, help="designs of its first generation")
    ap.add_argument("--repeat", type=int, default=3, help="pairs of runs (default 3)")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        base = Path(tmp) / "base"
        subprocess.run(
            ["git", "worktree", "add", "--detach", str(base), args.vs], cwd=ROOT, check=True, capture_output=True
        )
        try:
            here, there = [], []
            for _ in range(args.repeat):
                a, b = score(ROOT, args.study, args.designs), score(base, args.study, args.designs)
                here.append(a["cpu"])
                there.append(b["cpu"])
                pairs = list(zip(a["objective"], b["objective"], strict=True))
                diff = max((abs(x - y) for x, y in pairs if math.isfinite(x) and math.isfinite(y)), default=0.0)
                odd = sum(math.isfinite(x) != math.isfinite(y) for x, y in pairs)
                print(
                    f"this checkout {a['cpu']:.2f} s CPU, {args.vs} {b['cpu']:.2f} s CPU; finite objectives differ by up to {diff:.3g}, {odd} finite in one only",
                    flush=True,
                )
        finally:
            subprocess.run(["git", "worktree", "remove", "--force", str(base)], cwd=ROOT, check=True)
    m, n = statistics.median(here), statistics.median(there)
    print(f"median of {args.repeat}: this checkout {m:.2f} s, {args.vs} {n:.2f} s; {args.vs} / this: {n / m:.2f}")


if __name__ == "__main__":
    main()
