"""The subcommands, each registered once in :data:`COMMANDS`.

A :class:`Command` is its name and help, a function adding its arguments to its parser and a
function that runs it: it checks the values argparse cannot (ranges, combinations), makes one
call into :mod:`mjlink.pipeline`, prints the result (:mod:`.text`) and returns the exit status.
:mod:`mjlink.pipeline` imports MuJoCo, so it is imported inside the commands that need it:
``list``, ``check`` and ``--help`` stay quick.

How an option's text becomes a value (speeds with their unit, quantities, numbers, paths,
memory sizes) is :mod:`.values`.
"""

from __future__ import annotations

import argparse
import math
import re
import sys
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from .. import validation
from ..errors import InputError, MjlinkError
from ..model import catalogue
from ..model.catalogue import STUDIES_DIR
from ..model.limits import MAX_CYCLES, MAX_FPS
from ..model.mechanism import load
from ..runtime.signals import uninterrupted
from . import text
from .values import Speed, number_arg, path_arg, quantity_arg, size_arg, speed_arg, whole_arg

if TYPE_CHECKING:
    from ..model.mechanism import Mechanism
    from ..pipeline import Drive, Estimate

SPEEDS = """\
speeds: every speed on the command line is written with its unit, 955rpm or 100rad/s
  (also rev/min, r/min, rev/s, deg/s: the units of files, case-sensitive, so RPM is refused;
  '955 rpm' with a space when quoted), and signed: counter-clockwise positive about +Z,
  exactly as a mechanism file's [input] speed (rad/s).
  A bare number is an error. So a file whose crank turns clockwise (crank_slider,
  warp_knitting: negative [input] speed) keeps its direction with a negative speed,
  --speed -1000rpm; a speed against the file's own direction is run, with a 'note:' line.
  This holds for simulate --speed, torque/reactions --speed, --omega0 and --no-load-speed.
exit status: 0 done (also when a threshold is missed, unless --strict: then 3); 1 an error
  in a file, a value or a run (one line, 'mjlink: error: ...'); 2 a usage error (unknown
  option, missing argument, a value of the wrong form: one line too); 130/143 interrupted.
  --debug (before or after the command) shows the traceback of an error.
"""

EXAMPLES = f"""\
examples:
  python -m mjlink list
  python -m mjlink simulate takeup                     # everything into renders/takeup/
  python -m mjlink simulate takeup --no-video --out /tmp/runs
  python -m mjlink simulate my_linkage.toml --speed 50rad/s --cycles 2
  python -m mjlink simulate warp_knitting --phi01 -90 --phi04 30   # another crank setting
  python -m mjlink build takeup -o takeup.xml          # MJCF for plain mujoco.MjModel.from_xml_path
  python -m mjlink synth crank_slider --stroke 45 --offset 15 --lambda 0.35 --max-pressure-angle 40
  python -m mjlink simulate takeup --dynamics          # + steady motion and flywheel study
  python -m mjlink simulate crank_slider --dynamics --stall-torque -0.8 --no-load-speed -160rad/s --duration 2
  python -m mjlink torque warp_knitting --speed -1000rpm   # driving torque at 1000 rpm, clockwise as the file
  python -m mjlink reactions takeup --speed 955rpm     # forces in every kinematic pair
  python -m mjlink steady takeup --target-delta 0.01    # speed fluctuation and flywheel

{SPEEDS}"""

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


# ----------------------------------------------------------------------------- speeds
def _rad_s(v: Speed | None) -> float | None:
    return None if v is None else v.rad_s


def _notes(mech: Mechanism, args: argparse.Namespace, options: Sequence[tuple[str, str]]) -> None:
    """Print a 'note:' line for each speed option given against the file's own direction."""
    for option, attr in options:
        v: Speed | None = getattr(args, attr, None)
        if v is not None:
            note = text.against_file(option, v.arg, v.rad_s, mech.speed)
            if note:
                print(note, flush=True)


def _long_run(est: Estimate) -> None:
    """Say on stderr, before it starts, that a run will take a while (and what it will cost)."""
    r = est.long
    if r is not None:
        print(f"mjlink: long run: {r.describe()}; this takes minutes", file=sys.stderr, flush=True)


def _progress(what: str, done: float) -> None:
    """A long run's progress on stderr, on one line that ends when the run does."""
    print(f"\r  {what}: {done:6.1%}", end="\n" if done >= 1.0 else "", file=sys.stderr, flush=True)


# ----------------------------------------------------------------------------- shared
def _mechanism(p: argparse.ArgumentParser) -> None:
    p.add_argument("mechanism", help="registered name (see 'list') or path to a .toml file")


_SPEED_HELP = "with its unit (955rpm, 100rad/s), signed, counter-clockwise positive"


def _drive_options(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--moment", type=quantity_arg("N*m"), metavar="N_M", help="constant driving moment on the crank, N*m (signed)"
    )
    p.add_argument(
        "--stall-torque",
        type=quantity_arg("N*m"),
        metavar="N_M",
        help="motor characteristic: torque at rest, N*m, signed (with --no-load-speed)",
    )
    p.add_argument(
        "--no-load-speed",
        type=speed_arg,
        metavar="SPEED",
        help=f"motor characteristic: speed at which the torque falls to zero, {_SPEED_HELP}",
    )
    p.add_argument("--damping", type=quantity_arg("N*m*s"), metavar="N_M_S", help="viscous damping on the crank, N*m*s")
    p.add_argument(
        "--omega0", type=speed_arg, metavar="SPEED", help=f"initial crank speed of the dynamic run, {_SPEED_HELP}"
    )
    p.add_argument("--target-delta", type=number_arg, help="target speed fluctuation for the flywheel (steady study)")


def _drive(args: argparse.Namespace) -> Drive:
    """The drive options a command has (the others None), speeds in rad/s;
    :func:`pipeline.with_drive` checks them."""
    from ..pipeline import Drive  # here: the pipeline loads MuJoCo, which list, check and --help do without

    return Drive(
        moment=getattr(args, "moment", None),
        damping=getattr(args, "damping", None),
        omega0=_rad_s(getattr(args, "omega0", None)),
        duration=getattr(args, "duration", None),
        stall_torque=getattr(args, "stall_torque", None),
        no_load_speed=_rad_s(getattr(args, "no_load_speed", None)),
        target_delta=getattr(args, "target_delta", None),
    )


def _outputs(q: argparse.ArgumentParser, folder: str, plots: str = "skip the PNG plots") -> None:
    """A command's output folder ``OUT/NAME_<folder>/``: --out, --force, --no-plots."""
    q.add_argument(
        "--out", type=path_arg, default=Path("renders"), help=f"output root; results go to OUT/NAME_{folder}/"
    )
    q.add_argument(
        "--force",
        action="store_true",
        help="publish into an existing output folder that mjlink did not write for this command (files of yours in it are still kept)",
    )
    q.add_argument("--no-plots", action="store_true", help=plots)


def _positive(option: str, v: float | None, unit: str = "", allow_none: bool = True) -> None:
    if v is None and allow_none:
        return
    if v is None or not (v > 0) or v != v or v == float("inf"):
        raise MjlinkError(f"{option} must be a positive finite number, got {v}{unit}")


def _size(size: str) -> tuple[int, int]:
    """``WIDTHxHEIGHT`` as pixels (checked later, with the other video options)."""
    m = re.fullmatch(r"\s*([0-9]+)\s*[xX]\s*([0-9]+)\s*", size)
    if m is None:
        raise MjlinkError(f"--size must be WIDTHxHEIGHT, e.g. 640x480; got {text.error_line(repr(size))}")
    return int(m[1]), int(m[2])


def _verdict(failures: Sequence[str], strict: bool) -> int:
    """Print the thresholds missed, if any; the exit status."""
    if failures:
        print(text.missed(failures))
        return 3 if strict else 0
    return 0


# ----------------------------------------------------------------------------- list, check
def _list(args: argparse.Namespace) -> int:

    print(text.catalogue_listing([load(catalogue.path_of(n)) for n in catalogue.names()]))
    return 0


def _check(args: argparse.Namespace) -> int:

    mech = load(catalogue.path_of(args.mechanism))  # an unreadable file raises: nothing to report
    report = validation.check(mech)
    print(text.format_report(report, speed=mech.speed))
    report.raise_if_failed()  # the first problem, as one line, exit 1
    return 0


# ----------------------------------------------------------------------------- build
def _build_arguments(p: argparse.ArgumentParser) -> None:
    _mechanism(p)
    p.add_argument("-o", "--output", type=path_arg, help="MJCF file to write (default: standard output)")
    p.add_argument("--force", action="store_true", help="replace the file if it exists")
    p.add_argument(
        "--kinematic",
        action="store_true",
        help="the kinematic-run model (flywheel on the crank, dt 5e-5) instead of the dynamic one",
    )


def _build(args: argparse.Namespace) -> int:
    from .. import pipeline  # here: it loads MuJoCo, which list, check and --help do without

    mech = validation.get(args.mechanism)
    res = pipeline.build(mech, kinematic=args.kinematic, path=args.output, force=args.force)
    if res.path is None:
        sys.stdout.write(res.xml)
    else:
        crank = (
            f"kinematic model, the crank held at {text.crank_speed(mech.speed)}"
            if args.kinematic
            else f"dynamic model, the crank starting at {text.crank_speed(mech.dynamics.omega0)}"
        )
        print(f"wrote {res.path} ({crank})", file=sys.stderr)
    return 0


# ----------------------------------------------------------------------------- export


def _export_arguments(p: argparse.ArgumentParser) -> None:
    _mechanism(p)
    p.add_argument("--dxf", type=path_arg, help="DXF file to write (mm; a layer per link, pivots, points, paths)")
    p.add_argument("--points", type=path_arg, help="the named points' coordinates, .csv or .json")
    p.add_argument(
        "--angle", type=quantity_arg("deg"), help="the input crank's angle, deg (default: the file's phi0, its setting)"
    )
    p.add_argument("--force", action="store_true", help="replace files that exist")


def _export(args: argparse.Namespace) -> int:
    from ..pipeline import export  # here: it reads the reference and ezdxf, which list and --help do without

    mech = validation.get(args.mechanism)
    res = export.export(mech, args.angle, args.dxf, args.points, force=args.force)
    wrote = ", ".join(str(p) for p in (res.dxf, res.points_file) if p is not None)
    print(f"wrote {wrote} ({mech.name} at input crank angle {res.angle_deg:g} deg, mm)", file=sys.stderr)
    return 0


# ----------------------------------------------------------------------------- design
def _design_arguments(p: argparse.ArgumentParser) -> None:
    _mechanism(p)
    p.add_argument(
        "--out",
        type=path_arg,
        help="output root (default: renders/); the page goes to OUT/NAME/design.html, where simulate puts it",
    )
    p.add_argument("-o", "--output", type=path_arg, help="write the page to this HTML file instead")
    p.add_argument(
        "--force",
        action="store_true",
        help="replace the -o file if it exists; or write into an OUT/NAME/ folder mjlink did not write for simulate",
    )


def _design(args: argparse.Namespace) -> int:
    from ..pipeline import design  # here: it loads MuJoCo, which list, check and --help do without

    if args.output is not None and args.out is not None:
        raise MjlinkError("design: give -o FILE or --out ROOT, not both")
    mech = validation.get(args.mechanism)
    root = args.out or Path("renders")
    path = design.design_page(mech, args.output, out_root=root, force=args.force, command=args.command_line)
    print(
        f"wrote {path}: open it in a browser (offline; drag the pivots, edit the numbers, save as TOML)",
        file=sys.stderr,
    )
    return 0


# ----------------------------------------------------------------------------- simulate
def _simulate_arguments(s: argparse.ArgumentParser) -> None:
    _mechanism(s)
    s.add_argument(
        "--out", type=path_arg, default=Path("renders"), help="output root (default: renders/); results go to OUT/NAME/"
    )
    s.add_argument(
        "--force",
        action="store_true",
        help="publish into an existing output folder that mjlink did not write for this command (files of yours in it are still kept)",
    )
    s.add_argument(
        "--speed",
        type=speed_arg,
        metavar="SPEED",
        help=f"crank speed of the kinematic run, {_SPEED_HELP} (default: the file's [input] speed)",
    )
    s.add_argument("--cycles", type=number_arg, help="crank periods in the kinematic run (default: the file's)")
    s.add_argument("--duration", type=quantity_arg("s"), help="duration of the dynamic run, s (default: the file's)")
    s.add_argument("--no-dynamics", action="store_true", help="skip the forward-dynamics run")
    s.add_argument("--no-plots", action="store_true", help="skip the PNG plots")
    s.add_argument("--no-video", action="store_true", help="skip the MP4")
    s.add_argument("--video-seconds", type=quantity_arg("s"), default=3.0, help="length of the video, s (default 3)")
    s.add_argument("--fps", type=number_arg, default=30, help="video frames per second, a whole number (default 30)")
    s.add_argument(
        "--size",
        default="640x480",
        help="video size WIDTHxHEIGHT in pixels (default 640x480; 1280x720 for HD, framed for its aspect)",
    )
    s.add_argument(
        "--phi0",
        "--phi01",
        dest="phi0",
        type=quantity_arg("deg"),
        metavar="DEG",
        help="initial angle of the input crank, deg (default: the file's)",
    )
    s.add_argument(
        "--phase",
        "--phi04",
        dest="phase",
        type=quantity_arg("deg"),
        metavar="DEG",
        help="angle of the geared crank at the initial input angle, deg (geared mechanisms)",
    )
    s.add_argument("--strict", action="store_true", help="exit 3 if any agreement threshold is missed")
    s.add_argument(
        "--base",
        metavar="NAME|FILE",
        help="print what the design does beside this design's numbers, and the dimensions that differ "
        "(default: the shipped mechanism of the file's name, when the file is another one)",
    )
    s.add_argument(
        "--dynamics",
        action="store_true",
        help="all dynamics studies: forward dynamics, driving torque and reactions, steady motion",
    )
    _drive_options(s)


def _simulate(args: argparse.Namespace) -> int:
    w, h = _size(args.size)
    from .. import pipeline  # here: it loads MuJoCo, which list, check and --help do without

    if args.speed is not None:
        pipeline.check_speed("--speed", args.speed.rad_s, str(args.speed))
    _positive("--cycles", args.cycles)
    if args.cycles is not None and args.cycles > MAX_CYCLES:
        raise MjlinkError(f"--cycles must be at most {MAX_CYCLES:g}, got {args.cycles:g}")
    _positive("--video-seconds", args.video_seconds, " s", allow_none=False)
    if not (0 < args.fps <= MAX_FPS and args.fps == round(args.fps)):  # no round(inf) below
        raise MjlinkError(
            f"--fps must be a whole number of frames/s from 1 to {MAX_FPS} (mechanisms/README.md, Limits), "
            f"got {args.fps:g}"
        )
    if w <= 0 or h <= 0 or w % 2 or h % 2 or w > MAX_VIDEO_SIZE[0] or h > MAX_VIDEO_SIZE[1]:
        raise MjlinkError(f"--size must be even and at most {MAX_VIDEO_SIZE[0]}x{MAX_VIDEO_SIZE[1]}, got {args.size}")

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
        speed=_rad_s(args.speed),
        cycles=args.cycles,
        duration=None,
        dynamics=not args.no_dynamics,
        plots=not args.no_plots,
        video=not args.no_video,
        video_seconds=args.video_seconds,
        fps=round(args.fps),
        width=w,
        height=h,
        steady=args.dynamics,
    )
    base = _base(mech, args.base)
    estimate = pipeline.estimate(mech, opts)  # the absurd is refused here, before anything runs
    if not args.no_video:
        from ..sim.render import check_backend  # here: MuJoCo, only for a video

        check_backend(held=uninterrupted)  # no OpenGL: fail now, not after the runs
    _notes(mech, args, (("--speed", "speed"), ("--omega0", "omega0"), ("--no-load-speed", "no_load_speed")))
    print(f"mjlink: simulating {mech.name} ({mech.title})", file=sys.stderr)
    _long_run(estimate)
    res = pipeline.run(
        mech,
        args.out,
        opts,
        force=args.force,
        command=args.command_line,
        progress=_progress if estimate.long is not None else None,
    )
    against = None
    if base is not None and res.design is not None:
        from ..analysis import summary  # here: the base's numbers only when there is a base

        against = (base[0], *summary.against(res.design, base[1]))
    print(text.simulation(res, against))
    return _verdict(res.failures, args.strict)


def _base(mech: Mechanism, given: str | None) -> tuple[str, Mechanism] | None:
    """The design ``simulate`` prints its numbers beside: ``--base``'s, or the shipped
    mechanism of the file's name when the file is another file (a copy being edited)."""
    if given is not None:
        return (f"the base {given}", validation.get(given))
    if mech.name not in catalogue.names() or mech.path is None:
        return None
    shipped = catalogue.path_of(mech.name)
    try:
        if Path(mech.path).resolve() == shipped.resolve():
            return None
    except OSError:
        return None
    return (f"the shipped {mech.name}", validation.get(mech.name))


# ----------------------------------------------------------------------------- torque, reactions, steady
def _loads_arguments(q: argparse.ArgumentParser) -> None:
    _mechanism(q)
    q.add_argument(
        "--speed",
        type=speed_arg,
        metavar="SPEED",
        help=f"crank speed, {_SPEED_HELP} as the file's [input] speed (default: the file's)",
    )
    _outputs(q, "loads")
    q.add_argument("--strict", action="store_true", help="exit 3 if an agreement threshold is missed")


def _loads(args: argparse.Namespace, *, torque: bool) -> int:
    from .. import pipeline  # here: it loads MuJoCo, which list, check and --help do without

    mech = validation.get(args.mechanism)
    speed = _rad_s(args.speed)
    if args.speed is not None:
        pipeline.check_speed("--speed", args.speed.rad_s, str(args.speed))
    estimate = pipeline.estimate(mech, pipeline.Options(speed=speed, dynamics=False, video=False), cycles_option=None)
    _notes(mech, args, (("--speed", "speed"),))
    _long_run(estimate)
    res = pipeline.loads(
        mech, args.out, speed=speed, plots=not args.no_plots, force=args.force, command=args.command_line
    )
    print(text.torque(res) if torque else text.reactions(res))
    return _verdict(res.failures, args.strict)


def _torque(args: argparse.Namespace) -> int:
    return _loads(args, torque=True)


def _reactions(args: argparse.Namespace) -> int:
    return _loads(args, torque=False)


def _steady_arguments(q: argparse.ArgumentParser) -> None:
    _mechanism(q)
    q.add_argument("--stall-torque", type=quantity_arg("N*m"), metavar="N_M", help="motor torque at rest, N*m (signed)")
    q.add_argument("--no-load-speed", type=speed_arg, metavar="SPEED", help=f"motor no-load speed, {_SPEED_HELP}")
    q.add_argument("--damping", type=quantity_arg("N*m*s"), metavar="N_M_S", help="viscous damping on the crank, N*m*s")
    q.add_argument(
        "--target-delta",
        type=number_arg,
        help="wanted coefficient of speed fluctuation (default: the file's [steady] target_delta, else 0.02)",
    )
    _outputs(q, "steady", "skip the PNG plot")
    q.add_argument("--strict", action="store_true", help="exit 3 if MuJoCo and the reference disagree")


def _steady(args: argparse.Namespace) -> int:
    from .. import pipeline  # here: it loads MuJoCo, which list, check and --help do without

    mech = validation.get(args.mechanism)
    drive = _drive(args)
    driven = pipeline.with_drive(mech, drive, steady=True)
    if driven.steady is not None:
        _long_run(
            pipeline.estimate(driven, pipeline.Options(dynamics=False, video=False, steady=True), kinematic=False)
        )
    _notes(mech, args, (("--no-load-speed", "no_load_speed"),))
    res = pipeline.steady(
        mech, args.out, drive=drive, plots=not args.no_plots, force=args.force, command=args.command_line
    )
    print(text.steady(res))
    return _verdict(res.failures, args.strict)


# ----------------------------------------------------------------------------- feed
def _feed_arguments(q: argparse.ArgumentParser) -> None:
    _mechanism(q)
    what = q.add_mutually_exclusive_group()
    what.add_argument("--speed", type=speed_arg, metavar="SPEED", help=f"main-shaft speed, {_SPEED_HELP}")
    what.add_argument("--sweep", action="store_true", help="every 500 rpm from 500 to 6,000 rpm")
    q.add_argument(
        "--stitches", type=whole_arg, default=6, help="stitches run from rest at each speed (2 to 50, default 6)"
    )
    _outputs(q, "feed")
    q.add_argument(
        "--video", action="store_true", help="feed.mp4: a close-up of the last stitch at the last speed, slowed down"
    )


def _feed(args: argparse.Namespace) -> int:
    from .. import pipeline  # here: it loads MuJoCo, which list, check and --help do without

    mech = validation.get(args.mechanism)
    rad = _rad_s(args.speed)
    if rad is not None and rad != 0.0 and (rad > 0.0) != (mech.speed > 0.0):
        # The feed's dog runs its path the file's way: a speed's sign does not turn it back.
        print(
            f"note: --speed {args.speed.arg} is against the file's own direction ([input] speed = {mech.speed:g} "
            "rad/s); the feed keeps the file's direction and runs at its size",
            flush=True,
        )
    res = pipeline.feed(
        mech,
        args.out,
        speed_rpm=None if rad is None else rad * 30.0 / math.pi,
        sweep=args.sweep,
        stitches=args.stitches,
        plots=not args.no_plots,
        video=args.video,
        force=args.force,
        command=args.command_line,
    )
    print(text.feed(res))
    return 0


# ----------------------------------------------------------------------------- synth
def _synth_arguments(y: argparse.ArgumentParser) -> None:
    y.add_argument("problem", help="what to synthesize: crank_slider")
    y.add_argument("--stroke", type=quantity_arg("mm"), help="slider stroke S, mm (default: crank_slider.toml's)")
    y.add_argument("--offset", type=quantity_arg("mm"), help="guide offset e, mm")
    y.add_argument("--lambda", dest="ratio", type=number_arg, help="lambda = r / l")
    y.add_argument("--max-pressure-angle", type=quantity_arg("deg"), help="allowed pressure angle [theta], deg")
    y.add_argument("--write", type=path_arg, metavar="FILE", help="save the accepted design as a mechanism file")
    y.add_argument("--force", action="store_true", help="replace the --write file if it exists")


def _synth(args: argparse.Namespace) -> int:
    from .. import pipeline  # here: it loads MuJoCo, which list, check and --help do without

    if args.write is not None:  # refused before any work; checked again as it is written
        from ..files import claim_outputs

        claim_outputs({"--write": args.write}, [catalogue.path_of("crank_slider")], force=args.force)
    res = pipeline.synthesize(
        args.problem,
        stroke_mm=args.stroke,
        offset_mm=args.offset,
        ratio=args.ratio,
        max_pressure_deg=args.max_pressure_angle,
    )
    print(text.synthesis(res))
    if args.write is not None:  # after the table: a design that cannot be saved is still shown
        pipeline.write_design(res, args.write, force=args.force)
        print(f"wrote {args.write}")
    return 0


# ----------------------------------------------------------------------------- study
def _study_arguments(q: argparse.ArgumentParser) -> None:
    q.add_argument("file", help="study file (studies/README.md), or the name of a shipped one: " + _shipped())
    q.add_argument("--out", type=path_arg, default=Path("renders"), help="output root; results go to OUT/NAME-study/")
    q.add_argument(
        "--scheduler",
        metavar="ADDR",
        help="run on an existing Dask cluster, tcp://HOST:PORT (default: $DASK_SCHEDULER_ADDRESS, else a local "
        "cluster of one worker process per core)",
    )
    q.add_argument(
        "--workers",
        type=whole_arg,
        metavar="N",
        help="worker processes of the local cluster (default: one per core; 0 runs in this process without Dask)",
    )
    q.add_argument(
        "--force",
        action="store_true",
        help="publish into an existing output folder that mjlink did not write for this study (your files are kept)",
    )
    q.add_argument("--no-plots", action="store_true", help="skip the PNG plots")
    q.add_argument("--strict", action="store_true", help="exit 3 if a variant MuJoCo verified missed a threshold")
    q.add_argument(
        "--dry-run",
        action="store_true",
        help="check the study and print its plan (variants, MuJoCo steps, memory, time), then stop: nothing is written",
    )
    q.add_argument(
        "--max-memory",
        type=size_arg,
        metavar="SIZE",
        help="the memory a study may need before it is refused (e.g. 64GiB; default: three quarters of the memory "
        "this machine has available)",
    )


def _shipped() -> str:
    # The folder from the catalogue, not mjlink.study (whose import every command would pay).

    return ", ".join(sorted(p.stem for p in STUDIES_DIR.glob("*.toml")))


def _study(args: argparse.Namespace) -> int:
    from ..pipeline import study as pipeline_study  # here: scipy and Dask, only for a study
    from ..study import spec  # here: as the line above

    if args.workers is not None and not 0 <= args.workers <= 256:
        raise InputError(f"--workers must be from 0 to 256, got {args.workers}")
    if args.workers is not None and args.scheduler:
        raise InputError("--workers sizes a local cluster: it does not apply with --scheduler")
    st = spec.load(args.file)
    pre = pipeline_study.prepare(
        st, args.out, scheduler=args.scheduler, workers=args.workers, force=args.force, max_memory=args.max_memory
    )
    print(f"mjlink: {pre.plan.describe()}", file=sys.stderr, flush=True)
    pre.plan.check()
    if args.dry_run:
        cal = pre.plan.calibration
        measured = (
            f"its plan computed {cal.variants} variant{'s' if cal.variants != 1 else ''} here to measure their cost"
            if cal is not None
            else "nothing computed"
        )
        print(f"dry run: nothing written ({measured}); the outputs would go to {pre.dest}/")
        return 0
    res = pipeline_study.run(
        pre,
        plots=not args.no_plots,
        force=args.force,
        command=" ".join(args.command_line),
    )
    print(text.study(res))
    return _verdict(
        res.failures[:20] + ([f"... {len(res.failures) - 20} more"] if len(res.failures) > 20 else []), args.strict
    )


def _no_arguments(p: argparse.ArgumentParser) -> None:
    pass


def _loads_command(name: str, what: str, run: Callable[[argparse.Namespace], int]) -> Command:
    return Command(
        name,
        what,
        f"example: python -m mjlink {name} takeup --speed 955rpm\n\n{SPEEDS}",
        _loads_arguments,
        run,
    )


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
        "design",
        "drag-to-design: an offline HTML page to edit the mechanism and watch its paths and numbers",
        "examples:\n  python -m mjlink design takeup                        # renders/takeup/design.html\n"
        "  python -m mjlink design takeup -o takeup-design.html",
        _design_arguments,
        _design,
    ),
    Command(
        "export",
        "the mechanism at one crank angle for CAD: a DXF and the points' coordinates",
        "examples:\n  python -m mjlink export takeup --dxf takeup.dxf --points takeup_points.csv\n"
        "  python -m mjlink export lockstitch_head --angle 180 --dxf head_at_bdc.dxf",
        _export_arguments,
        _export,
    ),
    Command(
        "simulate", "simulate, compare with the reference, plot and render", EXAMPLES, _simulate_arguments, _simulate
    ),
    _loads_command("torque", "driving torque to turn the crank at constant speed (inverse dynamics)", _torque),
    _loads_command("reactions", "forces in every kinematic pair at constant speed (kinetostatics)", _reactions),
    Command(
        "steady",
        "steady motion under a motor characteristic, speed fluctuation, flywheel",
        "example: python -m mjlink steady takeup --stall-torque 0.05 --no-load-speed 120rad/s --target-delta 0.02"
        f"\n\n{SPEEDS}",
        _steady_arguments,
        _steady,
    ),
    Command(
        "feed",
        "the fabric fed under the sprung presser foot through MuJoCo's contacts: stitch length against speed",
        "examples:\n  python -m mjlink feed lockstitch_head                 # at the file's speed\n"
        "  python -m mjlink feed lockstitch_head --speed 3000rpm\n"
        "  python -m mjlink feed lockstitch_head --sweep         # 500 to 6,000 rpm: the first speed beyond 2 %",
        _feed_arguments,
        _feed,
    ),
    Command(
        "study",
        "a design study (parameter grid, quasi-random sample, tolerance study) or an optimal synthesis, on Dask",
        "examples:\n  python -m mjlink study takeup_tolerance\n"
        "  python -m mjlink study takeup_eyelets_demand                 # [optimize]: writes winner.toml\n"
        "  python -m mjlink study crank_slider_grid --workers 0          # in this process\n"
        "  python -m mjlink study my_study.toml --scheduler tcp://10.0.0.5:8786\n"
        "  python -m mjlink study my_study.toml --dry-run                # its plan: size, memory, time",
        _study_arguments,
        _study,
    ),
    Command(
        "synth",
        "metric synthesis of the offset crank-slider (the crank-slider synthesis paper)",
        "example: python -m mjlink synth crank_slider --stroke 45 --offset 15 --lambda 0.35 "
        "--max-pressure-angle 40 --write my_slider.toml",
        _synth_arguments,
        _synth,
    ),
)
"""Every subcommand, in the order ``--help`` lists them."""
