"""Choosing MuJoCo's offscreen OpenGL backend, before MuJoCo is imported, through its documented
``MUJOCO_GL`` (and PyOpenGL's ``PYOPENGL_PLATFORM``, which MuJoCo's EGL and OSMesa backends set).

MuJoCo reads ``MUJOCO_GL`` once, when it is first imported. Every module that imports mujoco
lives in :mod:`mjlink.sim`, whose ``__init__`` calls :func:`choose` and then
:func:`import_mujoco` first: the ordering holds by construction.

Only rendering needs OpenGL. A ``MUJOCO_GL`` value mujoco does not accept makes ``import
mujoco`` itself fail (its RuntimeError naming the variable): :func:`import_mujoco` then keeps
mujoco's message as the render failure, takes the value out of the environment and imports
again, so ``check``, ``build`` and ``simulate --no-video`` work; rendering then fails with one
line naming the backend tried and how to install one. A backend whose library is missing and
``MUJOCO_GL=off`` import fine and fail at the first render, in the same words.
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

INSTALL_HINT = (
    "install one (Debian/Ubuntu: apt-get install libegl1 libosmesa6, or libgl1-mesa-dri), set "
    "MUJOCO_GL to a backend that works here, or unset it to let mjlink probe egl then osmesa; "
    "--no-video skips the video"
)

_backend: str | None = None
_failure: RenderError | None = None  # why rendering cannot work, found when mujoco was imported


def ensure_gl_backend() -> str:
    """Choose MuJoCo's offscreen OpenGL backend and return its name (e.g. ``'egl'``).

    * ``MUJOCO_GL`` already set in the environment: respected and returned as is; one that
      mujoco refused at its import (:func:`import_mujoco`) is the render failure.
    * mujoco already imported in this process with ``MUJOCO_GL`` unset: it is too late to
      choose, so the backend mujoco picked at import is returned (the module of
      ``mujoco.GLContext``: ``'glfw'`` on Linux and Windows, ``'cgl'`` or ``'glfw'`` on macOS;
      ``'none'`` if mujoco has no usable context class). Rendering then fails with a
      :class:`RenderError` if that backend cannot work here, e.g. glfw without a display.
    * Otherwise, on Linux: ``'egl'`` then ``'osmesa'`` are tried (:func:`_probe`: EGL first in
      this process through its C library, the cheap probe; where that says no, and for OSMesa,
      in a short subprocess that imports mujoco and makes a 16x16 context current) and the
      first that works is written to ``os.environ['MUJOCO_GL']``. On other systems mujoco's
      own default (cgl on macOS, glfw elsewhere) is returned and nothing is set, since EGL
      and OSMesa are Linux-only there.

    The answer is cached for the life of the process. Never imports mujoco itself.
    Raises :class:`RenderError` if no backend works, or if mujoco refused ``MUJOCO_GL``.
    """
    global _backend
    if _backend is not None:
        return _backend
    if _failure is not None:
        raise _failure
    preset = os.environ.get("MUJOCO_GL")
    if preset:
        _backend = preset
        return preset
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
        f"no offscreen OpenGL backend works: tried {', '.join(PROBE_ORDER)} ({'; '.join(reasons)}); {INSTALL_HINT}"
    )


def _imported_backend() -> str:
    """Name of the backend an already imported mujoco chose at import."""
    cls = getattr(sys.modules["mujoco"], "GLContext", None)
    module = getattr(cls, "__module__", "") or ""
    parts = module.split(".")
    if len(parts) == 2 and parts[0] == "mujoco":  # mujoco.egl, mujoco.osmesa, mujoco.glfw, mujoco.cgl
        return parts[1]
    return "none"


# EGL constants (Khronos egl.h, EGL_EXT_platform_device) for the in-process probe.
_EGL_NONE, _EGL_PLATFORM_DEVICE_EXT, _EGL_OPENGL_API = 0x3038, 0x313F, 0x30A2
# What mujoco.egl asks of a framebuffer configuration: RGBA 8 bits, depth 24, stencil 8, an
# RGB buffer, pbuffer surfaces, desktop OpenGL.
_EGL_ATTRIBUTES = (0x3024, 8, 0x3023, 8, 0x3022, 8, 0x3021, 8, 0x3025, 24, 0x3026, 8)
_EGL_ATTRIBUTES += (0x303F, 0x308E, 0x3033, 0x0001, 0x3040, 0x0008, _EGL_NONE)


def _loads(soname: str) -> bool:
    try:
        ctypes.CDLL(soname)
    except OSError:
        return False
    return True


def _egl_in_process() -> str | None:
    """None if an EGL device display makes an OpenGL context current here, as mujoco.egl
    makes one (device displays, the same configuration), else why not; without importing
    mujoco or PyOpenGL, so that a failure leaves the choice of osmesa open. It costs the
    driver's loading, which the renderer would pay anyway, instead of a fresh interpreter
    importing mujoco."""
    # Loaded by their sonames (dlopen), not through ctypes.util.find_library, which runs
    # ldconfig in a subprocess: PyOpenGL needs libOpenGL or libGL beside libEGL at import.
    try:
        egl = ctypes.CDLL("libEGL.so.1")
    except OSError:
        return "libEGL.so.1 not found"
    if not any(_loads(lib) for lib in ("libOpenGL.so.0", "libGL.so.1")):
        return "neither libOpenGL.so.0 nor libGL.so.1 found"
    p, i32 = ctypes.c_void_p, ctypes.c_int32
    egl.eglGetProcAddress.restype, egl.eglGetProcAddress.argtypes = p, [ctypes.c_char_p]
    egl.eglInitialize.argtypes = [p, ctypes.POINTER(i32), ctypes.POINTER(i32)]
    egl.eglChooseConfig.argtypes = [p, ctypes.POINTER(i32), ctypes.POINTER(p), i32, ctypes.POINTER(i32)]
    egl.eglBindAPI.argtypes = [ctypes.c_uint]
    egl.eglCreateContext.restype, egl.eglCreateContext.argtypes = p, [p, p, p, ctypes.POINTER(i32)]
    egl.eglMakeCurrent.argtypes = [p, p, p, p]
    egl.eglDestroyContext.argtypes = [p, p]
    query_addr = egl.eglGetProcAddress(b"eglQueryDevicesEXT")
    display_addr = egl.eglGetProcAddress(b"eglGetPlatformDisplayEXT")
    if not (query_addr and display_addr):
        return "EGL has no device platform (EGL_EXT_device_enumeration, EGL_EXT_platform_device)"
    query = ctypes.CFUNCTYPE(ctypes.c_uint, i32, ctypes.POINTER(p), ctypes.POINTER(i32))(query_addr)
    get_display = ctypes.CFUNCTYPE(p, ctypes.c_uint, p, ctypes.POINTER(i32))(display_addr)
    n = i32()
    if not query(0, None, ctypes.byref(n)) or n.value < 1:
        return "EGL lists no device"
    devices = (p * n.value)()
    query(n.value, devices, ctypes.byref(n))
    attributes = (i32 * len(_EGL_ATTRIBUTES))(*_EGL_ATTRIBUTES)
    for device in devices[: n.value]:
        display = get_display(_EGL_PLATFORM_DEVICE_EXT, device, None)
        major, minor, count, config = i32(), i32(), i32(), p()
        if not display or not egl.eglInitialize(display, ctypes.byref(major), ctypes.byref(minor)):
            continue
        if not egl.eglChooseConfig(display, attributes, ctypes.byref(config), 1, ctypes.byref(count)):
            continue
        if count.value < 1 or not egl.eglBindAPI(_EGL_OPENGL_API):
            continue
        context = egl.eglCreateContext(display, config, None, None)
        if not context:
            continue
        current = egl.eglMakeCurrent(display, None, None, context)
        egl.eglMakeCurrent(display, None, None, None)
        egl.eglDestroyContext(display, context)
        if current:
            return None
    return f"none of {n.value} EGL device(s) made an OpenGL context current"


def _probe(name: str) -> str | None:
    """None if backend ``name`` can make a context current, else why not: EGL in this process
    by its C library (:func:`_egl_in_process`), when it answers yes; any other backend, and an
    EGL that said no, in a fresh interpreter that imports mujoco with it, as rendering will."""
    if name == "egl":
        try:
            if _egl_in_process() is None:
                return None
        except (OSError, AttributeError, ValueError):
            pass
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


NO_GL_ENV = "MJLINK_NO_GL"  # "1": the process will not render, so choose() probes nothing


def choose() -> None:
    """Choose the backend if it can be chosen; a failure is kept for the first render to raise.

    Only rendering needs OpenGL: ``check`` and ``build`` must work where none does. A preset
    ``MUJOCO_GL`` is left to mujoco (:func:`import_mujoco` deals with one it refuses); a process
    that will not render (``MJLINK_NO_GL=1``) probes nothing.
    """
    global _failure
    if os.environ.get("MUJOCO_GL") or "mujoco" in sys.modules:
        return
    if os.environ.get(NO_GL_ENV) == "1":
        # This process will not render (a command without video): mujoco is imported without
        # probing OpenGL, which would load a library or start a subprocess for nothing.
        return
    try:
        ensure_gl_backend()
    except RenderError as e:
        _failure = e


def import_mujoco() -> None:
    """Import mujoco with the chosen ``MUJOCO_GL``. If that import fails while ``MUJOCO_GL`` is set
    (a value mujoco refuses: its RuntimeError; a backend whose library is missing: PyOpenGL's
    error), mujoco is imported again without it (and without the ``PYOPENGL_PLATFORM`` that
    attempt set); if that works, the first failure is kept, in one line, for the first render."""
    global _failure
    platform_before = os.environ.get("PYOPENGL_PLATFORM")
    try:
        import mujoco  # here: after choose() set MUJOCO_GL, which mujoco reads when it is imported
    except Exception as e:
        value = os.environ.get("MUJOCO_GL")
        if value is None:
            raise
        del os.environ["MUJOCO_GL"]
        if platform_before is None:
            os.environ.pop("PYOPENGL_PLATFORM", None)
        try:
            import mujoco  # noqa: F401  (the modules loaded before the failure are reused)
        except Exception:
            os.environ["MUJOCO_GL"] = value
            raise e from None
        shown = ascii(value)[1:-1]  # no control characters from the environment in a message
        if isinstance(e, RuntimeError) and "MUJOCO_GL" in str(e):
            why = f"MUJOCO_GL={shown} is no backend mujoco knows (mujoco: {_clip(e)})"
        else:
            lib = _LIBRARY.get(value.lower().strip())
            missing = f"lib{lib} not found: " if lib and ctypes.util.find_library(lib) is None else ""
            why = f"MUJOCO_GL={shown} cannot be loaded ({missing}{type(e).__name__}: {_clip(e)})"
        _failure = RenderError(f"cannot render: {why}; backend tried: {shown}; {INSTALL_HINT}")


def context_failure(backend: str, e: BaseException | None) -> RenderError:
    """The render failure of a backend mujoco imported but cannot make a context with: turned
    off (``MUJOCO_GL=off``: mujoco then has no GLContext), or its library missing (mujoco's
    placeholder context raises ImportError), in one line."""
    shown = ascii(backend)[1:-1]
    if e is None:
        why = f"MUJOCO_GL={shown} turns OpenGL off in mujoco"
    else:
        lib = _LIBRARY.get(backend.lower().strip())
        missing = f"lib{lib} not found; " if lib and ctypes.util.find_library(lib) is None else ""
        why = f"MUJOCO_GL={shown}: {missing}{_clip(e)}"
    return RenderError(f"cannot render: {why} (backend tried: {shown}); {INSTALL_HINT}")
