"""Units and closed vocabularies, one home each.

Mechanism files are written in the papers' units (mm, deg, g); everything inside mjlink is
SI (m, rad, kg, s). Multiply a file value by the factor to get SI, divide an SI value by it
to print in the file's unit: ``length_mm * MM`` is metres, ``phi / DEG`` is degrees.
"""

from __future__ import annotations

import enum
import math
from typing import TYPE_CHECKING, TypeVar

if TYPE_CHECKING:
    import numpy as np

# A quantity converted as it comes: a float gives a float, an array an array of the same shape.
Q = TypeVar("Q", float, "np.ndarray")

MM = 1e-3  # m per mm
UM = 1e-6  # m per um
G = 1e-3  # kg per g
DEG = math.pi / 180.0  # rad per deg
RPM = math.pi / 30.0  # rad/s per rev/min


def to_rpm(omega: Q) -> Q:
    """rev/min from rad/s (scalar or array)."""
    return omega * 30.0 / math.pi  # not omega / RPM: this order matches the CSVs written so far bit for bit


def from_rpm(n: Q) -> Q:
    """rad/s from rev/min (scalar or array)."""
    return n * math.pi / 30.0  # the order of operations the torque command has always used


def to_mm(x: Q) -> Q:
    """mm from m (scalar or array)."""
    return x / MM


def to_um(x: Q) -> Q:
    """um from m (scalar or array)."""
    return x / UM


class PairKind(enum.StrEnum):
    """A lower kinematic pair: a hinge about Z at a point, or a slide along a guide line."""

    REVOLUTE = "revolute"
    PRISMATIC = "prismatic"


class RunKind(enum.StrEnum):
    """The two MuJoCo runs: the crank turned at constant speed, or driven by its moment."""

    KINEMATICS = "kinematics"
    DYNAMICS = "dynamics"


class Source(enum.StrEnum):
    """Where a trace comes from."""

    MUJOCO = "mujoco"
    REFERENCE = "reference"


class PairRole(enum.StrEnum):
    """How the builder realises a pair: a tree joint, a loop-closing equality, or not at all."""

    JOINT = "joint"
    LOOP = "loop"
    UNPLACED = ""


class Integrator(enum.StrEnum):
    """MuJoCo's integrators by the names the settings use."""

    RK4 = "RK4"
    EULER = "Euler"
    IMPLICIT = "implicit"
    IMPLICITFAST = "implicitfast"


def shown(unit: str) -> str:
    """A unit as mjlink prints and draws it, one spelling in the terminal, on the pages and in
    the figures: 'um' -> 'µm', 'N*m' -> 'N·m', 'kg*m^2' -> 'kg·m²', 'm/s^2' -> 'm/s²'. Names a
    program reads (column names, CSV headers, JSON keys and values) keep the ASCII spelling,
    which the files' unit grammar takes as well."""
    out = unit.strip().replace("*", "·").replace("^2", "²").replace("^3", "³")
    return "µm" if out == "um" else out.replace("um/", "µm/")
