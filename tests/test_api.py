"""The public Python API (mjlink.__all__, docs/api.md) and the package's shape as a wheel."""

from __future__ import annotations

import json
import re
import subprocess
import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest
from documented import THRESHOLDS as LIMIT

import mjlink
from mjlink.model import catalogue

ROOT = Path(__file__).resolve().parent.parent


def _script(page: str, n: int = 0) -> str:
    return re.findall(r"```python\n(.*?)```", (ROOT / "docs" / page).read_text(), re.S)[n]


def test_the_documented_script_runs_as_written(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    exec(compile(_script("api.md"), "docs/api.md", "exec"), {"__name__": "__docs__"})
    out = capsys.readouterr().out
    assert "thresholds missed: none" in out
    m = re.search(r"(\d+) of 806 variants within the bounds; smallest pressure angle \d+\.\d+ deg", out)
    assert m is not None, out
    summary = json.loads((tmp_path / "renders" / "crank_slider_grid-study" / "summary.json").read_text())
    assert int(m[1]) == summary["within_bounds"]  # the table's column says what the summary counts
    import mujoco

    model = mujoco.MjModel.from_xml_path(str(tmp_path / "takeup.xml"))
    assert model.neq > 0  # the loop closure, as equality constraints
    assert (tmp_path / "renders" / "takeup" / "report.json").is_file()
    assert (tmp_path / "renders" / "crank_slider_grid-study" / "results.parquet").is_file()


def test_errors_are_one_line_mjlink_errors(tmp_path):
    exec(_script("api.md", 1), {"mjlink": mjlink})
    for call in (
        lambda: mjlink.load("tkaeup"),
        lambda: mjlink.load(tmp_path / "none.toml"),
        lambda: mjlink.read_study(tmp_path),
        lambda: mjlink.read_traces(tmp_path / "kinematics.csv"),
        lambda: mjlink.traces("takeup", speed_rpm=float("nan")),
        lambda: mjlink.traces("takeup", cycles=0),
        lambda: mjlink.traces("takeup", source="paper"),  # type: ignore[arg-type]
    ):
        with pytest.raises(mjlink.MjlinkError) as e:
            call()
        assert "\n" not in str(e.value)


def test_import_mjlink_is_light_and_every_public_name_resolves():
    code = (
        "import sys, mjlink; light = not {'numpy', 'mujoco', 'matplotlib'} & set(sys.modules);"
        "names = [getattr(mjlink, n) for n in mjlink.__all__]; print(light, len(names))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.split()
    assert out == ["True", str(len(mjlink.__all__))]
    with pytest.raises(AttributeError):
        _ = mjlink.pipeline_internals  # type: ignore[attr-defined]


def test_traces_carry_units_in_their_names_and_agree_with_the_reference():
    mech = mjlink.load("crank_slider")
    mj = mjlink.traces(mech, cycles=1, speed_rpm=600.0)
    ref = mjlink.traces(mech, cycles=1, speed_rpm=600.0, source="reference")
    assert (mj.source, ref.source, mj.mechanism) == ("mujoco", "reference", "crank_slider")
    assert list(ref) == [n for n in mj if n != "loop_gap_um"]  # the loop gap is MuJoCo's own
    assert mj["loop_gap_um"].max() <= LIMIT["loop_um"]
    units = ("_s", "_deg", "_rad_s", "_rad_s2", "_rpm", "_mm", "_mm_s", "_mm_s2", "_um")
    assert all(n.endswith(units) for n in mj), [n for n in mj if not n.endswith(units)]
    n = len(mj["time_s"])
    assert all(v.shape == (n,) for v in mj.values())
    assert np.allclose(mj["n1_rpm"], 600.0, rtol=LIMIT["speed_held_rel"], atol=0.0)  # the speed held
    assert np.ptp(mj["phi1_deg"]) == pytest.approx(360.0, abs=1e-6)  # one turn, end to end (measured 2e-9 deg)
    limit = LIMIT["position_um"] / 1000.0  # mm
    for p in ("C", "B"):
        for ax in "xy":
            assert np.abs(mj[f"{p}_{ax}_mm"] - ref[f"{p}_{ax}_mm"]).max() <= limit
    with pytest.raises(KeyError, match="no trace 'C_x_m'"):
        mj["C_x_m"]


def _joint_angle(tr, p, a, b):  # deg: the angle at p between p->a and p->b, from the position columns
    u, v = ([tr[f"{q}_{ax}_mm"] - tr[f"{p}_{ax}_mm"] for ax in "xy"] for q in (a, b))
    cos = (u[0] * v[0] + u[1] * v[1]) / (np.hypot(*u) * np.hypot(*v))
    return np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))


@pytest.mark.parametrize("name", ["lockstitch_head", "warp_knitting"])
def test_traces_hold_every_blocks_transmission_and_pressure_angle(name):
    """Every dyad's transmission angle (at its joint, between its two links) and every slider's
    pressure angle (between its rod and its guide) along the run, as the designer reads them,
    rebuilt here from the trace's own position columns; MuJoCo's from MuJoCo's positions."""
    mech = mjlink.load(name)
    mj = mjlink.traces(mech, cycles=1)
    ref = mjlink.traces(mech, cycles=1, source="reference")
    want = []
    for s in mech.steps:
        if s.kind == "dyad":
            want.append((f"{s.point}_transmission_deg", lambda tr, s=s: _joint_angle(tr, s.point, s.a, s.b)))
        elif s.kind == "slider":

            def pressure(tr, s=s):  # the rod against the guide line: 0 along it, 90 square to it
                rod = [tr[f"{s.point}_{ax}_mm"] - tr[f"{s.start}_{ax}_mm"] for ax in "xy"]
                g = [tr[f"{s.guide[1]}_{ax}_mm"] - tr[f"{s.guide[0]}_{ax}_mm"] for ax in "xy"]
                cos = np.abs(rod[0] * g[0] + rod[1] * g[1]) / (np.hypot(*rod) * np.hypot(*g))
                return np.degrees(np.arccos(np.clip(cos, 0.0, 1.0)))

            want.append((f"{s.point}_pressure_deg", pressure))
    assert len(want) >= 2 and {"dyad", "slider"} <= {s.kind for s in mech.steps}
    assert [n for n in mj if n.endswith(("_transmission_deg", "_pressure_deg"))] == [n for n, _ in want]
    # MuJoCo's positions are within the agreement threshold of the exact ones, over links of 5 mm
    # or more: its angles within 2 * threshold / 5 mm rad (the column takes the links' lengths
    # from the file and the distance their ends keep from MuJoCo's positions).
    tol = np.degrees(2 * LIMIT["position_um"] * 1e-3 / 5.0)
    for col, angle in want:
        assert np.abs(ref[col] - angle(ref)).max() <= 1e-6, col
        assert np.abs(mj[col] - angle(mj)).max() <= tol, col
        assert np.abs(mj[col] - ref[col]).max() <= tol, col


@pytest.mark.parametrize("name", ["lockstitch_head", "warp_knitting"])
def test_traces_hold_every_links_angle(name):
    """Every link's angle along the run (its guide line if it slides, else its first two points,
    as the file lists them), rebuilt here from the trace's own position columns; MuJoCo's within
    the agreement threshold of the reference's, and the reference's equal to the angle the
    function traces of a study hand a designer's function."""
    import tomllib

    from mjlink.model.catalogue import path_of

    mech = mjlink.load(name)
    raw = tomllib.loads(path_of(name).read_text())["links"]
    mj = mjlink.traces(mech, cycles=1)
    ref = mjlink.traces(mech, cycles=1, source="reference")
    tol = np.degrees(2 * LIMIT["position_um"] * 1e-3 / 5.0)  # links of 5 mm or more, as above
    for link, table in raw.items():
        a, b = table.get("guide") or table["points"][:2]
        for tr, within in ((ref, 1e-9), (mj, tol)):
            d = [tr[f"{b}_{ax}_mm"] - tr[f"{a}_{ax}_mm"] for ax in "xy"]
            want = np.degrees(np.arctan2(d[1], d[0]))
            off = np.abs(np.angle(np.exp(1j * np.radians(tr[f"{link}_angle_deg"] - want))))
            assert np.degrees(off).max() <= within, (link, tr.source)
        gap = np.angle(np.exp(1j * np.radians(mj[f"{link}_angle_deg"] - ref[f"{link}_angle_deg"])))
        assert np.degrees(np.abs(gap)).max() <= tol, link


def test_a_study_in_this_process_starts_no_cluster(tmp_path, monkeypatch):
    import distributed

    def refuse(*a, **k):
        raise AssertionError("a local Dask cluster was started for workers=0")

    monkeypatch.setattr(distributed, "LocalCluster", refuse)
    res = mjlink.run_study("crank_slider_grid", tmp_path, workers=0, plots=False)
    tab = mjlink.read_study(res.out_dir)
    assert tab.rows == 806 and tab.summary["variants"] == 806
    # A mapping like Traces: its column names, len their count.
    assert list(tab.keys()) == list(tab.columns) and len(tab) == len(tab.columns) and "within_bounds" in tab
    assert tab["reason"].dtype == object and tab["synthesis.lambda"].dtype == float


def test_the_wheel_lists_every_package_and_ships_the_data():
    conf = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
    packages = {
        ".".join(p.parent.relative_to(ROOT).parts)
        for p in (ROOT / "mjlink").rglob("__init__.py")
        if "__pycache__" not in p.parts
    }
    assert packages <= set(conf["packages"]), packages - set(conf["packages"])
    assert conf["package-dir"] == {"mjlink.mechanisms": "mechanisms", "mjlink.studies": "studies"}
    for pkg, folder in conf["package-dir"].items():
        shipped = {p.name for p in (ROOT / folder).glob("*.toml")}
        assert shipped and all(g == "*.toml" or not g.endswith(".toml") for g in conf["package-data"][pkg])
    # The checkout's folders are the shipped ones here (an editable install or a checkout).
    assert catalogue.MECHANISMS_DIR.samefile(ROOT / "mechanisms")
    assert catalogue.STUDIES_DIR.samefile(ROOT / "studies")
    assert (ROOT / "mjlink" / "py.typed").is_file()


def test_records_of_many_fields_are_built_by_keyword():
    """A record of seven or more fields (a check report, a run's summary, a timing row) cannot
    be built positionally, where two numbers of one type swapped would pass unnoticed: every
    dataclass of the package with that many constructor fields is keyword-only."""
    import dataclasses
    import importlib
    import inspect
    import pkgutil

    root = Path(mjlink.__file__).parent
    found, positional = [], []
    for info in pkgutil.walk_packages([str(root)], "mjlink."):
        module = importlib.import_module(info.name)
        for name, cls in inspect.getmembers(module, dataclasses.is_dataclass):
            if not inspect.isclass(cls) or cls.__module__ != info.name:
                continue
            fields = [f for f in dataclasses.fields(cls) if f.init]
            if len(fields) >= 7:
                found.append(name)
                positional += [f"{info.name}.{name}.{f.name}" for f in fields if not f.kw_only]
    assert {"CheckReport", "DynamicsSummary", "TimingRow", "Mechanism", "Plan"} <= set(found)
    assert positional == []


def test_a_finished_study_says_nothing_of_discarded_chunks(tmp_path, capsys):
    """Publishing a study removes its cache without judging the chunks against a study of
    unknown size (which said, after every finished sampled study, that they were discarded)."""
    from mjlink.cli import main

    assert main(["study", "crank_slider_grid", "--workers", "0", "--no-plots", "--out", str(tmp_path)]) == 0
    err = capsys.readouterr().err
    assert "discarding" not in err, err
    assert not (tmp_path / ".crank_slider_grid-study.chunks").exists()


# ================================================================= every argument, checked
BAD_PATH = [None, 5, ["takeup"], b"takeup", "", "a\x00b", "x" * 5000]
BAD_FLAG = [None, "yes", 1, 0.0, [True]]
BAD_NUMBER = ["100", [1.0], True, float("nan"), float("inf"), -1.0, 1e300, 10**400, 0]
# Every public function with valid arguments (a valid call's first refusal is the bad one).
VALID = {
    "load": {"name_or_path": "takeup"},
    "mjcf": {"mechanism": "MECH", "kinematic": False},
    "traces": {"mechanism": "MECH", "source": "mujoco", "cycles": 1.0, "speed_rpm": 955.0},
    "simulate": {
        "mechanism": "MECH",
        "out": "TMP",
        "video": False,
        "plots": False,
        "dynamics": True,
        "loads": True,
        "speed_rpm": 955.0,
        "cycles": 1.0,
        "duration": 0.5,
        "force": False,
    },
    "read_traces": {"path": "CSV"},
    "run_study": {
        "study": "crank_slider_grid",
        "out": "TMP",
        "workers": 0,
        "scheduler": None,
        "plots": False,
        "force": False,
        "progress": False,
    },
    "read_study": {"folder": "TMP"},
    "check": {"mechanism": "MECH"},
    "export": {"mechanism": "MECH", "dxf": "TMPDXF", "points": None, "angle_deg": 37.0, "force": False},
    "design": {"mechanism": "MECH", "output": None, "out": "TMP", "force": False},
    "loads": {"mechanism": "MECH", "out": "TMP", "speed_rpm": 955.0, "plots": False, "force": False},
    "steady": {"mechanism": "MECH", "out": "TMP", "plots": False, "force": False},
    "feed": {
        "mechanism": "HEAD",
        "out": "TMP",
        "speed_rpm": 3000.0,
        "sweep": False,
        "stitches": 2,
        "plots": False,
        "video": False,
        "force": False,
    },
    "synth": {
        "stroke_mm": 45.0,
        "offset_mm": 15.0,
        "ratio": 0.3,
        "max_pressure_deg": 40.0,
        "write": None,
        "force": False,
    },
}
BAD_OPTIONAL_PATH = [5, ["x.dxf"], b"x.dxf", "", "a\x00b"]  # None: the file is not asked for
BAD = {
    "name_or_path": BAD_PATH,
    "mechanism": BAD_PATH[:-1],
    "kinematic": BAD_FLAG,
    "source": [None, 3, "MUJOCO", ["mujoco"]],
    "cycles": [*BAD_NUMBER, 1e5],
    "speed_rpm": [*BAD_NUMBER, 0.001],
    "duration": [*BAD_NUMBER, 1e5],
    "out": BAD_PATH,
    "video": BAD_FLAG,
    "plots": BAD_FLAG,
    "dynamics": BAD_FLAG,
    "loads": BAD_FLAG,
    "force": BAD_FLAG,
    "path": BAD_PATH,
    "study": BAD_PATH,
    "workers": ["0", -1, 1.5, True, [1], float("nan")],
    "scheduler": [5, ["tcp://127.0.0.1:8786"], b"tcp://127.0.0.1:8786"],
    "progress": BAD_FLAG,
    "folder": BAD_PATH,
    "dxf": BAD_OPTIONAL_PATH,
    "points": BAD_OPTIONAL_PATH,
    "output": BAD_OPTIONAL_PATH,
    "write": BAD_OPTIONAL_PATH,
    "angle_deg": ["100", [1.0], True, float("nan"), float("inf"), 1e300, 10**400, 721.0],
    "stroke_mm": [*BAD_NUMBER],
    "offset_mm": ["100", [1.0], True, float("nan"), float("inf"), -1.0, 1e300, 10**400],
    "ratio": [*BAD_NUMBER, 1.5],
    "max_pressure_deg": [*BAD_NUMBER, 90.0],
    "sweep": BAD_FLAG,
    "stitches": ["3", 2.0, True, 0, 1, 51, [2], None],
}
CASES = [(fn, arg, bad) for fn, args in VALID.items() for arg in args for bad in BAD[arg]]


@pytest.fixture(scope="module")
def takeup():
    return mjlink.load("takeup")


@pytest.mark.parametrize(("fn", "arg", "bad"), CASES, ids=[f"{f}-{a}-{i}" for i, (f, a, _) in enumerate(CASES)])
def test_every_public_function_refuses_a_wrong_argument_in_one_line_naming_it(tmp_path, takeup, fn, arg, bad):
    """docs/api.md: a wrong type or a value beyond the command line's limits is one MjlinkError
    line naming the argument, before any work (nothing written)."""
    (tmp_path / "t.csv").write_text("time_s,phi1_deg\n0,0\n")
    fill = {
        "MECH": takeup,
        "TMP": str(tmp_path / "out"),
        "CSV": str(tmp_path / "t.csv"),
        "TMPDXF": str(tmp_path / "out" / "t.dxf"),
        "HEAD": "lockstitch_head",
    }
    kwargs = {k: fill.get(v, v) if isinstance(v, str) else v for k, v in VALID[fn].items()}
    kwargs[arg] = bad
    with pytest.raises(mjlink.MjlinkError) as e:
        getattr(mjlink, fn)(**kwargs)
    msg = str(e.value)
    assert "\n" not in msg and len(msg) < 600, msg
    assert msg.startswith(f"{fn}(") and arg in msg, msg
    assert not (tmp_path / "out").exists()


def test_the_api_refuses_a_run_by_the_command_lines_own_checks_before_it_starts(tmp_path, monkeypatch, capsys):
    from mjlink.cli import main
    from mjlink.sim import simulate as sim

    def never(*a, **k):
        raise AssertionError("a run was started")

    monkeypatch.setattr(sim, "run", never)
    # At the slowest speed the limits allow, 100 turns record far more than the memory bound.
    with pytest.raises(mjlink.MjlinkError) as e:
        mjlink.traces("takeup", speed_rpm=60 / (2 * np.pi), cycles=100)
    assert main(["simulate", "takeup", "--speed", "1rad/s", "--cycles", "100", "--out", str(tmp_path)]) != 0
    cli = capsys.readouterr().err.strip().removeprefix("mjlink: error: ")
    assert str(e.value) == "traces(): " + cli.replace("--cycles", "cycles").replace("--speed", "speed_rpm")
    for kwargs in ({"speed_rpm": 0.001}, {"cycles": 1e5}):
        with pytest.raises(mjlink.MjlinkError, match=r"^traces\(\): (speed_rpm|cycles) must be"):
            mjlink.traces("takeup", **kwargs)
    assert not list(tmp_path.iterdir())


TRACES_CSV = {  # content -> what the one-line error names (the file's name is in every one)
    "ragged": ("time_s,P5_y_mm\n0,1\n1\n", ":3: 1 value, the header names 2 columns"),
    "text": ("time_s,P5_y_mm\n0,1\n1,abc\n", ":3: column 2 ('P5_y_mm'): 'abc' is not a number"),
    "empty": ("", ": empty, no header row"),
    "no header": ("0,1\n1,2\n", ":1: no header row"),
    "binary": (bytes(range(256)) * 8, ": not a CSV text file"),
    "a folder": (None, " is a folder, not a CSV file"),
    "missing": (..., ": no such file"),
}


@pytest.mark.parametrize("case", list(TRACES_CSV))
def test_read_traces_refuses_a_malformed_file_in_one_line_naming_where(tmp_path, case):
    content, words = TRACES_CSV[case]
    f = tmp_path / "kinematics.csv"
    if content is None:
        f.mkdir()
    elif isinstance(content, bytes):
        f.write_bytes(content)
    elif isinstance(content, str):
        f.write_text(content)
    with pytest.raises(mjlink.MjlinkError) as e:
        mjlink.read_traces(f)
    msg = str(e.value)
    assert "\n" not in msg and msg.startswith(str(f)) and words in msg, msg


def test_read_traces_reads_back_what_simulate_wrote_exactly(tmp_path):
    res = mjlink.simulate("crank_slider", tmp_path, plots=False, dynamics=False, loads=False, cycles=1)
    back = mjlink.read_traces(res.out_dir / "kinematics.csv")
    mj = mjlink.traces("crank_slider", cycles=1)
    assert list(back) == list(mj)
    for k in mj:  # the CSV holds every double exactly (files.write_table)
        assert np.array_equal(back[k], mj[k], equal_nan=True), k
    (tmp_path / "one.csv").write_text("time_s,x_mm\nnan,-inf\n")
    one = mjlink.read_traces(tmp_path / "one.csv")
    assert one["time_s"].shape == (1,) and np.isnan(one["time_s"][0]) and one["x_mm"][0] == -np.inf


def test_read_study_refuses_a_damaged_table_in_one_line(tmp_path):
    (tmp_path / "summary.json").write_text('{"study": "x"}')
    (tmp_path / "results.parquet").write_bytes(b"PAR1" + bytes(100) + b"PAR1")
    with pytest.raises(mjlink.MjlinkError) as e:
        mjlink.read_study(tmp_path)
    assert "\n" not in str(e.value) and "results.parquet: not a readable Parquet table" in str(e.value)


def test_every_command_has_its_function_and_they_agree(tmp_path):
    """check, export, design, torque and reactions (loads), steady and synth, each through the
    API and through the command line: the same report, the same files, the same numbers."""
    from conftest import in_process

    from mjlink.cli.text import format_report
    from mjlink.pipeline import export as _export

    mech = mjlink.load("takeup")
    rep = mjlink.check("takeup")
    assert isinstance(rep, mjlink.CheckReport) and rep.ok and mjlink.check(mech).points == rep.points
    cli = in_process("check", "takeup")
    assert cli.returncode == 0 and format_report(rep, speed=mech.speed) == cli.stdout.rstrip("\n")

    res = mjlink.export(mech, dxf=tmp_path / "a.dxf", points=tmp_path / "a.csv", angle_deg=190.0)
    assert isinstance(res, mjlink.ExportResult) and res.angle_deg == 190.0
    cli = in_process(
        "export", "takeup", "--dxf", str(tmp_path / "b.dxf"), "--points", str(tmp_path / "b.csv"), "--angle", "190"
    )
    assert cli.returncode == 0
    assert (tmp_path / "a.csv").read_text() == (tmp_path / "b.csv").read_text()
    a, b = _export.read_back(tmp_path / "a.dxf"), _export.read_back(tmp_path / "b.dxf")
    assert a["lines"] == b["lines"] and a["circles"] == b["circles"] and a["layers"] == b["layers"]
    with pytest.raises(mjlink.MjlinkError, match="exists: give --force"):
        mjlink.export(mech, points=tmp_path / "a.csv")

    page = mjlink.design(mech, tmp_path / "p.html")
    assert page == tmp_path / "p.html"
    assert in_process("design", "takeup", "-o", str(tmp_path / "q.html")).returncode == 0
    assert page.read_text() == (tmp_path / "q.html").read_text()

    got = mjlink.loads(mech, tmp_path / "api", plots=False)
    assert isinstance(got, mjlink.LoadsResult) and got.failures == ()
    assert in_process("torque", "takeup", "--no-plots", "--out", str(tmp_path / "cli")).returncode == 0
    mine = json.loads((got.out_dir / "report.json").read_text())["loads"]
    theirs = json.loads((tmp_path / "cli" / "takeup_loads" / "report.json").read_text())["loads"]
    assert mine["torque_peak_N_m"] == theirs["torque_peak_N_m"]

    st = mjlink.steady(mech, tmp_path / "api", plots=False)
    assert isinstance(st, mjlink.SteadyResult) and st.failures == ()

    syn = mjlink.synth(stroke_mm=45.0, write=tmp_path / "cs.toml")
    assert isinstance(syn, mjlink.SynthResult) and mjlink.check(tmp_path / "cs.toml").ok
    before = (tmp_path / "cs.toml").read_text()
    with pytest.raises(mjlink.MjlinkError, match="exists: give --force"):
        mjlink.synth(stroke_mm=40.0, write=tmp_path / "cs.toml")
    assert (tmp_path / "cs.toml").read_text() == before

    from mjlink.cli import text

    fed = mjlink.feed("lockstitch_head", tmp_path / "g", speed_rpm=2000.0, stitches=2, plots=False)
    assert isinstance(fed, mjlink.FeedResult) and len(fed.sweep.runs) == 1
    assert fed.files == ("feed.csv", "feed_speeds.csv", "report.json")
    cli = in_process(
        "feed", "lockstitch_head", "--speed", "2000rpm", "--stitches", "2", "--no-plots", "--out", str(tmp_path / "f")
    )
    assert cli.returncode == 0
    assert cli.stdout == text.feed(fed).replace(str(tmp_path / "g"), str(tmp_path / "f")) + "\n"
    a, b = (
        json.loads((d / "lockstitch_head_feed" / "report.json").read_text()) for d in (tmp_path / "f", tmp_path / "g")
    )
    assert a["runs"] == b["runs"]
