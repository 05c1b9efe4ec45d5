"""One grammar for a number with its unit: the parser, and the same forms accepted in a
mechanism file, a study file and on the command line."""

from __future__ import annotations

import argparse
import math
import re

import pytest
from conftest import in_process

from mjlink import quantity
from mjlink.cli.values import quantity_arg, speed_arg
from mjlink.errors import MjlinkError
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


# ----------------------------------------------------------- one parser, one case rule, bounds
TAKEUP = catalogue.path_of("takeup").read_text()
TOLERANCE = (catalogue.STUDIES_DIR / "takeup_tolerance.toml").read_text()


def _file_refusal(old: str, new: str) -> str:
    assert old in TAKEUP, old
    with pytest.raises(mechanism.MechanismFileError) as e:
        mechanism.parse(TAKEUP.replace(old, new, 1), "units.toml")
    assert "\n" not in str(e.value)
    return str(e.value)


@pytest.mark.parametrize(
    "text", ["10rev/s", "100rad/s", "955rpm", "955 rpm", "955rev/min", "-90 deg/s", " 1.5e2 rad/s "]
)
def test_a_command_line_speed_is_read_by_the_files_grammar(text):
    assert speed_arg(text).rad_s == pytest.approx(quantity.parse(text, "rad/s"), rel=1e-15)
    assert speed_arg(text).value == quantity.read(text, "rad/s")[0]


@pytest.mark.parametrize("text", ["955", "-100", "1e3", " 12 "])
def test_a_bare_speed_on_the_command_line_is_still_refused(text):
    with pytest.raises(
        argparse.ArgumentTypeError, match=r"write the speed with its unit: .*a bare number is ambiguous"
    ):
        speed_arg(text)


# (text, the unit expected, the spelling meant): mm is not Mm, ms not Ms: units as listed.
CASES = [
    ("12 MM", "mm", "mm"),
    ("12Mm", "mm", "mm"),
    ("500 MS", "s", "ms"),
    ("5 Ms", "s", "ms"),
    ("2 S", "s", "s"),
    ("100 RPM", "rad/s", "rpm"),
    ("10 Rad/S", "rad/s", "rad/s"),
    ("1 KG", "g", "kg"),
    ("3 DEG", "deg", "deg"),
    ("5 n", "N", "N"),
    ("5 KN", "N", "kN"),
]


@pytest.mark.parametrize(("text", "unit", "meant"), CASES)
def test_units_are_case_sensitive_everywhere_and_the_message_names_the_spelling(text, unit, meant):
    rule = f"units are case-sensitive, write '{meant}'"
    with pytest.raises(quantity.QuantityError, match=re.escape(rule)):
        quantity.parse(text, unit)
    with pytest.raises(argparse.ArgumentTypeError, match=re.escape(rule)):
        quantity_arg(unit)(text)
    if unit == "rad/s":
        with pytest.raises(argparse.ArgumentTypeError, match=re.escape(rule)):
            speed_arg(text)
    # As listed, each is read.
    number = re.match(r"[\d.]+", text.strip())[0]
    assert quantity.parse(f"{number} {meant}", unit) == pytest.approx(
        float(number) * quantity.KINDS[quantity.kind_of(unit)][meant] / quantity.KINDS[quantity.kind_of(unit)][unit]
    )


def test_the_case_rule_holds_in_files_studies_and_options():
    assert "[input] speed: '100 RPM': 'RPM' is not a unit of angular speed: units are case-sensitive, write 'rpm'" in (
        _file_refusal("speed = 100.0 ", 'speed = "100 RPM" ')
    )
    assert "units are case-sensitive, write 'cm'" in _file_refusal("length = 30.0 ", 'length = "3 CM" ')
    assert "write 'mm'" in _file_refusal("P4 = [9.66, 2.59]", 'P4 = ["9.66 MM", 2.59]')
    text = TOLERANCE.replace("tolerance = 0.02", 'tolerance = "20 UM"', 1)
    with pytest.raises(
        MjlinkError, match=re.escape("'UM' is not a unit of length: units are case-sensitive, write 'um'")
    ):
        spec.parse(text, catalogue.STUDIES_DIR / "takeup_tolerance.toml")
    r = in_process("simulate", "takeup", "--duration", "500 MS", "--no-video")
    assert r.returncode == 2 and "write 'ms'" in r.stderr and r.stderr.count("\n") == 1
    r = in_process("simulate", "takeup", "--speed", "955 RPM", "--no-video")
    assert r.returncode == 2 and "write 'rpm'" in r.stderr and r.stderr.count("\n") == 1


@pytest.mark.parametrize("text", ["１２mm", "١٢ mm", "۱۲mm", "१२mm", "1２ mm", "-１２mm", "１２", "٠.٥ mm", "12.５mm"])
def test_digits_other_than_0_to_9_are_refused_with_one_line(text):
    message = "write the number with the digits 0-9"
    with pytest.raises(quantity.QuantityError, match=message):
        quantity.parse(text, "mm")
    with pytest.raises(argparse.ArgumentTypeError, match=message):
        quantity_arg("mm")(text)
    assert message in _file_refusal("length = 30.0 ", f'length = "{text}" ')
    with pytest.raises(argparse.ArgumentTypeError, match=message):
        speed_arg(text.replace("mm", "rpm"))


def test_the_micro_sign_may_be_typed_as_the_greek_mu():
    assert quantity.parse("100 μm", "mm") == quantity.parse("100 µm", "mm") == quantity.parse("100um", "mm")
    assert "μ" != "µ"  # U+03BC and U+00B5: two characters that look alike


@pytest.mark.parametrize(
    ("old", "new"),
    [
        ("length = 30.0 ", 'length = "100 um" '),  # 0.09999999999999999 mm once converted: the 0.1 mm bound
        ("length = 30.0 ", 'length = "0.01 cm" '),
        ("length = 30.0 ", 'length = "1 m" '),  # the 1000 mm bound
        ("P4 = [9.66, 2.59]", 'P4 = ["100 cm", "-1e6 um"]'),
        ("speed = 100.0 ", 'speed = "9.5492965855 rpm" '),  # 1 rad/s to ten digits
        ("speed = 100.0 ", 'speed = "1e4 rad/s" '),
    ],
)
def test_a_value_at_its_bound_in_another_unit_is_accepted(old, new):
    mechanism.parse(TAKEUP.replace(old, new, 1), "units.toml")


@pytest.mark.parametrize(
    ("old", "new", "message"),
    [
        ("length = 30.0 ", 'length = "99.99 um" ', "must be at least 0.1 mm in magnitude"),
        ("length = 30.0 ", 'length = "0.0099 cm" ', "must be at least 0.1 mm in magnitude"),
        ("length = 30.0 ", 'length = "1.000001 m" ', "must be at most 1000 mm in magnitude"),
        ("P4 = [9.66, 2.59]", 'P4 = ["100.001 cm", 0]', "coordinates must be at most 1000 mm in magnitude"),
        ("speed = 100.0 ", 'speed = "9.5 rpm" ', "must be between 1 and 10000 rad/s in magnitude"),
    ],
)
def test_a_value_truly_beyond_its_bound_is_refused(old, new, message):
    assert message in _file_refusal(old, new)


def test_command_line_values_at_their_bound_are_accepted_and_beyond_refused():
    from mjlink.pipeline.options import check_speed

    check_speed("--speed", speed_arg("9.5492965855rpm").rad_s)  # 1 rad/s to ten digits
    check_speed("--speed", speed_arg("-95492.96585513721rpm").rad_s)
    with pytest.raises(MjlinkError, match="--speed must be between 1 and 10000 rad/s"):
        check_speed("--speed", speed_arg("9.5rpm").rad_s)
    r = in_process("synth", "crank_slider", "--stroke", "100um")  # 0.09999999999999999 mm: the 0.1 mm bound
    assert r.returncode == 0, r.stderr
    r = in_process("synth", "crank_slider", "--stroke", "99um")
    assert r.returncode == 1 and "--stroke must be between 0.1 and 1000 mm, got 0.099 mm" in r.stderr


def test_a_plain_number_option_takes_no_unit():
    assert quantity_arg("")("2") == 2.0 and quantity_arg("")(" 0.5 ") == 0.5
    with pytest.raises(argparse.ArgumentTypeError, match="a plain number goes here, without a unit"):
        quantity_arg("")("2 mm")
    with pytest.raises(argparse.ArgumentTypeError, match="digits 0-9"):
        quantity_arg("")("２")


@pytest.mark.parametrize("text", ["1" + "x" * 100_000, "1" * 100_000 + " mm", "x" * 100_000, "12 " + "m" * 100_000])
def test_a_long_text_is_echoed_clipped_in_its_one_line(text):
    with pytest.raises(quantity.QuantityError) as e:
        quantity.parse(text, "mm", require_unit=True)
    assert len(str(e.value)) < 300 and "\n" not in str(e.value)
    assert len(_file_refusal("length = 30.0 ", f'length = "{text}" ')) < 400
