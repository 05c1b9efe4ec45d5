"""Imported first by :mod:`mjlink.cli`, before anything loads numpy: the command line's process
with one BLAS thread (:func:`mjlink.memory.one_blas_thread`; a value the user set is kept, and a
program that imported numpy before mjlink keeps whatever it has)."""

from .. import memory

memory.one_blas_thread()
