"""Property test: random four-bar and crank-slider mechanism files, valid and invalid, as TOML
text. Every case must either fail with a documented one-line error or, if it loads and
validates, simulate in MuJoCo within the agreement thresholds and on the reference's branch:
no crash, no silent disagreement.

The generated domain is the envelope the thresholds are claimed for (mechanisms/README.md,
"Limits"): bars of 2..250 mm, crank speeds of 20..150 rad/s either way with the crank pin's
acceleration (crank length x speed^2) within 10..500 m/s^2, links of 5..50 g with the inertia
of a bar (0.5..2 times m L^2 / 12). A mutated value can leave it (a speed of 12.5 rad/s):
such a file, valid with a note, is held to the same thresholds, and counted apart. A valid
file whose run is too short to be judged (a mutated ``cycles``) must be refused as
``simulate`` refuses it, in one line; every other valid file must simulate without error.
Invalid cases come from replacing a value with a bad one (zero, negative, huge, tiny,
non-finite, a wrong type), deleting or misspelling a key, a bad sign or an undefined point;
valid-looking geometry that cannot be assembled, passes near a dead point or has a
non-Grashof chain comes from the random lengths themselves.

Counts are reported as a warning (PropertyStats) so the CI log shows them without ``-s``.
``PROPERTY_EXAMPLES`` sets the number of cases (default 250); ``PROPERTY_RANDOM=1`` explores
new cases instead of the reproducible sequence. The sequence is pinned by ``PROPERTY_SEED``:
Hypothesis' derandomized seed is a digest of the test's source, so without a pinned seed any
reformatting of this file would draw other cases.
"""

import math
import os
import warnings
from collections import Counter

import pytest
from hypothesis import HealthCheck, given, seed, settings
from hypothesis import strategies as st

from mjlink import compare, validation
from mjlink import validation as check
from mjlink.cli import format_report
from mjlink.errors import AssemblyError, MechanismFileError, SimulationError
from mjlink.model import catalogue as registry
from mjlink.model import limits
from mjlink.model.mechanism import load
from mjlink.pipeline import cost
from mjlink.sim import simulate

EXAMPLES = int(os.environ.get("PROPERTY_EXAMPLES", "250"))
PROPERTY_SEED = 2026
BAD_VALUES = [
    "0",
    "0.0",
    "-12.5",
    "-1e-3",
    "1e6",
    "1e300",
    "1e-7",
    "nan",
    "inf",
    "-inf",
    '"12"',
    "[1.0, 2.0]",
    "true",
    "1" + "0" * 400,
    "{x = 1}",
]


class PropertyStats(UserWarning):
    """The property test's counts, reported in the warnings summary."""


def _num(x: float) -> str:
    return repr(round(x, 4))


@st.composite
def mechanism_text(draw):
    """TOML text of a random four-bar or crank-slider, then maybe one mutation."""
    length = lambda lo, hi: draw(st.floats(lo, hi, allow_nan=False, allow_infinity=False))  # noqa: E731
    kind = draw(st.sampled_from(["crank_rocker", "double_crank", "four_bar", "crank_slider"]))
    phi0 = length(-180.0, 180.0)
    mass = [length(5.0, 50.0) for _ in range(3)]  # g: comparable links
    bar = [length(0.5, 2.0) for _ in range(3)]  # inertia / that of a uniform bar, m L^2 / 12
    lines = ["[mechanism]", 'name = "prop"', 'title = "generated"', "", "[ground]", "A = [0.0, 0.0]"]
    if kind == "crank_slider":
        r, rod, e = length(2.0, 60.0), length(5.0, 250.0), length(-60.0, 60.0)
        lines += [f"G1 = [0.0, {_num(-e)}]", f"G2 = [100.0, {_num(-e)}]"]
        second = [
            "[[construct]]",
            'point = "C"',
            'block = "slider"',
            'start = "B"',
            f"length = {_num(rod)}",
            'guide = ["G1", "G2"]',
            f'toward = "{draw(st.sampled_from(["G1", "G2"]))}"',
        ]
        crank = r
        links = [
            ("crank", '["A", "B"]', "S1", None),
            ("rod", '["B", "C"]', "S2", None),
            ("slider", '["C"]', "C", '["G1", "G2"]'),
        ]
        coms = [("S1", "A", "B", crank / 2), ("S2", "B", "C", rod / 2)]
    else:
        if kind == "crank_rocker":
            b, c, d = length(20.0, 250.0), length(20.0, 250.0), length(20.0, 250.0)
            a = length(2.0, 0.9 * min(b, c, d))
        elif kind == "double_crank":
            d = length(2.0, 40.0)
            a, b, c = (length(1.2 * d, 250.0) for _ in range(3))
        else:
            a, b, c, d = (length(2.0, 250.0) for _ in range(4))
        lines += [f"D = [{_num(d)}, 0.0]"]
        second = [
            "[[construct]]",
            'point = "C"',
            'block = "dyad"',
            'a = "B"',
            'b = "D"',
            f"length_a = {_num(b)}",
            f"length_b = {_num(c)}",
            f"sign = {draw(st.sampled_from([1, -1]))}",
        ]
        crank = a
        links = [
            ("crank", '["A", "B"]', "S1", None),
            ("coupler", '["B", "C"]', "S2", None),
            ("rocker", '["D", "C"]', "S3", None),
        ]
        coms = [("S1", "A", "B", crank / 2), ("S2", "B", "C", b / 2), ("S3", "D", "C", c / 2)]
    # speed inside the verified envelope (limits): |speed| <= 150 rad/s, 10 <= crank * speed^2 <= 500 m/s^2
    lo, hi = limits.VERIFIED_CRANK_ACCELERATION
    w_lo = max(20.0, (lo / (crank * 1e-3)) ** 0.5)
    w_hi = max(w_lo, min(limits.VERIFIED_SPEED, (hi / (crank * 1e-3)) ** 0.5))
    speed = length(w_lo, w_hi) * draw(st.sampled_from([1, -1]))
    # Shared pins and longer chains: a second rod on the crank pin (to a rocker or a slider),
    # or a second dyad on the coupler; three bodies then meet at one point.
    extra = draw(st.sampled_from(["none", "none", "dyad_on_pin", "slider_on_pin", "dyad_on_coupler"]))
    if extra == "dyad_on_coupler" and kind == "crank_slider":
        extra = "dyad_on_pin"
    more_ground: list[str] = []
    more_construct: list[str] = []
    more_links: list[tuple[str, str, float, float]] = []  # name, points, length mm, mass g
    if extra in ("dyad_on_pin", "dyad_on_coupler"):
        # E at distance d from the chain's driving point's centre; lengths chosen so that the
        # dyad closes over the whole turn for a crank of length r (Grashof-like bounds).
        r = crank if extra == "dyad_on_pin" else length(2.0, 60.0)
        d = length(r + 20.0, r + 200.0)
        b2 = length(20.0, 200.0)
        lo2, hi2 = abs(b2 - (d - r)) + 5.0, b2 + (d - r) - 5.0
        lo2 = max(lo2, d + r - b2 + 5.0)
        c2 = length(lo2, hi2) if lo2 < hi2 else length(20.0, 200.0)
        ang = length(-180.0, 180.0)
        origin = "B" if extra == "dyad_on_pin" else "C"
        more_ground.append(f"E = [{_num(d * math.cos(math.radians(ang)))}, {_num(d * math.sin(math.radians(ang)))}]")
        more_construct += [
            "[[construct]]",
            'point = "X"',
            'block = "dyad"',
            f'a = "{origin}"',
            'b = "E"',
            f"length_a = {_num(b2)}",
            f"length_b = {_num(c2)}",
            f"sign = {draw(st.sampled_from([1, -1]))}",
            "",
        ]
        more_links += [
            ("rod2", f'["{origin}", "X"]', b2, length(5.0, 50.0)),
            ("rocker2", '["E", "X"]', c2, length(5.0, 50.0)),
        ]
    elif extra == "slider_on_pin":
        rod2, e2 = length(crank + 20.0, crank + 250.0), length(-60.0, 60.0)
        more_ground += [f"H1 = [{_num(e2)}, 0.0]", f"H2 = [{_num(e2)}, 100.0]"]
        more_construct += [
            "[[construct]]",
            'point = "X"',
            'block = "slider"',
            'start = "B"',
            f"length = {_num(rod2)}",
            'guide = ["H1", "H2"]',
            f'toward = "{draw(st.sampled_from(["H1", "H2"]))}"',
            "",
        ]
        more_links += [("rod2", '["B", "X"]', rod2, length(5.0, 50.0)), ("slide2", '["X"]', 10.0, length(5.0, 50.0))]
    lines += more_ground
    lines += ["", "[[construct]]", 'point = "B"', 'block = "crank"', 'pivot = "A"', f"length = {_num(crank)}", ""]
    lines += [*second, ""]
    lines += more_construct
    for p, o, t, l in coms:
        lines += [
            "[[construct]]",
            f'point = "{p}"',
            'block = "attached"',
            f'origin = "{o}"',
            f'toward = "{t}"',
            "angle = 0.0",
            f"length = {_num(max(l, 0.0))}",
            "",
        ]
    bars = [crank, coms[1][3] * 2, coms[2][3] * 2 if len(coms) > 2 else 10.0]  # mm
    for i, (name, pts, com, guide) in enumerate(links):
        inertia = mass[i] * 1e-3 * (bars[i] * 1e-3) ** 2 / 12 * bar[i]
        lines += (
            [
                f"[links.{name}]",
                f"points = {pts}",
                f"mass = {_num(mass[i])}",
                f"inertia = {inertia!r}",
                f'com = "{com}"',
            ]
            + ([f"guide = {guide}"] if guide else [])
            + [""]
        )
    for name, pts, bar_mm, m in more_links:
        guide = ['guide = ["H1", "H2"]'] if name == "slide2" else []
        inertia = m * 1e-3 * (bar_mm * 1e-3) ** 2 / 12
        # a point mass at the link's last point: the links' own centres need no extra blocks
        lines += [
            f"[links.{name}]",
            f"points = {pts}",
            f"mass = {_num(m)}",
            f"inertia = {inertia!r}",
            'com = "X"',
            *guide,
            "",
        ]
    lines += ["[input]", f"phi0 = {_num(phi0)}", f"speed = {_num(speed)}", "cycles = 1.0"]

    keyed = [i for i, l in enumerate(lines) if " = " in l and not l.startswith(("name", "title"))]
    mutation = draw(st.sampled_from(["none"] * 6 + ["value", "delete", "typo", "reference"]))
    if mutation == "value":
        i = draw(st.sampled_from([i for i in keyed if lines[i].split(" = ")[1][0] in "-0123456789["]))
        key = lines[i].split(" = ")[0]
        # a valid but unlike mass or inertia (a tonne, a point mass) leaves the envelope
        bad = [v for v in BAD_VALUES if key not in ("mass", "inertia") or v not in ("1e6", "1e-7", "0", "0.0")]
        lines[i] = key + " = " + draw(st.sampled_from(bad))
    elif mutation == "delete":
        del lines[draw(st.sampled_from(keyed))]
    elif mutation == "typo":
        i = draw(st.sampled_from(keyed))
        key, val = lines[i].split(" = ", 1)
        j = draw(st.integers(0, len(key) - 1))
        lines[i] = key[:j] + key[j + 1 :] + (key[j] if j == len(key) - 1 else "x") + " = " + val
    elif mutation == "reference":
        refs = [i for i in keyed if lines[i].split(" = ")[1].startswith('"') or lines[i].startswith("sign")]
        i = draw(st.sampled_from(refs))
        key = lines[i].split(" = ")[0]
        lines[i] = f"{key} = " + draw(st.sampled_from(['"Q"', '"S3"', '"C"', "0", "2", '"1"', "1.5"]))
    return f"{kind}+{extra}" if extra != "none" else kind, mutation, "\n".join(lines) + "\n"


@pytest.mark.slow
def test_random_mechanisms_fail_clearly_or_agree(tmp_path):
    stats: Counter = Counter()
    path = tmp_path / "generated mechanism.toml"

    @given(case=mechanism_text())
    @settings(
        max_examples=EXAMPLES,
        deadline=None,
        derandomize=not os.environ.get("PROPERTY_RANDOM"),
        database=None,
        suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
    )
    def one(case):
        kind, _mutation, text = case
        stats["cases"] += 1
        stats[f"kind {kind}"] += 1
        path.write_text(text)
        try:
            mech = load(registry.path_of(path))
        except MechanismFileError as e:
            msg = str(e)
            assert "\n" not in msg and str(path) in msg, msg
            stats["rejected when read: MechanismFileError"] += 1
            return
        # 'check' describes every file that reads, whatever its geometry, without crashing
        report = check.check(mech)
        text = format_report(report)
        assert all(p in text for p in mech.point_names) and text.splitlines()[-1].startswith("result: ")
        try:
            validation.validate(mech)
        except (MechanismFileError, AssemblyError) as e:
            msg = str(e)
            assert "\n" not in msg and str(path) in msg, msg
            assert report.problems and report.problems[0] == (type(e).__name__, msg)
            stats[f"rejected by validation: {type(e).__name__}"] += 1
            return
        assert report.ok
        stats["valid"] += 1
        if any("over which the agreement thresholds are verified" in n for n in report.notes):
            stats["valid outside the verified envelope"] += 1
        case = simulate.kinematic_case(mech)
        try:
            cost.enough_samples(mech, case, "cycles")
        except SimulationError as e:
            assert "\n" not in str(e) and "are needed to compare it with the reference" in str(e), str(e)
            stats["valid, refused as too short to judge"] += 1
            return
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # MuJoCo's own model warnings are not the subject here
            try:
                trace = simulate.run(mech, case)
            except SimulationError as e:
                raise AssertionError(f"a valid file failed to simulate: {e}\n{text}") from e
        a = compare.agreement(mech, trace)
        assert a.failures() == [], f"silent disagreement: {a.failures()}\n{text}"
        switched = compare.branch_switch(mech, trace)
        assert switched is None, f"{switched}\n{text}"
        stats["simulated within thresholds"] += 1
        if "+" in kind:
            stats["simulated within thresholds: shared pins and longer chains"] += 1

    (one if os.environ.get("PROPERTY_RANDOM") else seed(PROPERTY_SEED)(one))()
    summary = ", ".join(f"{k} {v}" for k, v in sorted(stats.items()))
    print(f"\nproperty test: {summary}")
    warnings.warn(
        PropertyStats(
            f"property test: {stats['cases']} generated mechanism files, {stats['valid']} "
            f"valid, {stats['simulated within thresholds']} simulated within the thresholds; "
            f"{summary}"
        ),
        stacklevel=2,
    )
    assert stats["cases"] >= min(EXAMPLES, 50)
    judged = stats["valid"] - stats["valid, refused as too short to judge"]
    assert stats["simulated within thresholds"] == judged, summary  # every valid file, none let off
    # The generator stays useful: 18 to 26 % of its files are valid (45 and 65 of 250 measured:
    # the sequence drawn also depends on what ran before it in the process); a tenth flags a
    # generator that has stopped exploring what runs.
    assert judged >= stats["cases"] // 10, summary
