"""Process-wide settings of the command line and of a study's worker processes, as environment
variables read when a process (or numpy) starts: nothing here calls into a library.

* One thread for numpy's BLAS (:data:`BLAS_ENV`; OpenBLAS in numpy's wheels, MKL and OpenMP
  builds alike): it starts a thread per core and, after a product large enough to split, keeps
  them spinning. mjlink's parallelism is its own (forked plot workers, MuJoCo's rollout threads,
  Dask processes) and its products are small. The command line sets them in its entry point
  before numpy loads (:func:`one_blas_thread`, called by :func:`mjlink.__main__.entry`); a value
  the user set is kept.
* glibc's allocator for a study's worker processes (:data:`MALLOC_ENV`): the reference computes
  on arrays of variants x crank angles, and every jet operation allocates and frees temporaries
  of hundreds of kilobytes. By default glibc serves blocks above its mmap threshold with fresh
  mappings and trims freed memory at the top of its heap, so the next call faults the same pages
  in again, and a Dask worker's task thread gets an arena of its own (a study chunk ran slower
  in a worker's thread than in the main thread, and slower still with the nanny's 64 KiB trim
  threshold). glibc reads these variables (its documented tunables) when a process starts: the
  local cluster (:mod:`.cluster`) gives them to the workers it spawns. Elsewhere (musl, macOS) they mean nothing.
"""

from __future__ import annotations

import os

TRIM_BYTES = 512 << 20  # freed memory at the heap's top kept for reuse, bytes
MMAP_BYTES = 256 << 20  # blocks below this come from the heap, not from a mapping of their own, bytes

BLAS_ENV = {"OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"}

MALLOC_ENV = {
    "MALLOC_TRIM_THRESHOLD_": str(TRIM_BYTES),
    "MALLOC_MMAP_THRESHOLD_": str(MMAP_BYTES),
    "MALLOC_ARENA_MAX": "1",  # a worker's tasks run one at a time: one arena, no contention
    **BLAS_ENV,
}


def one_blas_thread() -> None:
    """Set :data:`BLAS_ENV` in ``os.environ`` where the user has not set them: effective only
    before numpy is first imported (OpenBLAS's idle threads spin on the core the plot workers
    need)."""
    for k, v in BLAS_ENV.items():
        os.environ.setdefault(k, v)
