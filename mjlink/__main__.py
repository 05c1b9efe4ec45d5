"""``python -m mjlink``: the command line, :func:`mjlink.cli.main`."""

import sys

from .cli import main

sys.exit(main())
