"""Command line: ``python -m mjlink COMMAND ...``; argument parsing and printing only.

Every subcommand is one :class:`~.commands.Command` in :data:`~.commands.COMMANDS`; its
``run`` calls :mod:`mjlink.pipeline` (the one orchestrator) and prints the typed result with
:mod:`.text`. Errors print one line (``mjlink: error: ...``) and exit 1; ``--debug`` shows
the traceback. ``--strict`` commands exit 3 when a threshold is missed.
"""

from __future__ import annotations

import argparse
import sys

from ..errors import MjlinkError
from .commands import COMMANDS, EXAMPLES
from .text import format_report

__all__ = ["format_report", "main"]


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="python -m mjlink",
        description=(
            "MuJoCo models of sewing- and knitting-machine linkages, checked against the "
            "vector-method reference analysis."
        ),
        epilog=EXAMPLES,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("--debug", action="store_true", help="show tracebacks on errors")
    sub = p.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for command in COMMANDS:
        q = sub.add_parser(
            command.name, help=command.help, epilog=command.epilog, formatter_class=argparse.RawDescriptionHelpFormatter
        )
        command.arguments(q)
    return p


def main(argv: list[str] | None = None) -> int:
    """Parse ``argv`` (default: ``sys.argv[1:]``), run the command; returns the exit status."""
    args = _parser().parse_args(argv)
    run = next(c.run for c in COMMANDS if c.name == args.command)
    try:
        return run(args)
    except MjlinkError as e:
        if args.debug:
            raise
        print(f"mjlink: error: {e}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print("mjlink: interrupted", file=sys.stderr)
        return 130
