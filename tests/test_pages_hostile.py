"""Text from a mechanism file can neither break nor script a page: a corpus of hostile strings
in every string a file holds, each page opened in a real headless Chromium (skipped without it:
conftest.chromium).

The strings a file holds: names (the mechanism's, its points', its links', its makers'), which
the reader refuses unless they are plain identifiers; the title, ``[mechanism] source`` and a
maker's ``source`` in a head's ``[timing]``, one line of printable text of at most 200
characters (mechanisms/README.md). Each corpus string goes into every field that takes it: the take-up's title and source (a page each) and the source of one more maker's
settings in the head (all strings on one page). The drag-to-design page and the run's page must
start and finish their script, show the text as written and run none of it, and "Save as TOML"
must write a file that reads back as the same data and that ``check`` passes.
"""

from __future__ import annotations

import json
import re
import tomllib
import types

import pytest
from conftest import HUNG_S, chromium, in_process
from playwright.sync_api import sync_playwright

from mjlink.analysis import summary
from mjlink.errors import MechanismFileError
from mjlink.model import catalogue, mechanism
from mjlink.pages import design as design_page
from mjlink.pages import index as index_page

PWN = "window.__pwned=1"
CORPUS = {
    "script end": f"</script><script>{PWN}</script>",
    "comment and script": "<!--<script>",
    "comment end": f"<script>{PWN}</script>-->",
    "cdata end": "]]>",
    "event handler": f'<img src=x onerror="{PWN}"><svg onload={PWN}>',
    "upper-case end": f"</SCRIPT ><script >{PWN}</script >",
    "quotes and entities": "\"';&amp;&lt;&#60;\\",
    "templates": f"{{{{title}}}} ${{{PWN}}} `x` %s {{0}}",
    "line separators": "a\u2028b\u2029c",
    "delete": "a\x7fb",
    "control characters": "\x00\x01\x08\x0b\x0c\x0e\x1b[31m\x1f",
    "tab and new lines": "tab\there\nnew line\r\nend",
    "bidi overrides": "\u202eevil\u202c \u200f\u2066x\u2069",
    "beyond the BMP": "\U0001f9f5 Nähfaden – ½ 縫",
    "long title": "<" * 200,
    "too long a title": "<" * 201,
    "very long": "</script>" * 2000,
}


def _toml_string(s: str) -> str:
    """``s`` as a TOML basic string (toml.io: a quote, a backslash and every control character
    but the tab escaped)."""
    body = "".join(
        "\\" + c if c in '"\\' else f"\\u{ord(c):04X}" if (ord(c) < 0x20 and c != "\t") or ord(c) == 0x7F else c
        for c in s
    )
    return f'"{body}"'


def _set_line(text: str, key: str, value: str, nth: int) -> str:
    """``text`` with the ``nth`` (0-based) line ``key = "..."`` holding ``value`` instead."""
    lines = list(re.finditer(rf'^{key} = ".*"$', text, re.M))
    line = lines[nth]
    return text[: line.start()] + f"{key} = {_toml_string(value)}" + text[line.end() :]


def _a_title(s: str) -> bool:
    """Whether the reader takes ``s`` as a title or a source (mechanisms/README.md: one line,
    at most 200 characters; the reader: printable text)."""
    return s.isprintable() and len(s) <= 200


@pytest.fixture(scope="module")
def tab(tmp_path_factory):
    """One browser tab for the module's pages, opened in turn, and the page errors and requests
    beyond the file (none may happen) as they come."""
    exe = chromium()
    with sync_playwright() as pw:
        b = pw.chromium.launch(
            executable_path=exe, args=["--no-sandbox", "--disable-gpu"], downloads_path=tmp_path_factory.mktemp("saved")
        )
        page = b.new_page(viewport={"width": 1280, "height": 800})
        errors: list[str] = []
        page.on("pageerror", lambda e: errors.append(str(e)))
        page.on(
            "request",
            lambda r: errors.append(f"network: {r.url}") if not r.url.startswith(("file:", "blob:", "data:")) else None,
        )
        yield page, errors
        b.close()


def _open(tab, html, ready):
    """``html`` parsed and run in ``tab`` (as the browser reads a file: the pages use nothing
    beside them here) until ``ready`` (a selector) holds."""
    page, errors = tab
    errors.clear()
    page.set_content(html)
    page.wait_for_selector(ready, timeout=HUNG_S * 1000)  # ms
    return page, errors


def _nothing_injected(page, scripts: int) -> None:
    assert page.evaluate("typeof window.__pwned") == "undefined"
    assert page.evaluate("document.scripts.length") == scripts
    assert page.evaluate("document.images.length") == 0
    handlers = "[...document.querySelectorAll('*')].filter(e => [...e.attributes].some(a => a.name.startsWith('on')))"
    assert page.evaluate(f"{handlers}.length") == 0


def _design_page_runs(tab, mech, text, tmp_path) -> str:
    """design.html of ``mech`` (read from ``text``) opened: its script ran to the end (the
    drawing, every number, the status), the title shows as written, nothing was injected;
    returns what "Save as TOML" wrote, which is ``text``."""
    page, errors = _open(tab, design_page.design_html(mech, text), "body[data-ready=true]")
    _nothing_injected(page, scripts=2)
    assert page.text_content("p.sub").startswith(f"{mech.title}. Drag")
    assert page.eval_on_selector_all("#drawing line", "els => els.length") > 0
    numbers = page.eval_on_selector_all("[data-metric]", "els => els.map(e => e.textContent)")
    assert numbers and all(n not in ("", "–") for n in numbers), numbers
    assert page.get_attribute("#status", "class") == "ok"
    with page.expect_download():
        page.click("#save")
    saved = page.input_value("#toml")
    assert saved == text  # nothing edited: the file as read, byte for byte
    assert errors == []
    return saved


HEAD = catalogue.path_of("lockstitch_head").read_text(encoding="utf-8")
TAKEUP = catalogue.path_of("takeup").read_text(encoding="utf-8")


@pytest.fixture(scope="module")
def takeup_summary():
    """The take-up's design at a glance, which its title and source do not change."""
    return summary.summarize(mechanism.parse(TAKEUP))


@pytest.mark.parametrize("s", CORPUS.values(), ids=CORPUS.keys())
def test_a_name_holding_hostile_text_is_refused_by_the_reader(s):
    """No name reaches a page unless it is a plain identifier: the mechanism's, a point's, a
    link's and a maker's name holding the string are refused, and the title and the source
    where they are not one line of printable text of at most 200 characters."""
    renamed = [
        _set_line(HEAD, "name", s, 0),
        HEAD.replace("P4 = [", f"{_toml_string(s)} = [", 1),
        HEAD.replace("[links.rocker]", f"[links.{_toml_string(s)}]", 1),
        HEAD.replace("[timing.brother_s7000dd]", f"[timing.{_toml_string(s)}]", 1),
    ]
    assert all(t != HEAD for t in renamed)
    for t in renamed:
        with pytest.raises(MechanismFileError):
            mechanism.parse(t)
    for key in ("title", "source"):
        changed = _set_line(HEAD, key, s, 0)
        if _a_title(s):
            assert getattr(mechanism.parse(changed), key) == s
        else:
            with pytest.raises(MechanismFileError):
                mechanism.parse(changed)


def test_the_embedded_data_holds_no_markup():
    """The data design.html embeds in its script element reads back as it was, and holds no
    character that could end the element, open a comment or tag in it, or end a line of script."""
    data = {"title": list(CORPUS.values()), **{s: len(s) for s in CORPUS.values()}}
    text = design_page.script_json(data)
    assert not set(text) & set("<>&\u2028\u2029") and text.isascii()
    assert json.loads(text) == data
    script = design_page._script().lower()  # the page's own script, inlined beside it
    assert "</script" not in script and "<!--" not in script


TITLES = {k: s for k, s in CORPUS.items() if _a_title(s)}


def test_the_files_mjlink_writes_hold_any_text_as_written():
    """The Python writer of mechanism files (winner files, ``synth --write``, a study's variants)
    writes every corpus string, as a value, a key and a header line, so that TOML reads it back
    as written."""
    from mjlink.model import tomlio

    data = {
        "mechanism": {"title": list(CORPUS.values()), **{s: s for s in CORPUS.values()}},
        "construct": [{"source": s} for s in CORPUS.values()],
        "timing": {s: {"source": s} for s in CORPUS.values()},
    }
    text = tomlio.dumps(data, "\n".join(CORPUS.values()))
    assert tomllib.loads(text) == data


@pytest.mark.slow
@pytest.mark.parametrize("s", TITLES.values(), ids=TITLES.keys())
def test_a_title_and_source_of_hostile_text_are_shown_as_written(tab, takeup_summary, tmp_path, s):
    """The take-up with the string as its title and source: its design page starts, shows the
    title as written and saves the same data; its run's page finishes its script and shows the
    title, the source and a failure holding the string as written; nothing runs or is added."""
    text = _set_line(_set_line(TAKEUP, "title", s, 0), "source", s, 0)
    mech = mechanism.parse(text, tmp_path / "takeup.toml")
    assert (mech.title, mech.source) == (s, s)
    _design_page_runs(tab, mech, text, tmp_path)
    result = types.SimpleNamespace(
        mechanism=mech.name,
        title=mech.title,
        source=mech.source,
        mujoco_version="3",
        agreements=(),
        failures=(s,),
        design=takeup_summary,
        timing=None,
    )
    page, errors = _open(tab, index_page.index_html(result, ["design.html"]), "body[data-images='0/0']")
    _nothing_injected(page, scripts=1)
    assert page.text_content("h1") == mech.name
    assert page.text_content("h1 + p.sub") == s
    assert page.text_content("#agreement p.sub") == f"MuJoCo 3; mechanism file {s}"
    assert page.eval_on_selector_all("ul li", "els => els.map(e => e.textContent)") == [s]
    assert errors == []


@pytest.mark.slow
def test_every_hostile_text_in_a_head_is_carried_and_saved_as_written(tab, tmp_path):
    """The head with one more maker's settings per corpus string the reader takes as a source
    (one line of printable text; the others are refused there), and a hostile title: its
    design page starts and shows the title as written; "Save as TOML" writes every string as
    written (TOML escapes), and ``check`` passes the saved file as it does the original."""
    windows = "hook_rise = [1.8, 2.2]\nhook_above_eye = [1.2, 1.6]\n"
    text = _set_line(HEAD, "title", CORPUS["comment and script"], 0)
    for s in CORPUS.values():
        if not _a_title(s):
            with pytest.raises(
                MechanismFileError,
                match=r"\[timing.odd\] source: must be (one line of printable text|at most 200 characters)",
            ):
                mechanism.parse(f"{text}\n[timing.odd]\nsource = {_toml_string(s)}\n{windows}")
    text += "".join(
        f"\n[timing.hostile{i}]\nsource = {_toml_string(s)}\n{windows}" for i, s in enumerate(TITLES.values())
    )
    file = tmp_path / "lockstitch_head.toml"
    file.write_text(text, encoding="utf-8")
    mech = mechanism.parse(text, file)
    own = len(mechanism.parse(HEAD).timing.settings)  # the head's own tables come first
    assert [m.source for m in mech.timing.settings][own:] == list(TITLES.values())
    saved = _design_page_runs(tab, mech, text, tmp_path)
    (tmp_path / "saved.toml").write_text(saved, encoding="utf-8")
    r = in_process("check", str(tmp_path / "saved.toml"))
    assert r.returncode == 0, r.stdout + r.stderr
