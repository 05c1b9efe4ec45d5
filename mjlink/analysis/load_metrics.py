"""The design metrics of loads at constant crank speed: driving torque and power, the pairs'
reactions, the shaking force and moment of the inertia, the loads on the frame and the gravity
load; and the speed fluctuation of the steady motion under the file's drive. Definitions in
each class's docstring and in ``studies/README.md``.
"""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np

from ..model.jet import norms
from ..model.topology import pairs
from ..reference.batch import Batch, frame_loads, steady_delta
from .metric_base import AtSpeed, Column, Curve, Loads, Metric, MetricError, _slug


class TorquePeak(AtSpeed):
    """Peak driving torque at constant crank speed (``speed`` rad/s, default the file's
    [input] speed): max |tau| over the period, N*m."""

    kind = "torque_peak"

    def columns(self) -> list[Column]:
        return [Column("torque_peak" + self._tag(), "N*m", "peak driving torque")]

    def compute(self, b: Batch, nominal: Batch, loads: Loads) -> dict[str, np.ndarray]:
        return {self.columns()[0].name: np.abs(self._torque(b, loads)).max(axis=1)}

    def curve(self, b: Batch, loads: Loads) -> Curve | None:
        return Curve(f"driving torque at {self.speed:g} rad/s", "N*m", self._torque(b, loads))


class TorqueRms(AtSpeed):
    """RMS driving torque at constant crank speed over the period, N*m."""

    kind = "torque_rms"

    def columns(self) -> list[Column]:
        return [Column("torque_rms" + self._tag(), "N*m", "RMS driving torque")]

    def compute(self, b: Batch, nominal: Batch, loads: Loads) -> dict[str, np.ndarray]:
        return {self.columns()[0].name: np.sqrt((self._torque(b, loads) ** 2).mean(axis=1))}


class PowerMean(AtSpeed):
    """Mean driving power at constant crank speed, the period mean of tau * omega, W."""

    kind = "power_mean"

    def columns(self) -> list[Column]:
        return [Column("power_mean" + self._tag(), "W", "mean driving power")]

    def compute(self, b: Batch, nominal: Batch, loads: Loads) -> dict[str, np.ndarray]:
        return {self.columns()[0].name: self._torque(b, loads).mean(axis=1) * self.speed}


class ReactionPeak(AtSpeed):
    """Peak reaction in every kinematic pair at constant crank speed: max over the period of
    the force's magnitude (for a prismatic pair its normal force), N. One column per pair,
    ``reaction_peak_<pair>`` (pair label as in ``reactions``)."""

    kind = "reaction_peak"

    def columns(self) -> list[Column]:
        return [
            Column(f"reaction_peak_{_slug(pr.label)}" + self._tag(), "N", f"peak reaction {pr.label}")
            for _, pr in pairs(self.mech)
        ]

    def compute(self, b: Batch, nominal: Batch, loads: Loads) -> dict[str, np.ndarray]:
        r = self._reactions(b, loads)
        out = {}
        for col, (_, pr) in zip(self.columns(), pairs(self.mech), strict=True):
            f = r.forces[pr.label]
            out[col.name] = b.per_variant(np.sqrt((f**2).sum(axis=1))).max(axis=1)
        return out


class _Shaking(AtSpeed):
    def _loads(self, b: Batch, loads: Loads) -> Any:

        key = ("frame", self.speed)
        if key not in loads.frame:
            loads.frame[key] = frame_loads(b.mechanism, b.kin, self.speed)
        return loads.frame[key]


class _FramePeak(_Shaking):
    """The peak over the period of one of the frame's loads (a field of
    :class:`mjlink.reference.batch.FrameLoads`: ``part``), a force's magnitude or a moment's
    absolute value."""

    part: ClassVar[str]
    unit: ClassVar[str]
    label: ClassVar[str]

    def columns(self) -> list[Column]:
        return [Column(self.kind + self._tag(), self.unit, f"peak {self.label}")]

    def _q(self, b: Batch, loads: Loads) -> np.ndarray:
        q = getattr(self._loads(b, loads), self.part)
        return b.per_variant(norms(q) if q.ndim == 2 else q)

    def compute(self, b: Batch, nominal: Batch, loads: Loads) -> dict[str, np.ndarray]:
        return {self.columns()[0].name: np.abs(self._q(b, loads)).max(axis=1)}

    def curve(self, b: Batch, loads: Loads) -> Curve | None:
        return Curve(f"{self.label} at {self.speed:g} rad/s", self.unit, self._q(b, loads))


class ShakingForcePeak(_FramePeak):
    """Peak shaking force at constant crank speed: max over the period of |F_s|, F_s = -sum_i
    m_i a_Si the resultant of the links' inertia forces (the counterweight's included), N. It
    is what balancing acts on: zero for a balanced mechanism at any speed. Gravity and the
    file's point forces are not in it (``frame_force_peak``, ``gravity_load``;
    :class:`mjlink.reference.batch.FrameLoads`)."""

    kind = "shaking_force_peak"
    part, unit, label = "inertia_force", "N", "shaking force |F_s| (inertia)"


class ShakingMomentPeak(_FramePeak):
    """Peak shaking moment at constant crank speed: max over the period of |M_s|, M_s = sum_i
    [r_Si x (-m_i a_Si) - J_Si alpha_i] about the input crank's pivot (the inertia forces' and
    moments' moment), N*m. Gravity's and the point forces' moments are in
    ``frame_moment_peak``."""

    kind = "shaking_moment_peak"
    part, unit, label = "inertia_moment", "N*m", "shaking moment (inertia)"


class FrameForcePeak(_FramePeak):
    """Peak force on the frame at constant crank speed: max over the period of |F|, F = sum_i
    m_i (g - a_Si) + the file's point forces, the resultant of every ground pair's reaction on
    the frame (what its mounts carry: the shaking force, the gravity load and the point
    forces together), N."""

    kind = "frame_force_peak"
    part, unit, label = "force", "N", "force on the frame |F| (inertia, gravity, forces)"


class FrameMomentPeak(_FramePeak):
    """Peak moment on the frame at constant crank speed: max over the period of |M|, M about the
    input crank's pivot from the inertia, gravity and the point forces, the drive's reaction
    included (:class:`mjlink.reference.batch.FrameLoads`), N*m."""

    kind = "frame_moment_peak"
    part, unit, label = "moment", "N*m", "moment on the frame"


class GravityLoad(Metric):
    """The gravity load on the frame, |sum_i m_i g| (the links' and counterweight's weight), N:
    the same at every crank angle and speed."""

    kind = "gravity_load"

    def columns(self) -> list[Column]:
        return [Column("gravity_load", "N", "gravity load on the frame")]

    def compute(self, b: Batch, nominal: Batch, loads: Loads) -> dict[str, np.ndarray]:

        fl = frame_loads(b.mechanism, b.kin, 0.0)
        assert fl.gravity_force is not None
        return {"gravity_load": b.per_variant(norms(fl.gravity_force)).max(axis=1)}


class SpeedFluctuation(Metric):
    """Coefficient of speed fluctuation delta = (omega_max - omega_min) / omega_mean of the
    periodic steady motion under the file's drive (its ``[steady]`` motor, else its
    ``[dynamics.motor]``, with its damping), dimensionless (see
    :func:`mjlink.reference.batch.steady_delta`)."""

    kind = "speed_fluctuation"
    needs_loads = True

    def read(self, raw: dict[str, Any]) -> None:
        if self.mech.steady is None and self.mech.dynamics.motor is None:
            raise MetricError(
                f"{self.where}: {self.mech.name} has no drive characteristic ([steady] or [dynamics.motor])"
            )

    def columns(self) -> list[Column]:
        return [Column("delta", "", "coefficient of speed fluctuation")]

    def compute(self, b: Batch, nominal: Batch, loads: Loads) -> dict[str, np.ndarray]:

        return {"delta": steady_delta(b)}
