"""The subcommands, each registered once in :data:`COMMANDS`.

A :class:`Command` is its name and help, a function adding its arguments to its parser and a
function that runs it: it checks the values argparse cannot (ranges, combinations), makes one
call into :mod:`mjlink.pipeline`, prints the result (:mod:`.text`) and returns the exit status.
:mod:`mjlink.pipeline` imports MuJoCo, so it is imported inside the commands that need it:
``list``, ``check`` and ``--help`` stay quick.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from .. import validation
from ..errors import MjlinkError
from ..model.limits import MAX_CYCLES
from . import text

if TYPE_CHECKING:
    from ..pipeline import Drive

EXAMPLES = """\
examples:
  python -m mjlink list
  python -m mjlink simulate takeup                     # everything into renders/takeup/
  python -m mjlink simulate takeup --no-video --out /tmp/runs
  python -m mjlink simulate my_linkage.toml --speed 50 --cycles 2
  python -m mjlink simulate warp_knitting --phi01 -90 --phi04 30   # another crank setting
  python -m mjlink build takeup -o takeup.xml          # MJCF for plain mujoco.MjModel.from_xml_path
  python -m mjlink synth crank_slider --stroke 45 --offset 15 --lambda 0.35 --max-pressure-angle 40
  python -m mjlink simulate takeup --dynamics          # + steady motion and flywheel study
  python -m mjlink simulate crank_slider --dynamics --stall-torque -0.8 --no-load-speed -160 --duration 2
  python -m mjlink torque warp_knitting --speed 1000    # driving torque at 1000 rpm
  python -m mjlink reactions takeup --speed 955         # forces in every kinematic pair
  python -m mjlink steady takeup --target-delta 0.01    # speed fluctuation and flywheel
"""

MAX_VIDEO_SIZE = (1920, 1080)  # pixels: the offscreen buffer the builder sizes the model for


@dataclass(frozen=True)
class Command:
    """One subcommand: ``name`` and ``help`` as the command list shows them, ``epilog`` the
    examples under its own ``--help``, ``arguments`` adds its arguments to its parser, ``run``
    does it and prints, returning the exit status (0; 3 for a missed threshold with --strict)."""

    name: str
    help: str
    epilog: str
    arguments: Callable[[argparse.ArgumentParser], None]
    run: Callable[[argparse.Namespace], int]


# ----------------------------------------------------------------------------- shared
def _mechanism(p: argparse.ArgumentParser) -> None:
    p.add_argument("mechanism", help="registered name (see 'list') or path to a .toml file")


def _drive_options(p: argparse.ArgumentParser) -> None:
    p.add_argument("--moment", type=float, metavar="N_M", help="constant driving moment on the crank, N*m")
    p.add_argument(
        "--stall-torque",
        type=float,
        metavar="N_M",
        help="motor characteristic: torque at rest, N*m (with --no-load-speed)",
    )
    p.add_argument(
        "--no-load-speed",
        type=float,
        metavar="RAD_S",
        help="motor characteristic: speed at which the torque falls to zero, rad/s",
    )
    p.add_argument("--damping", type=float, metavar="N_M_S", help="viscous damping on the crank, N*m*s")
    p.add_argument("--omega0", type=float, metavar="RAD_S", help="initial crank speed of the dynamic run, rad/s")
    p.add_argument("--target-delta", type=float, help="target speed fluctuation for the flywheel (steady study)")


def _drive(args: argparse.Namespace) -> Drive:
    """The drive options a command has (the others None); :func:`pipeline.with_drive` checks them."""
    from ..pipeline import Drive

    return Drive(
        **{
            k: getattr(args, k, None)
            for k in ("moment", "damping", "omega0", "duration", "stall_torque", "no_load_speed", "target_delta")
        }
    )


def _positive(option: str, v: float | None, allow_none: bool = True) -> None:
    if v is None and allow_none:
        return
    if v is None or not (v > 0) or v != v or v == float("inf"):
        raise MjlinkError(f"{option} must be a positive finite number, got {v}")


def _size(size: str) -> tuple[int, int]:
    """``WIDTHxHEIGHT`` as pixels (checked later, with the other video options)."""
    try:
        w, h = (int(x) for x in size.lower().split("x"))
    except ValueError:
        raise MjlinkError(f"--size must be WIDTHxHEIGHT, e.g. 640x480; got '{size}'") from None
    return w, h


def _verdict(failures: Sequence[str], strict: bool) -> int:
    """Print the thresholds missed, if any; the exit status."""
    if failures:
        print(text.missed(failures))
        return 3 if strict else 0
    return 0


# ----------------------------------------------------------------------------- list, check
def _list(args: argparse.Namespace) -> int:
    from ..model import catalogue
    from ..model.mechanism import load

    print(text.catalogue_listing([load(catalogue.path_of(n)) for n in catalogue.names()]))
    return 0


def _check(args: argparse.Namespace) -> int:
    report = validation.check_file(args.mechanism)  # an unreadable file raises: nothing to report
    print(text.format_report(report))
    report.raise_if_failed()  # the first problem, as one line, exit 1
    return 0


# ----------------------------------------------------------------------------- build
def _build_arguments(p: argparse.ArgumentParser) -> None:
    _mechanism(p)
    p.add_argument("-o", "--output", type=Path, help="MJCF file to write (default: standard output)")
    p.add_argument(
        "--kinematic",
        action="store_true",
        help="the kinematic-run model (flywheel on the crank, dt 5e-5) instead of the dynamic one",
    )


def _build(args: argparse.Namespace) -> int:
    from .. import pipeline

    res = pipeline.build(validation.get(args.mechanism), kinematic=args.kinematic, path=args.output)
    if res.path is None:
        sys.stdout.write(res.xml)
    else:
        print(f"wrote {res.path}", file=sys.stderr)
    return 0


# ----------------------------------------------------------------------------- simulate
def _simulate_arguments(s: argparse.ArgumentParser) -> None:
    _mechanism(s)
    s.add_argument(
        "--out", type=Path, default=Path("renders"), help="output root (default: renders/); results go to OUT/NAME/"
    )
    s.add_argument(
        "--speed", type=float, help="crank speed of the kinematic run, rad/s, CCW positive (default: the file's)"
    )
    s.add_argument("--cycles", type=float, help="crank periods in the kinematic run (default: the file's)")
    s.add_argument("--duration", type=float, help="duration of the dynamic run, s (default: the file's)")
    s.add_argument("--no-dynamics", action="store_true", help="skip the forward-dynamics run")
    s.add_argument("--no-plots", action="store_true", help="skip the PNG plots")
    s.add_argument("--no-video", action="store_true", help="skip the MP4")
    s.add_argument("--video-seconds", type=float, default=3.0, help="length of the video, s (default 3)")
    s.add_argument("--fps", type=int, default=30, help="video frames per second (default 30)")
    s.add_argument("--size", default="640x480", help="video size WIDTHxHEIGHT in pixels (default 640x480)")
    s.add_argument(
        "--phi0",
        "--phi01",
        dest="phi0",
        type=float,
        metavar="DEG",
        help="initial angle of the input crank, deg (default: the file's)",
    )
    s.add_argument(
        "--phase",
        "--phi04",
        dest="phase",
        type=float,
        metavar="DEG",
        help="angle of the geared crank at the initial input angle, deg (geared mechanisms)",
    )
    s.add_argument("--strict", action="store_true", help="exit 3 if any agreement threshold is missed")
    s.add_argument(
        "--dynamics",
        action="store_true",
        help="all dynamics studies: forward dynamics, driving torque and reactions, steady motion",
    )
    _drive_options(s)


def _simulate(args: argparse.Namespace) -> int:
    w, h = _size(args.size)
    from .. import pipeline

    pipeline.check_speed("--speed", args.speed)
    _positive("--cycles", args.cycles)
    if args.cycles is not None and args.cycles > MAX_CYCLES:
        raise MjlinkError(f"--cycles must be at most {MAX_CYCLES:g}, got {args.cycles:g}")
    _positive("--duration", args.duration)
    _positive("--video-seconds", args.video_seconds, allow_none=False)
    _positive("--fps", args.fps, allow_none=False)
    if w <= 0 or h <= 0 or w % 2 or h % 2 or w > MAX_VIDEO_SIZE[0] or h > MAX_VIDEO_SIZE[1]:
        raise MjlinkError(f"--size must be even and at most {MAX_VIDEO_SIZE[0]}x{MAX_VIDEO_SIZE[1]}, got {args.size}")
    if not args.no_video:
        from ..sim.gl import ensure_gl_backend

        ensure_gl_backend()  # no OpenGL: fail now, not after the runs

    mech = validation.with_crank_settings(validation.get(args.mechanism), args.phi0, args.phase)
    mech = pipeline.with_drive(mech, _drive(args))
    if args.dynamics and args.no_dynamics:
        raise MjlinkError("--dynamics and --no-dynamics contradict each other")
    if args.dynamics and not pipeline.has_masses(mech):
        raise MjlinkError(f"{mech.name}: --dynamics needs masses and a [dynamics] table (or drive options) in the file")
    if args.dynamics and mech.steady is None:
        raise MjlinkError(
            f"{mech.name}: the steady-motion study needs a motor: give [steady] or [dynamics.motor] "
            "in the file, or --stall-torque and --no-load-speed"
        )
    # --duration is already the mechanism's (with_drive), so the run takes the file's.
    opts = pipeline.Options(
        speed=args.speed,
        cycles=args.cycles,
        duration=None,
        dynamics=not args.no_dynamics,
        plots=not args.no_plots,
        video=not args.no_video,
        video_seconds=args.video_seconds,
        fps=args.fps,
        width=w,
        height=h,
        steady=args.dynamics,
    )
    print(f"mjlink: simulating {mech.name} ({mech.title})", file=sys.stderr)
    res = pipeline.run(mech, args.out, opts)
    print(text.simulation(res))
    return _verdict(res.failures, args.strict)


# ----------------------------------------------------------------------------- torque, reactions, steady
def _loads_arguments(q: argparse.ArgumentParser) -> None:
    _mechanism(q)
    q.add_argument(
        "--speed",
        type=float,
        metavar="RPM",
        help="crank speed, rev/min, in the file's sense of rotation (negative reverses it; default: the file's speed)",
    )
    q.add_argument("--out", type=Path, default=Path("renders"), help="output root; results go to OUT/NAME_loads/")
    q.add_argument("--no-plots", action="store_true", help="skip the PNG plots")
    q.add_argument("--strict", action="store_true", help="exit 3 if an agreement threshold is missed")


def _loads(args: argparse.Namespace, *, torque: bool) -> int:
    from .. import pipeline

    res = pipeline.loads(validation.get(args.mechanism), args.out, rpm=args.speed, plots=not args.no_plots)
    print(text.torque(res) if torque else text.reactions(res))
    return _verdict(res.failures, args.strict)


def _torque(args: argparse.Namespace) -> int:
    return _loads(args, torque=True)


def _reactions(args: argparse.Namespace) -> int:
    return _loads(args, torque=False)


def _steady_arguments(q: argparse.ArgumentParser) -> None:
    _mechanism(q)
    q.add_argument("--stall-torque", type=float, metavar="N_M", help="motor torque at rest, N*m (signed)")
    q.add_argument("--no-load-speed", type=float, metavar="RAD_S", help="motor no-load speed, rad/s (signed)")
    q.add_argument("--damping", type=float, metavar="N_M_S", help="viscous damping on the crank, N*m*s")
    q.add_argument(
        "--target-delta",
        type=float,
        help="wanted coefficient of speed fluctuation (default: the file's [steady] target_delta, else 0.02)",
    )
    q.add_argument("--out", type=Path, default=Path("renders"), help="output root; results go to OUT/NAME_steady/")
    q.add_argument("--no-plots", action="store_true", help="skip the PNG plot")
    q.add_argument("--strict", action="store_true", help="exit 3 if MuJoCo and the reference disagree")


def _steady(args: argparse.Namespace) -> int:
    from .. import pipeline

    res = pipeline.steady(validation.get(args.mechanism), args.out, drive=_drive(args), plots=not args.no_plots)
    print(text.steady(res))
    return _verdict(res.failures, args.strict)


# ----------------------------------------------------------------------------- synth
def _synth_arguments(y: argparse.ArgumentParser) -> None:
    y.add_argument("problem", help="what to synthesize: crank_slider")
    y.add_argument("--stroke", type=float, help="slider stroke S, mm (default: crank_slider.toml's)")
    y.add_argument("--offset", type=float, help="guide offset e, mm")
    y.add_argument("--lambda", dest="ratio", type=float, help="lambda = r / l")
    y.add_argument("--max-pressure-angle", type=float, help="allowed pressure angle [theta], deg")
    y.add_argument("--write", type=Path, metavar="FILE", help="save the accepted design as a mechanism file")


def _synth(args: argparse.Namespace) -> int:
    from .. import pipeline

    res = pipeline.synthesize(
        args.problem,
        stroke_mm=args.stroke,
        offset_mm=args.offset,
        ratio=args.ratio,
        max_pressure_deg=args.max_pressure_angle,
    )
    print(text.synthesis(res))
    if args.write is not None:  # after the table: a design that cannot be saved is still shown
        pipeline.write_design(res, args.write)
        print(f"wrote {args.write}")
    return 0


def _no_arguments(p: argparse.ArgumentParser) -> None:
    pass


def _loads_command(name: str, what: str, run: Callable[[argparse.Namespace], int]) -> Command:
    return Command(name, what, f"example: python -m mjlink {name} takeup --speed 955", _loads_arguments, run)


COMMANDS: tuple[Command, ...] = (
    Command("list", "list the registered mechanisms", "example: python -m mjlink list", _no_arguments, _list),
    Command(
        "check",
        "what a mechanism file defines and whether it can be simulated faithfully",
        "example: python -m mjlink check mechanisms/examples/crank_rocker.toml",
        _mechanism,
        _check,
    ),
    Command(
        "build",
        "write the MJCF of a mechanism",
        "example: python -m mjlink build takeup -o takeup.xml",
        _build_arguments,
        _build,
    ),
    Command(
        "simulate", "simulate, compare with the reference, plot and render", EXAMPLES, _simulate_arguments, _simulate
    ),
    _loads_command("torque", "driving torque to turn the crank at constant speed (inverse dynamics)", _torque),
    _loads_command("reactions", "forces in every kinematic pair at constant speed (kinetostatics)", _reactions),
    Command(
        "steady",
        "steady motion under a motor characteristic, speed fluctuation, flywheel",
        "example: python -m mjlink steady takeup --stall-torque 0.05 --no-load-speed 120 --target-delta 0.02",
        _steady_arguments,
        _steady,
    ),
    Command(
        "synth",
        "metric synthesis of the offset crank-slider (seed 002)",
        "example: python -m mjlink synth crank_slider --stroke 45 --offset 15 --lambda 0.35 "
        "--max-pressure-angle 40 --write my_slider.toml",
        _synth_arguments,
        _synth,
    ),
)
"""Every subcommand, in the order ``--help`` lists them."""
