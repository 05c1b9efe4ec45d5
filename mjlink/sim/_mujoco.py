"""mujoco, imported once the OpenGL backend is chosen (:mod:`.gl`): the modules of
:mod:`mjlink.sim` take it from here, so a ``MUJOCO_GL`` mujoco refuses never breaks them
(:func:`.gl.import_mujoco` keeps the refusal for the first render and imports without it)."""

from . import gl

gl.import_mujoco()

import mujoco  # noqa: E402  (after import_mujoco: the module it imported)
from mujoco import rollout  # noqa: E402

__all__ = ["mujoco", "rollout"]
