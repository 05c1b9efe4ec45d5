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
    return validate(load(path_of(name_or_path)), full_turn=full_turn)


def validate(mech: Mechanism, *, full_turn: bool = True) -> Mechanism:
    """The assembly and rigidity checks of :func:`get`, for a mechanism built in code."""
    ok, ranges = reference.assembly_ranges(mech)
    if full_turn and not ok:
        raise AssemblyError(
            f"{mech.path}: the input crank cannot turn fully: the linkage assembles only for input angles "
            f"{ranges or 'none'} deg (it is a rocker there; mjlink does not pretend otherwise)")
    if ok:
        reference.check_rigidity(mech)
    return mech


def with_crank_settings(mech: Mechanism, phi0_deg: float | None = None, phase_deg: float | None = None) -> Mechanism:
    """``mech`` with another initial input angle (phi01) and/or geared-crank phase (phi04), deg.

    Raises MjlinkError if a phase is given for a mechanism without a geared crank.
    """
    import dataclasses
    import math

    from .errors import MjlinkError
    from .mechanism import Crank

    if phi0_deg is not None:
        if not math.isfinite(phi0_deg):
            raise MjlinkError(f"--phi0 must be finite, got {phi0_deg}")
        mech = dataclasses.replace(mech, phi0=math.radians(phi0_deg))
    if phase_deg is not None:
        geared = [s for s in mech.steps if isinstance(s, Crank) and s is not mech.input_crank]
        if not geared:
            raise MjlinkError(f"{mech.name} has no geared crank: --phase/--phi04 does not apply")
        if not math.isfinite(phase_deg):
            raise MjlinkError(f"--phase must be finite, got {phase_deg}")
        new = dataclasses.replace(geared[0], phase=math.radians(phase_deg))
        mech = dataclasses.replace(mech, steps=tuple(new if s is geared[0] else s for s in mech.steps))
    return validate(mech) if (phi0_deg is not None or phase_deg is not None) else mech
