"""The plots: every PNG is written, valid, atomic (no temporary files left behind)."""

from __future__ import annotations

import functools
import math
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from documented import THRESHOLDS as LIMIT

from mjlink import analysis, validation
from mjlink import reference as R
from mjlink.model import mechanism
from mjlink.model.timing import StitchType
from mjlink.plotting import figures as plots
from mjlink.plotting import style
from mjlink.sim import simulate as S

ROOT = Path(__file__).resolve().parents[1]
PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


@pytest.fixture(scope="module")
def traces():
    m = mechanism.load(ROOT / "mechanisms" / "takeup.toml")
    kin = S.run(m, S.kinematic_case(m))
    kin_ref = R.reference_trace(m, R.Motion(kin.time, kin.phi, kin.omega, kin.eps), "kinematics")
    # A short run-up keeps the test fast; the plots do not depend on the duration.
    dyn = S.run(m, S.dynamic_case(m, duration=0.1))
    dyn_ref = R.reference_trace(m, R.forward_dynamics(m, dyn.time), "dynamics")
    rk4 = R.rk4_dynamics(m)  # over the full duration: the plots clip it to the run shown
    return m, kin, kin_ref, dyn, dyn_ref, rk4


def _check_png(path: Path) -> None:
    assert path.is_file(), path
    data = path.read_bytes()
    assert data.startswith(PNG_MAGIC), path
    assert 10_000 < len(data) < 5_000_000, (path, len(data))


# The figures all_plots draws for each mechanism (the set, every PNG valid, nothing temporary
# left in the folder) are checked in test_figures on the one full run per mechanism.


def test_without_rk4_or_thread(traces, tmp_path):
    m, kin, kin_ref, dyn, dyn_ref, _ = traces
    paths = plots.speed_plots(m, dyn, dyn_ref, tmp_path)
    assert [p.name for p in paths] == ["speed_vs_time.png", "speed_vs_angle.png"]
    for p in paths:
        _check_png(p)
    no_thread = mechanism.Mechanism(**{**m.__dict__, "thread": None})
    assert plots.thread_plot(no_thread, kin, kin_ref, tmp_path / "x") is None
    assert analysis.key_point(no_thread) == "P5"  # last constructed point that is not a centre of mass
    _check_png(plots.positions_plot(no_thread, tmp_path, n=8, highlight="P5"))
    _check_png(plots.kinematics_plot(m, kin, kin_ref, tmp_path, "P3"))
    assert sorted(f.name for f in tmp_path.iterdir()) == sorted(
        ["speed_vs_time.png", "speed_vs_angle.png", "positions.png", "kinematics_P3.png"]
    )


def test_overwrite_is_atomic(traces, tmp_path):
    m = traces[0]
    out = tmp_path / "plots"  # does not exist yet: the first plot creates it
    first = plots.positions_plot(m, out, n=6)
    second = plots.positions_plot(m, out, n=12)
    assert first == second == out / "positions.png"
    _check_png(second)
    assert [f.name for f in out.iterdir()] == ["positions.png"]


# ----------------------------------------------------------------------------- every mechanism
@functools.cache
def _kinematics(name: str):
    """A registered mechanism with its kinematic MuJoCo run and the matching reference trace."""
    m = validation.get(name)
    kin = S.run(m, S.kinematic_case(m))
    kin_ref = R.reference_trace(m, R.Motion(kin.time, kin.phi, kin.omega, kin.eps), "kinematics")
    return m, kin, kin_ref


# The kinematic figures each mechanism of this checkout gets; a mechanism added later is checked
# against the rules of all_plots instead (see _expected). test_figures checks them on the
# figures of its one full run per mechanism.
KNOWN = {
    "takeup": {"positions.png", "thread_length.png", "kinematics_P5.png", "link_lever.png"},
    "crank_slider": {
        "positions.png",
        "kinematics_C.png",
        "slider_C.png",
        "slider_C_spectrum.png",
        "pressure_angle_C.png",
        "link_rod.png",
    },
    "takeup_eyelets": {
        "positions.png",
        "thread_length.png",
        "thread_feed.png",
        "thread_contour.png",
        "kinematics_P6.png",
        "link_rocker.png",
    },
    "warp_knitting": {
        "positions.png",
        "kinematics_P10.png",
        "slider_P9.png",
        "slider_P9_spectrum.png",
        "pressure_angle_P9.png",
        "link_cylinder.png",
        "phase_study.png",
    },
}


def _expected(m) -> set[str]:
    names = {"positions.png", f"kinematics_{analysis.key_point(m)}.png"}
    if m.thread:
        names.add("thread_length.png")
        if m.thread_elongation is not None:
            names.add("thread_feed.png")
        at0 = R.solve(m, [m.phi0])
        if any(abs(float(at0.position(p)[0, 2])) > 1e-12 for p in m.point_names):
            names.add("thread_contour.png")  # a spatial thread
    # A phase study where a geared crank's setting changes a path: some point moved by both the
    # input crank and a geared one (a point moved by one alone keeps its path, only its timing
    # moves: the head's needle and feed are driven apart, warp knitting's needle by both).
    cranks = {s.point for s in m.steps if isinstance(s, mechanism.Crank)}
    moved: dict[str, set[str]] = {}
    for s in m.steps:
        moved[s.point] = {c for p in s.inputs for c in moved.get(p, set())} | ({s.point} & cranks)
    both = [p for p, c in moved.items() if len(c) >= 2 and m.input_crank.point in c]
    for s in m.steps:
        if isinstance(s, mechanism.Slider):
            names |= {f"slider_{s.point}.png", f"slider_{s.point}_spectrum.png", f"pressure_angle_{s.point}.png"}
    if both:
        names.add("phase_study.png")
    names |= {f"link_{l}.png" for l in analysis.motion_links(m)}
    if m.timing is not None:
        names.add("cyclogram.png")  # a sewing head's timing diagram
        if m.timing.has("feed_dog"):
            names.add("feed.png")  # and its fabric fed under the presser foot
    if m.balance is not None:
        names.add("thread_balance.png")  # and its needle thread's balance
        if m.timing is not None and m.timing.stitch is StitchType.LOCKSTITCH:
            names.add("thread_tension.png")  # and, a lockstitch's, its tension
    return names


def test_slider_velocity_on_a_moving_guide():
    """warp_knitting's plunger P9 slides in the swinging cylinder P5-P6: the relative velocity
    and acceleration computed from the traces match time finite differences of s."""
    m, kin, kin_ref = _kinematics("warp_knitting")
    slider = next(s for s in m.steps if isinstance(s, mechanism.Slider) and s.point == "P9")
    assert slider.guide[0] not in m.ground  # the guide does move
    for tr in (kin, kin_ref):
        s, sd, sdd = analysis.slider_motion(tr, slider)
        # Central differences at the run's sampling carry their own error: measured 3e-6 of the
        # largest speed, and of the largest acceleration 5e-6 on the reference and 9e-5 on
        # MuJoCo (whose velocity carries the soft loop closures' ripple); limits ten times that.
        fd = np.gradient(s, tr.time)[1:-1]
        assert np.abs(sd[1:-1] - fd).max() < 3e-5 * np.abs(sd).max()
        fdd = np.gradient(sd, tr.time)[1:-1]
        assert np.abs(sdd[1:-1] - fdd).max() < 1e-3 * np.abs(sdd).max()
        # The absolute velocity along the guide is not the relative one: the guide's swing matters.
        n1, n2 = slider.guide
        u = tr.points[n2][:, :2] - tr.points[n1][:, :2]
        u /= np.linalg.norm(u, axis=1, keepdims=True)
        naive = np.einsum("ij,ij->i", tr.velocities["P9"][:, :2], u)
        assert np.abs(naive - sd).max() > 0.05 * np.abs(sd).max()
    # MuJoCo and the reference agree on the relative motion within the documented point
    # thresholds: position absolute, velocity and acceleration of their largest value.
    (s_mj, v_mj, a_mj), (s_ref, v_ref, a_ref) = (
        analysis.slider_motion(kin, slider),
        analysis.slider_motion(kin_ref, slider),
    )
    assert np.abs(s_mj - s_ref).max() <= LIMIT["position_um"] * 1e-6
    assert np.abs(v_mj - v_ref).max() <= LIMIT["velocity_rel"] * np.abs(v_ref).max()
    assert np.abs(a_mj - a_ref).max() <= LIMIT["acceleration_rel"] * np.abs(a_ref).max()


def test_crank_slider_pressure_angle_and_stroke():
    """The offset crank-slider's largest pressure angle is asin((r + e) / l) and its stroke the
    synthesis stroke; both within the sampling of the kinematic run."""
    m, kin, kin_ref = _kinematics("crank_slider")
    slider = next(s for s in m.steps if isinstance(s, mechanism.Slider))
    r, l, e = m.input_crank.length, slider.length, m.synthesis.offset
    for tr in (kin, kin_ref):
        # The run's samples, 0.29 deg of crank apart, straddle the peak and the dead centres: the
        # sampled pressure angle falls short by a measured 4.6e-5 deg, the stroke by 0.033 um
        # (within the documented position threshold).
        top = math.degrees(analysis.pressure_angle(tr, slider).max())
        assert top == pytest.approx(math.degrees(math.asin((r + e) / l)), abs=2e-4)
        assert top < math.degrees(m.synthesis.max_pressure_angle)
        stroke = np.ptp(analysis.slider_motion(tr, slider)[0])
        assert stroke == pytest.approx(m.synthesis.stroke, abs=LIMIT["position_um"] * 1e-6)


def test_harmonics_of_a_known_signal():
    """Amplitudes of a signal with known harmonics, over one period of a two-turn mechanism,
    sampled at a slightly uneven speed (the resampling in phi takes that out)."""
    t = np.linspace(0.0, 1.0, 4001)
    phi = 0.3 - 4.0 * math.pi * (t + 0.002 * np.sin(2.0 * math.pi * t))  # clockwise, two turns
    x = (phi - phi[0]) / 2.0  # angle of the mechanism period
    y = 3.0 * np.cos(x) + 0.5 * np.sin(2.0 * x + 0.3) + 0.01 * np.cos(7.0 * x)
    amp = analysis.harmonics(SimpleNamespace(period=4.0 * math.pi), SimpleNamespace(phi=phi), y, kmax=8)
    # The resampling in phi of the uneven samples: measured 6e-7 off, in amplitude and share.
    assert amp == pytest.approx([3.0, 0.5, 0, 0, 0, 0, 0.01, 0], abs=5e-6)
    assert analysis.higher_harmonics_share(amp) == pytest.approx(math.hypot(0.5, 0.01) / 3.0, rel=5e-6)
    short = SimpleNamespace(phi=phi[:2000])
    assert analysis.harmonics(SimpleNamespace(period=4.0 * math.pi), short, y[:2000]) is None


def test_clockwise_crank_angle_axis(tmp_path):
    """One convention for every crank-angle axis: the angle turned from the setting phi01, 0 to
    360 deg over a turn, in either sense (a clockwise crank's phi decreases). The speed plots of
    a clockwise run-up work too."""
    m, kin, kin_ref = _kinematics("crank_slider")
    assert m.speed < 0
    (xm, _xr), label = style.crank_x(m, kin, kin_ref)
    assert "turned clockwise from" in label
    assert xm[0] == pytest.approx(0.0) and np.all(np.diff(xm) > 0)
    assert abs(xm[-1] - 360.0) <= np.diff(xm).max()  # the turn's end, within one sample
    m2, kin2, _ = _kinematics("takeup_eyelets")
    (x2,), label2 = style.crank_x(m2, kin2)
    assert "turned from" in label2 and "clockwise" not in label2
    assert x2 == pytest.approx(np.degrees(kin2.phi - m2.phi0)) and x2[0] == pytest.approx(0.0)
    dyn = S.run(m, S.dynamic_case(m, duration=0.05))
    dyn_ref = R.reference_trace(m, R.forward_dynamics(m, dyn.time), "dynamics")
    for p in plots.speed_plots(m, dyn, dyn_ref, tmp_path):
        _check_png(p)
