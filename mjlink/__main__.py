"""``python -m mjlink``: the command line, :func:`mjlink.cli.main`."""

import sys

from .cli import main

# Guarded: a Dask LocalCluster starts its workers by spawning Python processes that import the
# parent's main module again (as ``__mp_main__``); unguarded, each would run the command anew.
if __name__ == "__main__":
    sys.exit(main())
