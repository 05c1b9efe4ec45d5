"""Degrees of freedom by the rank of the constraints, and full rotation of geared mechanisms
over their true common period."""

import re

import pytest

from mjlink import validation
from mjlink.errors import MechanismFileError
from mjlink.model import catalogue
from mjlink.model.mechanism import parse

EXAMPLE = (catalogue.MECHANISMS_DIR / "examples" / "crank_rocker.toml").read_text()
FLAP = """
[[construct]]
point = "F"
block = "attached"
origin = "D"
toward = "C"
angle = 90.0
length = 20.0

[[construct]]
point = "S1\""""


def _with_links(text: str, links: str) -> str:
    return text.replace("[input]", links.strip() + "\n\n[input]", 1)


def test_a_free_flap_and_a_redundant_rocker_do_not_balance(tmp_path):
    """W = 3*5 - 2*7 = 1 counts a free-spinning flap against a doubled rocker; the rank does not."""
    text = _with_links(
        EXAMPLE.replace('[[construct]]\npoint = "S1"', FLAP.strip(), 1),
        '[links.flap]\npoints = ["D", "F"]\nmass = 5.0\ninertia = 1e-7\ncom = "F"\n\n'
        '[links.rocker2]\npoints = ["D", "C"]\nmass = 5.0\ninertia = 1e-7\ncom = "C"',
    )
    mech = parse(text, tmp_path / "flap.toml")
    m = validation.mobility(mech)
    assert m.driven == 1 and m.actual == 2
    assert m.free == ("flap",) and m.redundant and "rocker2" in m.redundant[0]
    with pytest.raises(MechanismFileError, match=r"flap still moves with the input crank held; pair .*rocker2"):
        validation.validate(mech)


@pytest.mark.parametrize("name", catalogue.names())
def test_shipped_mechanisms_are_sound(name):
    m = validation.mobility(validation.get(name))
    assert (m.actual, m.free, m.redundant) == (1, (), ())


def test_a_gear_ratio_without_a_common_period_is_refused():
    text = catalogue.path_of("warp_knitting").read_text()
    assert "ratio = -0.5" in text
    with pytest.raises(MechanismFileError, match=r"ratio: 0.501 is no ratio p/q with q <= 64"):
        parse(text.replace("ratio = -0.5", "ratio = 0.501", 1), "g.toml")


def test_full_rotation_is_judged_over_the_common_period():
    """A ratio of 3/4 repeats after 4 input turns; the assembly check covers all four."""
    text = catalogue.path_of("warp_knitting").read_text().replace("ratio = -0.5", "ratio = -0.75", 1)
    mech = parse(text, "g.toml")
    assert mech.period == pytest.approx(4 * 2 * 3.141592653589793)
    report = validation.check(mech)
    assert report.period_deg == pytest.approx(1440.0)
    assert report.full_turn or re.search(r"\d+\.\d\.\.\d+", report.assembly_ranges)


@pytest.mark.parametrize(
    ("field", "value", "words"),
    # a tonne for 10 g: the inertia is then implausibly small for the mass
    [("inertia", 1000.0, "inertia 1000 kg*m^2 is"), ("mass", 1e3, "is only")],
)
def test_implausible_masses_and_inertias_are_warned_of(field, value, words):
    import dataclasses

    mech = validation.get("takeup")
    crank = dataclasses.replace(mech.links[0], **{field: value})
    odd = dataclasses.replace(mech, links=(crank, *mech.links[1:]))
    warnings = validation.plausibility(odd)
    assert len(warnings) == 1 and words in warnings[0] and "crank" in warnings[0]
    assert validation.check(odd).ok  # a warning, not an error
    assert any(words in n for n in validation.check(odd).notes)


@pytest.mark.parametrize("name", catalogue.names())
def test_shipped_mechanisms_are_plausible(name):
    assert validation.plausibility(validation.get(name)) == []
