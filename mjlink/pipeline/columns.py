"""Column names of the studies' tables (units last, as the CSVs' convention) and the versions a
report records."""

from __future__ import annotations

import sys

import numpy as np


def unit_slug(unit: str) -> str:
    """A unit as a column-name suffix: 'N*m' -> 'N_m', 'kg*m^2' -> 'kg_m2', '' -> ''."""
    return unit.replace("*", "_").replace("/", "_").replace("^", "")


def column_name(name: str, unit: str) -> str:
    """'position_error_P5' + 'um' -> 'position_error_P5_um' (the CSV convention: unit last)."""
    return f"{name}_{unit_slug(unit)}" if unit else name


def versions() -> dict[str, str]:
    """numpy's version and those of MuJoCo, Dask and scipy where this process loaded them."""
    out = {"numpy": np.__version__}
    for mod in ("mujoco", "dask", "distributed", "scipy"):
        m = sys.modules.get(mod)
        if m is not None:
            out[mod] = str(getattr(m, "__version__", ""))
    return out
