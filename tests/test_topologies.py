"""Topologies beyond the four shipped files: every one that ``check`` accepts must simulate.

A crank pin shared by a four-bar's coupler and a slider's rod (three bodies at one point), a
second slider on the crank pin, a second dyad on the coupler (a six-bar): built from the
example file, each must pass ``check``, run in MuJoCo within the thresholds and give the
same driving torque and pair reactions as the kinetostatics.
"""

import pytest

from mjlink import compare, reference, validation
from mjlink.model import catalogue
from mjlink.model.mechanism import parse
from mjlink.sim import simulate

EXAMPLE = (catalogue.MECHANISMS_DIR / "examples" / "crank_rocker.toml").read_text()

SLIDER_ON_PIN = """
[[construct]]
point = "F"
block = "slider"
start = "B"
length = 40.0
guide = ["G1", "G2"]
toward = "G2"
"""
SECOND_SLIDER = """
[[construct]]
point = "K"
block = "slider"
start = "B"
length = 45.0
guide = ["H1", "H2"]
toward = "H2"
"""
DYAD_ON_COUPLER = """
[[construct]]
point = "X"
block = "dyad"
a = "C"
b = "E2"
length_a = 30.0
length_b = 50.0
sign = 1
"""


def _file(constructs: str, ground: str, links: str) -> str:
    text = EXAMPLE.replace('name = "crank_rocker"', 'name = "variant"')
    text = text.replace('[[construct]]\npoint = "S1"', constructs.strip() + '\n\n[[construct]]\npoint = "S1"', 1)
    text = text.replace("[input]", links.strip() + "\n\n[input]", 1)
    head, _, rest = text.partition("[[construct]]")
    return head.rstrip() + "\n" + ground.strip() + "\n\n[[construct]]" + rest


VARIANTS = {
    "slider_on_crank_pin": _file(
        SLIDER_ON_PIN,
        "G1 = [-10.0, -60.0]\nG2 = [-10.0, 60.0]",
        '[links.rod]\npoints = ["B", "F"]\nmass = 10.0\ninertia = 2.0e-6\ncom = "F"\n\n'
        '[links.bar]\npoints = ["F"]\nguide = ["G1", "G2"]\nmass = 20.0\ncom = "F"',
    ),
    "two_sliders_on_crank_pin": _file(
        SLIDER_ON_PIN + SECOND_SLIDER,
        "G1 = [-10.0, -60.0]\nG2 = [-10.0, 60.0]\nH1 = [-60.0, 10.0]\nH2 = [60.0, 10.0]",
        '[links.rod]\npoints = ["B", "F"]\nmass = 10.0\ninertia = 2.0e-6\ncom = "F"\n\n'
        '[links.bar]\npoints = ["F"]\nguide = ["G1", "G2"]\nmass = 20.0\ncom = "F"\n\n'
        '[links.rod2]\npoints = ["B", "K"]\nmass = 10.0\ninertia = 2.0e-6\ncom = "K"\n\n'
        '[links.bar2]\npoints = ["K"]\nguide = ["H1", "H2"]\nmass = 20.0\ncom = "K"',
    ),
    "dyad_on_coupler": _file(
        DYAD_ON_COUPLER,
        "E2 = [60.0, 40.0]",
        '[links.rod]\npoints = ["C", "X"]\nmass = 10.0\ninertia = 2.0e-6\ncom = "X"\n\n'
        '[links.rocker2]\npoints = ["E2", "X"]\nmass = 10.0\ninertia = 2.0e-6\ncom = "X"',
    ),
}


@pytest.mark.parametrize("name", list(VARIANTS))
def test_every_accepted_topology_simulates(name, tmp_path):
    path = tmp_path / f"{name}.toml"
    path.write_text(VARIANTS[name])
    report = validation.check_file(path)
    assert report.ok, report.problems
    assert report.mobility.driven == 1
    mech = validation.get(path)
    trace = simulate.run(mech, simulate.kinematic_case(mech))
    assert compare.agreement(mech, trace).failures() == []
    assert compare.loads(mech, trace).failures() == []
    rx = reference.reactions(mech, trace.phi, trace.omega, trace.eps)
    assert set(rx.forces) == set(trace.reactions)


def test_pins_shared_by_three_bodies_make_two_pairs():
    mech = parse(VARIANTS["slider_on_crank_pin"], "v.toml")
    from mjlink.model.topology import pairs

    at_b = [p for _, p in pairs(mech) if p.point == "B"]
    assert len(at_b) == 2 and {p.child for p in at_b} | {p.parent for p in at_b} == {"crank", "coupler", "rod"}
