"""Choosing MuJoCo's offscreen OpenGL backend, before MuJoCo is imported.

MuJoCo reads ``MUJOCO_GL`` once, when it is first imported. Every module that imports mujoco
lives in :mod:`mjlink.sim`, whose ``__init__`` calls :func:`choose` first: the ordering holds
by construction. This module never imports mujoco itself.
"""

from __future__ import annotations

import ctypes.util
import os
import platform
import subprocess
import sys

from ..errors import RenderError

PROBE_ORDER = ("egl", "osmesa")
PROBE_TIMEOUT = 10.0  # s: a broken EGL driver can hang instead of failing

# What mujoco does with MUJOCO_GL unset, per platform (mujoco.rendering.classic.gl_context).
_MUJOCO_DEFAULT = {"Darwin": "cgl"}

_PROBE_CODE = """\
import mujoco
ctx = mujoco.GLContext(16, 16)
ctx.make_current()
ctx.free()
"""

# Shared library each probed backend needs (ctypes.util.find_library names).
_LIBRARY = {"egl": "EGL", "osmesa": "OSMesa"}

_backend: str | None = None


def ensure_gl_backend() -> str:
    """Choose MuJoCo's offscreen OpenGL backend and return its name (e.g. ``'egl'``).

    * ``MUJOCO_GL`` already set in the environment: respected and returned as is.
    * mujoco already imported in this process with ``MUJOCO_GL`` unset: it is too late to
      choose, so the backend mujoco picked at import is returned (the module of
      ``mujoco.GLContext``: ``'glfw'`` on Linux and Windows, ``'cgl'`` or ``'glfw'`` on macOS;
      ``'none'`` if mujoco has no usable context class). Rendering then fails with a
      :class:`RenderError` if that backend cannot work here, e.g. glfw without a display.
    * Otherwise, on Linux: ``'egl'`` then ``'osmesa'`` are each tried in a short subprocess
      (import mujoco, create and make current a 16x16 context; about 0.5 s each) and the
      first that works is written to ``os.environ['MUJOCO_GL']``. On other systems mujoco's
      own default (cgl on macOS, glfw elsewhere) is returned and nothing is set, since EGL
      and OSMesa are Linux-only there.

    The answer is cached for the life of the process. Never imports mujoco itself.
    Raises :class:`RenderError` if no backend works.
    """
    global _backend
    if _backend is not None:
        return _backend
    preset = os.environ.get("MUJOCO_GL")
    if preset:
        _backend = preset
        return _backend
    if "mujoco" in sys.modules:
        _backend = _imported_backend()
        return _backend
    system = platform.system()
    if system != "Linux":
        _backend = _MUJOCO_DEFAULT.get(system, "glfw")
        return _backend
    reasons = []
    for name in PROBE_ORDER:
        why = _probe(name)
        if why is None:
            os.environ["MUJOCO_GL"] = name
            _backend = name
            return _backend
        reasons.append(f"{name}: {why}")
    raise RenderError(
        f"no offscreen OpenGL backend works: tried {', '.join(PROBE_ORDER)} ({'; '.join(reasons)}); "
        f"install Mesa's libEGL or libOSMesa, or set MUJOCO_GL"
    )


def _imported_backend() -> str:
    """Name of the backend an already imported mujoco chose at import."""
    cls = getattr(sys.modules["mujoco"], "GLContext", None)
    module = getattr(cls, "__module__", "") or ""
    parts = module.split(".")
    if len(parts) == 2 and parts[0] == "mujoco":  # mujoco.egl, mujoco.osmesa, mujoco.glfw, mujoco.cgl
        return parts[1]
    return "none"


def _probe(name: str) -> str | None:
    """None if backend ``name`` can make a context current in a fresh interpreter, else why not."""
    env = dict(os.environ, MUJOCO_GL=name)
    try:
        res = subprocess.run(
            [sys.executable, "-c", _PROBE_CODE], env=env, capture_output=True, text=True, timeout=PROBE_TIMEOUT
        )
    except subprocess.TimeoutExpired:
        return f"timed out after {PROBE_TIMEOUT:g} s"
    except OSError as e:
        return f"cannot start {sys.executable}: {e.strerror or e}"
    if res.returncode == 0:
        return None
    # PyOpenGL's error for a missing library is cryptic ('NoneType' has no attribute ...).
    lib = _LIBRARY.get(name)
    if lib and ctypes.util.find_library(lib) is None:
        return f"lib{lib} not found"
    lines = [l.strip() for l in res.stderr.splitlines() if l.strip()]
    return _clip(lines[-1] if lines else f"exit status {res.returncode}")


def _clip(msg: object, limit: int = 160) -> str:
    msg = " ".join(str(msg).split())
    return msg if len(msg) <= limit else msg[: limit - 3] + "..."


_failure: RenderError | None = None


def choose() -> None:
    """Choose the backend if it can be chosen; a failure is kept for the first render to raise.

    Only rendering needs OpenGL: ``check`` and ``build`` must work where none does.
    """
    global _failure
    try:
        ensure_gl_backend()
    except RenderError as e:
        _failure = e
