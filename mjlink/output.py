"""Output files: CSV traces with units in the column names, and all-or-nothing folders.

A run writes into a hidden staging folder beside its destination and renames it into place
only when everything is written, so an interrupted or failed run never leaves a folder that
looks complete.
"""

from __future__ import annotations

import json
import os
import shutil
import tempfile
from contextlib import contextmanager
from pathlib import Path
from typing import Iterator

import numpy as np

from .errors import OutputError
from .mechanism import Mechanism
from .simulate import Trace


def columns(mech: Mechanism, trace: Trace) -> tuple[list[str], np.ndarray]:
    """Column names and the (N, k) table of a trace, in mm, deg, rpm, rad/s, rad/s^2, s."""
    names = ["time_s", "phi1_deg", "omega1_rad_s", "eps1_rad_s2", "n1_rpm"]
    cols = [trace.time, np.degrees(trace.phi), trace.omega, trace.eps, trace.omega * 30.0 / np.pi]
    for n in mech.point_names:
        for i, ax in enumerate("xyz"):
            names.append(f"{n}_{ax}_mm")
            cols.append(trace.points[n][:, i] * 1e3)
    for n in mech.moving_points:
        for i, ax in enumerate("xyz"):
            names.append(f"{n}_v{ax}_mm_s")
            cols.append(trace.velocities[n][:, i] * 1e3)
        for i, ax in enumerate("xyz"):
            names.append(f"{n}_a{ax}_mm_s2")
            cols.append(trace.accelerations[n][:, i] * 1e3)
    for l in mech.links:
        if l.name in trace.link_omega:
            names += [f"{l.name}_omega_rad_s", f"{l.name}_eps_rad_s2"]
            cols += [trace.link_omega[l.name], trace.link_eps[l.name]]
    if trace.thread_length is not None:
        names.append("thread_length_mm")
        cols.append(trace.thread_length * 1e3)
    if trace.loop_gap is not None:
        names.append("loop_gap_um")
        cols.append(trace.loop_gap * 1e6)
    return names, np.column_stack(cols)


def write_csv(path: Path, mech: Mechanism, trace: Trace) -> Path:
    """Write a trace as CSV at full double precision (17 significant digits)."""
    names, table = columns(mech, trace)
    # repr() is the shortest text that reads back to the same double.
    lines = [",".join(names)] + [",".join(map(repr, row)) for row in table.tolist()]
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def read_csv(path: Path) -> dict[str, np.ndarray]:
    """Read a trace CSV back into columns by name."""
    data = np.genfromtxt(path, delimiter=",", names=True, dtype=float)
    return {n: np.asarray(data[n]) for n in data.dtype.names}


def write_json(path: Path, obj: dict) -> Path:
    path.write_text(json.dumps(obj, indent=2, default=_jsonable) + "\n", encoding="utf-8")
    return path


def _jsonable(o):
    if isinstance(o, (np.floating, np.integer)):
        return o.item()
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, Path):
        return str(o)
    raise TypeError(f"not JSON serializable: {type(o).__name__}")


@contextmanager
def staged_dir(dest: Path) -> Iterator[Path]:
    """Yield a staging folder; on success it replaces ``dest`` whole, on failure it is removed."""
    dest = Path(dest)
    parent = dest.parent
    try:
        parent.mkdir(parents=True, exist_ok=True)
        stage = Path(tempfile.mkdtemp(prefix=f".{dest.name}.partial-", dir=parent))
        stage.chmod(0o755)  # mkdtemp's 0700 would make the published folder private
    except OSError as e:
        raise OutputError(f"cannot write to output folder {parent}: {e.strerror or e}") from None
    try:
        yield stage
        old = None
        if dest.exists():
            if not dest.is_dir():
                raise OutputError(f"output path {dest} exists and is not a folder")
            old = parent / f".{dest.name}.old-{os.getpid()}"
            os.replace(dest, old)
        os.replace(stage, dest)
        if old is not None:
            shutil.rmtree(old, ignore_errors=True)
    except OSError as e:
        shutil.rmtree(stage, ignore_errors=True)
        raise OutputError(f"cannot write outputs to {dest}: {e.strerror or e}") from None
    except BaseException:
        shutil.rmtree(stage, ignore_errors=True)
        raise


def _label(lab: str) -> str:
    """A pair label as a column-name stem: ``P3:lever-rocker`` -> ``P3_lever_rocker``."""
    return lab.replace(":", "_").replace("-", "_")


def write_loads_csv(path: Path, trace: Trace, torque: np.ndarray, forces: dict, moments: dict) -> Path:
    """Driving torque (N*m) and the force (N) in every pair, with its moment (N*m) for prismatic
    pairs, against time and crank angle; full double precision."""
    names = ["time_s", "phi1_deg", "omega1_rad_s", "torque_N_m"]
    cols = [trace.time, np.degrees(trace.phi), trace.omega, torque]
    for lab, f in forces.items():
        s = _label(lab)
        names += [f"{s}_Fx_N", f"{s}_Fy_N", f"{s}_F_N"]
        cols += [f[:, 0], f[:, 1], np.linalg.norm(f, axis=1)]
        if lab in moments:
            names.append(f"{s}_M_N_m")
            cols.append(moments[lab])
    table = np.column_stack(cols)
    lines = [",".join(names)] + [",".join(map(repr, row)) for row in table.tolist()]
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path
