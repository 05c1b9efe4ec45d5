"""One run per output folder, and the tidying of what killed runs left beside it.

:class:`FolderLock` is held by a run from before its work until it has published; a second
run into the same folder is refused at once, naming the first. :func:`remove_stale` removes
the staging folders and old outputs of runs that were killed, and only those: what mjlink
created and marked, once its process is gone.
"""

from __future__ import annotations

import contextlib
import errno
import hashlib
import os
import re
import shutil
import socket
import sys
from pathlib import Path

from ..errors import OutputError
from .markers import COMMANDS, read_marker

__all__ = ["STALE", "FolderLock", "alive", "remove_stale"]

STALE = re.compile(r"\.(?P<name>.+)\.(?:partial-(?P<pid>[0-9]+)-[^.]+|old-(?P<old>[0-9]+)(?:-[0-9a-f]+)?)", re.S)


def remove_stale(folder: Path | str) -> list[str]:
    """Remove what killed runs left in ``folder``; returns the names removed or put back.

    Only folders mjlink created and marked are touched, and only once their process is gone (or
    a zombie): a staging folder ``.NAME.partial-<pid>-<random>`` whose marker names it as a
    stage made on this host, or that the marker of ``NAME`` names as its previous output (the
    old output, exchanged into the stage's place, not yet deleted), is deleted; an old output
    ``.NAME.old-<pid>[-<random>]`` with mjlink's marker is renamed back to ``NAME`` if ``NAME``
    is missing (the previous output cut off in mid-publication), or deleted if ``NAME``'s marker
    names it as its previous output. Anything else, whatever its name (a user's folder, file or
    link that looks like one of these), is left alone; errors are ignored (this is tidying,
    not the run's work).
    """
    removed: list[str] = []
    try:
        entries = list(os.scandir(folder))
    except OSError:
        return removed
    host = socket.gethostname()
    for entry in entries:
        m = STALE.fullmatch(entry.name)
        if m is None:
            continue
        try:
            if not entry.is_dir(follow_symlinks=False) or alive(int(m["pid"] or m["old"])):
                continue
            path, dest = Path(entry.path), Path(folder) / m["name"]
            marker = read_marker(path)
            if marker is None:
                continue  # not mjlink's, whatever its name says
            previous = (read_marker(dest) or {}).get("previous") if os.path.isdir(dest) else None
            if m["pid"]:
                ours = marker.get("stage") == entry.name and marker.get("host") == host
                if not (ours or previous == entry.name):
                    continue
                shutil.rmtree(path)
            elif not os.path.lexists(dest):
                os.rename(path, dest)
            elif previous == entry.name:
                shutil.rmtree(path)
            else:
                continue
            removed.append(entry.name)
        except OSError:
            continue
    return removed


def alive(pid: int) -> bool:
    """Whether process ``pid`` may still be running (True when in doubt)."""
    if os.name != "posix" or pid <= 0:
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (OSError, OverflowError):
        return True  # EPERM: another user's live process
    try:
        with open(f"/proc/{pid}/stat", "rb") as f:
            st = f.read()
    except OSError:
        return True
    state = st[st.rfind(b")") + 2 : st.rfind(b")") + 3]
    return state not in (b"Z", b"X")


class FolderLock:
    """The lock of output folder ``dest`` while a run writes it: on Linux an abstract-namespace
    Unix socket bound to a name derived from the folder's real path. Binding fails while
    another process holds the name, and the kernel releases it when the holder ends, however
    it ends: a killed run never blocks the next one, and nothing is left on disk. The holder is
    named from its staging folder's marker. Elsewhere (no abstract namespace) there is no lock:
    two runs into one folder then each publish whole, the later one replacing the earlier.
    """

    def __init__(self, dest: Path, kind: str, line: str | None):
        self.dest = dest
        self.sock: socket.socket | None = None
        if not sys.platform.startswith("linux"):
            return
        where = os.path.join(os.path.realpath(dest.parent), dest.name)
        name = "\0mjlink-output:" + hashlib.sha256(os.fsencode(where)).hexdigest()
        sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)  # close-on-exec, as Python makes it
        try:
            sock.bind(name)
        except OSError as e:
            sock.close()
            if e.errno != errno.EADDRINUSE:
                return  # no abstract namespace here: run without the lock
            raise OutputError(
                f"cannot write outputs to {dest}: another mjlink run is writing there{self._holder()}; "
                "wait for it to end, or give another --out"
            ) from None
        self.sock = sock

    def _holder(self) -> str:
        """' (process N, 'COMMAND', since TIME)' from the live run's staging folder, if found."""
        with contextlib.suppress(OSError):
            for entry in os.scandir(self.dest.parent):
                m = STALE.fullmatch(entry.name)
                if m is None or not m["pid"] or m["name"] != self.dest.name or not alive(int(m["pid"])):
                    continue
                marker = read_marker(entry.path)
                if marker is not None and marker.get("stage") == entry.name:
                    since = str(marker.get("written", "")).replace("T", " ")[:19]
                    who = marker.get("command_line") or f"mjlink {COMMANDS.get(marker['kind'], marker['kind'])}"
                    return f" (process {marker.get('pid')}, '{who}', since {since})"
        return ""

    def release(self) -> None:
        if self.sock is not None:
            self.sock.close()
            self.sock = None
