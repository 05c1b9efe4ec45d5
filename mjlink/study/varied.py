"""One varied parameter of a study and how it varies (:class:`Varied`)."""

from __future__ import annotations

import math
from dataclasses import dataclass

from ..model import paths


@dataclass(frozen=True, kw_only=True)
class Varied:
    """One varied parameter and how it varies (file units).

    grid: ``values``; random: ``low``/``high``; tolerance: ``tolerance`` (the +- band) and
    ``distribution`` ('uniform' over the band, 'normal' with sigma = tolerance / 3, or
    'even'); an operating condition's ``levels`` (0: drawn) its values evenly over the band,
    crossed with every other condition's (:func:`.sampling.crossed`).
    """

    param: paths.Param
    values: tuple[float, ...] = ()
    low: float = math.nan
    high: float = math.nan
    tolerance: float = math.nan
    distribution: str = "uniform"
    levels: int = 0
