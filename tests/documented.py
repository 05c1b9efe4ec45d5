"""Values the user guide promises, read from the guide's own pages, for the tests to hold the
program to: the thresholds of docs/verification.md's table "Every threshold".

A test compares with these, never with ``mjlink.compare``'s constants: a constant loosened in
the program then fails test_thresholds (which pins each one to this table) and every test that
holds a run to it."""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
VERIFICATION = ROOT / "docs" / "verification.md"

# The table's "quantity" cells and the names the tests (and report.json's thresholds) use.
QUANTITIES = {
    "point position": "position_um",
    "point velocity": "velocity_rel",
    "point acceleration": "acceleration_rel",
    "loop gap": "loop_um",
    "thread length": "thread_um",
    "crank speed held": "speed_held_rel",
    "crank speed omega": "omega_rel",
    "samples": "min_samples",
    "driving torque": "torque_rel",
    "pair reactions": "force_rel",
    "frame's shaking force and moment": "shaking_rel",
    "coefficient of speed fluctuation delta": "steady_delta_rel",
}
NUMBER = re.compile(r"[0-9]+(?:\.[0-9]+)?(?:e[-+]?[0-9]+)?")


def first_number(cell: str) -> float:
    """The first number written in a table cell ('0.1 um', '2e-5 of ...', 'at least 100')."""
    m = NUMBER.search(cell)
    if m is None:
        raise ValueError(f"no number in {cell!r}")
    return float(m.group())


def table_after(path: Path, heading: str) -> list[list[str]]:
    """The body rows (cells stripped) of the first Markdown table after the line ``heading``."""
    lines = path.read_text(encoding="utf-8").splitlines()
    start = lines.index(heading)
    rows: list[list[str]] = []
    for line in lines[start + 1 :]:
        if line.startswith("|"):
            rows.append([c.strip() for c in line.strip().strip("|").split("|")])
        elif rows:
            break
    return [r for r in rows[1:] if not set("".join(r)) <= set("-: ")]  # no header, no rule


def row_starting(path: Path, first: str) -> list[str]:
    """The cells after the first of the one table row of ``path`` whose first cell is ``first``."""
    found = [
        [c.strip() for c in line.strip().strip("|").split("|")]
        for line in path.read_text(encoding="utf-8").splitlines()
        if line.startswith(f"| {first} |")
    ]
    if len(found) != 1:
        raise ValueError(f"{path.name}: {len(found)} rows start with {first!r}, not one")
    return found[0][1:]


def _thresholds() -> dict[str, float]:
    rows = table_after(VERIFICATION, "## Every threshold")
    out = {QUANTITIES[quantity]: first_number(limit) for quantity, _run, limit in rows}
    missing = set(QUANTITIES.values()) - set(out)
    if missing:
        raise ValueError(f"docs/verification.md, Every threshold: no row for {sorted(missing)}")
    return out


THRESHOLDS = _thresholds()
