"""Notes to the user: one line each about something mjlink did that the user should know of.

A previous output replaced (and which of its files are gone), a resume cache discarded and why,
a damaged cache chunk recomputed, a value clamped. They go through the standard :mod:`logging`
module, logger ``mjlink`` at level INFO: the command line prints them on stderr as
``mjlink: note: ...`` (:func:`to_stderr`); a program using the Python API sees them once it
configures logging (``logging.basicConfig(level=logging.INFO)``).
"""

from __future__ import annotations

import logging
import sys
from collections.abc import Iterator
from contextlib import contextmanager

LOGGER = logging.getLogger("mjlink")


def note(message: str) -> None:
    """Tell the user ``message`` (one line)."""
    LOGGER.info(message)


@contextmanager
def to_stderr(prefix: str = "mjlink: note: ") -> Iterator[None]:
    """For the duration, notes are printed on stderr with ``prefix`` (the command line's)."""
    handler = logging.StreamHandler(sys.stderr)
    handler.setFormatter(logging.Formatter(prefix + "%(message)s"))
    level, propagate = LOGGER.level, LOGGER.propagate
    LOGGER.addHandler(handler)
    LOGGER.setLevel(logging.INFO)
    LOGGER.propagate = False
    try:
        yield
    finally:
        LOGGER.removeHandler(handler)
        LOGGER.setLevel(level)
        LOGGER.propagate = propagate
