"""mjlink: MuJoCo models of sewing- and knitting-machine linkages, checked against the
classical vector-method analysis.

The data flows through the packages in this order: :mod:`.model` (a mechanism file read
once into typed objects; the building blocks own their behaviour), :mod:`.reference` (the
papers' analysis, exact and vectorized), :mod:`.validation`, :mod:`.runs` (run data),
:mod:`.sim` (the only MuJoCo side: builder, simulation, video), :mod:`.analysis`,
:mod:`.compare` (every threshold), :mod:`.output`, :mod:`.plotting`, :mod:`.pipeline` (the
only orchestrator) and :mod:`.cli`. Nothing is imported here.
"""

__version__ = "0.1.0"
