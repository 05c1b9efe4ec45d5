"""Where this process's memory comes from: glibc's allocator told to keep what it frees.

The reference computes on arrays of crank angles (and of variants x angles in a study): every
jet operation allocates and frees temporaries of hundreds of kilobytes to megabytes. By
default glibc serves blocks above its mmap threshold (128 KiB, raised only as such blocks are
freed) with fresh mappings and returns freed memory at the top of its heap above its trim
threshold to the system, so the next call faults the same pages in again. On this project's
virtual machines a page fault is expensive: measured, the take-up's four-bar at 36,000 crank
angles costs 16 to 20 ms of CPU with the defaults and 8 ms with the thresholds raised, and a
study chunk inside a Dask worker (whose nanny sets a 64 KiB trim threshold) twice what it
costs here. Raising the thresholds changes where memory comes from, never what is computed;
the price is that up to :data:`TRIM_BYTES` of freed memory stays with the process.

The command line calls :func:`keep_freed_memory` once at start; a study's worker processes get
:data:`MALLOC_ENV` at start and call it with :func:`one_arena` when they are warmed up. A
program using mjlink's Python API on large batches can call :func:`keep_freed_memory` itself.

The other process-wide setting both get the same way lives here too: one BLAS thread
(:data:`BLAS_ENV`, :func:`one_blas_thread`), from the environment before numpy loads.
"""

from __future__ import annotations

import ctypes
import functools
import os
import sys

TRIM_BYTES = 512 << 20  # freed memory at the heap's top kept for reuse, bytes
MMAP_BYTES = 256 << 20  # blocks below this come from the heap, not from a mapping of their own, bytes

# One thread for numpy's BLAS (OpenBLAS in numpy's wheels; MKL and OpenMP builds alike): it
# starts a thread per core and, after a product large enough to split, keeps them spinning.
# mjlink's parallelism is its own (forked plot workers, MuJoCo's rollout threads, Dask
# processes) and its products are small. Read when numpy loads: the command line sets them
# first (:func:`one_blas_thread`), Dask's defaults for its workers are the same.
BLAS_ENV = {"OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"}

# The allocator settings as environment variables, for processes started by the study engine
# (glibc reads them at start-up, before any thread exists), with BLAS_ENV.
MALLOC_ENV = {
    "MALLOC_TRIM_THRESHOLD_": str(TRIM_BYTES),
    "MALLOC_MMAP_THRESHOLD_": str(MMAP_BYTES),
    "MALLOC_ARENA_MAX": "1",
    **BLAS_ENV,
}

_M_TRIM_THRESHOLD, _M_MMAP_THRESHOLD, _M_ARENA_MAX = -1, -3, -8  # glibc's mallopt parameters


@functools.cache
def _libc() -> ctypes.CDLL | None:
    if not sys.platform.startswith("linux"):
        return None
    try:
        return ctypes.CDLL("libc.so.6")
    except OSError:  # not glibc (musl): its allocator has no such thresholds
        return None


@functools.cache
def keep_freed_memory() -> None:
    """Raise glibc's trim and mmap thresholds (:data:`TRIM_BYTES`, :data:`MMAP_BYTES`) for the
    rest of this process; nothing where the C library is not glibc. Idempotent."""
    libc = _libc()
    if libc is not None:
        libc.mallopt(_M_TRIM_THRESHOLD, TRIM_BYTES)
        libc.mallopt(_M_MMAP_THRESHOLD, MMAP_BYTES)


@functools.cache
def one_arena() -> None:
    """One allocator arena (the main one) for every thread created after this call.

    glibc gives each thread its own arena, a heap of at most 64 MiB, so a task running in a
    worker thread maps the reference's larger temporaries afresh on every call whatever the
    thresholds (measured: a study chunk 28 % slower in a thread than in the main thread). For
    the study's workers, whose tasks run one at a time, so there is no contention; not for a
    process whose threads allocate side by side."""
    libc = _libc()
    if libc is not None:
        libc.mallopt(_M_ARENA_MAX, 1)


def one_blas_thread() -> None:
    """Set :data:`BLAS_ENV` in ``os.environ`` where the user has not set them: effective only
    before numpy is first imported (measured: OpenBLAS's spinning threads took 0.3 s of the
    CPU of a ``simulate takeup`` of about 6 s, on the core the plot workers need)."""
    for k, v in BLAS_ENV.items():
        os.environ.setdefault(k, v)
