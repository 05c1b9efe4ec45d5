"""Rules the tests' expected values are held to, read from the tests' own source: a test takes
its thresholds from the user guide (tests/documented.py), not from the code it checks; a
tolerance above 1e-4 says why beside it; no check confirms itself (an error the test raises,
names drawn from the program's own pattern, an assertion repeating the one before it scaled, a
name asserted after loading by that name). Each rule comes with a test that it finds what it
is for."""

from __future__ import annotations

import ast
import functools
import re

from conftest import ROOT

# The guide's names of the thresholds as the program and its reports spell them.
THRESHOLD_NAMES = (
    "position_um",
    "velocity_rel",
    "acceleration_rel",
    "loop_um",
    "thread_um",
    "omega_rel",
    "speed_rel",
    "torque_rel",
    "force_rel",
    "shaking_force_rel",
    "shaking_moment_rel",
)
# compare's constants and its table of them: the thresholds as the code under test holds them.
PROGRAM_THRESHOLD = re.compile(r"\bcompare\.(?:[A-Z][A-Z_]+\b|thresholds\(\))")
TOLERANCE = re.compile(r"\b(?:rel|abs|atol|rtol)\s*=\s*([0-9.]+(?:e-?[0-9]+)?)|<=?\s*([0-9.]+(?:e-?[0-9]+)?)\s*\*")
REASON_LINES = 6  # a tolerance's reason: a comment on its line or within this many lines above


@functools.cache
def _sources() -> dict[str, tuple[str, ast.Module]]:
    """Every test module but the rules' own (whose examples break them on purpose): its text
    and its syntax tree."""
    out = {}
    for p in sorted((ROOT / "tests").glob("*.py")):
        if p.name not in ("test_oracles.py", "test_thresholds.py"):
            text = p.read_text(encoding="utf-8")
            out[p.name] = (text, ast.parse(text))
    return out


_WALKED: dict[int, tuple[ast.AST, list[ast.AST]]] = {}


def _walk(tree: ast.AST) -> list[ast.AST]:
    """Every node of ``tree``, listed once per tree (the rules read the same trees)."""
    kept = _WALKED.get(id(tree))
    if kept is None or kept[0] is not tree:
        kept = _WALKED[id(tree)] = (tree, list(ast.walk(tree)))
    return kept[1]


def program_thresholds(text: str) -> list[int]:
    """Lines that compare with mjlink.compare's thresholds rather than the documented ones."""
    return [i for i, line in enumerate(text.splitlines(), 1) if PROGRAM_THRESHOLD.search(line)]


def literal_thresholds(tree: ast.AST) -> list[int]:
    """Lines comparing a threshold's quantity (by its name) with a bare number: a documented
    threshold copied into the test, which a changed guide leaves behind."""
    found = []
    for node in _walk(tree):
        if not isinstance(node, ast.Compare):
            continue
        sides = [node.left, *node.comparators]
        number = any(isinstance(s, ast.Constant) and isinstance(s.value, int | float) and s.value for s in sides)
        if number and any(n in ast.unparse(s) for s in sides for n in THRESHOLD_NAMES):
            found.append(node.lineno)
    return found


def unexplained_tolerances(text: str) -> list[int]:
    """Lines with a tolerance of at least 1e-4 (and below 1: not a count) and no comment on the
    line or the REASON_LINES above it."""
    lines = text.splitlines()
    found = []
    for i, line in enumerate(lines):
        for m in TOLERANCE.finditer(line):
            value = float(m.group(1) or m.group(2))
            if 1e-4 <= value < 1 and "#" not in line:
                if not any(x.strip().startswith("#") for x in lines[max(0, i - REASON_LINES) : i]):
                    found.append(i + 1)
    return found


def _is_raises(item: ast.withitem) -> bool:
    call = item.context_expr
    return isinstance(call, ast.Call) and isinstance(call.func, ast.Attribute) and call.func.attr == "raises"


def self_raised(tree: ast.AST) -> list[int]:
    """``with pytest.raises(...)`` blocks whose body is the test's own ``raise``."""
    return [
        node.lineno
        for node in _walk(tree)
        if isinstance(node, ast.With)
        and any(_is_raises(i) for i in node.items)
        and all(isinstance(s, ast.Raise) for s in node.body)
    ]


def drawn_from_the_program(tree: ast.AST) -> list[int]:
    """Hypothesis strategies drawn from a regular expression the test did not write out (the
    program's own pattern: what it accepts is then checked against itself)."""
    return [
        node.lineno
        for node in _walk(tree)
        if isinstance(node, ast.Call)
        and isinstance(node.func, ast.Attribute)
        and node.func.attr == "from_regex"
        and not (node.args and isinstance(node.args[0], ast.Constant))
    ]


def _unscaled(node: ast.expr) -> str:
    """An expression's source with multiplications by a number taken out."""

    class Strip(ast.NodeTransformer):
        def visit_BinOp(self, n: ast.BinOp) -> ast.AST:
            self.generic_visit(n)
            if isinstance(n.op, ast.Mult):
                if isinstance(n.left, ast.Constant):
                    return n.right
                if isinstance(n.right, ast.Constant):
                    return n.left
            return n

    return ast.unparse(Strip().visit(ast.parse(ast.unparse(node), mode="eval")))


def repeated_assertions(tree: ast.AST) -> list[int]:
    """Assertions that say again, scaled by a number, what an earlier one of the same test said
    (the same assertion written again is left alone: it follows something the test did)."""
    found = []
    for fn in _walk(tree):
        if not isinstance(fn, ast.FunctionDef):
            continue
        seen: dict[str, str] = {}  # unscaled -> as written (the same check again may follow a change)
        for node in ast.walk(fn):
            if isinstance(node, ast.Assert):
                written = ast.unparse(node.test)
                scaled = any(isinstance(n, ast.BinOp) and isinstance(n.op, ast.Mult) for n in ast.walk(node.test))
                key = _unscaled(node.test) if scaled else written
                if seen.get(key, written) != written:
                    found.append(node.lineno)
                seen.setdefault(key, written)
    return found


def names_asserted_after_loading(tree: ast.AST) -> list[int]:
    """``v = load("x")`` then ``assert v.name == "x"``: the name the test gave, read back."""
    found = []
    for fn in _walk(tree):
        if not isinstance(fn, ast.FunctionDef):
            continue
        nodes = list(ast.walk(fn))
        loaded: dict[str, str] = {}
        for node in nodes:
            if isinstance(node, ast.Assign) and len(node.targets) == 1 and isinstance(node.targets[0], ast.Name):
                v = node.value
                if isinstance(v, ast.Call) and len(v.args) == 1 and isinstance(v.args[0], ast.Constant):
                    loaded[node.targets[0].id] = v.args[0].value
        for node in nodes:
            if isinstance(node, ast.Compare) and isinstance(node.left, ast.Attribute) and node.left.attr == "name":
                owner, (other,) = node.left.value, node.comparators
                if isinstance(owner, ast.Name) and isinstance(other, ast.Constant):
                    if loaded.get(owner.id) == other.value:
                        found.append(node.lineno)
    return found


def _all(rule) -> list[str]:
    out = []
    for name, (text, tree) in _sources().items():
        out += [
            f"{name}:{line}" for line in rule(text if rule in (program_thresholds, unexplained_tolerances) else tree)
        ]
    return out


def test_no_test_takes_a_threshold_from_the_code_it_checks():
    assert _all(program_thresholds) == []
    assert _all(literal_thresholds) == []


def test_every_loose_tolerance_says_why():
    assert _all(unexplained_tolerances) == []


def test_no_check_confirms_itself():
    assert _all(self_raised) == []
    assert _all(drawn_from_the_program) == []
    assert _all(repeated_assertions) == []
    assert _all(names_asserted_after_loading) == []


def test_the_rules_find_what_they_are_for():
    """Each rule on code written as the tests it is for were written."""
    code = """
def test_a():
    a = compare.agreement(mech, trace)
    assert a.position_um <= compare.POSITION_UM
    assert mj["loop_gap_um"].max() <= compare.thresholds()["loop_um"]
    assert rep["agreement"]["kinematics"]["position_um"] <= 0.1
    assert np.abs(x - y).max() < 1e-3 * np.abs(y).max()
    assert run.delta == pytest.approx(0.02, rel=2e-3)
    with pytest.raises(paths.PathError, match="input crank"):
        raise paths.PathError("input crank")
    assert t.per_stitch == pytest.approx(s + th)
    assert 2 * t.per_stitch == pytest.approx(2 * (s + th))
    mech = validation.get("takeup")
    assert mech.name == "takeup"

@given(name=st.from_regex(NAME_RE.pattern, fullmatch=True))
def test_b(name):
    pass
"""
    tree = ast.parse(code)
    assert program_thresholds(code) == [4, 5]
    assert literal_thresholds(tree) == [6]
    assert unexplained_tolerances(code) == [7, 8]
    assert self_raised(tree) == [9]
    assert repeated_assertions(tree) == [12]
    assert names_asserted_after_loading(tree) == [14]
    assert drawn_from_the_program(tree) == [16]
    # What they let pass: the documented values, a stated reason, an error mjlink raises.
    fine = """
def test_c():
    assert a.position_um <= LIMIT["position_um"]
    # measured 3e-6; ten times that
    assert np.abs(x - y).max() < 3e-5 * np.abs(y).max()
    with pytest.raises(paths.PathError, match="unknown parameter path"):
        paths.resolve(cs, "construct.B.phase")
    mech = validation.get("takeup")
    assert mech.name == other.name
"""
    tree = ast.parse(fine)
    assert program_thresholds(fine) == literal_thresholds(tree) == unexplained_tolerances(fine) == []
    assert self_raised(tree) == repeated_assertions(tree) == names_asserted_after_loading(tree) == []
