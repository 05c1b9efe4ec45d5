"""A sewing head's thread and feed as ``check`` shows them: the tables the runs will take (the
file's, else the defaults), in words and the file's units."""

from __future__ import annotations

from .mechanism import Mechanism
from .presser import FABRIC_DEFAULTS, GRAVITY, PRESSER_DEFAULTS
from .tension import DEFAULTS as TENSION_DEFAULTS
from .tension import GF
from .timing import StitchType

__all__ = ["feed_lines", "thread_lines"]


def feed_lines(mech: Mechanism) -> tuple[str, ...]:
    """A head's presser and fabric as ``feed`` runs them (the file's tables, else the defaults):
    the spring, the foot, the plies and how far the foot presses them at rest (the plies'
    springs in series under the spring's preload and the foot's weight); () without a feed
    dog."""
    tm = mech.timing
    if tm is None or not tm.has("feed_dog"):
        return ()
    p, f = mech.presser or PRESSER_DEFAULTS, mech.fabric or FABRIC_DEFAULTS
    plies = f.layers(tm.fabric)
    k = f.stiffness_of(tm.fabric)
    load = k * (p.preload + p.mass * GRAVITY) / (k + p.rate)
    each = " + ".join(f"{q.thickness * 1e3:g}" for q in plies)
    return (
        f"presser: spring {p.preload:g} N with the foot at the fabric's top, {p.rate * 1e-3:g} N/mm; foot "
        f"{p.mass * 1e3:g} g, lifts to {p.lift * 1e3:g} mm" + ("" if mech.presser else " (the defaults)"),
        f"fabric: {len(plies)} {'ply' if len(plies) == 1 else 'plies'} ({each} mm), a {f.piece(tm.fabric) * 1e3:.3g} g "
        f"piece of {f.area * 1e4:g} cm^2, {k * 1e-3:.4g} N/mm under the foot; friction on the dog {f.dog:g}, "
        f"the foot {f.foot:g}, the plate {f.plate:g}"
        + (f", ply on ply {f.ply:g}" if len(plies) > 1 else "")
        + ("" if mech.fabric else " (the defaults)"),
        f"at rest the foot presses the fabric {load * 1e3 / k:.3f} mm thinner with {load:.3g} N",
    )


def thread_lines(mech: Mechanism) -> tuple[str, ...]:
    """A lockstitch head's needle thread and what tensions it, as the tension model takes them
    (the file's ``[tension]`` table, else the defaults): the thread (by its count where it is a
    row of the chart of :mod:`.threads`), its stiffness, the needle tension, the friction, the
    check spring and the bobbin thread; () for a head the tension model does not cover."""
    tm, bal = mech.timing, mech.balance
    if tm is None or bal is None or tm.stitch is not StitchType.LOCKSTITCH:
        return ()
    t = mech.tension or TENSION_DEFAULTS
    row = t.thread
    named = f"{row.describe()} (MH Thread's chart): " if row is not None else ""
    return (
        f"thread: {named}breaking load {t.breaking_load:.4g} N, elongation at break "
        f"{t.elongation_at_break * 100:.4g} %, EA {t.stiffness:.4g} N",
        f"needle tension {t.needle_tension:.3g} N ({t.needle_tension / GF:.0f} gf) drawn out of the eye; friction "
        f"{t.friction:g} at every contact; check spring {t.spring_force:.3g} N at rest, {t.spring_rate * 1e-3:.3g} "
        f"N/mm over its {bal.check_spring_travel * 1e3:.3g} mm, {t.spring_mass * 1e3:.3g} g at its hook; bobbin "
        f"thread {t.bobbin_tension / GF:.3g} gf" + ("" if mech.tension else " (the defaults)"),
    )
