"""CI: every figure of every shipped mechanism and study, checked as a reader sees it.

Runs ``simulate`` (and ``steady`` where the file has a motor) on each shipped mechanism and
``study`` on each shipped study file (its budget cut to a few candidates: the figures are the
same kinds, drawn from the study's own parameters, metrics and titles) as the command line
does, and lists what :func:`mjlink.plotting.style.figure_defects` finds on every figure: an
axis without a unit in brackets, overlapping texts or tick labels, a text off the canvas. The
figures are checked where the command draws them (``simulate``'s forked plot workers), right
after each is written (:class:`mjlink.plotting.style.examine`): the figures checked are the
ones written. Exit status 1 if any figure has a defect or a run fails. Run:
``python .ci/check_figures.py [NAME ...]``.
"""

from __future__ import annotations

import contextlib
import io
import math
import re
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from mjlink.sim.gl import ensure_gl_backend

ensure_gl_backend()

from matplotlib.figure import Figure  # noqa: E402

from mjlink import validation  # noqa: E402
from mjlink.cli import main  # noqa: E402
from mjlink.model import catalogue  # noqa: E402
from mjlink.plotting import style  # noqa: E402

# At most this many of each (a study keeps its own smaller numbers). The head's eyelet
# take-up needs a larger population to find a feasible design at all.
CAPS = {"samples": 12, "population": 24, "generations": 4, "seeds": 1, "polish_evaluations": 12, "count": 1}
# Where that finds no feasible design, the study's own population over a few more generations,
# one run and no polish: the shipped eyelet take-up's search (4 runs of up to 300 generations
# of 80, robust over 8 deviation sets) would take hours, this one minutes.
WIDER = {"generations": 12, "seeds": 1, "polish_evaluations": 0, "count": 1}
# Where that finds none either, one run of the study's own population and generations without
# its polish: no run of the lockstitch head's sized take-up meets its shortfall bound before
# its 25th generation.
WHOLE = {"seeds": 1, "polish_evaluations": 0, "count": 1}
OPTIMIZE_BUDGET = ("population", "generations", "seeds", "polish_evaluations")


def cut_budget(text: str, folder: Path, caps: dict[str, int] = CAPS) -> str:
    """A study file's text with its budget capped (:data:`CAPS`) and a relative mechanism
    path made absolute (the copy is written elsewhere). A single-objective optimization's budget
    keys the file leaves at their defaults (3 runs, a polish of 2,000 evaluations a parameter)
    are written in at their caps."""
    levels = [int(n) for n in re.findall(r"(?m)^levels\s*=\s*(\d+)", text)]
    for key, most in caps.items():
        if key == "samples" and levels:
            # Crossed conditions: the samples must stay a multiple of their combinations.
            most = max(most - most % math.prod(levels), math.prod(levels))
        text = re.sub(
            rf"(?m)^({key}\s*=\s*)(\d+)", lambda m, most=most: m.group(1) + str(min(int(m.group(2)), most)), text
        )
    # A Pareto search runs once and polishes each point of its front: left as the file has it.
    single = not re.search(r"(?m)^pareto\s*=", text)
    absent = "".join(
        f"{k} = {caps[k]}\n" for k in OPTIMIZE_BUDGET if single and k in caps and not re.search(rf"(?m)^{k}\s*=", text)
    )
    text = re.sub(r"(?m)^\[optimize\]\n", lambda m: m.group(0) + absent, text, count=1)
    return re.sub(r'(?m)^(mechanism\s*=\s*")(\.\.?/)', lambda m: m.group(1) + str(folder) + "/" + m.group(2), text)


def _defects(name: str, fig: Figure) -> list[str]:
    return style.figure_defects(fig)


def run(args: list[str]) -> tuple[int, list[tuple[str, str]], str]:
    """``python -m mjlink ARGS`` here, every figure checked where it is drawn: its status,
    (figure, defect) pairs and its last line on stderr."""
    err = io.StringIO()
    with style.examine(_defects) as figs, contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(err):
        status = main(args)
    found = [(name, d) for name, defects in figs for d in defects]
    if status == 0 and not figs:  # every run here draws: none examined is the check broken
        found.append(("(none)", "no figure was examined"))
    return status, found, (err.getvalue().strip().splitlines() or [""])[-1]


def report(label: str, status: int, found: list[tuple[str, str]], last: str) -> bool:
    """Print one run's verdict and its defects; True if it failed."""
    failed = status != 0 or bool(found)
    print(f"{label}: {'FAILED' if failed else 'ok'}" + (f" ({last})" if status else ""))
    for fig, d in found:
        print(f"  {fig}: {d}")
    return failed


def main_check(names: list[str]) -> int:
    mechs = catalogue.names()
    studies = sorted(p.stem for p in catalogue.STUDIES_DIR.glob("*.toml"))
    bad = 0
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp)
        for name in names or [*mechs, *studies]:
            if name in mechs:
                args = ["simulate", name, "--out", str(out / "runs"), "--no-video"]
                mech = validation.get(name)
                if mech.steady is not None or mech.dynamics.motor is not None:
                    # steady.png is the steady command's own figure: checked too.
                    bad += report(f"{name} (steady)", *run(["steady", name, "--out", str(out / "steady")]))
            else:
                copy = out / f"{name}.toml"
                copy.write_text(cut_budget((catalogue.STUDIES_DIR / f"{name}.toml").read_text(), catalogue.STUDIES_DIR))
                args = ["study", str(copy), "--out", str(out / "studies"), "--workers", "0"]
            status, found, last = run(args)
            # Where the cut budget finds nothing to draw, a wider one (WIDER), then the study's own
            # (WHOLE), on the cores.
            for label, caps in (("wider", WIDER), ("whole", WHOLE)):
                if status != 0 and "no feasible design" in last:
                    again = out / label / f"{name}.toml"
                    again.parent.mkdir(exist_ok=True)
                    again.write_text(
                        cut_budget((catalogue.STUDIES_DIR / f"{name}.toml").read_text(), catalogue.STUDIES_DIR, caps)
                    )
                    status, found, last = run(["study", str(again), "--out", str(out / f"{label}-runs")])
            bad += report(name, status, found, last)
    print(f"{bad} run(s) with a defect or an error" if bad else "every figure passes")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main_check(sys.argv[1:]))
