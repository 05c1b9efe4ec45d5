"""Bad mechanism files are rejected with one clear line naming the file, key and cause."""

import pytest

from mjlink import registry
from mjlink.errors import AssemblyError, MechanismFileError, MjlinkError, UnknownMechanismError
from mjlink.mechanism import parse

GOOD = (registry.MECHANISMS_DIR / "takeup.toml").read_text()


def bad(old, new, count=1):
    assert old in GOOD, old
    return GOOD.replace(old, new, count)


@pytest.mark.parametrize("text, match", [
    ("[mechanism\nname=1", "TOML syntax error"),
    (bad("length = 30.0", "lenght = 30.0"), "unknown key 'lenght' \\(did you mean 'length'\\?\\)"),
    (bad("length = 30.0", ""), "missing key 'length'"),
    (bad("length = 30.0", "length = \"30\""), "must be a number"),
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
], ids=lambda v: v if len(v) < 40 else None)
def test_rejected(tmp_path, text, match):
    f = tmp_path / "bad.toml"
    f.write_text(text)
    with pytest.raises(MechanismFileError, match=match) as e:
        registry.get(f)
    msg = str(e.value)
    assert "\n" not in msg and str(f) in msg


def test_dyad_that_cannot_close_reports_the_angle_range(tmp_path):
    f = tmp_path / "rocker.toml"
    f.write_text(bad("length_b = 19.0", "length_b = 9.0"))
    with pytest.raises(AssemblyError, match=r"cannot turn fully.*assembles only for input angles [-0-9.]+\.\.[-0-9.]+"):
        registry.get(f)


def test_unknown_name_lists_valid_choices():
    with pytest.raises(UnknownMechanismError, match="valid: .*takeup"):
        registry.get("takup")


def test_one_base_exception():
    for cls in (MechanismFileError, AssemblyError, UnknownMechanismError):
        assert issubclass(cls, MjlinkError)


def test_parse_accepts_the_shipped_file():
    m = parse(GOOD, "takeup.toml")
    assert m.name == "takeup" and len(m.links) == 3
