"""What the commands print: each typed result of :mod:`mjlink.pipeline` (or check report) as text.

Units as printed (:func:`mjlink.units.shown`): speeds rad/s and rev/min, torques N·m, forces N, power W, inertia kg·m²,
lengths mm, masses g, angles deg; errors relative unless a unit is given. Every speed says its
direction (:func:`crank_speed`): signed speeds are counter-clockwise positive about +Z, as in files.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING, cast

from .. import compare, validation
from ..analysis.tension import NeedleTension
from ..analysis.timing import HeadTiming
from ..model import names
from ..model.limits import MAX_PRESSURE_DEG, MIN_TRANSMISSION_DEG
from ..model.tension import GF
from ..pipeline.optimize import conditions_text, speed_option
from ..units import MM, G, PairKind, PairRole, shown, to_mm, to_rpm

if TYPE_CHECKING:
    from ..analysis.summary import Change, Summary
    from ..model.mechanism import Mechanism
    from ..pipeline import LoadsResult, SimulateResult, SteadyResult, SteadySummary, SynthResult
    from ..pipeline.feed import FeedResult
    from ..pipeline.optimize import OptimizeResult
    from ..pipeline.study import StudyResult


def error_line(message: object, limit: int = 2000) -> str:
    """An error as one printable line: control characters and newlines (a file's values, a path
    or the environment can bring them) shown as escapes, clipped to ``limit`` characters. The
    one place errors are printed (:func:`mjlink.cli.main` and argparse's errors) goes through it."""
    line = "".join(c if c.isprintable() else ascii(c)[1:-1] for c in str(message))
    return line if len(line) <= limit else line[: limit - 3] + "..."


def direction(w: float) -> str:
    """The sense of a signed speed (rad/s, counter-clockwise positive about +Z)."""
    return "counter-clockwise" if w > 0 else "clockwise" if w < 0 else "at rest"


def crank_speed(w: float) -> str:
    """A signed crank speed (rad/s) as printed: '954.9 rpm (100 rad/s), counter-clockwise'."""
    if w == 0:
        return "0 rpm (0 rad/s), at rest"
    return f"{abs(to_rpm(w)):.1f} rpm ({abs(w):.4g} rad/s), {direction(w)}"


def against_file(option: str, given: str, w: float, file_speed: float) -> str | None:
    """The note a command prints when ``option`` (written ``given`` as on the command line, e.g.
    '100rad/s'; ``w`` rad/s signed) turns the crank against the file's own direction (the sign
    of its ``[input] speed``, rad/s); None if it does not."""
    if w == 0 or (w > 0) == (file_speed > 0):
        return None
    flipped = given[1:] if given.startswith("-") else "-" + given.lstrip("+")
    return (
        f"note: {option} {given} is {direction(w)}, against the file's own direction "
        f"({direction(file_speed)}: [input] speed = {file_speed:g} rad/s); {option}={flipped} keeps the "
        "file's direction"
    )


def missed(failures: Sequence[str]) -> str:
    """The thresholds missed, one per line under a heading."""
    return "THRESHOLDS MISSED:\n  " + "\n  ".join(failures)


def catalogue_listing(mechs: Sequence[Mechanism]) -> str:
    """What ``list`` prints: each registered mechanism's name and title, and its source."""
    out = []
    for m in mechs:
        out.append(f"{m.name:<16} {m.title}")
        if m.source:
            out.append(f"{'':<16} source: {m.source}")
    return "\n".join(out)


def _num(v: float | None) -> str:
    return "-" if v is None else f"{v:.6g}"


def design_table(d: Summary, base: tuple[str, Sequence[Change], Sequence[Change]] | None = None) -> str:
    """What the design does: the summary's headline numbers with their study metric names;
    with a ``base`` (its name, :func:`mjlink.analysis.summary.against`'s rows) each beside
    the base's and the change, then every dimension that differs."""
    where = f"drawn at phi1 = {d.phi0_deg:g} deg; loads at {crank_speed(d.speed)}"
    if base is None:
        rows = [(r.label, _num(r.value), shown(r.unit), r.metric) for r in d.headline]
        w = max(len(r[0]) for r in rows) if rows else 0
        wv = max(len(r[1]) for r in rows) if rows else 0
        wu = max(len(r[2]) for r in rows) if rows else 0
        out = [f"What the design does ({where}):"]
        out += [f"  {a:<{w}}  {v:>{wv}} {u:<{wu}}  {m}" for a, v, u, m in rows]
        return "\n".join(out)
    name, head, dims = base
    out = [f"What the design does, beside {name} ({where}):"]
    table = [("", "this design", "base", "change", "", "")]
    table += [(c.label, _num(c.value), _num(c.base), _signed(c.delta, c.base), shown(c.unit), c.name) for c in head]
    out += _columns(table)
    if dims:
        out.append(f"Dimensions that differ from {name} ({len(dims)}):")
        out += _columns(
            [("", "this design", "base", "change", "", "")]
            + [(c.name, _num(c.value), _num(c.base), _signed(c.delta, c.base), shown(c.unit), "") for c in dims]
        )
    else:
        out.append(f"Dimensions: the same as {name}'s")
    return "\n".join(out)


def _signed(v: float | None, base: float | None) -> str:
    """A change as '+0.2861'; '0' where it is rounding (below 1e-9 of the base)."""
    if v is None:
        return "-"
    return "0" if abs(v) <= 1e-9 * abs(base or 0.0) else f"{v:+.4g}"


def _columns(rows: Sequence[tuple[str, ...]]) -> list[str]:
    """Rows as aligned text: the first column left, the numbers right, unit and name left."""
    w = [max(len(r[i]) for r in rows) for i in range(len(rows[0]))]
    out = []
    for r in rows:
        cells = [r[0].ljust(w[0])] + [r[i].rjust(w[i]) for i in (1, 2, 3)] + [r[4].ljust(w[4]), r[5]]
        out.append(("  " + "  ".join(cells)).rstrip())
    return out


def simulation(res: SimulateResult, base: tuple[str, Sequence[Change], Sequence[Change]] | None = None) -> str:
    """What ``simulate`` prints after the runs: the agreement table, the paper's RK4 against the
    tight solution, the loads, steady motion and video summaries, what the design does (beside
    a ``base`` design when given: :func:`design_table`), the files and the time taken."""
    k = res.kinematics
    out = [f"kinematic run: {crank_speed(k.speed)}, for {k.duration:.4g} s"]
    if res.dynamics is not None:
        d = res.dynamics
        out.append(f"dynamic run: {d.duration:g} s, final speed {crank_speed(d.omega_final_mujoco)}")
    out += [
        f"\nAgreement of MuJoCo with the vector-method reference ({res.mechanism}):",
        compare.table(list(res.agreements)),
    ]
    if res.dynamics is not None and res.dynamics.rk4 is not None:
        r = res.dynamics.rk4
        d = res.dynamics
        per_turn = (
            2.0 * math.pi * r.steps / (abs(d.omega_final_mujoco) * d.duration) if d.omega_final_mujoco else math.inf
        )
        out.append(
            f"fixed-step RK4 ({r.steps} steps, the paper's method) vs tight ODE: omega differs by up "
            f"to {r.omega_max_abs_diff:.3g} rad/s ({r.omega_max_rel_diff:.2%} of max), final "
            f"{r.omega_final_rel_diff:.2%}: the paper's constant moment has no steady state, the crank "
            f"speeds up to {crank_speed(d.omega_final_mujoco)}, where its {1e3 * d.duration / r.steps:.3g} ms "
            f"step is only {per_turn:.3g} steps per crank turn (docs/verification.md); the tight "
            "solution is the reference"
        )
    if res.timing is not None:
        out.append(timing_table(res.timing))
    if res.tension is not None:
        out.append(tension_line(res.tension))
    if res.loads is not None:
        L = res.loads
        out.append(
            f"driving torque at {crank_speed(L.speed)}: peak {L.torque_peak:.4g} N·m, RMS "
            f"{L.torque_rms:.4g} N·m, mean power {L.power_mean:.4g} W; MuJoCo vs kinetostatics: torque "
            f"{L.torque_error:.2e}, reactions {L.force_error:.2e} of range"
        )
        moment = "not compared (geared)" if L.shaking_moment_error is None else f"{L.shaking_moment_error:.2e} of range"
        out.append(
            f"loads on the frame (shaking.png): MuJoCo vs reference force {L.shaking_force_error:.2e}, moment {moment}"
        )
    if res.steady is not None:
        out.append(steady_line(res.steady))
    if res.video is not None:
        v = res.video
        out.append(f"video: {v.frames} frames at {v.fps} fps, slowed down {v.slowed_down_by:.1f}x ({v.backend})")
    if res.design is not None:
        out.append(design_table(res.design, base))
    out.append(f"outputs in {res.out_dir}/: {', '.join(res.files)}")
    out.append(f"total {res.timings.total:.2f} s")
    return "\n".join(out)


def _loads_heading(res: LoadsResult) -> str:
    L = res.loads
    return f"{res.mechanism} at {crank_speed(L.speed)}:"


def torque(res: LoadsResult) -> str:
    """What ``torque`` prints: the driving torque's peak and RMS, mean power, MuJoCo's error."""
    L = res.loads
    return "\n".join(
        [
            _loads_heading(res),
            f"  driving torque: peak {L.torque_peak:.5g} N·m, RMS {L.torque_rms:.5g} N·m, mean power {L.power_mean:.5g} W",
            f"  MuJoCo vs reference: max error {L.torque_error:.2e} of the torque range "
            f"(threshold {L.torque_threshold:g})",
            f"outputs in {res.out_dir}/",
        ]
    )


def reactions(res: LoadsResult) -> str:
    """What ``reactions`` prints: per pair the largest force (reference, MuJoCo) and MuJoCo's error."""
    L = res.loads
    out = [_loads_heading(res), f"  {'pair':<28} {'max |F| N':>10} {'MuJoCo N':>10} {'error/range':>12}"]
    for lab, p in L.pairs.items():
        extra = f"   moment max {p['max_moment_N_m']:.4g} N·m" if "max_moment_N_m" in p else ""
        out.append(
            f"  {lab:<28} {p['max_force_N']:>10.4g} {p['max_force_mujoco_N']:>10.4g} {p['error_rel']:>12.2e}{extra}"
        )
    out.append(f"  threshold {L.force_threshold:g} of each pair's largest force")
    out.append(f"outputs in {res.out_dir}/")
    return "\n".join(out)


def _share(ratio: float) -> str:
    """A ratio with its percentage: '0.0200 (2 %)'."""
    return f"{ratio:.4g} ({100 * ratio:.3g} %)"


def steady_line(s: SteadySummary) -> str:
    """Steady motion in one line: mean speed, delta without and with the flywheel, MuJoCo's."""
    return (
        f"steady motion: mean {crank_speed(s.omega_mean)}, speed fluctuation delta {_share(s.delta)} "
        f"(MuJoCo {s.delta_mujoco:.4f}); flywheel {s.flywheel:.4g} kg·m² gives delta {_share(s.delta_with_flywheel)} "
        f"(MuJoCo {s.delta_with_flywheel_mujoco:.4f}, target {s.target_delta:g}); "
        "delta = (w_max - w_min) / w_mean, a ratio"
    )


def steady(res: SteadyResult) -> str:
    """What ``steady`` prints."""
    return f"{steady_line(res.steady)}\noutputs in {res.out_dir}/"


def feed(res: FeedResult) -> str:
    """What ``feed`` prints: a row per speed, then the geometric stitch and, over a sweep, the
    first speed beyond the error limit."""
    plied = res.sweep.runs[0].ply_x.shape[1] > 1
    head = (
        f"{'speed':>11}  {'stitch':>9}  {'error':>7}  {'spread':>8}  {'foot off the fabric':>24}  "
        f"{'largest gap':>11}  {'spring load':>11}  {'slip on dog':>11}  {'foot force':>9}"
    ) + (f"  {'ply shift':>9}" if plied else "")
    rows = [
        f"the feed of {res.mechanism} under its presser foot (MuJoCo contacts, {res.stitches} stitches a speed)",
        head,
    ]
    for r in res.sweep.runs:
        deg, start = r.separation
        off = "never" if start is None else f"{deg:.0f} deg from {start:.0f} deg"
        rows.append(
            f"{r.speed_rpm:>7.0f} rpm  {to_mm(r.stitch):>6.3f} mm  {r.error * 100:>+6.2f}%  "
            f"{r.spread * 1e6:>5.1f} µm  {off:>24}  {to_mm(r.lift.max()):>8.3f} mm  "
            f"{r.load_factor:>10.3f}x  {r.slip * 1e6:>8.1f} µm  {r.foot_force.max():>7.1f} N"
            + (f"  {to_mm(r.shift):>+6.3f} mm" if plied else "")
        )
    first = res.sweep.runs[0]
    rows.append(
        f"stitch: the fabric's advance in the last stitch; error: against the dog's own advance with its teeth "
        f"above the plate, {to_mm(first.geometric):.4f} mm; spring load: the presser spring's largest push over "
        f"its {first.presser.preload:g} N preload (the dynamic load factor); foot force: the foot's largest push "
        f"on the fabric; the foot bounces on the fabric at {first.bounce_hz:.0f} Hz (closed form), what a "
        f"once-a-stitch push meets at {first.bounce_hz * 60:,.0f} rpm"
        + ("; ply shift: the top ply's advance less the bottom one's (negative: it lags)" if plied else "")
    )
    if len(res.sweep.runs) > 1:
        over = res.first_over
        rows.append(
            f"no speed of the sweep errs by more than {res.limit:.0%}"
            if over is None
            else f"the stitch first errs by more than {res.limit:.0%} at {over.speed_rpm:.0f} rpm ({over.error:+.2%})"
        )
    rows.append(
        "not modelled: each ply's own compression, the dog's teeth as teeth, the needle in the fabric, the operator's hold "
        "(docs/head.md, The fabric under the presser foot)"
    )
    if res.out_dir is not None:
        rows.append(f"outputs in {res.out_dir}/: {', '.join(res.files)}")
    return "\n".join(rows)


def synthesis(res: SynthResult) -> str:
    """What ``synth`` prints: the roots' table, the chosen design, the largest admissible lambda."""
    th = math.degrees(res.max_pressure_angle)
    b = res.best
    chosen = (
        "none admissible"
        if b is None
        else f"r = {to_mm(b.r.real):.4f} mm, l = {to_mm(b.l.real):.4f} mm, "
        f"theta_max = {math.degrees(b.theta_max):.2f} deg"
    )
    out = [res.table, f"\nchosen: {chosen}"]
    if res.largest_ratio is None or res.at_largest is None:
        out.append(f"no lambda in 0.01..0.99 gives an admissible design with [theta] = {th:g} deg")
    else:
        top = res.largest_ratio
        out.append(
            f"largest admissible lambda (step 0.01): {top:.2f} (theta_max "
            f"{math.degrees(res.at_largest.theta_max):.2f} deg)"
        )
        if res.beyond_largest is not None:
            out.append(
                f"  at lambda = {top + 0.01:.2f}: theta_max {math.degrees(res.beyond_largest.theta_max):.2f} deg > "
                f"{th:g} deg"
            )
    return "\n".join(out)


def _mm(x: tuple[float, float, float]) -> str:
    """'(12.345, -3.2, 0) mm' from metres: to 0.001 mm, as a saved design rounds."""

    def one(v: float) -> str:
        t = f"{v * 1e3:.3f}".rstrip("0").rstrip(".")
        return "0" if t in ("-0", "") else t

    return "(" + ", ".join(one(v) for v in x) + ") mm"


def format_report(r: validation.CheckReport, *, speed: float | None = None) -> str:
    """What ``check`` prints: the points, links, pairs, loops, gears, degrees of freedom,
    assembly and dead points of a file, its notes and problems (masses g, angles deg, lengths
    as the file gives them); with ``speed`` (rad/s, the file's [input] speed) its direction."""
    out = [f"{r.name}: {r.title}", f"file: {r.path}"]
    if speed is not None:
        out.append(f"input crank: {crank_speed(speed)} ([input] speed = {speed:g} rad/s)")
    out.append("")
    w = max([len(p.name) for p in r.points] + [4])
    wm = max(len(p.made_by) for p in r.points)
    moving = [p for p in r.points if not p.ground]
    where = {p.name: "at " + _mm(p.at) if p.at is not None else "not assembled" for p in moving}
    wa = max((len(v) for v in where.values()), default=0)
    out.append(
        f"points ({len(r.points) - len(moving)} ground, {len(moving)} moving"
        + ("; a moving one 'at' where it is at the input crank's setting)" if moving else ")")
    )
    for p in r.points:
        on = f"on {', '.join(p.links)}" if p.links else "on no link"
        if p.ground:
            out.append(f"  {p.name:<{w}}  ground  {p.made_by:<{wm}}  {on}")
        else:
            out.append(f"  {p.name:<{w}}  moving  {p.made_by:<{wm}}  {where[p.name]:<{wa}}  {on}")
    out.append("")
    out.append(f"links ({len(r.links)} moving)")
    wl = max([len(l.name) for l in r.links] + [4])
    for l in r.links:
        extra = []
        if l.mass > 0:
            extra.append(f"mass {l.mass / G:g} g at {l.com}, inertia {l.inertia:g} kg·m²")
        else:
            extra.append("massless")
        if l.guide:
            extra.append(f"slides along {l.guide[0]}-{l.guide[1]}")
        out.append(f"  {l.name:<{wl}}  points {', '.join(l.points)}; {'; '.join(extra)}")
    out.append("")
    out.append("kinematic pairs (as MuJoCo builds them: tree joints, loop-closing equalities)")
    if not r.pairs:
        out.append("  none could be formed (see problems)")
    for p in r.pairs:
        if p.kind == PairKind.REVOLUTE:
            assert p.point is not None  # a hinge is about a point, a slide along a guide
            where, joint = f"at {p.point}", names.hinge_joint(p.child, p.point)
        else:
            assert p.guide is not None
            where, joint = f"along {p.guide[0]}-{p.guide[1]}", names.slide_joint(p.child)
        role = {
            PairRole.JOINT: f"joint {joint}",
            PairRole.LOOP: "closes a loop: connect equality",
            PairRole.UNPLACED: "not placed",
        }[p.role]
        out.append(f"  {p.kind:<9} {where:<14} {p.parent + ' - ' + p.child:<{2 * wl + 3}}  {role}")
    loops = r.loops
    out.append(f"loops: {len(loops)}" + (f" (closed at {', '.join(str(p.point) for p in loops)})" if loops else ""))
    if r.gears:
        for g in r.gears:
            out.append(
                f"gear coupling: {g.link} ({g.point}) turns {g.ratio:g} times the input crank, "
                f"phase {math.degrees(g.phase):g} deg at phi0 (joint equality)"
            )
    else:
        out.append("gear couplings: none")
    m = r.mobility
    out.append(
        f"degrees of freedom: structural W = 3 n - 2 p = 3*{m.moving_links} - 2*{m.lower_pairs} = "
        f"{m.structural} ({m.revolute} revolute + {m.prismatic} prismatic pairs); with "
        f"{m.gears} gear coupling{'' if m.gears == 1 else 's'}: {m.driven}"
        + (" (the input crank's angle; none left once it is driven)" if m.driven == 1 else "  <-- must be 1")
    )
    out.append("")
    if r.full_turn:
        out.append(f"assembly: the input crank turns fully (over {r.period_deg:g} deg)")
    else:
        out.append(f"assembly: NOT over a full turn; assembles only for input angles {r.assembly_ranges or 'none'} deg")
        for a in r.angles:
            if not a.closes:
                out.append(f"  {a.kind} {a.label} cannot close for input angles {a.fails_deg} deg")
    out.append(
        f"dead points (limits: transmission angle {MIN_TRANSMISSION_DEG:g}.."
        f"{180 - MIN_TRANSMISSION_DEG:g} deg, pressure angle <= {MAX_PRESSURE_DEG:g} deg"
        + ("" if r.full_turn else "; where it assembles")
        + ")"
    )
    if not r.angles:
        out.append("  no dyad or slider")
    for a in r.angles:
        if math.isnan(a.worst_deg):
            out.append(f"  {a.kind} {a.label}: never assembles")
            continue
        verdict = ("ok" if a.ok else "TOO CLOSE") if r.full_turn else "(not judged: no full turn)"
        if a.kind == "dyad":
            out.append(
                f"  dyad {a.label:<22} transmission angle {a.worst_deg:7.2f} deg at input {a.phi_deg:6.1f} deg "
                f"({a.margin_deg:.2f} deg from the dead point)  {verdict}"
            )
        else:
            out.append(
                f"  slider {a.label:<20} pressure angle up to {a.worst_deg:5.2f} deg at input "
                f"{a.phi_deg:6.1f} deg ({a.margin_deg:.2f} deg from the dead point)  {verdict}"
            )
    if r.timing is not None:
        out.append(timing_table(r.timing))
    if r.thread:
        out.append("\nThe needle thread under tension ('python -m mjlink simulate' runs it):")
        out += [f"  {line}" for line in r.thread]
    if r.feed:
        out.append("\nThe feed under the presser foot ('python -m mjlink feed' runs it):")
        out += [f"  {line}" for line in r.feed]
    if r.notes:
        out.append("")
        out += [f"note: {n}" for n in r.notes]
    out.append("")
    missed = len(r.timing.failures()) if r.timing is not None else 0
    if missed and not r.problems:
        out.append(
            f"timing: {missed} window(s) missed (the general checks"
            + (f" and the {r.timing.target} settings" if r.timing and r.timing.target else "")
            + "): the head assembles and runs, but would not form its stitch as set"
        )
    if r.problems:
        out.append(f"problems ({len(r.problems)}):")
        out += [f"  - {msg}" for _, msg in r.problems]
        out.append("result: cannot be simulated faithfully as it stands")
    else:
        out.append("result: ok, ready for 'python -m mjlink simulate'")
    return "\n".join(out)


def optimization(res: OptimizeResult) -> str:
    """An optimization's summary: the winner, its metrics, the front, MuJoCo's verdict, files."""
    s = res.summary
    o = s["optimizer"]
    w = s["winner"]
    rb = s["robust"]
    lines = [
        f"study {s['study']} of {s['mechanism']}: {o['objective']}"
        + (f" (robust: mean + {rb['k']:g} std over {rb['samples']} tolerance samples)" if rb else "")
        + (f", subject to {', '.join(s['bounds'])}" if s["bounds"] else ""),
        f"differential evolution: {s['evaluations']} evaluations in {len(s['runs'])} run(s) of "
        f"{o['population']} per generation, random seed {o['seed']}; {s['engine']}",
    ]
    if s.get("conditions"):
        held = conditions_text(s["conditions"])
        lines.append(f"operating conditions, held at the file's values and deviated over the samples: {held}")
    conv = s["convergence"]
    if conv["converged"]:
        o = s["optimizer"]
        agree = f"; the {o['seeds']} independent runs agree" if o["seeds"] > 1 and not o["pareto"] else ""
        polish = f", then polished to {o['xtol']:g} of every range" if o["polish_evaluations"] else ""
        lines.append(f"converged: yes (every run settled{polish}{agree}; the criterion is in summary.json)")
    else:
        lines.append("converged: NO: " + "; ".join(conv["not_converged"]))
    if w["objective"] is not None:
        f = s["mechanism_file_design"]["objective"]
        was = f"{f:.6g}" if f is not None else "infeasible or out of bounds"
        lines.append(
            f"winner: objective {w['objective']:.8g} as written, rounded to "
            + ", ".join(f"{v:g} {u}" for u, v in s["optimizer"]["resolution"].items())
            + f" ({w['objective_unrounded']:.8g} unrounded; the mechanism file's design: {was})"
        )
    elif s["front"]:
        n = len(s["front"])
        lines.append(f"Pareto front: {n} design{'' if n == 1 else 's'}; winner: the knee ({s['optimizer']['knee']})")
    for p in s["parameters"]:
        lines.append(
            f"  {p['path']:<32} {p['winner']:>12.10g} {shown(p['unit']):<7} (file: {p['nominal']:.6g}, range {p['low']:g}..{p['high']:g})"
        )
    for c in s["caveats_text"]:
        lines.append(f"caveat: {c}")
    for c in s.get("findings_text", ()):
        lines.append(f"found: {c}")
    if s["rejected"]:
        n = len(s["rejected"])
        more = f" ({n} better candidates set aside in all: summary.json lists them)" if n > 1 else ""
        lines.append(f"set aside: the best candidate: {s['rejected'][0]['reason']}{more}")
    # The winner beside the mechanism file's own design; a robust winner's metrics are its
    # mean + k std under the tolerances, so its values without them are shown too.
    file_metrics = s["mechanism_file_design"]["metrics"]
    robust = s["robust"] is not None
    head = f"{'metric':<34} {'unit':>6} {'winner':>12}" + (f" {'no tolerances':>13}" if robust else "")
    lines.append(head + f" {'file design':>12}")
    for name, m in w["metrics"].items():
        row = f"{name:<34} {shown(m['unit']):>6} {m['value']:>12.6g}"
        if robust:
            row += f" {m['nominal_dimensions']:>13.6g}"
        fm = file_metrics.get(name)
        lines.append(row + (f" {fm:>12.6g}" if isinstance(fm, int | float) else f" {'-':>12}"))
    fly = s["flywheel"]
    if fly:
        lines.append(
            f"flywheel for a speed fluctuation delta = (w_max - w_min) / w_mean of {_share(fly['target_delta'])}: "
            f"{fly['inertia_kg_m2']:.4g} kg·m² on links.{fly['link']} "
            f"(delta {_share(fly['delta_without'])} without it, {fly['omega_mean_rad_s']:.4g} rad/s mean)"
        )
    designs = [w["mujoco"]] + [f["mujoco"] for f in (s["front"] or [])]
    agree = sum(d["passed"] for d in designs)
    worst = max(d["position_error_um"] for d in designs)
    lines.append(
        f"MuJoCo: {agree} of {len(designs)} designs agree (winner{' and front' if s['front'] else ''}); worst position error {worst:.3g} µm"
    )
    lines.append(
        f"wrote {res.out_dir}/ (winner.toml, {', '.join(p.name for p in res.files if p.name != 'winner.toml')}) in {s['timing_s']['total']:.1f} s"
    )
    rpm = s.get("objective_speed_rpm")
    at = f" {speed_option(rpm)}" if rpm is not None else ""  # its loads where they were optimized
    lines.append(f"next: python -m mjlink simulate {res.winner_file}{at}")
    return "\n".join(lines)


def study(res: StudyResult | OptimizeResult) -> str:
    """A study's summary: variants, feasibility, each metric's spread, MuJoCo's verdict, files."""
    if not hasattr(res, "outcome"):  # an [optimize] study
        return optimization(res)
    res = cast("StudyResult", res)
    s = res.summary
    lines = [
        f"study {s['study']} of {s['mechanism']}: {s['variants']} variants ({s['method']}"
        + (f", random seed {s['seed']}" if s["seed"] is not None else "")
        + f"), {s['angles_per_turn']} crank angles per turn; {s['engine']}",
        f"feasible: {s['feasible']} of {s['variants']}"
        + (f"; within the bounds ({', '.join(s['bounds'])}): {s['within_bounds']}" if s["bounds"] else ""),
    ]
    infeasible = [r for r in res.outcome.reason if r]
    if infeasible:
        lines.append(f"  e.g. {infeasible[0]}")
    lines.append(f"{'metric':<34} {'unit':>5} {'min':>11} {'p50':>11} {'max':>11} {'std':>11}")
    for name, m in s["metrics"].items():
        if not m.get("count"):
            lines.append(f"{name:<34} {shown(m['unit']):>5} {'(no feasible variant)':>47}")
            continue
        lines.append(
            f"{name:<34} {shown(m['unit']):>5} {m['min']:>11.6g} {m['p50']:>11.6g} {m['max']:>11.6g} {m['std']:>11.4g}"
        )
    if s.get("sensitivity"):
        lines.append("most sensitive parameters (share of the metric's variance, from a linear fit):")
        for name, sv in s["sensitivity"].items():
            ranked = ", ".join(f"{r['parameter']} {r['share']:.0%}" for r in sv["ranked"][:3] if r["share"] >= 0.005)
            lines.append(f"  {name:<32} {ranked} (fit R^2 {sv['r2']:.2f})")
    mj = s["mujoco"]
    if mj["verified"]:
        w, t = mj["worst_um"], mj["thresholds_um"]
        worst = ", ".join(
            f"{k.replace('_', ' ')} {w[k]:.3g} µm (<= {t[k]:g})"
            for k in ("position_error", "loop_gap", "thread_error")
            if w.get(k) is not None and math.isfinite(w[k])
        )
        lines.append(f"MuJoCo ({mj['verify']}): {mj['passed']} of {mj['verified']} variants agree; worst {worst}")
    else:
        lines.append("MuJoCo: no variant verified ([verify] mujoco = 'none')")
    if s["resumed_chunks"]:
        lines.append(f"resumed: {s['resumed_chunks']} finished chunks taken from the previous run")
    lines.append(f"wrote {res.out_dir}/ ({', '.join(p.name for p in res.files)}) in {s['timing_s']['total']:.1f} s")
    return "\n".join(lines)


def timing_table(head: HeadTiming) -> str:
    """A head's timing checks, one row each: value, window, result; the target maker's and the
    general rows decide the run, the other makers' are shown for comparison."""
    built = f"built to '{head.target}'" if head.target else "no maker's settings: the general checks"
    rows = [f"\nTiming over one stitch (main-shaft angle from {head.origin}; {built}):"]
    # A settings table is named by its machine's model: the column as wide as the longest name.
    w = max([len("settings"), *(len(r.maker or "every head") for r in head.rows)])
    wl = max([len("check"), *(len(r.label) for r in head.rows)])
    if head.rows:
        rows.append(f"{'settings':{w}s} {'check':{wl}s} {'measured':>9s} {'window':>17s} unit  result")
    else:
        rows.append("no check applies to the parts [timing] names (docs/head.md, The timing table)")
    for r in head.rows:
        rows.append(
            f"{r.maker or 'every head':{w}s} {r.label:{wl}s} {r.shown(r.value):>9s} {r.window_text():>17s} {shown(r.unit):4s}  {r.verdict}"
        )
    rows.append("events (deg): " + ", ".join(f"{k} {v:.1f}" for k, v in head.events.items() if k != "needle bar top"))
    if head.values:
        rows.append("measured: " + ", ".join(f"{k} {v:.4g} {u}" for k, (v, u) in head.values.items()))
    return "\n".join(rows)


def tension_line(t: NeedleTension) -> str:
    """A lockstitch head's needle thread under tension, in three lines: the peak against the
    breaking load, the thread a stitch draws through the discs, the check spring's travel, and
    the take-up's pull on the stitch against the bobbin thread's tension."""
    zone, at = t.peak_at
    return (
        f"needle thread tension (thread_tension.png): peak {t.peak:.3g} N ({t.peak / GF:.0f} gf) in {zone} at "
        f"{at:.1f} deg, breaking load {t.breaking_load:.3g} N (margin {t.margin:.3g}); discs' hold {t.hold:.3g} N\n"
        f"  a stitch draws {t.per_stitch / MM:.3f} mm through the discs (stitch formula {t.formula / MM:.2f} mm); "
        f"check spring travel up to {float(t.spring.max()) / MM:.2f} mm; below the eye slack for "
        f"{float(t.slack.mean()) * 360.0:.0f} deg of the stitch" + t.repeats + "\n"
        f"  the take-up sets the stitch pulling it with up to {t.set_pull:.3g} N ({t.set_pull / GF:.0f} gf), "
        f"{t.drawn_up:.3g} times the bobbin thread's {t.bobbin:.3g} N"
        + ("" if t.drawn_up >= 1.0 else ": too little to draw the bobbin thread and the interlacing up")
    )
