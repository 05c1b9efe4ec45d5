"""Rules the test suite holds itself to, read from its own source: no test installs anything on
the machine it runs on (a missing tool is a skip with the command to get it, conftest.chromium)."""

from __future__ import annotations

import ast
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
    code = """
subprocess.run(["apt-get", "install", "-y", "chromium"])
subprocess.run([sys.executable, "-m", "pip", "install", "x"])
os.system("sudo apt-get install chromium")
subprocess.run(["python", "-m", "playwright", "install", "chromium"])
"""
    hits = [w for _, w in _commands(ast.parse(code)) if w[0] in INSTALLERS or INSTALLING.search(" ".join(w))]
    assert len(hits) == 4, hits
