"""The errors a study file can cause."""

from __future__ import annotations

from ..errors import InputError, MjlinkError


class StudyFileError(MjlinkError):
    """A study file is unreadable or asks for something that cannot be done."""


class StudyLimitError(StudyFileError, InputError):
    """A study file (or its path) beyond one of mjlink's limits: too large, nested too deeply,
    a number of too many digits or too large, more variants than allowed. Refused before any
    work, exit status 2 on the command line (as a usage error: nothing ran, nothing was
    written)."""
