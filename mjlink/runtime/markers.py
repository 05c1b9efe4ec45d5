"""The marker every output folder of mjlink carries, and what it says.

A folder's marker is what lets a later run replace mjlink's own files in it, and only those;
a staging folder carries one from the moment it is made, which is what lets a later run
recognise it as mjlink's and tidy it away once its process is gone.
"""

from __future__ import annotations

import datetime
import json
import os
import socket
from pathlib import Path
from typing import Any

from ..files import read_json

__all__ = ["COMMANDS", "MARKER", "command_name", "marker", "read_marker", "stage_marker", "write_marker"]

MARKER = ".mjlink-output.json"
"""The file every output folder carries: ``written_by`` "mjlink", ``kind`` and ``command`` (what
wrote it), ``mechanism``, ``files`` (the names mjlink wrote there; the marker itself is not
listed), ``written`` (when, ISO 8601) and ``command_line``; ``previous`` names where the output
it replaced went while it was being removed. It is what allows a later run to replace those
files and only those. A staging folder carries one from its creation, with ``stage`` = its own
name, ``pid`` and ``host``: what lets a later run recognise it as mjlink's."""

# The command that writes each kind of output folder, for markers and messages.
COMMANDS = {"simulate": "simulate", "loads": "torque/reactions", "steady": "steady", "study": "study", "feed": "feed"}


def now() -> str:
    return datetime.datetime.now().astimezone().isoformat(timespec="seconds")


def marker(kind: str, mechanism: str | None, files: list[str], line: str | None, **more: Any) -> dict[str, Any]:
    """A folder's :data:`MARKER` (a stage's carries ``stage``, ``pid`` and ``host`` as ``more``)."""
    return {
        "written_by": "mjlink",
        "kind": kind,
        "command": f"mjlink {COMMANDS.get(kind, kind)}",
        "mechanism": mechanism,
        "files": files,
        "written": now(),
        "command_line": line,
        **more,
    }


def stage_marker(stage: Path, kind: str, mechanism: str | None, line: str | None) -> dict[str, Any]:
    return marker(kind, mechanism, [], line, stage=stage.name, pid=os.getpid(), host=socket.gethostname())


def write_marker(folder: Path, data: dict[str, Any]) -> None:
    (folder / MARKER).write_text(json.dumps(data, indent=2) + "\n", encoding="utf-8")


def read_marker(folder: Path | str) -> dict[str, Any] | None:
    """The :data:`MARKER` of an output folder, or None if it has none that mjlink wrote (absent,
    not a regular file, not JSON, or without ``written_by``, ``kind`` and ``files``)."""
    data = read_json(Path(folder) / MARKER)
    if not (
        isinstance(data, dict)
        and data.get("written_by") == "mjlink"
        and isinstance(data.get("kind"), str)
        and isinstance(data.get("files"), list)
        and all(isinstance(f, str) for f in data["files"])
    ):
        return None
    return data


def command_name(kind: str) -> str:
    return f"'mjlink {COMMANDS[kind]}'" if kind in COMMANDS else f"kind '{kind}'"
