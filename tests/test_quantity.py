"""One grammar for a number with its unit: the parser, and the same forms accepted in a
mechanism file, a study file and on the command line."""

from __future__ import annotations

import math
import re

import pytest
from conftest import in_process

from mjlink import quantity
from mjlink.cli.commands import quantity_arg
from mjlink.model import catalogue, mechanism
from mjlink.study import spec


@pytest.mark.parametrize(
    ("text", "unit", "value"),
    [
        ("2s", "s", 2.0),
        ("2 s", "s", 2.0),
        ("500 ms", "s", 0.5),
        ("2", "s", 2.0),
        ("100rpm", "rad/s", 100.0 * math.pi / 30.0),
        ("-955 rev/min", "rad/s", -955.0 * math.pi / 30.0),
        ("10.5rad/s", "rad/s", 10.5),
        ("12mm", "mm", 12.0),
        ("1.2cm", "mm", 12.0),
        ("0.5 m", "mm", 500.0),
        ("3deg", "deg", 3.0),
        ("0.5 rev", "deg", 180.0),
        ("15 g", "g", 15.0),
        ("0.02 kg", "g", 20.0),
        ("2.5e-1 N*m", "N*m", 0.25),
        ("1e-3", "kg*m^2", 1e-3),
    ],
)
def test_a_number_with_its_unit_in_the_unit_expected(text, unit, value):
    assert quantity.parse(text, unit) == pytest.approx(value, rel=1e-15)


@pytest.mark.parametrize(
    ("text", "unit", "message"),
    [
        ("12 s", "mm", "'s' is not a unit of length (m, cm, mm, um, µm)"),
        ("twelve", "mm", "is not a number with a unit"),
        ("12 furlongs", "mm", "'furlongs' is not a unit of length"),
        ("1e999 mm", "mm", "is not finite"),
    ],
)
def test_a_wrong_quantity_names_the_units_that_fit(text, unit, message):
    with pytest.raises(quantity.QuantityError, match=re.escape(message)):
        quantity.parse(text, unit)


def test_a_mechanism_file_takes_numbers_with_their_units():
    src = catalogue.path_of("takeup").read_text()
    text = (
        src.replace('name = "takeup"', 'name = "takeup_units"')
        .replace("P4 = [9.66, 2.59]", 'P4 = ["9.66mm", "0.259 cm"]')
        .replace("length = 30.0 ", 'length = "3cm" ', 1)
        .replace("phi0 = 101.0 ", 'phi0 = "101deg" ', 1)
        .replace("speed = 100.0 ", 'speed = "10000/10.5 rpm" ', 1)
    )
    with pytest.raises(mechanism.MechanismFileError, match=r"\[input\] speed: '10000/10.5 rpm' is not a number"):
        mechanism.parse(text, "units.toml")
    a = mechanism.parse(text.replace('"10000/10.5 rpm"', '"954.9296585513721rpm"'), "units.toml")
    b = mechanism.load(catalogue.path_of("takeup"))
    assert a.speed == pytest.approx(b.speed, rel=1e-15) and a.phi0 == pytest.approx(b.phi0, rel=1e-15)
    assert (abs(a.ground["P4"] - b.ground["P4"]) < 1e-15).all()
    assert a.steps[0].length == pytest.approx(b.steps[0].length, rel=1e-15)
    with pytest.raises(mechanism.MechanismFileError, match="'s' is not a unit of length"):
        mechanism.parse(text.replace('"3cm"', '"3 s"'), "units.toml")


def test_a_study_file_takes_ranges_tolerances_and_set_values_with_their_units(tmp_path):
    text = (catalogue.STUDIES_DIR / "takeup_tolerance.toml").read_text()
    plain = spec.parse(text, catalogue.STUDIES_DIR / "takeup_tolerance.toml")
    path = plain.params[0].path
    unit = plain.params[0].unit
    tol = plain.varied[0].tolerance
    assert unit == "mm"
    with_units = re.sub(
        r"(?m)^tolerance = ([0-9.]+)", lambda m: f'tolerance = "{float(m[1]) * 1000:g} um"', text, count=1
    )
    st = spec.parse(with_units, catalogue.STUDIES_DIR / "takeup_tolerance.toml")
    assert st.params[0].path == path and st.varied[0].tolerance == pytest.approx(tol, rel=1e-12)


def test_the_command_line_takes_the_same_forms(tmp_path):
    assert quantity_arg("s")("2s") == 2.0 and quantity_arg("s")("500 ms") == 0.5 and quantity_arg("s")("2") == 2.0
    r = in_process("export", "crank_slider", "--points", str(tmp_path / "a.csv"), "--angle", "0.25rev")
    assert r.returncode == 0 and "input crank angle 90 deg" in r.stderr
    r = in_process("export", "crank_slider", "--points", str(tmp_path / "b.csv"), "--angle", "12 s")
    assert r.returncode == 2 and "'s' is not a unit of angle" in r.stderr and not (tmp_path / "b.csv").exists()
