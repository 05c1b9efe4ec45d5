"""The command line's process before numpy is loaded: one OpenBLAS thread (imported first by
:mod:`mjlink.cli`, before anything that imports numpy).

numpy's OpenBLAS starts a thread per core when it is loaded, and after a call large enough to
split it keeps them spinning for a while, waiting for the next: measured with a sampling
profiler, 0.3 s of CPU in a ``simulate takeup`` of about 6 s went to those threads. mjlink's own
parallelism is elsewhere (the forked plot workers, MuJoCo's rollout thread pool, the study's
Dask processes, which get the same setting) and its matrix products are small. A value the
user set is kept; a program that imported numpy before mjlink keeps whatever it has.
"""

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
