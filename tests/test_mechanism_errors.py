"""Bad mechanism files are rejected with one clear line naming the file, key and cause."""

import math
import os
import re
from pathlib import Path

import numpy as np
import pytest

from mjlink import validation
from mjlink.errors import AssemblyError, MechanismFileError, MjlinkError, UnknownMechanismError
from mjlink.model import catalogue as registry
from mjlink.model.mechanism import parse

GOOD = (registry.MECHANISMS_DIR / "takeup.toml").read_text()


def bad(old, new, count=1):
    assert old in GOOD, old
    return GOOD.replace(old, new, count)


@pytest.mark.parametrize(
    "text, match",
    [
        ("[mechanism\nname=1", "TOML syntax error"),
        (bad("length = 30.0", "lenght = 30.0"), "unknown key 'lenght' \\(did you mean 'length'\\?\\)"),
        (bad("length = 30.0", ""), "missing key 'length'"),
        (bad("length = 30.0", 'length = "30"'), "must be a number"),
        (bad("length = 30.0", "length = -30.0"), "must be > 0"),
        (bad("length = 30.0", "length = nan"), "must be finite"),
        (bad("length = 30.0", "length = inf"), "must be finite"),
        (bad('a = "P2"', 'a = "P9"'), "uses point 'P9', which is not defined"),
        (bad('toward = "P2"', 'toward = "S2"'), "is defined later"),
        (bad("sign = -1", "sign = 0"), "must be \\+1 or -1"),
        (bad('block = "dyad"', 'block = "dyadd"'), "unknown block 'dyadd' \\(did you mean 'dyad'\\?"),
        (bad("mass = 10.0", "mass = -10.0"), "must be >= 0"),
        (bad('com = "S1"\n', ""), "has a mass but no 'com'"),
        (bad('name = "takeup"', 'name = "../../etc"'), "invalid name"),
        (bad('points = ["P4", "P3"]', 'points = ["P4", "P3", "P5"]'), "do not stay at a fixed distance"),
    ],
    ids=lambda v: v if len(v) < 40 else None,
)
def test_rejected(tmp_path, text, match):
    f = tmp_path / "bad.toml"
    f.write_text(text)
    with pytest.raises(MechanismFileError, match=match) as e:
        validation.get(f)
    msg = str(e.value)
    assert "\n" not in msg and str(f) in msg


def test_dyad_that_cannot_close_reports_the_angle_range(tmp_path):
    f = tmp_path / "rocker.toml"
    f.write_text(bad("length_b = 19.0", "length_b = 9.0"))
    with pytest.raises(AssemblyError, match=r"cannot turn fully.*assembles only for input angles [-0-9.]+\.\.[-0-9.]+"):
        validation.get(f)


def test_unknown_name_lists_valid_choices():
    with pytest.raises(UnknownMechanismError, match=r"valid: .*takeup"):
        validation.get("takup")


def test_one_base_exception():
    """Every exception mjlink declares derives from MjlinkError, so the CLI's one-line handler catches it."""
    import inspect

    from mjlink import errors

    declared = [
        c
        for _, c in inspect.getmembers(errors, inspect.isclass)
        if issubclass(c, BaseException) and c.__module__ == errors.__name__
    ]
    assert len(declared) >= 7
    for cls in declared:
        assert issubclass(cls, MjlinkError), cls


def test_parse_accepts_the_shipped_file():
    m = parse(GOOD, "takeup.toml")
    assert m.name == "takeup" and len(m.links) == 3


# ----------------------------------------------------------------------------- issue 5
# One test (or one parameter) per class of error a user's own file can make. Every message
# is one line naming the file, the key (where there is one) and the cause.

EXAMPLE = (registry.MECHANISMS_DIR / "examples" / "crank_rocker.toml").read_text()


def ex(old, new, count=1):
    assert EXAMPLE.count(old) >= count, old
    return EXAMPLE.replace(old, new, count)


def rejected(tmp_path, text, cls=MechanismFileError, name="mine.toml"):
    f = tmp_path / name
    f.write_text(text)
    with pytest.raises(cls) as e:
        validation.get(f)
    msg = str(e.value)
    assert "\n" not in msg and str(f) in msg, msg
    return msg


@pytest.mark.parametrize(
    "text, match",
    [
        # TOML syntax, with the line
        ('[mechanism]\nname = "x"\ntitle = = 1\n', r"TOML syntax error: .*\(at line 3, column"),
        # unknown keys, with the nearest valid one, in every table
        (ex("[links.crank]", "[linkz.crank]"), r"unknown key 'linkz' \(did you mean 'links'\?\)"),
        (ex('title = "Plain', 'titel = "Plain'), r"\[mechanism\]: unknown key 'titel' \(did you mean 'title'\?\)"),
        (
            ex("length_a = 45.0", "lenght_a = 45.0"),
            r"\[\[construct\]\] C \(dyad\): unknown key 'lenght_a' "
            r"\(did you mean 'length_a'\?\)",
        ),
        (
            ex("inertia = 1.0e-6", "inertial = 1.0e-6"),
            r"\[links.crank\]: unknown key 'inertial' \(did you mean 'inertia'\?\)",
        ),
        (ex("phi0 = 0.0", "phi_0 = 0.0"), r"\[input\]: unknown key 'phi_0' \(did you mean 'phi0'\?\)"),
        (
            ex("damping = 1.0e-4", "dampign = 1.0e-4"),
            r"\[dynamics\]: unknown key 'dampign' \(did you mean 'damping'\?\)",
        ),
        # missing keys
        (ex("sign = 1", ""), r"\[\[construct\]\] C \(dyad\): missing key 'sign'"),
        (ex("speed = 100.0", ""), r"\[input\]: missing key 'speed'"),
        (ex('point = "E"', ""), r"\[\[construct\]\] #3: missing key 'point'"),
        # wrong types
        (ex("length = 15.0", "length = [15.0]"), r"length: must be a number, got list"),
        (ex("sign = 1 ", "sign = true "), r"sign: must be \+1 or -1"),
        (ex("D = [50.0, 0.0]", 'D = "50, 0"'), r"\[ground\] D: must be a list of 2 or 3 numbers"),
        (ex('points = ["A", "B"]', 'points = "A B"'), r"\[links.crank\] points: must be a list"),
        (ex('[[construct]]\npoint = "B"', '[construct]\npoint = "B"'), r"must be an array of tables|TOML syntax"),
        # zero, negative, non-finite, absurd sizes
        (ex("length = 15.0", "length = 0.0"), r"length: must be > 0, got 0"),
        (ex("length_b = 35.0", "length_b = -35.0"), r"length_b: must be > 0, got -35"),
        (ex("length = 15.0", "length = nan"), r"must be finite"),
        (ex("length = 15.0", "length = -inf"), r"must be finite"),
        (ex("length = 15.0", "length = 1" + "0" * 400), r"must be finite, got an integer of 401 digits"),
        (ex("length = 15.0", "length = 1e6"), r"must be at most 1000 mm in magnitude"),
        (ex("length = 15.0", "length = 1e-5"), r"must be at least 0.1 mm in magnitude"),
        (ex("D = [50.0, 0.0]", "D = [5e4, 0.0]"), r"\[ground\] D: coordinates must be at most 1000 mm"),
        (ex("speed = 100.0", "speed = 1e-3"), r"\[input\] speed: must be between 1 and 10000 rad/s"),
        (ex("speed = 100.0", "speed = 0"), r"\[input\] speed: must be non-zero"),
        (ex("cycles = 1.0", "cycles = 1e9"), r"\[input\] cycles: must be at most 100"),
        (ex("phi0 = 0.0", "phi0 = 1e300"), r"\[input\] phi0: must be at most 720 deg in magnitude \(an angle\)"),
        (ex("angle = 30.0", "angle = -1e20"), r"E \(attached\) angle: must be at most 720 deg"),
        # references to undefined points and links
        (ex('b = "D"', 'b = "Q"'), r"\[\[construct\]\] C: uses point 'Q', which is not defined"),
        (ex('points = ["D", "C"]', 'points = ["D", "X"]'), r"\[links.rocker\]: uses point 'X', which is not defined"),
        (ex('com = "S3"', 'com = "S9"'), r"\[links.rocker\]: uses point 'S9', which is not defined"),
        (EXAMPLE + '\n[thread]\npath = ["A", "Z"]\n', r"\[thread\] path: uses point 'Z', which is not defined"),
        (ex('points = ["B", "C", "E"]', 'points = ["B", "C"]'), r"point 'E' belongs to no link"),
        # a block that uses a point defined later, and two blocks that depend on each other
        (ex('toward = "C"', 'toward = "S3"'), r"\[\[construct\]\] E: uses point 'S3', which is defined later: order"),
        (
            ex('origin = "A"\ntoward = "B"', 'origin = "A"\ntoward = "S2"').replace(
                'origin = "B"\ntoward = "C"\nangle = 0.0\nlength = 22.5',
                'origin = "B"\ntoward = "S1"\nangle = 0.0\nlength = 22.5',
            ),
            r"\[\[construct\]\] S1: uses point 'S2', which is built from 'S1' itself: the blocks S1 -> S2 -> S1 form a cycle",
        ),
        (
            ex(
                'a = "B"\nb = "D"',
                'a = "B"\nb = "D"',
            )
            .replace('origin = "B"\ntoward = "C"\nangle = 30.0', 'origin = "B"\ntoward = "C"\nangle = 30.0')
            .replace(
                'block = "dyad"                         # 45 mm from B and 35 mm from D\na = "B"',
                'block = "dyad"                         # 45 mm from B and 35 mm from D\na = "E"',
            ),
            r"\[\[construct\]\] C: uses point 'E', which is built from 'C' itself: the blocks C -> E -> C form a cycle",
        ),
        # blocks whose own points make a direction undefined
        (ex('a = "B"\nb = "D"', 'a = "D"\nb = "D"'), r"C \(dyad\) b: must differ from a"),
        (
            ex('origin = "B"\ntoward = "C"\nangle = 30.0', 'origin = "B"\ntoward = "B"\nangle = 30.0'),
            r"E \(attached\) toward: must differ from origin",
        ),
        # mass and inertia
        (ex("mass = 10.0", "mass = -10.0"), r"\[links.crank\] mass: must be >= 0"),
        (ex("inertia = 1.0e-6", "inertia = -1.0e-6"), r"\[links.crank\] inertia: must be >= 0"),
        (ex("mass = 10.0", "mass = 0.0"), r"\[links.crank\]: has a moment of inertia but zero mass"),
        (ex('com = "S1"', ""), r"\[links.crank\]: has a mass but no 'com'"),
        (
            ex("mass = 10.0", "mass = 1e300"),
            r"\[links.crank\] mass: must be at most 1e\+06 g in magnitude \(a machine part\)",
        ),
        (ex("inertia = 1.0e-6", "inertia = 5e3"), r"\[links.crank\] inertia: must be at most 1000 kg\*m\^2"),
        # names that would escape the output folder or break the MJCF
        (ex('name = "crank_rocker"', 'name = "../x"'), r"\[mechanism\] name: invalid name '../x'"),
        (ex('name = "crank_rocker"', 'name = "a/b"'), r"invalid name 'a/b'"),
        (ex('name = "crank_rocker"', 'name = "/etc/passwd"'), r"invalid name '/etc/passwd'"),
        (ex('name = "crank_rocker"', 'name = "' + "x" * 33 + '"'), r"invalid name 'x{33}'"),
        (ex('name = "crank_rocker"', 'name = "Kurbelschwinge_ä"'), r"invalid name"),
        (ex('name = "crank_rocker"', 'name = "crank\\n"'), r"invalid name 'crank\\n'"),
        (ex('name = "crank_rocker"', 'name = ""'), r"invalid name ''"),
        (ex("[links.crank]", "[links.world]"), r"\[links.world\]: 'world' is reserved"),
        (ex("[links.crank]", "[links.ground]"), r"\[links.ground\]: 'ground' is reserved"),
    ],
    ids=lambda v: "file" if "\n" in v or len(v) > 70 else v,
)
def test_rejected_with_key_and_cause(tmp_path, text, match):
    msg = rejected(tmp_path, text)
    assert __import__("re").search(match, msg), msg


def with_attached(text: str, point: str, origin: str, toward: str, length: float) -> str:
    """The example's text with one more 'attached' block (angle 0) just before S1's."""
    block = (
        f'[[construct]]\npoint = "{point}"\nblock = "attached"\norigin = "{origin}"\n'
        f'toward = "{toward}"\nangle = 0.0\nlength = {length}\n\n'
    )
    return text.replace('[[construct]]\npoint = "S1"', block + '[[construct]]\npoint = "S1"', 1)


def test_name_clash_between_joint_names(tmp_path):
    # link 'a_b' at point 'c' and link 'a' at point 'b_c' would both make the joint 'a_b_c'
    text = (
        ex("[links.crank]", "[links.a]")
        .replace("[links.rocker]", "[links.a_D]")
        .replace("D = [50.0, 0.0]", "D = [50.0, 0.0]\nA_D = [0.0, 0.0]")
    )
    text = text.replace('points = ["A", "B"]', 'points = ["A", "B", "D_C"]')
    # simpler: the joint names a_D_C (link a_D at C) and a_D_C (link a at D_C) clash
    text = with_attached(text, "D_C", "A", "B", 15.0)
    text = text.replace('[links.coupler]\npoints = ["B", "C", "E"]', '[links.coupler]\npoints = ["B", "C", "E", "D_C"]')
    msg = rejected(tmp_path, text)
    assert "would be the same as" in msg


def test_cannot_close_names_block_and_ranges(tmp_path):
    # rocker 15 mm: |BD| reaches 65 > 45 + 15, so the dyad cannot close around phi = 180
    msg = rejected(tmp_path, ex("length_b = 35.0", "length_b = 15.0"), AssemblyError)
    assert "cannot turn fully" in msg and "it is a rocker there" in msg
    import re

    lo, hi = (
        float(x)
        for x in re.search(r"dyad B-C-D cannot close for input angles ([0-9.]+)\.\.([0-9.]+) deg", msg).groups()
    )
    assert 90 < lo < 180 < hi < 270
    assert re.search(r"assembles only for input angles 0\.0\.\.[0-9.]+, [0-9.]+\.\.360\.0 deg", msg)


def test_rocker_still_loads_without_full_turn(tmp_path):
    f = tmp_path / "rocker.toml"
    f.write_text(ex("length_b = 35.0", "length_b = 15.0"))
    m = validation.get(f, full_turn=False)
    assert m.name == "crank_rocker"


def test_dead_point_of_a_dyad_is_rejected(tmp_path):
    # a = 15, d = 50, b = c = 32.55: at phi = 180 |BD| = 65 and the transmission angle is 173.9 deg
    text = ex("length_a = 45.0", "length_a = 32.55").replace("length_b = 35.0", "length_b = 32.55")
    msg = rejected(tmp_path, text, AssemblyError)
    assert "dyad B-C-D passes within" in msg and "of a dead point" in msg
    assert "transmission angle at C between links coupler and rocker reaches 17" in msg
    assert "at input angle 180.0 deg" in msg and "20..160 deg" in msg


def test_dead_point_of_a_slider_is_rejected(tmp_path):
    text = (registry.MECHANISMS_DIR / "crank_slider.toml").read_text()
    # r + e = 36.7 mm and l = 37.5 mm: the pressure angle reaches asin(36.73/37.5) = 78.4 deg
    old = "length = 62.08849880581459"
    assert old in text
    msg = rejected(tmp_path, text.replace(old, "length = 37.5"), AssemblyError)
    assert "slider B-C on G1-G2 passes within" in msg and "pressure angle reaches 78." in msg
    assert "input angle 90.0 deg" in msg and "up to 60 deg" in msg


def test_missing_link_leaves_two_degrees_of_freedom(tmp_path):
    # C on the rocker only: the coupler B-C is gone, the rocker swings freely
    text = ex('[links.coupler]\npoints = ["B", "C", "E"]', '[links.coupler]\npoints = ["B", "E"]')
    text = text.replace('origin = "B"\ntoward = "C"\nangle = 30.0', 'origin = "B"\ntoward = "A"\nangle = 30.0')
    text = text.replace(
        'origin = "B"\ntoward = "C"\nangle = 0.0\nlength = 22.5',
        'origin = "B"\ntoward = "A"\nangle = 0.0\nlength = 22.5',
    )
    msg = rejected(tmp_path, text)
    assert "the links give the linkage 3 degrees of freedom (W = 3*3 - 2*3 = 3) where it must have one" in msg
    assert "dyad B-C-D needs its joint C on one link with B and on another with D" in msg


def test_redundant_link_is_over_constrained(tmp_path):
    # a second coupler on the same pins repeats the coupler's constraint
    text = EXAMPLE + '\n[links.coupler2]\npoints = ["B", "C"]\nmass = 1.0\ncom = "C"\n'
    msg = rejected(tmp_path, text)
    assert "over-constrain the linkage (W = 3*4 - 2*6 = 0 degrees of freedom" in msg


def test_coinciding_points_make_an_undefined_direction(tmp_path):
    text = with_attached(ex("D = [50.0, 0.0]", "D = [50.0, 0.0]\nF = [0.0, 0.0]"), "G", "A", "F", 5.0)
    text = text.replace('points = ["D", "C"]', 'points = ["D", "C", "G"]')
    msg = rejected(tmp_path, text)
    assert "G: its origin and toward A and F come within 0 mm" in msg


def test_point_mass_is_accepted(tmp_path):
    # mass without inertia is an idealised point mass at 'com' (documented)
    f = tmp_path / "pm.toml"
    f.write_text(ex("inertia = 1.0e-6                       # kg*m^2 about the centre of mass\n", ""))
    m = validation.get(f)
    assert m.links[0].mass > 0 and m.links[0].inertia == 0


def test_messages_name_the_file_as_given(tmp_path, monkeypatch):
    d = tmp_path / "with space"
    d.mkdir()
    (d / "bad.toml").write_text(ex("length = 15.0", "length = -1"))
    monkeypatch.chdir(tmp_path)
    with pytest.raises(MechanismFileError) as e:
        validation.get("with space/bad.toml")
    assert str(e.value).startswith("with space/bad.toml: [[construct]] B (crank) length: must be > 0")


# ------------------------------------------------------------------------ names and paths
def test_paths_relative_absolute_spaces_and_home(tmp_path, monkeypatch):
    d = tmp_path / "my linkages"
    d.mkdir()
    f = d / "crank rocker.toml"
    f.write_text(EXAMPLE)
    monkeypatch.chdir(d)
    assert registry.path_of("crank rocker.toml") == registry.Path("crank rocker.toml")
    assert registry.path_of("./crank rocker.toml").is_file()
    assert registry.path_of(str(f)) == f
    assert validation.get(f).name == "crank_rocker"
    monkeypatch.setenv("HOME", str(tmp_path))
    assert registry.path_of("~/my linkages/crank rocker.toml") == f
    assert validation.get("~/my linkages/crank rocker.toml").name == "crank_rocker"
    with pytest.raises(UnknownMechanismError, match=r"^~/nope.toml \(.*nope.toml\): no such mechanism file$"):
        registry.path_of("~/nope.toml")
    with pytest.raises(UnknownMechanismError, match="is a folder, not a mechanism file"):
        registry.path_of(str(d))


def test_names_and_paths_are_unambiguous(tmp_path, monkeypatch):
    # A file in the current folder called like a registered mechanism: the bare name is the
    # registered one; './takeup' or 'takeup.toml' is the file.
    monkeypatch.chdir(tmp_path)
    (tmp_path / "takeup").write_text(EXAMPLE)
    (tmp_path / "takeup.toml").write_text(EXAMPLE)
    assert registry.path_of("takeup") == registry.MECHANISMS_DIR / "takeup.toml"
    assert registry.path_of("./takeup") == registry.Path("takeup")
    assert registry.path_of("takeup.toml") == registry.Path("takeup.toml")
    assert validation.get("takeup.toml").name == "crank_rocker"
    assert validation.get("takeup").name == "takeup"
    # a bare word that is no registered name but an existing file is that file
    (tmp_path / "mine").write_text(EXAMPLE)
    assert validation.get("mine").name == "crank_rocker"
    # a path is never looked up as a name
    with pytest.raises(UnknownMechanismError, match="no such mechanism file"):
        registry.path_of("warp_knitting.toml")
    with pytest.raises(UnknownMechanismError, match="unknown mechanism"):
        registry.path_of("warp_knittin")
    with pytest.raises(UnknownMechanismError, match="empty mechanism name"):
        registry.path_of("")


def test_example_file_is_valid():
    m = validation.get(registry.MECHANISMS_DIR / "examples" / "crank_rocker.toml")
    assert m.name == "crank_rocker" and "crank_rocker" not in registry.names()


def test_points_of_a_link_closer_than_mujoco_resolves(tmp_path):
    # a centre of mass 1e-4 mm from the crank's pivot: MuJoCo would put it on the pivot
    msg = rejected(tmp_path, ex("angle = 0.0\nlength = 7.5", "angle = 0.0\nlength = 1e-4"))
    assert "[links.crank]: points A and S1 are only 0.0001 mm apart" in msg
    # exactly on the pivot is fine
    f = tmp_path / "on_pivot.toml"
    f.write_text(ex("angle = 0.0\nlength = 7.5", "angle = 0.0\nlength = 0.0"))
    assert validation.get(f).name == "crank_rocker"


def test_crank_setting_overrides_are_bounded():
    m = validation.get("takeup")
    with pytest.raises(MjlinkError, match="--phi0 must be finite and at most 720 deg"):
        validation.with_crank_settings(m, phi0_deg=1e300)
    assert abs(validation.with_crank_settings(m, phi0_deg=-90.0).phi0 + __import__("math").pi / 2) < 1e-15


def test_a_point_named_like_a_site_of_the_model_is_refused(tmp_path):
    """Points are MuJoCo sites: one named like the load site the builder adds on a link's joint
    (``load_LINK``) or a loop anchor would make the model fail to compile; refused by name."""
    text = with_attached(EXAMPLE, "load_coupler", "B", "C", 15.0)
    text = text.replace(
        '[links.coupler]\npoints = ["B", "C", "E"]', '[links.coupler]\npoints = ["B", "C", "E", "load_coupler"]'
    )
    msg = rejected(tmp_path, text)
    assert "point 'load_coupler' has the name of a site the model adds" in msg and "rename the point" in msg


# ----------------------------------------------------------------------------- forces and loads
# Every force, moment and load a file gives is bounded (mechanisms/README.md, Limits: forces at
# most 1e6 N a component, moments 1e6 N*m, damping 1e6 N*m*s, gravity 100 m/s^2, target_delta
# within (0, 2)); a force table's angles lie within one period, [0, 360 deg x the period's turns).


def with_force(body: str, base: str = GOOD, point: str = "P5") -> str:
    return f'{base}\n[[dynamics.force]]\npoint = "{point}"\n{body}\n'


@pytest.mark.parametrize(
    "body",
    [
        "value = [1e6, -1e6]",
        'value = ["1e3 kN", "-1000000N", 0.0]',
        "value = [0.0, -1.0, 0.0]",
        "angles = [0.0, 90.0, 180.0, 359.999]\nvalues = [[0, 1], [0, 2], [0, 3], [1e6, 0]]",
        'angles = ["0 deg", "0.25 rev", "3 rad"]\nvalues = [[0, 1], ["1 kN", 0], [0, 3]]',
    ],
)
def test_a_force_within_its_limits_is_read(body):
    parse(with_force(body), "f.toml")


@pytest.mark.parametrize(
    ("body", "message"),
    [
        ('value = ["1e300 kN", 0.0]', "value: force components must be at most 1e+06 N in magnitude"),
        ("value = [1.000001e6, 0.0]", "value: force components must be at most 1e+06 N in magnitude"),
        ("value = [0.0, -1e300]", "force components must be at most 1e+06 N"),
        ('value = ["1e306 kN", 0.0]', "value: '1e306 kN' is not finite in N"),
        ("value = [nan, 0.0]", "value: must hold finite numbers"),
        ('value = [0.0, "1 m"]', "'m' is not a unit of force (N, kN, cN, gf)"),
        ('value = [0.0, "1 KN"]', "units are case-sensitive, write 'kN'"),
        ("angles = [0.0, 90.0]\nvalues = [[0, 1], [0, 1e300]]", "values: force components must be at most 1e+06 N"),
        (
            "angles = [0.0, 90.0, 180.0, 270.0, 450.0]\nvalues = [[0, 1], [0, 2], [0, 3], [0, 4], [0, 5]]",
            "angles: must lie within one period of the mechanism, 0 to 360 deg (excluded), got 450 deg",
        ),
        ("angles = [-90.0, 0.0, 90.0]\nvalues = [[0, 1], [0, 2], [0, 3]]", "got -90 deg: write it as 270"),
        ("angles = [0.0, 360.0]\nvalues = [[0, 1], [0, 2]]", "0 to 360 deg (excluded), got 360 deg"),
        ('angles = [0.0, "1 rev"]\nvalues = [[0, 1], [0, 2]]', "got 360 deg"),
        ("angles = [0.0, 1e300]\nvalues = [[0, 1], [0, 2]]", "(excluded), got 1e+300 deg"),
        ("angles = [0.0, 90.0, 90.0]\nvalues = [[0, 1], [0, 2], [0, 3]]", "angles: must increase strictly"),
        ("angles = [0.0, nan]\nvalues = [[0, 1], [0, 2]]", "#1 angles [1]: must be finite"),
    ],
)
def test_a_force_beyond_its_limits_or_one_period_is_refused(body, message):
    with pytest.raises(MechanismFileError) as e:
        parse(with_force(body), "f.toml")
    assert message in str(e.value) and "[[dynamics.force]] #1" in str(e.value), str(e.value)


def test_a_geared_mechanisms_force_table_spans_its_whole_period():
    warp = (registry.MECHANISMS_DIR / "warp_knitting.toml").read_text()
    m = parse(warp, "w.toml")
    assert m.period == pytest.approx(4 * math.pi)  # two crank turns (the file's gears)
    point = m.moving_points[-1]
    parse(with_force("angles = [0.0, 400.0, 719.9]\nvalues = [[0, 1], [0, 2], [0, 3]]", warp, point), "w.toml")
    with pytest.raises(MechanismFileError, match=r"0 to 720 deg \(excluded\), got 720 deg"):
        parse(with_force("angles = [0.0, 720.0]\nvalues = [[0, 1], [0, 2]]", warp, point), "w.toml")


def test_a_force_table_has_one_interpolation():
    """Linear between rows and from the last row to the first a period on, at any input angle,
    by both the per-sample and the array interpolation (the issue: a table beyond one period
    gave -0.688 N one way and +0.550 N the other at 90 deg)."""
    table = "angles = [0.0, 90.0, 180.0, 270.0]\nvalues = [[0, 1], [2, 3], [4, -5], [-6, 7]]"
    m = parse(with_force(table), "f.toml")
    f, period = m.dynamics.forces[0], m.period
    closed = {0: (0, 1), 45: (1, 2), 90: (2, 3), 135: (3, -1), 300: (-4, 5), 315: (-3, 4)}
    for deg, (fx, fy) in closed.items():
        for turns in (-2, -1, 0, 1, 5):
            phi = math.radians(deg + 360 * turns)
            assert f.at_scalar(phi, period)[:2] == pytest.approx((fx, fy), abs=1e-12), (deg, turns)
            assert tuple(f.at(phi, period)[0, :2]) == pytest.approx((fx, fy), abs=1e-12), (deg, turns)
    phi = np.linspace(-30.0, 30.0, 6001)
    np.testing.assert_array_equal(f.at(phi, period), np.array([f.at_scalar(x, period) for x in phi]))
    # A table that does not start at 0: still the same one interpolation.
    g = parse(with_force("angles = [10.0, 200.0]\nvalues = [[0, 0], [0, 19]]"), "f.toml").dynamics.forces[0]
    assert g.at_scalar(math.radians(105.0), period)[1] == pytest.approx(9.5, abs=1e-12)
    assert g.at_scalar(math.radians(5.0), period)[1] == pytest.approx(19.0 * (1 - 165.0 / 170.0), abs=1e-12)
    np.testing.assert_array_equal(g.at(phi, period), np.array([g.at_scalar(x, period) for x in phi]))


@pytest.mark.parametrize(
    ("old", "new", "message"),
    [
        ("moment = 0.05 ", "moment = 1e300 ", "[dynamics] moment: must be at most 1e+06 N*m in magnitude"),
        ("moment = 0.05 ", 'moment = "-2e6 N*m" ', "[dynamics] moment: must be at most 1e+06 N*m"),
        ("damping = 10e-6 ", "damping = 1.5e6 ", "[dynamics] damping: must be at most 1e+06 N*m*s"),
        ("gravity = 9.81 ", "gravity = 101 ", "[dynamics] gravity: must be at most 100 m/s^2"),
        ("stall_torque = 0.05", "stall_torque = 1e300", "[steady] stall_torque: must be at most 1e+06 N*m"),
        ("target_delta = 0.02", "target_delta = 2.0", "[steady] target_delta: must be above 0 and below 2"),
        ("target_delta = 0.02", "target_delta = 0.0", "[steady] target_delta: must be above 0 and below 2"),
        ("[thread]\n", "[thread]\nelongation = 1e300\n", "[thread] elongation: must be at most 1000 mm"),
    ],
)
def test_every_load_a_file_gives_is_bounded(old, new, message):
    with pytest.raises(MechanismFileError) as e:
        parse(bad(old, new), "f.toml")
    assert message in str(e.value), str(e.value)


def test_loads_at_their_limits_are_read():
    text = bad("moment = 0.05 ", "moment = -1e6 ").replace("damping = 10e-6 ", "damping = 1e6 ", 1)
    m = parse(text.replace("gravity = 9.81 ", "gravity = 100.0 ", 1), "f.toml")
    assert m.dynamics.moment == -1e6 and m.dynamics.damping == 1e6 and m.dynamics.gravity == 100.0
    assert parse(bad("target_delta = 0.02", "target_delta = 1.99"), "f.toml").steady.target_delta == 1.99


# ----------------------------------------------------------------------------- not a file
def test_a_fifo_a_device_or_a_dangling_link_is_named_for_what_it_is(tmp_path, monkeypatch, capsys):
    """None of them is read (reading a FIFO would wait for a writer) nor called 'no such file'."""
    from mjlink.cli import main
    from mjlink.model.mechanism import load
    from mjlink.study import spec

    fifo = tmp_path / "pipe.toml"
    os.mkfifo(fifo)
    dangling = tmp_path / "gone.toml"
    dangling.symlink_to(tmp_path / "nothing.toml")
    cases = [
        (fifo, "is a FIFO (named pipe), not a mechanism file"),
        (Path("/dev/null"), "is a character device, not a mechanism file"),
        (dangling, "is a symbolic link to nothing, not a mechanism file"),
        (tmp_path, "is a folder, not a mechanism file"),
    ]
    for p, what in cases:
        for get in (validation.get, load, lambda p: validation.get(str(p))):
            with pytest.raises(MjlinkError) as e:
                get(p)
            assert what in str(e.value) and "no such" not in str(e.value), str(e.value)
        assert main(["check", str(p)]) == 1
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and what in err, err
    monkeypatch.chdir(tmp_path)
    os.mkfifo(tmp_path / "mypipe")
    with pytest.raises(UnknownMechanismError, match="mypipe: is a FIFO \\(named pipe\\), not a mechanism file"):
        validation.get("mypipe")  # a bare word that is no registered name
    for p, what in [(fifo, "FIFO (named pipe)"), (Path("/dev/null"), "character device"), (dangling, "symbolic link")]:
        with pytest.raises(MjlinkError, match=f"is a {re.escape(what)}.*, not a study file"):
            spec.load(p)
    study = tmp_path / "s.toml"
    study.write_text(
        (registry.STUDIES_DIR / "takeup_tolerance.toml")
        .read_text()
        .replace('mechanism = "takeup"', 'mechanism = "pipe.toml"')
    )
    with pytest.raises(
        MjlinkError, match=r"\[study\] mechanism: .*pipe\.toml: is a FIFO \(named pipe\), not a mechanism"
    ):
        spec.load(study)
