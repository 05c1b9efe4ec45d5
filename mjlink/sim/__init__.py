"""The MuJoCo side: the only package that imports mujoco.

:mod:`.gl` chooses the OpenGL backend first (MuJoCo reads ``MUJOCO_GL`` at import) and
:mod:`._mujoco` imports mujoco with it for the others: then
:mod:`.builder` (MjSpec -> model with element ids), :mod:`.simulate` (runs -> traces) and
:mod:`.render` (traces -> MP4).
"""

from . import gl

gl.choose()
