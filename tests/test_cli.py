"""The command line end to end, as a user runs it: through ``mjlink.cli.main`` in this process
(what a command computes, writes and prints), and in a real process where only a process shows
it (the one-line errors and exit statuses of ``python -m mjlink``, numpy's threads)."""

import json
import os
import re
import subprocess
import sys

import mujoco
import pytest
from conftest import ROOT, in_process
from documented import THRESHOLDS as LIMIT

ENV = {**os.environ, "PYTHONPATH": str(ROOT)}
mjlink = in_process


def in_a_process(*args, cwd=None):
    return subprocess.run(
        [sys.executable, "-m", "mjlink", *args], capture_output=True, text=True, cwd=cwd, env=ENV, timeout=600
    )


@pytest.mark.slow
def test_build_writes_loadable_mjcf(tmp_path):
    f = tmp_path / "takeup.xml"
    r = mjlink("build", "takeup", "-o", str(f))
    assert r.returncode == 0, r.stderr
    model = mujoco.MjModel.from_xml_path(str(f))
    assert model.neq == 1 and model.ntendon == 1


def test_list_and_help():
    r = mjlink("list")
    assert r.returncode == 0
    for name in ("takeup", "crank_slider", "takeup_eyelets", "warp_knitting", "lockstitch_head"):
        assert name in r.stdout
    assert r.stdout.count("source: ") == 5 and r.stdout.count("paper, docs/papers.md)") == 4
    assert "settings from Juki and Brother manuals (docs/head.md)" in r.stdout
    r = mjlink("--help")
    assert r.returncode == 0 and "examples:" in r.stdout
    r = mjlink("simulate", "--help")
    assert r.returncode == 0 and "--no-video" in r.stdout


def test_errors_are_one_line_and_nonzero(tmp_path):
    # A real process: the status the entry point exits with; the messages in this process.
    r = in_a_process("simulate", "nosuch", "--out", str(tmp_path))
    assert r.returncode == 1
    assert r.stderr.strip().count("\n") == 0 and "unknown mechanism 'nosuch'" in r.stderr
    bad = tmp_path / "bad.toml"
    bad.write_text("[mechanism]\nname = 'x'\n")
    r = mjlink("simulate", str(bad), "--out", str(tmp_path), "--no-video")
    assert r.returncode == 1 and "Traceback" not in r.stderr and str(bad) in r.stderr
    assert r.stderr.strip().count("\n") == 0
    assert not (tmp_path / "x").exists()
    r = mjlink("simulate", "takeup", "--speed", "0rad/s", "--out", str(tmp_path))
    assert r.returncode == 1 and "--speed" in r.stderr and r.stderr.strip().count("\n") == 0


def test_synth_prints_the_table_and_writes_a_runnable_file(tmp_path):
    f = tmp_path / "my_slider.toml"
    r = mjlink(
        "synth",
        "crank_slider",
        "--stroke",
        "45",
        "--offset",
        "15",
        "--lambda",
        "0.35",
        "--max-pressure-angle",
        "40",
        "--write",
        str(f),
    )
    assert r.returncode == 0, r.stderr
    assert "21.731" in r.stdout and "62.088" in r.stdout and "36.3 deg  accepted" in r.stdout
    assert "62.3 deg  rejected" in r.stdout and "largest admissible lambda (step 0.01): 0.37" in r.stdout
    r = mjlink("simulate", str(f), "--out", str(tmp_path), "--no-video", "--no-plots", "--strict")
    assert r.returncode == 0, r.stderr
    assert (tmp_path / "my_slider" / "kinematics.csv").is_file()


@pytest.mark.slow
def test_warp_knitting_crank_settings(tmp_path):
    r = mjlink(
        "simulate",
        "warp_knitting",
        "--phi01",
        "-90",
        "--phi04",
        "30",
        "--out",
        str(tmp_path),
        "--no-video",
        "--no-plots",
        "--strict",
    )
    assert r.returncode == 0, r.stderr
    rep = json.loads((tmp_path / "warp_knitting" / "report.json").read_text())
    assert rep["failures"] == []
    r = mjlink("simulate", "takeup", "--phi04", "30", "--out", str(tmp_path), "--no-video")
    assert r.returncode == 1 and "no geared crank" in r.stderr


@pytest.mark.slow
def test_torque_reactions_and_steady_commands(tmp_path):
    r = mjlink("torque", "warp_knitting", "--speed", "-1000rpm", "--out", str(tmp_path), "--strict")
    assert r.returncode == 0, r.stderr
    assert "driving torque: peak" in r.stdout and "1000.0 rpm" in r.stdout
    out = tmp_path / "warp_knitting_loads"
    for f in ("loads.csv", "reference_loads.csv", "torque.png", "reactions.png", "report.json"):
        assert (out / f).is_file(), f
    r = mjlink("reactions", "crank_slider", "--out", str(tmp_path), "--no-plots", "--strict")
    assert r.returncode == 0, r.stderr
    assert "slide:ground-needle_bar" in r.stdout
    r = mjlink("steady", "takeup", "--target-delta", "0.05", "--out", str(tmp_path), "--strict")
    assert r.returncode == 0, r.stderr
    rep = json.loads((tmp_path / "takeup_steady" / "report.json").read_text())["steady"]
    assert rep["delta_with_flywheel"] == pytest.approx(0.05, rel=1e-6)  # the secant stops within 1e-6 of it
    steady_limit = LIMIT["steady_delta_rel"] * rep["delta_with_flywheel"]
    assert abs(rep["delta_with_flywheel_mujoco"] - rep["delta_with_flywheel"]) <= steady_limit
    r = mjlink("steady", "takeup", "--stall-torque", "0.05", "--out", str(tmp_path))
    assert r.returncode == 1 and "go together" in r.stderr


def test_simulate_dynamics_flag(tmp_path):
    r = mjlink(
        "simulate",
        "crank_slider",
        "--dynamics",
        "--no-video",
        "--no-plots",
        "--out",
        str(tmp_path),
        "--stall-torque",
        "-0.8",
        "--no-load-speed",
        "-160rad/s",
        "--strict",
    )
    assert r.returncode == 0, r.stderr
    rep = json.loads((tmp_path / "crank_slider" / "report.json").read_text())
    assert rep["failures"] == [] and "steady" in rep and "loads" in rep
    assert (tmp_path / "crank_slider" / "loads.csv").is_file()


def test_command_line_runs_openblas_on_one_thread():
    """The command line's entry point, before it imports numpy, leaves numpy's OpenBLAS with one
    thread (its idle threads spun on a core the plot workers need), unless the user set a number."""
    code = (
        "import os, mjlink.__main__, mjlink.runtime.environment; mjlink.runtime.environment.one_blas_thread(); import mjlink.cli; "
        "import numpy as np; a = np.ones((600, 600)); a @ a; "
        "print(os.environ['OPENBLAS_NUM_THREADS'], len(os.listdir('/proc/self/task')))"
    )
    env = {k: v for k, v in os.environ.items() if k != "OPENBLAS_NUM_THREADS"}
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True).stdout
    assert out.split() == ["1", "1"]
    env["OPENBLAS_NUM_THREADS"] = "2"
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True).stdout
    assert out.split()[0] == "2"


# What the docs and the help say --strict does to the exit status, in each of the phrasings they
# use; every mention of --strict near an exit status must be one of these (checked below), so a
# new phrasing is read too rather than skipped.
STRICT_STATEMENTS = (
    r"--strict`?\)?:?,?\s+(?:it\s+)?exits?\s+(\d+)",  # "with `--strict` it exits 3", "--strict: exit 3"
    r"--strict`?\s+makes\s+[^.]{0,40}?\bexit\s+(\d+)",  # "`--strict` makes the command exit 3"
    r"with\s+`--strict`\s+it\s+is\s+(\d+)",  # "with `--strict` it is 3"
    r"exit(?:\s+status)?\s+(\d+)\s+with\s+`?--strict",  # "(exit status 3 with `--strict`)"
    r"--strict[^#]{0,40}#\s*exit\s+(\d+)",  # "simulate my.toml --strict   # exit 3 if ..."
    r"unless\s+--strict:\s+then\s+(\d+)",  # the help's "unless --strict: then 3"
)


def strict_statements():
    """(where, exit status) of every statement of what --strict exits with, in the guides and
    in the --help of every command that has --strict."""
    texts = {p.relative_to(ROOT): p.read_text() for p in sorted((ROOT / "docs").glob("*.md"))}
    for p in ("README.md", "mechanisms/README.md", "studies/README.md"):
        texts[p] = (ROOT / p).read_text()
    for command in ((), ("simulate",), ("torque",), ("reactions",), ("steady",), ("study",)):
        texts[" ".join(("mjlink", *command, "--help"))] = mjlink(*command, "--help").stdout
    found = []
    for where, text in texts.items():
        flat = " ".join(text.split())  # sentences wrap across lines
        spans = [(m.start(), m.end(), int(m[1])) for p in STRICT_STATEMENTS for m in re.finditer(p, flat)]
        for m in re.finditer("--strict", flat):
            if re.search(r"\bexit", flat[max(0, m.start() - 60) : m.end() + 100]):
                assert any(a <= m.start() < b for a, b, _ in spans), (
                    f"{where}: an unread statement: {flat[m.start() - 60 : m.end() + 100]!r}"
                )
        found += [(str(where), status) for _, _, status in spans]
    return found


def test_the_exit_status_the_docs_give_for_strict_is_the_one_a_run_exits_with(tmp_path):
    """A head built to Juki's settings judged against the Brother S-7200C's misses a timing check
    (docs/head.md): it exits 0, and with --strict what every statement in the docs and the help
    says."""
    found = strict_statements()
    where = {w for w, _ in found}
    assert {"docs/head.md", "docs/commands.md", "README.md", "mjlink simulate --help"} <= where, where
    text = (ROOT / "mechanisms" / "lockstitch_head.toml").read_text()
    head = tmp_path / "head.toml"
    head.write_text(text.replace('target = "juki_composite"', 'target = "brother_s7200c"', 1))
    args = ("simulate", str(head), "--out", str(tmp_path), "--no-video", "--no-plots", "--no-dynamics")
    r = mjlink(*args)
    assert r.returncode == 0 and "(brother_s7200c)" in r.stdout, r.stdout
    assert json.loads((tmp_path / "lockstitch_head" / "report.json").read_text())["failures"]
    strict = mjlink(*args, "--strict").returncode
    assert [(w, s) for w, s in found if s != strict] == []


def _design_rows(stdout: str) -> dict[str, list[str]]:
    """The lines of 'What the design does' and its dimensions, by their last word."""
    start = stdout.index("What the design does")
    rows = {}
    for line in stdout[start:].splitlines()[1:]:
        if not line.startswith("  "):
            if line.startswith("Dimensions"):
                continue
            break
        rows[line.split()[-1] if not line.split()[0].startswith("construct.") else line.split()[0]] = line.split()
    return rows


def test_simulate_prints_what_the_design_does_beside_its_base(tmp_path):
    """A copy of the take-up with one length changed: the terminal gives every headline number
    (the report's), the shipped design's beside it and the change, and the dimension changed."""
    mine = tmp_path / "my_takeup.toml"
    text = (ROOT / "mechanisms" / "takeup.toml").read_text()
    assert "length_a = 22.0" in text
    mine.write_text(text.replace("length_a = 22.0", "length_a = 23.0", 1))
    r = mjlink("simulate", str(mine), "--out", str(tmp_path), "--no-video", "--no-plots", "--no-dynamics")
    assert r.returncode == 0, r.stderr
    assert "What the design does, beside the shipped takeup" in r.stdout
    rows = _design_rows(r.stdout)
    assert rows["construct.P3.length_a"][1:] == ["23", "22", "+1", "mm"]
    rep = json.loads((tmp_path / "takeup" / "report.json").read_text())
    r0 = mjlink("simulate", "takeup", "--out", str(tmp_path / "base"), "--no-video", "--no-plots", "--no-dynamics")
    assert r0.returncode == 0, r0.stderr
    assert "What the design does (drawn at phi1 = 101 deg" in r0.stdout and "beside" not in r0.stdout
    base = {
        s["metric"]: s["value"]
        for s in json.loads((tmp_path / "base" / "takeup" / "report.json").read_text())["design"]["summary"]
    }
    for s in rep["design"]["summary"]:
        row = rows[s["metric"]]
        value, was = float(row[-5]), float(row[-4])
        assert value == pytest.approx(s["value"], rel=1e-5) and was == pytest.approx(base[s["metric"]], rel=1e-5)
    r = mjlink("simulate", str(mine), "--base", str(tmp_path / "nosuch.toml"), "--out", str(tmp_path / "x"))
    assert r.returncode == 1 and r.stderr.strip().count("\n") == 0 and "nosuch.toml" in r.stderr
    assert not (tmp_path / "x").exists()
