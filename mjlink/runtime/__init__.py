"""The run machinery: what a command needs to run safely, apart from what it computes.

Used by :mod:`mjlink.pipeline` and :mod:`mjlink.cli` (and the entry point) only; the layers
that compute and draw (``model``, ``reference``, ``analysis``, ``sim``, ``study``,
``plotting``, ``pages``) never import it (an import-linter contract in ``pyproject.toml``).

* :mod:`.staging`: output folders written whole or not at all, only where mjlink may write;
  :mod:`.markers` what an output folder says of itself; :mod:`.lock` one run per folder and
  the tidying of what killed runs left.
* :mod:`.signals`: SIGINT and SIGTERM end a run cleanly.
* :mod:`.workers`: the figures' worker process, forked beside the run.
* :mod:`.progress`: a long study's progress on stderr.
* :mod:`.environment`: process settings read when a process starts (BLAS threads, glibc's
  allocator for a study's workers).
* :mod:`.cluster`: the Dask cluster a study runs on, connected to or started here.

Nothing is imported here: the entry point imports :mod:`.environment` before numpy loads.
"""
