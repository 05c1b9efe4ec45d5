"""The design summary (the page's first screen and report.json's ``design``) against closed form
and against the loads the run computes by another route."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mjlink import analysis
from mjlink import reference as R
from mjlink.analysis import summary
from mjlink.model import catalogue, mechanism


def _load(name: str) -> mechanism.Mechanism:
    return mechanism.load(catalogue.path_of(name))


def test_crank_slider_extremes_are_the_closed_form_dead_centres():
    """Offset crank-slider, crank r, rod l, offset e: the slider's extreme positions along the
    guide are sqrt((l + r)^2 - e^2) and sqrt((l - r)^2 - e^2) from the crank's pivot."""
    m = _load("crank_slider")
    rows = {r.metric: r for r in summary.design_summary(m)}
    r, l, e = 21.730974582035103, 62.08849880581459, 15.0
    far, near = math.sqrt((l + r) ** 2 - e**2), math.sqrt((l - r) ** 2 - e**2)
    assert rows["C_x_max"].value == pytest.approx(far, abs=1e-6)
    assert rows["C_x_min"].value == pytest.approx(near, abs=1e-6)
    assert rows["stroke_C"].value == pytest.approx(far - near, abs=1e-6) and rows["stroke_C"].unit == "mm"
    assert rows["stroke_C"].value == pytest.approx(45.0, abs=1e-6)  # the file's synthesized stroke


@pytest.mark.parametrize("name", ["takeup", "lockstitch_head"])
def test_torque_and_power_agree_with_the_kinetostatics(name):
    """The summary's torque and power come from the study metrics (the batch reference's
    reduced equation of motion); the same statistics of the torque of the kinetostatic solve
    (Newton-Euler link by link) at the summary's crank angles agree with them to rounding, and
    the loads stage's finer period has the same RMS and power (a periodic mean) and a peak
    its coarser samples cannot exceed."""
    m = _load(name)
    rows = {r.metric: r.value for r in summary.design_summary(m)}
    phi = analysis.one_period(m, summary.PER_TURN)
    tau = R.reactions(m, phi, m.speed).torque
    assert rows["torque_peak"] == pytest.approx(np.abs(tau).max(), rel=1e-12)
    assert rows["torque_rms"] == pytest.approx(np.sqrt(np.mean(tau**2)), rel=1e-12)
    assert rows["power_mean"] == pytest.approx(tau.mean() * m.speed, rel=1e-12)
    fine = analysis.torque_cycle(m, m.speed)
    assert rows["torque_peak"] <= fine.peak * (1 + 1e-12)
    assert rows["torque_rms"] == pytest.approx(fine.rms, rel=1e-12)
    assert rows["power_mean"] == pytest.approx(fine.power, rel=1e-12)


def test_every_moving_point_and_every_dimension_is_listed():
    m = _load("takeup")
    strokes = [r.metric for r in summary.point_strokes(m)]
    assert [s for s in strokes if s.startswith("stroke_")] == ["stroke_P2", "stroke_P3", "stroke_P5"]
    assert len(strokes) == 9  # a stroke, a lowest and a highest per point
    dims = {p: v for p, v, _ in summary.dimensions(m)}
    assert dims["construct.P2.length"] == 30.0 and dims["ground.P4.x"] == 9.66 and dims["input.phi0"] == 101.0
    assert not [p for p in dims if p.startswith("construct.S")], "centres of mass are not dimensions"
