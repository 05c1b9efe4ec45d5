"""The classical side: the papers' vector-method analysis, exact and vectorized, no MuJoCo.

:mod:`.kinematics` (positions with exact derivatives, assembly), :mod:`.dynamics` (reduced
inertia, the equation of motion, steady motion and flywheel; :mod:`.energy` its solution over
the crank angle), :mod:`.kinetostatics` (driving
torque, forces in every pair), :mod:`mjlink.model.synthesis` (crank-slider metric synthesis, here as ``synthesis``).
"""

from ..model import synthesis  # the crank-slider's metric synthesis, a design of the model's numbers
from . import energy
from .dynamics import (
    TIGHT_RTOL,
    Motion,
    Reduced,
    SpectralDynamics,
    Steady,
    constant_speed,
    flywheel_for,
    forward_dynamics,
    reduced,
    rk4_dynamics,
    steady_motion,
    steady_variant,
)
from .kinematics import Kinematics, angle_ranges, check_rigidity, link_angle, solve
from .kinetostatics import Reactions, driving_torque, pair_label, reactions
from .traces import reference_trace

__all__ = [
    "TIGHT_RTOL",
    "Kinematics",
    "Motion",
    "Reactions",
    "Reduced",
    "SpectralDynamics",
    "Steady",
    "angle_ranges",
    "check_rigidity",
    "constant_speed",
    "driving_torque",
    "energy",
    "flywheel_for",
    "forward_dynamics",
    "link_angle",
    "pair_label",
    "reactions",
    "reduced",
    "reference_trace",
    "rk4_dynamics",
    "solve",
    "steady_motion",
    "steady_variant",
    "synthesis",
]
