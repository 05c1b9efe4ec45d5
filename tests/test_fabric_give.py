"""The last stitch's give into a compressible fabric (``[tension] fabric_give``): the thread below
the needle's eye is anchored at the last stitch's end, which sinks into the fabric by ``give``
per newton of that thread's pull, a spring in series with the anchored stretch.

The closed form: a taut thread whose discs hold it (no thread through them) holds a fixed
length ``M`` of unstretched thread, and with no friction anywhere it pulls with one tension
``T`` along its whole path ``L`` (the head's points and the balance's thread below the eye), so
``L = M + T M / EA + give T``: the thread stretches as a spring of ``EA / M`` and the stitch
gives as one of ``1 / give``, in series. From one step's ``L`` and ``T`` the next step's ``T``
follows. Published: a more compressible fabric lowers the main peak (*Parameters affecting
needle thread tension during lockstitch process*, IJFTR); docs/head.md's figures of it are
held to the digits it prints.
"""

from __future__ import annotations

import dataclasses
import itertools

import numpy as np
import pytest
from threadchecks import tension_with

from mjlink import study
from mjlink.analysis import tension_many
from mjlink.analysis.tension import needle_tension, prepare, step
from mjlink.analysis.timing import head_timing
from mjlink.errors import MjlinkError
from mjlink.model import mechanism
from mjlink.model.catalogue import shipped

HEAD = shipped("mechanisms") / "lockstitch_head.toml"
PAPER = shipped("mechanisms") / "examples" / "lockstitch_head_paper_takeup.toml"
MM = 1e-3


@pytest.fixture(scope="module")
def head():
    mech = mechanism.load(HEAD)
    return mech, head_timing(mech)


def _path(mech, timing, samples):
    """(N,) m on the tension's steps: the path from the discs to the eye through the head's
    points (the check spring's hook at rest) and the balance's thread below the eye, while the
    hook carries the loop; NaN elsewhere (the stitch being set lies below the eye there too)."""
    every = len(timing.theta) // samples
    P = [timing.positions[p][::every] for p in mech.thread]
    above = sum(np.linalg.norm(b - a, axis=1) for a, b in itertools.pairwise(P))
    carried = np.isfinite(timing.balance.past[::every])
    return np.where(carried, above + timing.balance.below[::every] * MM, np.nan)


@pytest.mark.parametrize("give", [0.0, 0.2, 1.0])  # mm/N
def test_a_held_frictionless_thread_pulls_as_the_thread_and_the_fabric_in_series(head, give):
    """Without friction or check spring, wherever the thread is taut below the discs' hold at
    two neighbouring steps of the carry, the second step's tension is the series law's from the
    first's: the thread it holds, M, from L = M (1 + T / EA) + give T, and then T' from L'."""
    mech, timing = head
    t_off = needle_tension(
        mech,
        timing,
        settings=dataclasses.replace(mech.tension, friction=0.0, fabric_give=give * MM),
        spring=False,
    )
    ea, c = t_off.stiffness, give * MM
    L = _path(mech, timing, len(t_off.theta))
    T = t_off.tension.max(axis=0)
    # One tension along the thread: no friction anywhere.
    np.testing.assert_allclose(t_off.tension.min(axis=0), T, rtol=0, atol=1e-9 * T.max())
    held = np.isfinite(L) & (T > 0.05 * t_off.hold) & (T < 0.999 * t_off.hold)
    k = np.flatnonzero(held & np.roll(held, -1))
    k = k[k < len(T) - 1]
    assert len(k) > 40
    M = (L[k] - c * T[k]) / (1.0 + T[k] / ea)
    expected = (L[k + 1] - M) / (M / ea + c)
    np.testing.assert_allclose(T[k + 1], expected, rtol=1e-6)
    if give:
        # The rigid fabric's law misses the same steps by far more: the test tells them apart.
        rigid = ea * (L[k + 1] - M) / M
        assert np.abs(rigid - T[k + 1]).max() > 1e-3 * T[k + 1].max()


def test_a_fabric_that_gives_lowers_the_peak_as_published(head):
    """IJFTR: a more compressible fabric lowers the main peak. The shipped head's peak (past the
    hook's blade, as the loop grows) falls as the stitch gives more, the thread per stitch and
    the pull that sets the stitch stay: docs/head.md's figures, to the digits printed."""
    mech, timing = head
    runs = [tension_with(mech, timing, fabric_give=g * MM) for g in (0.0, 0.05, 0.1, 0.2)]
    peaks = [round(r.peak, 2) for r in runs]
    assert peaks == [1.75, 1.71, 1.66, 1.59]
    assert all(r.peak_at[0] == "past the hook's blade" for r in runs)
    assert [round(r.per_stitch / MM, 4) for r in runs] == [4.5] * 4
    assert [round(r.set_pull, 3) for r in runs] == [0.287] * 4
    # The slack's span counts the tension's quarter-degree steps.
    assert [float(r.slack.mean()) * 360.0 for r in runs] == pytest.approx([230.5, 230.25, 230.0, 228.5], abs=1e-9)


def test_the_paper_take_ups_head_lowers_its_peak_less():
    """The head with the paper's take-up peaks where its take-up's shortfall draws thread
    through the discs: the give lowers it by under 1 % (docs/head.md)."""
    mech = mechanism.load(PAPER)
    timing = head_timing(mech)
    peaks = [round(tension_with(mech, timing, fabric_give=g * MM).peak, 2) for g in (0.0, 0.05, 0.1, 0.2)]
    assert peaks == [3.83, 3.82, 3.81, 3.81]


def test_no_give_is_the_rigid_fabric_bit_for_bit_and_the_anchored_thread_ignores_it(head):
    mech, timing = head
    a, b = tension_with(mech, timing), tension_with(mech, timing, fabric_give=0.0)
    assert np.array_equal(a.tension, b.tension) and a.per_stitch == b.per_stitch
    # The thread held at its ends (MuJoCo's comparison) has no stitch to give.
    longest = sum(
        np.linalg.norm(timing.positions[b] - timing.positions[a], axis=1) for a, b in itertools.pairwise(mech.thread)
    )
    kw = {"anchored": float(longest.max()) - 5e-3, "cycles": 1}
    c = needle_tension(mech, timing, **kw)
    d = needle_tension(mech, timing, settings=dataclasses.replace(mech.tension, fabric_give=0.5 * MM), **kw)
    assert np.array_equal(c.tension, d.tension)


def test_the_array_step_gives_what_the_twin_gives_with_the_fabric_giving():
    mech = mechanism.load(PAPER)
    timing = head_timing(mech, samples=720)
    problems = [
        prepare(
            mech,
            timing,
            settings=dataclasses.replace(
                mech.tension, fabric_give=0.02 * i * MM, needle_tension=1.2 + 0.03 * i, spring_rate=20.0 + i
            ),
            samples=360,
        )
        for i in range(tension_many.TOGETHER)
    ]
    for p, b in zip(problems, tension_many.step_many(problems), strict=True):
        a = step(p)
        assert (b.cycles, b.period) == (a.cycles, a.period)
        np.testing.assert_allclose(b.tension, a.tension, rtol=0, atol=1e-9 * a.peak)
        assert b.per_stitch == pytest.approx(a.per_stitch, rel=1e-12)


def test_the_give_is_read_in_mm_per_newton_and_a_study_may_vary_it(head):
    mech, _ = head
    text = HEAD.read_text().replace("fabric_give = 0.0 ", "fabric_give = '0.3 mm/N' ", 1)
    assert mechanism.parse(text, "head.toml").tension.fabric_give == pytest.approx(3e-4, rel=1e-12)
    assert study.override(mech, {"tension.fabric_give": 0.1}).tension.fabric_give == pytest.approx(1e-4)


@pytest.mark.parametrize("value", ["-0.1", "11", "'x'", "'0.1 N/mm'", "nan", "true"])
def test_a_bad_give_is_one_line_naming_it(value):
    text = HEAD.read_text().replace("fabric_give = 0.0 ", f"fabric_give = {value} ", 1)
    with pytest.raises(MjlinkError) as e:
        mechanism.parse(text, "head.toml")
    assert "\n" not in str(e.value) and "fabric_give" in str(e.value)
