"""The catalogue of mechanisms: every shipped ``mechanisms/*.toml``, by name.

The shipped mechanism and study files are package data (``mjlink/mechanisms`` and
``mjlink/studies`` of an installed wheel, found with :mod:`importlib.resources`); run from a
source checkout (an editable install, or ``python -m mjlink`` inside the checkout, where the
package's own folder shadows an installed copy), they are the checkout's top-level
``mechanisms/`` and ``studies/``, which the wheel is built from.

Names and paths, the rule (one argument, never both readings):

* An argument that ends in ``.toml``, contains a path separator (``/``, or ``\\`` on
  Windows), or starts with ``~`` or ``.`` is a **path**, always: ``~`` is expanded, a relative
  path is taken from the current folder, spaces need only the shell's quoting. It is never
  looked up as a name: ``./takeup.toml`` is the file in the current folder even though
  ``takeup`` is registered. A :class:`pathlib.Path` is always a path.
* Any other argument is a **registered name** (:func:`names`): the shipped
  ``mechanisms/NAME.toml``. A file in the current folder called like a registered mechanism is not
  used for the bare name; write ``./takeup``. Only a bare word that is no registered name but
  is an existing file is read as that file (so ``my_linkage`` works without an extension).

"""

from __future__ import annotations

import difflib
import importlib.resources
import os
import reprlib
import stat
from pathlib import Path

from ..errors import UnknownMechanismError


def shipped(folder: str) -> Path:
    """The folder of shipped files called *folder* (``'mechanisms'`` or ``'studies'``).

    Package data of the installed package where it is there; otherwise the source checkout's
    top-level folder (the package's parent). Shipped files are read as files on disk: a
    mechanism file can name another by a relative path (``../mechanisms/examples/...``), which
    the wheel keeps by shipping both folders side by side inside the package.
    """
    data = importlib.resources.files("mjlink").joinpath(folder)
    if isinstance(data, Path) and data.is_dir():
        return data
    return Path(__file__).resolve().parent.parent.parent / folder


MECHANISMS_DIR = shipped("mechanisms")
STUDIES_DIR = shipped("studies")  # the shipped study files (mjlink.study.spec)


def names() -> list[str]:
    """Names of the registered mechanisms, sorted."""
    return sorted(p.stem for p in MECHANISMS_DIR.glob("*.toml"))


def _is_path(s: str) -> bool:
    seps = {"/", os.sep} | ({os.altsep} if os.altsep else set())
    return s.endswith(".toml") or any(c in s for c in seps) or s.startswith(("~", "."))


def what_is(p: Path) -> str | None:
    """What ``p`` is when it is no regular file ('a folder', 'a FIFO (named pipe)', 'a character
    device', ...), None for a regular file or nothing at all. Never opens ``p``: reading a FIFO
    would wait for a writer."""
    try:
        mode = p.stat().st_mode
    except FileNotFoundError:
        return "a symbolic link to nothing" if p.is_symlink() else None
    except OSError as e:  # a loop of links, a path through a file, no permission to look
        return f"a path that cannot be looked at ({e.strerror or e})"
    return None if stat.S_ISREG(mode) else kind_of(mode)


_FILE_KINDS = (
    (stat.S_ISREG, "a regular file"),
    (stat.S_ISDIR, "a folder"),
    (stat.S_ISFIFO, "a FIFO (named pipe)"),
    (stat.S_ISCHR, "a character device"),
    (stat.S_ISBLK, "a block device"),
    (stat.S_ISSOCK, "a socket"),
)


def kind_of(mode: int) -> str:
    """What a file of ``mode`` (``os.stat``'s ``st_mode``) is, for a message: 'a FIFO (named
    pipe)', 'a folder', ..."""
    return next((name for test, name in _FILE_KINDS if test(mode)), "not a regular file")


_REPR = reprlib.Repr()
_REPR.maxstring = 300


def _said(s: str) -> str:
    """A name or path as a message echoes it: as written if it is short printable text, else
    quoted, escaped and clipped (one short line)."""
    return s if s.isprintable() and len(s) <= 300 else _REPR.repr(s)


def path_of(name_or_path: str | Path) -> Path:
    """The file of a registered name, or the given path (see the module docstring for the rule).

    Raises UnknownMechanismError (one line) for an unknown name, a missing file or a folder.
    """
    s = str(name_or_path)
    said = _said(s)
    if not s.strip():
        raise UnknownMechanismError(f"empty mechanism name (valid: {', '.join(names())}, or a path to a .toml file)")
    if isinstance(name_or_path, Path) or _is_path(s):
        try:
            p = Path(s).expanduser()
        except RuntimeError:  # ~user of no such user
            raise UnknownMechanismError(
                f"{said}: cannot expand '{_said(s.split('/')[0])}': no such user or home folder"
            ) from None
        shown = said if str(p) == s else f"{said} ({_said(str(p))})"
        what = what_is(p)
        if what is not None:
            raise UnknownMechanismError(f"{shown}: is {what}, not a mechanism file")
        if not p.is_file():
            raise UnknownMechanismError(f"{shown}: no such mechanism file")
        return p
    if s in names():
        return MECHANISMS_DIR / f"{s}.toml"
    p = Path(s)
    what = what_is(p)  # first: it never raises (a name too long for the file system)
    if what is None and p.is_file():
        return p
    if what is not None and what != "a folder":  # a folder called like a name: the name's error
        raise UnknownMechanismError(f"{said}: is {what}, not a mechanism file")
    near = difflib.get_close_matches(s.lower(), [n.lower() for n in names()], n=1)
    hint = f"did you mean '{next(n for n in names() if n.lower() == near[0])}'? " if near else ""
    raise UnknownMechanismError(
        f"unknown mechanism {said if said != s else repr(s)} ({hint}valid: {', '.join(names())}, or a path to a .toml file)"
    )
