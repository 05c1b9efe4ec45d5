"""``[timing]`` by parts: a needle drive alone gets its penetration and exit instants and
velocities, a feed alone its dog's height and flush instants, the hook's rows only with a hook;
what a part needs is said in one line. Each part's numbers are the whole head's (the same
mechanism), and the needle's velocities those of the study metric that asks for them."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

from mjlink import study, validation
from mjlink.analysis.timing import head_timing
from mjlink.cli.text import format_report
from mjlink.errors import MechanismFileError
from mjlink.model import catalogue
from mjlink.model.mechanism import parse

HEAD = catalogue.path_of("lockstitch_head").read_text()
PLATE, FABRIC = -100.0, 1.5  # mm, the head's


def _without(text: str, *tables: str) -> str:
    """The file without the named top-level tables (and their sub-tables)."""
    out, skip = [], False
    for line in text.splitlines():
        m = re.match(r"\[+([A-Za-z_.]+)\]+", line)
        if m:
            skip = m[1].split(".")[0] in tables
        if not skip:
            out.append(line)
    return "\n".join(out) + "\n"


def _head(timing: str):
    return parse(_without(HEAD, "timing", "balance", "tension") + timing, "part.toml")


NEEDLE = f"""
[timing]
needle_bar = "NB"
needle_point = "NT"
plate = {PLATE}
fabric = {FABRIC}
"""

FEED = f"""
[timing]
feed_dog = "F"
plate = {PLATE}
target = "juki_tl2010q"

[timing.juki_tl2010q]
source = "Juki TL-2010Q instruction manual, 4. Height of feed dog"
dog_height = [1.1, 1.3]
"""


@pytest.fixture(scope="module")
def whole():
    return head_timing(validation.get("lockstitch_head"))


def test_a_needle_drive_alone_gets_its_penetration_and_exit(whole):
    mech = _head(NEEDLE)
    report = validation.check(mech)
    assert report.ok and report.timing is not None
    head = report.timing
    assert head.rows == () and head.target == ""  # no feed, no hook, no maker: nothing to hold
    for event in ("needle point into the fabric, down", "needle point out of the fabric, up", "needle bar bottom"):
        assert head.events[event] == pytest.approx(whole.events[event], abs=1e-9)
    for key in ("penetration velocity", "exit velocity"):
        assert head.values[key][0] == pytest.approx(whole.values[key][0], rel=1e-12)
    # The study metric that asks for the same numbers (tests/test_motion.py holds it to a
    # scalar root of the reference).
    cols = study.evaluate(
        mech,
        {"input.phi0": [math.degrees(mech.phi0)]},
        [
            {
                "kind": "motion",
                "name": name,
                "point": "NT",
                "quantity": "velocity",
                "axis": "y",
                "event": {"height": PLATE + FABRIC, "direction": way},
            }
            for name, way in (("into", "down"), ("out", "up"))
        ],
    ).columns
    assert head.values["penetration velocity"] == (pytest.approx(cols["into"][0], rel=1e-6), "m/s")
    assert head.values["exit velocity"] == (pytest.approx(cols["out"][0], rel=1e-6), "m/s")
    assert cols["into"][0] < 0 < cols["out"][0]
    text = format_report(report)
    assert "main-shaft angle from the needle bar's top dead centre; no maker's settings" in text
    assert "measured: penetration velocity -8.363 m/s, exit velocity" in text


def test_a_feed_alone_gets_its_dog_height_and_flush_instants(whole):
    mech = _head(FEED)
    head = validation.check(mech).timing
    assert head is not None and head.origin == "the crank's setting"
    assert [r.key for r in head.rows] == ["dog_height"]  # no needle: none of the needle's checks
    full = next(r for r in whole.rows if r.key == "dog_height")
    assert head.rows[0].value == pytest.approx(full.value, abs=1e-12)
    # The same instants, counted from the crank's setting instead of the needle bar's top.
    assert whole.order is not None
    tdc = math.degrees(2 * math.pi * whole.order[0] / len(whole.theta))
    for event in ("dog flush, descending", "dog through the plate, rising"):
        assert head.events[event] == pytest.approx((whole.events[event] + tdc) % 360.0, abs=1e-9)
    assert set(head.curves) == {"dog height", "dog advance"}


@pytest.mark.parametrize(
    ("timing", "words"),
    [
        (NEEDLE.replace('needle_point = "NT"\n', ""), "[timing] needle_bar: needs needle_point named too"),
        (NEEDLE + 'hook_point = "HP"\n', "[timing] hook_point: needs needle_eye named too"),
        (NEEDLE + 'needle_eye = "NE"\ntake_up = "P5"\n', "[timing] take_up: needs hook_point named too"),
        (f"\n[timing]\nplate = {PLATE}\n", "names no part to time"),
        (NEEDLE + 'target = "x"\n', "names settings, but the table has no maker's settings table"),
        (FEED.replace('target = "juki_tl2010q"\n', ""), "needs 'target'"),
        (
            FEED.replace("dog_height = [1.1, 1.3]", "needle_at_dog_flush = [-0.2, 0.2]"),
            "needle_at_dog_flush: measures the needle_bar and needle_point, which [timing] does not name",
        ),
    ],
)
def test_a_part_without_what_it_needs_is_one_line(timing, words):
    with pytest.raises(MechanismFileError) as e:
        _head(timing)
    assert words in str(e.value) and "\n" not in str(e.value), str(e.value)


def test_a_balance_needs_the_hook_and_the_eye():
    text = _without(HEAD, "timing", "tension") + NEEDLE
    with pytest.raises(
        MechanismFileError, match=r"\[balance\]: needs the needle's eye and the hook named in \[timing\]"
    ):
        parse(text, "part.toml")


def test_the_whole_head_is_measured_as_before(whole):
    """Naming every part gives every check, in the order the head's table has always had."""
    keys = [r.key for r in whole.rows]
    assert keys[:3] == ["dog_below_while_needle_down", "feed_in_fabric", "take_up_after_release"]
    assert whole.origin == "the needle bar's top dead centre" and whole.target == "juki_composite"
    assert (
        np.isfinite(whole.values["penetration velocity"][0]) and whole.values["dog height above the plate"][1] == "mm"
    )


def test_a_timing_table_without_its_optional_numbers_takes_their_documented_defaults():
    """mjlink/model/timing.py's table documents ``fabric`` 1.5 mm, ``loop_release`` 270 deg and
    ``feed_in_fabric`` 0.2 mm when a file leaves them out. The shipped head writes exactly
    those: without the three lines it is the same head, its every timing row the same."""
    lines = ("fabric = 1.5 ", "loop_release = 270.0 ", "feed_in_fabric = 0.2 ")
    assert all(sum(line.startswith(k) for line in HEAD.splitlines()) == 1 for k in lines)
    bare = "\n".join(line for line in HEAD.splitlines() if not line.startswith(lines)) + "\n"
    written, left_out = parse(HEAD, "whole.toml"), parse(bare, "bare.toml")
    assert left_out.timing.fabric == pytest.approx(1.5e-3, rel=1e-15)  # m
    assert left_out.timing.loop_release == pytest.approx(math.radians(270.0), rel=1e-15)
    assert left_out.timing.feed_in_fabric == pytest.approx(0.2e-3, rel=1e-15)  # m
    a, b = head_timing(written, samples=720), head_timing(left_out, samples=720)
    rows = [[(r.key, r.maker, r.value, r.window, r.ok) for r in t.rows] for t in (a, b)]
    assert rows[0] == rows[1] and len(rows[0]) > 10
