"""Output folders: written whole or not at all, only where mjlink may write, one run at a time.

A run writes into a hidden staging folder beside its destination and renames it into place only
when everything is written (:func:`staged_dir`); single files are written atomically by
:mod:`mjlink.files`.

What mjlink may touch in an output folder, and when it checks:

* **Before any work** (:func:`check_destination`, called by :func:`staged_dir` on entry and by
  commands that compute before they stage): the destination is absent or a folder (a regular
  file, a FIFO, a device is refused), its nearest existing parent is a folder mjlink can write
  into, and an existing destination is mjlink's own output of the same command and mechanism
  (its :data:`MARKER`), empty, or ``force`` is given. A refusal creates nothing.
* **One run per destination**: a run holds the folder's lock from before its work until it has
  published; a second run into the same folder is refused at once with a line naming the
  first (its process, command and start). On Linux the lock is an abstract-namespace socket
  name (nothing on disk; the kernel releases it when the run ends, however it ends).
* **Only what mjlink created and marked is ever removed**: a staging folder carries a marker
  naming itself from the moment it is made; the tidying of what killed runs left behind
  (:func:`.lock.remove_stale`) removes a staging folder only if it carries that marker and its
  process is gone, and never touches an entry without it (a user's folder, file or link whose
  name merely looks like one). The previous output is replaced only in the files its marker
  lists; everything else in the folder is kept.
* **A replaced output is said so**, in one line (:mod:`mjlink.notes`): when it was written,
  by which command, and which of its files this run did not write again (gone now).

A run ends cleanly on SIGINT and SIGTERM (:mod:`.signals`).
"""

import contextlib
import ctypes
import errno
import os
import secrets
import shutil
import stat
import sys
import tempfile
import threading
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from ..errors import OutputError
from ..model.catalogue import kind_of
from ..notes import note
from .lock import FolderLock, remove_stale
from .markers import MARKER, command_name, read_marker, stage_marker, write_marker
from .markers import marker as folder_marker
from .signals import interruptible, raise_if_signalled, uninterrupted

__all__ = ["check_destination", "on_discard", "staged_dir"]

_stages = threading.local()  # per thread: the stop hooks of each open staged_dir, innermost last


def on_discard(stop: Callable[[], None]) -> Callable[[], None]:
    """Have ``stop`` called before the innermost :func:`staged_dir` of this thread publishes or
    removes its stage.

    A process that writes into the stage (the forked plot worker) registers how to stop and reap
    it, so that a failed, interrupted or terminated run never removes a stage that is still being
    written into (the worker would re-create it and leave it behind). Returns the function that
    unregisters ``stop``, to call once the helper is done. Outside a staged_dir nothing is
    registered.
    """
    stack: list[list[Callable[[], None]]] = getattr(_stages, "hooks", [])
    if not stack:
        return lambda: None
    hooks = stack[-1]
    hooks.append(stop)

    def cancel() -> None:
        with contextlib.suppress(ValueError):
            hooks.remove(stop)

    return cancel


def _stop(hooks: list[Callable[[], None]]) -> None:
    while hooks:
        with contextlib.suppress(Exception):
            hooks.pop()()


def check_destination(
    dest: Path | str, *, kind: str = "output", mechanism: str | None = None, force: bool = False
) -> Path:
    """Refuse, before any work, an output folder mjlink cannot or may not write; returns it
    (a symbolic link to a folder resolved).

    ``dest`` must be absent or a folder (not a regular file, a FIFO, a device); its nearest
    existing parent must be a folder this process can write into; an existing ``dest`` must be
    mjlink's output of ``kind`` for ``mechanism``, or empty, or ``force`` given (see
    :func:`staged_dir`). Creates nothing. Raises a one-line OutputError.
    """
    dest = Path(dest)
    try:
        link = stat.S_ISLNK(os.lstat(dest).st_mode)
    except (FileNotFoundError, NotADirectoryError):  # nothing there yet; a path through a file: below
        link = False
    except OSError as e:  # a name longer than the system allows, a loop of links on the way
        raise OutputError(f"cannot write outputs to {dest}: {_why(e)}") from None
    if link:
        target = Path(os.path.realpath(dest))
        if not os.path.lexists(target):
            # Following it would create folders wherever it points, outside the one asked for.
            raise OutputError(f"output path {dest} is a symbolic link to {target}, which does not exist")
        dest = target
    anc = dest.parent
    while not os.path.lexists(anc) and anc != anc.parent:
        anc = anc.parent
    try:
        mode = os.stat(anc).st_mode
    except OSError as e:
        raise OutputError(f"cannot write to output folder {dest.parent}: {_why(e)}") from None
    if not stat.S_ISDIR(mode):
        raise OutputError(f"cannot write to output folder {dest.parent}: {anc} is {kind_of(mode)}, not a folder")
    if os.path.lexists(dest):
        try:
            mode = os.stat(dest).st_mode
        except OSError as e:
            raise OutputError(f"cannot write outputs to {dest}: {_why(e)}") from None
        if not stat.S_ISDIR(mode):
            raise OutputError(f"output path {dest} exists and is not a folder ({kind_of(mode)})")
        _owned(dest, kind, mechanism, force)
        anc = dest
    if not os.access(anc, os.W_OK | os.X_OK):
        raise OutputError(f"cannot write to output folder {dest.parent}: permission denied ({anc})")
    return dest


@contextmanager
def staged_dir(
    dest: Path | str,
    *,
    kind: str = "output",
    force: bool = False,
    mechanism: str | None = None,
    command: str | Sequence[str] | None = None,
) -> Iterator[Path]:
    """Yield a staging folder; on success its files are published at ``dest``, on failure it is
    removed.

    Args:
        dest: the output folder (a symbolic link to a folder is followed).
        kind: what writes it (``"simulate"``, ``"loads"`` for torque and reactions,
            ``"steady"``, ``"study"``; the default ``"output"`` is no command's): recorded in
            the folder's :data:`MARKER`, and an existing ``dest`` is only published into if its
            marker has the same kind.
        force: publish into an existing ``dest`` that mjlink did not write for this ``kind``
            and ``mechanism``: the files of the new output replace entries of the same name,
            every other entry is kept.
        mechanism: the mechanism's name, recorded in the marker and compared like ``kind``.
        command: the command line, recorded in the marker (and named when this output is
            replaced by a later run, or when a second run finds this one holding the lock).

    * On entry, before the body runs: :func:`check_destination`; the folder's lock (a second
      run into the same folder is refused, :class:`_Lock`); the tidying of what killed runs left
      (:func:`remove_stale`); the stage, a hidden ``.NAME.partial-<pid>-<random>`` beside
      ``dest`` (same file system, so publishing is a rename, never a copy), marked as mjlink's
      at once.
    * Publishing writes the marker listing the new files into the stage. A ``dest`` that does
      not exist is then simply renamed into place. An existing ``dest`` is published into only
      if its marker says mjlink wrote it with the same ``kind`` and ``mechanism`` (checked again:
      the folder may have changed during the run); then the files that marker lists are
      mjlink's and are replaced (or removed, if this run did not write them again: a note says
      which); every other entry (a user's notes, a folder) is kept, and one with the name of a
      new file makes the run refuse. Without such a marker the run refuses, unless the folder is
      empty or ``force`` is given: a one-line OutputError naming the folder and ``--force``.
    * The kept entries are hard-linked into the stage (a folder as a tree of hard links), then
      the stage and ``dest`` are exchanged atomically (Linux ``renameat2(RENAME_EXCHANGE)``): at
      every instant ``dest`` is the complete old output or the complete new one, and every kept
      file is in it. Elsewhere (or on file systems without the exchange) by two renames, ``dest``
      -> ``.NAME.old-<pid>-<random>`` then stage -> ``dest``, putting the old one back if the
      second fails. The old output is then deleted (an entry that appeared in it meanwhile is
      moved over first); the new marker's ``previous`` names where it was, so that a run killed
      in between leaves something the next run recognises.
    * If the body raises, helpers registered with :func:`on_discard` are stopped, the stage is
      deleted and ``dest`` is left as it was (absent, or the previous complete output): a failed
      run never leaves a folder that looks complete. An OSError (disk full, permission, ...)
      becomes a one-line OutputError; anything else propagates unchanged. For the duration,
      SIGTERM raises :class:`Terminated` (:func:`interruptible`), so a terminated run cleans up
      like an interrupted one, and a run that received SIGINT or SIGTERM publishes nothing even
      if some code swallowed the exception; the clean-up and the publication are not cut short
      by a second signal (:func:`uninterrupted`). Only SIGKILL or a power loss leaves a stage
      behind, and the next run into the same folder removes it.
    """
    dest = check_destination(dest, kind=kind, mechanism=mechanism, force=force)
    parent = dest.parent
    line = command if isinstance(command, str) or command is None else " ".join(command)
    stack: list[list[Callable[[], None]]] = _stages.__dict__.setdefault("hooks", [])
    hooks: list[Callable[[], None]] = []
    stage: Path | None = None
    lock: FolderLock | None = None
    with interruptible():
        stack.append(hooks)
        try:
            try:
                parent.mkdir(parents=True, exist_ok=True)
                lock = FolderLock(dest, kind, line)
                remove_stale(parent)
                stage = Path(tempfile.mkdtemp(prefix=f".{dest.name}.partial-{os.getpid()}-", dir=parent))
                stage.chmod(0o755)  # mkdtemp's 0700 would make the published folder private
                write_marker(stage, stage_marker(stage, kind, mechanism, line))
            except OSError as e:
                raise OutputError(f"cannot write to output folder {parent}: {_why(e)}") from None
            yield stage
            raise_if_signalled()  # interrupted, though the body swallowed it: publish nothing
            with uninterrupted():
                _stop(hooks)
                _publish(stage, dest, kind, mechanism, force, line)
        except OSError as e:
            _discard(stage, hooks)
            raise OutputError(f"cannot write outputs to {dest}: {_why(e)}") from None
        except BaseException:
            _discard(stage, hooks)
            raise
        finally:
            if lock is not None:
                lock.release()
            stack[:] = [h for h in stack if h is not hooks]  # by identity: empty lists are all equal


def _discard(stage: Path | None, hooks: list[Callable[[], None]]) -> None:
    """Stop the stage's writers, then delete it."""
    with uninterrupted():
        _stop(hooks)
        if stage is not None:
            shutil.rmtree(stage, ignore_errors=True)


def _why(e: OSError) -> str:
    """An OSError as a short cause: 'No space left on device (kinematics.csv)'."""
    what = e.strerror or str(e) or type(e).__name__
    return f"{what} ({Path(e.filename).name})" if e.filename else what


def _shown(names: Sequence[str]) -> str:
    """File names for a one-line message (at most three, non-printable ones quoted)."""
    shown = [n if n.isprintable() else repr(n) for n in names[:3]]
    return ", ".join(shown) + (f" and {len(names) - 3} more" if len(names) > 3 else "")


def _owned(dest: Path, kind: str, mechanism: str | None, force: bool) -> set[str]:
    """The entries of the existing folder ``dest`` that mjlink may replace or remove: those its
    marker lists if it was written for ``kind`` and ``mechanism``; with ``force`` and no such
    marker, none (entries are then replaced only by new files of the same name)."""
    marker = read_marker(dest)
    if marker is not None and marker["kind"] == kind and (mechanism is None or marker.get("mechanism") == mechanism):
        return set(marker["files"])
    if force or (marker is None and not os.listdir(dest)):  # an empty folder has nothing to lose
        return set()
    if marker is None:
        why = f"it was not written by mjlink (it has no {MARKER})"
    else:
        other = marker.get("mechanism")
        why = f"it holds the output of {command_name(marker['kind'])}{f' for {other}' if other else ''}, not of {command_name(kind)}"
        if mechanism is not None and marker["kind"] == kind:
            why = (
                f"it holds the output of {command_name(kind)} for {other or 'no named mechanism'}, not for {mechanism}"
            )
    raise OutputError(
        f"cannot write outputs to {dest}: {why}; move it away, or use --force to write mjlink's files into it "
        "(other files are kept)"
    )


def _publish(stage: Path, dest: Path, kind: str, mechanism: str | None, force: bool, line: str | None = None) -> None:
    """Put the complete ``stage`` at ``dest`` with its marker, keeping every entry of an existing
    ``dest`` that mjlink did not write (see :func:`staged_dir`)."""
    new = sorted(e for e in os.listdir(stage) if e != MARKER)
    marker = folder_marker(kind, mechanism, new, line)
    if not os.path.lexists(dest):
        write_marker(stage, marker)
        os.replace(stage, dest)
        return
    if not dest.is_dir():
        raise OutputError(f"output path {dest} exists and is not a folder")
    before = read_marker(dest)
    owned = _owned(dest, kind, mechanism, force)
    present = set(os.listdir(dest))
    keep = sorted(e for e in present if e != MARKER and e not in owned)
    clash = [e for e in keep if e in new]
    if clash and not force:
        them = "it" if len(clash) == 1 else "them"
        raise OutputError(
            f"cannot write outputs to {dest}: {_shown(clash)} in it {'was' if len(clash) == 1 else 'were'} not "
            f"written by mjlink; move {them} away, or use --force to replace {them}"
        )
    for name in keep:
        if name not in new:
            _keep(dest / name, stage / name, dest)
    with contextlib.suppress(OSError):
        os.chmod(stage, stat.S_IMODE(os.stat(dest).st_mode))  # the folder keeps its permissions
    # Where the previous output waits until it is deleted, in the marker: a run killed in that
    # instant leaves it under a name the next run can check against this marker (remove_stale).
    write_marker(stage, {**marker, "previous": stage.name})
    if _exchange(stage, dest):
        old = stage  # now holds the previous output
    else:
        old = _free_name(dest.parent, f".{dest.name}.old-{os.getpid()}-")
        write_marker(stage, {**marker, "previous": old.name})
        os.replace(dest, old)
        try:
            os.replace(stage, dest)
        except OSError:
            os.replace(old, dest)  # put the previous output back
            raise
    for name in os.listdir(old):  # an entry that appeared in dest while publishing goes on
        if name != MARKER and name not in owned and not os.path.lexists(dest / name):
            with contextlib.suppress(OSError):
                os.rename(old / name, dest / name)
    shutil.rmtree(old, ignore_errors=True)
    _replaced(dest, before, owned & present, set(new), clash)


def _replaced(dest: Path, before: dict[str, Any] | None, owned: set[str], new: set[str], clash: list[str]) -> None:
    """Say in one line what this publication replaced (nothing when the folder held no output)."""
    if owned:
        when = before.get("written") if before else None
        by = before.get("command_line") or before.get("command") if before else None
        what = ", ".join(x for x in ((when or "").replace("T", " ")[:16], by and f"'{by}'") if x)
        gone = sorted(owned - new)
        note(
            f"replaced the previous output in {dest}"
            + (f" ({what})" if what else "")
            + (f"; not written this time, so removed: {_shown(gone)}" if gone else "")
        )
    if clash:
        note(f"replaced in {dest} (--force): {_shown(clash)}")


def _free_name(folder: Path, prefix: str) -> Path:
    """A name in ``folder`` starting with ``prefix`` that nothing has (never an existing entry:
    a rename onto an empty folder would replace it)."""
    while True:
        p = folder / f"{prefix}{secrets.token_hex(4)}"
        if not os.path.lexists(p):
            return p


def _keep(src: Path, dst: Path, dest: Path) -> None:
    """Hard-link the entry ``src`` that mjlink did not write (a folder: as a tree of hard links)
    at ``dst`` in the stage, so that the published folder has it without it ever being absent."""
    try:
        if src.is_dir() and not src.is_symlink():
            shutil.copytree(src, dst, symlinks=True, copy_function=_hard_link)
        else:
            _hard_link(src, dst)
    except OSError as e:
        errs = e.args[0] if isinstance(e, shutil.Error) and e.args and isinstance(e.args[0], list) else None
        why = str(errs[0][-1]) if errs else _why(e)
        raise OutputError(
            f"cannot write outputs to {dest}: cannot keep {_shown([src.name])} in it ({why}); move it away"
        ) from None


def _hard_link(src: str | Path, dst: str | Path) -> str | Path:
    os.link(src, dst, follow_symlinks=False)
    return dst


def _exchange(a: Path, b: Path) -> bool:
    """Swap two existing paths atomically (Linux ``renameat2`` RENAME_EXCHANGE).

    False where that is unavailable (another OS, an old C library, a file system without it);
    raises OSError for any other failure.
    """
    if not sys.platform.startswith("linux"):
        return False
    try:
        fn = ctypes.CDLL(None, use_errno=True).renameat2
    except (OSError, AttributeError):
        return False
    fn.argtypes = [ctypes.c_int, ctypes.c_char_p, ctypes.c_int, ctypes.c_char_p, ctypes.c_uint]
    fn.restype = ctypes.c_int
    at_fdcwd, rename_exchange = -100, 2
    if fn(at_fdcwd, os.fsencode(str(a)), at_fdcwd, os.fsencode(str(b)), rename_exchange) == 0:
        return True
    err = ctypes.get_errno()
    if err in (errno.EINVAL, errno.ENOSYS, errno.EOPNOTSUPP, errno.ENOTSUP):
        return False
    raise OSError(err, os.strerror(err), str(b))
