"""Output: the one atomic writer, CSV tables with units in the column names, JSON.

Every file mjlink writes is complete or absent: a file on its own is written to a temporary
name beside it and renamed into place (:func:`atomic_path`, :func:`write_text`); a run writes
into a hidden staging folder beside its destination and renames it into place only when
everything is written (:func:`staged_dir`). The files of a staging folder are written in place
(``write_text(..., in_stage=True)``): the folder is what is published atomically. CSV files are
written by :func:`write_table` alone, report files by :func:`write_json`.

CSV columns carry their unit in their name (``P5_x_mm``, ``omega1_rad_s``, ``torque_N_m``) and
are written at full double precision.
"""

from __future__ import annotations

import contextlib
import ctypes
import errno
import json
import os
import secrets
import shutil
import sys
import tempfile
from collections.abc import Iterator, Mapping, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from .errors import OutputError
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
    """
    path = Path(path)
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


def write_text(path: Path | str, text: str, *, in_stage: bool = False) -> Path:
    """Write a whole text file (UTF-8) at ``path``; returns the path.

    A file on its own (``in_stage`` False: an MJCF from ``build -o``, a synthesized mechanism
    file) goes through :func:`atomic_path`: complete or absent, an OSError as an OutputError.
    A file inside a :func:`staged_dir` folder (``in_stage`` True) is written in place: the
    folder is published whole, and an OSError reaches ``staged_dir``, whose message names the
    output folder and the file instead of the hidden staging path.
    """
    path = Path(path)
    if in_stage:
        path.write_text(text, encoding="utf-8")
        return path
    with atomic_path(path) as tmp:
        tmp.write_text(text, encoding="utf-8")
    return path


def write_table(path: Path, names: Sequence[str], cols: Sequence[Any]) -> Path:
    """Write a CSV table into a staging folder; returns ``path``.

    Args:
        path: the file, inside a :func:`staged_dir` folder.
        names: the k column names (header), units in the names.
        cols: arrays of N rows each, (N,) for one column or (N, m) for m columns, k columns in
            all; written at full double precision (repr() is the shortest text that reads back
            to the same double).
    """
    table = np.column_stack(cols)
    lines = [",".join(names)] + [",".join(map(repr, row)) for row in table.tolist()]
    return write_text(path, "\n".join(lines) + "\n", in_stage=True)


def columns(mech: Mechanism, trace: Trace) -> tuple[list[str], np.ndarray]:
    """Column names and the (N, k) table of a trace of N samples: time s, crank angle deg,
    speed rad/s and rpm, acceleration rad/s^2, point positions mm, velocities mm/s and
    accelerations mm/s^2, link speeds rad/s and accelerations rad/s^2, thread length mm, loop
    gap um."""
    names = ["time_s", "phi1_deg", "omega1_rad_s", "eps1_rad_s2", "n1_rpm"]
    cols = [trace.time, np.degrees(trace.phi), trace.omega, trace.eps, to_rpm(trace.omega)]
    for n in mech.point_names:
        for i, ax in enumerate("xyz"):
            names.append(f"{n}_{ax}_mm")
            cols.append(trace.points[n][:, i] * _MM_PER_M)
    for n in mech.moving_points:
        for i, ax in enumerate("xyz"):
            names.append(f"{n}_v{ax}_mm_s")
            cols.append(trace.velocities[n][:, i] * _MM_PER_M)
        for i, ax in enumerate("xyz"):
            names.append(f"{n}_a{ax}_mm_s2")
            cols.append(trace.accelerations[n][:, i] * _MM_PER_M)
    for l in mech.links:
        if l.name in trace.link_omega:
            names += [f"{l.name}_omega_rad_s", f"{l.name}_eps_rad_s2"]
            cols += [trace.link_omega[l.name], trace.link_eps[l.name]]
    if trace.thread_length is not None:
        names.append("thread_length_mm")
        cols.append(trace.thread_length * _MM_PER_M)
    if trace.loop_gap is not None:
        names.append("loop_gap_um")
        cols.append(trace.loop_gap * _UM_PER_M)
    return names, np.column_stack(cols)


def write_csv(path: Path, mech: Mechanism, trace: Trace) -> Path:
    """Write a trace as CSV (the columns of :func:`columns`) at full double precision."""
    names, table = columns(mech, trace)
    return write_table(path, names, [table])


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


@contextmanager
def staged_dir(dest: Path) -> Iterator[Path]:
    """Yield a staging folder; on success it replaces ``dest`` whole, on failure it is removed.

    * The stage is a hidden ``.NAME.partial-<random>`` beside ``dest`` (same file system, so
      publishing it is a rename, never a copy).
    * ``dest`` is replaced whole: on Linux the stage and an existing ``dest`` are exchanged
      atomically (``renameat2(RENAME_EXCHANGE)``), so at every instant ``dest`` is either the
      complete old output or the complete new one; elsewhere (or on file systems without the
      exchange) by two renames, ``dest`` -> ``.NAME.old-PID`` then stage -> ``dest``, putting
      the old one back if the second fails. The old output is then deleted.
    * If the body raises, the stage is deleted and ``dest`` is left as it was (absent, or the
      previous complete output): a failed run never leaves a folder that looks complete.
      An OSError (disk full, permission, ...) becomes a one-line OutputError; anything else
      propagates unchanged. Only a killed process (SIGKILL, power loss) can leave a hidden
      ``.NAME.partial-*`` folder behind; it is never mistaken for an output and may be deleted.
    * An output path that exists and is not a folder, or a parent that cannot be created or
      written (a path under a regular file, a read-only file system), is an OutputError before
      the body runs.
    """
    dest = Path(dest)
    parent = dest.parent
    if dest.exists() and not dest.is_dir():
        raise OutputError(f"output path {dest} exists and is not a folder")
    try:
        parent.mkdir(parents=True, exist_ok=True)
        stage = Path(tempfile.mkdtemp(prefix=f".{dest.name}.partial-", dir=parent))
        stage.chmod(0o755)  # mkdtemp's 0700 would make the published folder private
    except OSError as e:
        raise OutputError(f"cannot write to output folder {parent}: {_why(e)}") from None
    try:
        yield stage
        _publish(stage, dest)
    except OSError as e:
        shutil.rmtree(stage, ignore_errors=True)
        raise OutputError(f"cannot write outputs to {dest}: {_why(e)}") from None
    except BaseException:
        shutil.rmtree(stage, ignore_errors=True)
        raise


def _why(e: OSError) -> str:
    """An OSError as a short cause: 'No space left on device (kinematics.csv)'."""
    what = e.strerror or str(e) or type(e).__name__
    return f"{what} ({Path(e.filename).name})" if e.filename else what


def _publish(stage: Path, dest: Path) -> None:
    """Put the complete ``stage`` at ``dest``, replacing an existing ``dest`` whole."""
    if not dest.exists():
        os.replace(stage, dest)
        return
    if not dest.is_dir():
        raise OutputError(f"output path {dest} exists and is not a folder")
    if _exchange(stage, dest):
        shutil.rmtree(stage, ignore_errors=True)  # now holds the previous output
        return
    old = dest.parent / f".{dest.name}.old-{os.getpid()}"
    shutil.rmtree(old, ignore_errors=True)
    os.replace(dest, old)
    try:
        os.replace(stage, dest)
    except OSError:
        os.replace(old, dest)  # put the previous output back
        raise
    shutil.rmtree(old, ignore_errors=True)


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
        cols += [f[:, 0], f[:, 1], np.linalg.norm(f, axis=1)]
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
