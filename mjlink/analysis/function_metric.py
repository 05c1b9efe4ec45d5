"""A metric that is the designer's own Python function over a batch's traces.

``mjlink.run_study(study, metrics={"name": fn})`` (or ``{"name": (fn, "m/s")}`` with a unit)
adds one column per function to a study's table, computed for every variant, bounded and
optimized like the file's metrics, and verified as they are: each variant MuJoCo checks is
checked by the same path, the metric's numbers coming from the reference it agrees with.

The contract (docs/api.md, Your own metric in Python):

* ``fn(traces)`` receives a read-only mapping from column name to an array of shape (V, A):
  V variants, A crank angles over one period from each variant's setting (uniform, the end
  excluded), the names and units of ``kinematics.csv`` (``phi1_deg``, ``P5_x_mm``,
  ``P5_vy_mm_s``, ``P5_ay_mm_s2``, ``lever_angle_deg``, ``lever_omega_rad_s``, ``P3_transmission_deg``...), at the
  constant crank speed of the file (or the variant's ``input.speed``); ``theta_deg`` is the
  angle from the setting.
* It returns one number per variant: an array of shape (V,) (NaN where a variant has no
  value: an optimization counts it infeasible). Work on whole arrays (``axis=1`` is over the
  cycle): a study hands the function thousands of variants at once.
* It may run on the workers of a Dask cluster: a function of a script's ``__main__`` or a
  lambda is sent there by value; it must not rely on state it changes.
"""

from __future__ import annotations

import hashlib
import marshal
import re
from collections.abc import Callable, Iterator, Mapping
from typing import Any

import numpy as np

from ..model.mechanism import Mechanism
from ..reference.batch import Batch
from .metric_base import COLUMN_NAME, Column, Loads, Metric, MetricError, taken_by_table


class Traces(Mapping[str, np.ndarray]):
    """A batch's traces by column name, each (V, A), computed when first asked for."""

    def __init__(self, b: Batch, speed: np.ndarray):
        self._b = b
        self._w = speed  # (V*A,) or scalar, rad/s
        self._cache: dict[str, np.ndarray] = {}
        mech = b.mechanism
        names = ["phi1_deg", "theta_deg", "omega1_rad_s"]
        for p in mech.point_names:
            names += [f"{p}_{ax}_mm" for ax in "xyz"]
        for p in mech.moving_points:
            names += [f"{p}_v{ax}_mm_s" for ax in "xyz"] + [f"{p}_a{ax}_mm_s2" for ax in "xyz"]
        for l in mech.links:
            names += [f"{l.name}_angle_deg", f"{l.name}_omega_rad_s", f"{l.name}_eps_rad_s2"]
        for s in mech.steps:
            if s.kind == "dyad":
                names.append(f"{s.point}_transmission_deg")
            elif s.kind == "slider":
                names.append(f"{s.point}_pressure_deg")
        self._names = names

    def __iter__(self) -> Iterator[str]:
        return iter(self._names)

    def __len__(self) -> int:
        return len(self._names)

    def __getitem__(self, name: str) -> np.ndarray:
        if name not in self._cache:
            if name not in self._names:
                raise KeyError(f"no trace {name!r} (names: {', '.join(self._names)})")
            v = self._compute(name)
            v.flags.writeable = False
            self._cache[name] = v
        return self._cache[name]

    def _rows(self, x: Any) -> np.ndarray:
        b = self._b
        return b.per_variant(np.broadcast_to(np.asarray(x, dtype=float), (b.variants * b.angles,))).copy()

    def _compute(self, name: str) -> np.ndarray:
        b, w = self._b, self._w
        kin = b.kin
        if name == "phi1_deg":
            return self._rows(np.degrees(kin.phi))
        if name == "theta_deg":
            return self._rows(np.tile(np.degrees(b.theta), b.variants))
        if name == "omega1_rad_s":
            return self._rows(w)
        m = re.fullmatch(r"(.+)_([xyz])_mm", name)
        if m:
            return self._rows(kin.points[m[1]].v[..., "xyz".index(m[2])] * 1e3)
        m = re.fullmatch(r"(.+)_v([xyz])_mm_s", name)
        if m:
            return self._rows(kin.points[m[1]].d[..., "xyz".index(m[2])] * w * 1e3)
        m = re.fullmatch(r"(.+)_a([xyz])_mm_s2", name)
        if m:
            return self._rows(kin.points[m[1]].dd[..., "xyz".index(m[2])] * w * w * 1e3)
        m = re.fullmatch(r"(.+)_(angle_deg|omega_rad_s|eps_rad_s2)", name)
        if m:
            a = kin.angles[m[1]]
            if m[2] == "angle_deg":  # as the link stands, -180..180 (kinematics.csv's)
                return self._rows(np.degrees(np.angle(np.exp(1j * a.v))))
            return self._rows(a.d * w if m[2] == "omega_rad_s" else a.dd * w * w)
        point = name.rsplit("_", 2)[0]
        step = next(s for s in b.mechanism.steps if s.point == point)
        dp = step.dead_point(kin.positions())
        assert dp is not None
        return self._rows(dp.value_deg)


class FunctionMetric(Metric):
    """The designer's function ``fn`` as a study metric named ``name`` (its column), in
    ``unit`` (module doc: the contract)."""

    def __init__(self, mech: Mechanism, name: str, fn: Callable[[Mapping[str, np.ndarray]], Any], unit: str = ""):
        where = f"metrics[{name!r}]"
        if not isinstance(name, str) or not COLUMN_NAME.fullmatch(name):
            raise MetricError(
                f"{where}: a metric's name must be a column name of letters, digits and '_' (not first a digit), "
                "at most 64 characters"
            )
        if taken_by_table(name):
            raise MetricError(f"{where}: '{name}' is a column every study table has; choose another name")
        if not callable(fn):
            raise MetricError(
                f"{where}: must be a function of the traces (or (function, unit)), got {type(fn).__name__}"
            )
        if not isinstance(unit, str) or len(unit) > 16 or not re.fullmatch(r"[A-Za-z0-9_/^*.%-]*", unit):
            raise MetricError(f"{where}: unit must be a short text such as 'm/s' or 'mm', got {unit!r}")
        self.mech = mech
        self.where = where
        self.point = ""
        self.name = name
        self.fn = fn
        self.unit = unit
        self.label = getattr(fn, "__qualname__", type(fn).__name__)

    def fingerprint(self) -> bytes:
        """What the function computes, as far as can be told without running it: its code,
        defaults, closure and the values of the globals it names (a value whose text differs
        run to run, such as an object's address, makes every run compute anew: the safe way)."""
        h = hashlib.sha256(f"{self.name}\0{self.unit}\0".encode())
        code = getattr(self.fn, "__code__", None)
        if code is None:  # a callable object: its class's code and its state
            h.update(repr(type(self.fn)).encode() + repr(getattr(self.fn, "__dict__", None)).encode())
            code = getattr(vars(type(self.fn)).get("__call__"), "__code__", None)
        if code is not None:
            h.update(marshal.dumps(code))
            glob = getattr(self.fn, "__globals__", {})
            h.update(repr([(n, glob[n]) for n in code.co_names if n in glob]).encode())
        h.update(repr(getattr(self.fn, "__defaults__", None)).encode())
        cells = getattr(self.fn, "__closure__", None) or ()
        h.update(repr([c.cell_contents for c in cells]).encode())
        return h.digest()

    def columns(self) -> list[Column]:
        return [Column(self.name, self.unit, f"{self.label} (a Python function)")]

    def compute(self, b: Batch, nominal: Batch, loads: Loads) -> dict[str, np.ndarray]:
        speed = b.mechanism.speed
        try:
            out = self.fn(Traces(b, np.asarray(speed, dtype=float)))
        except MetricError:
            raise
        except Exception as e:
            what = str(e).splitlines()[0] if str(e) else ""
            raise MetricError(
                f"{self.where}: {self.label} raised {type(e).__name__}{': ' + what if what else ''}"
            ) from e
        try:
            v = np.array(out, dtype=float)  # a copy: the study writes into its columns
        except (TypeError, ValueError):
            raise MetricError(
                f"{self.where}: {self.label} returned {type(out).__name__}, not numbers: one per variant, shape "
                f"({b.variants},)"
            ) from None
        if v.shape != (b.variants,):
            raise MetricError(
                f"{self.where}: {self.label} returned shape {v.shape}; it must give one number per variant, shape "
                f"({b.variants},) (reduce over the cycle: axis=1)"
            )
        return {self.name: v}


def functions(mech: Mechanism, given: Mapping[str, Any] | None) -> tuple[FunctionMetric, ...]:
    """The metrics of ``run_study(metrics=...)``: name -> function, or name -> (function, unit)."""
    if given is None:
        return ()
    if not isinstance(given, Mapping):
        raise MetricError(f"metrics must be a mapping of column name to function, got {type(given).__name__}")
    out = []
    for name, f in given.items():
        if isinstance(f, tuple):
            if len(f) != 2:
                raise MetricError(f"metrics[{name!r}]: give a function, or (function, unit)")
            out.append(FunctionMetric(mech, name, f[0], f[1]))
        else:
            out.append(FunctionMetric(mech, name, f))
    return tuple(out)


def fingerprint(metrics: tuple[FunctionMetric, ...]) -> bytes:
    """All the functions' fingerprints, in order (b'' for none)."""
    return b"".join(m.fingerprint() for m in metrics) if metrics else b""


__all__ = ["FunctionMetric", "Traces", "fingerprint", "functions"]
