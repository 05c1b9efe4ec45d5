"""Plausibility and faithfulness limits (mechanisms/README.md, "Limits" and "Dead points").

One home for every bound a mechanism, a command-line value or a check is held to. Lengths in
the file's mm where the name says so; everything else SI unless named.
"""

from __future__ import annotations

# Lengths and coordinates, mm: beyond a metre the agreement thresholds, which are absolute
# (0.1 um), are no longer met at machine speeds (errors grow with size); bars below 0.1 mm are
# not machine parts, and far below it MuJoCo's fixed tolerances dominate (a 2 um crank-slider
# missed the thresholds).
MAX_LENGTH_MM = 1000.0
MIN_BAR_MM = 0.1
# [input] speed, rad/s: below 1 rad/s a kinematic run of one turn needs > 125 000 steps;
# above 1e4 rad/s a turn is shorter than 13 steps. [input] cycles at most MAX_CYCLES.
MIN_SPEED, MAX_SPEED = 1.0, 1e4
MAX_CYCLES = 100.0
MAX_GEAR_RATIO = 64.0
# Angles in files (phi0, phase, attached angle): beyond a turn or two they only lose precision
# (phi0 = 1e300 deg leaves no digits for the crank's motion).
MAX_ANGLE_DEG = 720.0
# A link's mass (g) and moment of inertia (kg*m^2): a tonne and 1000 kg*m^2 are far beyond any
# machine part; absurd values would only overflow the reduced inertia or MuJoCo's mass matrix.
MAX_MASS_G, MAX_INERTIA = 1e6, 1e3

# Dead points, measured with the kinematic run (dt 50 us) on four-bars and crank-sliders whose
# links carry bar-like masses: four-bars miss the velocity threshold (2e-5 of range) from 8-12
# deg from the dead point at 100-150 rad/s and the position threshold (0.1 um) at 20 deg with a
# 40 mm crank at 150 rad/s; crank-sliders (20 mm crank) miss 0.1 um once the pressure angle
# passes 75-80 deg (100 rad/s) or 70-75 deg (150 rad/s). Errors grow with speed and, for
# positions, with crank length x speed^2. Within the envelope below the limits keep every run
# measured within the thresholds.
MIN_TRANSMISSION_DEG = 20.0  # a dyad's transmission angle stays within [20, 160] deg
MAX_PRESSURE_DEG = 60.0  # a slider's pressure angle stays at most 60 deg
# The envelope over which the thresholds are verified (test_property.py generates inside it):
# crank speed up to 150 rad/s, crank-pin acceleration r omega^2 between 10 m/s^2 (below it
# gravity's load on the soft loop closures dominates the acceleration error) and 500 m/s^2
# (errors grow with it), links with comparable, bar-like masses. Outside it a run is reported,
# not refused: the agreement table shows how close it came and --strict fails on a miss.
VERIFIED_SPEED = 150.0  # rad/s
VERIFIED_CRANK_ACCELERATION = (10.0, 500.0)  # m/s^2, crank length x speed^2
MIN_DIRECTION_M = 1e-6  # points that define a direction (attached, guide) stay this far apart
# Points of one link are one point or at least this far apart: MuJoCo's compiler takes a site or
# centre of mass within 1e-7 m of its body's frame for the frame itself (measured: a centre of
# mass 1e-4 mm from its crank's pivot was simulated on the pivot, a 0.1 um position error).
MIN_DISTINCT_M = 1e-6
SAMPLES_PER_TURN = 3600  # input-angle samples per crank turn for every check over a cycle
