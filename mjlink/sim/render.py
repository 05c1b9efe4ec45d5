"""Offscreen rendering of a MuJoCo trace to an MP4 video.

Two steps, in this order:

1. :func:`mjlink.sim.gl.ensure_gl_backend` has picked the offscreen OpenGL backend when
   :mod:`mjlink.sim` was imported.
2. :func:`render_video` replays a trace's joint positions through the model's fixed camera
   ``front`` and encodes the frames as H.264 (yuv420p) with imageio's ffmpeg.

Units: times s, frame rates frames/s, sizes pixels; the trace is in SI units.
"""

from __future__ import annotations

import contextlib
import os
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np

from .. import output, reference
from ..errors import OutputError, RenderError
from ..model.mechanism import Mechanism
from ..runs import Settings, Trace
from . import builder, simulate
from .gl import _clip, ensure_gl_backend


def _is_3d(mech) -> bool:
    """Whether any point leaves the mechanism's plane (z != 0)."""
    k = reference.solve(mech, [mech.phi0])
    return any(abs(v.v[0, 2]) > 1e-9 for v in k.points.values())


PROGRESS_AFTER = 1.0  # s of rendering before a progress line is worth printing


# ----------------------------------------------------------------------------- video
@dataclass(frozen=True)
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
) -> VideoInfo:
    """Render ``trace`` of ``mech`` to an MP4 (H.264, yuv420p) at ``path``.

    ``seconds`` video duration (s) over which the whole trace is played, ``fps`` frames/s,
    ``width`` and ``height`` pixels (even; beyond 1920x1080 the GL driver's limits apply).
    ``settings`` those the trace was run with (default: the kinematic case's); only the
    number and order of joints matter, since the geometry is the same for any settings.
    The view is the model's fixed camera ``front`` (``oblique`` for a mechanism with points
    out of its plane, so the eyelets' depth shows) with sites and the thread tendon shown.

    The file is written to a temporary name in the same folder and renamed at the end, so
    ``path`` is either complete or untouched. With ``progress``, a frame counter goes to
    stderr once rendering has taken more than about 1 s.

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
    _, qpos = frame_qpos(trace, n)
    backend = ensure_gl_backend()
    built = builder.make(mech, settings or simulate.kinematic_case(mech).settings)
    model = built.model
    if qpos.shape[1] != model.nq:
        raise RenderError(
            f"{mech.name}: the trace has {qpos.shape[1]} joint positions per sample, the model has "
            f"{model.nq}: was it run on another mechanism?"
        )
    # A mechanism with points out of its plane (eyelets in depth) is shown obliquely.
    camera = built.oblique if _is_3d(mech) else built.front
    # The builder sizes the offscreen buffer for 1080p; a larger video only needs a larger one.
    model.vis.global_.offwidth = max(int(model.vis.global_.offwidth), width)
    model.vis.global_.offheight = max(int(model.vis.global_.offheight), height)
    data = mujoco.MjData(model)
    option = mujoco.MjvOption()
    option.sitegroup[:] = 1  # points (eyelet, pivots) are sites; not every group is on by default
    option.tendongroup[:] = 1

    if not path.parent.is_dir():
        raise OutputError(f"{path}: folder {path.parent} does not exist")

    with output.atomic_path(path, suffix=".mp4") as tmp:
        _frames(model, data, qpos, camera, option, tmp, fps, width, height, backend, progress)
    span = float(trace.time[-1] - trace.time[0])
    return VideoInfo(path, n, fps, width, height, (n / fps) / span, backend)


def _frames(
    model, data, qpos, camera: int, option, tmp: Path, fps: float, width: int, height: int, backend: str, progress: bool
) -> None:
    """Render every frame into an H.264 file at ``tmp`` (complete when this returns)."""
    n = len(qpos)
    renderer = writer = None
    shown = False
    try:
        try:
            renderer = mujoco.Renderer(model, height, width)
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
        # The planar linkage has no surface for shadows to fall on (<0.1 % of pixels change),
        # yet the 4096^2 shadow map costs ~2/3 of a frame on a software (Mesa) renderer.
        renderer.scene.flags[mujoco.mjtRndFlag.mjRND_SHADOW] = False
        writer = _open_writer(tmp, fps)
        start = last = time.monotonic()
        for i in range(n):
            data.qpos[:] = qpos[i]
            mujoco.mj_forward(model, data)
            try:
                renderer.update_scene(data, camera=camera, scene_option=option)
                frame = renderer.render()
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


def _open_writer(path: Path, fps: float):
    """An imageio ffmpeg writer for H.264 yuv420p at ``fps`` frames/s."""
    try:
        import imageio.v2 as iio
    except ImportError as e:
        raise RenderError(
            f"cannot encode video: imageio is not installed ({e}); pip install imageio imageio-ffmpeg"
        ) from e
    try:
        # macro_block_size=2: sizes are already even, so imageio must not rescale the frames.
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
        )
    except Exception as e:
        raise RenderError(f"cannot start the video encoder: {_clip(e)}") from e
