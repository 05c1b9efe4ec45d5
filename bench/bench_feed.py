"""The fabric under the presser foot (mjlink.sim.feed) on the shipped lockstitch head: the
advance per stitch over a speed sweep, its change when the timestep is halved, the foot's lift,
and the cost of 20 stitches at the file's speed beside ``simulate takeup``.

Prints, for each speed, the advance of the last stitch of 8 (mm), the same at half the
timestep and their difference, the foot's largest gap above the fabric, and the geometric
advance (the dog's travel while its teeth are above the plate) for comparison; then, for the
fabric's mass, the same at 20 g and 100 g. Then the cost: the CPU of 20 stitches at the file's
speed (5,000 rpm), as the median of ``--repeat`` runs, and the CPU of ``python -m mjlink
simulate takeup --no-video --no-plots`` in a fresh process, interleaved with them.

Run: ``python bench/bench_feed.py [--repeat N]`` (default 5).
"""

from __future__ import annotations

import argparse
import dataclasses
import statistics
import tempfile
from pathlib import Path

import numpy as np
from bench_tension import _cpu, _simulate_takeup

from mjlink import reference
from mjlink.model import mechanism
from mjlink.model.catalogue import shipped
from mjlink.model.presser import FABRIC_DEFAULTS
from mjlink.sim import feed

SPEEDS = (300, 500, 1000, 2000, 3000, 4000, 5000, 6000)


def geometric(mech: mechanism.Mechanism) -> float:
    phi = mech.phi0 + np.linspace(0.0, mech.period, 72_001)
    tm = mech.timing
    assert tm is not None
    p = reference.solve(mech, phi).position(tm.roles["feed_dog"])
    up = (p[:-1, 1] > tm.plate) & (p[1:, 1] > tm.plate)
    return float(np.diff(p[:, 0])[up].sum())


def sweep(mech: mechanism.Mechanism) -> None:
    print(f"geometric advance (the dog's travel while its teeth are up): {geometric(mech) * 1e3:.4f} mm")
    assert mech.timing is not None
    default = FABRIC_DEFAULTS.piece(mech.timing.fabric)
    for piece in (default, 0.02, 0.1):  # kg: the piece the dog carries
        print(f"fabric {piece * 1e3:g} g:")
        for rpm in SPEEDS:
            f = dataclasses.replace(FABRIC_DEFAULTS, mass=piece / FABRIC_DEFAULTS.area)
            a = feed.run_feed(mech, speed_rpm=rpm, stitches=8, fabric=f)
            deg, _ = a.separation
            line = (
                f"  {rpm:5d} rpm: advance {a.advance[-1] * 1e3:.4f} mm ({a.error:+.2%} of the dog's), foot off "
                f"{deg:.0f} deg, spring load {a.load_factor:.3f}x, slip {a.slip * 1e6:.1f} um"
            )
            if piece == default:
                b = feed.run_feed(mech, speed_rpm=rpm, stitches=8, fabric=f, timestep=a.timestep / 2)
                line += (
                    f", half the timestep {b.advance[-1] * 1e3:.4f} mm "
                    f"({(b.advance[-1] - a.advance[-1]) / a.advance[-1] * 100:+.2f} %)"
                )
            print(f"{line}; the foot up to {a.lift.max() * 1e3:.4f} mm off the fabric", flush=True)


def cost(mech: mechanism.Mechanism, repeat: int) -> None:
    feed.run_feed(mech, stitches=2)  # warm: imports
    runs: list[float] = []
    takeup: list[float] = []
    with tempfile.TemporaryDirectory() as tmp:
        _simulate_takeup(Path(tmp))
        for _ in range(repeat):
            c0 = _cpu()
            feed.run_feed(mech, stitches=20)
            runs.append(_cpu() - c0)
            takeup.append(_simulate_takeup(Path(tmp)))
            print(f"feed, 20 stitches: {runs[-1]:.3f} s CPU; simulate takeup: {takeup[-1]:.2f} s CPU", flush=True)
    a, b = statistics.median(runs), statistics.median(takeup)
    print(f"median of {repeat}: feed {a:.3f} s CPU for 20 stitches; simulate takeup {b:.2f} s; ratio {a / b:.3f}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5, help="runs of each for the cost (default 5)")
    ap.add_argument("--no-sweep", action="store_true", help="only the cost")
    a = ap.parse_args()
    mech = mechanism.load(shipped("mechanisms") / "lockstitch_head.toml")
    if not a.no_sweep:
        sweep(mech)
    cost(mech, a.repeat)


if __name__ == "__main__":
    main()
