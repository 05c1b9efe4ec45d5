"""A small TOML writer for mechanism files (tables, arrays of tables, strings, numbers, lists).

The standard library reads TOML but does not write it; mechanism files need only this subset.
"""

from __future__ import annotations

import math
from typing import Any


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
        return '"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_value(x) for x in v) + "]"
    raise TypeError(f"cannot write {type(v).__name__} to TOML")


def dumps(data: dict, header: str = "") -> str:
    """TOML text of ``data``; ``header`` lines become leading comments."""
    out = [f"# {line}" if line else "#" for line in header.splitlines()]

    def table(prefix: str, d: dict) -> None:
        scalars = {k: v for k, v in d.items() if not isinstance(v, dict) and not _is_aot(v)}
        if prefix and scalars:
            out.append(f"\n[{prefix}]")
        for k, v in scalars.items():
            out.append(f"{k} = {_value(v)}")
        for k, v in d.items():
            name = f"{prefix}.{k}" if prefix else k
            if isinstance(v, dict):
                table(name, v)
            elif _is_aot(v):
                for item in v:
                    out.append(f"\n[[{name}]]")
                    for kk, vv in item.items():
                        out.append(f"{kk} = {_value(vv)}")

    table("", data)
    return "\n".join(out).lstrip("\n") + "\n"


def _is_aot(v: Any) -> bool:
    return isinstance(v, list) and bool(v) and all(isinstance(x, dict) for x in v)
