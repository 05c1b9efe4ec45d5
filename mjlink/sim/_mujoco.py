"""mujoco, imported once the OpenGL backend is chosen (:mod:`.gl`): the modules of
:mod:`mjlink.sim` take it from here, so a ``MUJOCO_GL`` mujoco refuses never breaks them
(:func:`.gl.import_mujoco` keeps the refusal for the first render and imports without it).

MuJoCo's warnings (a state gone non-finite, which it answers by resetting the data) go to the
Python logger ``mjlink.mujoco`` at level DEBUG rather than to MuJoCo's default handler, which
appends them to ``MUJOCO_LOG.TXT`` in the current folder (the user's, wherever a script or
the command line runs) and prints them among the command's own output. mjlink reads what they mean from MuJoCo's warning counters itself and
reports it as its own error (a run that diverged, at its time). A program that installed its
own handler (``mujoco.set_mju_user_warning``) before this import keeps it."""

import logging

from . import gl

gl.import_mujoco()

import mujoco  # noqa: E402  (after import_mujoco: the module it imported)
from mujoco import rollout  # noqa: E402

__all__ = ["mujoco", "rollout"]

LOG = logging.getLogger("mjlink.mujoco")


def _warning(message: str) -> None:
    """MuJoCo's warning handler: its message, on the logger. Logging raises nothing (an
    exception here would unwind through MuJoCo's C code)."""
    LOG.debug("MuJoCo: %s", message)


if mujoco.get_mju_user_warning() is None:
    mujoco.set_mju_user_warning(_warning)
