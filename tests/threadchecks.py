"""Checks of the needle thread's check spring shared by its tests (a slide and an arc alike):
the Newton steps' stiffness against the pull's central difference, and MuJoCo's thread against
the reference's with friction off; and a head's tension with some of its ``[tension]`` numbers
changed."""

from __future__ import annotations

import dataclasses
import itertools

import numpy as np
import pytest

from mjlink.analysis import tension, tension_many
from mjlink.analysis.tension import needle_tension, step
from mjlink.analysis.timing import head_timing
from mjlink.model.tension import DEFAULTS


def tension_with(mech, timing, **change):
    """The head's needle tension with these ``[tension]`` numbers changed (SI)."""
    return needle_tension(mech, timing, settings=dataclasses.replace(mech.tension or DEFAULTS, **change))


def hook_stiffness_checked(pb, per_state: int, states: tuple[int, ...]) -> tuple[int, int]:
    """Step ``pb`` three stitches, keeping up to ``per_state`` steps with the hook off its rest
    for each state of the thread on the hook (-1, 0, 1); at each whose contacts keep their
    states over the difference, the exact stiffness (twin and array step) against the pull's
    central difference. Every state of ``states`` must be seen. Returns (steps checked, steps
    where an arc's turning counts)."""
    seen: dict[int, list] = {-1: [], 0: [], 1: []}
    real = tension._Thread.settle

    def settle(self, k, xh, s, prev, state):
        now = real(self, k, xh, s, prev, state)
        if xh > 0.0 and len(seen[now.state[self.spring_at]]) < per_state:
            seen[now.state[self.spring_at]].append((self, k, xh, list(s), list(prev), list(state), now))
        return now

    tension._Thread.settle = settle
    try:
        step(pb, cycles=3)
    finally:
        tension._Thread.settle = real
    cs, h = pb.spring_at, 1e-9
    checked = turning = 0
    for hook_state in states:
        assert seen[hook_state], f"no step with the thread {hook_state} on the hook"
    for samples in seen.values():
        for thread, k, xh, s, prev, state, now in samples:
            ends = [thread.settle(k, xh + d, s, prev, state) for d in (h, -h)]
            if any(e.state != now.state for e in ends):
                continue  # a contact changes its state within the difference
            f = [e.T[cs - 1] * e.ga + e.T[cs] * e.gb for e in ends]
            numeric = -(f[0] - f[1]) / (2 * h)
            exact = tension._hook_stiffness(now, cs, pb.friction)
            assert exact == pytest.approx(numeric, rel=1e-6, abs=1e-6), (exact, numeric)
            arrays = {
                name: np.array([getattr(now, name)])
                for name in tension._Step.__dataclass_fields__
                if name in tension_many._Now.__dataclass_fields__
            }
            arrays["first"], arrays["w"] = tension_many._runs(arrays["state"], np.log(arrays["r"]))[1:]
            many = tension_many._hook_stiffness(
                tension_many._Now(**arrays),
                cs,
                np.array([now.state[0] != 0]),
                np.array([pb.friction]),
                np.array([[pb.stiffness]]),
            )
            assert many[0] == pytest.approx(exact, rel=1e-12, abs=1e-9)
            checked += 1
            turning += abs(now.T[cs - 1] * now.ha + now.T[cs] * now.hb) > 1e-3 * abs(exact)
    return checked, turning


def stepped_alike(problems):
    """Each problem stepped by the twin and within the array step agrees to rounding: its state,
    period, stitches run, every zone's tension, the spring's travel and the thread drawn.
    Returns the twin's results."""
    out = []
    for p, b in zip(problems, tension_many.step_many(problems), strict=True):
        a = step(p)
        assert (b.cycles, b.period, b.converged) == (a.cycles, a.period, a.converged)
        np.testing.assert_allclose(b.tension, a.tension, rtol=0, atol=1e-9 * a.peak)
        np.testing.assert_allclose(b.spring, a.spring, rtol=0, atol=1e-12)  # m
        np.testing.assert_allclose(b.drawn, a.drawn, rtol=0, atol=1e-12)  # m
        assert b.per_stitch == pytest.approx(a.per_stitch, rel=1e-12, abs=1e-15)
        out.append(a)
    return out


def mujoco_agrees(mech):
    """:func:`mujoco_against_reference` within what its callers' docstrings measure and allow:
    the tension to 1 % of its peak, the spring's travel to 0.1 mm off its rest stop and 0.2 mm
    where it lands on it (MuJoCo's stop is soft). Returns the reference's run."""
    mj, T, x, ref = mujoco_against_reference(mech)
    assert mj.tension.max() > 0.1 and 1e-3 < mj.spring.max() < mech.balance.check_spring_travel
    assert np.abs(T - mj.tension).max() <= 1e-2 * mj.tension.max()  # the callers' docstrings say why
    off = (x > 2e-4) & (mj.spring > 2e-4)
    assert np.abs(x - mj.spring)[off].max() <= 1e-4  # m; the callers' docstrings say why
    assert np.abs(x - mj.spring).max() <= 2e-4  # m; the callers' docstrings say why
    return ref


def mujoco_against_reference(mech, samples: int = 14400):
    """MuJoCo's thread (mjlink/sim/thread.py) and the reference's over the third of three
    stitches from the needle bar's top, friction off, the thread held at the discs and the eye
    5 mm short of the path's longest: (MuJoCo's run, the reference's tension and spring on
    MuJoCo's angles, the reference's run)."""
    from mjlink.sim.thread import run_thread

    timing = head_timing(mech, samples)
    cfg = dataclasses.replace(DEFAULTS, friction=0.0)
    L = sum(
        np.linalg.norm(timing.positions[b] - timing.positions[a], axis=1) for a, b in itertools.pairwise(mech.thread)
    )
    held = float(L.max()) - 5e-3
    mj = run_thread(mech, held, settings=cfg, cycles=3)
    ref = needle_tension(mech, timing, settings=cfg, anchored=held, cycles=3, samples=samples)
    T = np.interp(mj.theta, ref.theta, ref.tension[0])
    x = np.interp(mj.theta, ref.theta, ref.spring)
    return mj, T, x, ref


# The lockstitch head's take-up linkage as it shipped before it was refined for the least peak
# tension (the winner of studies/lockstitch_head_takeup_sized.toml: docs/head.md's least-slack
# design), mm and deg.
LEAST_SLACK = {
    "construct.P2.angle": -14.63,
    "construct.P2.length": 26.32,
    "construct.P3.length_a": 62.48,
    "construct.P3.length_b": 77.76,
    "ground.P4.x": -52.7,
    "ground.P4.y": 69.1,
    "construct.P5.length": 69.81,
    "construct.P5.angle": 32.62,
}


def least_slack(mech):
    """The shipped lockstitch head with its take-up linkage as :data:`LEAST_SLACK`."""
    from mjlink.model import paths

    return paths.apply(mech, {paths.resolve(mech, k): v for k, v in LEAST_SLACK.items()})
