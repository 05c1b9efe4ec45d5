"""A head's thread named by its count (docs/head.md, The thread under tension: The thread by its
count): the chart against the maker's published text, the ``[tension] thread`` key and its
errors, a study's winner written from a file that names a count, ``check``'s lines, and the
page's table over the two-ply counts."""

from __future__ import annotations

import dataclasses

import pytest

from mjlink.analysis.tension import needle_tension
from mjlink.analysis.timing import head_timing
from mjlink.errors import MjlinkError
from mjlink.model import mechanism, paths, threads
from mjlink.model.catalogue import shipped
from mjlink.model.tension import DEFAULTS
from mjlink.validation import check

HEAD = shipped("mechanisms") / "lockstitch_head.toml"
BAND_HEAD = shipped("mechanisms") / "examples" / "lockstitch_head_band.toml"

# MH Thread, All About Polyester Threads (2024), the Spun Polyester Sewing Thread Size Chart as
# published: Ne count, tex, average strength (cN), elongation at break (%).
PUBLISHED = """
12s/3 150 5010 8-13
12s/4 200 7080 8-13
20s/2 60 2124 10-16
20s/3 90 3540 11-16
20s/6 180 5832 8-13
20s/9 270 9045 7-12
30s/2 40 1379 10-15
30s/3 60 2245 11-16
40s/2 30 1050 10-15
40s/3 45 1642 10-15
50s/2 24 850 9-14
50s/3 36 1309 10-15
60s/2 20 666 9-14
60s/3 30 1030 10-15
"""


def _published() -> list[tuple[str, float, float, float, float]]:
    out = []
    for line in PUBLISHED.strip().splitlines():
        count, tex, cn, band = line.split()
        lo, hi = band.split("-")
        out.append((count, float(tex), float(cn), float(lo), float(hi)))
    return out


def test_the_chart_is_the_makers_as_published():
    published = _published()
    assert [t.count for t in threads.CHART] == [p[0] for p in published]
    got = [(t.tex, t.strength * 100, t.elongation_low * 100, t.elongation_high * 100) for t in threads.CHART]
    assert got == [pytest.approx(p[1:], rel=1e-12) for p in published]


def _head_with(lines: str) -> str:
    """The shipped head's text with its thread's two numbers replaced by ``lines``."""
    text = HEAD.read_text()
    kept = [line for line in text.splitlines() if not line.startswith(("breaking_load =", "elongation_at_break ="))]
    out = "\n".join(kept) + "\n"
    return out.replace("[tension]\n", f"[tension]\n{lines}\n", 1)


@pytest.mark.parametrize("spelled", ["50s/2", "50/2", " 50S / 2 "])
def test_a_count_gives_its_breaking_strength_and_the_middle_of_its_elongation(spelled):
    t = mechanism.parse(_head_with(f'thread = "{spelled}"')).tension
    assert t is not None
    assert (t.breaking_load, t.elongation_at_break) == pytest.approx((8.50, (0.09 + 0.14) / 2), rel=1e-12)
    assert t.thread is not None and t.thread.count == "50s/2"
    assert t.needle_tension == DEFAULTS.needle_tension


def test_the_defaults_are_the_files_count():
    assert DEFAULTS.thread is not None and DEFAULTS.thread.count == "40s/2"
    assert dataclasses.replace(DEFAULTS, breaking_load=10.0).thread is None


@pytest.mark.parametrize(
    ("lines", "message"),
    [
        ('thread = "55s/2"', "did you mean '50s/2'"),
        ('thread = "cotton"', "the chart's counts: 12s/3"),
        ('thread = "4s0/2"', "no spun polyester count '4s0/2'"),
        ('thread = "040s/2"', "no spun polyester count '040s/2'"),
        ("thread = 40", "must be a string"),
        ('thread = "' + "4" * 40 + '"', "at most 16 characters"),
        ('thread = "40s/2\\n"', "printable"),
        ('thread = "40s/2"\nbreaking_load = 9', "give it or breaking_load, not both"),
        ('thread = "40s/2"\nelongation_at_break = 0.1', "give it or elongation_at_break, not both"),
        ('thred = "40s/2"', "did you mean 'thread'"),
    ],
)
def test_a_bad_thread_is_one_line_naming_the_cause(lines, message):
    with pytest.raises(MjlinkError) as e:
        mechanism.parse(_head_with(lines))
    assert "\n" not in str(e.value) and "[tension]" in str(e.value) and message in str(e.value)


@pytest.mark.parametrize(
    ("path", "value", "expected"),
    [
        ("tension.breaking_load", 9.0, (9.0, 0.115, None)),
        ("tension.elongation_at_break", 0.2, (8.5, 0.2, None)),
        ("tension.needle_tension", 1.2, (8.5, 0.115, "50s/2")),
    ],
)
def test_a_winner_from_a_file_naming_a_count_is_written_whole(path, value, expected):
    """A study that moves one of a count's numbers writes both in its place (a file with the
    count and a number would be refused); one that moves neither keeps the count."""
    mech = mechanism.parse(_head_with('thread = "50s/2"'), HEAD)
    param = paths.catalogue(mech)[path]
    paths.check_values(mech, {param: value})
    text = paths.file_text(mech, {param: value}, "# a winner")
    t = mechanism.parse(text).tension
    assert t is not None
    got = (t.breaking_load, t.elongation_at_break, t.thread.count if t.thread else None)
    assert got[:2] == pytest.approx(expected[:2], rel=1e-12) and got[2] == expected[2]
    assert ('thread = "50s/2"' in text) == (expected[2] is not None)


def test_check_shows_the_thread_by_its_count():
    mech = mechanism.parse(_head_with('thread = "60s/2"'), HEAD)
    lines = check(mech).thread
    assert lines[0].startswith("thread: spun polyester 60s/2, tex 20: 666 cN, 9-14 % (MH Thread's chart): ")
    assert "breaking load 6.66 N, elongation at break 11.5 %, EA 57.91 N" in lines[0]
    assert "needle tension 1.6 N (163 gf)" in lines[1] and "bobbin thread 25 gf" in lines[1]
    assert check(mechanism.load(shipped("mechanisms") / "examples" / "chainstitch_head.toml")).thread == ()


# docs/head.md, The thread by its count: (peak N, margin, slack deg) over the two-ply counts at
# the needle tensions given, at 1,440 steps a stitch.
TABLE = {
    "shipped": {
        1.0: {
            "60s/2": (0.597, 11.2, 257.25),
            "50s/2": (0.560, 15.2, 271.75),
            "40s/2": (0.536, 19.6, 279.5),
            "30s/2": (0.475, 29.1, 296.25),
            "20s/2": (0.442, 48.0, 313.5),
        },
        1.6: {
            "60s/2": (1.740, 3.83, 211.5),
            "50s/2": (1.746, 4.87, 224.5),
            "40s/2": (1.750, 6.00, 230.5),
            "30s/2": (1.762, 7.83, 245.75),
            "20s/2": (1.788, 11.9, 263.75),
        },
        2.2: {
            "60s/2": (2.493, 2.67, 204.0),
            "50s/2": (2.836, 3.00, 214.5),
            "40s/2": (3.034, 3.46, 220.0),
            "30s/2": (3.470, 3.97, 229.75),
            "20s/2": (3.849, 5.52, 253.0),
        },
    },
    "band": {
        1.0: {
            "60s/2": (0.488, 13.7, 288.0),
            "50s/2": (0.443, 19.2, 296.75),
            "40s/2": (0.443, 23.7, 300.75),
            "30s/2": (0.444, 31.1, 309.25),
            "20s/2": (0.444, 47.9, 323.25),
        },
        2.2: {
            "60s/2": (1.624, 4.10, 216.0),
            "50s/2": (1.774, 4.79, 224.25),
            "40s/2": (1.873, 5.61, 228.5),
            "30s/2": (2.170, 6.36, 236.0),
            "20s/2": (2.513, 8.45, 259.0),
        },
    },
}


def _rounded(x: float, like: float) -> bool:
    """``x`` written as the page writes ``like`` (its digits after the point)."""
    digits = len(f"{like}".split(".")[1]) if "." in f"{like}" else 0
    return round(x, digits) == pytest.approx(like, abs=1e-12)


@pytest.mark.parametrize("which", ["shipped", "band"])
def test_the_pages_table_over_the_counts(which):
    mech = mechanism.load(HEAD if which == "shipped" else BAND_HEAD)
    timing = head_timing(mech)
    base = mech.tension or DEFAULTS
    for tension, rows in TABLE[which].items():
        for count, (peak, margin, slack) in rows.items():
            row = threads.by_count(count)
            cfg = dataclasses.replace(
                base, breaking_load=row.strength, elongation_at_break=row.elongation, needle_tension=tension
            )
            r = needle_tension(mech, timing, settings=cfg)
            assert r.converged and r.period == 1, (which, tension, count)
            got = (r.peak, r.margin, float(r.slack.mean()) * 360.0)
            assert _rounded(got[0], peak) and f"{got[1]:.3g}" == f"{margin:.3g}", (which, tension, count, got)
            assert got[2] == pytest.approx(slack, abs=1e-9), (which, tension, count, got)
