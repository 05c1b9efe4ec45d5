"""Where each value of a TOML text is written, so that a file can be edited in place: its
comments, its order and the spelling of every value not changed kept (design.html's "Save as
TOML" changes the numbers a designer changed and nothing else).

The standard library reads TOML but does not say where a value stands in the text; this scanner
does. It follows the TOML 1.0 grammar for keys (bare, quoted, dotted), tables, arrays of tables,
strings (the four kinds), arrays and inline tables; any other value (a number, a boolean, a date)
is the text up to the next separator. A text the scanner cannot follow raises ValueError;
:func:`edit` checks every edit it makes against tomllib, so a span it got wrong can never write a
value to the wrong place.
"""

from __future__ import annotations

import copy
import re
import tomllib
from dataclasses import dataclass
from typing import Any

Path = tuple[str | int, ...]  # keys and array indices from the document's root


@dataclass(frozen=True, kw_only=True)
class Span:
    """A value's text ``[start, end)`` (code-point offsets); for an array, where its closing
    bracket is (``close``), how many elements it has and whether the last has a comma after it."""

    start: int
    end: int
    close: int | None = None
    count: int = 0
    trailing_comma: bool = False


@dataclass(frozen=True, kw_only=True)
class Layout:
    """Every value's span by path (an array of tables' elements by index, as tomllib's lists), and
    for every table the offset at which a new ``key = value`` line is inserted (``"\\n" + line``):
    the end of its last key's line, or of its header's."""

    values: dict[Path, Span]
    table_ends: dict[Path, int]


_BARE = re.compile(r"[A-Za-z0-9_-]+")
_DATE_TIME = re.compile(r"\d{4}-\d{2}-\d{2} \d")  # a date, a space and a time: one value


class _Scanner:
    def __init__(self, text: str) -> None:
        self.t = text
        self.i = 0
        self.values: dict[Path, Span] = {}
        self.ends: dict[Path, int] = {(): 0}
        self.arrays_of_tables: dict[Path, int] = {}

    def fail(self, what: str) -> ValueError:
        line = self.t.count("\n", 0, self.i) + 1
        return ValueError(f"line {line}: {what}")

    def peek(self, k: int = 0) -> str:
        j = self.i + k
        return self.t[j] if j < len(self.t) else ""

    def blank(self) -> None:
        while self.peek() in (" ", "\t"):
            self.i += 1

    def blank_lines(self) -> None:
        """Blanks, newlines and comments (between a table's lines and an array's elements)."""
        while True:
            c = self.peek()
            if c in (" ", "\t", "\r", "\n"):
                self.i += 1
            elif c == "#":
                self.line_rest()
            else:
                return

    def line_rest(self) -> None:
        j = self.t.find("\n", self.i)
        self.i = len(self.t) if j < 0 else j

    def end_of_line(self) -> int:
        """After a header or a value: blanks and a comment to the line's end, whose offset is
        returned (where a new line is inserted)."""
        self.blank()
        if self.peek() == "#":
            self.line_rest()
        if self.peek() not in ("\n", "\r", ""):
            raise self.fail("text after a value")
        if self.peek() == "\n" and self.t[self.i - 1] == "\r":  # a comment's CRLF: before both
            return self.i - 1
        return self.i

    def string(self) -> None:
        t, q = self.t, self.peek()
        if t.startswith(q * 3, self.i):
            self.i += 3
            while True:
                if self.i >= len(t):
                    raise self.fail("an unterminated string")
                if q == '"' and t[self.i] == "\\":
                    self.i += 2
                elif t.startswith(q * 3, self.i):
                    self.i += 3
                    extra = 0  # up to two quotes of the content may stand before the closing three
                    while self.peek() == q and extra < 2:
                        self.i += 1
                        extra += 1
                    return
                else:
                    self.i += 1
        self.i += 1
        while True:
            c = self.peek()
            if c in ("", "\n"):
                raise self.fail("an unterminated string")
            if q == '"' and c == "\\":
                self.i += 2
                continue
            self.i += 1
            if c == q:
                return

    def key(self) -> tuple[str, ...]:
        parts: list[str] = []
        while True:
            self.blank()
            start = self.i
            if self.peek() in ('"', "'"):
                self.string()
                parts.append(next(iter(tomllib.loads(self.t[start : self.i] + " = 0"))))
            else:
                m = _BARE.match(self.t, self.i)
                if not m:
                    raise self.fail("a key was expected")
                self.i = m.end()
                parts.append(m[0])
            self.blank()
            if self.peek() != ".":
                return tuple(parts)
            self.i += 1

    def value(self, path: Path) -> None:
        start, c = self.i, self.peek()
        if c in ('"', "'"):
            self.string()
            self.values[path] = Span(start=start, end=self.i)
        elif c == "[":
            self.i += 1
            count, trailing = 0, False
            while True:
                self.blank_lines()
                if self.peek() == "]":
                    break
                self.value((*path, count))
                count, trailing = count + 1, False
                self.blank_lines()
                if self.peek() == ",":
                    self.i += 1
                    trailing = True
                elif self.peek() != "]":
                    raise self.fail("',' or ']' was expected in an array")
            close = self.i
            self.i += 1
            self.values[path] = Span(start=start, end=self.i, close=close, count=count, trailing_comma=trailing)
        elif c == "{":
            self.i += 1
            self.blank()
            while self.peek() != "}":
                key = self.key()
                if self.peek() != "=":
                    raise self.fail("'=' was expected")
                self.i += 1
                self.blank()
                self.value(path + key)
                self.blank()
                if self.peek() == ",":
                    self.i += 1
                elif self.peek() != "}":
                    raise self.fail("',' or '}' was expected in an inline table")
            self.i += 1
            self.values[path] = Span(start=start, end=self.i)
        else:
            if _DATE_TIME.match(self.t, self.i):
                self.i += 11
            while self.peek() not in ("", ",", "]", "}", "#", " ", "\t", "\r", "\n"):
                self.i += 1
            if self.i == start:
                raise self.fail("a value was expected")
            self.values[path] = Span(start=start, end=self.i)

    def resolved(self, key: tuple[str, ...]) -> Path:
        """A header's key with the current index of every array of tables it passes through."""
        out: Path = ()
        for part in key[:-1]:
            out = (*out, part)
            if out in self.arrays_of_tables:
                out = (*out, self.arrays_of_tables[out] - 1)
        return (*out, key[-1])

    def run(self) -> Layout:
        table: Path = ()
        while True:
            self.blank_lines()
            if self.i >= len(self.t):
                return Layout(values=self.values, table_ends=self.ends)
            if self.peek() == "[":
                many = self.peek(1) == "["
                self.i += 2 if many else 1
                path = self.resolved(self.key())
                if not self.t.startswith("]]" if many else "]", self.i):
                    raise self.fail("a table header's ']' was expected")
                self.i += 2 if many else 1
                if many:
                    index = self.arrays_of_tables.get(path, 0)
                    self.arrays_of_tables[path] = index + 1
                    path = (*path, index)
                table = path
                self.ends[table] = self.end_of_line()
            else:
                key = self.key()
                if self.peek() != "=":
                    raise self.fail("'=' was expected")
                self.i += 1
                self.blank()
                self.value(table + key)
                self.ends[table] = self.end_of_line()


def layout(text: str) -> Layout:
    """Where every value and table of the TOML ``text`` is written. Raises ValueError naming the
    line where the text leaves the grammar the scanner follows."""
    return _Scanner(text).run()


@dataclass(frozen=True, kw_only=True)
class Edit:
    """Writing a value at a path: the text ``[start, end)`` is replaced by ``before``, the value
    and ``after``. A value the text holds is replaced (``before`` and ``after`` empty); a key its
    table lacks is a new line after the table's last; an array's missing last element is added."""

    start: int
    end: int
    before: str = ""
    after: str = ""

    def apply(self, text: str, value: str) -> str:
        return text[: self.start] + self.before + value + self.after + text[self.end :]


def _get(data: Any, path: Path) -> Any:
    for p in path:
        data = data[p]
    return data


def edit(text: str, where: Layout, path: Path, doc: dict[str, Any] | None = None) -> Edit | None:
    """How to write a number at ``path`` of ``text`` (laid out as ``where``), or None where the
    text has no place for it the scanner can find (a table missing, an array more than one
    element short). Every edit is checked: written with a probe number, tomllib must read that
    number at ``path`` and the rest of the document unchanged (``doc``: ``text`` as tomllib reads
    it, when the caller has it)."""
    out: Edit | None = None
    if path in where.values:
        s = where.values[path]
        out = Edit(start=s.start, end=s.end)
    elif path[:-1] in where.table_ends and isinstance(path[-1], str):
        key = path[-1] if _BARE.fullmatch(path[-1]) else None
        if key is not None:
            at = where.table_ends[path[:-1]]
            newline = "\r\n" if "\r\n" in text else "\n"  # the file's own line ending
            out = Edit(start=at, end=at, before=f"{newline}{key} = ")
    elif isinstance(path[-1], int) and path[:-1] in where.values:
        s = where.values[path[:-1]]
        if s.close is not None and s.count == path[-1]:
            sep = " " if s.trailing_comma else (", " if s.count else "")
            out = Edit(start=s.close, end=s.close, before=sep)
    if out is None:
        return None
    probe = 271828.125  # exact in binary and in decimal: read back as written
    try:
        expected = copy.deepcopy(doc) if doc is not None else tomllib.loads(text)
        got = tomllib.loads(out.apply(text, repr(probe)))
        parent = _get(expected, path[:-1])
        if isinstance(parent, list) and path[-1] == len(parent):
            parent.append(probe)
        else:
            parent[path[-1]] = probe
    except (tomllib.TOMLDecodeError, KeyError, IndexError, TypeError):
        return None
    return out if got == expected else None
