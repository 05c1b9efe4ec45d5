"""Output: the one atomic writer, CSV tables with units in the column names, JSON.

Every file mjlink writes is complete or absent: a file on its own is written to a temporary
name beside it and renamed into place (:func:`atomic_path`, :func:`write_text`); a run writes
into a hidden staging folder beside its destination and renames it into place only when
everything is written (:func:`staged_dir`). The files of a staging folder are written in place
(``write_text(..., in_stage=True)``): the folder is what is published atomically. CSV files are
written by :func:`write_table` alone, report files by :func:`write_json`.

mjlink replaces only what it wrote itself: a single file only if it is a regular file (a FIFO, a
device or a folder is refused; a symbolic link is written through, its target replaced), an
output folder only if its marker (:data:`MARKER`) says mjlink wrote it for the same command and
mechanism, and then only the files the marker lists; anything else in it is kept. A run ends
cleanly on SIGINT and SIGTERM (:func:`interruptible`, :class:`Terminated`), and the staging
folders of runs that were killed are removed by the next run into the same folder.

CSV columns carry their unit in their name (``P5_x_mm``, ``omega1_rad_s``, ``torque_N_m``) and
are written at full double precision.
"""

from __future__ import annotations

import contextlib
import ctypes
import errno
import functools
import itertools
import json
import math
import os
import re
import secrets
import shutil
import signal
import stat
import sys
import tempfile
import threading
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from .errors import OutputError
from .model.jet import norms
from .model.mechanism import Mechanism
from .runs import Trace
from .units import MM, UM, to_rpm

if TYPE_CHECKING:
    from .reference import Steady

# Exactly 1000.0 and 1e6: multiplying by them writes the same digits the CSVs have always had
# (x / MM, i.e. units.to_mm, can differ from x * 1e3 in the last bit).
_MM_PER_M = 1.0 / MM
_UM_PER_M = 1.0 / UM


@contextmanager
def atomic_path(path: Path | str, suffix: str = ".tmp") -> Iterator[Path]:
    """A fresh, empty temporary file beside ``path`` for the body to fill; renamed onto ``path``
    when the body returns, removed if it raises (``path`` is then untouched).

    ``suffix`` keeps the extension a writer may need (ffmpeg picks its format from it). The
    temporary is created with mode 0666 less the umask (mkstemp's 0600 would survive the
    rename). An OSError becomes a one-line OutputError.

    Only a regular file is ever replaced. ``path`` may be absent or a regular file; a FIFO, a
    device, a socket or a folder there is refused with a one-line OutputError before the body
    runs (``build -o /dev/null`` must not replace /dev/null with a file). A symbolic link is
    written through: the file it points to (which must be absent or regular) is replaced
    atomically in its own folder and the link is kept.
    """
    path = _write_target(Path(path))
    tmp = None
    for _ in range(100):
        cand = path.with_name(f".{path.name}.{secrets.token_hex(4)}{suffix}")
        try:
            os.close(os.open(cand, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666))
            tmp = cand
            break
        except FileExistsError:
            continue
        except OSError as e:
            raise OutputError(f"{path}: cannot write in {path.parent}: {e.strerror or e}") from None
    if tmp is None:
        raise OutputError(f"{path}: cannot find a free temporary name in {path.parent}")
    try:
        yield tmp
        os.replace(tmp, path)
    except OSError as e:
        with contextlib.suppress(OSError):
            tmp.unlink()
        raise OutputError(f"{path}: cannot write: {e.strerror or e}") from None
    except BaseException:
        with contextlib.suppress(OSError):
            tmp.unlink()
        raise


_FILE_KINDS = (
    (stat.S_ISDIR, "a folder"),
    (stat.S_ISFIFO, "a FIFO (named pipe)"),
    (stat.S_ISCHR, "a character device"),
    (stat.S_ISBLK, "a block device"),
    (stat.S_ISSOCK, "a socket"),
)


def _write_target(path: Path) -> Path:
    """The file a whole-file write to ``path`` replaces: ``path``, or for a symbolic link the
    file it finally points to; OutputError if that exists and is not a regular file."""
    target = Path(os.path.realpath(path)) if path.is_symlink() else path
    try:
        mode = os.stat(target).st_mode
    except FileNotFoundError:
        return target
    except OSError as e:
        raise OutputError(f"{path}: cannot write: {e.strerror or e}") from None
    if stat.S_ISREG(mode):
        return target
    what = next((name for test, name in _FILE_KINDS if test(mode)), "not a regular file")
    via = f" (a link to {target})" if target != path else ""
    raise OutputError(f"{path}{via} is {what}, not a regular file: refusing to replace it")


def write_text(path: Path | str, text: str | bytes | Iterable[bytes | memoryview], *, in_stage: bool = False) -> Path:
    """Write a whole text file (UTF-8; ``bytes`` as they are; byte strings from an iterable one
    after the other, as it yields them) at ``path``; returns the path.

    A file on its own (``in_stage`` False: an MJCF from ``build -o``, a synthesized mechanism
    file) goes through :func:`atomic_path`: complete or absent, an OSError as an OutputError.
    A file inside a :func:`staged_dir` folder (``in_stage`` True) is written in place: the
    folder is published whole, and an OSError reaches ``staged_dir``, whose message names the
    output folder and the file instead of the hidden staging path.
    """
    path = Path(path)
    parts = [text.encode("utf-8")] if isinstance(text, str) else [text] if isinstance(text, bytes) else text
    if in_stage:
        with open(path, "wb") as f:
            f.writelines(parts)
        return path
    with atomic_path(path) as tmp, open(tmp, "wb") as f:
        f.writelines(parts)
    return path


def write_table(path: Path, names: Sequence[str], cols: Sequence[Any], scale: Sequence[float] | None = None) -> Path:
    """Write a CSV table into a staging folder; returns ``path``.

    Args:
        path: the file, inside a :func:`staged_dir` folder.
        names: the k column names (header), units in the names.
        cols: arrays of N rows each, (N,) for one column or (N, m) for m columns, k columns in
            all; written at full double precision: the shortest text that reads back to the
            same double (``1e-05`` as ``0.00001``, ``-0.0``, ``nan``, ``inf``).
        scale: a factor per array of ``cols`` (into the unit its names say), applied as the
            rows are written (None: all 1).

    The numbers are formatted by orjson's shortest-round-trip writer in C, a block of rows at a
    time as a JSON array of rows that becomes CSV by replacing the row brackets: 40 ns a number
    on the traces, written, where Arrow's CSV writer took 150 and Python's repr() 480. It counts
    because a traced point costs 9 columns x every sample of four files.
    """
    head = (",".join(names) + "\n").encode()
    return write_text(path, itertools.chain([head], _csv_rows(cols, len(names), scale)), in_stage=True)


def _csv_rows(cols: Sequence[Any], k: int, scale: Sequence[float] | None = None) -> Iterator[bytes | memoryview]:
    """The rows of the columns ``cols`` (k in all) as CSV text, a block of rows at a time:
    each block is copied from the columns into one small (rows, k) table, formatted and
    written before the next, so the table stays in cache and its memory is reused, where a
    whole (N, k) table is fresh memory written a column at a time (a traced point adds 1.5
    MB of text)."""
    import orjson

    arrays = [np.asarray(c, dtype=float) for c in cols]
    if not arrays:
        return
    widths = [1 if a.ndim == 1 else a.shape[1] for a in arrays]
    if sum(widths) != k or len({len(a) for a in arrays}) > 1:
        raise ValueError(f"{k} column names for columns of widths {widths} and lengths {[len(a) for a in arrays]}")
    factors = [1.0] * len(arrays) if scale is None else list(scale)
    n = len(arrays[0])
    block = max(1, (1 << 22) // (20 * max(k, 1)))  # rows of about 4 MB of text
    part = np.empty((min(block, n), k))
    for i in range(0, n, block):
        rows = part[: min(block, n - i)]
        j = 0
        for a, w, f in zip(arrays, widths, factors, strict=True):
            src = a[i : i + len(rows)].reshape(len(rows), w)
            if f == 1.0:
                rows[:, j : j + w] = src
            else:  # scaled in the copy: no scaled array of the whole column made first
                np.multiply(src, f, out=rows[:, j : j + w])
            j += w
        raw = orjson.dumps(rows, option=orjson.OPT_SERIALIZE_NUMPY)
        # One sum, no mask, tells that every number is finite (a sum that overflows only sends
        # a block to the exact check below, without a warning).
        with np.errstate(over="ignore", invalid="ignore"):
            total = np.add.reduce(rows, axis=None)
        if not np.isfinite(total):
            bad = ~np.isfinite(rows)
            raw = _non_finite(raw, rows[bad])
        # '[[a,b],[c,d]]' -> 'a,b\nc,d\n': each row is a view between its '[' and ']', found
        # with bytes.find (memchr speed), joined by newlines: one copy of the text. Splitting
        # at ']' copied it twice (half the cost of this whole step with wide rows), and
        # bytes.replace(b'],[', b'\n') searches three bytes, as slow as orjson's formatting.
        view, find, stop = memoryview(raw), raw.find, len(raw) - 2
        lines = []
        a, b = 2, find(b"]", 2)
        while b < stop:
            lines.append(view[a:b])
            a = b + 3
            b = find(b"]", a)
        lines.append(view[a:b])
        yield b"\n".join(lines)
        yield b"\n"


def _non_finite(rows: bytes, values: np.ndarray) -> bytes:
    """orjson writes every NaN and infinity as ``null``; put back each one's own text, in row
    order (``values``: the table's non-finite entries, row by row, as boolean indexing gives
    them)."""
    pieces = rows.split(b"null")
    text = [b"nan" if np.isnan(v) else b"inf" if v > 0 else b"-inf" for v in values]
    out = [pieces[0]]
    for t, p in zip(text, pieces[1:], strict=True):
        out += [t, p]
    return b"".join(out)


def write_records(path: Path, columns: Mapping[str, Sequence[Any] | np.ndarray]) -> Path:
    """Write a CSV of mixed columns (numbers and text) into a staging folder; returns ``path``.

    Args:
        path: the file, inside a :func:`staged_dir` folder.
        columns: name (unit in the name) -> N values each; floats at full double precision
            (NaN as ``nan``), text quoted where it must be (RFC 4180).
    """
    import csv
    import io

    names = list(columns)
    cols = [np.asarray(c).tolist() if isinstance(c, np.ndarray) else list(c) for c in columns.values()]
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(names)
    for row in zip(*cols, strict=True):
        w.writerow([repr(x) if isinstance(x, float) else x for x in row])
    return write_text(path, buf.getvalue(), in_stage=True)


def write_parquet(path: Path, columns: Mapping[str, Sequence[Any] | np.ndarray]) -> Path:
    """Write the same columns as :func:`write_records` as a Parquet table into a staging folder."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    table = pa.table({k: (np.asarray(v) if isinstance(v, np.ndarray) else list(v)) for k, v in columns.items()})
    with atomic_path(path, suffix=".parquet") as tmp:
        pq.write_table(table, tmp)
    return path


def columns(mech: Mechanism, trace: Trace) -> tuple[list[str], list[tuple[np.ndarray, float]]]:
    """Column names of a trace of N samples, and its columns as (values (N,) or (N, 3) in SI,
    factor into the column's unit): time s, crank angle deg, speed rad/s and rpm, acceleration
    rad/s^2, point positions mm, velocities mm/s and accelerations mm/s^2, link speeds rad/s and
    accelerations rad/s^2, thread length mm, loop gap um. The CSV writer scales them as it
    copies the rows (no scaled copy of each column first)."""
    names = ["time_s", "phi1_deg", "omega1_rad_s", "eps1_rad_s2", "n1_rpm"]
    # A point's three axes stay one (N, 3) block, not sliced into columns.
    blocks: list[tuple[np.ndarray, float]] = [
        (trace.time, 1.0),
        (trace.phi, 180.0 / math.pi),
        (trace.omega, 1.0),
        (trace.eps, 1.0),
        (to_rpm(trace.omega), 1.0),
    ]
    for n in mech.point_names:
        names += [f"{n}_{ax}_mm" for ax in "xyz"]
        blocks.append((trace.points[n], _MM_PER_M))
    for n in mech.moving_points:
        names += [f"{n}_v{ax}_mm_s" for ax in "xyz"]
        names += [f"{n}_a{ax}_mm_s2" for ax in "xyz"]
        blocks += [(trace.velocities[n], _MM_PER_M), (trace.accelerations[n], _MM_PER_M)]
    for l in mech.links:
        if l.name in trace.link_omega:
            names += [f"{l.name}_omega_rad_s", f"{l.name}_eps_rad_s2"]
            blocks += [(trace.link_omega[l.name], 1.0), (trace.link_eps[l.name], 1.0)]
    if trace.thread_length is not None:
        names.append("thread_length_mm")
        blocks.append((trace.thread_length, _MM_PER_M))
    if trace.loop_gap is not None:
        names.append("loop_gap_um")
        blocks.append((trace.loop_gap, _UM_PER_M))
    return names, blocks


def write_csv(path: Path, mech: Mechanism, trace: Trace) -> Path:
    """Write a trace as CSV (the columns of :func:`columns`) at full double precision."""
    names, blocks = columns(mech, trace)
    return write_table(path, names, [v for v, _ in blocks], [f for _, f in blocks])


def read_csv(path: Path) -> dict[str, np.ndarray]:
    """Read a CSV written here back into its columns by name, each (N,) in the unit its name says."""
    data = np.genfromtxt(path, delimiter=",", names=True, dtype=float)
    return {n: np.asarray(data[n]) for n in data.dtype.names or ()}


def write_json(path: Path, obj: Mapping[str, Any]) -> Path:
    """Write ``obj`` as indented JSON into a staging folder; numpy numbers and arrays become
    JSON numbers and lists, paths strings. Returns ``path``."""
    return write_text(path, json.dumps(obj, indent=2, default=_jsonable) + "\n", in_stage=True)


def _jsonable(o: object) -> object:
    if isinstance(o, (np.floating, np.integer)):
        return o.item()
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, Path):
        return str(o)
    raise TypeError(f"not JSON serializable: {type(o).__name__}")


# ============================================================================ interruption
class Terminated(BaseException):
    """SIGTERM arrived while :func:`interruptible` was in force. Like KeyboardInterrupt it is no
    Exception: only cleanups (``finally``, ``with``) run as it unwinds, which remove the staging
    folder and stop the plot worker. The command line exits 143 (128 + SIGTERM)."""


_signalled: list[int] = []  # SIGINT / SIGTERM received during the current interruptible run


def _interruption(signum: int) -> BaseException:
    return Terminated(f"terminated by signal {signum}") if signum == signal.SIGTERM else KeyboardInterrupt()


def _on_signal(signum: int, frame: object) -> None:
    if signum == signal.SIGTERM and signum in _signalled:
        return  # once: a second SIGTERM must not cut short the clean-up the first one started
    _signalled.append(signum)
    raise _interruption(signum)


def _main_thread() -> bool:
    return threading.current_thread() is threading.main_thread()


def _quiet_interruption(hook: Callable[[Any], Any], unraisable: Any) -> None:
    """An unraisable exception goes to ``hook`` unless it is the interruption itself."""
    if isinstance(unraisable.exc_value, KeyboardInterrupt | Terminated):
        return
    hook(unraisable)


@contextmanager
def interruptible() -> Iterator[None]:
    """Make SIGINT and SIGTERM end the body cleanly, whatever code they land in.

    For its duration (main thread only) SIGTERM raises :class:`Terminated`, as SIGINT raises
    KeyboardInterrupt, so that a terminated run cleans up like an interrupted one instead of
    dying in the middle of its work; a second SIGTERM is ignored while that happens. The
    signals are also recorded: code that catches the exception and fails otherwise (a C
    library's callback turning it into an ordinary error) or swallows it cannot hide it, since
    the body then ends with KeyboardInterrupt or Terminated all the same (chained to the other
    error), and :func:`staged_dir` publishes nothing once a signal came. Nothing changes in
    another thread, or for a signal whose handler is not Python's default (an embedding
    program's choice, an ignored signal, or an outer ``interruptible``).
    """
    install: dict[int, Any] = {}  # signal -> the handler to put back
    if _main_thread():
        if signal.getsignal(signal.SIGTERM) is signal.SIG_DFL:
            install[signal.SIGTERM] = signal.SIG_DFL
        if signal.getsignal(signal.SIGINT) is signal.default_int_handler:
            install[signal.SIGINT] = signal.default_int_handler
    if not install:
        yield
        return
    _signalled.clear()
    for sig in install:
        signal.signal(sig, _on_signal)
    # A signal that lands in code whose exceptions Python can only print (an import lock's
    # weakref callback, a __del__) would show as "Exception ignored ... Traceback" on stderr;
    # it is recorded above and re-raised when the body ends, so it is not printed there.
    before = sys.unraisablehook
    sys.unraisablehook = functools.partial(_quiet_interruption, before)
    try:
        yield
    except BaseException as e:
        if _signalled and not isinstance(e, KeyboardInterrupt | Terminated):
            raise _interruption(_signalled[0]) from e
        raise
    else:
        if _signalled:
            raise _interruption(_signalled[0])
    finally:
        sys.unraisablehook = before
        for sig, old in install.items():
            signal.signal(sig, old)
        _signalled.clear()


@contextmanager
def uninterrupted() -> Iterator[None]:
    """Hold SIGINT and SIGTERM back while the body runs (their Python handlers, in the main
    thread), so that a cleanup or a publication is not cut in half by a second Ctrl-C. A signal
    that came meanwhile is acted on when the body returns (its handler runs then: raises
    KeyboardInterrupt or :class:`Terminated`); if the body raised, that exception goes on and the
    signal is dropped, since the run is ending anyway."""
    if not _main_thread():
        yield
        return
    came: list[int] = []
    held: dict[int, Callable[[int, Any], Any]] = {}
    for sig in (signal.SIGINT, signal.SIGTERM):
        handler = signal.getsignal(sig)
        if callable(handler):
            held[sig] = handler
            signal.signal(sig, lambda signum, frame: came.append(signum))
    try:
        yield
    finally:
        for sig, handler in held.items():
            signal.signal(sig, handler)
    for signum in came[:1]:
        held[signum](signum, None)


# ============================================================================ output folders
MARKER = ".mjlink-output.json"
"""The file every output folder carries: ``written_by`` "mjlink", ``kind`` and ``command`` (what
wrote it), ``mechanism`` and ``files`` (the names mjlink wrote there; the marker itself is not
listed). It is what allows a later run to replace those files and only those."""

# The command that writes each kind of output folder, for markers and messages.
COMMANDS = {"simulate": "simulate", "loads": "torque/reactions", "steady": "steady", "study": "study"}

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


@contextmanager
def staged_dir(
    dest: Path | str, *, kind: str = "output", force: bool = False, mechanism: str | None = None
) -> Iterator[Path]:
    """Yield a staging folder; on success its files are published at ``dest``, on failure it is
    removed.

    Args:
        dest: the output folder (a symbolic link to a folder is followed).
        kind: what writes it (``"simulate"``, ``"loads"`` for torque and reactions,
            ``"steady"``; the default ``"output"`` is no command's): recorded in the folder's
            :data:`MARKER`, and an existing ``dest`` is only published into if its marker has
            the same kind.
        force: publish into an existing ``dest`` that mjlink did not write for this ``kind``
            and ``mechanism``: the files of the new output replace entries of the same name,
            every other entry is kept.
        mechanism: the mechanism's name, recorded in the marker and compared like ``kind``.

    * The stage is a hidden ``.NAME.partial-<pid>-<random>`` beside ``dest`` (same file system,
      so publishing is a rename, never a copy). Stages of runs whose process is gone (killed)
      and ``.NAME.old-<pid>`` folders of the fallback below are removed when a run stages into
      the same folder (:func:`remove_stale`).
    * Publishing writes the marker listing the new files into the stage. A ``dest`` that does
      not exist is then simply renamed into place. An existing ``dest`` is published into only
      if its marker says mjlink wrote it with the same ``kind`` and ``mechanism``; then the files
      that marker lists are mjlink's and are replaced (or removed, if this run did not write
      them again); every other entry (a user's notes, a folder) is kept, and one with the name
      of a new file makes the run refuse. Without such a marker (a user's folder, another
      command's output: ``torque`` writes ``x_loads``, which a ``simulate`` of a mechanism named
      ``x_loads`` must not replace) the run refuses, unless the folder is empty: a one-line
      OutputError naming the folder and ``--force``. The check is made when publishing (the
      folder may change during the run), so a refused run has done its work in vain but has
      changed nothing.
    * The kept entries are hard-linked into the stage (a folder as a tree of hard links), then
      the stage and ``dest`` are exchanged atomically (Linux ``renameat2(RENAME_EXCHANGE)``): at
      every instant ``dest`` is the complete old output or the complete new one, and every kept
      file is in it. Elsewhere (or on file systems without the exchange) by two renames, ``dest``
      -> ``.NAME.old-<pid>`` then stage -> ``dest``, putting the old one back if the second
      fails. The old folder is then deleted (an entry that appeared in it meanwhile is moved
      over first).
    * If the body raises, helpers registered with :func:`on_discard` are stopped, the stage is
      deleted and ``dest`` is left as it was (absent, or the previous complete output): a failed
      run never leaves a folder that looks complete. An OSError (disk full, permission, ...)
      becomes a one-line OutputError; anything else propagates unchanged. For the duration,
      SIGTERM raises :class:`Terminated` (:func:`interruptible`), so a terminated run cleans up
      like an interrupted one, and a run that received SIGINT or SIGTERM publishes nothing even
      if some code swallowed the exception; the clean-up and the publication are not cut short
      by a second signal (:func:`uninterrupted`). Only SIGKILL or a power loss leaves a stage
      behind, and the next run removes it.
    * An output path that exists and is not a folder, or a parent that cannot be created or
      written (a path under a regular file, a read-only file system), is an OutputError before
      the body runs.
    """
    dest = Path(dest)
    if dest.is_symlink():
        dest = Path(os.path.realpath(dest))
    parent = dest.parent
    if dest.exists() and not dest.is_dir():
        raise OutputError(f"output path {dest} exists and is not a folder")
    stack: list[list[Callable[[], None]]] = _stages.__dict__.setdefault("hooks", [])
    hooks: list[Callable[[], None]] = []
    stage: Path | None = None
    with interruptible():
        stack.append(hooks)
        try:
            try:
                parent.mkdir(parents=True, exist_ok=True)
                remove_stale(parent)
                stage = Path(tempfile.mkdtemp(prefix=f".{dest.name}.partial-{os.getpid()}-", dir=parent))
                stage.chmod(0o755)  # mkdtemp's 0700 would make the published folder private
            except OSError as e:
                raise OutputError(f"cannot write to output folder {parent}: {_why(e)}") from None
            yield stage
            if _signalled:  # interrupted, though the body swallowed it: publish nothing
                raise _interruption(_signalled[0])
            with uninterrupted():
                _stop(hooks)
                _publish(stage, dest, kind, mechanism, force)
        except OSError as e:
            _discard(stage, hooks)
            raise OutputError(f"cannot write outputs to {dest}: {_why(e)}") from None
        except BaseException:
            _discard(stage, hooks)
            raise
        finally:
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


def read_marker(folder: Path | str) -> dict[str, Any] | None:
    """The :data:`MARKER` of an output folder, or None if it has none that mjlink wrote (absent,
    not a regular file, not JSON, or without ``written_by``, ``kind`` and ``files``)."""
    path = Path(folder) / MARKER
    try:
        if not stat.S_ISREG(os.lstat(path).st_mode):
            return None
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    if not (
        isinstance(data, dict)
        and data.get("written_by") == "mjlink"
        and isinstance(data.get("kind"), str)
        and isinstance(data.get("files"), list)
        and all(isinstance(f, str) for f in data["files"])
    ):
        return None
    return data


def _command(kind: str) -> str:
    return f"'mjlink {COMMANDS[kind]}'" if kind in COMMANDS else f"kind '{kind}'"


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
        why = f"it holds the output of {_command(marker['kind'])}{f' for {other}' if other else ''}, not of {_command(kind)}"
        if mechanism is not None and marker["kind"] == kind:
            why = f"it holds the output of {_command(kind)} for {other or 'no named mechanism'}, not for {mechanism}"
    raise OutputError(
        f"cannot write outputs to {dest}: {why}; move it away, or use --force to write mjlink's files into it "
        "(other files are kept)"
    )


def _publish(stage: Path, dest: Path, kind: str, mechanism: str | None, force: bool) -> None:
    """Put the complete ``stage`` at ``dest`` with its marker, keeping every entry of an existing
    ``dest`` that mjlink did not write (see :func:`staged_dir`)."""
    new = sorted(e for e in os.listdir(stage) if e != MARKER)
    write_json(
        stage / MARKER,
        {
            "written_by": "mjlink",
            "kind": kind,
            "command": f"mjlink {COMMANDS.get(kind, kind)}",
            "mechanism": mechanism,
            "files": new,
        },
    )
    if not os.path.lexists(dest):
        os.replace(stage, dest)
        return
    if not dest.is_dir():
        raise OutputError(f"output path {dest} exists and is not a folder")
    owned = _owned(dest, kind, mechanism, force)
    keep = sorted(e for e in os.listdir(dest) if e != MARKER and e not in owned)
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
    if _exchange(stage, dest):
        old = stage  # now holds the previous output
    else:
        old = dest.parent / f".{dest.name}.old-{os.getpid()}"
        shutil.rmtree(old, ignore_errors=True)
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


_STALE = re.compile(r"\.(?P<name>.+)\.(?:partial-(?P<pid>[0-9]+)-[^.]+|old-(?P<old>[0-9]+))", re.S)


def remove_stale(folder: Path | str) -> list[str]:
    """Remove what killed runs left in ``folder``; returns the names removed.

    A staging folder ``.NAME.partial-<pid>-<random>`` or a fallback's ``.NAME.old-<pid>`` is left
    only when its process was killed; if that process is gone (or a zombie), the folder is
    deleted, except that an ``.old`` folder whose ``NAME`` is missing is the previous output
    cut off in mid-publication and is renamed back. Folders of live processes, and anything
    else, are left alone; errors are ignored (this is tidying, not the run's work).
    """
    removed: list[str] = []
    try:
        entries = list(os.scandir(folder))
    except OSError:
        return removed
    for entry in entries:
        m = _STALE.fullmatch(entry.name)
        if m is None:
            continue
        try:
            if not entry.is_dir(follow_symlinks=False) or _alive(int(m["pid"] or m["old"])):
                continue
            path, dest = Path(entry.path), Path(folder) / m["name"]
            if m["old"] and not os.path.lexists(dest):
                os.rename(path, dest)
            else:
                shutil.rmtree(path)
            removed.append(entry.name)
        except OSError:
            continue
    return removed


def _alive(pid: int) -> bool:
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


def _label(lab: str) -> str:
    """A pair label as a column-name stem: ``P3:lever-rocker`` -> ``P3_lever_rocker``."""
    return lab.replace(":", "_").replace("-", "_")


def write_loads_csv(
    path: Path, trace: Trace, torque: np.ndarray, forces: Mapping[str, np.ndarray], moments: Mapping[str, np.ndarray]
) -> Path:
    """Driving torque and pair forces against time and crank angle, as CSV.

    Args:
        path: the file, inside a staging folder.
        trace: the run of N samples whose time (s), crank angle and speed (rad/s) head the table.
        torque: (N,) driving torque on the input crank, N*m.
        forces: per pair label, (N, 3) force in the pair, N (columns Fx, Fy and |F|).
        moments: per prismatic pair label, (N,) its moment, N*m.
    """
    names = ["time_s", "phi1_deg", "omega1_rad_s", "torque_N_m"]
    cols = [trace.time, np.degrees(trace.phi), trace.omega, torque]
    for lab, f in forces.items():
        s = _label(lab)
        names += [f"{s}_Fx_N", f"{s}_Fy_N", f"{s}_F_N"]
        cols += [f[:, 0], f[:, 1], norms(f)]
        if lab in moments:
            names.append(f"{s}_M_N_m")
            cols.append(moments[lab])
    return write_table(path, names, cols)


def write_steady_csv(path: Path, plain: Steady, fly: Steady) -> Path:
    """Steady motion over one period, without and with the flywheel, as CSV: crank angle deg
    (``plain``'s grid), crank speed rad/s and time s of each orbit (``plain.phi``,
    ``plain.omega``, ``plain.t``, ``fly.omega``, ``fly.t``: (N,) each)."""
    return write_table(
        path,
        ["phi1_deg", "omega_rad_s", "t_s", "omega_flywheel_rad_s", "t_flywheel_s"],
        [np.degrees(plain.phi), plain.omega, plain.t, fly.omega, fly.t],
    )
