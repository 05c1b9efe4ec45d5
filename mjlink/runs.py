"""Run data: what to simulate and what a run gives, free of MuJoCo.

:class:`Settings` (numerical settings of a model), :class:`Case` (one run to make) and
:class:`Trace` (a run sampled in time, from MuJoCo or from the reference) are plain data, so
comparison, output and plotting read them without importing mujoco. Units SI.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .errors import MjlinkError
from .units import Integrator, RunKind, Source


@dataclass(frozen=True, kw_only=True)
class Settings:
    """Numerical settings of a model.

    ``timestep`` s; ``integrator`` one of RK4, Euler, implicit, implicitfast; ``solref``
    time constant (s) and damping ratio of the loop and gear equalities; ``solimp`` their
    impedance; ``flywheel`` armature (kg*m^2) added to the input crank; ``imposed_speed``
    (rad/s, CCW positive): if given, the model's drive holds the crank at this speed (the
    kinematic run: a flywheel with a speed servo, as a machine's handwheel and motor do);
    otherwise the drive is the file's moment and motor characteristic.
    """

    timestep: float = 1e-4
    integrator: Integrator = Integrator.RK4
    solref: tuple[float, float] = (2e-4, 1.0)
    solimp: tuple[float, float, float, float, float] = (0.9999, 0.9999, 1e-6, 0.5, 2.0)
    flywheel: float = 0.0
    tolerance: float = 1e-13
    imposed_speed: float | None = None

    def __post_init__(self) -> None:
        if self.integrator not in set(Integrator):
            valid = ", ".join(Integrator)
            raise MjlinkError(f"unknown integrator '{self.integrator}' (valid: {valid})")


# Soft loop closure is the main error source: RK4 at 50 us with these time constants keeps it
# below 0.1 um (the kinematic run) and omega within 5e-4 (the dynamic run).
KINEMATIC = Settings(timestep=5e-5, solref=(2e-4, 1.0))
DYNAMIC = Settings(timestep=5e-5, solref=(1e-4, 1.0))


@dataclass(frozen=True, kw_only=True)
class Trace:
    """A run sampled in time. ``source`` 'mujoco' or 'reference'; ``kind`` 'kinematics' or
    'dynamics'. ``time`` s, ``phi`` rad (unwrapped input angle), ``omega`` rad/s, ``eps``
    rad/s^2; per point name (N, 3) arrays of position m, velocity m/s, acceleration m/s^2;
    ``thread_length`` m (None without a thread); ``loop_gap`` m, the largest loop-closure
    violation per sample (MuJoCo only); ``qpos`` MuJoCo joint positions (for rendering);
    ``gear_torques`` per ground pair of a geared shaft, the torque (N*m, about Z) its joint
    carries from the frame: the gear coupling's share (MuJoCo's loads runs only)."""

    source: Source
    kind: RunKind
    time: np.ndarray
    phi: np.ndarray
    omega: np.ndarray
    eps: np.ndarray
    points: dict[str, np.ndarray]
    velocities: dict[str, np.ndarray]
    accelerations: dict[str, np.ndarray]
    thread_length: np.ndarray | None = None
    loop_gap: np.ndarray | None = None
    qpos: np.ndarray | None = None
    link_omega: dict[str, np.ndarray] = field(default_factory=dict)
    link_eps: dict[str, np.ndarray] = field(default_factory=dict)
    torque: np.ndarray | None = None
    reactions: dict[str, np.ndarray] = field(default_factory=dict)
    moments: dict[str, np.ndarray] = field(default_factory=dict)
    gear_torques: dict[str, np.ndarray] = field(default_factory=dict)


@dataclass(frozen=True)
class Case:
    """What to simulate: ``duration`` s, ``omega0`` initial crank speed rad/s (CCW positive),
    ``settings`` numerical settings (the drive is in the model they build), ``sample_every``
    steps between recorded samples; ``loads``: also record the driving torque and the pair
    reaction forces."""

    kind: RunKind
    duration: float
    omega0: float
    settings: Settings
    sample_every: int = 1
    loads: bool = False

    @property
    def steps(self) -> int:
        """Integrator steps of the run (the last one may pass ``duration`` by less than a step)."""
        return math.ceil(self.duration / self.settings.timestep - 1e-9)

    @property
    def samples(self) -> int:
        """Recorded samples, the initial state included."""
        return self.steps // self.sample_every + 1


@dataclass(frozen=True)
class SteadyRun:
    """MuJoCo on the reference's steady orbit: its ``delta`` and mean speed ``omega_mean``
    (rad/s) over the last of ``periods`` crank periods, and the trace."""

    delta: float
    omega_mean: float
    trace: Trace
