"""Command line: ``python -m mjlink COMMAND ...``; argument parsing and printing only.

Every subcommand is one :class:`~.commands.Command` in :data:`~.commands.COMMANDS`; its
``run`` calls :mod:`mjlink.pipeline` (the one orchestrator) and prints the typed result with
:mod:`.text`. Errors print one line (``mjlink: error: ...``) and exit 1; usage errors
(argparse's: unknown option, missing argument, a value of the wrong form) print one line in
the same form and exit 2; ``--debug``, before or after the command, shows the traceback.
``--strict`` commands exit 3 when a threshold is missed. ``--version`` names mjlink's,
MuJoCo's and Python's versions.
"""

from __future__ import annotations

import argparse
import difflib
import functools
import os
import re
import sys
from importlib import metadata
from typing import Any, NoReturn

from .. import notes
from ..errors import MjlinkError
from ..runtime.signals import Terminated, interruptible
from ..version import __version__
from .commands import COMMANDS, EXAMPLES
from .text import error_line, format_report

__all__ = ["format_report", "main"]

# An argument that starts with '-' and a digit or point is a value (-1000rpm, -0.8, -1e-3,
# -.5), never an option: argparse itself only knows plain negative numbers.
_NEGATIVE_VALUE = re.compile(r"-\.?\d")


class _Parser(argparse.ArgumentParser):
    """argparse with mjlink's conventions: a usage error is one line, ``mjlink: error: ...``,
    exit status 2; negative values with units are values; a mistyped command gets a
    did-you-mean."""

    def error(self, message: str) -> NoReturn:
        m = re.search(r"invalid choice: '([^']*)'", message)
        if m:
            near = difflib.get_close_matches(m[1].lower(), [c.name for c in COMMANDS], n=1)
            if near:
                message += f"; did you mean '{near[0]}'?"
        self.exit(2, f"mjlink: error: {error_line(message)} (see '{self.prog} --help')\n")

    def _parse_optional(self, arg_string: str) -> Any:
        if _NEGATIVE_VALUE.match(arg_string):
            return None
        return super()._parse_optional(arg_string)


class _Version(argparse.Action):
    """``--version``: mjlink's version with MuJoCo's and Python's (MuJoCo's from its package
    metadata, without importing it)."""

    def __init__(self, option_strings: list[str], dest: str = argparse.SUPPRESS, **kwargs: Any) -> None:
        super().__init__(option_strings, dest, nargs=0, default=argparse.SUPPRESS, **kwargs)

    def __call__(self, parser: argparse.ArgumentParser, *args: Any, **kwargs: Any) -> NoReturn:

        try:
            mujoco = metadata.version("mujoco")
        except metadata.PackageNotFoundError:
            mujoco = "not installed"
        v = sys.version_info
        print(f"mjlink {__version__} (mujoco {mujoco}, python {v.major}.{v.minor}.{v.micro})")
        parser.exit(0)


# Built once per process: a parser keeps nothing from one parse to the next, and a script or
# a test suite may call main() many times (the help's width is still the terminal's when shown).
@functools.cache
def _parser() -> argparse.ArgumentParser:
    p = _Parser(
        prog="python -m mjlink",
        description=(
            "MuJoCo models of sewing- and knitting-machine linkages, checked against the "
            "vector-method reference analysis."
        ),
        epilog=EXAMPLES,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("--debug", action="store_true", help="show tracebacks on errors (also after the command)")
    p.add_argument("--version", action=_Version, help="print the versions of mjlink, MuJoCo and Python")
    sub = p.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for command in COMMANDS:
        q = sub.add_parser(
            command.name, help=command.help, epilog=command.epilog, formatter_class=argparse.RawDescriptionHelpFormatter
        )
        # Given after the command too; SUPPRESS keeps the value from before it when absent here.
        q.add_argument("--debug", action="store_true", default=argparse.SUPPRESS, help="show tracebacks on errors")
        command.arguments(q)
    return p


def main(argv: list[str] | None = None) -> int:
    """Parse ``argv`` (default: ``sys.argv[1:]``), run the command; returns the exit status.

    SIGINT ends a command with ``mjlink: interrupted`` and status 130, SIGTERM with ``mjlink:
    terminated`` and 143 (128 + the signal), both after the run has cleaned up (no staging
    folder, no worker process left)."""

    args = _parser().parse_args(argv)
    if not (args.command == "simulate" and not args.no_video) and not (args.command == "feed" and args.video):
        # Only simulate's and feed's videos render: every other command (and its Dask workers, which
        # inherit the environment) imports mujoco without probing OpenGL first.
        os.environ.setdefault("MJLINK_NO_GL", "1")
    # The command line as typed, for the reports: "python -m mjlink" and the arguments.
    args.command_line = ("python", "-m", "mjlink", *(sys.argv[1:] if argv is None else argv))
    run = next(c.run for c in COMMANDS if c.name == args.command)
    try:
        # SIGTERM unwinds like Ctrl-C instead of killing mid-run; notes go to stderr.
        with notes.to_stderr(), interruptible():
            return run(args)
    except MjlinkError as e:
        if args.debug:
            raise
        print(f"mjlink: error: {error_line(e)}", file=sys.stderr)
        return e.exit_status
    except KeyboardInterrupt:
        print("mjlink: interrupted", file=sys.stderr)
        return 130
    except Terminated:
        print("mjlink: terminated", file=sys.stderr)
        return 143
