"""One base exception for everything mjlink reports to a user.

Every error carries a one-line message naming the cause (and, where there is one, the file
and key), so the CLI can print it without a traceback and exit non-zero.
"""

from __future__ import annotations

import difflib
from collections.abc import Iterable


class MjlinkError(Exception):
    """Base class of every error mjlink raises on purpose. ``exit_status``: what the command line
    exits with when it ends a command (1; 2 for input refused before any work)."""

    exit_status = 1


class InputError(MjlinkError):
    """Input refused before any work began because it is beyond a limit or cannot be used: a
    study file too large or too deep, a number too large, an output location that is a file, a
    scheduler that cannot be reached, a study too large for this machine. Exit status 2, as the
    command line's usage errors: nothing ran and nothing was written."""

    exit_status = 2


class ArgumentError(InputError):
    """A Python API function's argument of the wrong type or beyond its range (or a limit of the
    command line's): the message names the function and the argument."""


class MechanismFileError(MjlinkError):
    """A mechanism file is unreadable, malformed, or describes an impossible mechanism."""


class FileTooLargeError(MechanismFileError, InputError):
    """A mechanism file larger than mechanism files are (refused by its size, before reading)."""


class UnknownMechanismError(MjlinkError):
    """A mechanism name that is neither in the registry nor a path to a file."""


class AssemblyError(MjlinkError):
    """The linkage cannot be assembled at some input angle (a dyad or slider cannot close)."""


class SimulationError(MjlinkError):
    """A MuJoCo run diverged or left the reference's assembly branch."""


class RenderError(MjlinkError):
    """No offscreen OpenGL backend works, or the video could not be encoded."""


class OutputError(MjlinkError):
    """An output folder or file cannot be written."""


def did_you_mean(word: str, choices: Iterable[str]) -> str:
    """``"did you mean 'X'? "`` for the choice closest to a misspelt ``word``, or ``""``: the
    start of the parenthesis of an error message that then lists the valid choices."""
    near = difflib.get_close_matches(word, list(choices), n=1)
    return f"did you mean '{near[0]}'? " if near else ""
