"""Files: the one atomic writer of a single file, CSV tables with units in the column names, JSON.

Every file mjlink writes is complete or absent: a file on its own is written to a temporary
name beside it and renamed into place (:func:`atomic_path`, :func:`write_text`); the files of an
output folder are written into its staging folder (``write_text(..., in_stage=True)``), which
:func:`mjlink.runtime.staging.staged_dir` publishes whole. CSV files are written by :func:`write_table`
alone, report files by :func:`write_json`. A single file is replaced only if it is a regular
file (a FIFO, a device or a folder is refused; a symbolic link is written through, its target
replaced).

The files a user names on the command line (``build -o``, ``design -o``, ``export --dxf`` and
``--points``, ``synth --write``) follow one rule, :func:`claim_outputs`, checked before any
work: an existing file is kept unless ``--force``, a command's input is never an output, two
outputs are never one file. They are written by :func:`write_files`, all of them or none.

CSV columns carry their unit in their name (``P5_x_mm``, ``omega1_rad_s``, ``torque_N_m``) and
are written at full double precision.
"""

from __future__ import annotations

import contextlib
import csv
import io
import itertools
import json
import math
import os
import secrets
import stat
import warnings
from collections.abc import Iterable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import orjson

from .errors import InputError, OutputError
from .model.catalogue import kind_of
from .model.jet import norms
from .model.mechanism import Link, Mechanism
from .model.reader import shown
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
    tmp = _temporary(path, suffix)
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


def _temporary(path: Path, suffix: str = ".tmp") -> Path:
    """A new empty file beside ``path`` under a hidden free name, mode 0666 less the umask."""
    for _ in range(100):
        cand = path.with_name(f".{path.name}.{secrets.token_hex(4)}{suffix}")
        try:
            os.close(os.open(cand, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666))
            return cand
        except FileExistsError:
            continue
        except OSError as e:
            raise OutputError(f"{path}: cannot write in {path.parent}: {e.strerror or e}") from None
    raise OutputError(f"{path}: cannot find a free temporary name in {path.parent}")


def read_json(path: Path | str) -> Any:
    """The JSON in the regular file ``path`` (not a link, FIFO or device), or None if there is
    none to read."""
    try:
        if not stat.S_ISREG(os.lstat(path).st_mode):
            return None
        return json.loads(Path(path).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None


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
    what = kind_of(mode)
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


def claim_outputs(
    outputs: Mapping[str, Path | str | None], inputs: Iterable[Path | str | None] = (), *, force: bool = False
) -> dict[str, Path]:
    """The one rule for the files a command is asked to write by name (``build -o``, ``design
    -o``, ``export --dxf/--points``, ``synth --write``), checked before any work.

    Args:
        outputs: option -> the path given with it (None: not asked for), for messages.
        inputs: the files the command reads (the mechanism file; None skipped).
        force: an existing regular file may be replaced.

    Returns option -> the file to write: the path with every symbolic link resolved (a link
    is written through, its target replaced). Raises a one-line OutputError naming the path
    for an output that is a folder, a FIFO, a device or a socket; one that is one of
    ``inputs`` (also with ``force``: a command never writes onto what it reads); two outputs
    that are the same file (by name after resolving links, or by inode); a file that exists,
    unless ``force`` (the message names ``--force``); a folder that does not exist, is not a
    folder or cannot be written into. Creates nothing.
    """
    claimed: dict[str, tuple[Path, Path]] = {}
    for option, given in outputs.items():
        if given is None:
            continue
        path = Path(given)
        target = Path(os.path.realpath(path))
        try:
            mode: int | None = os.stat(target).st_mode
        except FileNotFoundError:
            mode = None
        except OSError as e:
            raise OutputError(f"{path}: cannot write: {e.strerror or e}") from None
        via = f" (a link to {target})" if path.is_symlink() else ""
        if mode is not None and not stat.S_ISREG(mode):
            raise OutputError(f"{path}{via} is {kind_of(mode)}, not a regular file: refusing to replace it")
        if path.name in ("", ".", ".."):
            raise OutputError(f"{option} {str(given)!r}: names no file: give a file's name")
        for src in inputs:
            if src is not None and _same_file(target, Path(src)):
                which = "" if str(src) == str(path) else f" ({src})"
                raise OutputError(
                    f"{path}{via} is the file this command reads{which}: write to another file (--force never "
                    "replaces a command's input)"
                )
        for other, (other_path, other_target) in claimed.items():
            if _same_file(target, other_target):
                raise OutputError(
                    f"{other} {other_path} and {option} {path} are the same file: give each output its own file"
                )
        if mode is not None and not force:
            raise OutputError(f"{path}{via} exists: give --force to replace it")
        folder = target.parent
        try:
            fmode = os.stat(folder).st_mode
        except FileNotFoundError:
            raise OutputError(f"{path}: cannot write: the folder {folder} does not exist") from None
        except OSError as e:
            raise OutputError(f"{path}: cannot write in {folder}: {e.strerror or e}") from None
        if not stat.S_ISDIR(fmode):
            raise OutputError(f"{path}: cannot write: {folder} is {kind_of(fmode)}, not a folder")
        if not os.access(folder, os.W_OK | os.X_OK):
            raise OutputError(f"{path}: cannot write in {folder}: permission denied")
        claimed[option] = (path, target)
    return {option: target for option, (_, target) in claimed.items()}


def _same_file(a: Path, b: Path) -> bool:
    """Whether ``a`` and ``b`` name one file: the same path once links are resolved, or the
    same inode (a hard link) when both exist."""
    if os.path.realpath(a) == os.path.realpath(b):
        return True
    try:
        return os.path.samefile(a, b)
    except OSError:  # one of them does not exist (yet): only its name can tell
        return False


def write_files(files: Sequence[tuple[Path, str | bytes]], *, force: bool = False) -> None:
    """Write several whole files, all or none (``export``'s DXF and points file; one file is
    the same rule): each ``(path, text)`` (text UTF-8, bytes as they are) at ``path``, the
    targets :func:`claim_outputs` returned.

    Every file is first written to a temporary beside its destination; nothing is replaced
    until all are written. Then they are put in place one after the other, each previous file
    kept under a hidden hard link until the last is in place: if one cannot be put in place
    (or the run is interrupted), those already placed are put back as they were, byte for
    byte, and files that did not exist are removed. Without ``force`` a file is placed only if
    nothing has appeared at its name meanwhile. An OSError becomes a one-line OutputError.
    """
    staged: list[tuple[Path, Path]] = []  # (temporary, destination)
    current: Path | None = None
    try:
        for path, text in files:
            current = Path(path)
            target = _write_target(current)
            tmp = _temporary(target)
            staged.append((tmp, target))
            with open(tmp, "wb") as f:
                f.write(text.encode("utf-8") if isinstance(text, str) else text)
    except BaseException as e:
        _remove(tmp for tmp, _ in staged)
        if isinstance(e, OSError):
            raise OutputError(f"{current}: cannot write: {e.strerror or e}") from None
        raise
    placed: list[tuple[Path, Path | None]] = []  # (destination, its previous file kept aside)
    try:
        for tmp, target in staged:
            current = target
            placed.append((target, _place(tmp, target, force)))
        current = None
    except BaseException as e:
        for target, old in reversed(placed):
            with contextlib.suppress(OSError):
                if old is not None:
                    os.replace(old, target)
                else:
                    target.unlink()
        _remove(tmp for tmp, _ in staged)
        if isinstance(e, FileExistsError):
            raise OutputError(f"{current}: exists (it appeared meanwhile): give --force to replace it") from None
        if isinstance(e, OSError):
            raise OutputError(f"{current}: cannot write: {e.strerror or e}") from None
        raise
    _remove(old for _, old in placed if old is not None)


def _place(tmp: Path, target: Path, force: bool) -> Path | None:
    """Put the written ``tmp`` at ``target``; returns where the file it replaced is kept (a hard
    link, or the file itself moved aside where links are not supported), None if there was
    none. Without ``force``, FileExistsError if ``target`` exists."""
    if not force:
        try:
            os.link(tmp, target)  # fails if anything is there: never replaces
        except FileExistsError:
            raise
        except OSError:  # a file system without hard links
            if os.path.lexists(target):
                raise FileExistsError(target) from None
            os.replace(tmp, target)
        else:
            tmp.unlink()
        return None
    if not os.path.lexists(target):
        os.replace(tmp, target)
        return None
    old = _temporary(target, ".old")
    try:
        os.unlink(old)
        os.link(target, old)
    except OSError:  # no hard links: the previous file moves aside for the instant of the swap
        os.replace(target, old)
        try:
            os.replace(tmp, target)
        except BaseException:
            os.replace(old, target)
            raise
        return old
    try:
        os.replace(tmp, target)
    except BaseException:
        os.unlink(old)
        raise
    return old


def _remove(paths: Iterable[Path]) -> None:
    for p in paths:
        with contextlib.suppress(OSError):
            os.unlink(p)


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
    import pyarrow as pa  # here: only for a study's table
    import pyarrow.parquet as pq

    table = pa.table({k: (np.asarray(v) if isinstance(v, np.ndarray) else list(v)) for k, v in columns.items()})
    with atomic_path(path, suffix=".parquet") as tmp:
        pq.write_table(table, tmp)
    return path


def read_parquet(path: Path) -> dict[str, np.ndarray]:
    """The columns of a Parquet table written by :func:`write_parquet`, by name: numbers as
    float or integer arrays, text as object arrays. Raises InputError (one line naming the
    file) for a file that is not such a table."""
    import pyarrow as pa  # here: only for a study's table
    import pyarrow.parquet as pq

    try:
        table = pq.read_table(path)
        return {name: table.column(name).to_numpy(zero_copy_only=False) for name in table.column_names}
    except (OSError, pa.ArrowException) as e:  # not Parquet, truncated, unreadable
        why = " ".join(str(e).split()) or type(e).__name__
        raise InputError(f"{path}: not a readable Parquet table ({why[:200]})") from None


def columns(mech: Mechanism, trace: Trace) -> tuple[list[str], list[tuple[np.ndarray, float]]]:
    """Column names of a trace of N samples, and its columns as (values (N,) or (N, 3) in SI,
    factor into the column's unit): time s, crank angle deg, speed rad/s and rpm, acceleration
    rad/s^2, point positions mm, velocities mm/s and accelerations mm/s^2, link angles deg
    (-180..180), speeds rad/s and accelerations rad/s^2, transmission and pressure angles deg, thread length mm, loop gap um. The CSV writer scales them as it
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
            names += [f"{l.name}_angle_deg", f"{l.name}_omega_rad_s", f"{l.name}_eps_rad_s2"]
            blocks += [
                (link_angle_trace(l, trace.points), 180.0 / math.pi),
                (trace.link_omega[l.name], 1.0),
                (trace.link_eps[l.name], 1.0),
            ]
    for name, angle in block_angle_traces(mech, trace.points):
        names.append(name)
        blocks.append((angle, 1.0))
    if trace.thread_length is not None:
        names.append("thread_length_mm")
        blocks.append((trace.thread_length, _MM_PER_M))
    if trace.loop_gap is not None:
        names.append("loop_gap_um")
        blocks.append((trace.loop_gap, _UM_PER_M))
    return names, blocks


_ANGLE_COLUMN = {"transmission angle": "transmission", "pressure angle": "pressure"}


def link_angle_trace(link: Link, points: dict[str, np.ndarray]) -> np.ndarray:
    """(N,) rad in -pi..pi: a link's direction in the plane along a trace, from the trace's own
    positions (MuJoCo's for a MuJoCo run), as the reference measures it: its guide line if it
    slides, else its first two points (``Link.direction``, as ``reference.kinematics.link_angle``)."""
    a, b = link.direction
    d = points[b] - points[a]
    out: np.ndarray = np.arctan2(d[:, 1], d[:, 0])
    return out


def block_angle_traces(mech: Mechanism, points: dict[str, np.ndarray]) -> list[tuple[str, np.ndarray]]:
    """Every dyad's transmission angle and every slider's pressure angle along a trace, deg,
    each (N,), named by the point the block places: ``<P>_transmission_deg`` (0..180, dead at
    0 and 180), ``<P>_pressure_deg`` (0..90, dead at 90). Computed from the trace's own
    positions (MuJoCo's for a MuJoCo run), as the dead-point check measures them."""
    out = []
    for s in mech.steps:
        dp = s.dead_point(points)
        if dp is not None:
            out.append((f"{s.point}_{_ANGLE_COLUMN[dp.quantity]}_deg", dp.value_deg))
    return out


def write_csv(path: Path, mech: Mechanism, trace: Trace) -> Path:
    """Write a trace as CSV (the columns of :func:`columns`) at full double precision."""
    names, blocks = columns(mech, trace)
    return write_table(path, names, [v for v, _ in blocks], [f for _, f in blocks])


def read_csv(path: Path) -> dict[str, np.ndarray]:
    """Read a CSV written here back into its columns by name, each (N,) in the unit its name says.

    The file must be what :func:`write_table` writes: a header row of distinct column names,
    then rows of as many numbers (``nan``, ``inf`` included; blank lines are skipped). Raises
    InputError, one line naming the file and, where there is one, the line and the column at
    fault: a missing or unreadable file, one that is not a regular file, not UTF-8 text, empty,
    without a header row, a row of another length, a value that is not a number."""
    p = Path(path)
    try:
        mode = os.stat(p).st_mode
    except FileNotFoundError:
        raise InputError(f"{p}: no such file") from None
    except OSError as e:
        raise InputError(f"{p}: cannot be read ({e.strerror or type(e).__name__})") from None
    if not stat.S_ISREG(mode):
        raise InputError(f"{p} is {kind_of(mode)}, not a CSV file")
    try:
        with open(p, encoding="utf-8", newline="") as f:
            names = _csv_header(p, f.readline(_MAX_HEADER))
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", UserWarning)  # a header without rows: no data
                data = np.loadtxt(f, delimiter=",", dtype=float, ndmin=2, comments=None)
    except UnicodeDecodeError:
        raise InputError(f"{p}: not a CSV text file (not UTF-8; binary?)") from None
    except OSError as e:
        raise InputError(f"{p}: cannot be read ({e.strerror or type(e).__name__})") from None
    except ValueError:
        _csv_fault(p, names)
        raise InputError(f"{p}: not a table of numbers under its header row") from None
    if data.size == 0:
        return {n: np.empty(0) for n in names}
    if data.shape[1] != len(names):
        _csv_fault(p, names)
    return {n: data[:, j].copy() for j, n in enumerate(names)}


_MAX_HEADER = 1 << 20  # characters: a traced point's nine names are about 120


def _csv_header(p: Path, line: str) -> list[str]:
    """The column names of a CSV's first ``line``, checked (InputError naming ``p``)."""
    if not line.strip():
        raise InputError(f"{p}: empty, no header row of column names")
    if "\x00" in line:
        raise InputError(f"{p}: not a CSV text file (binary)")
    if len(line) >= _MAX_HEADER and not line.endswith("\n"):
        raise InputError(f"{p}:1: a header row longer than {_MAX_HEADER} characters: not a traces file")
    names = [n.strip() for n in line.rstrip("\r\n").split(",")]
    if all(_number(n) for n in names):
        raise InputError(f"{p}:1: no header row: the first line holds numbers, not column names")
    for j, n in enumerate(names, 1):
        if not n or _number(n):
            raise InputError(f"{p}:1: column {j}: {shown(n)} is not a column name")
        if names.index(n) != j - 1:
            raise InputError(f"{p}:1: column {j}: {shown(n)} names two columns")
    return names


def _number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return "_" not in text  # Python's float() reads 1_000, a CSV reader does not


def _csv_fault(p: Path, names: list[str]) -> None:
    """Raise InputError at the first row of the CSV ``p`` whose length differs from the
    header's or that holds a value that is not a number (line and column named)."""
    with open(p, encoding="utf-8", newline="") as f:
        f.readline()
        for k, line in enumerate(f, 2):
            if not line.strip():
                continue
            if "\x00" in line:
                raise InputError(f"{p}:{k}: not a CSV text file (binary)")
            values = line.rstrip("\r\n").split(",")
            if len(values) != len(names):
                raise InputError(
                    f"{p}:{k}: {len(values)} value{'s' if len(values) != 1 else ''}, the header names "
                    f"{len(names)} column{'s' if len(names) != 1 else ''}"
                )
            for j, (v, n) in enumerate(zip(values, names, strict=True), 1):
                if not _number(v):
                    raise InputError(f"{p}:{k}: column {j} ({shown(n)}): {shown(v.strip())} is not a number")


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
