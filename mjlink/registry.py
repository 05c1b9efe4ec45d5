"""The registry of mechanisms: every ``mechanisms/*.toml`` of this checkout, by name.

A command-line argument that is not a registered name but a path to a file is loaded from
that file, so users' own mechanisms need no registration.
"""

from __future__ import annotations

from pathlib import Path

from . import reference
from .errors import AssemblyError, UnknownMechanismError
from .mechanism import Mechanism, load

MECHANISMS_DIR = Path(__file__).resolve().parent.parent / "mechanisms"


def names() -> list[str]:
    """Names of the registered mechanisms, sorted."""
    return sorted(p.stem for p in MECHANISMS_DIR.glob("*.toml"))


def path_of(name_or_path: str | Path) -> Path:
    """The file of a registered name, or the given path if it is a file."""
    s = str(name_or_path)
    if s in names():
        return MECHANISMS_DIR / f"{s}.toml"
    p = Path(s)
    if p.is_file():
        return p
    if p.suffix == ".toml" or "/" in s or "\\" in s:
        raise UnknownMechanismError(f"{s}: no such mechanism file")
    raise UnknownMechanismError(f"unknown mechanism '{s}' (valid: {', '.join(names())}, or a path to a .toml file)")


def get(name_or_path: str | Path, *, full_turn: bool = True) -> Mechanism:
    """Load and validate a mechanism; with ``full_turn`` its input crank must turn fully.

    Raises MechanismFileError, UnknownMechanismError or AssemblyError with a one-line message.
    """
    mech = load(path_of(name_or_path))
    ok, ranges = reference.assembly_ranges(mech)
    if full_turn and not ok:
        raise AssemblyError(
            f"{mech.path}: the input crank cannot turn fully: the linkage assembles only for input angles "
            f"{ranges or 'none'} deg (it is a rocker there; mjlink does not pretend otherwise)")
    if ok:
        reference.check_rigidity(mech)
    return mech
