"""design.html's "Save as TOML" edits the file in place (mjlink.model.tomledit and
mjlink.pages.design.save_edits): every number the page edits is found where the file writes
it, in every spelling TOML allows a mechanism file, and writing it there changes that number of
the mechanism the reader reads and nothing else. The page's own use of it runs in Chromium in
tests/test_design_page.py."""

from __future__ import annotations

import json
import re
import tomllib

import pytest

from mjlink.analysis import summary
from mjlink.model import catalogue, mechanism, paths, tomledit
from mjlink.pages import design as design_page

NAMES = ["takeup", "crank_slider", "takeup_eyelets", "warp_knitting", "lockstitch_head"]
TAKEUP = catalogue.path_of("takeup").read_text(encoding="utf-8")


def _respelled(text: str) -> dict[str, str]:
    """The take-up file in the other spellings TOML gives a designer: each must be edited in
    place as the shipped spelling is."""
    blocks = text[text.index("[[construct]]") : text.index("# Rigid links")]
    inline = ",\n".join(
        "  { " + ", ".join(f"{k} = {json.dumps(v)}" for k, v in c.items()) + " }"
        for c in tomllib.loads(text)["construct"]
    )
    return {
        "CRLF line ends": text.replace("\n", "\r\n"),
        "no newline at the end": text.rstrip("\n"),
        "quoted keys": text.replace("P4 = [", '"P4" = [', 1).replace("length_a =", "'length_a' =", 1),
        "units written": re.sub(r"length_b = ([0-9.]+)", r'length_b = "\1 mm"', text, count=1),
        "an array over lines with comments": text.replace("P4 = [", "P4 = [  # the pivot\n    ", 1),
        "tabs and no blanks": text.replace("phi0 = ", "phi0\t=\t", 1).replace(" = ", "=", 3),
        "comments with non-BMP text": "# \U0001f9f5 thread\n" + text.replace("[input]", "[input]  # \U0001f600", 1),
        "a crank's phase left out": text,  # the take-up writes none: the page adds the line
        "a trailing comma": text.replace("P4 = [9.66, 2.59]", "P4 = [9.66, 2.59,]", 1),
        "blocks as inline tables": f"construct = [\n{inline},\n]\n\n" + text.replace(blocks, ""),
    }


def _check_every_number(text: str, where) -> int:
    """Writes each editable number with its own probe value, reads the file back with the
    mechanism reader and asserts that exactly that number changed; returns how many."""
    mech = mechanism.parse(text)
    edits = design_page.save_edits(mech, text)
    dims = {p: v for p, v, _ in summary.dimensions(mech)}
    assert set(dims) <= set(edits), sorted(set(dims) - set(edits))
    raw = tomllib.loads(text)
    layout = tomledit.layout(text)
    for i, path in enumerate(edits):
        at = design_page._raw_path(raw, path)
        assert at is not None
        e = tomledit.edit(text, layout, at)
        assert e is not None
        probe = 11.0 + 0.125 * i
        changed = mechanism.parse(e.apply(text, repr(probe)))
        assert paths.resolve(changed, path).nominal == pytest.approx(probe, abs=1e-9), (where, path)
        for other, v in dims.items():
            if other != path:
                assert paths.resolve(changed, other).nominal == pytest.approx(v, rel=1e-12, abs=1e-12), (path, other)
    return len(edits)


@pytest.mark.parametrize("name", NAMES)
def test_every_number_of_a_shipped_file_is_written_in_its_place(name):
    text = catalogue.path_of(name).read_text(encoding="utf-8")
    assert _check_every_number(text, name) >= len(summary.dimensions(mechanism.parse(text)))


@pytest.mark.parametrize("spelling", list(_respelled(TAKEUP)))
def test_every_spelling_of_a_file_is_edited_in_place(spelling):
    text = _respelled(TAKEUP)[spelling]
    assert text != TAKEUP or spelling == "a crank's phase left out"
    _check_every_number(text, spelling)


def test_a_missing_key_is_a_new_line_after_its_tables_last_and_the_rest_is_kept():
    """The take-up's crank writes no phase: setting it adds one line to that block, after its
    last key; every other line of the file is kept byte for byte."""
    raw = tomllib.loads(TAKEUP)
    index = next(i for i, c in enumerate(raw["construct"]) if c["block"] == "crank")
    assert "phase" not in raw["construct"][index]
    e = tomledit.edit(TAKEUP, tomledit.layout(TAKEUP), ("construct", index, "phase"))
    assert e is not None and e.start == e.end and e.before == "\nphase = "
    out = e.apply(TAKEUP, "12.5")
    assert tomllib.loads(out)["construct"][index]["phase"] == 12.5
    new, old = out.splitlines(), TAKEUP.splitlines()
    assert len(new) == len(old) + 1
    added = next(i for i, (a, b) in enumerate(zip(new, old, strict=False)) if a != b)
    assert new[added] == "phase = 12.5" and new[:added] + new[added + 1 :] == old


def test_a_place_the_scanner_cannot_find_is_never_written():
    """A path the text has no table for, or an array more than one element short, gets no edit;
    a text outside the grammar raises ValueError naming its line."""
    where = tomledit.layout(TAKEUP)
    assert tomledit.edit(TAKEUP, where, ("nowhere", "x")) is None
    assert tomledit.edit(TAKEUP, where, ("ground", "P4", 5)) is None
    with pytest.raises(ValueError, match="line 2"):
        tomledit.layout("a = 1\nb = [1 2]\n")
