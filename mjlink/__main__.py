"""``python -m mjlink`` and the ``mjlink`` command: the command line's entry point, :func:`entry`.

It sets what the process needs before numpy loads (:func:`mjlink.runtime.environment.one_blas_thread`), runs
:func:`mjlink.cli.main`, and exits with its status.
"""

from __future__ import annotations

import os
import sys
from typing import NoReturn

from .runtime import environment


def entry() -> NoReturn:
    """Run the command line on ``sys.argv`` and exit with its status.

    An interrupted command (status 130) ends through ``os._exit`` once it has cleaned up (its
    staging folder removed, its workers and cluster stopped: the ``with`` blocks have ended) and
    its output is flushed: a Ctrl-C that reached Python code called from C (MuJoCo's bindings)
    leaves CPython believing the interruption unhandled, and a normal exit would then end the
    process by re-raising SIGINT on itself (status -2, not the documented 130)."""
    environment.one_blas_thread()
    from .cli import main  # after one_blas_thread: the command line loads numpy

    status = main()
    if status == 130:
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(130)
    sys.exit(status)


# Guarded: a Dask LocalCluster starts its workers by spawning Python processes that import the
# parent's main module again (as ``__mp_main__``); unguarded, each would run the command anew.
if __name__ == "__main__":
    entry()
