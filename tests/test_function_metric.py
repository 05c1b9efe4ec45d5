"""The designer's own metric as a Python function (``run_study(..., metrics={...})``): the
traces it is given are the reference's at the study's angles, its column is bounded like the
file's, a wrong function is one line, a changed one is never served from the resume cache, and
on a real Dask cluster a script's function and a lambda travel to the workers."""

from __future__ import annotations

import math
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

import mjlink
from mjlink import reference, study
from mjlink.errors import MjlinkError
from mjlink.study import spec

ROOT = Path(__file__).resolve().parent.parent
CRANKS = [15.0, 15.35, 16.0]  # mm, the head's needle bar crank: two variants and the file's

STUDY = f"""
[study]
mechanism = "lockstitch_head"
name = "fn"
angles = 360

[sampling]
method = "grid"

[[parameter]]
path = "construct.P6.length"
values = {CRANKS}

[[bound]]
metric = "bar_speed_peak"
max = 8.5
"""


def bar_speed_peak(t):
    return np.abs(t["NB_vy_mm_s"]).max(axis=1) / 1000.0


def test_the_function_gets_the_references_traces_and_its_column_is_bounded(tmp_path):
    (tmp_path / "s.toml").write_text(STUDY)
    got = {}

    def sample(t):  # the traces at the 17th angle from the setting, and their shapes
        got["shape"] = t["NB_y_mm"].shape
        got["names"] = list(t)
        got["lever"] = t["lever_angle_deg"][:, 17].copy()
        return t["NB_vy_mm_s"][:, 17]

    res = mjlink.run_study(
        tmp_path / "s.toml",
        tmp_path / "out",
        workers=0,
        plots=False,
        metrics={
            "bar_speed_peak": (bar_speed_peak, "m/s"),
            "stroke_fn": lambda t: np.ptp(t["NB_y_mm"], axis=1),
            "v17": (sample, "mm/s"),
        },
    )
    tab = mjlink.read_study(res.out_dir)
    assert got["shape"] == (3, 360)
    assert {
        "phi1_deg",
        "theta_deg",
        "P5_x_mm",
        "P5_vy_mm_s",
        "lever_angle_deg",
        "lever_omega_rad_s",
        "P3_transmission_deg",
    } <= set(got["names"])
    # The crank points straight up and down on the grid (its setting is 90 deg): the bar's
    # stroke is 2 r exactly.
    assert np.allclose(tab.columns["stroke_fn"], 2 * np.array(CRANKS), rtol=0, atol=1e-9)
    head = mjlink.load("lockstitch_head")
    for i, r in enumerate(CRANKS):
        mech = study.override(head, {"construct.P6.length": r})
        one = reference.solve(mech, [mech.phi0 + math.radians(17.0)], check=False)
        want = one.points["NB"].d[0, 1] * mech.speed * 1e3
        assert tab.columns["v17_mm_s"][i] == pytest.approx(want, rel=1e-12)
        # The lever's angle: its first two points as the file lists them, from the positions.
        a, b = next(l for l in mech.links if l.name == "lever").points[:2]
        d = one.points[b].v[0] - one.points[a].v[0]
        assert got["lever"][i] == pytest.approx(math.degrees(math.atan2(d[1], d[0])), abs=1e-9)
    speeds = tab.columns["bar_speed_peak_m_s"]
    assert list(tab.columns["within_bounds"]) == [bool(v <= 8.5) for v in speeds]
    assert speeds[0] < 8.5 < speeds[2]  # the bound cuts the table


@pytest.mark.parametrize(
    ("metrics", "words"),
    [
        (
            {"x": lambda t: t["NB_y_mm"][:, :2]},
            "returned shape (1, 2); it must give one number per variant, shape (1,)",
        ),
        ({"x": lambda t: t["nope"]}, "raised KeyError: \"no trace 'nope' (names: phi1_deg, theta_deg,"),
        ({"x": 3}, "must be a function of the traces"),
        ({"2x": bar_speed_peak}, "must be a column name"),
        ({"feasible": bar_speed_peak}, "is a column every study table has"),
        ({"x": (bar_speed_peak, "m/s", 1)}, "give a function, or (function, unit)"),
    ],
)
def test_a_wrong_function_is_one_line_naming_it(tmp_path, metrics, words):
    (tmp_path / "s.toml").write_text(STUDY.replace("bar_speed_peak", "x"))
    with pytest.raises(MjlinkError) as e:
        mjlink.run_study(tmp_path / "s.toml", tmp_path / "out", workers=0, plots=False, metrics=metrics)
    msg = str(e.value)
    assert words in msg and "\n" not in msg, msg
    assert not (tmp_path / "out" / "fn-study").exists()


def test_a_changed_function_is_never_served_from_the_cache(tmp_path):
    """The resume cache keys on the study's definition: the function's code and the values it
    reads are part of it."""

    def digest(fn):
        return spec.parse(STUDY, tmp_path / "s.toml", {"bar_speed_peak": fn}).definition_digest

    scale = 1000.0

    def a(t):
        return np.abs(t["NB_vy_mm_s"]).max(axis=1) / scale

    def b(t):
        return np.abs(t["NB_vy_mm_s"]).max(axis=1) / 1000.0

    assert digest(a) == digest(a)
    assert digest(bar_speed_peak) == digest(bar_speed_peak)
    assert len({digest(a), digest(b), digest(bar_speed_peak), digest(lambda t: t["NB_y_mm"][:, 0])}) == 4
    scale = 2000.0
    assert digest(a) != spec.parse(STUDY, tmp_path / "s.toml", {"bar_speed_peak": b}).definition_digest


@pytest.mark.slow
def test_a_scripts_function_and_a_lambda_run_on_a_dask_cluster(tmp_path):
    """A designer's script, run as a script: its function and a lambda go by value to the
    worker of a local Dask cluster (scheduler, nanny, worker process)."""
    (tmp_path / "s.toml").write_text(STUDY)
    (tmp_path / "run.py").write_text(
        textwrap.dedent(
            """
            import numpy as np, mjlink

            def bar_speed_peak(t):
                return np.abs(t["NB_vy_mm_s"]).max(axis=1) / 1000.0

            if __name__ == "__main__":
                res = mjlink.run_study("s.toml", "out", workers=1, plots=False, metrics={
                    "bar_speed_peak": (bar_speed_peak, "m/s"),
                    "stroke_fn": lambda t: np.ptp(t["NB_y_mm"], axis=1),
                })
                print(res.summary["engine"])
                print(",".join(repr(float(v)) for v in mjlink.read_study(res.out_dir).columns["stroke_fn"]))
            """
        )
    )
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    r = subprocess.run([sys.executable, "run.py"], cwd=tmp_path, capture_output=True, text=True, env=env, timeout=300)
    assert r.returncode == 0, r.stderr
    engine, strokes = r.stdout.strip().splitlines()[-2:]
    assert "cluster" in engine.lower() or "dask" in engine.lower(), engine
    assert np.allclose([float(v) for v in strokes.split(",")], 2 * np.array(CRANKS), atol=1e-9)
