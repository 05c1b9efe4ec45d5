"""The vector-method reference: hand-computed values, exact derivatives, fast path vs plain twin."""

import math
import re
from pathlib import Path

import numpy as np
import pytest

from mjlink import reference as R
from mjlink.model import jet, mechanism

PARALLELOGRAM = """
[mechanism]
name = "parallelogram"
title = "crank-rocker parallelogram with hand-checkable positions"
[ground]
P1 = [0, 0]
P4 = [40, 0]
[[construct]]
point = "P2"
block = "crank"
pivot = "P1"
length = 30
[[construct]]
point = "P3"
block = "dyad"
a = "P2"
b = "P4"
length_a = 40
length_b = 30
sign = -1
[links.crank]
points = ["P1", "P2"]
[links.coupler]
points = ["P2", "P3"]
[links.rocker]
points = ["P4", "P3"]
[input]
phi0 = 90
speed = 10
"""


def test_parallelogram_by_hand():
    m = mechanism.parse(PARALLELOGRAM)
    k = R.solve(m, [math.pi / 2])
    # P2 = (0, 30); the 40-30-50 triangle puts P3 at (40, 30) on the W = -1 branch.
    np.testing.assert_allclose(k.position("P2")[0] * 1e3, [0, 30, 0], atol=1e-12)
    np.testing.assert_allclose(k.position("P3")[0] * 1e3, [40, 30, 0], atol=1e-12)
    # The coupler of a parallelogram translates: P3 moves exactly as P2 does.
    np.testing.assert_allclose(k.points["P3"].d[0] * 1e3, [-30, 0, 0], atol=1e-12)
    np.testing.assert_allclose(k.points["P3"].dd[0] * 1e3, [0, -30, 0], atol=1e-12)
    np.testing.assert_allclose(k.angles["coupler"].d[0], 0.0, atol=1e-14)
    np.testing.assert_allclose(k.angles["rocker"].d[0], 1.0, atol=1e-14)


def _plain_takeup(phi):
    """The take-up solved point by point with the textbook circle intersection (no jets)."""
    p1, p4 = np.array([0.0, 0.0]), np.array([9.66, 2.59])
    p2 = p1 + 30.0 * np.array([math.cos(phi), math.sin(phi)])
    d = math.dist(p2, p4)
    a = (19.0**2 - 22.0**2 + d * d) / (2 * d)  # distance from P4 to the chord's foot
    h = math.sqrt(19.0**2 - a * a)
    e = (p2 - p4) / d
    n = np.array([e[1], -e[0]])  # clockwise normal: the W = -1 closure
    p3 = p4 + a * e + h * n
    u = (p2 - p3) / np.linalg.norm(p2 - p3)
    c, s = math.cos(math.radians(-95)), math.sin(math.radians(-95))
    p5 = p3 + 47.0 * np.array([c * u[0] - s * u[1], s * u[0] + c * u[1]])
    return p2, p3, p5


@pytest.mark.parametrize("deg", [0.0, 45.0, 90.0, 101.0, 180.0, 270.0, 333.3])
def test_takeup_matches_plain_twin(takeup, deg):
    k = R.solve(takeup, [math.radians(deg)])
    for name, want in zip(("P2", "P3", "P5"), _plain_takeup(math.radians(deg))):
        np.testing.assert_allclose(k.position(name)[0, :2] * 1e3, want, atol=1e-10)


def test_solve_only_gives_the_same_points_as_the_whole_solve(takeup):
    """Solving for some points solves what they are built from, and gives them bit for bit."""
    phi = np.radians(np.arange(0, 360, 7.5))
    whole = R.solve(takeup, phi)
    part = R.solve(takeup, phi, only={"P3"})
    assert "P3" in part.points and "P5" not in part.points
    for name, got in part.points.items():
        for k in ("v", "d", "dd"):
            assert np.array_equal(getattr(got, k), getattr(whole.points[name], k))
    assert part.angles.keys() == whole.angles.keys()


def test_derivatives_match_finite_differences(takeup):
    phi = np.radians(np.arange(0, 360, 7.5))
    h = 1e-5
    k, kp, km = (R.solve(takeup, phi + s) for s in (0.0, h, -h))
    # The central differences' own error at h = 1e-5: measured 7e-11 of the largest first
    # derivative and 9e-6 of the largest second (its rounding, about eps / h^2).
    for name in takeup.moving_points:
        fd1 = (kp.position(name) - km.position(name)) / (2 * h)
        fd2 = (kp.position(name) - 2 * k.position(name) + km.position(name)) / h**2
        scale = np.abs(k.points[name].d).max()
        assert np.abs(fd1 - k.points[name].d).max() < 1e-8 * scale, name
        assert np.abs(fd2 - k.points[name].dd).max() < 1e-4 * np.abs(k.points[name].dd).max(), name
    for link in takeup.links:
        th, thp, thm = k.angles[link.name], kp.angles[link.name], km.angles[link.name]
        fd = np.angle(np.exp(1j * (thp.v - thm.v))) / (2 * h)
        assert np.abs(fd - th.d).max() < 1e-8


def _quadratic(v, d, dd, t):
    """The Taylor polynomial of a jet (value, first and second derivative) at t."""
    return v + d * t + 0.5 * dd * t * t


def test_polar_and_turn_derivatives_match_finite_differences():
    # Along t, the angle (or the cosine) and the rotated vector move as the quadratics their
    # jets describe; the jet operations' derivatives at t = 0 must be those of the composed
    # function, whatever the curvature (a geared crank, a dyad's varying angle).
    rng = np.random.default_rng(7)
    n, h = 64, 1e-4
    a = jet.S(*rng.uniform(-3.0, 3.0, (3, n)))
    length = rng.uniform(0.01, 0.05, n)
    w = jet.S(rng.uniform(-0.9, 0.9, n), *rng.uniform(-1.0, 1.0, (2, n)))
    pc = [rng.normal(size=n) + 1j * rng.normal(size=n) for _ in range(3)]
    sign = -1.0

    def polar_at(t):
        return length * np.exp(1j * _quadratic(a.v, a.d, a.dd, t))

    def turn_at(t):
        c = _quadratic(w.v, w.d, w.dd, t)
        return _quadratic(*pc, t) * (c + 1j * sign * np.sqrt(1.0 - c * c))

    # The differences' own error at h = 1e-4: measured 7e-8 (first) and 4e-7 (second).
    for got, f in ((jet.polar(length, a), polar_at), (jet.turn(jet.V(*pc), w, sign), turn_at)):
        fp, f0, fm = f(h), f(0.0), f(-h)
        np.testing.assert_allclose(got.c, f0, rtol=0, atol=1e-14)
        np.testing.assert_allclose(got.cd, (fp - fm) / (2 * h), rtol=0, atol=1e-6)
        np.testing.assert_allclose(got.cdd, (fp - 2 * f0 + fm) / h**2, rtol=0, atol=5e-6)


def test_a_shared_direction_is_the_direction_and_is_forgotten_after_the_solve():
    """jet.direction inside jet.sharing: computed once per pair of point jets (the same object
    for every block that asks), equal to the unit vector with finite-difference derivatives,
    and nothing kept once the solve ends."""
    rng = np.random.default_rng(3)
    n, h = 32, 1e-4
    pa, pb = ([rng.normal(size=n) + 1j * rng.normal(size=n) for _ in range(3)] for _ in range(2))
    a, b = jet.V(*pa), jet.V(*pb)

    def unit_at(t):
        d = _quadratic(*pb, t) - _quadratic(*pa, t)
        return d / np.abs(d)

    with jet.sharing():
        u = jet.direction(a, b)
        assert jet.direction(a, b) is u
        assert jet.direction(b, a) is not u
    assert jet.direction(a, b) is not u  # outside: computed anew
    # The differences' own error at h = 1e-4 on these random pairs, some close together:
    # measured 7e-6 (first) and 1.3e-4 (second).
    fp, f0, fm = unit_at(h), unit_at(0.0), unit_at(-h)
    np.testing.assert_allclose(u.c, f0, rtol=0, atol=1e-14)
    np.testing.assert_allclose(u.cd, (fp - fm) / (2 * h), rtol=0, atol=1e-5)
    np.testing.assert_allclose(u.cdd, (fp - 2 * f0 + fm) / h**2, rtol=0, atol=1e-3)


def test_velocity_and_acceleration_chain_rule(takeup):
    k = R.solve(takeup, [1.0])
    p = k.points["P5"]
    np.testing.assert_allclose(k.velocity("P5", 100.0), p.d * 100.0)
    np.testing.assert_allclose(k.acceleration("P5", 100.0, 7.0), p.dd * 1e4 + p.d * 7.0)


def test_spectral_fast_path_matches_direct_evaluation(takeup):
    sd = R.SpectralDynamics(takeup)
    assert sd.error < 1e-11
    phi = np.random.default_rng(1).uniform(-20, 20, 50)
    direct = R.reduced(takeup, R.solve(takeup, phi))
    fast = np.array([sd.scalar(p) for p in phi]).T
    for i, v in enumerate((direct.J, direct.dJ, direct.Q)):
        assert np.abs(fast[i] - v).max() < 1e-11 * np.abs(v).max()


def test_reduced_inertia_matches_kinetic_energy(takeup):
    # J(phi) omega^2 / 2 must equal the sum of the links' kinetic energies.
    phi = np.radians(np.arange(0, 360, 10.0))
    k = R.solve(takeup, phi)
    red = R.reduced(takeup, k)
    w = 3.0
    T = np.zeros_like(phi)
    for link in takeup.links:
        v = k.velocity(link.com, w)
        T += 0.5 * link.mass * np.einsum("ij,ij->i", v, v) + 0.5 * link.inertia * (k.angles[link.name].d * w) ** 2
    np.testing.assert_allclose(0.5 * red.J * w**2, T, rtol=1e-13)
    fd = (R.reduced(takeup, R.solve(takeup, phi + 1e-6)).J - R.reduced(takeup, R.solve(takeup, phi - 1e-6)).J) / 2e-6
    np.testing.assert_allclose(red.dJ, fd, atol=1e-8 * np.abs(red.dJ).max())


def _documented_rk4() -> tuple[float, float, float]:
    """docs/verification.md's figures of the paper's RK4: omega(1 s) with 1000 steps and the
    tight solution's, rad/s, and the largest difference along the way, rad/s."""
    text = (Path(__file__).resolve().parent.parent / "docs" / "verification.md").read_text(encoding="utf-8")
    ends = re.search(r"omega\(1 s\) = ([0-9.]+)\s+against ([0-9.]+) rad/s", text)
    off = re.search(r"omega is off by up to ([0-9]+) rad/s", text)
    assert ends and off, "docs/verification.md no longer gives the paper's RK4 figures"
    return float(ends[1]), float(ends[2]), float(off[1])


def test_paper_rk4_converges_to_tight_solution(takeup):
    sd = R.SpectralDynamics(takeup)
    paper = R.rk4_dynamics(takeup, 1000, sd=sd)  # the paper's 1000 steps over 1 s
    along = R.forward_dynamics(takeup, paper.t, sd=sd).omega
    tight = along[-1]
    errs = [abs(R.rk4_dynamics(takeup, n, sd=sd).omega[-1] - tight) for n in (5000, 10000, 20000)]
    # High order: each halving of the step divides the error by more than ten (about 31 is
    # measured), so RK4 converges on the tight solution.
    assert errs[0] / errs[1] > 10 and errs[1] / errs[2] > 10, errs
    assert errs[2] < 2e-4
    # The documented figures, to the digits the page gives them: the tight solution's and the
    # paper's omega(1 s), and how far the paper's strays along the way.
    rk4_end, tight_end, off = _documented_rk4()
    assert tight == pytest.approx(tight_end, abs=0.005)
    assert paper.omega[-1] == pytest.approx(rk4_end, abs=0.005)
    assert np.abs(paper.omega - along).max() == pytest.approx(off, abs=0.5)
