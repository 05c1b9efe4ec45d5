"""The needle thread's tension over one stitch, as :func:`.tension.needle_tension` and
:func:`.tension_many.step_many` give it: :class:`NeedleTension`."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["TINY", "NeedleTension"]

TINY = 1e-9  # N: tensions this small count as none


@dataclass(frozen=True, kw_only=True)
class NeedleTension:
    """The needle thread's tension over one stitch in its periodic state.

    ``theta`` (N,) deg from the needle bar's top; ``zones`` (Z,) the stretches from the discs
    to below the eye, each named by its ends; ``tension`` (Z, N) N; ``spring`` (N,) m the check
    spring's travel from its rest stop (zeros without one); ``drawn`` (N,) m the thread drawn
    through the discs since the stitch was set; ``per_stitch`` m the thread drawn through the
    discs per stitch, which the stitch locks; ``formula`` m the stitch formula's needle thread
    per stitch (stitch length + fabric); ``set_at`` deg where the stitch is set (its thread
    locked); ``hold`` N the discs' hold; ``stiffness`` N the thread's EA; ``breaking_load`` N;
    ``cycles`` the stitches run; ``period`` the stitches after which the state repeats: 1,
    or more where the check spring, striking its stop, repeats its motion only every so many
    stitches (any period the stitches run show twice over; the traces are then those of the
    period's stitch with the highest peak, ``per_stitch`` the period's mean), 0 where none was
    found within the stitches run; ``converged`` whether one was (each stitch drew the same
    thread through the discs as the one a period before, within
    :data:`~.tension_state.PERIODIC`); ``set_pull`` N the largest tension below the eye from
    the loop's release to the stitch's setting, the take-up's pull on the stitch as it draws
    it up, against the bobbin thread's ``bobbin`` N (0 for a thread held at both ends)."""

    theta: np.ndarray
    zones: tuple[str, ...]
    tension: np.ndarray
    spring: np.ndarray
    drawn: np.ndarray
    per_stitch: float
    formula: float
    set_at: float
    hold: float
    stiffness: float
    breaking_load: float
    cycles: int
    converged: bool
    period: int = 1
    set_pull: float = 0.0
    bobbin: float = math.inf

    @property
    def peak(self) -> float:
        """The largest tension anywhere over the stitch, N."""
        return float(self.tension.max())

    @property
    def peak_at(self) -> tuple[str, float]:
        """The zone and the angle (deg) of :attr:`peak`."""
        z, k = np.unravel_index(int(np.argmax(self.tension)), self.tension.shape)
        return self.zones[int(z)], float(self.theta[int(k)])

    @property
    def repeats(self) -> str:
        """A clause for a summary line: empty for a stitch that repeats itself, else how the
        state repeats (or that it did not)."""
        if not self.converged:
            return f"; NOT periodic after {self.cycles} stitches"
        if self.period > 1:
            return f"; the stitches repeat every {self.period} (shown: the hardest pulled; the draw: their mean)"
        return ""

    @property
    def margin(self) -> float:
        """The breaking load over the peak tension (above 1: the thread holds)."""
        return self.breaking_load / self.peak if self.peak > 0 else math.inf

    @property
    def slack(self) -> np.ndarray:
        """(N,) bool: the thread below the eye is slack (a loop, no tension): the stretch from
        the eye (to the hook's blade while it carries the loop)."""
        out: np.ndarray = self.tension[_below(self.zones)] <= TINY
        return out

    @property
    def drawn_up(self) -> float:
        """The take-up's largest pull on the stitch as it sets it over the bobbin thread's
        tension: at least 1 for the needle thread to draw the bobbin thread out of its case and
        the interlacing up into the fabric (a bound: the thread's friction through the fabric,
        not modelled, takes some of the pull)."""
        return self.set_pull / self.bobbin

    def failures(self) -> tuple[str, ...]:
        """One line if the thread breaks (its peak tension at or above its breaking load) or the
        run did not reach its periodic state."""
        zone, at = self.peak_at
        out = []
        if self.margin <= 1.0:
            out.append(
                f"tension: the needle thread's peak {self.peak:.3g} N ({zone} at {at:.1f} deg) reaches its "
                f"breaking load {self.breaking_load:.3g} N"
            )
        if not self.converged:
            out.append(
                f"tension: no periodic state in {self.cycles} stitches (no run of stitches repeats twice over in them)"
            )
        return tuple(out)

    def columns(self) -> tuple[list[str], list[np.ndarray]]:
        """The tension.csv table: names (units in them) and (N,) columns."""
        names = ["theta_deg", *(f"T {z} [N]" for z in self.zones), "spring_mm", "drawn_mm"]
        return names, [self.theta, *self.tension, self.spring * 1e3, self.drawn * 1e3]

    def as_dict(self) -> dict[str, object]:
        zone, at = self.peak_at
        return {
            "peak_N": round(self.peak, 6),
            "peak_zone": zone,
            "peak_deg": round(at, 3),
            "breaking_load_N": self.breaking_load,
            "margin": round(self.margin, 4),
            "per_stitch_mm": round(self.per_stitch * 1e3, 6),
            "formula_mm": round(self.formula * 1e3, 6),
            "disc_hold_N": round(self.hold, 6),
            "spring_travel_max_mm": round(float(self.spring.max()) * 1e3, 6),
            "slack_deg": round(float(self.slack.mean()) * 360.0, 3),
            "set_pull_N": round(self.set_pull, 6),
            "bobbin_N": round(self.bobbin, 6) if math.isfinite(self.bobbin) else None,
            "cycles": self.cycles,
            "converged": self.converged,
            "period": self.period,
        }


def _below(zones: tuple[str, ...]) -> int:
    """The stretch from the needle's eye down (to the hook's blade while it carries the loop):
    the last of a thread held at the eye."""
    below = [k for k, z in enumerate(zones) if z.startswith("below ")]
    return below[0] if below else len(zones) - 1
