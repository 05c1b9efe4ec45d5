"""``export``: the DXF and the points file read back and compared with the reference, and with
the crank-slider's closed form."""

from __future__ import annotations

import csv
import json
import math

import numpy as np
import pytest
from conftest import in_process

from mjlink import analysis, reference
from mjlink.model import catalogue, mechanism
from mjlink.pipeline import export
from mjlink.units import DEG, to_mm

NAMES = ["takeup", "crank_slider", "takeup_eyelets", "warp_knitting", "lockstitch_head"]


@pytest.mark.parametrize("name", NAMES)
def test_the_dxf_read_back_holds_the_reference_positions_in_mm(name, tmp_path):
    mech = mechanism.load(catalogue.path_of(name))
    angle = math.degrees(mech.phi0) + 37.0
    dxf = tmp_path / f"{name}.dxf"
    r = in_process("export", name, "--dxf", str(dxf), "--angle", f"{angle}deg")
    assert r.returncode == 0, r.stderr
    got = export.read_back(dxf)
    kin = reference.solve(mech, np.array([angle * DEG]))
    at = {p: to_mm(kin.position(p))[0] for p in mech.point_names}
    assert got["units"] == 4  # millimetres
    assert {link.name for link in mech.links} | set(export.LAYERS) <= got["layers"]
    pairs = analysis.segments(mech)
    assert len(got["lines"]) == len(pairs)
    for (layer, start, end), (a, b) in zip(got["lines"], pairs, strict=True):
        assert np.allclose(start, at[a], rtol=0, atol=1e-9) and np.allclose(end, at[b], rtol=0, atol=1e-9)
        assert any(layer == link.name and a in link.points and b in link.points for link in mech.links)
    assert len(got["points"]) == len(at)
    # A pivot is a ground point a link carries; a thread guide one of the thread's that no link
    # carries: each drawn as its kind, on its own layer.
    carried = {p for link in mech.links for p in link.points}
    pivots = {p for p in mech.ground if p in carried}
    guides = {p for p in mech.ground if p not in carried and p in (mech.thread or ())}
    for layer, radius, want in (("PIVOTS", export.PIVOT_MM, pivots), ("GUIDES", export.GUIDE_MM, guides)):
        drawn = {tuple(np.round(c, 9)) for lay, c, r in got["circles"] if lay == layer and r == radius}
        assert drawn == {tuple(np.round(at[p], 9)) for p in want}, layer
    assert len(got["circles"]) == len(pivots) + len(guides)
    moving = [p for p in mech.moving_points if p not in analysis.mass_centres(mech)]
    path_kin = reference.solve(mech, mech.phi0 + np.linspace(0.0, mech.period, export.PATH_SAMPLES))
    assert sorted(got["paths"]) == sorted(f"PATH_{p}" for p in moving)  # each point's path on its own layer
    for p in moving:
        assert np.allclose(got["paths"][f"PATH_{p}"], to_mm(path_kin.position(p))[:-1], rtol=0, atol=1e-9)
    if mech.thread:  # the thread at that angle, through its points in order
        assert np.allclose(got["thread"], [at[p] for p in mech.thread], rtol=0, atol=1e-9)
    else:
        assert got["thread"] is None


def test_the_points_file_of_the_crank_slider_is_its_closed_form(tmp_path):
    """Crank r at angle t from A = (0, 0), rod l, guide y = -e: B = r (cos t, sin t),
    C = (r cos t + sqrt(l^2 - (r sin t + e)^2), -e)."""
    r_, l_, e_ = 21.730974582035103, 62.08849880581459, 15.0
    for t_deg, fmt in ((0.0, "csv"), (123.4, "json")):
        out = tmp_path / f"p{t_deg}.{fmt}"
        assert in_process("export", "crank_slider", "--points", str(out), "--angle", str(t_deg)).returncode == 0
        if fmt == "csv":
            with open(out, newline="") as f:
                rows = {row["point"]: row for row in csv.DictReader(f)}
        else:
            rows = {row["point"]: row for row in json.loads(out.read_text())["points"]}
        t = math.radians(t_deg)
        b = (r_ * math.cos(t), r_ * math.sin(t))
        c = (r_ * math.cos(t) + math.sqrt(l_**2 - (r_ * math.sin(t) + e_) ** 2), -e_)
        for name, xy in (("B", b), ("C", c)):  # to 1e-6 mm, as the file writes them
            assert float(rows[name]["x_mm"]) == pytest.approx(xy[0], abs=5e-7)
            assert float(rows[name]["y_mm"]) == pytest.approx(xy[1], abs=5e-7)
        if fmt == "csv":  # flags a spreadsheet reads, six decimals, the crank's angle on every row
            assert (rows["A"]["ground"], rows["C"]["ground"]) == ("1", "0")
            assert all(len(row[k].split(".")[1]) == 6 for row in rows.values() for k in ("x_mm", "y_mm", "z_mm"))
            assert {float(row["phi1_deg"]) for row in rows.values()} == {t_deg}
        else:
            assert rows["A"]["ground"] is True and rows["C"]["ground"] is False
            assert json.loads(out.read_text())["phi1_deg"] == t_deg


@pytest.mark.parametrize(
    ("args", "status", "message"),
    [
        ([], 1, "nothing to write"),
        (["--points", "p.txt"], 1, "must end in .csv or .json"),
        (["--dxf", "x.dxf", "--angle", "ninety"], 2, "is not a number with a unit: write e.g. 12deg"),
        # The bound of every crank angle (mechanisms/README.md, Limits: 720 deg, as phi0).
        (["--dxf", "x.dxf", "--angle", "1e17"], 1, "--angle must be finite and at most 720 deg in magnitude"),
        (["--dxf", "x.dxf", "--angle", "-720.5deg"], 1, "--angle must be finite and at most 720 deg in magnitude"),
        (["--dxf", "x.dxf", "--angle", "13rad"], 1, "--angle must be finite and at most 720 deg in magnitude"),
    ],
)
def test_bad_export_arguments_are_one_line_and_write_nothing(tmp_path, args, status, message):
    """Status 1 for a bad request, 2 for a usage error: one line each, naming the cause."""
    r = in_process("export", "takeup", *args, cwd=tmp_path)
    lines = r.stderr.strip().splitlines()
    assert r.returncode == status and len(lines) == 1 and message in lines[0], r.stderr
    assert list(tmp_path.iterdir()) == []


def test_an_existing_file_is_kept_unless_force_is_given(tmp_path):
    """export and design never replace a file the user did not ask them to: one line, status 1,
    the file untouched; --force replaces it."""
    mine = tmp_path / "mine.dxf"
    mine.write_text("my drawing")
    page = tmp_path / "mine.html"
    page.write_text("my page")
    for args, path, text in (
        (["export", "takeup", "--dxf", str(mine)], mine, "my drawing"),
        (["design", "takeup", "-o", str(page)], page, "my page"),
    ):
        r = in_process(*args)
        lines = r.stderr.strip().splitlines()
        assert r.returncode == 1 and len(lines) == 1 and "exists: give --force to replace it" in lines[0], r.stderr
        assert path.read_text() == text
        assert in_process(*args, "--force").returncode == 0 and path.read_text() != text


EXAMPLE = (catalogue.MECHANISMS_DIR / "examples" / "crank_rocker.toml").read_text()


@pytest.mark.parametrize(
    ("crank", "coupler", "rocker", "layers"),
    [
        # Expected from the rule docs/outputs.md states: the link's name, or the first free
        # suffix _2, _3, ... when a layer has it ignoring case (0, Defpoints, the five fixed
        # layers, a point's path layer PATH_<point>, a link listed before).
        ("PIVOTS", "POINTS", "LABELS", ["PIVOTS_2", "POINTS_2", "LABELS_2"]),
        ("THREAD", "Defpoints", "defpoints", ["THREAD_2", "Defpoints_2", "defpoints_3"]),
        ("lever", "Lever", "LEVER", ["lever", "Lever_2", "LEVER_3"]),
        ("GUIDES_2", "guides", "Guides", ["GUIDES_2", "guides_3", "Guides_4"]),
        ("pivots", "crank", "rocker", ["pivots_2", "crank", "rocker"]),
        ("PATH_B", "path_c", "PATHS", ["PATH_B_2", "path_c_2", "PATHS"]),  # a point's path has its layer
    ],
)
def test_every_link_has_its_own_valid_layer(tmp_path, crank, coupler, rocker, layers):
    """Links named like the export's own layers, DXF's standard ones, or each other but for
    case: the DXF is written and read back (ezdxf.readfile), one layer per link, each link's
    lines on its own layer."""
    text = EXAMPLE
    for old, new in (("crank", crank), ("coupler", coupler), ("rocker", rocker)):
        text = text.replace(f"[links.{old}]", f"[links.{new}]")
    src = tmp_path / "renamed.toml"
    src.write_text(text)
    dxf = tmp_path / "renamed.dxf"
    r = in_process("export", str(src), "--dxf", str(dxf))
    assert r.returncode == 0 and "Traceback" not in r.stderr, r.stderr
    got = export.read_back(dxf)
    expected = dict(zip((crank, coupler, rocker), layers, strict=True))
    paths = export.path_layers(mechanism.load(src)).values()
    assert got["layers"] == {"0", "Defpoints", *export.LAYERS, *paths, *layers}
    assert len({n.casefold() for n in got["layers"]}) == len(got["layers"])  # DXF compares ignoring case
    mech = mechanism.load(src)
    for layer, _, _ in got["lines"]:
        assert layer in layers
    for link in mech.links:
        on = [(a, b) for layer, a, b in got["lines"] if layer == expected[link.name]]
        assert on, f"no line on {link.name}'s layer"
