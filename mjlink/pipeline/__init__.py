"""The one orchestrator: every command's work, in order, as typed results.

Each layer lives in its own package: :mod:`mjlink.sim` (MuJoCo runs and video),
:mod:`mjlink.reference` (the vector-method analysis), :mod:`mjlink.compare` (agreement and every
threshold), :mod:`mjlink.files` (files), :mod:`mjlink.plotting` (figures). The modules here only
order and time them, and return frozen dataclasses; the command line (:mod:`mjlink.cli`) parses
arguments, calls one function here and prints what it returns. How a run is carried out safely
(output folders staged and locked, signals, the figures' worker process, the Dask cluster) is
:mod:`mjlink.runtime`'s, used here and by the command line only.

=====================  ===================  ==========================================
function               command              result, output
=====================  ===================  ==========================================
:func:`run`            ``simulate``         :class:`SimulateResult`, folder ``OUT/NAME/``
:func:`loads`          ``torque``,          :class:`LoadsResult`, folder ``OUT/NAME_loads/``
                       ``reactions``
:func:`steady`         ``steady``           :class:`SteadyResult`, folder ``OUT/NAME_steady/``
:func:`build`          ``build``            :class:`BuildResult`, the MJCF (and a file)
:func:`synthesize`     ``synth``            :class:`SynthResult`; :func:`write_design` its file
:func:`.study.run`     ``study``            :class:`.study.StudyResult`, ``OUT/NAME-study/``
:func:`feed`           ``feed``             :class:`FeedResult`, nothing written
=====================  ===================  ==========================================

The modules, one concept each: :mod:`.options` (what a run is asked to do, the drive
overrides), :mod:`.cost` (what it will cost, checked before it starts), :mod:`.results` (the
typed results and their reports), :mod:`.simulate` (the ``simulate`` run), :mod:`.loads`
(torque, reactions, steady motion), :mod:`.design` (``build`` and ``synth``), :mod:`.study`,
:mod:`.optimize` and :mod:`.winner` (design studies and optimal synthesis).

Every output folder is all or nothing (:func:`mjlink.runtime.staging.staged_dir`), every single
file too (:func:`mjlink.files.write_text`). Units SI (m, rad, s, kg, N, N*m, W) unless a name says
otherwise (``speed_rpm``). Errors are one-line :class:`~mjlink.errors.MjlinkError` subclasses;
where the value at fault can come from a command-line option, the message names the option.
"""

from __future__ import annotations

from .cost import Estimate, RunCost, estimate, values_per_sample
from .design import build, synthesize, write_design
from .feed import FeedResult, feed
from .loads import loads, steady
from .options import Drive, Options, check_speed, has_masses, speed_text, with_drive
from .results import (
    BuildResult,
    DynamicsSummary,
    KinematicsSummary,
    LoadsResult,
    LoadsSummary,
    Provenance,
    Rk4Comparison,
    SimulateResult,
    SteadyResult,
    SteadySummary,
    SynthResult,
    Timings,
    VideoSummary,
    provenance,
)
from .simulate import run

__all__ = [
    "BuildResult",
    "Drive",
    "DynamicsSummary",
    "Estimate",
    "FeedResult",
    "KinematicsSummary",
    "LoadsResult",
    "LoadsSummary",
    "Options",
    "Provenance",
    "Rk4Comparison",
    "RunCost",
    "SimulateResult",
    "SteadyResult",
    "SteadySummary",
    "SynthResult",
    "Timings",
    "VideoSummary",
    "build",
    "check_speed",
    "estimate",
    "feed",
    "has_masses",
    "loads",
    "provenance",
    "run",
    "speed_text",
    "steady",
    "synthesize",
    "values_per_sample",
    "with_drive",
    "write_design",
]
