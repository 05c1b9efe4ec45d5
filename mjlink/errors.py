"""One base exception for everything mjlink reports to a user.

Every error carries a one-line message naming the cause (and, where there is one, the file
and key), so the CLI can print it without a traceback and exit non-zero.
"""

from __future__ import annotations


class MjlinkError(Exception):
    """Base class of every error mjlink raises on purpose."""


class MechanismFileError(MjlinkError):
    """A mechanism file is unreadable, malformed, or describes an impossible mechanism."""


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
