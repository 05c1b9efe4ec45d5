"""Command-line and file input (issue 9): every bad input is one line, never a traceback.

* Speeds (class 1): every speed is written with its unit and signed counter-clockwise positive,
  as a file's [input] speed; a bare number is an error; a speed against the file's direction
  is run with a 'note:' line; every command states the direction.
* One-line errors (class 8): '$' in titles, deep TOML nesting, integers of thousands of digits,
  absurd durations and synthesis inputs, empty and folder output paths, '~nosuchuser'.
* GL (class 12): an unusable MUJOCO_GL breaks only rendering, with one line.
* Cost (class 13): runs, videos, titles and point counts beyond the limits are refused before
  they start, with the estimate and the option to change.
* Conventions (class 15): --debug after the command, --version, did-you-mean, usage errors in
  one line with exit 2, values in the user's units, no raw control characters in errors.
"""

import argparse
import ctypes.util
import json
import math
import os
import subprocess
import sys

import matplotlib
import pytest
from conftest import ROOT, in_process

from mjlink import pipeline, validation
from mjlink.cli import _parser, main
from mjlink.cli.commands import _long_run
from mjlink.cli.text import against_file, crank_speed, error_line
from mjlink.cli.values import Speed, path_arg, speed_arg
from mjlink.errors import MechanismFileError, MjlinkError
from mjlink.model import catalogue, limits
from mjlink.model.mechanism import parse
from mjlink.model.reader import shown

matplotlib.use("Agg")

EXAMPLE_PATH = catalogue.MECHANISMS_DIR / "examples" / "crank_rocker.toml"
EXAMPLE = EXAMPLE_PATH.read_text()
ENV = {**os.environ, "PYTHONPATH": str(ROOT)}


def mjlink(*args, env=None, cwd=None):
    return subprocess.run(
        [sys.executable, "-m", "mjlink", *args],
        capture_output=True,
        text=True,
        cwd=cwd,
        env=env or ENV,
        timeout=600,
    )


def one_line_error(text: str) -> str:
    """The stderr of a failed command: exactly one line, 'mjlink: error: ...', no traceback."""
    lines = text.strip().splitlines()
    assert len(lines) == 1, text
    assert lines[0].startswith("mjlink: error: ") and "Traceback" not in text, text
    return lines[0]


def ex(old: str, new: str) -> str:
    assert old in EXAMPLE, old
    return EXAMPLE.replace(old, new, 1)


def refused(tmp_path, text: str) -> str:
    """The one-line MechanismFileError a file with ``text`` gets from the reader."""
    f = tmp_path / "mine.toml"
    f.write_text(text)
    with pytest.raises(MechanismFileError) as e:
        validation.get(f)
    msg = str(e.value)
    assert "\n" not in msg and msg.isprintable() and str(f) in msg, msg
    return msg


def usage_error(capsys, argv) -> str:
    """The one-line usage error of ``main(argv)``: exit status 2."""
    with pytest.raises(SystemExit) as e:
        main(argv)
    assert e.value.code == 2
    return one_line_error(capsys.readouterr().err)


def failed(capsys, argv) -> str:
    """The one-line error of ``main(argv)``: exit status 1."""
    assert main(argv) == 1
    return one_line_error(capsys.readouterr().err)


# ============================================================================ 1. speeds
@pytest.mark.parametrize(
    "text, rad_s",
    [
        ("955rpm", 955 * 3.141592653589793 / 30),
        ("100rad/s", 100.0),
        ("-100rad/s", -100.0),
        ("955 rpm", 955 * 3.141592653589793 / 30),
        ("955rev/min", 955 * 3.141592653589793 / 30),
        ("955 r/min", 955 * 3.141592653589793 / 30),
        ("+1e3rpm", 1000 * 3.141592653589793 / 30),
        (" -.5 rad/s ", -0.5),
        ("10rev/s", 20 * 3.141592653589793),
        ("-90 deg/s", -3.141592653589793 / 2),
    ],
)
def test_speeds_are_read_with_their_unit_and_sign(text, rad_s):
    assert speed_arg(text).rad_s == pytest.approx(rad_s, rel=1e-15)


@pytest.mark.parametrize(
    "text",
    [
        "955",
        "-100",
        "1e3",
        "fast",
        "955 rps",
        "rpm",
        "nan rpm",
        "1e999rpm",
        "955 rpm/s",
        "955 RPM",
        "10 Rev/s",
        "1e308rev/s",
    ],
)
def test_a_speed_without_a_unit_is_refused(text):
    with pytest.raises(argparse.ArgumentTypeError) as e:
        speed_arg(text)
    assert ("rpm" in str(e.value) and "rad/s" in str(e.value)) or "finite" in str(e.value)


@pytest.mark.parametrize(
    "argv",
    [
        ["simulate", "takeup", "--speed", "955"],
        ["torque", "warp_knitting", "--speed", "1000"],
        ["reactions", "takeup", "--speed", "-955"],
        ["simulate", "takeup", "--omega0", "5"],
        ["steady", "takeup", "--stall-torque", "0.05", "--no-load-speed", "120"],
    ],
)
def test_bare_numbers_are_one_line_usage_errors_naming_the_units(capsys, argv):
    msg = usage_error(capsys, argv)
    assert "with its unit" in msg and "rpm" in msg and "rad/s" in msg and "counter-clockwise" in msg


def test_negative_speeds_with_units_are_values_not_options():
    args = _parser().parse_args(
        ["simulate", "crank_slider", "--speed", "-955rpm", "--omega0", "-5 rpm", "--stall-torque", "-1e-3"]
    )
    assert args.speed == Speed(-955.0, "rpm") and args.omega0 == Speed(-5.0, "rpm") and args.stall_torque == -1e-3
    args = _parser().parse_args(["simulate", "crank_slider", "--no-load-speed=-160rad/s"])
    assert args.no_load_speed.rad_s == -160.0


def test_direction_is_stated_and_a_reversal_noted():
    assert crank_speed(100.0) == "954.9 rpm (100 rad/s), counter-clockwise"
    assert crank_speed(-104.71975511965977) == "1000.0 rpm (104.7 rad/s), clockwise"
    assert against_file("--speed", "-100rad/s", -100.0, -100.0) is None
    note = against_file("--speed", "100rad/s", 100.0, -100.0)
    assert note.startswith("note: --speed 100rad/s is counter-clockwise, against the file's own direction")
    assert "--speed=-100rad/s keeps" in note


@pytest.mark.slow
def test_simulate_speed_is_rpm_when_written_rpm_and_keeps_its_sign(tmp_path):
    # The issue: 'simulate takeup --speed 955' ran at 9,120 rpm; 955rpm is 100 rad/s.
    r = in_process(
        "simulate", "takeup", "--speed", "955rpm", "--no-dynamics", "--no-video", "--no-plots", "--out", str(tmp_path)
    )
    assert r.returncode == 0, r.stderr
    rep = json.loads((tmp_path / "takeup" / "report.json").read_text())
    assert rep["kinematics"]["speed_rad_s"] == pytest.approx(955.0 * 2.0 * math.pi / 60.0, rel=1e-12)
    assert "kinematic run: 955.0 rpm (100 rad/s), counter-clockwise" in r.stdout and "note:" not in r.stdout
    # crank_slider turns clockwise: a positive speed reverses it, never silently.
    r = in_process(
        "simulate", "crank_slider", "--speed", "100rad/s", "--no-dynamics", "--no-video", "--no-plots",
        "--out", str(tmp_path),
    )  # fmt: skip
    assert r.returncode == 0, r.stderr
    assert "note: --speed 100rad/s is counter-clockwise, against the file's own direction (clockwise" in r.stdout
    assert "kinematic run: 954.9 rpm (100 rad/s), counter-clockwise" in r.stdout
    rep = json.loads((tmp_path / "crank_slider" / "report.json").read_text())
    assert rep["kinematics"]["speed_rad_s"] == pytest.approx(100.0, rel=1e-6)


@pytest.mark.slow
def test_torque_speed_is_signed_like_the_file(tmp_path):
    r = in_process("reactions", "crank_slider", "--speed", "-955rpm", "--no-plots", "--out", str(tmp_path))
    assert r.returncode == 0, r.stderr
    assert "crank_slider at 955.0 rpm (100 rad/s), clockwise:" in r.stdout and "note:" not in r.stdout
    r = in_process("torque", "crank_slider", "--speed", "955rpm", "--no-plots", "--out", str(tmp_path))
    assert r.returncode == 0, r.stderr
    assert "at 955.0 rpm (100 rad/s), counter-clockwise:" in r.stdout
    assert "note: --speed 955rpm is counter-clockwise, against the file's own direction" in r.stdout


def test_speed_errors_show_the_value_as_written(capsys):
    msg = failed(capsys, ["simulate", "takeup", "--speed", "0rpm", "--no-video"])
    assert "--speed must be between 1 and 10000 rad/s" in msg and msg.endswith("got 0 rpm")
    msg = failed(capsys, ["simulate", "takeup", "--omega0", "1e6rad/s", "--no-video"])
    assert "--omega0" in msg and "1e+06 rad/s" in msg


def test_check_states_the_file_direction(capsys):
    assert main(["check", "crank_slider"]) == 0
    assert "input crank: 954.9 rpm (100 rad/s), clockwise ([input] speed = -100 rad/s)" in capsys.readouterr().out


# ============================================================================ 8. one-line errors
def test_user_text_in_plots_is_never_mathtext(tmp_path):
    import matplotlib.pyplot as plt

    from mjlink.plotting import style

    mech = parse(ex('title = "Plain crank-rocker (example)"', 'title = "a $5 part, $x^$ and $\\\\frac{$"'))
    assert style.user_text("a $5 $x^$") == r"a \$5 \$x^\$"
    fig, ax = plt.subplots()
    ax.set_title(style.title(mech, "speed $\\omega_1$"))  # mjlink's own mathtext stays
    style.save(fig, tmp_path, "t.png")
    assert (tmp_path / "t.png").stat().st_size > 0


def test_deep_toml_nesting_is_one_line(tmp_path):
    assert "TOML nested too deeply" in refused(tmp_path, ex("[input]", "[input]\nz = " + "[" * 5000 + "]" * 5000))
    assert "TOML nested too deeply" in refused(
        tmp_path, ex("[input]", "[input]\nz = " + "{a=" * 5000 + "1" + "}" * 5000)
    )


@pytest.mark.parametrize(
    "old, new, match",
    [
        ("length = 15.0", "length = " + "1" * 5000, "an integer of more than"),  # tomllib's own limit
        ("length = 15.0", "length = 0x" + "f" * 5000, "must be finite, got an integer of about 6021 digits"),
        ("D = [50.0, 0.0]", "D = [0x" + "f" * 5000 + ", 0.0]", "<an integer of about 6021 digits>"),
        ("sign = 1 ", "sign = 0x" + "f" * 5000 + " ", "sign: must be +1 or -1"),
        ('com = "S1"', "com = 0x" + "f" * 5000, "invalid name <an integer"),
    ],
    ids=["decimal", "hex", "vector", "sign", "name"],
)
def test_integers_of_thousands_of_digits_are_one_line(tmp_path, old, new, match):
    msg = refused(tmp_path, ex(old, new))
    assert match in msg and len(msg) < 400, msg


@pytest.mark.parametrize(
    "argv, match",
    [
        (["simulate", "takeup", "--duration", "1e-9", "--no-video"], "--duration must be between 0.025 and 100 s"),
        (["simulate", "takeup", "--duration", "1e9", "--no-video"], "got 1e+09 s"),
        (["simulate", "takeup", "--duration", "1e308", "--no-video"], "got 1e+308 s"),
        (["synth", "crank_slider", "--stroke", "1e308"], "--stroke must be between 0.1 and 1000 mm, got 1e+308 mm"),
        (["synth", "crank_slider", "--offset", "-5"], "--offset must be between 0 and 1000 mm, got -5 mm"),
        (["synth", "crank_slider", "--lambda", "1.5"], "--lambda must be between 0 and 1"),
        (["simulate", "takeup", "--size", "\uff16\uff140x480"], "--size must be WIDTHxHEIGHT"),
        (["synth", "crank_slider", "--max-pressure-angle", "90"], "--max-pressure-angle must be between 0 and 90 deg"),
        (["build", "takeup", "-o", "/"], "is a folder"),
        (["simulate", "~nosuchuser_mjlink/x.toml"], "cannot expand '~nosuchuser_mjlink'"),
    ],
)
def test_absurd_values_and_paths_are_one_line(capsys, argv, match):
    assert match in failed(capsys, argv)


@pytest.mark.parametrize("value", ["nan", "2 furlongs", "2 mm"])
def test_a_duration_that_is_not_a_time_is_a_usage_error_naming_the_units(capsys, value):
    msg = usage_error(capsys, ["simulate", "takeup", "--duration", value, "--no-video"])
    assert "--duration" in msg and repr(value) in msg
    assert "not a number with a unit" in msg or "not a unit of time (s, ms, min)" in msg


@pytest.mark.parametrize(
    "argv",
    [
        ["build", "takeup", "-o", ""],
        ["simulate", "takeup", "--out", ""],
        ["simulate", "takeup", "--out", "~nosuchuser_mjlink/x"],
        ["build", "takeup", "-o", "~nosuchuser_mjlink/x.xml"],
        ["synth", "crank_slider", "--write", "~nosuchuser_mjlink/x.toml"],
    ],
)
def test_empty_and_unexpandable_paths_are_usage_errors(capsys, argv):
    msg = usage_error(capsys, argv)
    assert "empty path" in msg or "no such user" in msg


def test_paths_expand_the_users_home():
    assert path_arg("~/x.xml") == path_arg(os.path.expanduser("~/x.xml"))


# ============================================================================ 12. GL backends
@pytest.mark.slow
@pytest.mark.parametrize(
    "value",
    ["bogus", pytest.param("osmesa", marks=pytest.mark.skipif(bool(ctypes.util.find_library("OSMesa")), reason="OSMesa installed"))],
)  # fmt: skip
def test_broken_mujoco_gl_breaks_only_rendering(tmp_path, value):
    env = {**ENV, "MUJOCO_GL": value}
    assert mjlink("check", "takeup", env=env).returncode == 0
    # build imports mujoco and the model builder: importing them does not touch the GL backend.
    r = mjlink("build", "takeup", "-o", str(tmp_path / "t.xml"), env=env)
    assert r.returncode == 0, r.stderr
    r = mjlink("simulate", "crank_slider", "--no-video", "--no-plots", "--no-dynamics", "--out", str(tmp_path), env=env)
    assert r.returncode == 0, r.stderr
    r = mjlink("simulate", "crank_slider", "--no-plots", "--no-dynamics", "--out", str(tmp_path / "v"), env=env)
    assert r.returncode == 1
    msg = one_line_error(r.stderr)
    assert "cannot render: MUJOCO_GL=" in msg and "backend tried:" in msg and "apt-get install libegl1" in msg


@pytest.mark.slow
def test_a_mujoco_gl_with_control_characters_fails_rendering_in_one_line(tmp_path):
    r = mjlink("simulate", "crank_slider", "--out", str(tmp_path), env={**ENV, "MUJOCO_GL": "b\x07d\nx"})
    assert r.returncode == 1
    msg = one_line_error(r.stderr)
    assert "MUJOCO_GL=b\\x07d\\nx is no backend mujoco knows" in msg and "\x07" not in msg


# ============================================================================ 13. cost
def test_the_estimate_counts_what_a_run_records(takeup):
    from mjlink.sim import simulate

    tr = simulate.run(takeup, simulate.kinematic_case(takeup, cycles=0.1))
    recorded = sum(
        a.size
        for a in (tr.time, tr.phi, tr.omega, tr.eps, tr.thread_length, tr.loop_gap, tr.torque, tr.qpos)
        if a is not None
    )
    recorded += sum(
        a.size
        for d in (tr.points, tr.velocities, tr.accelerations, tr.link_omega, tr.link_eps, tr.reactions, tr.moments)
        for a in d.values()
    )
    assert pipeline.values_per_sample(takeup) == recorded / len(tr.time)
    est = pipeline.estimate(takeup, pipeline.Options(video=False))
    assert [r.run for r in est.runs] == ["kinematic run", "dynamic run"] and est.long is None
    # The full turn the estimate is for, to the sample: the case's count of what the run records.
    assert abs(est.runs[0].samples - simulate.kinematic_case(takeup).samples) <= 1.0


def test_a_long_run_says_so_first(takeup, capsys):
    est = pipeline.estimate(takeup, pipeline.Options(speed=1.0, video=False, dynamics=False))
    assert est.long is not None and est.long.samples > limits.LONG_RUN_SAMPLES
    _long_run(est)
    err = capsys.readouterr().err
    assert err.startswith("mjlink: long run: the kinematic run records about 125,665 samples of 118 values")


@pytest.mark.parametrize(
    "argv, match",
    [
        (
            ["simulate", "takeup", "--speed", "1rad/s", "--cycles", "100", "--no-video"],
            "at most 2 GB of memory and 1 GB of CSV (mechanisms/README.md, Limits): lower --cycles or raise --speed",
        ),
        (["torque", "warp_knitting", "--speed", "1rad/s"], "GB of memory"),
        (["simulate", "takeup", "--video-seconds", "1e5"], "3,000,000 frames"),
        (["simulate", "takeup", "--fps", "1e9"], "--fps must be a whole number of frames/s from 1 to 240"),
        (["simulate", "takeup", "--fps", "29.97"], "--fps must be a whole number"),
        (["steady", "takeup", "--stall-torque", "1", "--no-load-speed", "0.5rad/s"], "--no-load-speed"),
    ],
)
def test_absurd_runs_are_refused_before_they_start(capsys, argv, match):
    msg = failed(capsys, argv)
    assert match in msg, msg


def test_memory_estimate_is_in_the_message(capsys):
    msg = failed(capsys, ["simulate", "takeup", "--speed", "1rad/s", "--cycles", "100", "--no-video"])
    assert "12,566,37" in msg and "samples of 118 values" in msg and "GB of memory" in msg


@pytest.mark.parametrize(
    "old, new, match",
    [
        ("omega0 = 0.0 ", "omega0 = 1e6 ", "omega0: must be at most 10000 rad/s in magnitude"),
        ("duration = 0.5 ", "duration = 1e308 ", "duration: must be at most 100 s"),
        ('title = "Plain crank-rocker (example)"', 'title = "' + "x" * 1_000_000 + '"', "at most 200 characters"),
        ('title = "Plain crank-rocker (example)"', 'title = "two\\nlines"', "one line of printable text"),
    ],
    ids=["omega0", "duration", "title_1MB", "title_newline"],
)
def test_absurd_file_values_are_refused(tmp_path, old, new, match):
    msg = refused(tmp_path, ex(old, new))
    assert match in msg and len(msg) < 500, msg


def test_too_many_points_are_refused_before_any_check(tmp_path):
    extra = "".join(
        f'[[construct]]\npoint = "Q{i}"\nblock = "attached"\norigin = "B"\ntoward = "C"\nangle = 10.0\n'
        f"length = {5 + i * 0.01}\n"
        for i in range(2000)
    )
    text = ex("# Rigid links.", extra + "# Rigid links.")
    text = text.replace(
        'points = ["B", "C", "E"]', 'points = ["B", "C", "E", ' + ", ".join(f'"Q{i}"' for i in range(2000)) + "]"
    )
    msg = refused(tmp_path, text)
    assert "at most 200" in msg


def test_points_times_turns_is_bounded():
    assert limits.MAX_CHECK_POINT_SAMPLES // limits.SAMPLES_PER_TURN >= 16 * 2  # warp_knitting fits
    for name in catalogue.names():
        validation.get(name)  # every registered file is within every limit


# ============================================================================ 15. conventions
def test_debug_after_the_command_shows_the_traceback(capsys, tmp_path):
    with pytest.raises(MjlinkError):
        main(["simulate", "nosuch", "--debug", "--out", str(tmp_path)])
    with pytest.raises(MjlinkError):
        main(["--debug", "simulate", "nosuch", "--out", str(tmp_path)])
    assert main(["simulate", "nosuch", "--out", str(tmp_path)]) == 1


def test_version(capsys):
    import mujoco

    with pytest.raises(SystemExit) as e:
        main(["--version"])
    assert e.value.code == 0
    v = sys.version_info
    assert (
        capsys.readouterr().out == f"mjlink 0.1.0 (mujoco {mujoco.__version__}, python {v.major}.{v.minor}.{v.micro})\n"
    )


@pytest.mark.parametrize("name", ["Takeup", "takup", "TAKEUP", "take_up"])
def test_did_you_mean_for_mechanisms(capsys, name):
    assert "did you mean 'takeup'?" in failed(capsys, ["check", name])


@pytest.mark.parametrize(
    "argv, match",
    [
        (["simulat", "takeup"], "invalid choice: 'simulat'"),
        (["simulate", "takeup", "--bogus"], "unrecognized arguments: --bogus"),
        (["simulate"], "the following arguments are required: mechanism"),
        (["simulate", "takeup", "--cycles", "x"], "argument --cycles: 'x' is not a number"),
        (["synth", "crank_slider", "--lambda", "nan"], "argument --lambda: 'nan' is not a number"),
        # other scripts' digits, which float() and int() would take, in every plain-number option
        (["simulate", "takeup", "--cycles", "\u0661\u0662"], "write the number with the digits 0-9"),
        (["simulate", "takeup", "--fps", "\uff13\uff10"], "write the number with the digits 0-9"),
        (["steady", "takeup", "--target-delta", "\u0660.\u0660\u0662"], "write the number with the digits 0-9"),
        (["synth", "crank_slider", "--lambda", "\u0660.\u0663"], "write the number with the digits 0-9"),
        (["study", "crank_slider_grid", "--workers", "\uff12"], "is not a whole number: write it with the digits 0-9"),
        (["study", "crank_slider_grid", "--max-memory", "\uff16\uff14GiB"], "is not a memory size"),
        ([], "the following arguments are required: COMMAND"),
    ],
)
def test_usage_errors_are_one_line_with_status_2(capsys, argv, match):
    msg = usage_error(capsys, argv)
    assert match in msg and "--help" in msg
    if argv[:1] == ["simulat"]:
        assert "did you mean 'simulate'?" in msg


def test_usage_error_in_a_real_process():
    r = mjlink("simulate", "takeup", "--speed", "955")
    assert r.returncode == 2
    one_line_error(r.stderr)


def test_values_are_given_in_the_users_units(tmp_path):
    assert refused(tmp_path, ex("length = 15.0", "length = -5")).endswith("must be > 0, got -5 mm")
    assert refused(tmp_path, ex("length = 15.0", "length = 0.001")).endswith("got 0.001 mm")
    assert refused(tmp_path, ex("speed = 100.0", "speed = 1e5")).endswith("got 100000 rad/s")


def test_errors_never_carry_control_characters(tmp_path, capsys):
    msg = refused(tmp_path, ex("length_a = 45.0", '"bad\\nkey\\u0007" = 45.0'))
    assert "unknown key 'bad\\nkey\\x07'" in msg
    msg = refused(tmp_path, ex('name = "crank_rocker"', 'name = "x\\u001b[31mred"'))
    assert "\x1b" not in msg and "\\x1b" in msg
    msg = failed(capsys, ["simulate", str(tmp_path / "nosuch\nfile\x07.toml")])
    assert "\\n" in msg and "\\x07" in msg
    assert error_line("a\nb\tc\x00\u2028d") == "a\\nb\\tc\\x00\\u2028d" and error_line("µ ä") == "µ ä"
    assert shown("x" * 10_000).endswith("xxx'") and len(shown("x" * 10_000)) < 100
    assert shown([[[[[[1]]]]]]) == "[[[[...]]]]"


LONG = "a" * 5000  # no file system holds a name of 5000 bytes (Linux: 255 a name)


@pytest.mark.parametrize(
    "argv",
    [
        ["build", "takeup", "-o", LONG],
        ["export", "takeup", "--dxf", f"{LONG}.dxf"],
        ["design", "takeup", "-o", LONG],
        ["simulate", "takeup", "--no-video", "--out", LONG],
        ["torque", "takeup", "--out", f"x/{LONG}"],
        ["study", "crank_slider_grid", "--dry-run", "--out", LONG],
        ["synth", "crank_slider", "--write", f"{LONG}.toml"],
    ],
    ids=["build", "export", "design", "simulate", "torque", "study", "synth"],
)
def test_a_path_option_too_long_for_the_file_system_is_a_usage_error(capsys, argv):
    msg = usage_error(capsys, argv)
    assert "path too long for the file system" in msg and len(msg) < 400, msg


@pytest.mark.parametrize("command", ["check", "simulate", "study"])
@pytest.mark.parametrize("name", [LONG, f"{'a/' * 3000}x.toml"], ids=["name", "path"])
def test_a_mechanism_or_study_too_long_for_the_file_system_is_one_line(capsys, command, name):
    # a study file refused before any work is status 2, as every bad study file (studies/README.md)
    assert main([command, name]) == (2 if command == "study" else 1)
    msg = one_line_error(capsys.readouterr().err)
    assert "File name too long" in msg and len(msg) < 400, msg
