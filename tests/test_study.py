"""Design studies: study files, parameter paths, the batched reference and its metrics, the engine."""

from __future__ import annotations

import dataclasses
import json
import math
import os
import statistics
import subprocess
import sys
import warnings
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from conftest import environment_back, in_process

from mjlink import analysis, reference, validation
from mjlink.errors import MjlinkError
from mjlink.model import paths
from mjlink.reference import batch, dynamics, kinetostatics
from mjlink.runtime import cluster as runtime_cluster
from mjlink.runtime import environment
from mjlink.study import engine, spec, tasks

ROOT = Path(__file__).resolve().parent.parent
TAKEUP_PARAMS = [
    "construct.P2.length",
    "construct.P3.length_a",
    "construct.P3.length_b",
    "construct.P5.length",
    "ground.P1.x",
    "ground.P4.y",
]

BASE = """
[study]
mechanism = "takeup"
angles = 72

[sampling]
method = "tolerance"
samples = 40
seed = 7

[[parameter]]
path = "construct.P3.length_a"
tolerance = 0.05

[[parameter]]
path = "ground.P4.x"
tolerance = 0.05
distribution = "normal"

[[metric]]
kind = "thread_range"
"""


def study_text(extra: str = "", base: str = BASE) -> str:
    return base + extra


# --------------------------------------------------------------------------- study files
@pytest.mark.parametrize(
    ("text", "message"),
    [
        (BASE.replace("construct.P3.length_a", "construct.P3.lenght_a"), "did you mean 'construct.P3.length_a'"),
        (BASE.replace("ground.P4.x", "ground.P9.x"), "unknown parameter path 'ground.P9.x'"),
        (BASE.replace('kind = "thread_range"', 'kind = "thread_rang"'), "did you mean 'thread_range'"),
        (
            BASE.replace("tolerance = 0.05\n\n[[parameter]]", "tolerence = 0.05\n\n[[parameter]]"),
            "did you mean 'tolerance'",
        ),
        (BASE.replace('method = "tolerance"', 'method = "sweep"'), "method: must be one of grid, random, tolerance"),
        (BASE + '\n[verify]\nmujoco = "best"\ncount = 2\nby = "thread_rnage"\n', "did you mean 'thread_range'"),
        (BASE + '\n[verify]\nmujoco = "best"\ncount = 2\n', "'best' needs 'by'"),
        (BASE + '\n[verify]\nmujoco = "worst"\nby = "thread_range"\n', "'worst' needs 'count' (how many of the worst"),
        (BASE.replace("angles = 72", "angles = 73"), "must be even"),
        (BASE + '\n[[metric]]\nkind = "stroke"\npoint = "P55"\n', "did you mean 'P5'"),
        (BASE.replace('mechanism = "takeup"', 'mechanism = "takeupp"'), "did you mean 'takeup'"),
        (BASE.replace("samples = 40\n", ""), "missing key 'samples'"),
        (BASE + '\n[[bound]]\nmetric = "thread_range"\n', "needs 'min' or 'max'"),
    ],
)
def test_study_file_errors_are_one_line_and_name_the_nearest(text: str, message: str) -> None:
    with pytest.raises(MjlinkError) as e:
        spec.parse(text, "s.toml")
    assert message in str(e.value)
    assert "\n" not in str(e.value)
    assert str(e.value).startswith("s.toml: ")


def test_every_documented_kind_of_path_resolves() -> None:
    wk = validation.get("warp_knitting")
    for p in ("ground.P7.x", "construct.P8.phase", "construct.P9.length", "links.plunger.mass", "input.phi0"):
        assert paths.resolve(wk, p).path == p
    assert paths.resolve(wk, "construct.P8.phase").unit == "deg"
    assert paths.resolve(wk, "links.plunger.mass").nominal == pytest.approx(900.0)
    cs = validation.get("crank_slider")
    assert paths.resolve(cs, "synthesis.lambda").nominal == pytest.approx(0.35)
    # The input crank has no phase (its setting is input.phi0): refused, naming the path.
    with pytest.raises(paths.PathError, match=r"unknown parameter path 'construct\.B\.phase'"):
        paths.resolve(cs, "construct.B.phase")


def test_a_wrong_parameter_path_lists_what_its_point_or_section_has() -> None:
    """A wrong number of a point names what that point has, not another point's number; a
    wrong point names the section's points (the take-up's ground points as its file writes
    them); a guess only where it is a close spelling of what exists."""
    import tomllib

    from mjlink.model.catalogue import path_of

    cs, tu = validation.get("crank_slider"), validation.get("takeup")
    ground = ", ".join(sorted(tomllib.loads(path_of("takeup").read_text())["ground"]))
    cases = [
        (cs, "construct.B.angle", "(construct.B has length)"),
        (tu, "ground.P9.x", f"(ground has no 'P9'; it has {ground})"),
        (tu, "ground.P44.x", "(did you mean 'ground.P4.x'? ground has no 'P44'"),
        (tu, "construct.P3.lenght_a", "(did you mean 'construct.P3.length_a'? construct.P3 has length_a, length_b)"),
        (tu, "grond.P4.x", "(did you mean 'ground.P4.x'? valid paths start with: construct., "),
    ]
    for mech, path, words in cases:
        with pytest.raises(paths.PathError) as e:
            paths.resolve(mech, path)
        assert words in str(e.value), str(e.value)
    with pytest.raises(paths.PathError) as e:
        paths.resolve(cs, "construct.B.angle")
    assert "did you mean" not in str(e.value)


def test_the_summary_states_the_spread_of_values_near_the_floats_range() -> None:
    """A thread under next to no tension has a margin of some 1e301 to its breaking load:
    summary.json's standard deviation is Python's statistics module's (in exact fractions), not
    an overflow."""
    from mjlink.pipeline.study import _stats

    v = [0.5639, 1.6198e301, 1.6198e301 / 2]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        got = _stats(np.array(v))
    assert got["std"] == pytest.approx(statistics.stdev(v), rel=1e-12)


def test_sampling_is_seeded_and_within_its_law() -> None:
    st = spec.parse(BASE.replace("samples = 40", "samples = 4000"), "s.toml")
    v = st.values()
    assert np.array_equal(v, spec.parse(BASE.replace("samples = 40", "samples = 4000"), "s.toml").values())
    nominal = [p.nominal for p in st.params]
    dev = v - nominal
    assert np.abs(dev[:, 0]).max() <= 0.05 and np.abs(dev[:, 0]).max() > 0.049  # uniform over +-tol
    # normal, sigma = tol / 3: over 4000 samples the standard deviation's own spread is 1.1 %
    assert dev[:, 1].std() == pytest.approx(0.05 / 3, rel=0.05)
    grid = spec.parse(
        BASE.replace('method = "tolerance"', 'method = "grid"')
        .replace("samples = 40\nseed = 7\n", "")
        .replace('tolerance = 0.05\ndistribution = "normal"', "values = [9.6, 9.7]")
        .replace("tolerance = 0.05", "range = [21.0, 23.0]\nstep = 0.5"),
        "g.toml",
    )
    assert grid.grid_shape == (5, 2)
    assert grid.values()[:3].tolist() == [[21.0, 9.6], [21.0, 9.7], [21.5, 9.6]]  # first parameter slowest


# --------------------------------------------------------------------------- reference
def _takeup_values(n: int, seed: int = 3) -> tuple[list[paths.Param], np.ndarray]:
    mech = validation.get("takeup")
    params = [paths.resolve(mech, p) for p in TAKEUP_PARAMS]
    rng = np.random.default_rng(seed)
    return params, np.array([p.nominal for p in params]) + rng.uniform(-0.1, 0.1, (n, len(params)))


def test_batch_equals_the_single_variant_reference_bit_for_bit() -> None:
    mech = validation.get("takeup")
    params, values = _takeup_values(7)
    b = batch.solve_batch(mech, params, values, 72)
    for i in (0, 4, 6):
        v = batch.variant(mech, params, values[i])
        k = reference.solve(v, v.phi0 + b.theta)
        for p in ("P3", "P5"):
            for part in ("v", "d", "dd"):
                assert np.array_equal(getattr(k.points[p], part), b.per_variant(getattr(b.kin.points[p], part))[i])


def test_chunking_does_not_change_a_bit() -> None:
    st = spec.parse(
        study_text('\n[[metric]]\nkind = "torque_peak"\n[[metric]]\nkind = "speed_fluctuation"\n'), "s.toml"
    )
    v = st.values()
    whole = tasks.reference_chunk(st, v)
    parts = [tasks.reference_chunk(st, v[a:b]) for a, b in ((0, 1), (1, 17), (17, 40))]
    for k, col in whole.columns.items():
        assert np.array_equal(col, np.concatenate([p.columns[k] for p in parts]), equal_nan=True)


def test_metrics_agree_with_an_independent_computation() -> None:
    """Random rows of a batch against the single-design tools of mjlink (other code paths:
    trace-based analysis, scalar kinetostatics, DOP853 steady motion, check's block angles)."""
    mech = validation.get("takeup")
    params, values = _takeup_values(12, seed=11)
    mets = [
        {"kind": "stroke", "point": "P5", "axis": "y"},
        {"kind": "position_error", "point": "P5"},
        {"kind": "thread_range"},
        {"kind": "transmission_min"},
        {"kind": "torque_peak"},
        {"kind": "power_mean"},
        {"kind": "reaction_peak"},
        {"kind": "speed_fluctuation"},
    ]
    from mjlink import study

    res = study.evaluate(mech, {p.path: values[:, j] for j, p in enumerate(params)}, mets, per_turn=360)
    assert res.feasible.all()
    nominal = reference.solve(mech, analysis.one_period(mech, 360))
    for i in (2, 9):
        v = batch.variant(mech, params, values[i])
        fine = analysis.one_period(v, 20000)
        k = reference.solve(v, fine)
        y = k.points["P5"].v[:, 1]
        # Extremes refined from 1 deg samples: within 1e-5 mm (10 nm) of a 0.018 deg sampling.
        assert res.columns["stroke_P5_y"][i] == pytest.approx((y.max() - y.min()) * 1e3, abs=1e-5)
        lf = k.thread_length()
        assert lf is not None
        assert res.columns["thread_range"][i] == pytest.approx(np.ptp(lf.v) * 1e3, abs=1e-5)
        k360 = reference.solve(v, analysis.one_period(v, 360))
        err = np.linalg.norm(k360.points["P5"].v - nominal.points["P5"].v, axis=1).max() * 1e6
        assert res.columns["position_error_P5"][i] == pytest.approx(err, rel=1e-9)
        angles = validation.block_angles(v, k360)
        assert res.columns["transmission_min"][i] == pytest.approx(min(a.margin_deg for a in angles), rel=1e-9)
        cyc = analysis.torque_cycle(v, v.speed, per_turn=360)
        assert res.columns["torque_peak"][i] == pytest.approx(cyc.peak, rel=1e-9)
        assert res.columns["power_mean"][i] == pytest.approx(cyc.power, rel=1e-6)
        r = kinetostatics.reactions(v, analysis.one_period(v, 360), v.speed)
        for lab, f in r.forces.items():
            col = "reaction_peak_" + "".join(c if c.isalnum() else "_" for c in lab).strip("_")
            assert res.columns[col][i] == pytest.approx(np.linalg.norm(f, axis=1).max(), rel=1e-9)
        steady = dynamics.steady_motion(dynamics.steady_variant(v))
        # The batch's solution over the crank angle against DOP853: measured 5e-6 apart.
        assert res.columns["delta"][i] == pytest.approx(steady.delta, rel=5e-5)


def test_infeasible_variants_have_a_reason_and_no_numbers() -> None:
    res = tasks.reference_chunk(
        dataclasses.replace(
            spec.parse(study_text('\n[[metric]]\nkind = "torque_peak"\n'), "s.toml"),
        ),
        np.array([[22.0, 9.66], [8.0, 9.66], [-1.0, 9.66], [22.0, 9.66]]),
    )
    assert res.feasible.tolist() == [True, False, False, True]
    assert "dyad P2-P3-P4 cannot close at" in res.reason[1] and "deg from phi0" in res.reason[1]
    assert "construct.P3.length_a = -1 mm must be positive" in res.reason[2]
    assert all(np.isnan(c[1:3]).all() and np.isfinite(c[[0, 3]]).all() for c in res.columns.values())


def test_crank_slider_grid_edge_is_the_synthesis_bound() -> None:
    """The grid's admissible edge at e = 15 mm is the lambda_max = 0.37 that synth finds."""
    st = spec.load(ROOT / "studies" / "crank_slider_grid.toml")
    lam = np.array([0.36, 0.37, 0.38])
    res = tasks.reference_chunk(st, np.column_stack([lam, np.full(3, 15.0)]))
    theta = res.columns["pressure_max"]
    assert theta[1] <= 40.0 < theta[2]
    # The synthesized stroke, its extremes refined between the study's angles: measured 5e-7 mm.
    assert np.allclose(res.columns["stroke_C_x"], 45.0, rtol=0, atol=5e-6)
    assert reference.synthesis.largest_ratio(0.045, 0.015, math.radians(40.0)) == pytest.approx(0.37)


# ------------------------------------------------------------------------------ engine
def test_interrupted_study_resumes_from_its_finished_chunks(tmp_path: Path) -> None:
    st = spec.parse(study_text(base=BASE.replace("samples = 40", "samples = 200")), "s.toml")
    calls = []

    def stop_after_two(stage: str, done: int, total: int) -> None:
        calls.append(done)
        if len(calls) == 3:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        engine.run(st, cache_dir=tmp_path / "c", progress=stop_after_two)
    again = engine.run(st, cache_dir=tmp_path / "c")
    fresh = engine.run(st)
    assert again.resumed == 2 and fresh.resumed == 0
    assert np.array_equal(again.columns["thread_range"], fresh.columns["thread_range"])
    changed = spec.parse(
        study_text(base=BASE.replace("samples = 40", "samples = 200").replace("seed = 7", "seed = 8")), "s.toml"
    )
    assert engine.run(changed, cache_dir=tmp_path / "c").resumed == 0  # another study: cache not used


@pytest.fixture(scope="module")
def two_workers() -> Iterator[Any]:
    """A LocalCluster of 2 worker processes, started here (no mocks), shared by the tests that
    need a real cluster without starting or stopping one of their own. Its nanny's settings for
    the workers (e.g. glibc's trim threshold) are taken back out of this process's environment,
    where a cluster started later would take them for the user's."""
    from distributed import LocalCluster

    before = dict(os.environ)
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        environment_back(before)
        yield cluster


@pytest.mark.slow
def test_a_real_two_worker_dask_cluster_gives_the_same_bits(two_workers: Any) -> None:
    """A LocalCluster of 2 worker processes against in-process."""
    from distributed import Client

    st = spec.parse(
        study_text('\n[[metric]]\nkind = "torque_peak"\n', BASE.replace("samples = 40", "samples = 300")), "s.toml"
    )
    from distributed import get_task_stream

    local = engine.run(st)
    cluster = two_workers
    with Client(cluster) as client:
        assert len(client.scheduler_info()["workers"]) == 2
        with get_task_stream(client) as ts:
            remote = engine.run(st, client=client)
        with runtime_cluster.client_for(cluster.scheduler_address) as (by_client, what):
            by_address = engine.run(st, client=by_client, what=what)

        def fails(study, values):
            raise ValueError("no such thing")

        with pytest.raises(engine.EngineError, match="a study task failed on the cluster: ValueError: no such thing"):
            engine._map(client, fails, st, np.zeros((4, 1)), [(0, 2), (2, 4)], lambda k, r: None, {})
    # Every worker computed some of the chunks: nothing pins the tasks to one of them.
    assert len({d["worker"] for d in ts.data}) == 2
    assert remote.chunks == local.chunks > 2
    for k in local.columns:
        assert np.array_equal(local.columns[k], remote.columns[k], equal_nan=True)
        assert np.array_equal(local.columns[k], by_address.columns[k], equal_nan=True)
    assert "2 workers" in by_address.engine


@pytest.mark.slow
def test_dask_cluster_gives_the_same_optimum(two_workers: Any) -> None:
    """An optimization's generations on a real cluster: the in-process winner and archive."""
    from distributed import Client
    from test_optimize import CIRCLE, _short, _study

    from mjlink.study import optimize

    st = _study(_short(CIRCLE, **{"generations = 120": "generations = 10"}))
    here = optimize.run(st)
    with Client(two_workers) as client:
        there = optimize.run(st, client=client, workers=2)
    assert np.array_equal(here.winner, there.winner)
    assert np.array_equal(here.archive.objective, there.archive.objective)


@pytest.mark.slow
def test_the_actor_pool_on_a_real_cluster_survives_a_lost_worker() -> None:
    """engine.Pool (an optimization's generations) on the engine's own LocalCluster of 2
    processes: one actor per worker, the in-process bits, a failing chunk as one line, and a
    batch whose worker was killed run again on the workers left; the workers' environment
    stays theirs."""
    import signal

    st = spec.parse(study_text(base=BASE.replace("samples = 40", "samples = 64")), "s.toml")
    values = st.values()
    parts = [(0, 16), (16, 32), (32, 48), (48, 64)]
    local = tasks.reference_chunk(st, values)
    before = dict(os.environ)
    with runtime_cluster.client_for(workers=2) as (client, _):
        # The workers have the allocator settings; this process, whose nanny set them before
        # spawning each worker, has its own environment back.
        assert set(client.run(lambda: tuple(os.environ.get(k) for k in environment.MALLOC_ENV)).values()) == {
            tuple(environment.MALLOC_ENV.values())
        }
        assert dict(os.environ) == before
        with engine.Pool(client, st) as pool:
            holders = [w for ws in client.who_has(pool._futures).values() for w in ws]
            assert sorted(holders) == sorted(client.scheduler_info()["workers"])  # one actor on each worker
            got: dict[tuple[int, int], tasks.Evaluated] = {}
            pool.reference(values, parts, got.__setitem__)
            with pytest.raises(engine.EngineError, match="a study task failed on the cluster: ValueError"):
                pool.reference(np.zeros((4, 99)), [(0, 2), (2, 4)], lambda k, r: None)
            os.kill(client.run(os.getpid, workers=holders[:1])[holders[0]], signal.SIGKILL)
            again: dict[tuple[int, int], tasks.Evaluated] = {}
            pool.reference(values, parts, again.__setitem__)
    assert dict(os.environ) == before  # also after the lost worker's restart, once closed
    for run in (got, again):
        for k in local.columns:
            assert np.array_equal(np.concatenate([run[p].columns[k] for p in parts]), local.columns[k], equal_nan=True)


def test_an_unreachable_scheduler_is_one_line(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(runtime_cluster, "CONNECT_TIMEOUT_S", 1.0)
    st = spec.parse(BASE, "s.toml")
    with pytest.raises(engine.EngineError, match=r"cannot reach the Dask scheduler at tcp://127\.0\.0\.1:9"):
        with runtime_cluster.client_for("tcp://127.0.0.1:9") as (client, _):
            engine.run(st, client=client)


# ------------------------------------------------------------------------------- command
def _mjlink(*args: str, cwd: Path | None = None) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    return subprocess.run(
        [sys.executable, "-m", "mjlink", *args], capture_output=True, text=True, cwd=cwd, env=env, timeout=600
    )


def test_study_command_writes_table_summary_and_is_one_line_on_errors(tmp_path: Path) -> None:
    f = tmp_path / "tol.toml"
    f.write_text(study_text('\n[[metric]]\nkind = "stroke"\npoint = "P5"\naxis = "y"\n'))
    r = in_process("study", str(f), "--workers", "0", "--no-plots", "--out", str(tmp_path / "out"))
    assert r.returncode == 0, r.stderr
    out = tmp_path / "out" / "tol-study"
    assert "feasible: 40 of 40" in r.stdout and "stroke_P5_y" in r.stdout
    import csv

    with open(out / "results.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == 40
    assert set(rows[0]) >= {
        "variant",
        "construct.P3.length_a_mm",
        "ground.P4.x_mm",
        "thread_range_mm",
        "stroke_P5_y_mm",
    }
    import pyarrow.parquet as pq

    t = pq.read_table(out / "results.parquet")
    assert t.num_rows == 40
    assert np.array_equal(t.column("thread_range_mm").to_numpy(), [float(r["thread_range_mm"]) for r in rows])
    summ = json.loads((out / "summary.json").read_text())
    assert summ["variants"] == 40 and summ["metrics"]["thread_range"]["unit"] == "mm"
    assert not (tmp_path / "out" / ".tol-study.chunks").exists()
    # Errors: one line, exit 1.
    bad = tmp_path / "bad.toml"
    bad.write_text(BASE.replace("ground.P4.x", "ground.P44.x"))
    r = _mjlink("study", str(bad), "--workers", "0")
    assert r.returncode == 1 and r.stderr.count("\n") == 1
    assert "unknown parameter path 'ground.P44.x' (did you mean 'ground.P4.x'? ground has no 'P44'" in r.stderr
    r = _mjlink("study", "takeup_tolerence")
    assert r.returncode == 1 and "did you mean 'takeup_tolerance'" in r.stderr


def test_varied_masses_give_each_variant_its_own_loads() -> None:
    """Link masses as per-row arrays: every load metric equals the single design's."""
    from mjlink import study

    mech = validation.get("takeup")
    masses = np.array([5.0, 6.5, 9.0])
    res = study.evaluate(
        mech,
        {"links.lever.mass": masses},
        [{"kind": "torque_peak"}, {"kind": "reaction_peak"}, {"kind": "speed_fluctuation"}],
        per_turn=72,
    )
    for i, m in enumerate(masses):
        v = study.override(mech, {"links.lever.mass": m})
        one = study.evaluate(
            v, {"input.phi0": [101.0]}, [{"kind": "torque_peak"}, {"kind": "reaction_peak"}], per_turn=72
        )
        for k, col in one.columns.items():
            assert res.columns[k][i] == pytest.approx(col[0], rel=1e-12)


def test_a_force_table_scale_varies_per_variant() -> None:
    from mjlink import study

    mech = validation.get("takeup_eyelets")
    scales = np.array([0.5, 2.0])
    res = study.evaluate(mech, {"dynamics.force.P5.scale": scales}, [{"kind": "torque_peak"}], per_turn=72)
    for i, s in enumerate(scales):
        v = study.override(mech, {"dynamics.force.P5.scale": s})
        one = study.evaluate(v, {"input.phi0": [math.degrees(v.phi0)]}, [{"kind": "torque_peak"}], per_turn=72)
        assert res.columns["torque_peak"][i] == pytest.approx(one.columns["torque_peak"][0], rel=1e-12)
    assert res.columns["torque_peak"][0] != res.columns["torque_peak"][1]


@pytest.mark.parametrize("name", ["takeup", "crank_slider", "warp_knitting", "takeup_eyelets"])
def test_shaking_from_the_links_equals_the_ground_pairs_reactions(name: str) -> None:
    """Two independent routes to the frame's loads: the links' inertia and gravity summed
    (batch.frame_loads) and the kinetostatic solution's ground reactions plus the drive's."""
    mech = validation.get(name)
    phi = analysis.one_period(mech, 90)
    kin = reference.solve(mech, phi)
    fl = batch.frame_loads(mech, kin, mech.speed)
    r = kinetostatics.reactions(mech, phi, mech.speed)
    from mjlink.model.topology import pairs

    pivot = kin.points[mech.input_crank.pivot].v[:, :2]
    force = np.zeros((len(phi), 2))
    # The drive's motor and the crank bearing's viscous friction both act between crank and frame.
    moment = -r.torque + mech.dynamics.damping * mech.speed
    for _, pr in pairs(mech):
        if pr.parent is not None:
            continue
        f = -r.forces[pr.label][:, :2]  # on the frame
        force += f
        if pr.revolute:
            d = kin.points[pr.pin].v[:, :2] - pivot
        else:
            d = kin.points[mech.link(pr.child).points[0]].v[:, :2] - pivot
            moment = moment - r.moments[pr.label]
        moment = moment + d[:, 0] * f[:, 1] - d[:, 1] * f[:, 0]
    ratio = {mech.carrier(g).name: g.ratio for g in mech.geared}
    for lab, tq in r.gear.items():  # ideal gears: +T on the geared crank, -ratio T on the input
        moment = moment - tq * (1.0 - ratio[lab])
    scale_f = np.abs(fl.force).max()
    assert np.abs(force - fl.force).max() <= 1e-9 * scale_f
    assert np.abs(moment - fl.moment).max() <= 1e-9 * np.abs(fl.moment).max()


def test_a_client_registration_race_is_retried_once() -> None:
    """distributed's client fails with a bare AssertionError when the scheduler's first reply
    batch holds more than its stream-start (a race under load): the cluster module connects once more,
    and only once."""
    calls: list[str] = []

    class Flaky:
        def __init__(self, address: str, timeout: str) -> None:
            calls.append(address)
            if len(calls) == 1:
                raise AssertionError

    assert isinstance(runtime_cluster._connect(Flaky, "tcp://x:1"), Flaky) and calls == ["tcp://x:1"] * 2

    class Broken:
        def __init__(self, address: str, timeout: str) -> None:
            raise AssertionError

    with pytest.raises(AssertionError):
        runtime_cluster._connect(Broken, "tcp://x:1")


def test_a_speed_in_a_column_name_reads_in_rpm_and_the_old_name_still_works(caplog) -> None:
    """523.6 rad/s is 5,000 rpm (523.6 x 60 / 2 pi = 4999.99): the column says so; a study
    naming it the earlier way, in rad/s, runs with one note giving the new name."""
    text = (ROOT / "studies" / "takeup_counterweight.toml").read_text()
    st = spec.parse(text, ROOT / "studies" / "takeup_counterweight.toml")
    assert "shaking_force_peak_at_5000rpm" in [c.name for c in st.columns]
    assert st.optimize is not None and st.optimize.objective[0][0] == "shaking_force_peak_at_5000rpm"
    old = text.replace('objective = "shaking_force_peak_at_5000rpm"', 'objective = "shaking_force_peak_at_523p6rad_s"')
    assert old != text
    with caplog.at_level("INFO", logger="mjlink"):
        again = spec.parse(old, ROOT / "studies" / "takeup_counterweight.toml")
    assert again.optimize is not None and again.optimize.objective == st.optimize.objective
    notes = [r.message for r in caplog.records if "is now named" in r.message]
    assert (
        len(notes) == 1
        and "'shaking_force_peak_at_523p6rad_s' is now named 'shaking_force_peak_at_5000rpm'" in notes[0]
    )


def test_every_shipped_study_file_reads_with_its_own_name(tmp_path):
    """A shipped study is run by its file's name: each reads, and a name one letter too long
    for the mechanism names (32) is refused in one line that says where the name came from."""
    from mjlink.model.catalogue import shipped
    from mjlink.study import spec

    files = sorted(shipped("studies").glob("*.toml"))
    assert files
    for path in files:
        assert spec.load(path).name == path.stem
    long = tmp_path / ("s" * 33 + ".toml")
    long.write_text(files[0].read_text())
    with pytest.raises(MjlinkError) as e:
        spec.load(long)
    msg = str(e.value)
    assert "\n" not in msg and "at most 31 letters" in msg and "the file's name" in msg
