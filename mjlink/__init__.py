"""mjlink: MuJoCo models of sewing- and knitting-machine linkages, checked against the
classical vector-method analysis.

Modules, one job each: :mod:`mechanism` (files -> validated objects), :mod:`jet` (exact
derivatives), :mod:`reference` (vector method, reduced-inertia dynamics), :mod:`builder`
(MjSpec), :mod:`simulate` (MuJoCo runs), :mod:`compare` (agreement), :mod:`output` (CSV,
atomic folders), :mod:`plots`, :mod:`render` (MP4), :mod:`pipeline` and :mod:`cli`.
Nothing is imported here, so that ``MUJOCO_GL`` can be chosen before MuJoCo loads.
"""

__version__ = "0.1.0"
