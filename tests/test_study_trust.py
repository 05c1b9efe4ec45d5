"""Studies and optima a designer can trust: one test (or more) per class of failure.

Data loss and silent wrong results: a user's look-alike folders survive every command; a resume
cache made for another study, mechanism or code is discarded and a damaged chunk recomputed;
a winner is written only once the design as written passes check and MuJoCo; every value a
study writes into a mechanism passes the mechanism file's validation; the output folder is
checked before any work and held by one run at a time; a replaced output is said so.
The optimizer's honesty: convergence with its criterion, known answers found, caveats, a knee
that does not depend on the front's sampling, names that say what is computed. Bad input: one
line, status 2, nothing written; the cost planned before the work; interruption; progress.
"""

from __future__ import annotations

import json
import math
import os
import re
import signal
import socket
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from conftest import HUNG_S, wait_for
from test_study_plan import plan_holds

from mjlink import validation
from mjlink.cli import main
from mjlink.errors import MjlinkError
from mjlink.runtime import cluster as runtime_cluster
from mjlink.runtime import markers, staging
from mjlink.study import engine, optimize, spec

ROOT = Path(__file__).resolve().parent.parent
CRANK_ROCKER = ROOT / "mechanisms" / "examples" / "crank_rocker.toml"

SMALL = """
[study]
mechanism = "takeup"
name = "small"
angles = 36

[sampling]
method = "tolerance"
samples = 40
seed = 3

[[parameter]]
path = "construct.P3.length_a"
tolerance = 0.05

[[metric]]
kind = "thread_range"
"""


def _dead_pid() -> int:
    p = subprocess.Popen([sys.executable, "-c", "pass"])
    p.wait()
    return p.pid


def _mjlink(*args: str, cwd: Path | None = None, env: dict[str, str] | None = None, timeout: float = 300):
    return subprocess.run(
        [sys.executable, "-m", "mjlink", *args],
        capture_output=True,
        text=True,
        cwd=cwd,
        env={**os.environ, "PYTHONPATH": str(ROOT), **(env or {})},
        timeout=timeout,
    )


# ================================================================= 1. look-alike names survive
def _plant(out: Path, names: list[str]) -> dict[str, str]:
    """Folders, files and links named as mjlink's own hidden entries, each with content of the
    user's; returns what each must still hold."""
    out.mkdir(parents=True, exist_ok=True)
    dead = _dead_pid()
    planted: dict[str, str] = {}
    for n in names:
        base = n.replace("{dead}", str(dead))
        folder = out / base
        folder.mkdir()
        (folder / "mine.txt").write_text(f"user's {base}")
        planted[f"{base}/mine.txt"] = f"user's {base}"
        f = out / (base + "-file")
        f.write_text("a file of the user's")
        planted[f.name] = "a file of the user's"
    (out / "target.txt").write_text("linked")
    planted["target.txt"] = "linked"
    for n in [".crank_rocker.partial-{dead}-link", ".crank_rocker.old-{dead}"]:
        link = out / n.replace("{dead}", str(dead) + "1")
        link.symlink_to("target.txt")
        planted[link.name] = "linked"
    return planted


def _survived(out: Path, planted: dict[str, str]) -> None:
    for rel, text in planted.items():
        assert (out / rel).read_text() == text, rel


LOOKALIKES = [
    ".crank_rocker.partial-{dead}-abc",
    ".crank_rocker.old-{dead}",
    ".crank_rocker.old-1",
    ".crank_rocker_loads.partial-{dead}-x",
    ".crank_rocker_steady.old-{dead}-ab12",
    ".small-study.partial-{dead}-q",
    ".small-study.old-{dead}",
]


def test_look_alike_names_survive_every_command(tmp_path, capsys):
    out = tmp_path / "out"
    planted = _plant(out, LOOKALIKES)
    study = tmp_path / "small.toml"
    study.write_text(SMALL)
    for argv in (
        ["simulate", str(CRANK_ROCKER), "--no-video", "--no-plots", "--no-dynamics"],
        ["torque", str(CRANK_ROCKER), "--no-plots"],
        ["steady", str(CRANK_ROCKER), "--no-plots", "--stall-torque", "0.05", "--no-load-speed", "150rad/s"],
        ["study", str(study), "--workers", "0", "--no-plots"],
    ):
        assert main([*argv, "--out", str(out)]) == 0, capsys.readouterr().err
    _survived(out, planted)
    # The outputs are there, and nothing mjlink made is left beside them.
    left = {p.name for p in out.iterdir()} - {Path(k).parts[0] for k in planted}
    assert left == {"crank_rocker", "crank_rocker_loads", "crank_rocker_steady", "small-study"}


def test_a_users_folder_in_the_cache_s_place_is_refused_and_kept(tmp_path, capsys):
    out = tmp_path / "out"
    mine = out / ".small-study.chunks"
    mine.mkdir(parents=True)
    (mine / "cache.json").write_text('{"study": "small", "digest": "x", "version": 2}')
    (mine / "notes.npz").write_text("the user's")
    study = tmp_path / "small.toml"
    study.write_text(SMALL)
    assert main(["study", str(study), "--workers", "0", "--no-plots", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "mjlink did not make it" in err and str(mine) in err
    assert (mine / "notes.npz").read_text() == "the user's" and sorted(p.name for p in out.iterdir()) == [mine.name]


def test_a_killed_runs_marked_stage_is_removed_and_a_copied_output_is_not_deleted(tmp_path):
    """What mjlink made and marked goes; an old output's look-alike with mjlink's marker but no
    evidence that it is the previous output of the folder beside it stays."""
    mech = validation.get(CRANK_ROCKER)
    from mjlink import pipeline

    fast = pipeline.Options(video=False, plots=False, dynamics=False, loads=False)
    first = pipeline.run(mech, tmp_path, fast)
    dead = _dead_pid()
    stage = tmp_path / f".crank_rocker.partial-{dead}-zz"
    stage.mkdir()
    (stage / markers.MARKER).write_text(
        json.dumps(
            {
                "written_by": "mjlink",
                "kind": "simulate",
                "files": [],
                "stage": stage.name,
                "pid": dead,
                "host": os.uname().nodename,
            }
        )
    )
    copy = tmp_path / f".crank_rocker.old-{dead}"  # a copy of an output, not the folder's previous one
    copy.mkdir()
    (copy / markers.MARKER).write_text((first.out_dir / markers.MARKER).read_text())
    (copy / "kept.txt").write_text("mine")
    pipeline.run(mech, tmp_path, fast)
    assert not stage.exists()
    assert (copy / "kept.txt").read_text() == "mine"


# ================================================================= 2. stale or damaged resume cache
def _interrupted(st: spec.Study, folder: Path, after: int = 2) -> None:
    calls: list[int] = []

    def stop(stage: str, done: int, total: int) -> None:
        calls.append(done)
        if len(calls) > after:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        engine.run(st, cache_dir=folder, progress=stop)


BIG = SMALL.replace("samples = 40", "samples = 120")


@pytest.mark.parametrize("change", ["study", "mechanism", "code"])
def test_a_cache_for_another_study_mechanism_or_code_is_discarded(tmp_path, monkeypatch, caplog, change):
    from mjlink.study import cache

    mfile = tmp_path / "m.toml"
    mfile.write_text((ROOT / "mechanisms" / "takeup.toml").read_text())
    text = BIG.replace('mechanism = "takeup"', 'mechanism = "m.toml"')
    st = spec.parse(text, tmp_path / "s.toml")
    folder = tmp_path / ".small-study.chunks"
    _interrupted(st, folder)
    assert any(folder.glob("ref-*.npz"))
    if change == "study":
        st = spec.parse(text.replace("tolerance = 0.05", "tolerance = 0.06"), tmp_path / "s.toml")
    elif change == "mechanism":  # the same numbers, another text: the cache cannot know, so it goes
        mfile.write_text(mfile.read_text() + "\n# edited\n")
        st = spec.parse(text, tmp_path / "s.toml")
    else:
        monkeypatch.setattr(cache, "code_digest", lambda: "another mjlink")
    with caplog.at_level("INFO", logger="mjlink"):
        again = engine.run(st, cache_dir=folder)
    assert again.resumed == 0
    what = {"study": "the study file", "mechanism": "the mechanism file", "code": "mjlink's code"}[change]
    assert any("discarding the" in r.message and what in r.message for r in caplog.records)
    fresh = engine.run(st)
    assert np.array_equal(again.columns["thread_range"], fresh.columns["thread_range"], equal_nan=True)


@pytest.mark.parametrize("damage", ["truncated", "flipped", "garbage", "empty"])
def test_a_damaged_chunk_is_recomputed_not_a_traceback(tmp_path, caplog, damage):
    st = spec.parse(BIG, tmp_path / "s.toml")
    folder = tmp_path / "c"
    _interrupted(st, folder, after=4)
    chunk = sorted(folder.glob("ref-*.npz"))[0]
    raw = chunk.read_bytes()
    if damage == "truncated":
        chunk.write_bytes(raw[: len(raw) // 2])
    elif damage == "flipped":  # a bit of the first array's numbers
        npy = raw.index(b"\x93NUMPY")
        i = npy + 10 + int.from_bytes(raw[npy + 8 : npy + 10], "little") + 3
        chunk.write_bytes(raw[:i] + bytes([raw[i] ^ 0x40]) + raw[i + 1 :])
    elif damage == "garbage":
        chunk.write_bytes(os.urandom(len(raw)))
    else:
        chunk.write_bytes(b"")
    with caplog.at_level("INFO", logger="mjlink"):
        again = engine.run(st, cache_dir=folder)
    assert any(f"cached chunk {chunk.name} is damaged" in r.message for r in caplog.records)
    fresh = engine.run(st)
    assert np.array_equal(again.columns["thread_range"], fresh.columns["thread_range"], equal_nan=True)
    assert again.resumed >= 1


def test_a_chunk_write_interrupted_leaves_no_open_archive(tmp_path, monkeypatch):
    """Ctrl-C while a chunk is written: the interrupt goes through, the chunk file is not
    left behind, and no half-written archive is finalised later onto its closed file (which
    prints a traceback as the process exits)."""
    from mjlink.study import cache

    st = spec.parse(BIG, tmp_path / "s.toml")
    c = cache.Cache(tmp_path / "c", st, variants=4, chunking={"chunks": [[0, 4]]})
    real = np.lib.format.write_array
    calls = []

    def interrupted(*args, **kwargs):
        calls.append(1)
        if len(calls) == 2:  # the second array: the archive holds one member already
            raise KeyboardInterrupt
        return real(*args, **kwargs)

    monkeypatch.setattr(np.lib.format, "write_array", interrupted)
    unraisable = []
    monkeypatch.setattr(sys, "unraisablehook", unraisable.append)
    with pytest.raises(KeyboardInterrupt):
        c.save("ref", 0, 4, {"a": np.arange(3.0), "b": np.ones(2)})
    import gc

    gc.collect()
    assert unraisable == [] and not list((tmp_path / "c").glob("*.npz*"))
    monkeypatch.setattr(np.lib.format, "write_array", real)
    c.save("ref", 0, 4, {"a": np.arange(3.0), "b": np.ones(2)})
    got = c.load("ref", 0, 4)
    assert got is not None and np.array_equal(got["a"], np.arange(3.0)) and np.array_equal(got["b"], np.ones(2))


# ================================================================= 3. a winner check would refuse
COARSE = f"""
[study]
mechanism = "{CRANK_ROCKER}"
name = "coarse"
angles = 8

[set]
"input.phi0" = 22.5

[optimize]
objective = "stroke_C"
sense = "max"
population = 16
generations = 40
seed = 2
seeds = 1
polish_evaluations = 300

[[parameter]]
path = "construct.B.length"
range = [10.0, 29.9]

[[metric]]
kind = "stroke"
point = "C"
[[metric]]
kind = "transmission_min"
"""


def test_a_winner_is_written_only_once_check_and_mujoco_accept_it(tmp_path):
    """At 8 angles per turn the search misses the dead point between its samples and its best
    candidates pass the rocker's limit; check (3600 angles per turn) refuses them. The winner
    written is the best candidate that passes, and the study says why the better were set aside."""
    from mjlink.pipeline import study as pipeline_study

    st = spec.parse(COARSE, tmp_path / "coarse.toml")
    res = pipeline_study.run(st, tmp_path, workers=0, plots=False, progress=False)
    report = validation.check(validation.get(res.winner_file))
    assert report.ok
    assert res.verified.passed[0]
    summ = json.loads((res.out_dir / "summary.json").read_text())
    assert summ["rejected"] and "check refuses it" in summ["rejected"][0]["reason"]
    assert "raise [study] angles" in summ["rejected"][0]["reason"]
    assert res.result.winner[0] < max(r["parameters"]["construct.B.length"] for r in summ["rejected"])


# ================================================================= 4. values written into a mechanism
GRID = """
[study]
mechanism = "takeup"
angles = 36

[sampling]
method = "grid"

[[parameter]]
path = "construct.P3.length_a"
values = [21.0, 22.0]

[[parameter]]
path = "links.lever.mass"
values = [1.0, 2.0]

[[metric]]
kind = "thread_range"
"""


@pytest.mark.parametrize(
    ("old", "new", "line", "words"),
    [
        ("values = [21.0, 22.0]", "values = [-21.0, 22.0]", 10, "length_a: must be > 0, got -21 mm"),
        ("values = [1.0, 2.0]", "values = [-1.0, 2.0]", 14, "mass: must be >= 0, got -1 g"),
        ("[sampling]", '[set]\n"construct.P2.length" = -3.0\n\n[sampling]', 7, "length: must be > 0, got -3 mm"),
        ("[sampling]", '[set]\n"links.lever.inertia" = -1e-6\n\n[sampling]', 7, "inertia: must be >= 0"),
        ("[sampling]", '[set]\n"links.lever.mass" = 5e7\n\n[sampling]', 7, "mass: must be at most"),
        (
            'method = "grid"',
            'method = "random"\nsamples = 8',
            11,
            "length_a: must be > 0",
        ),
        (
            'method = "grid"',
            'method = "tolerance"\nsamples = 50',
            15,
            "mass: must be >= 0",
        ),
    ],
)
def test_every_value_a_study_writes_is_held_to_the_mechanism_files_validation(old, new, line, words):
    text = GRID.replace(old, new)
    if 'method = "random"' in text:
        text = text.replace("values = [21.0, 22.0]", "range = [-5.0, 22.0]").replace(
            "values = [1.0, 2.0]", "range = [1.0, 2.0]"
        )
    if 'method = "tolerance"' in text:
        text = text.replace("values = [21.0, 22.0]", "tolerance = 0.1").replace(
            "values = [1.0, 2.0]", 'tolerance = 100.0\ndistribution = "normal"'
        )
    with pytest.raises(MjlinkError) as e:
        spec.parse(text, "s.toml")
    msg = str(e.value)
    assert "\n" not in msg and msg.startswith(f"s.toml:{line}: ") and words in msg, msg


def test_a_robust_range_widened_by_its_tolerance_is_checked():
    body = f"""
[study]
mechanism = "{CRANK_ROCKER}"
angles = 36
[optimize]
objective = "stroke_C"
[robust]
samples = 4
[[parameter]]
path = "construct.E.length"
range = [0.0, 5.0]
tolerance = 0.5
[[metric]]
kind = "stroke"
point = "C"
"""
    with pytest.raises(MjlinkError, match=r"range with its tolerance: -0\.\d+ mm would make an invalid mechanism"):
        spec.parse(body, "r.toml")


# ================================================================= 5. the output location before the work; one run at a time
def test_a_study_into_a_folder_mjlink_did_not_write_is_refused_before_any_work(tmp_path, capsys, monkeypatch):
    out = tmp_path / "out"
    (out / "small-study").mkdir(parents=True)
    (out / "small-study" / "thesis.tex").write_text("mine")
    study = tmp_path / "small.toml"
    study.write_text(SMALL)
    computed: list[int] = []
    monkeypatch.setattr(engine, "run", lambda *a, **k: computed.append(1))
    assert main(["study", str(study), "--workers", "0", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "it was not written by mjlink" in err and "--force" in err
    assert not computed and sorted(p.name for p in out.iterdir()) == ["small-study"]
    assert [p.name for p in (out / "small-study").iterdir()] == ["thesis.tex"]


def test_a_second_run_into_the_same_folder_is_refused_while_the_first_writes(tmp_path):
    """This process holds the folder (its staging open), as a running command does: a study and
    a simulate into it are refused at once, naming it; once it has published, they run."""
    out = tmp_path / "out"
    study = tmp_path / "small.toml"
    study.write_text(SMALL)
    with staging.staged_dir(out / "small-study", kind="study", mechanism="small", command="python -m mjlink study x"):
        r = _mjlink("study", str(study), "--workers", "0", "--no-plots", "--out", str(out))
        err = [line for line in r.stderr.splitlines() if not line.startswith("mjlink: plan:")]
        assert r.returncode != 0 and len(err) == 1, r.stderr
        assert "another mjlink run is writing there" in r.stderr and f"process {os.getpid()}" in r.stderr
        assert "python -m mjlink study x" in r.stderr
        assert not (out / ".small-study.chunks").exists()  # refused before the work: nothing computed
    r = _mjlink("study", str(study), "--workers", "0", "--no-plots", "--out", str(out))
    assert r.returncode == 0, r.stderr


# ================================================================= 6. a replaced output is said so
def test_a_rerun_says_what_it_replaced(tmp_path, capsys):
    # The command line in this process: what it prints does not depend on the process.
    out = tmp_path / "out"
    # The first run writes the dynamic run's files, the second does not: they are named as removed.
    common = ["simulate", str(CRANK_ROCKER), "--no-video", "--no-plots", "--out", str(out)]
    assert main(common) == 0
    first = capsys.readouterr().err
    assert "replaced" not in first, first
    assert (out / "crank_rocker" / "dynamics.csv").is_file()
    assert main([*common, "--no-dynamics"]) == 0
    again = capsys.readouterr().err
    lines = [line for line in again.splitlines() if "replaced the previous output" in line]
    assert len(lines) == 1
    assert str(out / "crank_rocker") in lines[0] and "simulate" in lines[0] and "dynamics.csv" in lines[0]
    assert not (out / "crank_rocker" / "dynamics.csv").exists()
    assert "not written this time, so removed" in lines[0] and lines[0].startswith("mjlink: note: ")


# ================================================================= 7. convergence, known answers
@pytest.mark.parametrize(
    ("name", "answer"),
    [
        ("known_path_crank_rocker", [15.0, 45.0, 35.0, 30.0, 30.0]),
        ("known_feed_takeup_eyelets", [12.0, 40.0, 30.0, -35.0, 25.0]),
    ],
)
def test_known_answers_are_found_at_the_shipped_budgets(name, answer):
    st = spec.load(name)
    res = optimize.run(st)
    span = np.array([v.high - v.low for v in st.varied])
    assert np.all(np.abs(res.winner - answer) <= 1e-6 * span), (res.winner - answer) / span
    assert res.converged and not res.not_converged
    assert all(r.converged for r in res.runs)
    plan_holds(st, res.evaluations)


def test_an_unconverged_search_says_so_everywhere(tmp_path, capsys):
    f = tmp_path / "short.toml"
    f.write_text(
        (ROOT / "studies" / "known_path_crank_rocker.toml")
        .read_text()
        .replace("../mechanisms", str(ROOT / "mechanisms"))
        .replace("generations = 300", "generations = 4")
        .replace('title = "', 'name = "short"\ntitle = "')
    )
    assert main(["study", str(f), "--workers", "0", "--no-plots", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "converged: NO: " in out and "still improving at its last generation (4)" in out
    summ = json.loads((tmp_path / "short-study" / "summary.json").read_text())
    assert summ["converged"] is False and summ["convergence"]["criterion"].startswith("each run's differential")
    assert any("still improving" in w for w in summ["convergence"]["not_converged"])
    page = (tmp_path / "short-study" / "index.html").read_text()
    assert "NOT CONVERGED" in page and "Criterion:" in page
    assert "NOT CONVERGED" in (tmp_path / "short-study" / "winner.toml").read_text()
    # The winner's metrics beside the mechanism file's design (a study without tolerances has
    # no second value of the winner to show).
    lines = out.splitlines()
    head = next(i for i, line in enumerate(lines) if line.startswith("metric "))
    assert lines[head].split()[-3:] == ["winner", "file", "design"], lines[head]
    for line in lines[head + 1 : head + 1 + len(summ["winner"]["metrics"])]:
        name, *_, winner, file_design = line.split()
        # printed to 6 significant digits
        assert float(winner) == pytest.approx(summ["winner"]["metrics"][name]["value"], rel=1e-5)
        assert float(file_design) == pytest.approx(summ["mechanism_file_design"]["metrics"][name], rel=1e-5)


def test_the_polish_never_overflows_on_a_degenerate_covariance():
    """A nearly singular covariance made the CMA-ES polish's evolution path so long that the
    step-size update overflowed (a traceback at the end of a head's take-up synthesis): the
    factor is capped at e per generation, the axes floored relative to the longest."""
    from mjlink.study import polish

    assert polish.step_size(0.1, 1e300, 0.3, 1.3, 3.4) == pytest.approx(0.1 * math.e)
    assert polish.step_size(0.1, 3.4, 0.3, 1.3, 3.4) == pytest.approx(0.1)
    d = polish.axes(np.array([1.0, 1e-300, 0.0, -1e-17]))
    assert np.all(np.isfinite(1.0 / d)) and d.min() == pytest.approx(1e-10)
    # A whole polish whose objective only one coordinate moves, from the box's corner.
    r = polish.polish(
        lambda X: ((X[:, 0] - 0.3) ** 2, np.where(X[:, 1:].min(axis=1) < 1.0, 1.0, 0.0)),
        np.ones(12),
        0.49,
        sigma0=0.2,
        evaluations=4000,
        seed=1,
    )
    assert math.isfinite(r.step) and r.f <= 0.49


# ================================================================= 8. caveats, rounding
CIRCLE = f"""
[study]
mechanism = "{CRANK_ROCKER}"
name = "t"
angles = 72
[optimize]
objective = "path_error_B"
population = 20
generations = 120
seed = 7
seeds = 2
tol = 0
atol = 1e-10
[[parameter]]
path = "construct.B.length"
range = [8.0, 20.0]
[[parameter]]
path = "ground.D.x"
range = [46.0, 54.0]
[[metric]]
kind = "path_error"
point = "B"
targets = [[6.0, 10.392304845413264]]
"""


def test_caveats_name_range_bounds_active_constraints_and_redundant_parameters(tmp_path):
    res = optimize.run(spec.parse(CIRCLE, "c.toml"))
    # The rocker pivot does not move the crank pin's path: the objective does not depend on it.
    assert any(t.startswith("ground.D.x: the objective does not change") for t in res.caveats.redundant)
    assert res.caveats.seeds is not None and res.caveats.seeds.agree
    # Runs that agree speak for the winner: a finding, not a caveat.
    assert not [c for c in res.caveats.lines() if c.startswith("runs:")]
    assert [f[:40] for f in res.caveats.findings()] == [
        f"runs: the {len(res.caveats.seeds.seeds)} independent runs' optima agree"[:40]
    ]
    edge = spec.parse(CIRCLE.replace("range = [8.0, 20.0]", "range = [8.0, 11.0]"), "c.toml")
    at = optimize.run(edge).caveats.at_bounds
    assert any("construct.B.length = 11 mm is within 1% of its range's high end" in t for t in at)
    head = """
[study]
mechanism = "crank_slider"
angles = 180
[optimize]
objective = "distance_A_C"
population = 16
generations = 60
seed = 1
seeds = 1
[[parameter]]
path = "synthesis.lambda"
range = [0.2, 0.6]
[[metric]]
kind = "distance"
points = ["A", "C"]
[[metric]]
kind = "pressure_max"
[[bound]]
metric = "pressure_max"
max = 40.0
"""
    active = optimize.run(spec.parse(head, "h.toml")).caveats.active
    assert len(active) == 1 and active[0].startswith("pressure_max <= 40")
    # A band narrower than the 1 % a caveat allows has both ends near: the winner is named
    # once, on the end it sits on.
    band = head.replace("max = 40.0", "min = 39.9\nmax = 40.0")
    active = optimize.run(spec.parse(band, "h.toml")).caveats.active
    assert len(active) == 1 and active[0].endswith("on its max"), active


def test_the_winner_file_is_rounded_to_the_resolution_and_reverified(tmp_path):
    from mjlink.pipeline import study as pipeline_study
    from mjlink.study.spec import parse

    st = parse(CIRCLE.replace("seeds = 2", "seeds = 1").replace("[8.0, 20.0]", "[8.0, 20.003]"), tmp_path / "c.toml")
    res = pipeline_study.run(st, tmp_path, workers=0, plots=False, progress=False)
    text = res.winner_file.read_text()
    import tomllib

    raw = tomllib.loads(text)
    b = next(s for s in raw["construct"] if s["point"] == "B")
    assert b["length"] == round(b["length"], 2) and len(repr(b["length"])) <= 6
    assert raw["ground"]["D"][0] == round(raw["ground"]["D"][0], 2)
    summ = json.loads((res.out_dir / "summary.json").read_text())
    p = summ["parameters"][0]
    assert abs(p["winner"] - p["optimum"]) <= 0.005 and summ["winner"]["mujoco"]["passed"]
    assert summ["optimizer"]["resolution"] == {"deg": 0.01, "mm": 0.01}


def test_a_resolution_in_the_study_file_is_used():
    st = spec.parse(CIRCLE.replace("seed = 7", "seed = 7\nresolution = { mm = 0.5 }"), "c.toml")
    from mjlink.pipeline.winner import rounded_candidates

    assert rounded_candidates(st, np.array([12.26, 50.3]))[0].tolist() == [12.5, 50.5]


# ================================================================= 9. the knee
PARETO = """
[study]
mechanism = "crank_slider"
angles = 90
[optimize]
pareto = ["accel_peak_C", "distance_A_C"]
points = POINTS
population = 12
generations = 40
seed = 2
[[parameter]]
path = "synthesis.lambda"
range = [0.15, 0.5]
[[metric]]
kind = "acceleration_peak"
point = "C"
[[metric]]
kind = "distance"
points = ["A", "C"]
[[metric]]
kind = "pressure_max"
[[bound]]
metric = "pressure_max"
max = 40.0
"""


def test_the_knee_does_not_depend_on_how_the_front_was_sampled():
    a = optimize.run(spec.parse(PARETO.replace("POINTS", "3"), "p.toml"))
    b = optimize.run(spec.parse(PARETO.replace("POINTS", "6"), "p.toml"))
    assert a.front is not None and b.front is not None and len(b.front) > len(a.front)
    assert abs(a.winner[0] - b.winner[0]) <= 1e-6 * 0.35
    assert any(np.array_equal(a.winner, x) for x in a.front) and any(np.array_equal(b.winner, x) for x in b.front)


def test_a_seed_dependent_result_says_how_much():
    body = (ROOT / "studies" / "takeup_eyelets_demand.toml").read_text()
    body = body.replace("generations = 150", "generations = 6").replace("population = 96", "population = 24")
    body = body.replace("seed = 3", "seed = 3\nseeds = 2\npolish_evaluations = 200")
    res = optimize.run(spec.parse(body, ROOT / "studies" / "x.toml"))
    s = res.caveats.seeds
    assert s is not None and s.seeds == (3, 4) and len(s.objectives) == 2 and s.spread > 0
    assert not s.agree and not res.converged and any("runs' optima differ" in w for w in res.not_converged)


# ================================================================= 10. names that say what is computed
def test_shaking_force_is_the_inertia_and_the_gravity_load_is_its_own():
    from mjlink import study as api

    mech = api.mechanism("takeup")
    cols = api.evaluate(
        mech,
        {"input.phi0": [math.degrees(mech.phi0)]},
        [{"kind": k} for k in ("shaking_force_peak", "frame_force_peak", "gravity_load", "shaking_moment_peak")],
        per_turn=360,
    ).columns
    from mjlink import analysis, reference

    phi = analysis.one_period(mech, 360)
    kin = reference.solve(mech, phi)
    w2 = mech.speed**2
    inertia = np.zeros((len(phi), 2))
    weight = 0.0
    for l in mech.links:
        if l.com is not None and l.mass > 0:
            inertia -= l.mass * kin.points[l.com].dd[:, :2] * w2
            weight += l.mass * mech.dynamics.gravity
    assert cols["shaking_force_peak"][0] == pytest.approx(np.linalg.norm(inertia, axis=1).max(), rel=1e-12)
    assert cols["gravity_load"][0] == pytest.approx(weight, rel=1e-12)
    total = inertia + np.array([0.0, -weight])
    assert cols["frame_force_peak"][0] == pytest.approx(np.linalg.norm(total, axis=1).max(), rel=1e-12)
    assert cols["frame_force_peak"][0] != pytest.approx(cols["shaking_force_peak"][0], rel=1e-6)
    readme = (ROOT / "studies" / "README.md").read_text()
    assert "`gravity_load`" in readme and "`frame_force_peak`" in readme


# ================================================================= 11. bad input: one line, status 2, nothing written
def _case_files(tmp_path: Path) -> dict[str, str]:
    base = SMALL.replace('name = "small"', 'name = "bad"')
    cases = {
        "grid_overflow": base.replace('method = "tolerance"\nsamples = 40', 'method = "grid"').replace(
            "tolerance = 0.05",
            # 10^5 x 10^5 x 10^4 = 10^14 variants: each parameter's values are built before the
            # grid's size is checked, so three moderate counts keep that cheap (two of 10^7 took 1.3 s).
            "range = [21.0, 23.0]\ncount = 100000\n\n[[parameter]]\npath = 'ground.P4.x'\nrange = [9, 10]\ncount = 100000"
            "\n\n[[parameter]]\npath = 'ground.P4.y'\nrange = [2, 3]\ncount = 10000",
        ),
        "deep": base + "\n[[metric]]\nkind = 'stroke'\npoint = " + "[" * 5000 + "]" * 5000 + "\n",
        "digits_5000": base.replace("samples = 40", "samples = " + "9" * 5000),
        "digits_400": base.replace("angles = 36", "angles = " + "9" * 400),
        "step_overflow": base.replace('method = "tolerance"\nsamples = 40', 'method = "grid"').replace(
            "tolerance = 0.05", "range = [-1e308, 1e308]\nstep = 1e-300"
        ),
        "speed_overflow": base + "\n[[metric]]\nkind = 'torque_peak'\nspeed = 1e308\n",
        "speed_integer": base + "\n[[metric]]\nkind = 'torque_peak'\nspeed = " + "9" * 400 + "\n",
        "huge_file": base + "#" + "x" * (1 << 21) + "\n",
    }
    for name, text in cases.items():
        (tmp_path / f"{name}.toml").write_text(text)
    return cases


@pytest.mark.parametrize(
    ("case", "words"),
    [
        ("grid_overflow", "the grid has 100000000000000 variants, at most 10000000"),
        ("deep", "nested too deeply"),
        ("digits_5000", "an integer of more than 4300 digits"),
        ("digits_400", "must be an integer from 8 to 3600, got <an integer of 400 digits>"),
        ("step_overflow", "gives more than 10000000 values"),
        ("speed_overflow", "speed must be 1 to 10000 rad/s"),
        ("speed_integer", "speed must be 1 to 10000 rad/s"),
        ("huge_file", "a study file is at most 1048576 bytes"),
    ],
)
def test_bad_study_files_are_one_line_status_2_nothing_written(tmp_path, capsys, case, words):
    _case_files(tmp_path)
    out = tmp_path / "out"
    assert main(["study", str(tmp_path / f"{case}.toml"), "--workers", "0", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("mjlink: error: ") and words in err, err
    assert not out.exists()


@pytest.mark.parametrize(
    ("args", "words"),
    [
        (["--scheduler", "garbage!!"], "is not a Dask scheduler address"),
        (["--scheduler", "tcp://127.0.0.1:99999"], "is not a Dask scheduler address"),
        (["--scheduler", "tcp://127.0.0.1:9"], "cannot reach the Dask scheduler at tcp://127.0.0.1:9"),
        (["--out", "AFILE"], "AFILE is a regular file, not a folder"),
        (["--out", "FIFO"], "FIFO is a FIFO (named pipe), not a folder"),
        (["--out", "SOCKET"], "SOCKET is a socket, not a folder"),
        (["--max-memory", "1MiB"], "the study would need about"),
    ],
)
def test_bad_command_line_values_are_one_line_status_2_nothing_written(tmp_path, capsys, monkeypatch, args, words):
    """Refused before the work: the study's engine is never called."""
    computed: list[int] = []
    monkeypatch.setattr(engine, "run", lambda *a, **k: computed.append(1))
    study = tmp_path / "small.toml"
    study.write_text(SMALL)
    (tmp_path / "AFILE").write_text("mine")
    os.mkfifo(tmp_path / "FIFO")
    with socket.socket(socket.AF_UNIX) as s:
        s.bind(str(tmp_path / "SOCKET"))
    args = [str(tmp_path / a) if a in ("AFILE", "FIFO", "SOCKET") else a for a in args]
    for made in ("AFILE", "FIFO", "SOCKET"):
        words = words.replace(f"{made} is", f"{tmp_path / made} is")
    before = sorted(p.name for p in tmp_path.iterdir())
    out = ["--out", str(tmp_path / "out")] if "--out" not in args else []
    assert main(["study", str(study), *args, *out]) == 2
    err = [line for line in capsys.readouterr().err.splitlines() if not line.startswith("mjlink: plan:")]
    assert len(err) == 1 and words in err[0], err
    assert not computed
    assert sorted(p.name for p in tmp_path.iterdir()) == before
    assert (tmp_path / "AFILE").read_text() == "mine"


def test_a_study_path_of_an_unknown_user_is_one_line_status_2(capsys):
    assert main(["study", "~nosuchuser_mjlink/s.toml"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "cannot expand '~nosuchuser_mjlink'" in err


# ================================================================= 12. the cost, before the work
def test_a_study_too_large_for_the_machine_is_refused_with_its_estimate(tmp_path, capsys, monkeypatch):
    body = (ROOT / "studies" / "takeup_eyelets_demand_robust.toml").read_text()
    body = body.replace("population = 96", "population = 100000").replace("samples = 16", "samples = 100000")
    f = tmp_path / "huge.toml"
    f.write_text(body)
    st = spec.load(f)
    assert st.optimize is not None and st.optimize.population == 100000 and st.robust is not None
    computed: list[int] = []
    monkeypatch.setattr(engine, "run", lambda *a, **k: computed.append(1))
    monkeypatch.setattr(optimize, "run", lambda *a, **k: computed.append(1))
    assert main(["study", str(f), "--out", str(tmp_path / "out")]) == 2
    assert not computed  # refused from its estimate, before the work
    err = capsys.readouterr().err.splitlines()
    assert err[0].startswith("mjlink: plan: ") and "GiB" in err[0]
    assert err[1].startswith("mjlink: error: ") and "more than the" in err[1] and "--max-memory" in err[1]
    assert not (tmp_path / "out").exists()


def test_dry_run_prints_the_plan_and_writes_nothing(tmp_path, capsys):
    study = tmp_path / "small.toml"
    study.write_text(SMALL)
    assert main(["study", str(study), "--dry-run", "--workers", "64", "--out", str(tmp_path / "out")]) == 0
    cap = capsys.readouterr()
    cores = os.cpu_count() or 1
    assert f"--workers 64 is more than this machine's {cores} cores: using {cores}" in cap.err
    plan = next(line for line in cap.err.splitlines() if line.startswith("mjlink: plan: "))
    assert "40 variants x 36 crank angles" in plan and "memory about" in plan and "time about" in plan
    assert "dry run" in cap.out and not (tmp_path / "out").exists()
    # It says what its calibration computed: a dry run plans by measuring a few variants.
    assert re.search(
        r"dry run: nothing written \(its plan computed \d+ variants? here to measure their cost\)", cap.out
    )


def test_the_plan_measures_and_scales():
    from mjlink.study import plan

    st = spec.parse(SMALL, "s.toml")
    cal = plan.Calibration(2e-6, 1000.0, 0.5)
    p = plan.estimate(st, workers=2, calibration=cal, limit=1e12)
    assert p.variants == 40 and p.angles == 36 and p.mujoco_models == 0
    # studies/README.md, Engine: about 16 reference tasks of 8..256 variants. 40 variants in 16
    # would be under 8 each: tasks of 8; a sixteenth of a million is over 256: tasks of 256.
    assert p.tasks == math.ceil(40 / 8)
    # The time is the variant-angles at the calibrated seconds each, shared by the workers: at
    # least that share, in proportion to the calibration, halved by twice the workers.
    assert p.seconds >= 40 * 36 * 2e-6 / 2
    slower = plan.estimate(st, workers=2, calibration=plan.Calibration(6e-6, 1000.0, 0.5), limit=1e12)
    assert slower.seconds == pytest.approx(3 * p.seconds, rel=1e-12)
    assert plan.estimate(st, workers=1, calibration=cal, limit=1e12).seconds == pytest.approx(2 * p.seconds, rel=1e-12)
    big = plan.estimate(
        spec.parse(SMALL.replace("samples = 40", "samples = 1000000"), "s.toml"), workers=2, calibration=cal
    )
    assert big.memory > 1e8 and big.tasks == math.ceil(1_000_000 / 256)
    with pytest.raises(plan.PlanError, match="more than the 1 bytes"):
        plan.estimate(st, workers=1, calibration=cal, limit=1.0).check()
    from mjlink.cli.values import parse_size

    assert parse_size("64GiB") == 64 * 2**30 and parse_size("500MB") == 5e8


def test_a_cluster_without_workers_fails_within_a_timeout(monkeypatch):
    from distributed import LocalCluster

    monkeypatch.setattr(runtime_cluster, "WORKERS_TIMEOUT_S", 2.0)
    with LocalCluster(n_workers=0, processes=False, dashboard_address=None) as cluster:
        # The error says the wait ended at the timeout set here, not at the default.
        with pytest.raises(engine.SchedulerError, match=r"has no workers \(none joined within 2 s\)"):
            with runtime_cluster.client_for(cluster.scheduler_address):
                pass


def test_a_flywheel_without_a_motor_is_refused_when_the_file_is_read():
    body = CIRCLE.replace("atol = 1e-10", "atol = 1e-10\nflywheel_delta = 0.02")
    with pytest.raises(MjlinkError, match=r"flywheel_delta: sizing a flywheel needs a drive characteristic"):
        spec.parse(body, "c.toml")


# ================================================================= 13. interruption
@pytest.mark.slow
def test_ctrl_c_prints_at_most_three_lines_and_the_study_resumes(tmp_path):
    """SIGINT to the whole process group, as a terminal sends it, during a study on a local
    cluster: three lines at most after the plan, status 130, no worker left, the finished
    chunks kept; the same command then resumes and gives the uninterrupted study's numbers."""
    study = tmp_path / "s.toml"
    # 235 chunks: after the third is written, the rest and the publication outlast the poll
    # below many times over (also with both cores loaded), so the interrupt lands with chunks
    # left.
    study.write_text(SMALL.replace("samples = 40", "samples = 60000"))
    out = tmp_path / "out"
    env = {**os.environ, "PYTHONPATH": str(ROOT), "MJLINK_PROGRESS_SECONDS": "1000"}
    # python -m mjlink as a terminal's foreground job starts it: with SIGINT at its default. A
    # shell's background job (the suite may run as one) has SIGINT ignored, which a child
    # inherits and Python then leaves ignored, so the study would never see the Ctrl-C.
    foreground = (
        "import runpy, signal; signal.signal(signal.SIGINT, signal.default_int_handler); "
        "runpy.run_module('mjlink', run_name='__main__', alter_sys=True)"
    )
    args = [sys.executable, "-c", foreground, "study", str(study), "--out", str(out), "--no-plots"]
    # On a local cluster of one worker process: a cluster all the same (scheduler, nanny, worker).
    p = subprocess.Popen(
        [*args, "--workers", "1"],
        stderr=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
        env=env,
        start_new_session=True,
    )
    cache_dir = out / ".small-study.chunks"
    wait_for(lambda: len(list(cache_dir.glob("ref-*.npz"))) >= 3 or p.poll() is not None, "three finished chunks")
    assert p.poll() is None, p.communicate()[1]  # still running: the interrupt lands with chunks left
    os.killpg(p.pid, signal.SIGINT)
    _, err = p.communicate(timeout=HUNG_S)
    assert p.returncode == 130, err
    lines = [line for line in err.splitlines() if not line.startswith("mjlink: plan:")]
    assert len(lines) <= 3 and lines[-1] == "mjlink: interrupted", err
    assert "Traceback" not in err and "Port 8787" not in err
    kept = len(list(cache_dir.glob("ref-*.npz")))
    assert kept >= 3 and not (out / "small-study").exists()

    def running() -> list[str]:  # the session's processes still running (an exited one may wait to be reaped)
        ps = subprocess.run(["ps", "-o", "stat=", "-s", str(p.pid)], capture_output=True, text=True).stdout.split()
        return [s for s in ps if not s.startswith("Z")]

    wait_for(lambda: running() == [], "the interrupted study's processes to end")
    r = subprocess.run([*args, "--workers", "0"], capture_output=True, text=True, env=env, timeout=300)
    assert r.returncode == 0 and "resuming:" in r.stderr, r.stderr
    summ = json.loads((out / "small-study" / "summary.json").read_text())
    assert summ["resumed_chunks"] >= kept and not cache_dir.exists()
    st = spec.load(study)
    fresh = engine.run(st)
    import csv

    with open(out / "small-study" / "results.csv", newline="") as fh:
        got = np.array([float(row["thread_range_mm"]) for row in csv.DictReader(fh)])
    assert np.array_equal(got, fresh.columns["thread_range"])


@pytest.mark.slow
def test_two_local_studies_at_once_print_no_port_warning(tmp_path):
    for i in (1, 2):
        (tmp_path / f"s{i}.toml").write_text(SMALL.replace('name = "small"', f'name = "s{i}"'))
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    procs = [
        subprocess.Popen(
            [
                sys.executable,
                "-m",
                "mjlink",
                "study",
                str(tmp_path / f"s{i}.toml"),
                "--out",
                str(tmp_path),
                "--no-plots",
            ],
            stderr=subprocess.PIPE,
            stdout=subprocess.PIPE,
            text=True,
            env=env,
        )
        for i in (1, 2)
    ]
    for p in procs:
        _, err = p.communicate(timeout=300)
        assert p.returncode == 0, err
        assert "Port" not in err and "Traceback" not in err and "UserWarning" not in err


# ================================================================= 14. progress without a terminal
def test_progress_without_a_terminal_prints_lines_between_updates():
    """The lines come from the thread, one a period, also while nothing is updated, and the
    next one tells the update. Counted, not timed: the period is short here, and only a hung
    thread makes the test wait long."""
    from mjlink.runtime.progress import Lines

    class Sink:
        def __init__(self) -> None:
            self.lines: list[str] = []

        def write(self, s: str) -> None:
            if s.strip():
                self.lines.append(s)

        def flush(self) -> None:
            pass

    sink = Sink()
    lines = Lines("study x", "variants", stream=sink, every=0.01)  # type: ignore[arg-type]
    lines.update("reference", 0, 1000)
    wait_for(lambda: len(sink.lines) >= 3, "three lines without an update")
    assert all("reference 0 of 1,000 variants (0.0%)" in line for line in sink.lines[:3]), sink.lines
    lines.update("reference", 500, 1000)
    wait_for(lambda: "500 of 1,000" in sink.lines[-1], "a line after the update")
    lines.close()
    text = sink.lines[-1]
    assert "reference 500 of 1,000 variants (50.0%)" in text and "variants/s" in text and "left" in text


def test_a_study_without_a_terminal_prints_progress_lines(tmp_path):
    study = tmp_path / "s.toml"
    study.write_text(SMALL.replace("samples = 40", "samples = 3000"))
    r = _mjlink(
        "study",
        str(study),
        "--workers",
        "0",
        "--no-plots",
        "--out",
        str(tmp_path),
        env={"MJLINK_PROGRESS_SECONDS": "0.2"},
    )
    assert r.returncode == 0, r.stderr
    prog = [line for line in r.stderr.splitlines() if line.startswith("mjlink: study small: reference")]
    assert prog and "\r" not in r.stderr and prog[-1].startswith("mjlink: study small: reference 3,000 of 3,000")
