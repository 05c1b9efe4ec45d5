"""mjlink: MuJoCo models of sewing- and knitting-machine linkages, checked against the
classical vector-method analysis.

The public API (documented in docs/api.md; each name is a function of :mod:`mjlink.api`)::

    import mjlink

    mech = mjlink.load("takeup")              # a shipped mechanism, or a path to a .toml
    tr = mjlink.traces(mech)                  # traces in memory: tr["P5_y_mm"], tr["phi1_deg"]
    xml = mjlink.mjcf(mech)                   # the MJCF
    res = mjlink.simulate(mech, "renders")    # `python -m mjlink simulate`: files and report
    st = mjlink.run_study("crank_slider_grid", "renders", workers=0)
    tab = mjlink.read_study(st.out_dir)       # the study's table and summary
    rep = mjlink.check(mech)                  # and check, export, design, loads, steady, synth, feed

The names load on first use: ``import mjlink`` alone imports neither numpy nor MuJoCo.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from .version import __version__

if TYPE_CHECKING:
    from .api import (
        CheckReport,
        ExportResult,
        FeedResult,
        LoadsResult,
        OptimizeResult,
        SimulateResult,
        SteadyResult,
        StudyResult,
        StudyTable,
        SynthResult,
        Traces,
        check,
        design,
        export,
        feed,
        load,
        loads,
        mjcf,
        read_study,
        read_traces,
        run_study,
        simulate,
        steady,
        synth,
        traces,
    )
    from .errors import MjlinkError
    from .model.mechanism import Mechanism

__all__ = [
    "CheckReport",
    "ExportResult",
    "FeedResult",
    "LoadsResult",
    "Mechanism",
    "MjlinkError",
    "OptimizeResult",
    "SimulateResult",
    "SteadyResult",
    "StudyResult",
    "StudyTable",
    "SynthResult",
    "Traces",
    "__version__",
    "check",
    "design",
    "export",
    "feed",
    "load",
    "loads",
    "mjcf",
    "read_study",
    "read_traces",
    "run_study",
    "simulate",
    "steady",
    "synth",
    "traces",
]

_HOME = {"Mechanism": "mjlink.model.mechanism", "MjlinkError": "mjlink.errors"}


def __getattr__(name: str) -> Any:
    # The API's modules import numpy, the pipeline and (for a run) MuJoCo: loaded when a name
    # is first used, so `import mjlink` (and `python -m mjlink --help`) stays light.
    if name in __all__ and name != "__version__":
        import importlib

        value = getattr(importlib.import_module(_HOME.get(name, "mjlink.api")), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'mjlink' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
