"""The feed's surfaces held against hostile input: runs longer than the fabric's piece, heads
that feed with the default presser and fabric, values no contact can step, speeds at the ends of
their range, output folders through dangling links."""

from __future__ import annotations

import os
import re

import pytest

from mjlink.errors import OutputError
from mjlink.model import mechanism
from mjlink.model.catalogue import shipped
from mjlink.pipeline.feed import MAX_RPM
from mjlink.pipeline.feed import feed as feed_command
from mjlink.runtime.staging import check_destination
from mjlink.sim import feed

HEAD = shipped("mechanisms") / "lockstitch_head.toml"
HEAD_TEXT = HEAD.read_text()


def _with(tables: str = "", fabric: str | None = None):
    text = HEAD_TEXT
    if fabric is not None:
        text, n = re.subn(r"(?m)^fabric = 1\.5 ", f"fabric = {fabric} ", text)
        assert n == 1
    return mechanism.parse(text + "\n" + tables, "head.toml")


@pytest.fixture(scope="module")
def head():
    return mechanism.load(HEAD)


def test_a_run_of_many_stitches_feeds_the_stitch_a_short_run_feeds(head):
    """The fabric's piece is as long as the run needs: fifteen stitches at the file's speed end
    with the stitch six end with (the periodic state, reached within a few stitches; before,
    the piece, 60 mm long, left the dog's teeth after some 24 mm and the run reported a stitch
    of 10 mm)."""
    short, long = feed.run_feed(head, stitches=6), feed.run_feed(head, stitches=15)
    assert long.fabric_half > short.fabric_half
    assert abs(long.stitch - short.stitch) < 1e-7  # m: a tenth of a micron, the state repeated
    assert abs(long.error) < 0.01


def test_a_fabric_that_feeds_beyond_its_piece_is_refused(head, monkeypatch):
    """A run whose fabric fed further than its piece reaches is refused, not reported."""
    monkeypatch.setattr(feed, "FED_ALLOWANCE", 0.1)
    monkeypatch.setattr(feed, "FABRIC_HALF", (0.005, 0.01))  # no piece longer than the allowance asks
    with pytest.raises(ValueError, match="it left the dog's teeth") as e:
        feed.run_feed(head, stitches=6)
    assert "\n" not in str(e.value)


@pytest.mark.parametrize(
    ("fabric", "says"),
    [
        ("0.0", "[timing] fabric: the feed dog feeds a fabric under the presser foot"),
        ("10.0", "[timing] fabric: 10 mm of fabric does not fit under the presser foot, which lifts to 7 mm"),
    ],
)
def test_a_head_without_presser_and_fabric_tables_is_held_to_their_defaults(fabric, says):
    """The defaults a head feeds with when it writes no [presser] or [fabric] table are checked
    as a written table is (before, a 0 mm fabric crashed MuJoCo's compiler, and 10 mm under the
    default 7 mm lift fed a stitch of -0.4 mm)."""
    with pytest.raises(mechanism.MechanismFileError) as e:
        _with(fabric=fabric)
    assert says in str(e.value) and "\n" not in str(e.value)


@pytest.mark.parametrize(
    "tables",
    [
        "[presser]\nmass = 5e-324\n",
        "[presser]\npreload = 1e-100\n",
        "[presser]\nrate = 1e-200\n",
        "[fabric]\narea = 5e-324\n",
        "[fabric]\nmass = 5e-324\n",
        "[fabric]\nstiffness = 5e-324\n",
        "[[fabric.ply]]\nthickness = 0.75\nmass = 1e-9\n[[fabric.ply]]\nthickness = 0.75\n",
        "[[fabric.ply]]\nthickness = 1e-300\n[[fabric.ply]]\nthickness = 1.5\n",
    ],
)
def test_values_no_contact_can_step_are_refused_in_one_line(tables):
    """Values above nought but below any presser or fabric (before: a division by zero, MuJoCo
    refusing a massless body, or a spring standing 1e198 m from its free length and NaN
    written as the result)."""
    with pytest.raises(mechanism.MechanismFileError, match="must be at least") as e:
        _with(tables)
    assert "\n" not in str(e.value)


def test_a_foot_too_light_to_step_is_named_not_the_fabric():
    """The lighter of the foot and the fabric's top ply sets the step: here the foot."""
    heavy = "[presser]\nmass = 1.0\n[fabric]\narea = 1e4\nmass = 5000.0\nstiffness = 1e5\n"
    with pytest.raises(mechanism.MechanismFileError, match=r"\[presser\] mass: the foot \(1 g\)"):
        _with(heavy)


def test_a_speed_at_the_end_of_its_range_given_another_way_is_taken(head):
    """10,000 rpm turned into rad/s and back is not exactly 10,000 (before, 60 rpm was refused
    with 'the feed runs at 60 to 10000 rpm, got 60 rpm')."""
    result = feed_command(head, None, speed_rpm=MAX_RPM * (1.0 + 4e-16), stitches=2, plots=False)
    assert result.sweep.runs[0].speed_rpm == pytest.approx(MAX_RPM, rel=1e-12)


def test_an_output_folder_that_is_a_dangling_link_is_refused(tmp_path):
    """Following it would create folders wherever it points."""
    link = tmp_path / "out"
    os.symlink(tmp_path / "elsewhere" / "deep", link)
    with pytest.raises(OutputError, match=r"symbolic link to .* which does not exist"):
        check_destination(link, kind="feed")
    assert not (tmp_path / "elsewhere").exists()


def test_a_thread_path_naming_a_point_twice_in_a_row_is_refused():
    text = HEAD_TEXT.replace('path = ["T", "CS", "N1", "P5",', 'path = ["T", "CS", "N1", "P5", "P5",', 1)
    assert text != HEAD_TEXT
    with pytest.raises(mechanism.MechanismFileError, match=r"\[thread\] path: names 'P5' twice in a row"):
        mechanism.parse(text, "head.toml")


def test_a_feed_speed_against_the_files_direction_says_its_sign_is_not_taken(tmp_path, capsys):
    from mjlink.cli import main

    code = main(["feed", str(HEAD), "--speed", "-3000rpm", "--stitches", "2", "--no-plots", "--out", str(tmp_path)])
    out = capsys.readouterr().out
    assert code == 0
    assert "note: --speed -3000rpm is against the file's own direction" in out
    assert "3000 rpm" in out.replace(",", "")


def test_a_study_of_the_fabrics_thickness_on_a_plied_head_is_told_to_vary_its_plies():
    from mjlink.errors import MjlinkError
    from mjlink.model.paths import resolve

    mech = _with("[[fabric.ply]]\nthickness = 0.9\n[[fabric.ply]]\nthickness = 0.6\n")
    with pytest.raises(MjlinkError, match=r"vary fabric\.ply1\.thickness, fabric\.ply2\.thickness") as e:
        resolve(mech, "timing.fabric")
    assert "\n" not in str(e.value)
