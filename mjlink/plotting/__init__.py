"""PNG figures comparing MuJoCo runs with the vector-method reference: drawing only.

:mod:`.figures` (kinematics, thread, sliders, phase study, run-up), :mod:`.loads` (torque,
pair reactions, steady motion), :mod:`.style` (the shared look and the atomic writer). The
quantities drawn come from the traces, :mod:`mjlink.reference` and :mod:`mjlink.analysis`.
"""

import matplotlib

# Headless: the CLI and tests run without a display. Chosen here, in the package, so that it
# happens before any module of the package imports pyplot.
matplotlib.use("Agg")
# Titles sit at the top of their axes: no axes here has tick labels above it, and leaving the
# position automatic makes matplotlib measure every axis's tick labels for it at every draw
# (a sixth of a figure's drawing). The figure tests check that no text overlaps.
matplotlib.rcParams["axes.titley"] = 1.0
