"""What a file states validly but probably does not mean, each said with its number.

``check`` prints these as warnings: the mechanism assembles and runs as written, but a designer
would rarely want it so. Each test here has a threshold named below and says the value it
found, so that a designer who does mean it can see how far the design is from the line.

* **Eccentrics in phase.** Two points that drive other links from one turning shaft (a link
  carrying a crank's point and its pivot) at the same angle about the pivot: one eccentric
  would drive both rods, so an angle between them was probably meant (the shipped head sets its
  feed's lift and advance eccentrics 150 deg apart). Whether the driven parts then move in
  phase depends on the linkages after them: the shipped head's feed dog still traces a loop.
* **A feed dog without lift, or on a line.** A head's feed dog whose path over the turn has no
  height to speak of (it cannot rise through the plate and drop back), or encloses almost no
  area (its lift and advance in phase or in opposition: the teeth go back along the line they
  fed on).
* **Plies the foot holds apart.** Plies that grip each other less than the presser foot grips
  the top one (``friction_ply`` below ``friction_foot``): the foot holds the top ply while the
  dog feeds the bottom one, a ply shift of about a whole stitch.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from ..model.blocks import Crank
from ..model.mechanism import Mechanism
from ..model.presser import FABRIC_DEFAULTS

IN_PHASE_DEG = 0.5
"""Two eccentrics closer than this about their shaft (deg) are called in phase."""

NO_LIFT = 0.05
"""A dog whose height range is below this fraction of its travel along the plate has no lift
(a feed dog rises about 1 mm above the plate for 2 to 5 mm of feed: a fifth or more)."""

LINE_AREA = 0.05
"""A dog path enclosing less than this fraction of its bounding box is a line (an ellipse
encloses pi/4 = 0.785 of its box)."""


def warnings(mech: Mechanism, positions: Mapping[str, np.ndarray]) -> list[str]:
    """Every warning for ``mech`` from its reference ``positions`` over one period (name ->
    (N, 3), m, the first sample at the input crank's setting)."""
    return eccentrics_in_phase(mech, positions) + feed_dog_path(mech, positions) + plies_held_apart(mech)


def eccentrics_in_phase(mech: Mechanism, positions: Mapping[str, np.ndarray]) -> list[str]:
    """Pairs of driving points at the same angle about their shaft's pivot, at the setting."""
    out = []
    for link in mech.links:
        pivots = [s.pivot for s in mech.steps if isinstance(s, Crank) and {s.point, s.pivot} <= set(link.points)]
        if not pivots:
            continue
        g = positions[pivots[0]][0]
        angle = {}
        for p in link.points:
            drives = [o.name for o in mech.links if o is not link and p in o.points]
            r = positions[p][0, :2] - g[:2]
            if p == pivots[0] or not drives or not np.all(np.isfinite(r)) or np.hypot(*r) < 1e-9:
                continue
            angle[p] = (math.degrees(math.atan2(r[1], r[0])), drives)
        names = list(angle)
        for i, p in enumerate(names):
            for q in names[i + 1 :]:
                apart = abs((angle[p][0] - angle[q][0] + 180.0) % 360.0 - 180.0)
                if apart < IN_PHASE_DEG:
                    out.append(
                        f"warning: link {link.name}: {p} and {q} sit at the same angle about its pivot "
                        f"{pivots[0]} ({apart:.2f} deg apart): one eccentric would drive both "
                        f"{', '.join(angle[p][1])} and {', '.join(angle[q][1])}; was an angle between them "
                        "meant (the shipped head sets its lift and advance eccentrics 150 deg apart)?"
                    )
    return out


def plies_held_apart(mech: Mechanism) -> list[str]:
    """Plies whose grip on each other is below the foot's on the top one."""
    f = mech.fabric or FABRIC_DEFAULTS
    if mech.timing is None or len(f.plies) < 2 or f.ply >= f.foot:
        return []
    return [
        f"warning: [fabric] friction_ply {f.ply:g} is below friction_foot {f.foot:g}: the foot holds the top ply "
        "while the dog feeds the bottom one, which slides under it (a ply shift of about a whole stitch; "
        "python -m mjlink feed says how much)"
    ]


def feed_dog_path(mech: Mechanism, positions: Mapping[str, np.ndarray]) -> list[str]:
    """A head's feed dog whose path has no lift, or is a line rather than a loop."""
    if mech.timing is None or "feed_dog" not in mech.timing.roles:
        return []
    f = mech.timing.roles["feed_dog"]
    xy = positions[f][:, :2]
    if not np.all(np.isfinite(xy)):
        return []
    along, lift = float(np.ptp(xy[:, 0])), float(np.ptp(xy[:, 1]))
    size = f"{lift * 1e3:.3g} mm up and down and {along * 1e3:.3g} mm along over the turn"
    if lift <= NO_LIFT * along:
        return [
            f"warning: the feed dog {f} has no lift: it moves {size}, so it cannot rise through the plate "
            "and drop back below it"
        ]
    x, y = xy[:, 0], xy[:, 1]
    area = 0.5 * abs(float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y)))
    box = along * lift
    if box > 0 and area < LINE_AREA * box:
        return [
            f"warning: the feed dog {f}'s path is a line, not a loop: it moves {size} and encloses "
            f"{100 * area / box:.2g} % of that box (an ellipse 79 %): its lift and advance are in phase "
            "or in opposition, so its teeth go back along the line they fed on"
        ]
    return []
