"""Degrees of freedom by the rank of the constraints, and full rotation of geared mechanisms
over their true common period."""

import re
from pathlib import Path

import numpy as np
import pytest

from mjlink import reference, validation
from mjlink.errors import MechanismFileError
from mjlink.model import catalogue
from mjlink.model.mechanism import load, parse

ROOT = Path(__file__).resolve().parent.parent

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


# ----------------------------------------------------- valid, but probably not what was meant
HEAD = catalogue.path_of("lockstitch_head").read_text()
ADVANCE = "angle = 150.0              # the dog advances while it is up"


def _head(**edit: str):
    text = HEAD
    for old, new in edit.values():
        assert old in text
        text = text.replace(old, new, 1)
    return parse(text, "head.toml")


def _dog_box_share(mech) -> tuple[float, float, float]:
    """The feed dog's travel along and up (mm) and the share of that box its path encloses,
    from the reference's positions over the turn (the shoelace formula)."""
    kin = reference.solve(mech, validation.cycle_angles(mech), check=False)
    x, y = kin.position(mech.timing.roles["feed_dog"])[:, :2].T * 1e3
    area = 0.5 * abs(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))
    return float(np.ptp(x)), float(np.ptp(y)), float(area / (np.ptp(x) * np.ptp(y)))


@pytest.mark.parametrize("path", [*catalogue.names(), *sorted((ROOT / "mechanisms" / "examples").glob("*.toml"))])
def test_shipped_files_raise_no_probably_unintended_warning(path):
    report = validation.check(validation.get(path) if isinstance(path, str) else load(path))
    assert not [n for n in report.notes if n.startswith("warning:")]


def test_two_eccentrics_at_one_angle_on_a_shaft_are_warned_of():
    same = validation.check(_head(advance=(ADVANCE, ADVANCE.replace("150.0", "0.2  "))))
    hits = [n for n in same.notes if "same angle" in n]
    assert len(hits) == 1 and "B and D" in hits[0] and "pivot L" in hits[0] and "(0.20 deg apart)" in hits[0]
    assert same.ok  # a warning, not an error
    # The shipped head's feed still traces a loop with its eccentrics in phase: the rock shaft
    # and the feed bar turn the phase, so no dog-path warning follows from this one.
    assert _dog_box_share(_head(advance=(ADVANCE, ADVANCE.replace("150.0", "0.2  "))))[2] > 0.5
    assert not [n for n in same.notes if "feed dog" in n]


def test_a_feed_dog_on_a_line_or_without_lift_is_warned_of():
    # Advance 60 deg from lift: the rock shaft's turn brings the dog's lift and advance into
    # step, and its path closes on a line.
    line = _head(advance=(ADVANCE, ADVANCE.replace("150.0", "60.0 ")))
    along, up, share = _dog_box_share(line)
    assert share < 0.05 < _dog_box_share(_head())[2]
    hits = [n for n in validation.check(line).notes if "feed dog F's path is a line" in n]
    assert len(hits) == 1 and f"{100 * share:.2g} %" in hits[0]
    # The feed bar's end at the rocker, named as the dog: it swings on an arc over the rock
    # shaft, along the plate, hardly up and down.
    flat = _head(dog=('feed_dog = "F"', 'feed_dog = "A"'))
    along, up, _ = _dog_box_share(flat)
    assert up < 0.02 * along
    hits = [n for n in validation.check(flat).notes if "feed dog A has no lift" in n]
    assert len(hits) == 1 and f"{up:.3g} mm up and down" in hits[0]


@pytest.mark.parametrize("name", ["lockstitch_head", "warp_knitting"])
def test_check_prints_every_moving_point_where_it_is_at_the_setting(name):
    from mjlink.cli.text import format_report

    mech = validation.get(name)
    text = format_report(validation.check(mech))
    ref = mjlink_traces(mech)
    for p in mech.point_names:
        if p in mech.ground:
            continue
        line = next(l for l in text.splitlines() if l.split()[:2] == [p, "moving"])
        got = [float(v) for v in re.findall(r"  at \(([^)]*)\) mm", line)[-1].split(",")]
        want = [ref[f"{p}_{ax}_mm"][0] for ax in "xyz"]
        assert np.allclose(got, want, atol=0.0005 + 1e-9), (p, got, want)  # printed to 0.001 mm


def mjlink_traces(mech):
    import mjlink

    return mjlink.traces(mech, cycles=1, source="reference")
