"""A small TOML writer for mechanism files (tables, arrays of tables, strings, numbers, lists).

The standard library reads TOML but does not write it; mechanism files need only this subset.
"""

from __future__ import annotations

import math
import re
from typing import Any

_BARE_KEY = re.compile(r"[A-Za-z0-9_-]+")
_CONTROL = re.compile(r"[\x00-\x08\x0a-\x1f\x7f]")
_ESCAPES = {"\b": "\\b", "\t": "\\t", "\n": "\\n", "\f": "\\f", "\r": "\\r", '"': '\\"', "\\": "\\\\"}


def _string(s: str) -> str:
    """``s`` as a TOML basic string: a quote, a backslash and every control character (U+0000 to
    U+001F and U+007F, which TOML allows in no string raw) escaped, so that any text reads back
    as written."""
    return (
        '"'
        + "".join(_ESCAPES.get(c) or (f"\\u{ord(c):04X}" if ord(c) < 0x20 or ord(c) == 0x7F else c) for c in s)
        + '"'
    )


def _escaped(m: re.Match[str]) -> str:
    return f"\\u{ord(m[0]):04X}"


def _key(k: str) -> str:
    """``k`` bare where TOML allows it, else quoted."""
    return k if _BARE_KEY.fullmatch(k) else _string(k)


def _value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if not math.isfinite(v):
            raise ValueError(f"cannot write non-finite number {v}")
        return repr(v)
    if isinstance(v, str):
        return _string(v)
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_value(x) for x in v) + "]"
    raise TypeError(f"cannot write {type(v).__name__} to TOML")


def dumps(data: dict, header: str = "") -> str:
    """TOML text of ``data``, which reads back as ``data`` whatever its strings and keys hold;
    ``header`` lines become leading comments."""
    # A comment holds no control character but the tab (TOML): any other is written escaped.
    out = [f"# {_CONTROL.sub(_escaped, line)}" if line else "#" for line in header.splitlines()]

    def table(prefix: str, d: dict) -> None:
        scalars = {k: v for k, v in d.items() if not isinstance(v, dict) and not _is_aot(v)}
        if prefix and scalars:
            out.append(f"\n[{prefix}]")
        for k, v in scalars.items():
            out.append(f"{_key(k)} = {_value(v)}")
        for k, v in d.items():
            name = f"{prefix}.{_key(k)}" if prefix else _key(k)
            if isinstance(v, dict):
                table(name, v)
            elif _is_aot(v):
                for item in v:
                    out.append(f"\n[[{name}]]")
                    for kk, vv in item.items():
                        out.append(f"{_key(kk)} = {_value(vv)}")

    table("", data)
    return "\n".join(out).lstrip("\n") + "\n"


def _is_aot(v: Any) -> bool:
    return isinstance(v, list) and bool(v) and all(isinstance(x, dict) for x in v)
