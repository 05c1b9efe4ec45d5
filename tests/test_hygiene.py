"""Rules the test suite holds itself to, read from its own source: no test installs anything on
the machine it runs on (a missing tool is a skip with the command to get it, conftest.chromium);
no test waits for a time or holds a run to one (it waits on the event itself, conftest.wait_for,
with a timeout only a hung test reaches: speed is measured in bench/); no test gives a file of
the machine's (/dev/null, /proc/...) as a place to write, even one a command should refuse.
Each rule is shown to find what it is for, as a test would write it."""

from __future__ import annotations

import ast
import itertools
import re

from conftest import ROOT

# Programs that change a machine when asked to install: the first word of a command.
INSTALLERS = {"apt-get", "apt", "aptitude", "dnf", "yum", "zypper", "pacman", "apk", "brew", "snap", "sudo", "conda"}
# An installing command anywhere in a command line.
INSTALLING = re.compile(r"\b(pip3?|uv|npm|playwright|apt-get|apt|dnf|yum|brew|snap|conda)\b\s+(.*\s)?(install|add)\b")


def _commands(tree: ast.AST):
    """Every literal command in ``tree``: a list or tuple whose first item is a string (its
    string items, others as '?'), and every string given to a call that runs a shell."""
    for node in ast.walk(tree):
        if isinstance(node, ast.List | ast.Tuple) and node.elts:
            first = node.elts[0]
            words = [e.value if isinstance(e, ast.Constant) and isinstance(e.value, str) else "?" for e in node.elts]
            if isinstance(first, ast.Constant) or "pip" in words:
                yield node.lineno, words
        elif isinstance(node, ast.Call):
            name = node.func.attr if isinstance(node.func, ast.Attribute) else getattr(node.func, "id", "")
            if name in ("system", "popen", "run", "Popen", "call", "check_call", "check_output", "getoutput"):
                for a in node.args:
                    if isinstance(a, ast.Constant) and isinstance(a.value, str):
                        yield node.lineno, a.value.split()


def test_no_test_installs_anything():
    found = []
    for path in sorted((ROOT / "tests").glob("*.py")):
        for line, words in _commands(ast.parse(path.read_text(encoding="utf-8"))):
            if words and (words[0] in INSTALLERS or INSTALLING.search(" ".join(words))):
                found.append(f"{path.name}:{line}: {' '.join(words)}")
    assert found == []


def test_the_rule_finds_an_installer():
    """The check above finds the commands it is for (here, as a test would write them)."""
    # Source text to parse, never run: the four ways a test could install something.
    code = """
subprocess.run(['apt-get', 'install', '-y', 'chromium'])
subprocess.run([sys.executable, '-m', 'pip', 'install', 'x'])
os.system('sudo apt-get install chromium')
subprocess.run(['python', '-m', 'playwright', 'install', 'chromium'])
"""
    hits = [w for _, w in _commands(ast.parse(code)) if w[0] in INSTALLERS or INSTALLING.search(" ".join(w))]
    assert len(hits) == 4, hits


# ------------------------------------------------------------------------------ the clock
CLOCK = {"sleep", "monotonic", "monotonic_ns", "time", "time_ns", "perf_counter", "perf_counter_ns", "process_time"}
LEAST_TIMEOUT_S = 60  # a timeout= below this ends a slow test, not a hung one


def _clock_uses(tree: ast.AST):
    """Every use of the clock in ``tree`` (``time.sleep(...)``, ``time.monotonic()``, a name
    imported from ``time``), and every ``timeout=`` shorter than :data:`LEAST_TIMEOUT_S`
    seconds, but for the one function that waits for events (conftest.wait_for)."""
    skip: set[int] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.FunctionDef) and node.name == "wait_for":
            skip |= {id(n) for n in ast.walk(node)}
    for node in ast.walk(tree):
        if id(node) in skip:
            continue
        if isinstance(node, ast.Attribute) and node.attr in CLOCK and getattr(node.value, "id", "") == "time":
            yield node.lineno, f"time.{node.attr}"
        elif isinstance(node, ast.ImportFrom) and node.module == "time":
            yield node.lineno, "from time import " + ", ".join(a.name for a in node.names)
        elif isinstance(node, ast.keyword) and node.arg == "timeout":
            v = node.value
            if isinstance(v, ast.Constant) and isinstance(v.value, int | float) and v.value < LEAST_TIMEOUT_S:
                yield node.lineno, f"timeout={v.value}"


def test_no_test_waits_for_a_time():
    found = [
        f"{path.name}:{line}: {what}"
        for path in sorted((ROOT / "tests").glob("*.py"))
        for line, what in _clock_uses(ast.parse(path.read_text(encoding="utf-8")))
    ]
    assert found == []


def test_the_clock_rule_finds_waits_and_deadlines():
    code = """
time.sleep(3.0)
t = time.monotonic()
assert time.monotonic() - t < 30
from time import perf_counter
_until(pidfile.exists, timeout=30)
p.communicate(timeout=5)
def wait_for(event, what, timeout=HUNG_S):
    time.sleep(0.02)
"""
    assert [w for _, w in sorted(_clock_uses(ast.parse(code)))] == [
        "time.sleep",
        "time.monotonic",
        "time.monotonic",
        "from time import perf_counter",
        "timeout=30",
        "timeout=5",
    ]


# ------------------------------------------------------------------------------ the machine's files
SYSTEM = re.compile(r"^/(dev|proc|sys|etc|usr|var|boot|lib|bin|sbin|root|run)(/|$)")
OUTPUT_OPTIONS = {"-o", "--out", "--output", "--dxf", "--points", "--write"}
# Calls that write to, make or replace the path they are given.
WRITERS = {
    "atomic_path",
    "write_text",
    "write_bytes",
    "write_csv",
    "staged_dir",
    "check_destination",
    "run",
    "simulate",
    "loads",
    "steady",
    "mkdir",
    "makedirs",
    "replace",
    "rename",
    "symlink_to",
    "mkfifo",
}


def _system_outputs(tree: ast.AST):
    """Every path of the machine's (:data:`SYSTEM`) given as an output: after an output option
    in a command's words (a list, a tuple or a call's arguments), or to a call that writes
    (:data:`WRITERS`)."""

    def system(node: ast.AST) -> bool:
        return isinstance(node, ast.Constant) and isinstance(node.value, str) and bool(SYSTEM.match(node.value))

    for node in ast.walk(tree):
        items: list[ast.AST] = []
        if isinstance(node, ast.List | ast.Tuple):
            items = list(node.elts)
        elif isinstance(node, ast.Call):
            items = list(node.args)
            name = node.func.attr if isinstance(node.func, ast.Attribute) else getattr(node.func, "id", "")
            if name in WRITERS:
                yield from (
                    (node.lineno, a.value) for a in [*node.args, *(k.value for k in node.keywords)] if system(a)
                )
        for before, item in itertools.pairwise(items):
            if isinstance(before, ast.Constant) and before.value in OUTPUT_OPTIONS and system(item):
                yield node.lineno, f"{before.value} {item.value}"  # type: ignore[attr-defined]


def test_no_test_writes_to_the_machines_files():
    found = [
        f"{path.name}:{line}: {what}"
        for path in sorted((ROOT / "tests").glob("*.py"))
        for line, what in _system_outputs(ast.parse(path.read_text(encoding="utf-8")))
    ]
    assert found == []


def test_the_files_rule_finds_system_outputs():
    code = """
main(["build", str(EXAMPLE_PATH), "-o", "/dev/null"])
files.atomic_path("/dev/null")
pipeline.run(mech, "/proc/mjlink-test", FAST)
cases = [(["--out", "/dev/null"], "/dev/null is a character device, not a folder")]
validation.get(Path("/dev/null"))
os.listdir("/proc")
"""
    assert sorted(w for _, w in _system_outputs(ast.parse(code))) == [
        "--out /dev/null",
        "-o /dev/null",
        "/dev/null",
        "/proc/mjlink-test",
    ]
