"""The public Python API (mjlink.__all__, docs/api.md) and the package's shape as a wheel."""

from __future__ import annotations

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
    assert re.search(r"\d+ of 806 variants feasible; smallest pressure angle \d+\.\d+ deg", out)
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


def test_a_study_in_this_process_starts_no_cluster(tmp_path, monkeypatch):
    import distributed

    def refuse(*a, **k):
        raise AssertionError("a local Dask cluster was started for workers=0")

    monkeypatch.setattr(distributed, "LocalCluster", refuse)
    res = mjlink.run_study("crank_slider_grid", tmp_path, workers=0, plots=False)
    tab = mjlink.read_study(res.out_dir)
    assert len(tab) == 806 and tab.summary["variants"] == 806
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


def test_a_finished_study_says_nothing_of_discarded_chunks(tmp_path, capsys):
    """Publishing a study removes its cache without judging the chunks against a study of
    unknown size (which said, after every finished sampled study, that they were discarded)."""
    from mjlink.cli import main

    assert main(["study", "crank_slider_grid", "--workers", "0", "--no-plots", "--out", str(tmp_path)]) == 0
    err = capsys.readouterr().err
    assert "discarding" not in err, err
    assert not (tmp_path / ".crank_slider_grid-study.chunks").exists()
