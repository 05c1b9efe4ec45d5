"""mjlink's version, one home: the package, its wheel (pyproject.toml reads it) and every
report and cache manifest take it from here."""

__version__ = "0.1.0"
