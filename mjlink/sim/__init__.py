"""The MuJoCo side: the only package that imports mujoco.

:mod:`.gl` chooses the OpenGL backend first (MuJoCo reads ``MUJOCO_GL`` at import), then
:mod:`.builder` (MjSpec -> model with element ids), :mod:`.simulate` (runs -> traces) and
:mod:`.render` (traces -> MP4).
"""

from . import gl

gl.choose()
