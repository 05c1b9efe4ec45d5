"""The designer's own motion metric (``kind = "motion"``): every statistic and event checked
against a plain solution written here (a scalar root of the reference's position, dense
samples, finite differences) and against the crank-slider's closed forms; its errors."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import brentq, minimize_scalar

from mjlink import api, reference, study
from mjlink.analysis.metric_base import MetricError
from mjlink.study import engine, spec

HEAD = api.load("lockstitch_head")
W = HEAD.speed  # rad/s, the file's
PLATE, FABRIC = -100.0, 1.5  # mm, the head's [timing] plate and fabric (docs/head.md)
CRANKS = [15.35, 14.0, 16.5]  # the needle bar crank's radius, mm: the file's and two variants
ROD = 52.0  # mm, the needle link


def _evaluate(metrics: list[dict], values=CRANKS) -> dict[str, np.ndarray]:
    return study.evaluate(HEAD, {"construct.P6.length": values}, metrics).columns


def _variant(r_mm: float):
    return study.override(HEAD, {"construct.P6.length": r_mm})


def _y(mech, point: str, phi: float, order: int = 0) -> float:
    kin = reference.solve(mech, [phi], check=False)
    p = kin.points[point]
    return float((p.v, p.d, p.dd)[order][0, 1])


def test_the_needle_bar_meets_the_crank_sliders_closed_forms():
    """An in-line crank-slider of radius r and rod l (the head's needle bar: the crank's pivot
    on the bar's line): at the bottom dead centre the bar's acceleration is r w^2 (1 + r / l)
    towards the crank; with the crank pointing down (270 deg) the bar is r + l below its pivot."""
    cols = _evaluate(
        [
            {"kind": "motion", "point": "NB", "quantity": "acceleration", "axis": "y", "event": {"extreme": "min"}},
            {"kind": "motion", "point": "NB", "quantity": "position", "axis": "y", "event": {"angle": 270.0}},
            {"kind": "motion", "point": "NB", "quantity": "position", "axis": "y", "statistic": "range"},
        ]
    )
    r = np.array(CRANKS) * 1e-3
    assert np.allclose(cols["acceleration_y_NB_at_NB_y_min"], r * W * W * (1 + r / (ROD * 1e-3)), rtol=1e-10, atol=0)
    assert np.allclose(cols["position_y_NB_at_270deg"], -(np.array(CRANKS) + ROD), rtol=0, atol=1e-9)
    assert np.allclose(cols["position_y_NB_range"], 2 * np.array(CRANKS), rtol=0, atol=1e-9)  # the stroke, 2 r


def _first_crossing(mech, point: str, height_m: float, down: bool, speed: float) -> float:
    """The plain twin: the first crank angle after the setting, in time, where the point's y
    passes the height the wanted way, bracketed on 0.1 deg samples and solved by brentq."""
    sense = 1 if speed > 0 else -1
    phi = mech.phi0 + sense * np.radians(np.arange(3601) * 0.1)
    y = reference.solve(mech, phi, check=False).points[point].v[:, 1] - height_m
    hit = (y[:-1] > 0) & (y[1:] <= 0) if down else (y[:-1] < 0) & (y[1:] >= 0)
    j = int(np.argmax(hit))
    assert hit[j], "no crossing"
    return brentq(lambda p: _y(mech, point, p) - height_m, *sorted((phi[j], phi[j + 1])), xtol=1e-15, rtol=1e-15)


@pytest.mark.parametrize("speed_sign", [1, -1])
def test_the_needles_velocity_as_it_passes_the_fabric_is_the_plain_solutions(speed_sign):
    """The needle point's velocity at its first crossing of the fabric's top going down (and
    coming up), for a crank turning either way: equal to the reference's exact velocity at the
    crank angle a scalar root-finder gives."""
    h = (PLATE + FABRIC) * 1e-3
    w = speed_sign * W
    mets = [
        {
            "kind": "motion",
            "name": f"v_{d}",
            "point": "NT",
            "quantity": "velocity",
            "axis": "y",
            "speed": w,
            "event": {"height": PLATE + FABRIC, "direction": d},
        }
        for d in ("down", "up")
    ]
    cols = _evaluate(mets)
    for i, r in enumerate(CRANKS):
        mech = _variant(r)
        for d in ("down", "up"):
            phi = _first_crossing(mech, "NT", h, d == "down", w)
            want = _y(mech, "NT", phi, 1) * w
            assert cols[f"v_{d}"][i] == pytest.approx(want, rel=1e-9), (r, d)
            assert (want < 0) == (d == "down")  # down in time is a negative velocity
    # Turning the other way meets the same angles in reverse: its down crossing is the
    # counter-clockwise up crossing, its velocity reversed.
    if speed_sign < 0:
        ccw = _evaluate([{**m, "speed": W} for m in mets])
        assert np.allclose(cols["v_down"], -ccw["v_up"], rtol=1e-9)


@pytest.mark.parametrize(("origin", "direction"), [("min", "down"), ("max", "up")])
def test_a_height_from_the_points_own_extreme_is_the_plain_solutions(origin, direction):
    """``from = "min"``: the needle point 12.5 mm above its own bottom dead centre, wherever a
    variant puts that centre (``"max"``: 12.5 mm below its top). The head's needle bar is an
    in-line crank-slider with the crank's pivot on its line, so the point's lowest and highest
    heights are -(r + l + NT) and -(l - r + NT) in closed form (NT the point 43.65 mm under the
    bar's joint); the crossing is then found by the plain root-finder."""
    offset = 12.5 if origin == "min" else -12.5
    cols = _evaluate(
        [
            {
                "kind": "motion",
                "name": "v",
                "point": "NT",
                "quantity": "velocity",
                "axis": "y",
                "event": {"height": offset, "from": origin, "direction": direction},
            }
        ]
    )
    for i, r in enumerate(CRANKS):
        extreme = -(r + ROD + 43.65) if origin == "min" else -(ROD - r + 43.65)
        mech = _variant(r)
        phi = _first_crossing(mech, "NT", (extreme + offset) * 1e-3, direction == "down", W)
        assert cols["v"][i] == pytest.approx(_y(mech, "NT", phi, 1) * W, rel=1e-9), r


def test_an_event_that_does_not_happen_gives_nan():
    cols = _evaluate(
        [
            {
                "kind": "motion",
                "point": "NT",
                "quantity": "velocity",
                "axis": "y",
                "event": {"height": 1000.0, "direction": "down"},
                "name": "never",
            }
        ]
    )
    assert np.isnan(cols["never"]).all()


def test_statistics_are_the_dense_samples():
    """Peak, RMS and range of the take-up eyelet's speed and the needle bar's jerk, against
    36,000 samples of the reference (the jerk by central differences of the exact
    acceleration)."""
    cols = _evaluate(
        [
            {"kind": "motion", "point": "P5", "quantity": "velocity", "statistic": stat}
            for stat in ("peak", "rms", "range", "min")
        ]
        + [{"kind": "motion", "point": "NB", "quantity": "jerk", "axis": "y", "statistic": "peak"}],
        values=[15.35],
    )
    phi = HEAD.phi0 + np.linspace(0, 2 * math.pi, 36000, endpoint=False)
    kin = reference.solve(HEAD, phi, check=False)
    speed = np.linalg.norm(kin.points["P5"].d, axis=1) * abs(W)
    assert cols["velocity_P5_peak"][0] == pytest.approx(speed.max(), rel=1e-7)
    assert cols["velocity_P5_rms"][0] == pytest.approx(np.sqrt(np.mean(speed**2)), rel=1e-10)
    assert cols["velocity_P5_range"][0] == pytest.approx(np.ptp(speed), rel=1e-6)
    assert cols["velocity_P5_min"][0] == pytest.approx(speed.min(), rel=1e-6, abs=1e-6)
    e = 1e-4
    ahead, back = (reference.solve(HEAD, phi + s, check=False).points["NB"].dd[:, 1] for s in (e, -e))
    jerk = (ahead - back) / (2 * e) * W**3
    assert cols["jerk_y_NB_peak"][0] == pytest.approx(np.abs(jerk).max(), rel=1e-6)


def test_a_study_file_names_its_own_metric_and_bounds_it(tmp_path):
    text = f"""
[study]
mechanism = "lockstitch_head"
name = "penetration"
angles = 360

[sampling]
method = "grid"

[[parameter]]
path = "construct.P6.length"
values = {CRANKS}

[[metric]]
kind = "motion"
name = "penetration_velocity"
point = "NT"
quantity = "velocity"
axis = "y"
event = {{ height = {PLATE + FABRIC}, direction = "down" }}

[[bound]]
metric = "penetration_velocity"
min = -8.5
"""
    st = spec.parse(text, tmp_path / "s.toml")
    res = engine.run(st)
    v = res.columns["penetration_velocity"]
    assert v.shape == (3,) and np.all(v < 0)
    # The same numbers as the metric asked for directly, and the bound applied to them.
    direct = _evaluate(
        [
            {
                "kind": "motion",
                "point": "NT",
                "quantity": "velocity",
                "axis": "y",
                "event": {"height": PLATE + FABRIC, "direction": "down"},
            }
        ]
    )
    assert np.array_equal(v, direct["velocity_y_NT_at_NT_y_down_m98p5mm"])
    assert [c.name for c in st.metrics[0].columns()] == ["penetration_velocity"]


@pytest.mark.parametrize(
    ("metric", "words"),
    [
        ({"kind": "velocity_peak", "point": "NT"}, "kind = 'motion' with its quantity"),
        ({"kind": "motion", "point": "NT", "quantity": "speed"}, "position, velocity, acceleration, jerk"),
        ({"kind": "motion", "link": "lever", "quantity": "velocity"}, "angle, angular_velocity, angular_acceleration"),
        ({"kind": "motion", "link": "levr", "quantity": "angle"}, "is not a link of lockstitch_head (links: crank,"),
        ({"kind": "motion", "block": "NB", "quantity": "transmission_angle"}, "is a slider: its quantity is pressure"),
        ({"kind": "motion", "block": "P5", "statistic": "max"}, "is not a dyad's or a slider's point"),
        ({"kind": "motion", "quantity": "velocity"}, "needs exactly one of point"),
        ({"kind": "motion", "link": "lever", "quantity": "angle", "axis": "y"}, "takes no axis"),
        (
            {"kind": "motion", "link": "lever", "quantity": "angle", "event": {"extreme": "max"}},
            "needs its point",
        ),
        ({"kind": "motion", "point": "NT", "quantity": "position"}, "a position needs an axis"),
        ({"kind": "motion", "point": "NT", "quantity": "velocity", "statistic": "mean"}, "peak, rms, range, max, min"),
        (
            {"kind": "motion", "point": "NT", "quantity": "velocity", "event": {"height": 1.0, "angle": 2.0}},
            "exactly one of height (mm), height_of (a point), extreme (max/min) or angle",
        ),
        (
            {"kind": "motion", "point": "NT", "quantity": "velocity", "event": {"height": 1.0}},
            "direction must be 'up' or 'down'",
        ),
        (
            {"kind": "motion", "point": "NT", "quantity": "velocity", "event": {"point": "XX", "extreme": "max"}},
            "'XX' is not a point of lockstitch_head (points: P1, ",
        ),
        (
            {"kind": "motion", "point": "NT", "quantity": "velocity", "event": {"when": 1}},
            "unknown key 'when' (valid: point, link, quantity, axis, height, from, height_of, direction, extreme, angle)",
        ),
        (
            {"kind": "motion", "point": "NT", "quantity": "velocity", "event": {"extreme": "min", "from": "min"}},
            "'from' measures a height (mm) from the point's own min or max; give height",
        ),
        (
            {"kind": "motion", "point": "NT", "quantity": "velocity", "event": {"height": 1, "from": "bdc"}},
            "from must be 'min' or 'max' (the point's own lowest or highest coordinate), got 'bdc'",
        ),
        ({"kind": "motion", "point": "NT", "quantity": "velocity", "name": "2fast"}, "name must be a column name"),
        ({"kind": "motion", "point": "NT", "quantity": "velocity", "name": "feasible"}, "every study table has"),
        (
            {"kind": "motion", "point": "NT", "quantity": "velocity", "statistic": "peak", "event": {"angle": 1}},
            "either 'statistic' or 'event'",
        ),
        (
            {"kind": "motion", "point": "NT", "quantity": "velocity", "event": {"link": "lever", "height": 1.0}},
            "a link or a quantity other than a point's position names an extreme",
        ),
        (
            {
                "kind": "motion",
                "point": "NB",
                "quantity": "position",
                "axis": "y",
                "event": {"quantity": "speed", "extreme": "max"},
            },
            "event quantity: a point's must be one of position, velocity, acceleration, jerk, got 'speed'",
        ),
        (
            {
                "kind": "motion",
                "point": "NB",
                "quantity": "position",
                "axis": "y",
                "event": {"link": "levr", "extreme": "max"},
            },
            "event link: 'levr' is not a link of lockstitch_head (links: crank,",
        ),
        (
            {
                "kind": "motion",
                "point": "NB",
                "quantity": "position",
                "axis": "y",
                "event": {"link": "lever", "quantity": "jerk", "extreme": "max"},
            },
            "a link's must be one of angle, angular_velocity, angular_acceleration, velocity_ratio, got 'jerk'",
        ),
        (
            {
                "kind": "motion",
                "point": "NB",
                "quantity": "position",
                "axis": "y",
                "event": {"link": "lever", "axis": "y", "extreme": "max"},
            },
            "a link's extreme takes no axis",
        ),
    ],
)
def test_a_wrong_motion_metric_is_one_line_naming_what_exists(metric, words):
    with pytest.raises(MetricError) as e:
        study.evaluate(HEAD, {"construct.P6.length": [15.35]}, [metric])
    msg = str(e.value)
    assert words in msg and "\n" not in msg, msg
    assert "did you mean 'acceleration_peak'" not in msg


def test_a_name_another_metrics_column_has_is_refused_naming_both():
    mine = {"kind": "motion", "point": "NB", "quantity": "velocity", "axis": "y", "name": "stroke_NB"}
    with pytest.raises(
        MetricError,
        match=r"'stroke_NB' is computed twice \(\[\[metric\]\] #1 \(motion\) and \[\[metric\]\] #2 \(stroke\)\)",
    ):
        study.evaluate(HEAD, {"construct.P6.length": [15.35]}, [mine, {"kind": "stroke", "point": "NB"}])


def _dense(mech, n: int = 36000):
    phi = mech.phi0 + np.linspace(0, 2 * math.pi, n, endpoint=False)
    return phi, reference.solve(mech, phi, check=False)


def test_a_links_angle_angular_velocity_and_ratio_are_the_plain_ones():
    """The feed rocker's swing and its largest velocity ratio to the input, from the direction
    of its own two pivots' line (atan2 of the positions, differentiated numerically), the
    take-up rocker's angular velocity at a crank angle from the reference's exact derivative
    and its largest angle against the dense samples'; a link that turns fully has none."""
    cols = _evaluate(
        [
            {"kind": "motion", "link": "feed_rocker", "quantity": "angle", "statistic": "range"},
            {"kind": "motion", "link": "feed_rocker", "quantity": "velocity_ratio", "statistic": "peak"},
            {"kind": "motion", "link": "rocker", "quantity": "angular_velocity", "event": {"angle": 200.0}},
            {"kind": "motion", "link": "rocker", "quantity": "angle", "statistic": "max"},
            {"kind": "motion", "link": "hook", "quantity": "angle", "statistic": "max", "name": "turning"},
        ],
        values=[15.35],
    )
    phi, kin = _dense(HEAD)
    rc = kin.points["C"].v - kin.points["R"].v
    a = np.unwrap(np.arctan2(rc[:, 1], rc[:, 0]))
    assert cols["angle_feed_rocker_range"][0] == pytest.approx(math.degrees(np.ptp(a)), rel=1e-7)
    ratio = np.gradient(a, phi[1] - phi[0])
    assert cols["velocity_ratio_feed_rocker_peak"][0] == pytest.approx(np.abs(ratio).max(), rel=1e-5)
    one = reference.solve(HEAD, [math.radians(200.0)], check=False)
    assert cols["angular_velocity_rocker_at_200deg"][0] == pytest.approx(one.angles["rocker"].d[0] * W, rel=1e-10)
    rp = kin.points["P3"].v - kin.points["P4"].v
    # deg: the dense samples' largest against the extreme refined between the study's samples
    assert cols["angle_rocker_max"][0] == pytest.approx(math.degrees(np.arctan2(rp[:, 1], rp[:, 0]).max()), abs=1e-3)
    assert np.isnan(cols["turning"][0])  # the hook turns fully: it has no largest angle


def test_a_blocks_transmission_and_pressure_angle_are_the_plain_ones():
    """The needle bar's crank-slider (in line): its largest pressure angle is asin(r / l); the
    take-up dyad's smallest transmission angle from the angle at its joint (dense samples)."""
    cols = _evaluate(
        [
            {"kind": "motion", "block": "NB", "statistic": "max"},
            {"kind": "motion", "block": "P3", "statistic": "min"},
            {"kind": "motion", "block": "P3", "event": {"angle": 101.0}},
        ]
    )
    r = np.array(CRANKS)
    assert np.allclose(cols["pressure_angle_NB_max"], np.degrees(np.arcsin(r / ROD)), rtol=1e-9, atol=0)
    _, kin = _dense(HEAD)
    u, v = (kin.points[q].v[:, :2] - kin.points["P3"].v[:, :2] for q in ("P2", "P4"))
    mu = np.degrees(np.arccos((u * v).sum(1) / np.linalg.norm(u, axis=1) / np.linalg.norm(v, axis=1)))
    assert cols["transmission_angle_P3_min"][0] == pytest.approx(mu.min(), rel=1e-7)
    one = reference.solve(HEAD, [math.radians(101.0)], check=False)
    u, v = (one.points[q].v[0, :2] - one.points["P3"].v[0, :2] for q in ("P2", "P4"))
    at = math.degrees(math.acos(u @ v / np.linalg.norm(u) / np.linalg.norm(v)))
    assert cols["transmission_angle_P3_at_101deg"][0] == pytest.approx(at, rel=1e-9)


def test_an_extreme_of_a_quantity_is_an_event():
    """The instant a quantity other than a coordinate is at its extreme: the needle bar's
    upward acceleration is largest at its bottom dead centre (cos t + lambda cos 2t is largest
    at t = 0 for any lambda > 0), where the bar stands r + l below the crank's pivot and is at
    rest; the needle point's speed is at its peak where the metric's own peak is; the lever's
    angle is largest where it stands still."""
    cols = _evaluate(
        [
            {
                "kind": "motion",
                "point": "NB",
                "quantity": "position",
                "axis": "y",
                "event": {"quantity": "acceleration", "axis": "y", "extreme": "max"},
            },
            {
                "kind": "motion",
                "point": "NB",
                "quantity": "velocity",
                "axis": "y",
                "event": {"quantity": "acceleration", "axis": "y", "extreme": "max"},
            },
            {
                "kind": "motion",
                "point": "NT",
                "quantity": "velocity",
                "event": {"quantity": "velocity", "extreme": "max"},
            },
            {"kind": "motion", "point": "NT", "quantity": "velocity", "statistic": "peak"},
            {
                "kind": "motion",
                "link": "lever",
                "quantity": "angular_velocity",
                "event": {"link": "lever", "extreme": "max"},
            },
            {"kind": "motion", "link": "lever", "quantity": "angular_velocity", "statistic": "peak"},
            {"kind": "motion", "link": "lever", "quantity": "angle", "event": {"link": "lever", "extreme": "max"}},
            {"kind": "motion", "link": "lever", "quantity": "angle", "statistic": "max"},
        ]
    )
    r = np.array(CRANKS)
    assert np.allclose(cols["position_y_NB_at_NB_acceleration_y_max"], -(r + ROD), rtol=0, atol=1e-9)  # mm
    speed = np.abs(r * 1e-3 * W)  # m/s: the crank pin's, a scale for the bar's
    assert np.all(np.abs(cols["velocity_y_NB_at_NB_acceleration_y_max"]) < 1e-9 * speed)
    # The needle point's largest speed, the plain way: the reference's exact velocity over a
    # dense grid of crank angles, its best sample refined by a bounded scalar search.
    for i, rr in enumerate(CRANKS):
        mech = _variant(rr)
        phi = mech.phi0 + np.radians(np.arange(7200) * 0.05)
        v = np.linalg.norm(reference.solve(mech, phi, check=False).points["NT"].d, axis=1) * abs(W)
        j = int(np.argmax(v))

        def speed(p, mech=mech):
            return -float(np.linalg.norm(reference.solve(mech, [p], check=False).points["NT"].d[0])) * abs(W)

        best = -minimize_scalar(speed, bounds=(phi[j - 1], phi[j + 1]), method="bounded", options={"xatol": 1e-12}).fun
        assert cols["velocity_NT_at_NT_velocity_max"][i] == pytest.approx(best, rel=1e-10)
        assert cols["velocity_NT_peak"][i] == pytest.approx(best, rel=1e-10)
    lever = cols["angular_velocity_lever_peak"]
    assert np.all(np.abs(cols["angular_velocity_lever_at_lever_angle_max"]) < 1e-9 * lever)
    assert np.allclose(cols["angle_lever_at_lever_angle_max"], cols["angle_lever_max"], rtol=0, atol=1e-9)  # deg


def test_every_wrong_value_of_a_motion_metric_or_its_event_is_a_one_line_error():
    """Hostile input: each key of a motion metric and of its event given a value of the wrong
    kind (a list, a table, nothing, a bool, a number beyond any bound, an empty or control
    string) is a one-line MetricError, never a crash of another kind."""
    bad = [[1], {}, {"a": 1}, None, True, 1e309, "", "\x00", 10**400, -1]
    bases = [
        {"kind": "motion", "point": "NT", "quantity": "velocity"},
        {"kind": "motion", "link": "lever", "quantity": "angle"},
        {"kind": "motion", "block": "NB"},
    ]
    events = [
        {"extreme": "max"},
        {"height": 1.0, "direction": "down"},
        {"link": "lever", "extreme": "max"},
        {"quantity": "velocity", "extreme": "max"},
    ]
    keys = ("point", "link", "block", "speed", "quantity", "axis", "statistic", "event", "name")
    event_keys = ("point", "link", "quantity", "axis", "height", "from", "height_of", "direction", "extreme", "angle")
    cases = [{**b, k: v} for b in bases for k in keys for v in bad]
    cases += [{**b, "event": {**e, k: v}} for b in bases[:1] for e in events for k in event_keys for v in bad]
    for metric in cases:
        try:
            study.evaluate(HEAD, {"construct.P6.length": [15.35]}, [metric])
        except MetricError as e:
            assert "\n" not in str(e), metric
        except Exception as e:
            pytest.fail(f"{metric}: {type(e).__name__}: {e}")
