"""Drag-to-design (design.html) driven in a real headless Chromium through Playwright: the
browser's port of the closed-form kinematics against the Python reference on every shipped
mechanism and on random variants, the page's contract (every dimension an input with its study
path, every number an element with its metric's name and value), editing and dragging, the
page's verdict on a design as ``check``'s (the reader's rules on every number, the geometry on
random and edge variants), and the saved file accepted by ``check``. Without Chromium the tests
are skipped (conftest.chromium)."""

from __future__ import annotations

import math
import re
import tomllib

import numpy as np
import pytest
from conftest import HUNG_S, chromium, in_process
from playwright.sync_api import sync_playwright

from mjlink import reference, study, validation
from mjlink.analysis import summary
from mjlink.errors import MechanismFileError
from mjlink.model import catalogue, mechanism, paths
from mjlink.pages import design as design_page

NAMES = ["takeup", "crank_slider", "takeup_eyelets", "warp_knitting", "lockstitch_head"]
pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def browser(tmp_path_factory):
    exe = chromium()
    with sync_playwright() as pw:
        b = pw.chromium.launch(
            executable_path=exe, args=["--no-sandbox", "--disable-gpu"], downloads_path=tmp_path_factory.mktemp("saved")
        )
        yield b
        b.close()


@pytest.fixture(scope="module")
def pristine(browser, tmp_path_factory):
    """One unedited page per mechanism, opened once for the tests that only read it (they
    evaluate the port's pure functions and read the DOM; the tests that edit open their own)."""
    pages: dict = {}

    def get(name):
        if name not in pages:
            pages[name] = _open(browser, name, tmp_path_factory.mktemp(name))
        return pages[name]

    yield get
    for page, _ in pages.values():
        page.close()


def _open(browser, name, tmp_path):
    path = catalogue.path_of(name)
    page_file = tmp_path / f"{name}-design.html"
    page_file.write_text(design_page.design_html(mechanism.load(path), path.read_text()))
    page = browser.new_page(viewport={"width": 1280, "height": 800})
    errors: list[str] = []
    page.on("pageerror", lambda e: errors.append(str(e)))
    page.on(
        "request",
        lambda r: errors.append(f"network: {r.url}") if not r.url.startswith(("file:", "blob:", "data:")) else None,
    )
    page.goto(page_file.as_uri())
    page.wait_for_selector("body[data-ready=true]", timeout=HUNG_S * 1000)  # ms
    return page, errors


def _drag(page, pivot: str, dx: float, dy: float, steps: int) -> None:
    """The ground pivot ``pivot`` dragged by the mouse ``dx``, ``dy`` pixels from its centre."""
    box = page.locator(f"circle[data-pivot='{pivot}']").bounding_box()
    x, y = box["x"] + box["width"] / 2, box["y"] + box["height"] / 2
    page.mouse.move(x, y)
    page.mouse.down()
    page.mouse.move(x + dx, y + dy, steps=steps)
    page.mouse.up()


def _port_errors(page, mechs) -> list[float]:
    """For each mechanism, the largest |browser - reference| over 24 angles and every point,
    relative to its extent (the browser solves them all in one call)."""
    cases = []
    for mech in mechs:
        phis = list(math.degrees(mech.phi0) + np.linspace(0.0, math.degrees(mech.period), 25)[:-1])
        cases.append([design_page.model(mech), phis])
    solved = page.evaluate("(cases) => cases.map(([m, phis]) => phis.map(p => mjlinkDesign.solve(m, p).P))", cases)
    out = []
    for mech, (_, phis), got in zip(mechs, cases, solved, strict=True):
        kin = reference.solve(mech, np.radians(phis))
        ref = {p: kin.position(p) * 1e3 for p in mech.point_names}
        extent = max(float(np.ptp(np.concatenate([v[:, :2] for v in ref.values()]), axis=0).max()), 1.0)
        out.append(max(abs(g[p][k] - ref[p][i, k]) for i, g in enumerate(got) for p in ref for k in range(3)) / extent)
    return out


@pytest.mark.parametrize("name", NAMES)
def test_the_browser_port_is_the_reference_on_the_design_and_random_variants(pristine, name):
    page, errors = pristine(name)
    mech = mechanism.load(catalogue.path_of(name))
    # Random variants: every dimension moved by up to 2 % (or 0.5 mm / 2 deg), those that
    # assemble over the cycle compared the same way as the design.
    rng = np.random.default_rng(7)
    dims = [(p, v, u) for p, v, u in summary.dimensions(mech) if p != "input.phi0"]
    drawn = [
        [v + rng.uniform(-1, 1) * max(0.02 * abs(v), 0.5 if u == "mm" else 2.0) for p, v, u in dims] for _ in range(12)
    ]
    values = {p: [row[j] for row in drawn] for j, (p, _, _) in enumerate(dims)}
    feasible = study.evaluate(mech, values, [{"kind": "transmission_min"}]).feasible
    variants = [
        study.override(mech, {p: x for (p, _, _), x in zip(dims, row)}) for row, ok in zip(drawn, feasible) if ok
    ]
    assert len(variants) >= 3, "too few random variants assembled to compare"
    errs = _port_errors(page, [mech, *variants])
    assert max(errs) < 1e-9, errs
    assert errors == []


@pytest.mark.parametrize("name", NAMES)
def test_every_dimension_is_an_input_and_every_number_the_study_metric(pristine, name):
    page, errors = pristine(name)
    mech = mechanism.load(catalogue.path_of(name))
    params = page.eval_on_selector_all("input[data-param]", "els => els.map(e => [e.dataset.param, Number(e.value)])")
    assert [p for p, _ in params] == [p for p, _, _ in summary.dimensions(mech)]
    for (p, v), (_, nominal, _) in zip(params, summary.dimensions(mech), strict=True):
        assert v == pytest.approx(nominal, rel=1e-9, abs=1e-12), p
    shown = dict(page.eval_on_selector_all("[data-metric]", "els => els.map(e => [e.dataset.metric, e.dataset.value])"))
    want = {r.metric: r.value for r in summary.design_summary(mech)}
    assert shown and set(shown) <= set(want)
    for metric, value in shown.items():
        assert float(value) == pytest.approx(want[metric], rel=1e-6, abs=1e-6), metric
    assert "assembles over the whole cycle" in page.inner_text("#status")
    assert errors == []


def test_editing_a_length_updates_the_numbers_to_the_variants_own(browser, tmp_path):
    page, _ = _open(browser, "takeup", tmp_path)
    mech = mechanism.load(catalogue.path_of("takeup"))
    before = int(page.get_attribute("body", "data-updates"))
    page.fill("input[data-param='construct.P2.length']", "29.6")
    page.wait_for_function(f"Number(document.body.dataset.updates) > {before}")
    variant = study.override(mech, {"construct.P2.length": 29.6})
    want = {r.metric: r.value for r in summary.design_summary(variant)}
    for metric in ("stroke_P5", "thread_feed", "transmission_min"):
        got = float(page.get_attribute(f"[data-metric='{metric}']", "data-value"))
        assert got == pytest.approx(want[metric], rel=1e-6), metric


def test_dragging_a_pivot_moves_it_and_its_numbers(browser, tmp_path):
    """The thread guide N2 dragged right and up: its coordinates follow in their fields and the
    thread feed is the variant's own."""
    page, _ = _open(browser, "takeup", tmp_path)
    mech = mechanism.load(catalogue.path_of("takeup"))
    _drag(page, "N2", 12, -9, steps=4)
    px = float(page.input_value("input[data-param='ground.N2.x']"))
    py = float(page.input_value("input[data-param='ground.N2.y']"))
    assert px > 30.0 and py > 85.0  # right and up on the page: +x and +y of the mechanism
    want = {
        r.metric: r.value for r in summary.design_summary(study.override(mech, {"ground.N2.x": px, "ground.N2.y": py}))
    }
    got = float(page.get_attribute("[data-metric='thread_feed']", "data-value"))
    assert got == pytest.approx(want["thread_feed"], rel=1e-5)  # the fields show 6 digits of the dragged point


def test_a_geometry_that_does_not_close_is_said_so_and_not_drawn(browser, tmp_path):
    """An infeasible design is said so with check's reason and its input angles within one
    period; the page then draws the last feasible design greyed (no link of the design that
    does not close) and shows its numbers marked stale, with no number given as the edited
    design's; a feasible edit brings colour and numbers back."""
    page, _ = _open(browser, "takeup", tmp_path)
    nominal = page.inner_text("[data-metric='stroke_P5']")
    page.fill("input[data-param='construct.P3.length_a']", "5")
    page.wait_for_function("document.getElementById('status').className === 'bad'")
    status = page.inner_text("#status")
    assert "infeasible: dyad P2-P3-P4 cannot close for input angles" in status and " deg" in status
    assert "the last feasible design" in page.inner_text("#stale-note")
    angles = [float(a) for a in re.findall(r"(-?[0-9.]+)\.\.(-?[0-9.]+)", status)[0]]
    assert all(0.0 <= a < 360.0 for a in angles), status
    assert page.eval_on_selector_all("#drawing > g > line", "els => els.length") == 0  # none in colour
    assert page.eval_on_selector_all("#drawing g.stale line", "els => els.length") > 0  # the last, greyed
    cell = "[data-metric='stroke_P5']"
    assert page.get_attribute(cell, "data-feasible") == "false"
    assert page.get_attribute(cell, "data-value") == ""
    assert page.inner_text(cell) == nominal and "stale" in page.get_attribute(cell, "class")
    assert "last feasible" in page.inner_text("#angle-value")
    # A crank 0.4 mm longer takes the dyad past its dead-point limit, as `check` and the
    # study metrics say (transmission angle beyond 160 deg near 90 deg from phi0).
    assert not study.evaluate(
        mechanism.load(catalogue.path_of("takeup")), {"construct.P2.length": [30.4]}, []
    ).feasible[0]
    page.fill("input[data-param='construct.P3.length_a']", "22")
    page.fill("input[data-param='construct.P2.length']", "30.4")
    page.wait_for_function("document.getElementById('status').textContent.includes('dead-point')")
    assert "dyad P2-P3-P4 passes its dead-point limit for input angles" in page.inner_text("#status")
    page.fill("input[data-param='construct.P2.length']", "30")
    page.wait_for_function("document.getElementById('status').className === 'ok'")
    assert page.eval_on_selector_all("#drawing g.stale", "els => els.length") == 0
    assert page.get_attribute(cell, "data-value") != "" and "stale" not in page.get_attribute(cell, "class")


def test_the_saved_file_is_accepted_by_check_with_the_edits(browser, tmp_path):
    """ "Save as TOML" writes the file as read with the changed numbers in their places: every
    comment, the order of the blocks and every other line kept, a dragged pivot's coordinates
    to 0.001 mm, no table added; ``check`` accepts it with the edits and the rest as it was."""
    page, _ = _open(browser, "lockstitch_head", tmp_path)
    page.fill("input[data-param='construct.P5.length']", "48.5")
    page.fill("input[data-param='ground.N2.x']", "72")
    _drag(page, "FG", 7.3, -4.1, steps=3)
    with page.expect_download():
        page.click("#save")
    text = page.input_value("#toml")
    original_text = catalogue.path_of("lockstitch_head").read_text(encoding="utf-8")
    new, old = text.splitlines(), original_text.splitlines()
    assert len(new) == len(old)
    changed = [(a, b) for a, b in zip(new, old, strict=True) if a != b]
    assert [b.split("=")[0].strip() for _, b in changed] == ["N2", "FG", "length"], changed
    for a, b in changed:  # the value changed, the comment after it kept
        assert a.split("#")[1:] == b.split("#")[1:], (a, b)
    fg = tomllib.loads(text)["ground"]["FG"]
    assert all(round(v, 3) == v for v in fg) and fg != tomllib.loads(original_text)["ground"]["FG"]
    saved = tmp_path / "edited_head.toml"
    saved.write_text(text.replace('name = "lockstitch_head"', 'name = "edited_head"'))
    r = in_process("check", str(saved))
    assert r.returncode == 0, r.stdout + r.stderr
    edited = validation.get(str(saved))
    original = mechanism.load(catalogue.path_of("lockstitch_head"))

    assert paths.resolve(edited, "construct.P5.length").nominal == 48.5
    assert paths.resolve(edited, "ground.N2.x").nominal == 72.0
    moved = ("construct.P5.length", "ground.N2.x", "ground.FG.x", "ground.FG.y")
    for p in [p for p, _, _ in summary.dimensions(original) if p not in moved]:
        assert paths.resolve(edited, p).nominal == pytest.approx(
            paths.resolve(original, p).nominal, rel=1e-12, abs=1e-12
        )
    assert edited.timing is not None and edited.balance is not None  # the rest of the file kept


def test_a_file_saved_unedited_is_the_file(pristine, name="takeup_eyelets"):
    """With nothing changed, or a number typed back to its value, the saved file is the file
    read, byte for byte."""
    page, _ = pristine(name)
    text = catalogue.path_of(name).read_text(encoding="utf-8")
    got = page.evaluate(
        """() => { const M = JSON.parse(document.getElementById('mechanism-data').textContent);
        return [mjlinkDesign.saved(M, {}), mjlinkDesign.saved(M, {'input.phi0': M.model.phi0})]; }"""
    )
    assert got == [text, text]


# A design edited in the page (each variant: study path -> value, file units): the page's
# verdict (`problems`, [] where it passes) and the file "Save as TOML" writes for it.
_JUDGE = """(variants) => {
  const M = JSON.parse(document.getElementById('mechanism-data').textContent);
  return variants.map((edits) => {
    const m = JSON.parse(JSON.stringify(M.model));
    for (const [p, v] of Object.entries(edits)) mjlinkDesign.set(m, p, v);
    return [mjlinkDesign.problems(m), mjlinkDesign.saved(M, edits)];
  });
}"""

# Edits `check` refuses, one of each kind of problem the page can make (mechanisms/README.md,
# Limits and Dead points): a length not positive or below 0.1 mm, a number beyond its largest
# magnitude (1000 mm, 720 deg), a dyad or slider that cannot close, a dead point, guide points
# meeting, the plunger's point crossing the guide point it is attached toward (the direction
# undefined there, then the plunger turning on its guide), two points of a link closer than
# 0.001 mm; and edits at the limits it accepts (a
# coordinate of 1000 mm, an angle of 720 deg, an attached point on its origin, two frame pivots
# on one axis).
EDGES = {
    "takeup": [
        {"construct.P2.length": -30.0},
        {"construct.P2.length": 0.0},
        {"construct.P2.length": 0.05},
        {"construct.P3.length_b": 1e-9},
        {"construct.P3.length_a": 1001.0},
        {"construct.P5.length": -1.0},
        {"construct.P5.length": 0.0005},
        {"construct.P5.angle": 721.0},
        {"ground.P4.x": 1000.5},
        {"input.phi0": -720.5},
        {"construct.P3.length_a": 5.0},
        {"construct.P2.length": 30.4},
        {"construct.P5.length": 0.0},
        {"ground.N1.x": 1000.0},
        {"ground.N1.y": -1000.0},
        {"input.phi0": 720.0},
        {"ground.P4.x": 0.0, "ground.P4.y": 0.0},
    ],
    "crank_slider": [
        {"construct.C.length": -62.0},
        {"construct.B.length": 0.0},
        {"construct.B.length": 40.0},
        {"construct.C.length": 25.0},
        {"ground.G2.x": 0.0, "ground.G2.y": -15.0},
        {"ground.G2.x": 0.0005, "ground.G2.y": -15.0},
        {"ground.G2.x": 0.002, "ground.G2.y": -15.0},
    ],
    "takeup_eyelets": [
        {"construct.P6.z": 1000.5},
        {"construct.P7.length": 0.0008, "construct.P7.z": 0.0},
        {"construct.P7.length": 0.0008},
        {"ground.N1.z": -1000.0},
    ],
    "warp_knitting": [
        {"construct.P8.length": -5.0},
        {"construct.P8.phase": 720.1},
        {"construct.P6.length": 0.0},
        {"construct.P9.length": 180.0},
        {"construct.P9.length": 190.0},
    ],
    "lockstitch_head": [
        {"construct.P2.length": 0.0004},
        {"construct.HP.phase": 800.0},
        {"construct.B.phase": -720.0},
        {"ground.GN2.x": 0.0, "ground.GN2.y": -30.0},
        {"construct.NT.length": 0.0009},
        {"construct.NT.length": 0.0},
    ],
}


@pytest.mark.parametrize("name", NAMES)
def test_the_page_refuses_a_design_exactly_where_check_does(pristine, name, tmp_path):
    """The page's verdict on edge variants (EDGES) and on random ones (three dimensions moved by
    up to 10 % or 3 mm / 3 deg) is ``check``'s on the file the page saves for them: refused
    with a reason where check refuses it, feasible where check passes it."""
    page, errors = pristine(name)
    mech = mechanism.load(catalogue.path_of(name))
    dims = summary.dimensions(mech)
    rng = np.random.default_rng(11)
    drawn = []
    for _ in range(6):
        picked = rng.choice(len(dims), size=3, replace=False)
        drawn.append({dims[j][0]: dims[j][1] + rng.uniform(-1, 1) * max(0.1 * abs(dims[j][1]), 3.0) for j in picked})
    variants = [{}, *EDGES[name], *drawn]
    verdicts = {}
    for edits, (problems, text) in zip(variants, page.evaluate(_JUDGE, variants), strict=True):
        try:
            report = validation.check(mechanism.parse(text, tmp_path / f"{name}.toml"))
            ok, why = report.ok, report.problems
        except MechanismFileError as e:  # the reader refuses it: check reads no further
            ok, why = False, str(e)
        assert (problems == []) == ok, (edits, problems, why)
        assert all(p.strip() for p in problems)
        verdicts[ok] = verdicts.get(ok, 0) + 1
    assert verdicts.get(True, 0) >= 2 and verdicts.get(False, 0) >= 2, verdicts  # both sides tried
    assert errors == []


# Values tried on one number of each rule: beyond and at the documented limits (0.1 mm, 1000 mm,
# 720 deg), zero and negative (mechanisms/README.md, Limits).
PROBES = [-1e4, -1000.5, -1000.0, -720.5, -720.0, -30.0, -0.05, 0.0, 0.05, 0.1, 30.0, 720.0, 720.5, 1000.0, 1000.5]


def test_every_rule_the_page_holds_a_number_to_is_the_readers(pristine):
    """Every kind of number the page edits (a ground coordinate, the input's phi0, each block
    type's numbers), at every probe: the page refuses the value exactly where the mechanism
    file's reader refuses it (written into the file, read again)."""
    page, errors = pristine("lockstitch_head")
    tried = set()
    for name in NAMES:
        mech = mechanism.load(catalogue.path_of(name))
        kinds = {s.point: s.kind for s in mech.steps}
        cases = []
        for p, _, _ in summary.dimensions(mech):
            section, point, key = [*p.split("."), ""][:3]
            kind = (section, kinds.get(point, ""), key if section == "construct" else "")
            if kind in tried:
                continue
            tried.add(kind)
            cases += [(p, v) for v in PROBES]
        model = design_page.model(mech)
        refused = page.evaluate(
            """([m, cases]) => cases.map(([p, v]) => {
                 const c = JSON.parse(JSON.stringify(m)); mjlinkDesign.set(c, p, v); return mjlinkDesign.refused(c);
               })""",
            [model, cases],
        )
        for (p, v), lines in zip(cases, refused, strict=True):
            try:
                paths.check_values(mech, {paths.resolve(mech, p): v})
                reader = True
            except MechanismFileError:
                reader = False
            assert (lines == []) == reader, (name, p, v, lines)
    assert {("construct", "crank", "phase"), ("construct", "attached", "z"), ("construct", "slider", "length")} <= tried
    assert errors == []


def test_a_number_check_refuses_is_infeasible_on_the_page(browser, tmp_path):
    """A negative crank length assembles in the formulas, but the file's reader refuses it:
    the page says so, shows no number as the design's (the last feasible one's, marked stale),
    and says feasible again once the length is back."""
    page, errors = _open(browser, "takeup", tmp_path)
    page.fill("input[data-param='construct.P2.length']", "-30")
    page.wait_for_function("document.getElementById('status').className === 'bad'")
    assert page.inner_text("#status") == "infeasible: construct.P2.length must be > 0, got -30 mm"
    assert page.get_attribute("[data-metric='stroke_P5']", "data-feasible") == "false"
    assert page.get_attribute("[data-metric='stroke_P5']", "data-value") == ""
    assert "stale" in page.get_attribute("[data-metric='stroke_P5']", "class")
    page.fill("input[data-param='construct.P2.length']", "30")
    page.wait_for_function("document.getElementById('status').className === 'ok'")
    assert "assembles over the whole cycle" in page.inner_text("#status")
    assert errors == []


def test_a_file_with_text_beyond_the_basic_plane_is_edited_in_place(browser, tmp_path):
    """Offsets in the file are the page's (UTF-16: a character beyond the basic plane is two
    units): with such characters before the numbers, an edited number still lands in its place
    and every other character of the file is kept."""
    text = catalogue.path_of("takeup").read_text(encoding="utf-8")
    text = "# \U0001f9f5\U0001f9f5 thread \u2028 take-up\n" + text.replace("[input]", "[input]  # \U0001f600 phi0", 1)
    path = tmp_path / "takeup.toml"
    path.write_text(text, encoding="utf-8")
    page_file = tmp_path / "design.html"
    page_file.write_text(design_page.design_html(mechanism.parse(text, path), text), encoding="utf-8")
    page = browser.new_page()
    page.goto(page_file.as_uri())
    page.wait_for_selector("body[data-ready=true]", timeout=HUNG_S * 1000)
    page.fill("input[data-param='input.phi0']", "95.5")
    page.fill("input[data-param='construct.P3.length_b']", "19.25")
    page.wait_for_function("document.body.dataset.updates >= 3")
    with page.expect_download():
        page.click("#save")
    saved = page.input_value("#toml")
    page.close()
    want = text.replace("phi0 = 101.0", "phi0 = 95.5", 1).replace("length_b = 19.0", "length_b = 19.25", 1)
    assert saved == want
    edited = mechanism.parse(saved, path)
    assert paths.resolve(edited, "input.phi0").nominal == 95.5
    assert paths.resolve(edited, "construct.P3.length_b").nominal == 19.25


@pytest.mark.parametrize(
    ("name", "edits"), [("takeup", {"construct.P3.length_a": 5.0}), ("crank_slider", {"construct.C.length": 25.0})]
)
def test_the_page_names_the_angles_check_names(pristine, name, edits, tmp_path):
    """A block that cannot close: the page's reason is check's, word for word, its input angles
    within one period from 0 in order (the take-up starts at phi0 = 101 deg: its range runs on
    through 101 deg as one)."""
    page, _ = pristine(name)
    problems, text = page.evaluate(_JUDGE, [edits])[0]
    report = validation.check(mechanism.parse(text, tmp_path / f"{name}.toml"))
    said = [p for p in problems if "cannot close" in p]
    told = " ".join(str(p) for problem in report.problems for p in problem)
    assert said and all(s in told for s in said), (said, report.problems)
    for lo, hi in re.findall(r"([0-9.]+)\.\.([0-9.]+)", said[0]):
        assert 0.0 <= float(lo) <= float(hi) <= 360.0
