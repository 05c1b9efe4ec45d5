"""Offscreen rendering of a MuJoCo trace to an MP4 video.

Two steps, in this order:

1. :func:`mjlink.sim.gl.ensure_gl_backend` has picked the offscreen OpenGL backend when
   :mod:`mjlink.sim` was imported.
2. :func:`render_video` replays a trace's joint positions through a camera framed on the
   box that every point sweeps over the cycle, for the video's own aspect ratio (straight on
   for a planar mechanism, obliquely with an axis triad for one with points in depth), draws
   the key point's path as a fading trail, writes time, crank angle, speed and slow-motion
   factor over each frame, and encodes the frames as H.264 (yuv420p) with imageio's ffmpeg.

Units: times s, frame rates frames/s, sizes pixels; the trace is in SI units.
"""

from __future__ import annotations

import contextlib
import ctypes
import math
import os
import sys
import time
from collections.abc import Callable
from contextlib import AbstractContextManager
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .. import analysis, palette, reference
from ..errors import OutputError, RenderError
from ..files import atomic_path
from ..model.mechanism import Mechanism
from ..runs import Settings, Trace
from . import builder, simulate
from ._mujoco import mujoco
from .gl import _clip, context_failure, ensure_gl_backend

PROGRESS_AFTER = 1.0  # s of rendering before a progress line is worth printing


# ----------------------------------------------------------------------------- video
@dataclass(frozen=True, kw_only=True)
class VideoInfo:
    """What :func:`render_video` wrote.

    ``path`` the MP4 file; ``frames`` frame count; ``fps`` frames/s; ``width`` and ``height``
    pixels; ``time_scale`` video seconds per simulated second: the video is slowed down by
    this factor (e.g. 3.0 s of video for a 0.0628 s cycle gives 47.7); ``backend`` the
    OpenGL backend that rendered it.
    """

    path: Path
    frames: int
    fps: float
    width: int
    height: int
    time_scale: float
    backend: str

    @property
    def seconds(self) -> float:
        """Video duration, s."""
        return self.frames / self.fps


def frame_qpos(trace: Trace, frames: int) -> tuple[np.ndarray, np.ndarray]:
    """Frame times (s) and joint positions for ``frames`` frames spread over the trace.

    Frame i is at ``t0 + i (t_end - t0) / frames``: the last frame stops one step short of
    ``t_end``, so a trace of whole cycles loops without a repeated pose. qpos is linearly
    interpolated per joint, which is exact enough for hinges and slides (the only joints the
    builder makes; hinge angles are unwrapped). Returns ``(times, qpos)`` of shapes (frames,)
    and (frames, nq).
    """
    if trace.qpos is None:
        raise RenderError(f"a {trace.source} trace has no joint positions to render: render a MuJoCo trace")
    t = np.asarray(trace.time, dtype=float)
    q = np.asarray(trace.qpos, dtype=float)
    if len(t) < 2 or not t[-1] > t[0]:
        raise RenderError("the trace spans no time: it needs at least two samples to render")
    times = t[0] + np.arange(frames) * (t[-1] - t[0]) / frames
    qpos = np.column_stack([np.interp(times, t, q[:, j]) for j in range(q.shape[1])])
    return times, qpos.reshape(frames, q.shape[1])


TRAIL_SAMPLES = 120  # key-point positions along the trail (one period)
OVERLAY_HEIGHT = 0.034  # overlay text height, share of the frame's height


def frame_camera(
    points: np.ndarray, axes: np.ndarray, aspect: float, fovy: float, band: float, margin: float = 1.1
) -> np.ndarray:
    """Where a camera of orientation ``axes`` (3 x 3, columns: its right, up and backward
    directions in the world, as ``data.cam_xmat``) must stand, m, to hold every point of
    ``points`` (M, 3) m with ``margin`` in a frame of ``aspect`` = width / height and vertical
    field of view ``fovy`` deg, below a top ``band`` (share of the height) kept for the overlay
    text. The least distance that keeps every point inside both half-angles."""
    right, up, back = axes[:, 0], axes[:, 1], axes[:, 2]
    fwd = -back
    lo, hi = points.min(axis=0), points.max(axis=0)
    center = 0.5 * (lo + hi)
    corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])]) - center
    ty = np.tan(np.radians(fovy) / 2.0)
    tx = ty * aspect
    # The usable height is (1 - band) of the frame: the content's half-height must fit in
    # (1 - band) ty d, and the camera aims above the content so that it sits below the band.
    dist = max(
        float(np.max(np.abs(corners @ right) * margin / tx - corners @ fwd)),
        float(np.max(np.abs(corners @ up) * margin / (ty * (1.0 - band)) - corners @ fwd)),
        1e-3,
    )
    aim = center + band * ty * dist * up
    return aim - dist * fwd


def key_path(mech: Mechanism, trace: Trace, times: np.ndarray) -> tuple[str, np.ndarray, np.ndarray]:
    """The key point (:func:`mjlink.analysis.key_point`), its positions at the frame ``times``
    (frames, 3) m, and for each frame the trail behind it: (frames, TRAIL_SAMPLES, 3) m, the
    positions over the last period of crank rotation (fewer at the start are repeated)."""
    key = analysis.key_point(mech)
    t = np.asarray(trace.time, dtype=float)
    p = np.asarray(trace.points[key], dtype=float)
    now = np.column_stack([np.interp(times, t, p[:, j]) for j in range(3)])
    period_t = mech.period / max(abs(float(np.mean(trace.omega))), 1e-9)
    back = times[:, None] - period_t * np.linspace(1.0, 0.0, TRAIL_SAMPLES)[None, :]
    back = np.maximum(back, t[0])
    trail = np.stack([np.interp(back, t, p[:, j]) for j in range(3)], axis=-1)
    return key, now, trail


def overlay_lines(trace: Trace, times: np.ndarray, time_scale: float, phi0: float) -> list[list[str]]:
    """The text written over each frame, one line: time (s), crank angle phi1 (deg) and the
    angle turned from phi0, crank speed (rpm, magnitude, its sense) and the slow-motion factor."""
    t = np.asarray(trace.time, dtype=float)
    phi = np.interp(times, t, trace.phi)
    omega = np.interp(times, t, trace.omega)
    out = []
    for i, ti in enumerate(times):
        turned = math.degrees(abs(phi[i] - phi0))
        w = float(omega[i])
        sense = "CCW" if w >= 0 else "CW"
        out.append(
            [
                f"t {ti:.4f} s   phi1 {math.degrees(phi[i]):7.1f} deg ({turned:3.0f} turned)   "
                f"n1 {abs(w) * 30.0 / math.pi:.0f} rpm {sense}   slow motion {time_scale:.3g}x"
            ]
        )
    return out


Held = Callable[[], AbstractContextManager[object]]
"""What holds SIGINT and SIGTERM back while a GL context is made: the command line passes
its own (:func:`mjlink.runtime.signals.uninterrupted`); a script's default holds nothing."""


def _new_renderer(model: mujoco.MjModel, height: int, width: int, held: Held) -> mujoco.Renderer:
    """``mujoco.Renderer(model, height, width)`` with SIGINT and SIGTERM acted on once it exists.

    Why: a GL context whose constructor an interruption cuts short (mujoco 3.8's EGL context
    sets its ``_context`` last) prints an ``AttributeError`` from its ``__del__`` after the
    run's one-line message; held back, the signal ends the run right after, cleanly."""
    with held():
        return mujoco.Renderer(model, height, width)


def check_backend(*, held: Held = contextlib.nullcontext) -> str:
    """The OpenGL backend rendering will use, tried now: one the environment chose
    (``MUJOCO_GL``) makes a 16x16 context current here, as the video will (a probed one already
    did); raises the one-line :class:`RenderError` a render would, before any run. ``held``
    holds signals back while the context is made (see :func:`_new_renderer`)."""
    backend = ensure_gl_backend()
    if not hasattr(mujoco, "GLContext"):  # MUJOCO_GL turned OpenGL off
        raise context_failure(backend, None)
    try:
        with held():  # see _new_renderer
            ctx = mujoco.GLContext(16, 16)
        ctx.make_current()
        ctx.free()
    except Exception as e:
        raise context_failure(backend, e) from None
    return backend


def render_video(
    mech: Mechanism,
    trace: Trace,
    path: str | os.PathLike,
    *,
    seconds: float = 3.0,
    fps: float = 30,
    width: int = 640,
    height: int = 480,
    settings: Settings | None = None,
    progress: bool = True,
    held: Held = contextlib.nullcontext,
) -> VideoInfo:
    """Render ``trace`` of ``mech`` to an MP4 (H.264, yuv420p) at ``path``.

    ``seconds`` video duration (s) over which the whole trace is played, ``fps`` frames/s,
    ``width`` and ``height`` pixels (even; beyond 1920x1080 the GL driver's limits apply).
    ``settings`` those the trace was run with (default: the kinematic case's); only the
    number and order of joints matter, since the geometry is the same for any settings.
    The view is the model's camera ``front`` (``oblique`` for a mechanism with points out of
    its plane, so the eyelets' depth shows, with a floor grid and an axis triad), moved so
    that it frames every point's sweep over a period in this width and height (below the
    overlay line), with sites and the thread tendon shown; the key point's path over the last
    period trails it, fading; time, crank angle, speed (rpm, CCW or CW) and the slow-motion
    factor are written at the top of every frame.

    The file is written to a temporary name in the same folder and renamed at the end, so
    ``path`` is either complete or untouched. With ``progress``, a frame counter goes to
    stderr once rendering has taken more than about 1 s. ``held`` holds SIGINT and SIGTERM back
    while a GL context is made (:data:`Held`).

    Raises :class:`RenderError` if the trace cannot be rendered, no OpenGL context can be
    made or encoding fails, :class:`OutputError` if the folder cannot be written.
    """
    path = Path(path)
    n = round(seconds * fps)
    if not (np.isfinite(seconds) and np.isfinite(fps) and fps > 0 and n >= 1):
        raise RenderError(f"a video needs at least one frame: seconds = {seconds:g} s at fps = {fps:g} frames/s")
    if width <= 0 or height <= 0 or width % 2 or height % 2:
        raise RenderError(
            f"video size {width}x{height} pixels: width and height must be positive and even (H.264 yuv420p)"
        )
    times, qpos = frame_qpos(trace, n)
    backend = ensure_gl_backend()
    built = builder.make(mech, settings or simulate.kinematic_case(mech).settings)
    model = built.model
    if qpos.shape[1] != model.nq:
        raise RenderError(
            f"{mech.name}: the trace has {qpos.shape[1]} joint positions per sample, the model has "
            f"{model.nq}: was it run on another mechanism?"
        )
    spatial = analysis.is_spatial(mech)
    camera = built.oblique if spatial else built.front
    # Framed on what every point sweeps over a period, for this video's aspect ratio.
    sweep = reference.solve(mech, mech.phi0 + np.linspace(0.0, mech.period, 73), check=False)
    pts = np.concatenate([v.v for v in sweep.points.values()])
    pts = pts[np.all(np.isfinite(pts), axis=1)]
    axes = np.zeros(9)
    mujoco.mju_quat2Mat(axes, model.cam_quat[camera])  # the builder's cameras sit on the world body
    axes = axes.reshape(3, 3)
    band = 2.3 * OVERLAY_HEIGHT * (2 if spatial else 1)
    model.cam_pos[camera] = frame_camera(pts, axes, width / height, float(model.cam_fovy[camera]), band)
    size = float(np.max(np.ptp(pts, axis=0)))
    span = float(trace.time[-1] - trace.time[0])
    time_scale = (n / fps) / span
    key, _, trail = key_path(mech, trace, times)
    lines = overlay_lines(trace, times, time_scale, mech.phi0)
    if spatial:
        for row in lines:
            row.append("axes: x red, y green, z blue; floor grid under the mechanism")
    extras = Extras(
        key=key, trail=trail, size=size, lo=pts.min(axis=0), hi=pts.max(axis=0), spatial=spatial, lines=lines
    )
    # The builder sizes the offscreen buffer for 1080p; a larger video only needs a larger one.
    model.vis.global_.offwidth = max(int(model.vis.global_.offwidth), width)
    model.vis.global_.offheight = max(int(model.vis.global_.offheight), height)
    data = mujoco.MjData(model)
    option = mujoco.MjvOption()
    option.sitegroup[:] = 1  # points (eyelet, pivots) are sites; not every group is on by default
    option.sitegroup[builder.SENSOR_SITE_GROUP] = 0  # sites that only carry sensors
    option.tendongroup[:] = 1

    if not path.parent.is_dir():
        raise OutputError(f"{path}: folder {path.parent} does not exist")

    with atomic_path(path, suffix=".mp4") as tmp:
        _frames(model, data, qpos, camera, extras, option, tmp, fps, width, height, backend, progress, held)
    return VideoInfo(path=path, frames=n, fps=fps, width=width, height=height, time_scale=time_scale, backend=backend)


def render_frames(
    model: mujoco.MjModel,
    qpos: np.ndarray,
    camera: str,
    path: str | os.PathLike,
    *,
    fps: float,
    width: int,
    height: int,
    lines: list[list[str]],
    held: Held | None = None,
) -> VideoInfo:
    """Render ``model`` at each of its joint positions ``qpos`` (F, nq), seen from its camera
    ``camera``, to an MP4 at ``path`` (complete or untouched, as :func:`render_video`), with
    ``lines`` written on each frame."""
    path = Path(path)
    n = len(qpos)
    if n < 1 or width <= 0 or height <= 0 or width % 2 or height % 2:
        raise RenderError(f"a video needs frames and an even size: {n} frames, {width}x{height} pixels")
    if not path.parent.is_dir():
        raise OutputError(f"{path}: folder {path.parent} does not exist")
    backend = ensure_gl_backend()
    model.vis.global_.offwidth = max(int(model.vis.global_.offwidth), width)
    model.vis.global_.offheight = max(int(model.vis.global_.offheight), height)
    zero = np.zeros(3)
    # Nothing beyond the model: no trail, a backdrop far below the view.
    extras = Extras(
        key="", trail=np.zeros((n, 2, 3)), size=1.0, lo=zero - 10.0, hi=zero - 10.0, spatial=False, lines=lines
    )
    with atomic_path(path, suffix=".mp4") as tmp:
        _frames(
            model,
            mujoco.MjData(model),
            qpos,
            model.camera(camera).id,
            extras,
            mujoco.MjvOption(),
            tmp,
            fps,
            width,
            height,
            backend,
            False,
            held or contextlib.nullcontext,
        )
    return VideoInfo(path=path, frames=n, fps=fps, width=width, height=height, time_scale=1.0, backend=backend)


@dataclass(frozen=True, kw_only=True)
class Extras:
    """What a frame shows beyond the model: the key point's trail (frames, samples, 3) m, the
    swept box (m) for the floor grid and axis triad of a 3D view, the overlay text per frame."""

    key: str
    trail: np.ndarray
    size: float
    lo: np.ndarray
    hi: np.ndarray
    spatial: bool
    lines: list[list[str]]


_ZERO3 = np.zeros(3)
_EYE = np.eye(3).ravel()  # read only by mjv_initGeom: one array for every geom


def _segment(scene, kind: int, a: np.ndarray, b: np.ndarray, width: float, rgba) -> None:
    """Append one connector geom (capsule, line or arrow from ``a`` to ``b``, m) to ``scene``."""
    if scene.ngeom >= scene.maxgeom:
        return
    g = scene.geoms[scene.ngeom]
    mujoco.mjv_initGeom(g, kind, _ZERO3, _ZERO3, _EYE, np.asarray(rgba, dtype=np.float32))
    mujoco.mjv_connector(g, kind, width, a, b)
    g.category = int(mujoco.mjtCatBit.mjCAT_DECOR)
    scene.ngeom += 1


def _decorate(scene, extras: Extras, i: int) -> None:
    """A light backdrop behind the mechanism, the fading trail of the key point up to frame
    ``i``, and for a 3D view a floor grid under the mechanism and an axis triad at the swept
    box's corner."""
    if scene.ngeom < scene.maxgeom:
        c = 0.5 * (extras.lo + extras.hi)
        g = scene.geoms[scene.ngeom]
        mujoco.mjv_initGeom(
            g,
            mujoco.mjtGeom.mjGEOM_BOX,
            np.array([40.0 * extras.size, 40.0 * extras.size, 1e-3 * extras.size]),
            np.array([c[0], c[1], extras.lo[2] - 0.25 * extras.size]),
            _EYE,
            np.array([0.86, 0.87, 0.9, 1.0], dtype=np.float32),
        )
        g.category = int(mujoco.mjtCatBit.mjCAT_DECOR)
        scene.ngeom += 1
    tr = extras.trail[i]
    r, g, b, _ = palette.rgba(palette.KEY_PATH)
    k = len(tr) - 1
    moved = np.abs(np.diff(tr, axis=0)).max(axis=1) > 1e-9 * extras.size  # the trail before t0 repeats its start
    for j in np.flatnonzero(moved):
        alpha = 0.08 + 0.92 * (j + 1) / k
        # Lines, not capsules: a capsule per segment doubles a software-rendered frame.
        _segment(scene, mujoco.mjtGeom.mjGEOM_LINE, tr[j], tr[j + 1], 3.0, (r, g, b, alpha))
    if not extras.spatial:
        return
    lo, hi, s = extras.lo, extras.hi, extras.size
    y = lo[1] - 0.08 * s
    x0, x1, z0, z1 = lo[0] - 0.1 * s, hi[0] + 0.1 * s, lo[2] - 0.1 * s, hi[2] + 0.1 * s
    step = 10 ** math.floor(math.log10(s / 4))  # a round grid pitch: 1, 10 or 100 mm
    grey = (0.45, 0.45, 0.5, 0.6)
    for x in np.arange(math.ceil(x0 / step) * step, x1, step):
        _segment(scene, mujoco.mjtGeom.mjGEOM_LINE, np.array([x, y, z0]), np.array([x, y, z1]), 1.0, grey)
    for z in np.arange(math.ceil(z0 / step) * step, z1, step):
        _segment(scene, mujoco.mjtGeom.mjGEOM_LINE, np.array([x0, y, z]), np.array([x1, y, z]), 1.0, grey)
    o = np.array([x0, y, z0])
    for axis, rgba in enumerate(((0.85, 0.1, 0.1, 1.0), (0.1, 0.65, 0.1, 1.0), (0.1, 0.2, 0.9, 1.0))):
        e = np.zeros(3)
        e[axis] = 0.18 * s
        _segment(scene, mujoco.mjtGeom.mjGEOM_ARROW, o, o + e, 0.012 * s, rgba)


def _overlay(frame: np.ndarray, lines: list[str], font) -> np.ndarray:
    """``lines`` written in the frame's top-left corner on a translucent white box."""
    from PIL import Image, ImageDraw  # here: only for a video's overlay

    img = Image.fromarray(frame)
    d = ImageDraw.Draw(img, "RGBA")
    pad = max(4, font.size // 3)
    boxes = [d.textbbox((0, 0), t, font=font) for t in lines]
    w = max(b[2] for b in boxes) + 2 * pad
    h = int(len(lines) * font.size * 1.25) + 2 * pad
    d.rectangle([0, 0, w, h], fill=(255, 255, 255, 200))
    for k, t in enumerate(lines):
        d.text((pad, pad + k * font.size * 1.25), t, fill=(20, 20, 20, 255), font=font)
    return np.asarray(img)


def _frames(
    model,
    data,
    qpos,
    camera: int,
    extras: Extras,
    option,
    tmp: Path,
    fps: float,
    width: int,
    height: int,
    backend: str,
    progress: bool,
    held: Held,
) -> None:
    """Render every frame into an H.264 file at ``tmp`` (complete when this returns)."""
    n = len(qpos)
    renderer = writer = None
    shown = False
    try:
        # A software rasterizer (Mesa llvmpipe, OSMesa: every machine here) pays for 4x
        # multisampling in every frame, for an image that changes by 0.4/255 on average at
        # these line widths: the first context is made without it, and only a hardware one is
        # made again with the model's setting.
        samples = int(model.vis.quality.offsamples)
        model.vis.quality.offsamples = 0
        # Capsules and cylinders with 16 slices and 8 stacks instead of MuJoCo's 28 and 16: a
        # cheaper software-rendered frame, 0.12/255 of image change on average (0.5 % of
        # the pixels by more than 8/255, along the links' outlines) at these sizes.
        slices = (int(model.vis.quality.numslices), int(model.vis.quality.numstacks))
        model.vis.quality.numslices, model.vis.quality.numstacks = min(slices[0], 16), min(slices[1], 8)
        # No shadow map either: shadows are switched off below, and MuJoCo would still
        # allocate the 4096^2 map with the context, for nothing.
        model.vis.quality.shadowsize = 0
        if not hasattr(mujoco, "GLContext"):  # MUJOCO_GL turned OpenGL off
            raise context_failure(backend, None)
        try:
            renderer = _new_renderer(model, height, width, held)
        except ImportError as e:  # the backend's library is missing (mujoco's placeholder context)
            raise context_failure(backend, e) from None
        except Exception as e:
            hint = (
                (
                    "; mujoco was imported before ensure_gl_backend() and chose glfw: call "
                    "mjlink.render.ensure_gl_backend() first or set MUJOCO_GL=egl"
                )
                if backend == "glfw"
                else ""
            )
            raise RenderError(
                f"cannot create a {width}x{height} offscreen renderer with MUJOCO_GL={backend}: {_clip(e)}{hint}"
            ) from e
        if samples and not _software_gl():
            # A hardware context can afford the model's antialiasing: made again with it.
            renderer.close()
            model.vis.quality.offsamples = samples
            model.vis.quality.numslices, model.vis.quality.numstacks = slices
            renderer = _new_renderer(model, height, width, held)
        # The planar linkage has no surface for shadows to fall on (<0.1 % of pixels change),
        # yet a software (Mesa) renderer would draw the 4096^2 shadow map for every frame.
        renderer.scene.flags[mujoco.mjtRndFlag.mjRND_SHADOW] = False
        # The skybox's textured sphere would be rasterized in software for every frame:
        # a flat backdrop behind the mechanism gives the same light ground (_decorate).
        renderer.scene.flags[mujoco.mjtRndFlag.mjRND_SKYBOX] = False
        from PIL import ImageFont  # here: only for a video's overlay

        font = ImageFont.load_default(size=max(10, round(OVERLAY_HEIGHT * height * 0.8)))
        writer = _open_writer(tmp, fps)
        start = last = time.monotonic()
        for i in range(n):
            data.qpos[:] = qpos[i]
            mujoco.mj_forward(model, data)
            try:
                renderer.update_scene(data, camera=camera, scene_option=option)
                _decorate(renderer.scene, extras, i)
                frame = _overlay(renderer.render(), extras.lines[i], font)
            except Exception as e:
                raise RenderError(f"rendering frame {i + 1}/{n} failed: {_clip(e)}") from e
            try:
                writer.append_data(frame)
            except Exception as e:
                raise RenderError(f"video encoding failed at frame {i + 1}/{n}: {_clip(e)}") from e
            now = time.monotonic()
            if progress and now - start > PROGRESS_AFTER and (now - last > 0.2 or i == n - 1):
                print(f"\r  video {i + 1}/{n} frames", end="", file=sys.stderr, flush=True)
                shown, last = True, now
        try:
            w, writer = writer, None
            w.close()  # flushes ffmpeg: the file is only complete after this
        except Exception as e:
            raise RenderError(f"video encoding failed while finishing the video: {_clip(e)}") from e
    except BaseException:
        # Also on KeyboardInterrupt: the encoder must stop before the half file is removed.
        if writer is not None:
            with contextlib.suppress(Exception):
                writer.close()
        raise
    finally:
        if renderer is not None:
            with contextlib.suppress(Exception):
                renderer.close()
        if shown:
            print(file=sys.stderr, flush=True)


def _gl_renderer() -> bytes:
    """GL_RENDERER of the current OpenGL context (b"" if none can be read): through the GL
    library's C entry point, which is cheaper than importing PyOpenGL's GL module; PyOpenGL where
    neither library loads (a system without glvnd's libOpenGL or libGL, e.g. macOS)."""
    osmesa = os.environ.get("MUJOCO_GL", "").lower() == "osmesa"  # its own GL entry points
    for lib in ("libOSMesa.so.8", "libOSMesa.so") if osmesa else ("libOpenGL.so.0", "libGL.so.1"):
        try:
            get = ctypes.CDLL(lib).glGetString
        except (OSError, AttributeError):
            continue
        get.restype, get.argtypes = ctypes.c_char_p, [ctypes.c_uint]
        name = get(0x1F01)  # GL_RENDERER
        if name:
            return name
    from OpenGL import GL  # here: only to name the renderer

    name = GL.glGetString(GL.GL_RENDERER) or b""
    return name if isinstance(name, bytes) else str(name).encode()


def _software_gl() -> bool:
    """Whether the current OpenGL context renders in software (Mesa's llvmpipe or softpipe,
    OSMesa, SwiftShader): read from GL_RENDERER once a context is current."""
    try:
        name = _gl_renderer()
    except Exception:  # no GL library or no current context: keep the model's setting
        return False
    text = name.decode("ascii", "replace").lower()
    return any(k in text for k in ("llvmpipe", "softpipe", "swrast", "swiftshader", "software"))


def _open_writer(path: Path, fps: float):
    """An imageio ffmpeg writer for H.264 yuv420p at ``fps`` frames/s."""
    try:
        import imageio.v2 as iio  # here: only for a video
    except ImportError as e:
        raise RenderError(
            f"cannot encode video: imageio is not installed ({e}); pip install imageio imageio-ffmpeg"
        ) from e
    try:
        # macro_block_size=2: sizes are already even, so imageio must not rescale the frames.
        # x264's "veryfast" preset: the same file size at this quality for less of the
        # encoder's CPU than its default preset.
        # One encoder thread: the frames come no faster than one thread encodes them, the
        # other core is drawing figures, and x264's threads decide differently with the
        # number of cores: with one, the same frames give the same file on every machine.
        return iio.get_writer(
            path,
            format="FFMPEG",
            mode="I",
            fps=fps,
            codec="libx264",
            quality=8,
            pixelformat="yuv420p",
            macro_block_size=2,
            ffmpeg_log_level="error",
            ffmpeg_params=["-preset", "veryfast", "-threads", "1"],
        )
    except Exception as e:
        raise RenderError(f"cannot start the video encoder: {_clip(e)}") from e
