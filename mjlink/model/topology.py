"""Kinematic pairs of a mechanism and the spanning tree MuJoCo's bodies follow.

A point shared by two links (or a ground point on a link) is a revolute pair, a link's
``guide`` a prismatic pair. The spanning tree of these pairs rooted at the ground becomes the
kinematic tree; every other pair closes a loop. Slides and crank pivots are put in the tree
first, since only revolute pairs can be closed by a ``connect`` equality. Used by the builder,
by the reference's kinetostatics and by ``check``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from ..errors import MechanismFileError
from ..units import PairKind
from .mechanism import Mechanism
from .names import GROUND


@dataclass(frozen=True)
class Pair:
    """A kinematic pair: revolute at ``point`` or prismatic along ``guide``; ``parent`` None is ground."""

    kind: PairKind
    parent: str | None
    child: str
    point: str | None = None
    guide: tuple[str, str] | None = None

    @property
    def pin(self) -> str:
        """The point of a revolute pair."""
        assert self.point is not None, "a prismatic pair has no pin"
        return self.point

    @property
    def rail(self) -> tuple[str, str]:
        """The guide line of a prismatic pair."""
        assert self.guide is not None, "a revolute pair has no guide"
        return self.guide

    @property
    def revolute(self) -> bool:
        return self.kind is PairKind.REVOLUTE

    @property
    def label(self) -> str:
        """Readable label: ``P3:lever-rocker`` (point:parent-child), ``slide:cylinder-plunger``."""
        parent = self.parent or GROUND
        return f"{self.point}:{parent}-{self.child}" if self.revolute else f"slide:{parent}-{self.child}"


@dataclass(frozen=True)
class Topology:
    """Tree pairs in build order, loop-closing pairs, and each link's body origin point."""

    tree: tuple[Pair, ...]
    loops: tuple[Pair, ...]
    origin: dict[str, str] = field(default_factory=dict)


def pairs(mech: Mechanism) -> list[tuple[int, Pair]]:
    """Every kinematic pair of the mechanism with its tree priority (lower goes first)."""
    out: list[tuple[int, Pair]] = []
    # A crank's pivot goes into the tree before other ground pivots, so its hinge is the drive.
    crank_pivots = {(s.inputs[0], s.point) for s in (mech.input_crank, *mech.geared)}
    owners: dict[str, list] = {}
    for l in mech.links:
        for p in l.points:
            owners.setdefault(p, []).append(l)
    for l in mech.links:
        if l.guide:
            g1, g2 = l.guide
            both = [o for o in owners.get(g1, []) if o in owners.get(g2, []) and o is not l]
            parent = None if (g1 in mech.ground and g2 in mech.ground) else (both[0].name if both else "")
            if parent == "":
                raise MechanismFileError(
                    f"{mech.path or mech.name}: [links.{l.name}] guide: points {g1} and {g2} are not on one link or the ground"
                )
            out.append((0, Pair(PairKind.PRISMATIC, parent, l.name, guide=l.guide)))
    for l in mech.links:
        for p in l.points:
            if p in mech.ground:
                crank = any(pv == p and pt in l.points for pv, pt in crank_pivots)
                out.append((1 if crank else 2, Pair(PairKind.REVOLUTE, None, l.name, point=p)))
    # k bodies pinned at one point make k - 1 pairs, not one per two of them: the others would
    # repeat a constraint (a redundant connect equality gets no constraint rows in MuJoCo, and
    # kinetostatics would count unknowns twice). At a ground point every link is pinned to the
    # frame above; elsewhere the links pinned there join the first of them.
    for p, ls in owners.items():
        if p in mech.ground:
            continue
        for b in ls[1:]:
            out.append((3, Pair(PairKind.REVOLUTE, ls[0].name, b.name, point=p)))
    return out


def topology(mech: Mechanism) -> Topology:
    """Spanning tree rooted at the ground (Kruskal over prioritized pairs); the rest close loops."""
    cand = sorted(enumerate(pairs(mech)), key=lambda t: (t[1][0], t[0]))
    parent_of = {l.name: l.name for l in mech.links}
    parent_of["@ground"] = "@ground"

    def find(x):
        while parent_of[x] != x:
            parent_of[x] = parent_of[parent_of[x]]
            x = parent_of[x]
        return x

    chosen, loops = [], []
    for _, (_, pr) in cand:
        a, b = find(pr.parent or "@ground"), find(pr.child)
        if a != b:
            parent_of[a] = b
            chosen.append(pr)
        elif pr.revolute:
            loops.append(pr)
        else:
            raise MechanismFileError(
                f"{mech.path or mech.name}: [links.{pr.child}] guide: a sliding pair "
                f"that closes a loop is not supported"
            )
    # Orient the chosen pairs away from the ground.
    tree: list[Pair] = []
    placed: set[str | None] = {None}
    origin: dict[str, str] = {}
    remaining = list(chosen)
    while remaining:
        progress = False
        for pr in list(remaining):
            if pr.parent in placed or pr.child in placed:
                if pr.parent not in placed:  # chosen the other way round: flip
                    assert pr.parent is not None  # the ground is always placed first
                    pr = Pair(pr.kind, pr.child, pr.parent, pr.point, pr.guide)
                tree.append(pr)
                placed.add(pr.child)
                origin[pr.child] = pr.pin if pr.revolute else mech.link(pr.child).points[0]
                remaining.remove(
                    next(r for r in remaining if {r.parent, r.child} == {pr.parent, pr.child} and r.point == pr.point)
                )
                progress = True
        if not progress:
            break
    unplaced = [l.name for l in mech.links if l.name not in placed]
    if unplaced:
        raise MechanismFileError(
            f"{mech.path or mech.name}: [links]: {', '.join(unplaced)} not connected to the ground"
        )
    return Topology(tuple(tree), tuple(loops), origin)
