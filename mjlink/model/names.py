"""Names: what a user may call a point, a link or a mechanism, and the MuJoCo element names
built from them. The file reader and the MJCF builder both use these, so a name the reader
accepts is one the builder can emit, and no other module spells an element name.
"""

from __future__ import annotations

import re
from collections.abc import Iterable
from typing import Any

# A letter, then letters, digits or _; at most 32. ASCII only; \Z (unlike $) refuses a trailing
# newline. Names become MuJoCo element names, CSV column prefixes and the output folder's name,
# so they can never hold a path separator, a dot, a space or anything MJCF would need to escape.
NAME_RE = re.compile(r"^[A-Za-z][A-Za-z0-9_]{0,31}\Z")

# Names the MJCF already uses for its own elements (body 'world', materials 'mat_ground' and
# 'mat_eyelet'; a link NAME gets material 'mat_NAME').
RESERVED_LINK_NAMES = ("world", "ground", "eyelet")
GROUND = "ground"  # the frame, as a pair's parent in labels and element names
THREAD = "thread"  # the tendon
DRIVE = "drive"  # the actuator on the input crank
FRONT = "front"  # the camera looking down -Z on the mechanism's plane
OBLIQUE = "oblique"  # the camera from front-right-above, for points in depth


def is_valid(name: object) -> bool:
    """Whether ``name`` is a valid point, link or mechanism name."""
    return isinstance(name, str) and NAME_RE.match(name) is not None


def hinge_joint(link: str, point: str) -> str:
    """The hinge of ``link`` about ``point``."""
    return f"{link}_{point}"


def slide_joint(link: str) -> str:
    """The slide of ``link`` along its guide."""
    return f"{link}_slide"


def loop_equality(point: str, parent: str | None, child: str) -> str:
    """The connect equality that closes a loop at ``point`` (parent None: the ground)."""
    return f"loop_{point}_{parent or GROUND}_{child}"


def loop_anchor(point: str, link: str | None) -> str:
    """The site marking a loop pin on one of its two bodies (None: the ground), whose framepos
    sensors give the loop's gap."""
    return f"anchor_{point}_{link or GROUND}"


def load_site(link: str) -> str:
    """The site at the joint of ``link``'s tree pair (its body origin), carrying the force and
    torque sensors of that pair's reaction."""
    return f"load_{link}"


def gear_equality(link: str) -> str:
    """The joint equality that ties a geared crank's ``link`` to the input crank."""
    return f"gear_{link}"


def sensor(element: str, quantity: str) -> str:
    """A sensor's name: ``P5_pos``, ``P5_vel``, ``thread_length``, ``crank_angle``."""
    return f"{element}_{quantity}"


INITIAL = "initial"  # the keyframe of the file's initial state


def material(link: str) -> str:
    return f"mat_{link}"


def element_clash(links: Iterable[Any], ground: set[str]) -> tuple[str, str] | None:
    """Two links whose MuJoCo element names would coincide: (link, message), or None.

    The builder names a link's joint ``LINK_POINT`` (or ``LINK_slide``) and a loop-closing
    equality ``loop_POINT_PARENT_CHILD``; names with underscores can collide (link ``a_b`` at
    point ``c`` and link ``a`` at point ``b_c``). Every candidate is checked, used or not.
    """
    owners: dict[str, list[str]] = {}
    for l in links:
        for p in l.points:
            owners.setdefault(p, []).append(l.name)
    joints: dict[str, tuple[str, str]] = {}
    loops: dict[str, tuple[str, str, str]] = {}
    for l in links:
        cands = [(hinge_joint(l.name, p), (l.name, p)) for p in l.points if p in ground or len(owners[p]) > 1]
        if l.guide:
            cands.append((slide_joint(l.name), (l.name, "slide")))
        for n, who in cands:
            if joints.setdefault(n, who) != who:
                return l.name, (
                    f"its joint name '{n}' would be the same as link {joints[n][0]}'s: rename the link "
                    f"or the point (names with underscores can run together)"
                )
    for p, ls in owners.items():
        bodies = ls + ([GROUND] if p in ground else [])
        for a in bodies:
            for b in bodies:
                if a != b:
                    n = loop_equality(p, a, b)
                    if loops.setdefault(n, (p, a, b)) != (p, a, b):
                        return b if b != GROUND else a, (
                            f"its loop equality name '{n}' would be the same as another's: rename the link or the point"
                        )
    # Points are sites too: a point may not take the name of a site the builder adds.
    points = set(owners) | set(ground)
    for l in links:
        sites = [load_site(l.name)] + [loop_anchor(p, l.name) for p in l.points if len(owners[p]) > 1 or p in ground]
        sites += [loop_anchor(p, None) for p in l.points if p in ground]
        for n in sites:
            if n in points:
                return l.name, f"point '{n}' has the name of a site the model adds for this link: rename the point"
    return None
