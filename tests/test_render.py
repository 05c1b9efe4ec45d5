"""Offscreen rendering: backend choice and the MP4 of takeup's kinematic cycle.

MuJoCo fixes its OpenGL backend when first imported, so the backend is chosen here before
``mjlink.simulate`` imports mujoco. If another test module imported mujoco first (with
``MUJOCO_GL`` unset it then picks glfw, which needs a display), the video is rendered in a
fresh interpreter instead; decoding and checks always run here.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from mjlink.sim import gl

BACKEND = gl.ensure_gl_backend()

from mjlink.errors import RenderError  # noqa: E402
from mjlink.model import mechanism  # noqa: E402
from mjlink.sim import render, simulate  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
TAKEUP = ROOT / "mechanisms" / "takeup.toml"
SECONDS, FPS, WIDTH, HEIGHT = 1.0, 30, 320, 240
FRAMES = round(SECONDS * FPS)
IN_PROCESS = BACKEND not in ("glfw", "none") or bool(os.environ.get("DISPLAY"))


def _env(**overrides: str | None) -> dict[str, str]:
    """This process's environment with the repo importable and ``overrides`` applied (None unsets)."""
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(p for p in (str(ROOT), env.get("PYTHONPATH", "")) if p)
    for k, v in overrides.items():
        if v is None:
            env.pop(k, None)
        else:
            env[k] = v
    return env


def _python(code: str, **env: str | None) -> str:
    res = subprocess.run(
        [sys.executable, "-c", textwrap.dedent(code)],
        env=_env(**env),
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert res.returncode == 0, res.stderr
    return res.stdout.strip().splitlines()[-1]


@pytest.fixture(scope="module")
def mech():
    return mechanism.load(TAKEUP)


@pytest.fixture(scope="module")
def trace(mech):
    return simulate.run(mech, simulate.kinematic_case(mech))


@pytest.fixture(scope="module")
def video(mech, trace, tmp_path_factory):
    folder = tmp_path_factory.mktemp("video")
    path = folder / "takeup.mp4"
    if IN_PROCESS:
        info = render.render_video(
            mech, trace, path, seconds=SECONDS, fps=FPS, width=WIDTH, height=HEIGHT, progress=False
        )
        fields = dict(
            frames=info.frames,
            fps=info.fps,
            width=info.width,
            height=info.height,
            time_scale=info.time_scale,
            backend=info.backend,
            path=str(info.path),
        )
    else:
        fields = json.loads(
            _python(
                f"""
            import json
            from mjlink.sim import gl, render
            gl.ensure_gl_backend()
            from mjlink.model import mechanism
            from mjlink.sim import simulate
            m = mechanism.load({str(TAKEUP)!r})
            tr = simulate.run(m, simulate.kinematic_case(m))
            i = render.render_video(m, tr, {str(path)!r}, seconds={SECONDS}, fps={FPS}, width={WIDTH},
                                    height={HEIGHT}, progress=False)
            print(json.dumps(dict(frames=i.frames, fps=i.fps, width=i.width, height=i.height,
                                  time_scale=i.time_scale, backend=i.backend, path=str(i.path))))
            """,
                MUJOCO_GL=None,
            )
        )
    return path, fields


@pytest.fixture(scope="module")
def frames(video):
    import imageio.v2 as iio

    reader = iio.get_reader(video[0], "ffmpeg")
    try:
        return np.stack([np.asarray(f) for f in reader])
    finally:
        reader.close()


def test_video_info(video, trace):
    path, info = video
    assert Path(info["path"]) == path
    assert (info["frames"], info["fps"], info["width"], info["height"]) == (FRAMES, FPS, WIDTH, HEIGHT)
    span = trace.time[-1] - trace.time[0]
    assert info["time_scale"] == pytest.approx(SECONDS / span, rel=1e-9)
    assert info["backend"]


def test_frame_count_and_size(frames):
    assert frames.shape == (FRAMES, HEIGHT, WIDTH, 3)


def test_frames_are_not_blank(frames):
    for i, f in enumerate(frames):
        assert f.std() > 5.0, f"frame {i} is nearly a single colour"
        # Colours binned by 32 per channel, as one code each (8 x 8 x 8 bins), then counted.
        q = (f // 32).astype(np.intp)
        bins = np.count_nonzero(np.bincount((q[..., 0] * 64 + q[..., 1] * 8 + q[..., 2]).ravel(), minlength=512))
        assert bins > 4, f"frame {i} has almost no colours"


def test_mechanism_moves(frames):
    f = frames.astype(np.int16)
    step = np.abs(np.diff(f, axis=0)).max(axis=3)
    moved = (step > 40).mean(axis=(1, 2))  # fraction of pixels that change clearly between frames
    assert moved.min() > 1e-3, f"frames {int(moved.argmin())} and {int(moved.argmin()) + 1} are the same"
    half = np.abs(f[0] - f[FRAMES // 2]).max(axis=2)
    assert (half > 40).mean() > 5e-3, "half a cycle apart, the first and middle frames should differ substantially"


def test_only_the_video_is_left(video):
    path, _ = video
    assert path.is_file() and path.stat().st_size > 0
    assert sorted(p.name for p in path.parent.iterdir()) == [path.name]


@pytest.mark.skipif(not IN_PROCESS, reason="mujoco was imported before the backend could be chosen")
def test_failed_encoding_leaves_old_file_and_no_temp(mech, trace, tmp_path, monkeypatch):
    path = tmp_path / "takeup.mp4"
    path.write_bytes(b"old")

    class Broken:
        def append_data(self, frame):
            raise BrokenPipeError("ffmpeg died")

        def close(self):
            pass

    monkeypatch.setattr(render, "_open_writer", lambda tmp, fps: Broken())
    with pytest.raises(RenderError, match="encoding failed at frame 1/"):
        render.render_video(mech, trace, path, seconds=0.2, fps=10, width=64, height=48, progress=False)
    assert path.read_bytes() == b"old"
    assert [p.name for p in tmp_path.iterdir()] == ["takeup.mp4"]


def test_bad_arguments(mech, trace, tmp_path):
    with pytest.raises(RenderError, match="even"):
        render.render_video(mech, trace, tmp_path / "v.mp4", width=321, height=240, progress=False)
    with pytest.raises(RenderError, match="at least one frame"):
        render.render_video(mech, trace, tmp_path / "v.mp4", seconds=0.0, progress=False)
    ref = simulate.Trace(
        source="reference",
        kind="kinematics",
        time=trace.time,
        phi=trace.phi,
        omega=trace.omega,
        eps=trace.eps,
        points={},
        velocities={},
        accelerations={},
    )
    with pytest.raises(RenderError, match="no joint positions"):
        render.render_video(mech, ref, tmp_path / "v.mp4", progress=False)
    assert list(tmp_path.iterdir()) == []


def test_frame_times_loop(trace):
    times, q = render.frame_qpos(trace, 10)
    span = trace.time[-1] - trace.time[0]
    assert times[0] == trace.time[0] and times[-1] == pytest.approx(trace.time[0] + 0.9 * span)
    assert q.shape == (10, trace.qpos.shape[1])
    np.testing.assert_allclose(q[0], trace.qpos[0])


def test_preset_mujoco_gl_is_respected():
    out = _python(
        """
        import os, sys
        from mjlink.sim import gl
        print(gl.ensure_gl_backend(), os.environ['MUJOCO_GL'], 'mujoco' in sys.modules)
        """,
        MUJOCO_GL="osmesa",
    )
    assert out == "osmesa osmesa False"


def test_probe_sets_backend_without_importing_mujoco():
    out = _python(
        """
        import os, sys
        from mjlink.sim import gl
        b = gl.ensure_gl_backend()
        print(b, os.environ.get('MUJOCO_GL'), 'mujoco' in sys.modules, gl.ensure_gl_backend() == b)
        """,
        MUJOCO_GL=None,
    )
    backend, env, imported, cached = out.split()
    assert backend in gl.PROBE_ORDER and env == backend
    assert (imported, cached) == ("False", "True")


def test_in_process_egl_probe_agrees_with_mujoco_in_a_fresh_interpreter():
    """The EGL probe by the C library in this process (no interpreter started) says yes exactly
    where mujoco itself, imported with MUJOCO_GL=egl, makes a context current."""
    fast = _python(
        """
        import sys
        from mjlink.sim import gl
        print(gl._egl_in_process() is None, 'mujoco' in sys.modules, 'OpenGL' in sys.modules)
        """,
        MUJOCO_GL="osmesa",  # chosen by the environment: importing mjlink.sim probes nothing
    )
    plain = subprocess.run(
        [sys.executable, "-c", gl._PROBE_CODE], env=_env(MUJOCO_GL="egl"), capture_output=True, timeout=60
    )
    assert fast == f"{plain.returncode == 0} False False"


def test_already_imported_mujoco_reports_its_choice():
    out = _python(
        """
        import os, mujoco
        from mjlink.sim import gl
        print(gl.ensure_gl_backend(), os.environ.get('MUJOCO_GL'))
        """,
        MUJOCO_GL=None,
    )
    assert out == "glfw None"


def test_overlay_text_is_in_every_frame(frames):
    """The top band carries the time, angle and speed: it changes from frame to frame (the
    numbers), while a band of the same height lower in the frame, away from the text, is
    the rendered scene's; and the overlay itself writes dark text on a light box."""
    band = max(8, round(2.3 * render.OVERLAY_HEIGHT * HEIGHT))
    top = frames[:, :band, : WIDTH // 2].astype(float)
    assert np.abs(top[0] - top[len(top) // 2]).mean() > 1.0, "the overlay's numbers do not change"
    # Text is dark on the light box: the top-left band holds near-black pixels.
    assert (top[0].min(axis=-1) < 80).mean() > 0.01


def test_overlay_writes_only_its_corner():
    from PIL import ImageFont

    blank = np.full((HEIGHT, WIDTH, 3), 128, np.uint8)
    font = ImageFont.load_default(size=12)
    out = render._overlay(blank, ["t 0.0100 s   phi1 90.0 deg   n1 955 rpm CCW   slow motion 47.7x"], font)
    changed = np.any(out != blank, axis=-1)
    rows, cols = np.nonzero(changed)
    assert changed.sum() > 200  # the text and its box are drawn
    assert rows.max() < 3 * 12 and cols.min() == 0  # only in the top-left band


def test_camera_frames_the_swept_box():
    """frame_camera puts every point inside the frame (below the overlay band) for 4:3 and 16:9."""
    rng = np.random.default_rng(1)
    pts = rng.uniform(-0.05, 0.08, size=(200, 3)) * [1.0, 0.6, 0.1]
    axes = np.eye(3)  # looking down -Z, Y up
    for aspect in (4 / 3, 16 / 9):
        fovy, band = 40.0, 0.08
        pos = render.frame_camera(pts, axes, aspect, fovy, band)
        rel = pts - pos
        depth = -rel[:, 2]
        x = rel[:, 0] / depth / np.tan(np.radians(fovy) / 2) / aspect
        y = rel[:, 1] / depth / np.tan(np.radians(fovy) / 2)
        assert np.all(np.abs(x) <= 1.0) and np.all(y >= -1.0) and np.all(y <= 1.0 - 2 * band + 1e-9)
        assert max(np.abs(x).max(), (y.max() - y.min()) / (2 - 2 * band)) > 0.85  # and fills it


def test_trail_follows_the_key_point(mech, trace):
    times = np.linspace(trace.time[0], trace.time[-1], 7, endpoint=False)
    key, now, trail = render.key_path(mech, trace, times)
    assert key == "P5"
    assert trail.shape == (7, render.TRAIL_SAMPLES, 3)
    np.testing.assert_allclose(trail[:, -1], now, atol=1e-12)  # the trail ends at the point


@pytest.mark.skipif(not hasattr(os, "sched_setaffinity"), reason="needs CPU affinity (Linux)")
def test_video_file_is_the_same_on_one_core_or_all():
    """The encoder's output depends on the frames alone: x264 decides differently with the
    number of threads it runs, so mjlink runs one, and a machine's core count does not change
    the MP4 (encoded here with this process on one core, then on all of them)."""
    import tempfile

    cpus = os.sched_getaffinity(0)
    if len(cpus) < 2:
        pytest.skip("one core: nothing to compare")
    rng = np.random.default_rng(3)
    base = rng.integers(0, 255, size=(240, 320, 3), dtype=np.uint8)
    frames = [np.roll(base, 4 * i, axis=1) for i in range(30)]

    def encode(path: Path) -> bytes:
        w = render._open_writer(path, 30)
        for f in frames:
            w.append_data(f)
        w.close()
        return path.read_bytes()

    with tempfile.TemporaryDirectory() as tmp:
        everywhere = encode(Path(tmp) / "all.mp4")
        os.sched_setaffinity(0, {min(cpus)})
        try:
            one = encode(Path(tmp) / "one.mp4")
        finally:
            os.sched_setaffinity(0, cpus)
    assert one == everywhere


def test_a_signal_while_the_renderer_is_made_acts_once_it_exists(monkeypatch):
    """SIGTERM (or Ctrl-C) landing inside the GL context's constructor would leave a half-made
    context whose ``__del__`` prints an AttributeError after the run's one-line message (mujoco
    3.8's EGL context): the renderer is made whole first, then the handler runs (with the
    holding the command line passes)."""
    import signal

    from mjlink.runtime.signals import uninterrupted

    made: list[object] = []

    class Renderer:
        def __init__(self, model, height, width):
            os.kill(os.getpid(), signal.SIGTERM)
            for _ in range(1000):  # bytecode boundaries at which a handler would run
                pass
            self._context = "made"
            made.append(self)

    def handler(signum, frame):
        raise RuntimeError(f"signal {signum}, {len(made)} made")

    monkeypatch.setattr(render.mujoco, "Renderer", Renderer)
    old = signal.signal(signal.SIGTERM, handler)
    try:
        with pytest.raises(RuntimeError, match="1 made"):
            render._new_renderer(None, 16, 16, uninterrupted)
    finally:
        signal.signal(signal.SIGTERM, old)
    assert len(made) == 1
