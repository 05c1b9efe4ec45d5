"""What a command is asked to do: the run's options, the drive overrides and their checks.

:class:`Options` is what :func:`mjlink.pipeline.run` does; :class:`Drive` the drive, load and
duration of the dynamic runs in place of the file's (:func:`with_drive` applies and checks
them). Speeds rad/s, signed, counter-clockwise positive as a file's ``[input] speed``; every
check's message names the command-line option the value can come from.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any

from ..errors import MjlinkError
from ..model.limits import (
    MAX_DAMPING,
    MAX_DURATION_S,
    MAX_SPEED,
    MAX_TORQUE_NM,
    MIN_DURATION_S,
    MIN_SPEED,
    above,
    below,
)
from ..model.mechanism import Mechanism, Motor, SteadyCase
from ..units import to_rpm

DEFAULT_TARGET_DELTA = SteadyCase.target_delta  # the file format's default coefficient of speed fluctuation


@dataclass(frozen=True, kw_only=True)
class Options:
    """What :func:`run` does (:func:`estimate` says what it will cost, and refuses the absurd).

    ``speed`` rad/s, signed, counter-clockwise positive about +Z as the file's ``[input]
    speed`` (a sign opposite to the file's turns the crank the other way), and ``cycles``
    crank periods of the kinematic run (None: the file's);
    ``duration`` s of the dynamic run (None: the file's); ``dynamics`` the forward-dynamics run
    (when the file has masses and a [dynamics] table); ``loads`` the driving torque and pair
    reactions (when it has masses); ``steady`` the steady-motion and flywheel study (needs a
    motor); ``plots`` the PNG figures; ``video`` the MP4, ``video_seconds`` s long at ``fps``
    frames/s, ``width`` x ``height`` pixels.
    """

    speed: float | None = None
    cycles: float | None = None
    duration: float | None = None
    dynamics: bool = True
    plots: bool = True
    video: bool = True
    video_seconds: float = 3.0
    fps: int = 30
    width: int = 640
    height: int = 480
    loads: bool = True
    steady: bool = False


@dataclass(frozen=True, kw_only=True)
class Drive:
    """Drive, load and duration of the dynamic runs in place of the file's (None: the file's).

    ``moment`` constant driving moment on the crank, N*m; ``damping`` viscous damping on it,
    N*m*s; ``omega0`` initial crank speed of the dynamic run, rad/s; ``duration`` s;
    ``stall_torque`` N*m and ``no_load_speed`` rad/s, together, a linear motor characteristic;
    ``target_delta`` the coefficient of speed fluctuation the flywheel is sized for. Speeds and
    moments are signed as in the file: counter-clockwise positive about +Z.
    """

    moment: float | None = None
    damping: float | None = None
    omega0: float | None = None
    duration: float | None = None
    stall_torque: float | None = None
    no_load_speed: float | None = None
    target_delta: float | None = None


def has_masses(mech: Mechanism) -> bool:
    """Whether the file defines a forward-dynamics case: a [dynamics] table and masses."""
    return mech.has_dynamics and has_mass(mech)


def has_mass(mech: Mechanism) -> bool:
    """Whether any link has a mass: the loads need nothing more."""
    return any(l.mass > 0 for l in mech.links)


def speed_text(w: float) -> str:
    """A speed as errors show it, in both units the command line takes: '0 rad/s (0 rpm)'."""
    return f"{w:g} rad/s ({to_rpm(w):.4g} rpm)"


def check_speed(option: str, w: float | None, given: str | None = None) -> None:
    """Raise MjlinkError unless the crank speed ``w`` (rad/s, signed; None: not given) is within
    the range the simulation is made for; the message names ``option`` and the value as the
    user wrote it (``given``, e.g. '0 rpm'; default both units)."""
    if w is None:
        return
    if not math.isfinite(w) or below(abs(w), MIN_SPEED) or above(abs(w), MAX_SPEED):
        raise MjlinkError(
            f"{option} must be between {MIN_SPEED:g} and {MAX_SPEED:g} rad/s in magnitude "
            f"({to_rpm(MIN_SPEED):.3g} to {to_rpm(MAX_SPEED):.3g} rpm), got {given or speed_text(w)}"
        )


def check_duration(d: float, option: str = "--duration") -> None:
    if not math.isfinite(d) or below(d, MIN_DURATION_S) or above(d, MAX_DURATION_S):
        raise MjlinkError(
            f"{option} must be between {MIN_DURATION_S:g} and {MAX_DURATION_S:g} s (mechanisms/README.md, "
            f"Limits), got {d:g} s"
        )


def with_drive(mech: Mechanism, drive: Drive, *, steady: bool = False) -> Mechanism:
    """``mech`` with the ``drive`` overrides applied, each validated (messages name the option).

    The motor characteristic becomes the file's [dynamics.motor] (unless ``steady``: then it
    drives only the steady-motion study) and, with ``target_delta``, its [steady] case. Raises
    MjlinkError for a non-finite value, a negative damping, a duration or speed outside its
    limits (mechanisms/README.md, "Limits"), half a motor characteristic or one of mixed signs,
    or a target delta outside (0, 2). Messages give values in the option's own unit.
    """
    dyn = mech.dynamics
    changes: dict[str, Any] = {}
    units = {"moment": "N*m", "damping": "N*m*s", "duration": "s"}
    for key in ("moment", "damping", "omega0", "duration"):
        v = getattr(drive, key)
        if v is None:
            continue
        if key == "omega0":
            if not math.isfinite(v) or above(abs(v), MAX_SPEED):
                raise MjlinkError(
                    f"--omega0 must be at most {MAX_SPEED:g} rad/s ({to_rpm(MAX_SPEED):.3g} rpm) in magnitude, "
                    f"got {speed_text(v)}"
                )
        elif key == "duration":
            check_duration(v)
        elif not math.isfinite(v) or (key == "damping" and v < 0):
            raise MjlinkError(
                f"--{key} must be a finite number{' >= 0' if key == 'damping' else ''}, got {v:g} {units[key]}"
            )
        elif above(abs(v), MAX_TORQUE_NM if key == "moment" else MAX_DAMPING):
            hi = MAX_TORQUE_NM if key == "moment" else MAX_DAMPING
            raise MjlinkError(
                f"--{key} must be at most {hi:g} {units[key]} in magnitude (mechanisms/README.md, Limits), "
                f"got {v:g} {units[key]}"
            )
        changes[key] = v
    ts, w0 = drive.stall_torque, drive.no_load_speed
    motor = None
    if ts is None or w0 is None:
        if ts is not None or w0 is not None:
            raise MjlinkError("--stall-torque and --no-load-speed go together (a linear motor characteristic)")
    else:
        if not (math.isfinite(ts) and math.isfinite(w0)) or ts == 0 or w0 == 0 or (ts > 0) != (w0 > 0):
            raise MjlinkError(
                "--stall-torque and --no-load-speed must be finite, non-zero and of the same sign, got "
                f"{ts:g} N*m and {speed_text(w0)}"
            )
        if above(abs(ts), MAX_TORQUE_NM):
            raise MjlinkError(
                f"--stall-torque must be at most {MAX_TORQUE_NM:g} N*m in magnitude (mechanisms/README.md, Limits), "
                f"got {ts:g} N*m"
            )
        check_speed("--no-load-speed", w0)
        motor = Motor(ts, w0)
        if not steady:
            changes["motor"] = motor
    if changes:
        mech = dataclasses.replace(
            mech, dynamics=dataclasses.replace(dyn, **changes), has_dynamics=mech.has_dynamics or bool(changes)
        )
    target = drive.target_delta
    if target is not None and not (0 < target < 2):
        raise MjlinkError(f"--target-delta must be between 0 and 2, got {target:g}")
    if motor is not None or target is not None:
        base = mech.steady or (SteadyCase(mech.dynamics.motor) if mech.dynamics.motor else None)
        m = motor or (base.motor if base else None)
        if m is not None:
            mech = dataclasses.replace(
                mech,
                steady=SteadyCase(
                    m, target if target is not None else (base.target_delta if base else DEFAULT_TARGET_DELTA)
                ),
            )
    return mech
