"""The plots: every PNG is written, valid, atomic (no temporary files left behind)."""

from __future__ import annotations

from pathlib import Path

import pytest

from mjlink import mechanism, plots
from mjlink import reference as R
from mjlink import simulate as S

ROOT = Path(__file__).resolve().parents[1]
PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


@pytest.fixture(scope="module")
def traces():
    m = mechanism.load(ROOT / "mechanisms" / "takeup.toml")
    kin = S.run(m, S.kinematic_case(m))
    kin_ref = S.reference_trace(m, R.Motion(kin.time, kin.phi, kin.omega, kin.eps), "kinematics")
    # A short run-up keeps the test fast; the plots do not depend on the duration.
    dyn = S.run(m, S.dynamic_case(m, duration=0.1))
    dyn_ref = S.reference_trace(m, R.forward_dynamics(m, dyn.time), "dynamics")
    rk4 = R.rk4_dynamics(m)  # over the full duration: the plots clip it to the run shown
    return m, kin, kin_ref, dyn, dyn_ref, rk4


def _check_png(path: Path) -> None:
    assert path.is_file(), path
    data = path.read_bytes()
    assert data.startswith(PNG_MAGIC), path
    assert 10_000 < len(data) < 5_000_000, (path, len(data))


def test_all_plots(traces, tmp_path):
    m, kin, kin_ref, dyn, dyn_ref, rk4 = traces
    out = tmp_path / "plots"  # does not exist yet: all_plots creates it
    paths = plots.all_plots(m, kin, kin_ref, dyn, dyn_ref, out, rk4)
    names = {p.name for p in paths}
    assert names == {"speed_vs_time.png", "speed_vs_angle.png", "positions.png",
                     "thread_length.png", "kinematics_P5.png"}
    for p in paths:
        assert p.parent == out
        _check_png(p)
    assert sorted(f.name for f in out.iterdir()) == sorted(names), "temporary files left behind"


def test_without_rk4_or_thread(traces, tmp_path):
    m, kin, kin_ref, dyn, dyn_ref, _ = traces
    paths = plots.speed_plots(m, dyn, dyn_ref, tmp_path)
    assert [p.name for p in paths] == ["speed_vs_time.png", "speed_vs_angle.png"]
    for p in paths:
        _check_png(p)
    no_thread = mechanism.Mechanism(**{**m.__dict__, "thread": None})
    assert plots.thread_plot(no_thread, kin, kin_ref, tmp_path / "x") is None
    assert plots.key_point(no_thread) == "P5"  # last constructed point that is not a centre of mass
    _check_png(plots.positions_plot(no_thread, tmp_path, n=8, highlight="P5"))
    _check_png(plots.kinematics_plot(m, kin, kin_ref, tmp_path, "P3"))
    assert sorted(f.name for f in tmp_path.iterdir()) == sorted(
        ["speed_vs_time.png", "speed_vs_angle.png", "positions.png", "kinematics_P3.png"])


def test_overwrite_is_atomic(traces, tmp_path):
    m = traces[0]
    first = plots.positions_plot(m, tmp_path, n=6)
    second = plots.positions_plot(m, tmp_path, n=12)
    assert first == second
    _check_png(second)
    assert [f.name for f in tmp_path.iterdir()] == ["positions.png"]
