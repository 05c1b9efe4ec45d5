"""Command line: ``python -m mjlink {list,build,simulate} ...``.

Errors print one line (``mjlink: error: ...``) and exit 1; ``--debug`` shows the traceback.
Heavy modules are imported only after the OpenGL backend is chosen, because MuJoCo reads
``MUJOCO_GL`` once, when it is first imported.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

from . import validation
from .model import names
from .model.limits import MAX_PRESSURE_DEG, MIN_TRANSMISSION_DEG
from .units import PairKind, PairRole

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


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="python -m mjlink", description=(
        "MuJoCo models of sewing- and knitting-machine linkages, checked against the "
        "vector-method reference analysis."), epilog=EXAMPLES, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--debug", action="store_true", help="show tracebacks on errors")
    sub = p.add_subparsers(dest="command", metavar="COMMAND", required=True)

    sub.add_parser("list", help="list the registered mechanisms", epilog="example: python -m mjlink list")

    k = sub.add_parser("check", help="what a mechanism file defines and whether it can be simulated faithfully",
                       formatter_class=argparse.RawDescriptionHelpFormatter,
                       epilog="example: python -m mjlink check mechanisms/examples/crank_rocker.toml")
    k.add_argument("mechanism", help="registered name (see 'list') or path to a .toml file")

    b = sub.add_parser("build", help="write the MJCF of a mechanism", formatter_class=argparse.RawDescriptionHelpFormatter,
                       epilog="example: python -m mjlink build takeup -o takeup.xml")
    b.add_argument("mechanism", help="registered name (see 'list') or path to a .toml file")
    b.add_argument("-o", "--output", type=Path, help="MJCF file to write (default: standard output)")
    b.add_argument("--kinematic", action="store_true",
                   help="the kinematic-run model (flywheel on the crank, dt 5e-5) instead of the dynamic one")

    s = sub.add_parser("simulate", help="simulate, compare with the reference, plot and render",
                       formatter_class=argparse.RawDescriptionHelpFormatter, epilog=EXAMPLES)
    s.add_argument("mechanism", help="registered name (see 'list') or path to a .toml file")
    s.add_argument("--out", type=Path, default=Path("renders"), help="output root (default: renders/); "
                   "results go to OUT/NAME/")
    s.add_argument("--speed", type=float, help="crank speed of the kinematic run, rad/s, CCW positive "
                   "(default: the file's)")
    s.add_argument("--cycles", type=float, help="crank periods in the kinematic run (default: the file's)")
    s.add_argument("--duration", type=float, help="duration of the dynamic run, s (default: the file's)")
    s.add_argument("--no-dynamics", action="store_true", help="skip the forward-dynamics run")
    s.add_argument("--no-plots", action="store_true", help="skip the PNG plots")
    s.add_argument("--no-video", action="store_true", help="skip the MP4")
    s.add_argument("--video-seconds", type=float, default=3.0, help="length of the video, s (default 3)")
    s.add_argument("--fps", type=int, default=30, help="video frames per second (default 30)")
    s.add_argument("--size", default="640x480", help="video size WIDTHxHEIGHT in pixels (default 640x480)")
    s.add_argument("--phi0", "--phi01", dest="phi0", type=float, metavar="DEG",
                   help="initial angle of the input crank, deg (default: the file's)")
    s.add_argument("--phase", "--phi04", dest="phase", type=float, metavar="DEG",
                   help="angle of the geared crank at the initial input angle, deg (geared mechanisms)")
    s.add_argument("--strict", action="store_true", help="exit 3 if any agreement threshold is missed")
    s.add_argument("--dynamics", action="store_true",
                   help="all dynamics studies: forward dynamics, driving torque and reactions, steady motion")
    _drive_options(s)

    for cmd, what in (("torque", "driving torque to turn the crank at constant speed (inverse dynamics)"),
                      ("reactions", "forces in every kinematic pair at constant speed (kinetostatics)")):
        q = sub.add_parser(cmd, help=what, formatter_class=argparse.RawDescriptionHelpFormatter,
                           epilog=f"example: python -m mjlink {cmd} takeup --speed 955")
        q.add_argument("mechanism", help="registered name (see 'list') or path to a .toml file")
        q.add_argument("--speed", type=float, metavar="RPM",
                       help="crank speed, rev/min, in the file's sense of rotation (negative reverses it; "
                            "default: the file's speed)")
        q.add_argument("--out", type=Path, default=Path("renders"), help="output root; results go to OUT/NAME_loads/")
        q.add_argument("--no-plots", action="store_true", help="skip the PNG plots")
        q.add_argument("--strict", action="store_true", help="exit 3 if an agreement threshold is missed")
    q = sub.add_parser("steady", help="steady motion under a motor characteristic, speed fluctuation, flywheel",
                       formatter_class=argparse.RawDescriptionHelpFormatter,
                       epilog="example: python -m mjlink steady takeup --stall-torque 0.05 --no-load-speed 120 "
                              "--target-delta 0.02")
    q.add_argument("mechanism", help="registered name (see 'list') or path to a .toml file")
    q.add_argument("--stall-torque", type=float, metavar="N_M", help="motor torque at rest, N*m (signed)")
    q.add_argument("--no-load-speed", type=float, metavar="RAD_S", help="motor no-load speed, rad/s (signed)")
    q.add_argument("--damping", type=float, metavar="N_M_S", help="viscous damping on the crank, N*m*s")
    q.add_argument("--target-delta", type=float, help="wanted coefficient of speed fluctuation (default: "
                   "the file's [steady] target_delta, else 0.02)")
    q.add_argument("--out", type=Path, default=Path("renders"), help="output root; results go to OUT/NAME_steady/")
    q.add_argument("--no-plots", action="store_true", help="skip the PNG plot")
    q.add_argument("--strict", action="store_true", help="exit 3 if MuJoCo and the reference disagree")

    y = sub.add_parser("synth", help="metric synthesis of the offset crank-slider (seed 002)",
                       formatter_class=argparse.RawDescriptionHelpFormatter, epilog=(
                           "example: python -m mjlink synth crank_slider --stroke 45 --offset 15 --lambda 0.35 "
                           "--max-pressure-angle 40 --write my_slider.toml"))
    y.add_argument("problem", help="what to synthesize: crank_slider")
    y.add_argument("--stroke", type=float, help="slider stroke S, mm (default: crank_slider.toml's)")
    y.add_argument("--offset", type=float, help="guide offset e, mm")
    y.add_argument("--lambda", dest="ratio", type=float, help="lambda = r / l")
    y.add_argument("--max-pressure-angle", type=float, help="allowed pressure angle [theta], deg")
    y.add_argument("--write", type=Path, metavar="FILE", help="save the accepted design as a mechanism file")
    return p


def _write_atomic(path: Path, text: str) -> None:
    """Write a whole file or nothing: a hidden temporary beside it, renamed into place."""
    from . import output

    output.write_text(path, text)


def _drive_options(p) -> None:
    p.add_argument("--moment", type=float, metavar="N_M", help="constant driving moment on the crank, N*m")
    p.add_argument("--stall-torque", type=float, metavar="N_M",
                   help="motor characteristic: torque at rest, N*m (with --no-load-speed)")
    p.add_argument("--no-load-speed", type=float, metavar="RAD_S",
                   help="motor characteristic: speed at which the torque falls to zero, rad/s")
    p.add_argument("--damping", type=float, metavar="N_M_S", help="viscous damping on the crank, N*m*s")
    p.add_argument("--omega0", type=float, metavar="RAD_S", help="initial crank speed of the dynamic run, rad/s")
    p.add_argument("--target-delta", type=float, help="target speed fluctuation for the flywheel (steady study)")


def _with_drive(mech, args, *, steady: bool = False):
    """``mech`` with the drive, load and duration options applied (all validated)."""
    import dataclasses
    import math

    from .errors import MjlinkError
    from .model.mechanism import Motor, SteadyCase

    dyn = mech.dynamics
    changes = {}
    for opt, key in (("moment", "moment"), ("damping", "damping"), ("omega0", "omega0"), ("duration", "duration")):
        v = getattr(args, opt, None)
        if v is None:
            continue
        if not math.isfinite(v) or (key in ("damping",) and v < 0) or (key == "duration" and v <= 0):
            raise MjlinkError(f"--{opt.replace('_', '-')} must be a finite number{' >= 0' if key == 'damping' else ''}"
                              f"{' > 0' if key == 'duration' else ''}, got {v}")
        changes[key] = v
    ts, w0 = getattr(args, "stall_torque", None), getattr(args, "no_load_speed", None)
    motor = None
    if (ts is None) != (w0 is None):
        raise MjlinkError("--stall-torque and --no-load-speed go together (a linear motor characteristic)")
    if ts is not None:
        if not (math.isfinite(ts) and math.isfinite(w0)) or ts == 0 or w0 == 0 or (ts > 0) != (w0 > 0):
            raise MjlinkError("--stall-torque and --no-load-speed must be finite, non-zero and of the same sign")
        motor = Motor(ts, w0)
        if not steady:
            changes["motor"] = motor
    if changes:
        mech = dataclasses.replace(mech, dynamics=dataclasses.replace(dyn, **changes),
                                   has_dynamics=mech.has_dynamics or bool(changes))
    target = getattr(args, "target_delta", None)
    if target is not None and not (0 < target < 2):
        raise MjlinkError(f"--target-delta must be between 0 and 2, got {target}")
    if motor is not None or target is not None:
        base = mech.steady or (SteadyCase(mech.dynamics.motor) if mech.dynamics.motor else None)
        m = motor or (base.motor if base else None)
        if m is not None:
            mech = dataclasses.replace(mech, steady=SteadyCase(m, target if target is not None else
                                                               (base.target_delta if base else 0.02)))
    return mech


def _check_speed(name: str, w) -> None:
    """A crank speed (rad/s) within the range the simulation is made for."""
    from .errors import MjlinkError
    from .model.limits import MAX_SPEED, MIN_SPEED

    if w is None:
        return
    if not (MIN_SPEED <= abs(w) <= MAX_SPEED):
        raise MjlinkError(f"{name} must be between {MIN_SPEED:g} and {MAX_SPEED:g} rad/s in magnitude "
                          f"({MIN_SPEED * 30 / 3.141592653589793:.3g} to {MAX_SPEED * 30 / 3.141592653589793:.3g} rpm), got {w:g} rad/s")


def _positive(name: str, v, allow_none=True):
    from .errors import MjlinkError

    if v is None and allow_none:
        return v
    if not (v > 0) or v != v or v == float("inf"):
        raise MjlinkError(f"{name} must be a positive finite number, got {v}")
    return v


def main(argv: list[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    from .errors import MjlinkError

    try:
        return _dispatch(args)
    except MjlinkError as e:
        if args.debug:
            raise
        print(f"mjlink: error: {e}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print("mjlink: interrupted", file=sys.stderr)
        return 130


def _dispatch(args) -> int:
    from .errors import MjlinkError

    if args.command == "list":
        from .model import catalogue
        from .model.mechanism import load

        for n in catalogue.names():
            m = load(catalogue.path_of(n))
            print(f"{n:<16} {m.title}")
            if m.source:
                print(f"{'':<16} source: {m.source}")
        return 0

    if args.command == "build":
        from .runs import DYNAMIC
        from .sim import builder, simulate

        mech = validation.get(args.mechanism)
        settings = DYNAMIC
        if args.kinematic:
            settings = simulate.kinematic_case(mech).settings
        xml = builder.to_xml(mech, settings)
        if args.output is None:
            sys.stdout.write(xml)
        else:
            _write_atomic(args.output, xml)
            print(f"wrote {args.output}", file=sys.stderr)
        return 0

    if args.command == "check":
        report = validation.check_file(args.mechanism)  # an unreadable file raises: nothing to report
        print(format_report(report))
        report.raise_if_failed()  # the first problem, as one line, exit 1
        return 0
    if args.command == "synth":
        return _synth(args)
    if args.command in ("torque", "reactions"):
        return _loads(args)
    if args.command == "steady":
        return _steady(args)

    # simulate
    try:
        w, h = (int(x) for x in args.size.lower().split("x"))
    except ValueError:
        raise MjlinkError(f"--size must be WIDTHxHEIGHT, e.g. 640x480; got '{args.size}'") from None
    _check_speed("--speed", args.speed)
    _positive("--cycles", args.cycles)
    from .model.limits import MAX_CYCLES

    if args.cycles is not None and args.cycles > MAX_CYCLES:
        raise MjlinkError(f"--cycles must be at most {MAX_CYCLES:g}, got {args.cycles:g}")
    _positive("--duration", args.duration)
    _positive("--video-seconds", args.video_seconds, allow_none=False)
    _positive("--fps", args.fps, allow_none=False)
    if w <= 0 or h <= 0 or w % 2 or h % 2 or w > 1920 or h > 1080:
        raise MjlinkError(f"--size must be even and at most 1920x1080, got {args.size}")
    if not args.no_video:
        from .sim.gl import ensure_gl_backend

        ensure_gl_backend()
    from . import compare, pipeline

    mech = validation.with_crank_settings(validation.get(args.mechanism), args.phi0, args.phase)
    mech = _with_drive(mech, args)
    if args.dynamics and args.no_dynamics:
        raise MjlinkError("--dynamics and --no-dynamics contradict each other")
    if args.dynamics and not pipeline.has_masses(mech):
        raise MjlinkError(f"{mech.name}: --dynamics needs masses and a [dynamics] table (or drive options) in the file")
    if args.dynamics and mech.steady is None:
        raise MjlinkError(f"{mech.name}: the steady-motion study needs a motor: give [steady] or [dynamics.motor] "
                          "in the file, or --stall-torque and --no-load-speed")
    opts = pipeline.Options(speed=args.speed, cycles=args.cycles, duration=None,
                            dynamics=not args.no_dynamics, plots=not args.no_plots, video=not args.no_video,
                            video_seconds=args.video_seconds, fps=args.fps, width=w, height=h,
                            steady=args.dynamics)
    print(f"mjlink: simulating {mech.name} ({mech.title})", file=sys.stderr)
    res = pipeline.run(mech, args.out, opts)
    print(f"\nAgreement of MuJoCo with the vector-method reference ({mech.name}):")
    print(compare.table(list(res.agreements)))
    dyn = res.report.get("dynamics", {})
    if "paper_rk4_1000_steps" in dyn:
        r = dyn["paper_rk4_1000_steps"]
        print(f"fixed-step RK4 (1000 steps, the paper's method) vs tight ODE: omega differs by up to {r['omega_max_abs_diff_rad_s']:.3g} "
              f"rad/s ({r['omega_max_rel_diff']:.2%} of max), final {r['omega_final_rel_diff']:.2%}")
    if "loads" in res.report:
        L = res.report["loads"]
        print(f"driving torque at {abs(L['speed_rpm']):.0f} rpm: peak {L['torque_peak_N_m']:.4g} N*m, RMS "
              f"{L['torque_rms_N_m']:.4g} N*m, mean power {L['power_mean_W']:.4g} W; MuJoCo vs kinetostatics: torque "
              f"{L['torque_error_rel']:.2e}, reactions {L['force_error_rel']:.2e} of range")
    if "steady" in res.report:
        _print_steady(res.report["steady"])
    if "video" in res.report:
        v = res.report["video"]
        print(f"video: {v['frames']} frames at {v['fps']} fps, slowed down {v['slowed_down_by']:.1f}x "
              f"({v['backend']})")
    print(f"outputs in {res.out_dir}/: {', '.join(res.files)}")
    print(f"total {res.report['timings']['total_s']:.2f} s")
    if res.failures:
        print("THRESHOLDS MISSED:\n  " + "\n  ".join(res.failures))
        return 3 if args.strict else 0
    return 0


def _synth(args) -> int:
    import math

    from .errors import MjlinkError
    from .model import catalogue
    from .reference import synthesis

    if args.problem != "crank_slider":
        raise MjlinkError(f"unknown synthesis problem '{args.problem}' (valid: crank_slider)")
    base_path = catalogue.path_of("crank_slider")
    base = validation.get("crank_slider").synthesis
    S = args.stroke * 1e-3 if args.stroke is not None else base.stroke
    e = args.offset * 1e-3 if args.offset is not None else base.offset
    lam = args.ratio if args.ratio is not None else base.ratio
    th = math.radians(args.max_pressure_angle) if args.max_pressure_angle is not None else base.max_pressure_angle
    print(synthesis.format_table(S, e, lam, th))
    best = synthesis.best(S, e, lam, th)
    print(f"\nchosen: {'none admissible' if best is None else f'r = {best.r.real * 1e3:.4f} mm, l = {best.l.real * 1e3:.4f} mm, theta_max = {math.degrees(best.theta_max):.2f} deg'}")
    top = synthesis.largest_ratio(S, e, th)
    if top is None:
        print(f"no lambda in 0.01..0.99 gives an admissible design with [theta] = {math.degrees(th):g} deg")
    else:
        t = synthesis.best(S, e, top, th)
        print(f"largest admissible lambda (step 0.01): {top:.2f} (theta_max {math.degrees(t.theta_max):.2f} deg)")
        nxt = synthesis.roots(S, e, round(top + 0.01, 10), th)[0]
        if not math.isnan(nxt.theta_max):
            print(f"  at lambda = {top + 0.01:.2f}: theta_max {math.degrees(nxt.theta_max):.2f} deg > "
                  f"{math.degrees(th):g} deg")
    if args.write is not None:
        name = args.write.stem
        from .model.mechanism import parse

        if not names.is_valid(name):
            raise MjlinkError(f"--write: the file name '{args.write.name}' must make a valid mechanism name "
                              "(a letter, then letters, digits or _)")
        text = synthesis.design_file(base_path.read_text(encoding="utf-8"), S, e, lam, th, name)
        validation.validate(parse(text, args.write))
        _write_atomic(args.write, text)
        print(f"wrote {args.write}")
    return 0


def _print_steady(s: dict) -> None:
    print(f"steady motion: mean {s['n_mean_rpm']:.1f} rpm, delta {s['delta']:.4f} (MuJoCo {s['delta_mujoco']:.4f}); "
          f"flywheel {s['flywheel_kg_m2']:.4g} kg*m^2 gives delta {s['delta_with_flywheel']:.4f} "
          f"(MuJoCo {s['delta_with_flywheel_mujoco']:.4f}, target {s['target_delta']:g})")


def _loads(args) -> int:
    import math

    import numpy as np

    from . import output, pipeline
    from .errors import MjlinkError
    from .sim import simulate

    mech = validation.get(args.mechanism)
    if not any(l.mass > 0 for l in mech.links):
        raise MjlinkError(f"{mech.name}: no masses in the file: give its links mass, inertia and com")
    speed = mech.speed
    if args.speed is not None:
        if not math.isfinite(args.speed) or args.speed == 0:
            raise MjlinkError(f"--speed must be a non-zero finite number of rev/min, got {args.speed}")
        speed = math.copysign(1.0, mech.speed) * args.speed * math.pi / 30.0
        _check_speed("--speed", speed)
    kin = simulate.run(mech, simulate.kinematic_case(mech, speed=speed))
    with output.staged_dir(Path(args.out) / f"{mech.name}_loads") as stage:
        jobs = [] if not args.no_plots else None
        entry, failures = pipeline.loads_outputs(mech, kin, stage, jobs)
        pipeline.run_jobs(jobs or [])
        output.write_json(stage / "report.json", {"mechanism": mech.name, "loads": entry, "failures": failures})
    print(f"{mech.name} at {abs(entry['speed_rpm']):.1f} rpm ({entry['speed_rad_s']:.4g} rad/s):")
    if args.command == "torque":
        print(f"  driving torque: peak {entry['torque_peak_N_m']:.5g} N*m, RMS {entry['torque_rms_N_m']:.5g} N*m, "
              f"mean power {entry['power_mean_W']:.5g} W")
        print(f"  MuJoCo vs reference: max error {entry['torque_error_rel']:.2e} of the torque range "
              f"(threshold {entry['thresholds']['torque_rel']:g})")
    else:
        print(f"  {'pair':<28} {'max |F| N':>10} {'MuJoCo N':>10} {'error/range':>12}")
        for lab, p in entry["pairs"].items():
            extra = f"   moment max {p['max_moment_N_m']:.4g} N*m" if "max_moment_N_m" in p else ""
            print(f"  {lab:<28} {p['max_force_N']:>10.4g} {p['max_force_mujoco_N']:>10.4g} {p['error_rel']:>12.2e}{extra}")
        print(f"  threshold {entry['thresholds']['force_rel']:g} of each pair's largest force")
    print(f"outputs in {Path(args.out) / (mech.name + '_loads')}/")
    if failures:
        print("THRESHOLDS MISSED:\n  " + "\n  ".join(failures))
        return 3 if args.strict else 0
    return 0


def _steady(args) -> int:
    from . import output, pipeline

    mech = _with_drive(validation.get(args.mechanism), args, steady=True)
    if mech.steady is None:
        from .errors import MjlinkError

        raise MjlinkError(f"{mech.name}: steady motion needs a motor: give [steady] or [dynamics.motor] in the file, "
                          "or --stall-torque and --no-load-speed")
    with output.staged_dir(Path(args.out) / f"{mech.name}_steady") as stage:
        jobs = [] if not args.no_plots else None
        entry = pipeline.steady_outputs(mech, stage, jobs)
        pipeline.run_jobs(jobs or [])
        output.write_json(stage / "report.json", {"mechanism": mech.name, "steady": entry})
    _print_steady(entry)
    print(f"outputs in {Path(args.out) / (mech.name + '_steady')}/")
    if entry["failures"]:
        print("THRESHOLDS MISSED:\n  " + "\n  ".join(entry["failures"]))
        return 3 if args.strict else 0
    return 0


def format_report(r: validation.CheckReport) -> str:
    """The report as text for a terminal (lengths mm, masses g, angles deg)."""
    out = [f"{r.name}: {r.title}", f"file: {r.path}", ""]
    w = max([len(p.name) for p in r.points] + [4])
    wm = max(len(p.made_by) for p in r.points)
    out.append(f"points ({sum(p.ground for p in r.points)} ground, {sum(not p.ground for p in r.points)} moving)")
    for p in r.points:
        on = f"on {', '.join(p.links)}" if p.links else "on no link"
        out.append(f"  {p.name:<{w}}  {'ground' if p.ground else 'moving'}  {p.made_by:<{wm}}  {on}")
    out.append("")
    out.append(f"links ({len(r.links)} moving)")
    wl = max([len(l.name) for l in r.links] + [4])
    for l in r.links:
        extra = []
        if l.mass > 0:
            extra.append(f"mass {l.mass * 1e3:g} g at {l.com}, inertia {l.inertia:g} kg*m^2")
        else:
            extra.append("massless")
        if l.guide:
            extra.append(f"slides along {l.guide[0]}-{l.guide[1]}")
        out.append(f"  {l.name:<{wl}}  points {', '.join(l.points)}; {'; '.join(extra)}")
    out.append("")
    out.append("kinematic pairs (as MuJoCo builds them: tree joints, loop-closing equalities)")
    if not r.pairs:
        out.append("  none could be formed (see problems)")
    for p in r.pairs:
        where = f"at {p.point}" if p.kind == PairKind.REVOLUTE else f"along {p.guide[0]}-{p.guide[1]}"
        role = {PairRole.JOINT: "joint " + (names.hinge_joint(p.child, p.point) if p.kind == PairKind.REVOLUTE
                                            else names.slide_joint(p.child)),
                PairRole.LOOP: "closes a loop: connect equality", PairRole.UNPLACED: "not placed"}[p.role]
        out.append(f"  {p.kind:<9} {where:<14} {p.parent + ' - ' + p.child:<{2 * wl + 3}}  {role}")
    loops = r.loops
    out.append(f"loops: {len(loops)}" + (f" (closed at {', '.join(str(p.point) for p in loops)})" if loops else ""))
    if r.gears:
        for g in r.gears:
            out.append(f"gear coupling: {g.link} ({g.point}) turns {g.ratio:g} times the input crank, "
                       f"phase {math.degrees(g.phase):g} deg at phi0 (joint equality)")
    else:
        out.append("gear couplings: none")
    m = r.mobility
    out.append(f"degrees of freedom: structural W = 3 n - 2 p = 3*{m.moving_links} - 2*{m.lower_pairs} = "
               f"{m.structural} ({m.revolute} revolute + {m.prismatic} prismatic pairs); with "
               f"{m.gears} gear coupling{'' if m.gears == 1 else 's'}: {m.driven}"
               + (" (the input crank's angle; none left once it is driven)" if m.driven == 1 else
                  "  <-- must be 1"))
    out.append("")
    if r.full_turn:
        out.append(f"assembly: the input crank turns fully (over {r.period_deg:g} deg)")
    else:
        out.append(f"assembly: NOT over a full turn; assembles only for input angles {r.assembly_ranges or 'none'} deg")
        for a in r.angles:
            if not a.closes:
                out.append(f"  {a.kind} {a.label} cannot close for input angles {a.fails_deg} deg")
    out.append(f"dead points (limits: transmission angle {MIN_TRANSMISSION_DEG:g}.."
               f"{180 - MIN_TRANSMISSION_DEG:g} deg, pressure angle <= {MAX_PRESSURE_DEG:g} deg"
               + ("" if r.full_turn else "; where it assembles") + ")")
    if not r.angles:
        out.append("  no dyad or slider")
    for a in r.angles:
        if math.isnan(a.worst_deg):
            out.append(f"  {a.kind} {a.label}: never assembles")
            continue
        verdict = ("ok" if a.ok else "TOO CLOSE") if r.full_turn else "(not judged: no full turn)"
        if a.kind == "dyad":
            out.append(f"  dyad {a.label:<22} transmission angle {a.worst_deg:7.2f} deg at input {a.phi_deg:6.1f} deg "
                       f"({a.margin_deg:.2f} deg from the dead point)  {verdict}")
        else:
            out.append(f"  slider {a.label:<20} pressure angle up to {a.worst_deg:5.2f} deg at input "
                       f"{a.phi_deg:6.1f} deg ({a.margin_deg:.2f} deg from the dead point)  {verdict}")
    if r.notes:
        out.append("")
        out += [f"note: {n}" for n in r.notes]
    out.append("")
    if r.problems:
        out.append(f"problems ({len(r.problems)}):")
        out += [f"  - {msg}" for _, msg in r.problems]
        out.append("result: cannot be simulated faithfully as it stands")
    else:
        out.append("result: ok, ready for 'python -m mjlink simulate'")
    return "\n".join(out)
