"""The ``export`` command: a mechanism for CAD, at one crank angle.

The DXF (R2010, millimetres, ``$INSUNITS`` = 4) holds, in the mechanism's own frame:

* one layer per link (:func:`layer_names`: its name in the file, unless DXF forbids that name
  or another layer already has it, ignoring case), the link's centre lines as LINEs, joining
  each of its points to the point it was built from (the shape the drawings show);
* ``PIVOTS``: a CIRCLE of radius :data:`PIVOT_MM` round every ground point a link turns or
  slides on; ``GUIDES``: a CIRCLE of radius :data:`GUIDE_MM` round every ground point of the
  thread's path that no link carries (a thread guide, an eyelet in the frame);
  ``POINTS``: a POINT at every named point, ``LABELS``: each point's name beside it;
* ``PATH_<point>``, one layer per point: the closed path over the period of every moving point
  that is not merely a link's centre of mass, as a closed polyline of :data:`PATH_SAMPLES`
  vertices: an LWPOLYLINE at the path's elevation where the path keeps one z (every planar
  path; one entity, as a CAD user draws an outline), a 3D POLYLINE where its z varies;
* ``THREAD``: the thread's path at that angle (a file with ``[thread]``), an open polyline
  through its points in order.

The points file lists every named point at that angle: name, whether it is on the ground (1/0
in CSV, true/false in JSON), the input crank's angle, x, y, z in mm to 1e-6 mm (CSV, or JSON
by the file's extension). Positions are the reference's (:func:`mjlink.reference.solve`), the
same as ``simulate`` checks MuJoCo against.

The two files are claimed before anything is computed (:func:`mjlink.files.claim_outputs`) and
written together, both or neither (:func:`mjlink.files.write_files`).
"""

from __future__ import annotations

import csv
import io
import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from .. import reference, validation
from ..analysis import link_segments, mass_centres
from ..errors import MjlinkError
from ..files import claim_outputs, write_files
from ..model.mechanism import Mechanism
from ..units import DEG, to_mm

PIVOT_MM = 2.0  # radius of the circle drawn round a ground pivot, mm
GUIDE_MM = 0.5  # radius of the circle drawn round a thread guide in the frame, mm
PATH_SAMPLES = 361  # vertices of a point's path over the period (closed)
LAYERS = ("PIVOTS", "GUIDES", "POINTS", "LABELS", "THREAD")  # besides one per link and per path
DECIMALS = 6  # the points file's coordinates, mm: to 1e-6 mm
# Layers every DXF has (a CAD program gives them their own meaning), and the characters a layer
# name may not hold (besides control characters): a link's layer never takes them.
STANDARD_LAYERS = ("0", "Defpoints")
_NOT_IN_LAYER_NAMES = frozenset('<>/\\":;?*|,=`')


@dataclass(frozen=True)
class ExportResult:
    """What :func:`export` wrote: ``angle_deg`` the input crank's angle (deg), ``points`` name ->
    (x, y, z) mm at it, ``dxf`` and ``points_file`` the paths written (None where not asked)."""

    mechanism: str
    angle_deg: float
    points: dict[str, tuple[float, float, float]]
    dxf: Path | None
    points_file: Path | None


def positions(mech: Mechanism, angle_deg: float) -> dict[str, tuple[float, float, float]]:
    """Every named point of ``mech`` at input crank angle ``angle_deg`` (deg), mm."""
    kin = reference.solve(mech, np.array([angle_deg * DEG]))
    return {p: tuple(float(v) for v in to_mm(kin.position(p))[0]) for p in mech.point_names}  # type: ignore[misc]


def _paths(mech: Mechanism) -> dict[str, np.ndarray]:
    coms = mass_centres(mech)
    moving = [p for p in mech.moving_points if p not in coms]
    phi = mech.phi0 + np.linspace(0.0, mech.period, PATH_SAMPLES)
    kin = reference.solve(mech, phi)
    return {p: to_mm(kin.position(p)) for p in moving}


def path_layers(mech: Mechanism) -> dict[str, str]:
    """Point -> the layer of its path (``PATH_P5``): every moving point that is not merely a
    link's centre of mass (a point's name is a valid layer name)."""
    coms = mass_centres(mech)
    return {p: f"PATH_{p}" for p in mech.moving_points if p not in coms}


def layer_names(mech: Mechanism) -> dict[str, str]:
    """Link name -> its DXF layer: the link's name, with any character a layer name may not hold
    replaced by ``_``; a name that a layer already has, ignoring case as DXF does (``0``,
    ``Defpoints``, :data:`LAYERS`, a path's ``PATH_<point>``, a link listed before it), gets the
    first free suffix of ``_2``, ``_3``, ... (``THREAD`` -> ``THREAD_2``; ``lever`` and ``Lever``
    -> ``lever``, ``Lever_2``). One layer per link, every name valid and readable."""
    taken = {n.casefold() for n in (*STANDARD_LAYERS, *LAYERS, *path_layers(mech).values())}
    names: dict[str, str] = {}
    for link in mech.links:
        base = "".join("_" if c in _NOT_IN_LAYER_NAMES or not c.isprintable() else c for c in link.name)
        base = base.strip() or "_"
        name, i = base, 1
        while name.casefold() in taken:
            i += 1
            name = f"{base}_{i}"
        taken.add(name.casefold())
        names[link.name] = name
    return names


def dxf_text(mech: Mechanism, angle_deg: float) -> str:
    """The DXF document of ``mech`` at ``angle_deg`` as text (see the module's docstring)."""
    import ezdxf  # here: only this command needs it

    at = positions(mech, angle_deg)
    doc = ezdxf.new("R2010")
    doc.header["$INSUNITS"] = 4  # millimetres
    doc.header["$MEASUREMENT"] = 1  # metric
    layer = layer_names(mech)
    paths = path_layers(mech)
    for i, name in enumerate([*LAYERS, *paths.values(), *layer.values()]):
        doc.layers.add(name, color=1 + i % 254)
    msp = doc.modelspace()
    for link, a, b in link_segments(mech):
        msp.add_line(at[a], at[b], dxfattribs={"layer": layer[link]})
    size = max(1.0, 0.02 * _extent(at))
    for name, xyz in at.items():
        msp.add_point(xyz, dxfattribs={"layer": "POINTS"})
        msp.add_text(
            name, height=size, dxfattribs={"layer": "LABELS", "insert": (xyz[0] + size, xyz[1] + size, xyz[2])}
        )
        role = ground_role(mech, name)
        if role == "pivot":
            msp.add_circle(xyz, PIVOT_MM, dxfattribs={"layer": "PIVOTS"})
        elif role == "guide":
            msp.add_circle(xyz, GUIDE_MM, dxfattribs={"layer": "GUIDES"})
    for p, xyz in _paths(mech).items():
        _polyline(msp, np.asarray(xyz[:-1], dtype=float), paths[p], closed=True)
    if mech.thread:
        _polyline(msp, np.array([at[p] for p in mech.thread], dtype=float), "THREAD", closed=False)
    stream = io.StringIO()
    doc.write(stream)
    return stream.getvalue()


def ground_role(mech: Mechanism, point: str) -> str:
    """What a point is in the drawing: 'pivot' (a ground point a link carries), 'guide' (a
    ground point of the thread's path no link carries), '' for any other point."""
    if point not in mech.ground:
        return ""
    if any(point in link.points for link in mech.links):
        return "pivot"
    return "guide" if mech.thread and point in mech.thread else ""


def _polyline(msp: Any, verts: np.ndarray, layer: str, *, closed: bool) -> None:
    """An LWPOLYLINE at its elevation where every vertex has one z, else a 3D POLYLINE."""
    if np.all(verts[:, 2] == verts[0, 2]):
        attribs = {"layer": layer, "elevation": float(verts[0, 2])}
        msp.add_lwpolyline(verts[:, :2].tolist(), format="xy", close=closed, dxfattribs=attribs)
    else:
        msp.add_polyline3d([tuple(map(float, v)) for v in verts], close=closed, dxfattribs={"layer": layer})


def _extent(at: dict[str, tuple[float, float, float]]) -> float:
    xy = np.array([v[:2] for v in at.values()])
    return float(np.max(np.ptp(xy, axis=0))) if len(xy) > 1 else 1.0


def _mm(v: float) -> float:
    """A coordinate to 1e-6 mm (no negative zero)."""
    return round(v, DECIMALS) + 0.0


def points_text(at: dict[str, tuple[float, float, float]], mech: Mechanism, fmt: str, angle_deg: float) -> str:
    """The points file's text, ``fmt`` 'csv' or 'json', for the input crank at ``angle_deg``."""
    rows = [
        {"point": p, "ground": p in mech.ground, "phi1_deg": angle_deg, "x_mm": _mm(x), "y_mm": _mm(y), "z_mm": _mm(z)}
        for p, (x, y, z) in at.items()
    ]
    if fmt == "json":
        return json.dumps({"mechanism": mech.name, "phi1_deg": angle_deg, "points": rows}, indent=1) + "\n"
    out = io.StringIO()
    w = csv.DictWriter(out, fieldnames=list(rows[0]), lineterminator="\n")
    w.writeheader()
    for r in rows:
        coords = {k: f"{r[k]:.{DECIMALS}f}" for k in ("x_mm", "y_mm", "z_mm")}
        w.writerow({**r, "ground": int(bool(r["ground"])), "phi1_deg": repr(angle_deg), **coords})
    return out.getvalue()


def export(
    mech: Mechanism, angle_deg: float | None, dxf: Path | None, points: Path | None, *, force: bool = False
) -> ExportResult:
    """Write the DXF to ``dxf`` and the points file to ``points`` (CSV or JSON by its
    extension), both or neither, for the input crank at ``angle_deg`` (deg; None: the file's
    ``phi0``). Raises MjlinkError (one line), before anything is computed, for an angle that is
    not finite or beyond the bound of every crank angle (:func:`mjlink.validation.check_angle`),
    a points file of another extension, no output asked for, or outputs that cannot be claimed
    (:func:`~mjlink.files.claim_outputs`: both the same file, the mechanism's own file, a file
    that exists without ``force``): nothing is replaced that the user did not ask to replace."""
    if dxf is None and points is None:
        raise MjlinkError("export: nothing to write: give --dxf FILE.dxf and/or --points FILE.csv|FILE.json")
    if points is not None and points.suffix.lower() not in (".csv", ".json"):
        raise MjlinkError(f"--points {points}: must end in .csv or .json")
    angle = math.degrees(mech.phi0) if angle_deg is None else validation.check_angle("--angle", float(angle_deg))
    targets = claim_outputs({"--dxf": dxf, "--points": points}, [mech.path], force=force)
    at = positions(mech, angle)
    texts: list[tuple[Path, str]] = []
    if dxf is not None:
        texts.append((targets["--dxf"], dxf_text(mech, angle)))
    if points is not None:
        texts.append((targets["--points"], points_text(at, mech, points.suffix.lower()[1:], angle)))
    write_files(texts, force=force)
    return ExportResult(mech.name, angle, at, dxf, points)


def read_back(path: Path) -> dict[str, Any]:
    """A DXF written by :func:`dxf_text` read back with ezdxf: its units, layers, and the
    entities per type as coordinate arrays (mm); for tests and for a user's own check."""
    import ezdxf
    from ezdxf.entities import LWPolyline, Polyline

    doc = ezdxf.readfile(str(path))
    msp = doc.modelspace()
    lines = [(e.dxf.layer, tuple(e.dxf.start), tuple(e.dxf.end)) for e in msp.query("LINE")]
    polylines = [e for e in msp.query("POLYLINE LWPOLYLINE") if isinstance(e, (Polyline, LWPolyline))]
    return {
        "units": doc.header.get("$INSUNITS"),
        "layers": {layer.dxf.name for layer in doc.layers},
        "lines": lines,
        "points": [tuple(e.dxf.location) for e in msp.query("POINT")],
        "labels": {e.dxf.text: tuple(e.dxf.insert) for e in msp.query("TEXT")},
        "circles": [(e.dxf.layer, tuple(e.dxf.center), e.dxf.radius) for e in msp.query("CIRCLE")],
        "paths": {e.dxf.layer: _vertices(e) for e in polylines if e.dxf.layer.startswith("PATH_")},
        "thread": next((_vertices(e) for e in polylines if e.dxf.layer == "THREAD"), None),
    }


def _vertices(e: Any) -> np.ndarray:
    """(N, 3) vertices of a path read back: a 3D POLYLINE's, or an LWPOLYLINE's at its elevation."""
    if e.dxftype() == "LWPOLYLINE":
        return np.array([(x, y, e.dxf.elevation) for x, y in e.get_points(format="xy")])
    return np.array([tuple(v.dxf.location) for v in e.vertices])
