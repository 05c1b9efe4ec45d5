"""Parameter paths: every number of a mechanism file, addressed as a design study varies it.

A path names one value of the file, in the file's own units (mm, deg, g, ...)::

    ground.P4.x                  a ground point's coordinate (x, y or z), mm
    construct.P3.length_a        a block's number (its key in [[construct]] point = "P3"):
                                 crank length / phase, dyad length_a / length_b, attached
                                 angle / length / z, slider length; mm or deg
    links.lever.mass             a link's mass, g (inertia: kg*m^2)
    input.phi0                   the input's initial angle (the crank setting phi01), deg
    input.speed                  the input's constant speed, rad/s (signed, CCW positive)
    dynamics.damping             dynamics numbers: moment N*m, damping N*m*s, omega0 rad/s,
                                 gravity m/s^2
    dynamics.force.P5.scale      a factor on the force (constant or table) at point P5, -
    dynamics.motor.stall_torque  the motor characteristic (N*m, no_load_speed rad/s)
    steady.stall_torque          the steady-motion motor (N*m, no_load_speed rad/s, target_delta -)
    thread.elongation            the thread elongation dP, mm
    tension.needle_tension       a lockstitch head's [tension] numbers (N, N/mm, g, deg, -)
    presser.preload              a head's presser foot: preload N, rate N/mm, mass g, damping -,
                                 lift mm (the file's [presser] or its defaults)
    fabric.stiffness             the fabric under it: area cm^2, mass g/m^2, stiffness N/mm,
                                 damping -, friction_dog / friction_foot / friction_plate -;
                                 with [[fabric.ply]], each ply's fabric.ply2.thickness mm,
                                 mass, stiffness, damping (and no timing.fabric: theirs)
    counterweight.mass           a point mass on the input crank (g; radius mm from its pivot,
                                 angle deg from the crank's direction; a study may add one to
                                 a file without it: nominal 0 g at 0 mm, 180 deg)
    synthesis.lambda             a crank-slider's synthesis input (stroke, offset mm, lambda -):
                                 varying one re-runs the metric synthesis (r, l and the guide
                                 follow, as ``synth --write`` does)

A geared crank's phase is the crank setting phi04 (``construct.P8.phase`` in warp_knitting).

:func:`apply` replaces values by scalars (one variant, a :class:`~.mechanism.Mechanism` like any
other) or by arrays of shape (N,) (one value per row: the study engine stacks variants x crank
angles into rows, and the blocks, the reference and the metrics compute on such arrays
elementwise, so a row's result does not depend on the other rows).
"""

from __future__ import annotations

import dataclasses
import difflib
import math
import tomllib
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any, cast

import numpy as np

from ..errors import MjlinkError
from ..units import DEG, MM, G
from . import synthesis as synth
from . import threads, tomlio
from .mechanism import Counterweight, Force, Mechanism, parse, unfed
from .presser import (
    FABRIC_BOUNDS,
    FABRIC_DEFAULTS,
    FABRIC_FIELDS,
    FABRIC_SCALES,
    PER_PLY,
    PRESSER_BOUNDS,
    PRESSER_DEFAULTS,
    PRESSER_SCALES,
)
from .tension import BOUNDS as TENSION_BOUNDS
from .tension import DEFAULTS as TENSION_DEFAULTS
from .tension import SCALES as TENSION_SCALES
from .tension import THREAD_KEYS
from .timing import StitchType

_AXES = ("x", "y", "z")
# section -> key -> (SI per file unit, file unit, must be positive)
_DYNAMICS = {
    "moment": (1.0, "N*m", False),
    "damping": (1.0, "N*m*s", False),
    "omega0": (1.0, "rad/s", False),
    "gravity": (1.0, "m/s^2", False),
}
_MOTOR = {"stall_torque": (1.0, "N*m", False), "no_load_speed": (1.0, "rad/s", False)}
_SYNTHESIS = {"stroke": (MM, "mm", True), "offset": (MM, "mm", False), "lambda": (1.0, "", True)}


class PathError(MjlinkError):
    """A parameter path that names no number of the mechanism (or a value it cannot take)."""


@dataclass(frozen=True)
class Param:
    """One number of a mechanism file that a study varies.

    ``path`` as written (see the module docstring); ``unit`` the file's unit ('' for none);
    ``scale`` SI per file unit; ``nominal`` the file's value (file units; 0 where the file
    leaves it out and 0 means "none", e.g. a force scale's 1); ``positive`` whether only
    values > 0 make a mechanism.
    """

    path: str
    unit: str
    scale: float
    nominal: float
    positive: bool

    @property
    def section(self) -> str:
        return self.path.split(".", 1)[0]

    def label(self) -> str:
        """'construct.P3.length_a [mm]'."""
        return f"{self.path} [{self.unit}]" if self.unit else self.path


def catalogue(mech: Mechanism) -> dict[str, Param]:
    """Every path of ``mech`` a study may vary, with its unit and nominal value."""
    out: dict[str, Param] = {}

    def add(path: str, scale: float, unit: str, positive: bool, si_value: float | None) -> None:
        nominal = math.nan if si_value is None else float(si_value) / scale
        out[path] = Param(path, unit, scale, nominal, positive)

    _entries(mech, add)
    return out


def nominal_values(mech: Mechanism) -> dict[str, float]:
    """Every path of ``mech`` a study may vary -> its nominal value in the file's units: the
    numbers of :func:`catalogue` without its :class:`Param` objects (a study compares them
    per variant)."""
    out: dict[str, float] = {}

    def add(path: str, scale: float, unit: str, positive: bool, si_value: float | None) -> None:
        out[path] = math.nan if si_value is None else float(si_value) / scale

    _entries(mech, add)
    return out


def _entries(mech: Mechanism, add: Callable[[str, float, str, bool, float | None], None]) -> None:
    """Call ``add(path, scale, unit, positive, si_value)`` for every path of ``mech``, in order."""
    for name, p in mech.ground.items():
        for i, ax in enumerate(_AXES):
            add(f"ground.{name}.{ax}", MM, "mm", False, p[i])
    for s in mech.steps:
        for key, (scale, unit, positive) in s.numbers.items():
            value = getattr(s, key, None)
            if key == "phase" and value is None:
                continue  # the input crank: its angle is input.phi0
            if value is None:  # an attached point without its own z keeps its origin's
                value = 0.0
            add(f"construct.{s.point}.{key}", scale, unit, positive, value)
    for l in mech.links:
        add(f"links.{l.name}.mass", G, "g", False, l.mass)
        add(f"links.{l.name}.inertia", 1.0, "kg*m^2", False, l.inertia)
    add("input.phi0", DEG, "deg", False, mech.phi0)
    add("input.speed", 1.0, "rad/s", False, mech.speed)
    dyn = mech.dynamics
    for key, (scale, unit, positive) in _DYNAMICS.items():
        add(f"dynamics.{key}", scale, unit, positive, getattr(dyn, key))
    for f in dyn.forces:
        add(f"dynamics.force.{f.point}.scale", 1.0, "", False, 1.0)
    if dyn.motor is not None:
        for key, (scale, unit, positive) in _MOTOR.items():
            add(f"dynamics.motor.{key}", scale, unit, positive, getattr(dyn.motor, key))
    # Without a [steady] table the file's [dynamics.motor] is the steady-motion motor too (the
    # same object): its paths are dynamics.motor.*, which move both.
    if mech.steady is not None and mech.steady.motor is not dyn.motor:
        for key, (scale, unit, positive) in _MOTOR.items():
            add(f"steady.{key}", scale, unit, positive, getattr(mech.steady.motor, key))
        add("steady.target_delta", 1.0, "", True, mech.steady.target_delta)
    if mech.thread:
        add("thread.elongation", MM, "mm", False, mech.thread_elongation or 0.0)
    cw = mech.counterweight or Counterweight(0.0, 0.0, math.pi)  # a study may add one
    add("counterweight.mass", G, "g", False, cw.mass)
    add("counterweight.radius", MM, "mm", False, cw.radius)
    add("counterweight.angle", DEG, "deg", False, cw.angle)
    if mech.timing is not None and not (mech.fabric is not None and mech.fabric.plies):
        # (with plies, the fabric's thickness is theirs: fabric.ply1.thickness, ...)
        add("timing.fabric", MM, "mm", False, mech.timing.fabric)
    if mech.balance is not None:
        add("balance.stitch_length", MM, "mm", True, mech.balance.stitch_length)
        body = (mech.timing.stitch if mech.timing is not None else StitchType.LOCKSTITCH).loop_body
        add(f"balance.{body}", MM, "mm", True, getattr(mech.balance, body))
        if body == "bobbin_case":
            add("balance.bobbin_case_width", MM, "mm", True, mech.balance.bobbin_case_width)
        add("balance.check_spring_travel", MM, "mm", False, mech.balance.check_spring_travel)
        add("balance.stretch", 1.0, "", False, mech.balance.stretch)
        # The thread under tension: the file's [tension] numbers or the defaults it would take.
        given = mech.tension or TENSION_DEFAULTS
        for key, scale in TENSION_SCALES.items():
            add(f"tension.{key}", scale, TENSION_BOUNDS[key].unit, False, getattr(given, key))
    if mech.timing is not None and mech.timing.has("feed_dog"):
        # The feed under the presser foot: the file's [presser] and [fabric] numbers or the
        # defaults it would take.
        presser, fabric = mech.presser or PRESSER_DEFAULTS, mech.fabric or FABRIC_DEFAULTS
        for key, scale in PRESSER_SCALES.items():
            add(f"presser.{key}", scale, PRESSER_BOUNDS[key].unit, key != "damping", getattr(presser, key))
        for key, scale in FABRIC_SCALES.items():
            if fabric.plies and key in PER_PLY:
                continue  # each ply's own, below
            positive = key in ("area", "mass", "stiffness")
            add(f"fabric.{key}", scale, FABRIC_BOUNDS[key].unit, positive, getattr(fabric, FABRIC_FIELDS[key]))
        for k, ply in enumerate(fabric.plies, 1):
            add(f"fabric.ply{k}.thickness", MM, "mm", True, ply.thickness)
            for key in PER_PLY:
                add(
                    f"fabric.ply{k}.{key}",
                    FABRIC_SCALES[key],
                    FABRIC_BOUNDS[key].unit,
                    key != "damping",
                    getattr(ply, key),
                )
    if mech.synthesis is not None:
        sy = mech.synthesis
        add("synthesis.stroke", MM, "mm", True, sy.stroke)
        add("synthesis.offset", MM, "mm", False, sy.offset)
        add("synthesis.lambda", 1.0, "", True, sy.ratio)


def resolve(mech: Mechanism, path: str) -> Param:
    """The parameter a path names, or a one-line PathError naming the nearest valid path."""
    known = catalogue(mech)
    if path in known:
        return known[path]
    if path == "timing.fabric" and mech.fabric is not None and mech.fabric.plies:
        plies = ", ".join(f"fabric.ply{k}.thickness" for k in range(1, len(mech.fabric.plies) + 1))
        raise PathError(f"{mech.name}: 'timing.fabric' is its plies' thickness together: vary {plies}")
    raise PathError(f"{mech.name}: unknown parameter path '{path}' ({_hint(known, path)})")


def _hint(known: Mapping[str, Param], path: str) -> str:
    """What exists near ``path``: the numbers of the point, link or table it names, or the names
    of the section it names, or the sections; a guess only where it is a close spelling of one
    of those (a guess by the number's name alone would name another point's number)."""
    head, _, last = path.rpartition(".")
    own = sorted(k[len(head) + 1 :] for k in known if k.startswith(head + ".") and "." not in k[len(head) + 1 :])
    if head and own:
        near = difflib.get_close_matches(last, own, n=1, cutoff=0.6)
        guess = f"did you mean '{head}.{near[0]}'? " if near else ""
        return f"{guess}{head} has {', '.join(own)}"
    section = path.split(".", 1)[0]
    names = sorted({k.split(".")[1] for k in known if k.startswith(section + ".") and k.count(".") >= 2})
    if names and "." in path:
        name = path.split(".")[1]
        near = [
            n
            for n in difflib.get_close_matches(name, names, n=3, cutoff=0.6)
            if path.replace(f"{section}.{name}.", f"{section}.{n}.", 1) in known
        ]
        guess = f"did you mean '{path.replace(f'{section}.{name}.', f'{section}.{near[0]}.', 1)}'? " if near else ""
        return f"{guess}{section} has no '{name}'; it has {', '.join(names)}"
    rest = path.split(".", 1)[1] if "." in path else ""
    near = [
        n
        for n in difflib.get_close_matches(section, [x[:-1] for x in _sections(known)], n=3, cutoff=0.6)
        if f"{n}.{rest}" in known
    ]
    guess = f"did you mean '{near[0]}.{rest}'? " if near else ""
    return f"{guess}valid paths start with: {', '.join(_sections(known))}"


def _sections(known: Mapping[str, Param]) -> list[str]:
    return sorted({k.split(".", 1)[0] + "." for k in known})


def apply(mech: Mechanism, values: Mapping[Param, Any]) -> Mechanism:
    """``mech`` with the given parameters replaced.

    Args:
      mech: the nominal mechanism.
      values: parameter -> value in the file's units: a float (one variant) or an array of
        shape (N,) (one value per row, see the module docstring).

    Returns:
      A mechanism whose affected numbers are SI floats or (N,) arrays. It is not validated:
      a study judges each variant by its metrics (assembly, dead points), and
      :func:`invalid` names values no mechanism can have.
    """
    ground = dict(mech.ground)
    steps = {s.point: s for s in mech.steps}
    links = {l.name: l for l in mech.links}
    top: dict[str, Any] = {}
    dyn: dict[str, Any] = {}
    motor: dict[str, Any] = {}
    steady: dict[str, Any] = {}
    scales: dict[str, Any] = {}
    synthesis: dict[str, Any] = {}
    counterweight: dict[str, Any] = {}
    for p, raw in values.items():
        v = np.asarray(raw, dtype=float) * p.scale if np.ndim(raw) else float(raw) * p.scale
        parts = p.path.split(".")
        sec = parts[0]
        if sec == "ground":
            base = ground[parts[1]]
            n = np.shape(v)[0] if np.ndim(v) else 0
            if n or np.ndim(base) == 2:
                rows = np.array(np.broadcast_to(base, (max(n, len(base) if np.ndim(base) == 2 else 1), 3)))
                rows[:, _AXES.index(parts[2])] = v
                ground[parts[1]] = rows
            else:
                new = np.array(base, dtype=float)
                new[_AXES.index(parts[2])] = v
                ground[parts[1]] = new
        elif sec == "construct":
            field_value: dict[str, Any] = {parts[2]: v}
            steps[parts[1]] = dataclasses.replace(cast(Any, steps[parts[1]]), **field_value)
        elif sec == "links":
            link_value: dict[str, Any] = {parts[2]: v}
            links[parts[1]] = dataclasses.replace(links[parts[1]], **link_value)
        elif sec == "input":
            top[parts[1]] = v
        elif sec == "dynamics" and parts[1] == "force":
            scales[parts[2]] = v
        elif sec == "dynamics" and parts[1] == "motor":
            motor[parts[2]] = v
        elif sec == "dynamics":
            dyn[parts[1]] = v
        elif sec == "steady":
            steady[parts[1]] = v
        elif sec == "thread":
            top["thread_elongation"] = v
        elif sec == "synthesis":
            synthesis[parts[1]] = v
        elif sec == "counterweight":
            counterweight[parts[1]] = v
        elif sec == "timing":
            assert mech.timing is not None
            top["timing"] = dataclasses.replace(top.get("timing", mech.timing), **{parts[1]: v})
        elif sec == "balance":
            assert mech.balance is not None
            top["balance"] = dataclasses.replace(top.get("balance", mech.balance), **{parts[1]: v})
        elif sec == "tension":
            given = top.get("tension", mech.tension or TENSION_DEFAULTS)
            top["tension"] = dataclasses.replace(given, **{parts[1]: v})
        elif sec == "presser":
            given = top.get("presser", mech.presser or PRESSER_DEFAULTS)
            top["presser"] = dataclasses.replace(given, **{parts[1]: v})
        elif sec == "fabric" and len(parts) == 3:  # fabric.plyK.key
            given = top.get("fabric", mech.fabric)
            assert given is not None
            k = int(parts[1][3:]) - 1
            ply = dataclasses.replace(given.plies[k], **{parts[2]: v})
            top["fabric"] = dataclasses.replace(given, plies=(*given.plies[:k], ply, *given.plies[k + 1 :]))
            if parts[2] == "thickness":
                assert mech.timing is not None
                thick = sum(q.thickness for q in top["fabric"].plies)
                top["timing"] = dataclasses.replace(top.get("timing", mech.timing), fabric=thick)
        elif sec == "fabric":
            given = top.get("fabric", mech.fabric or FABRIC_DEFAULTS)
            top["fabric"] = dataclasses.replace(given, **{FABRIC_FIELDS[parts[1]]: v})
        else:  # catalogue() lists no other section
            raise PathError(f"{mech.name}: parameter path '{p.path}' cannot be varied")
    d = mech.dynamics
    if scales:
        d = dataclasses.replace(d, forces=tuple(_scaled(f, scales.get(f.point)) for f in d.forces))
    if motor:
        assert d.motor is not None
        d = dataclasses.replace(d, motor=dataclasses.replace(d.motor, **motor))
    if dyn:
        d = dataclasses.replace(d, **dyn)
    st = mech.steady
    if motor and st is not None and d.motor is not None and st.motor is mech.dynamics.motor:
        st = dataclasses.replace(st, motor=d.motor)
    if steady:
        assert st is not None
        m = {k: v for k, v in steady.items() if k in _MOTOR}
        st = dataclasses.replace(st, motor=dataclasses.replace(st.motor, **m) if m else st.motor)
        if "target_delta" in steady:
            st = dataclasses.replace(st, target_delta=steady["target_delta"])
    if counterweight:
        base = mech.counterweight or Counterweight(0.0, 0.0, math.pi)
        top["counterweight"] = dataclasses.replace(base, **counterweight)
    out = dataclasses.replace(
        mech,
        ground=ground,
        steps=tuple(steps[s.point] for s in mech.steps),
        links=tuple(links[l.name] for l in mech.links),
        dynamics=d,
        steady=st,
        **top,
    )
    if synthesis:
        out = _synthesized(out, synthesis)
    return out


def _scaled(f: Force, scale: Any) -> Force:
    if scale is None:
        return f
    if np.ndim(scale):  # one factor per row: Force.at applies it
        if f.angles is None:  # Force.at broadcasts an (N, 3) value
            return dataclasses.replace(f, value=np.asarray(f.value)[None, :] * np.asarray(scale)[:, None])
        return dataclasses.replace(f, scale=scale)
    if f.angles is None:
        return dataclasses.replace(f, value=tuple(float(x) * scale for x in f.value))
    assert f.values is not None
    return dataclasses.replace(f, values=tuple(tuple(float(x) * scale for x in row) for row in f.values))


def _synthesized(mech: Mechanism, changed: Mapping[str, Any]) -> Mechanism:
    """The crank-slider re-synthesized for new synthesis inputs (one variant: floats); no
    admissible design raises PathError (the study records the variant as infeasible)."""
    sy = mech.synthesis
    assert sy is not None
    if any(np.ndim(v) for v in changed.values()):
        raise PathError("synthesis inputs are varied per variant, not per row")
    try:
        return synth.redesigned(
            mech, changed.get("stroke", sy.stroke), changed.get("offset", sy.offset), changed.get("lambda", sy.ratio)
        )
    except MjlinkError as e:
        raise PathError(str(e)) from None


def invalid(params: list[Param], values: np.ndarray, mech: Mechanism | None = None) -> list[str]:
    """Why each variant's values make no mechanism ('' where they do).

    Args:
      params: the varied parameters (P of them).
      values: (V, P) in the file's units.
      mech: the nominal mechanism: given, a head's variants whose presser presses their fabric
        through its thickness at rest are named too (values each fine alone may do it together).
    Returns:
      V strings.
    """
    out = [""] * len(values)
    for j, p in enumerate(params):
        col = values[:, j]
        bad = ~np.isfinite(col) | ((col <= 0) if p.positive else False)
        for i in np.flatnonzero(bad):
            if not out[i]:
                out[i] = f"{p.path} = {col[i]:g} {p.unit}".rstrip() + (
                    " is not finite" if not math.isfinite(col[i]) else " must be positive"
                )
    pressing = [j for j, p in enumerate(params) if p.section in ("presser", "fabric", "timing")]
    if mech is not None and pressing and mech.timing is not None and mech.timing.has("feed_dog"):
        for i, row in enumerate(values):
            if not out[i]:
                where, why = unfed(apply(mech, {params[j]: float(row[j]) for j in pressing}))
                out[i] = f"{where}: {why}" if why else ""
    return out


def check_values(mech: Mechanism, values: Mapping[Param, float]) -> None:
    """Hold values a study writes into ``mech`` to the mechanism file's own validation.

    The values (file units) are written into the file ``mech`` was read from, as a user would
    write them (a force's scale multiplies its numbers; a synthesis input is written into the
    [synthesis] table without re-synthesizing), and that text is read by the same reader as
    every mechanism file: a negative length, mass or inertia, an angle beyond the limits, ...
    fail exactly as they would in a user's file. Geometry (assembly over the cycle, dead
    points) is not judged here: that is a variant's feasibility.

    Raises:
      MechanismFileError: the reader's one-line message (it names the file's table and key).
      PathError: ``mech`` was not read from a file (nothing to validate against).
    """

    if mech.text is None:
        raise PathError(f"{mech.name}: has no file to validate values against")
    raw = tomllib.loads(mech.text)  # the text it was read from, not the file as it is now
    for p, v in values.items():
        parts = p.path.split(".")
        if parts[:2] == ["dynamics", "force"]:
            _scale_force(raw, parts[2], v)
        elif parts[0] == "counterweight" and "counterweight" not in raw:
            cw = catalogue(mech)
            raw["counterweight"] = {k: cw[f"counterweight.{k}"].nominal for k in ("mass", "radius", "angle")}
            raw["counterweight"][parts[1]] = float(v)
        elif parts[0] == "steady" and "steady" not in raw:
            continue  # the file's [dynamics.motor] serves as its steady motor: no such table to write
        else:
            _set(raw, p.path, float(v))
    parse(tomlio.dumps(raw, ""), mech.path or "<string>")


def file_text(
    mech: Mechanism,
    values: Mapping[Param, float],
    header: str,
    name: str | None = None,
    rounding: Callable[[Param, float], float] | None = None,
) -> str:
    """A mechanism file (TOML text) for ``mech`` with the given parameters replaced.

    The file ``mech`` was read from gives the structure; every number that the change moves
    is written in the file's units, including those a re-synthesis moves (a crank-slider's r,
    l, guide and centres of mass when ``synthesis.*`` changes). Comments of the original file
    do not survive (the standard library reads TOML but does not round-trip it); ``header``
    becomes the new file's leading comment.

    Args:
      mech: the mechanism as read from its file (``mech.text`` set).
      values: parameter -> value, file units (scalars).
      header: lines for the leading comment (say what produced the file).
      name: the new file's ``[mechanism] name`` (default: unchanged).
      rounding: applied to every number the change moves as it is written (a manufacturing
        resolution); None writes them to the last digit.
    Returns:
      The text; reading it gives ``apply(mech, values)`` (to the last digit of each number,
      or as ``rounding`` rounds them).
    """

    if mech.text is None:
        raise PathError(f"{mech.name}: has no file to derive a new one from")
    raw = tomllib.loads(mech.text)  # the text it was read from, not the file as it is now
    new = apply(mech, values)
    before, after = catalogue(mech), catalogue(new)
    for path, p in after.items():
        old = before.get(path)
        if old is None or old.nominal == p.nominal or (math.isnan(old.nominal) and math.isnan(p.nominal)):
            continue
        _set(raw, path, p.nominal if rounding is None else rounding(p, p.nominal))
    if "counterweight" in raw:  # a [counterweight] table is whole (mass and radius required)
        for key in ("mass", "radius", "angle"):
            raw["counterweight"].setdefault(key, after[f"counterweight.{key}"].nominal)
    for p, v in values.items():  # a force's scale multiplies its numbers (the catalogue keeps 1)
        parts = p.path.split(".")
        if parts[:2] == ["dynamics", "force"]:
            _scale_force(raw, parts[2], v)
    if name is not None:
        raw["mechanism"]["name"] = name
    return tomlio.dumps(raw, header)


def _scale_force(raw: dict, point: str, v: float) -> None:
    """Multiply the numbers of the force at ``point`` in a parsed mechanism file by ``v``."""
    for f in raw["dynamics"]["force"]:
        if f["point"] == point:
            if "value" in f:
                f["value"] = [float(x) * v for x in f["value"]]
            else:
                f["values"] = [[float(x) * v for x in row] for row in f["values"]]


def _set(raw: dict, path: str, v: float) -> None:
    """Write one catalogue path's value (file units) into a mechanism file's parsed TOML."""
    parts = path.split(".")
    sec = parts[0]
    if sec == "ground":
        xyz = raw["ground"][parts[1]]
        i = _AXES.index(parts[2])
        if i == 2 and len(xyz) == 2:
            xyz.append(0.0)
        xyz[i] = v
    elif sec == "construct":
        step = next(s for s in raw["construct"] if s["point"] == parts[1])
        step[parts[2]] = v
    elif sec == "links":
        raw["links"][parts[1]][parts[2]] = v
    elif sec == "fabric" and len(parts) == 3:  # fabric.plyK.key: the K-th [[fabric.ply]]
        plies = raw["fabric"]["ply"]
        plies[int(parts[1][3:]) - 1][parts[2]] = v
        if parts[2] == "thickness" and "fabric" in raw.get("timing", {}):
            raw["timing"]["fabric"] = sum(float(q["thickness"]) for q in plies)  # theirs together
    elif sec == "tension" and parts[1] in THREAD_KEYS and "thread" in raw.get("tension", {}):
        # A count names both numbers: the file then gives them, the changed one and the count's other.
        row = threads.by_count(raw["tension"].pop("thread"))
        raw["tension"].update(breaking_load=row.strength, elongation_at_break=row.elongation)
        raw["tension"][parts[1]] = v
    elif sec in (
        "input",
        "steady",
        "thread",
        "synthesis",
        "counterweight",
        "timing",
        "balance",
        "tension",
        "presser",
        "fabric",
    ):
        raw.setdefault(sec, {})[parts[1]] = v
    elif sec == "dynamics" and parts[1] == "motor":
        raw["dynamics"]["motor"][parts[2]] = v
    elif sec == "dynamics" and parts[1] != "force":
        raw["dynamics"][parts[1]] = v
