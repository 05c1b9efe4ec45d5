"""What a study will cost, estimated before it runs: variants, MuJoCo steps, memory and time.

The estimate comes from a short calibration on this machine (a few variants of the study's own
mechanism and metrics evaluated in this process, timed, their peak memory traced), scaled to
the study's size:

* MuJoCo steps: every verified model's, counted by the function the verification steps it with
  (:func:`mjlink.sim.steps.verify_steps`: one period at the variant's own speed, on the clock
  scaled above the verified speed), over the speeds the variants take (:func:`clock`);
* time: variant-angles x the measured seconds per variant-angle, shared by the workers; MuJoCo
  models x their steps at the measured rate (a calibration run of one model where the study
  verifies more than a few), or at :data:`MUJOCO_STEPS_PER_S` where it verifies a handful;
  an optimization's between its whole budget and its runs on a smooth bowl (:mod:`.settle`),
  the estimate their geometric mean, or, where these lie far apart, its first run rehearsed
  on a coarser grid, every run taken to need as many evaluations (or, unsettled after more
  generations than its stall test waits, its whole budget);
* memory: the largest of (a) the tasks running at once, each its rows x the measured peak bytes
  per variant-angle or a MuJoCo chunk's recorded sensor values (its longest model's steps) and
  one model's comparison with the reference, (b) what this process holds: the variants' values
  and metric columns, the results table as it is written (about :data:`TABLE_BYTES_PER_VALUE`
  per value), an optimization's archive of every candidate, and a task run here; plus
  :data:`PROCESS_BYTES` for this process and each worker.

A study whose memory estimate exceeds the bound (:func:`memory_limit`: three quarters of the
memory this machine has available now, or the user's ``--max-memory``) is refused before it
starts, with one line naming the estimate, the bound and what to change.
"""

from __future__ import annotations

import dataclasses
import math
import os
import time
import tracemalloc
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..analysis.metric_base import probing
from ..errors import InputError
from ..reference.batch import angle_grid
from ..sim import steps as _steps  # the clock alone: no MuJoCo is imported
from .engine import MUJOCO_CHUNK, REFERENCE_CHUNK, chunks, reference_chunks
from .optimize import CHUNK_ROWS, budget, needed
from .polish import batch_size as polish_batch
from .search import first_generation
from .settle import WIDE, Rehearsed, Settled, on_bowl, rehearse
from .spec import Study
from .tasks import mujoco_chunk, reference_chunk

MUJOCO_STEPS_PER_S = 60_000.0  # RK4 steps per second per core the plan assumes (bench/bench_study.py)
MUJOCO_BUILD_S = 0.03  # seconds the plan assumes to build and compile one model
TABLE_BYTES_PER_VALUE = 120.0  # a results table's value as Python objects and CSV text while written
# A verified model's comparison with the reference holds the reference's solution at every step:
# about this many bytes per point and step (tests/test_study_plan.py holds the memory bound to
# the traced peak of a run).
JUDGE_BYTES_PER_POINT = 160.0
PROCESS_BYTES = 2.0**27  # an interpreter with numpy, MuJoCo and mjlink loaded
CLOCK_SPEEDS = 1024  # speeds of a sampled study's variants the steps are counted at, at most
CLUSTER_START_S = 2.0  # a local Dask cluster's start
# An optimization's generation below this much work runs faster in this process than on a
# local cluster, whose every call makes a round trip and whose polish runs here anyway
# (bench/bench_optimize.py compares the two).
SMALL_GENERATION_S = 0.1
CALIBRATION_VARIANTS = 16
# The calibration evaluates as many variants as a task does, up to this many variant-angles:
# a call's own cost is spread over its rows, so a batch smaller than the tasks' overstates the
# cost per row (most where a study has few angles).
CALIBRATION_ROWS = 4096
CALIBRATION_RUNS = 3
# CPU seconds the calibration's batches may take together (traced once, timed up to
# CALIBRATION_RUNS times): a study whose variants each cost much (a head's thread under tension,
# stepped to its periodic state) calibrates on as few of them as fit, at least one, traced once
# and timed once, rather than spend on the estimate a good part of what the study itself costs.
CALIBRATION_SECONDS = 2.0
# How many times longer a call takes traced by tracemalloc than not, at most (a thread's
# tension, stepped in plain floats, every float an allocation traced; array code much less).
TRACING = 15.0
# A call whose tracing would take longer than this (CPU s: TRACING times its cost) is not traced:
# the growth of the process's resident peak over the first call measures its memory instead,
# where the system tells it (Linux). It misses what the call reuses of memory the process
# already held, so it may read lower than tracing would: taken only where tracing would hold
# a dry run up for long.
TRACED_MOST = 20.0


class PlanError(InputError):
    """A study refused before it starts (too large for this machine): exit status 2."""


@dataclass(frozen=True, kw_only=True)
class Plan:
    """The size and cost of a study (see the module docstring).

    ``variants`` reference evaluations (an optimization: at most, its whole budget; about
    ``expected_variants``), each over ``angles`` crank angles, in ``tasks`` tasks on ``workers``
    workers; ``mujoco_models`` and ``mujoco_steps``; ``memory`` bytes (an optimization's whole
    budget) and its bound ``memory_limit``; ``seconds`` wall, the estimate, between
    ``seconds_least`` and ``seconds_most`` (an optimization: its runs settling as on a smooth
    bowl or, where it was ``rehearsal``-ed, as its first run did or later, and its whole
    budget, :mod:`.settle`; a sampled study: all three the same);
    ``row_seconds`` and ``row_bytes`` the calibration's CPU seconds and peak bytes per
    variant-angle; ``what`` the study's shape in words.
    """

    study: str
    what: str
    variants: int
    angles: int
    tasks: int
    workers: int
    mujoco_models: int
    mujoco_steps: int
    memory: float
    memory_limit: float
    seconds: float
    seconds_least: float
    seconds_most: float
    expected_variants: int
    row_seconds: float
    row_bytes: float
    mujoco_model_seconds: float
    calibration: Calibration | None = None
    bowl: Settled | None = None
    rehearsal: Rehearsed | None = None
    least_rehearsed: bool = False

    def describe(self) -> str:
        """The plan as one line."""
        mj = (
            f"MuJoCo {self.mujoco_models:,} model(s), {self.mujoco_steps:,} steps"
            if self.mujoco_models
            else "no MuJoCo verification"
        )
        return (
            f"plan: {self.what}: {self.variants:,} variants x {self.angles} crank angles in {self.tasks:,} task(s) "
            f"{f'on {self.workers} worker(s)' if self.workers else 'in this process'}; {mj}; memory about {size_text(self.memory)} (bound {size_text(self.memory_limit)}); "
            f"time about {duration_text(self.seconds)}{self._bracket()}; calibrated here: {self.row_seconds * 1e6:.2g} µs and "
            f"{self.row_bytes:.0f} bytes per variant-angle"
        )

    def _bracket(self) -> str:
        if self.bowl is not None and not self.bowl.complete:
            return " for its whole budget (too large a search to try on a smooth bowl first)"
        if self.seconds_most <= self.seconds_least:
            return ""
        r = self.rehearsal
        least = f"{duration_text(self.seconds_least)} if every run settles as on a smooth bowl"
        if r is not None:
            done = f"its first run, rehearsed on {r.angles} crank angles, {{}} {r.search + r.polish:,} evaluations"
            if r.complete:
                least = done.format("settled in")
            elif self.least_rehearsed:
                least = f"at least {duration_text(self.seconds_least)}: {done.format('had not settled after')}"
            else:
                least += f"; {done.format('had not settled after')}"
        return (
            f" for about {self.expected_variants:,} variants ({least}; "
            f"at most {duration_text(self.seconds_most)} for the whole budget)"
        )

    def check(self) -> None:
        """Refuse (PlanError, one line) a study whose memory estimate exceeds the bound."""
        if self.memory > self.memory_limit:
            raise PlanError(
                f"{self.study}: the study would need about {size_text(self.memory)} of memory ({self.what}), more than "
                f"the {size_text(self.memory_limit)} this machine can give it; make it smaller (fewer samples, a "
                "smaller population or fewer [robust] samples, fewer angles), or give --max-memory to run it anyway"
            )


def size_text(n: float) -> str:
    """Bytes as '74.5 GiB'."""
    for unit, f in (("TiB", 2.0**40), ("GiB", 2.0**30), ("MiB", 2.0**20), ("KiB", 2.0**10)):
        if n >= f:
            return f"{n / f:.3g} {unit}"
    return f"{n:.0f} bytes"


def duration_text(s: float) -> str:
    """Seconds as '45 s', '12 min', '3.2 h', '9.1 days'."""
    if not math.isfinite(s):
        return "forever"
    if s < 90:
        return f"{s:.2g} s"
    if s < 5400:
        return f"{s / 60:.2g} min"
    if s < 48 * 3600:
        return f"{s / 3600:.2g} h"
    return f"{s / 86400:.3g} days"


def memory_limit() -> float:
    """Three quarters of the memory available now (Linux ``MemAvailable``; elsewhere half the
    physical memory), bytes."""
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return 0.75 * float(line.split()[1]) * 1024
    except OSError:
        pass
    try:
        return 0.5 * os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (OSError, ValueError, AttributeError):
        return 8.0 * 2**30


@dataclass(frozen=True)
class Calibration:
    """CPU seconds and peak traced bytes per variant-angle of the reference on this machine,
    and MuJoCo's CPU seconds per verified model (NaN where not measured) of ``model_steps``
    steps (0: at the file's speed); an optimization's polish's CPU seconds per variant-angle,
    in its smaller batches (NaN: as ``row_seconds``); ``variants`` the timed batch's."""

    row_seconds: float
    row_bytes: float
    model_seconds: float
    model_steps: int = 0
    polish_row_seconds: float = math.nan
    variants: int = 1  # in the timed batch


def calibrate(study: Study, *, mujoco: bool = False) -> Calibration:
    """Evaluate as many variants of ``study`` as one of its tasks does (at least
    :data:`CALIBRATION_VARIANTS`, at most :data:`CALIBRATION_ROWS` variant-angles, and no more
    than fit, traced once and timed, in :data:`CALIBRATION_SECONDS` by the first variant's
    cost) here: the first call at the nominal values (an optimization's nominal design, the
    middle of its ranges where it has none), then a sampled study's own variants spread over
    them, or an optimization's first generation. Timed (the fastest of
    :data:`CALIBRATION_RUNS` where they fit, else one; a variant that alone costs more than
    the budget by its first call), then traced once, on as many of them as fit in the budget
    at :data:`TRACING` times that cost; with ``mujoco``, verify one in MuJoCo, timed."""
    angles = len(angle_grid(study.mechanism, study.per_turn))
    per_task = budget(study).per_generation if study.optimize is not None else min(study.samples, REFERENCE_CHUNK[1])
    n = max(CALIBRATION_VARIANTS, min(per_task, CALIBRATION_ROWS // angles))
    if study.optimize is not None:  # what its search computes (the other metrics: a few designs at the end)
        study = dataclasses.replace(study, metrics=needed(study))
    if study.method == "optimize":
        row = [
            min(max(v.param.nominal, v.low), v.high) if math.isfinite(v.param.nominal) else 0.5 * (v.low + v.high)
            for v in study.varied
        ]
    else:
        row = [v.param.nominal if math.isfinite(v.param.nominal) else 0.0 for v in study.varied]
    values = np.tile(np.array(row, dtype=float), (n, 1))
    # A sampled study's first call (which sizes the batch) at its nominal values, then its own
    # variants spread over them: copies of one would be measured once by a metric that measures
    # a head once for variants of one geometry and thread balance.
    own = study.values() if study.method != "optimize" else None
    if own is not None:
        n = min(n, len(own))
    if study.optimize is not None:
        # After the nominal design (whose cost sizes the batch), the candidates the search
        # evaluates first: distinct designs, as the search's are. Copies of one would be
        # measured once by a metric that measures a head once for variants of one geometry
        # (mjlink.analysis.timing), and timed at next to nothing.
        values[1:] = first_generation(study, study.optimize.seed, n - 1)
    resident = _resident()
    t = time.process_time()
    reference_chunk(study, values[:1])  # the nominal batch and first-call costs, not timed
    first = time.process_time() - t
    grown = None if resident is None else max(0, _resident_peak() - resident)
    # The first call's cost bounds a variant's from above: it holds the first call's own too.
    # A variant that alone costs more than the whole budget is timed by that first call.
    runs = CALIBRATION_RUNS if first * n * (1 + CALIBRATION_RUNS) <= CALIBRATION_SECONDS else 1
    if first > CALIBRATION_SECONDS:
        n, runs = 1, 0
    elif first * n * (1 + runs) > CALIBRATION_SECONDS:
        n = max(1, int(CALIBRATION_SECONDS / (first * (1 + runs))))
    values = values[:n] if own is None else own[_spread(len(own), n)]
    # Timed without the tracing (which slows every allocation), the fastest of a few: a single
    # short run on a shared machine is as often slowed by a neighbour as it is representative.
    seconds = _fastest(lambda: reference_chunk(study, values), runs) if runs else first
    # Traced once, on as many of them as the budget allows at the tracing's cost (at least
    # one): the memory a row needs, the call's own shared by fewer rows, can only come out
    # larger.
    traced = n if not runs else max(1, min(n, int(n * CALIBRATION_SECONDS / (TRACING * seconds))))
    if grown is not None and TRACING * first > TRACED_MOST:
        # A costly variant: the first call's growth of the resident peak (TRACED_MOST says
        # what it may miss), not another call traced at many times its cost.
        peak, traced = grown, 1
    else:
        tracemalloc.start()
        try:
            with probing():
                reference_chunk(study, values[:traced])
            peak = tracemalloc.get_traced_memory()[1]
        finally:
            tracemalloc.stop()
    polish = math.nan
    m = polish_batch(len(study.varied)) * budget(study).samples if study.optimize is not None else 0
    if study.optimize is not None and budget(study).polish and m * angles <= CALIBRATION_ROWS:
        # The polish evaluates a generation of its own at a time, in this process: a batch
        # small enough that a call's own cost counts (a larger one costs what the search's do).
        batch = first_generation(study, study.optimize.seed, m)
        polish = _fastest(lambda: reference_chunk(study, batch)) / (m * angles)
    rows = n * angles
    model, model_steps = math.nan, 0
    if mujoco:
        t = time.process_time()  # CPU: one thread's, which a busy machine does not inflate
        mujoco_chunk(study, values[:1], threads=1)
        model = time.process_time() - t
        speed = next(
            (x * p.scale for x, p in zip(row, study.params, strict=True) if p.path == "input.speed"),
            study.mechanism.speed,
        )
        model_steps = _steps.verify_steps(study.mechanism.period, speed)
    return Calibration(seconds / rows, peak / (traced * angles), model, model_steps, polish, n)


def _resident() -> int | None:
    """Bytes of this process resident in memory now, None where the system does not say
    (not Linux)."""
    try:
        with open("/proc/self/statm") as f:
            return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")
    except (OSError, ValueError, IndexError):
        return None


def _resident_peak() -> int:
    """Bytes: the most this process has held resident so far (Linux counts it in KiB)."""
    import resource  # here: Unix only, and only where _resident found Linux's figure

    return int(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss) * 1024


def _in_tasks(study: Study, cal: Calibration, variants: int) -> float:
    """CPU seconds per variant-angle in tasks of ``variants`` variants: the calibration's, scaled
    where a metric's batches cost less per variant the larger they are (``Metric.share``: a
    head's thread stepped among hundreds costs a fifth of one stepped alone), from the
    calibration's batch to the task's. That metric's scale is taken for the whole row: it
    costs the most."""
    f = min((m.share(max(1, variants)) / m.share(cal.variants) for m in study.metrics), default=1.0)
    return cal.row_seconds * f


def _spread(V: int, n: int) -> np.ndarray:
    """(n,) indices of ``n`` of ``V`` variants spread evenly over them, the middle of each
    n-th share (one: the middle variant)."""
    out: np.ndarray = ((np.arange(n) + 0.5) * V / n).astype(int)
    return out


def _fastest(f: Callable[[], object], runs: int = CALIBRATION_RUNS) -> float:
    """The least CPU seconds of ``runs`` calls of ``f``."""
    best = math.inf
    for _ in range(runs):
        t = time.process_time()
        f()
        best = min(best, time.process_time() - t)
    return best


@dataclass(frozen=True)
class Clock:
    """MuJoCo steps of the models a study verifies (:func:`clock`): ``most`` the longest
    model's, ``mean`` their mean over the variants (the verified ones are chosen among them)."""

    most: int
    mean: float


def clock(study: Study) -> Clock:
    """The steps of every model ``study`` may verify, each counted as the verification steps it
    (:func:`mjlink.sim.steps.verify_steps`) at the variant's own crank speed.

    Only ``input.speed`` changes a variant's clock. A grid's variants take each of its values
    equally often; a random or tolerance study's are drawn (the study's own, seeded, samples:
    at most :data:`CLOCK_SPEEDS` of them counted, evenly spread by speed, the slowest always);
    an optimization verifies designs anywhere in the range (the steps of its slower end)."""
    mech = study.mechanism
    j = next((i for i, p in enumerate(study.params) if p.path == "input.speed"), None)
    if j is None:
        s = _steps.verify_steps(mech.period, mech.speed)
        return Clock(s, float(s))
    v = study.varied[j]
    si = v.param.scale  # file units to rad/s
    if study.method == "grid":
        speeds = np.asarray(v.values, dtype=float)
    elif study.method == "optimize":
        speeds = np.array([v.low, v.high])
        slow = speeds[np.argmin(np.abs(speeds))]
        s = _steps.verify_steps(mech.period, float(slow) * si)
        return Clock(s, float(s))
    else:
        col = study.values()[:, j]
        order = np.argsort(np.abs(col), kind="stable")
        speeds = col[order[np.unique(np.linspace(0, len(col) - 1, min(len(col), CLOCK_SPEEDS)).round().astype(int))]]
    counts = [_steps.verify_steps(mech.period, float(w) * si) for w in speeds]
    return Clock(max(counts), float(np.mean(counts)))


def mujoco_bytes(study: Study, models: int, steps: int) -> float:
    """Peak bytes of one MuJoCo task of ``models`` models of at most ``steps`` steps each: the
    sensor values rollout records for all of them (:func:`mjlink.sim.steps.verify_values` per
    step), the external forces it applies to them (a file with point forces), and one model's
    comparison with the reference (:data:`JUDGE_BYTES_PER_POINT`)."""
    mech = study.mechanism
    per_step = _steps.verify_values(mech) + (6 * (len(mech.links) + 1) if mech.dynamics.forces else 0)
    return models * steps * per_step * 8.0 + (steps * JUDGE_BYTES_PER_POINT * len(mech.point_names) if models else 0)


def estimate(
    study: Study,
    *,
    workers: int,
    limit: float | None = None,
    calibration: Calibration | None = None,
    cluster: bool = False,
    bowl: Settled | None = None,
    rehearsal: Rehearsed | None = None,
) -> Plan:
    """The :class:`Plan` of ``study`` on ``workers`` worker processes (0: this process), its
    memory held to ``limit`` bytes (default :func:`memory_limit`); ``cluster``: a local
    cluster is started for it; ``calibration``, ``bowl`` (an optimization's runs on the bowl,
    :mod:`.settle`) and ``rehearsal`` (its first run rehearsed, where the bowl and the whole
    budget lie more than :data:`~.settle.WIDE` apart) those of an earlier plan of the same
    study, not made again."""
    mech = study.mechanism
    angles = len(angle_grid(mech, study.per_turn))
    P, C = len(study.varied), len(study.columns)
    lanes = max(1, workers)
    client = 0.0
    raised = False  # an optimization's least set by its rehearsal cut short, not by the bowl
    if study.optimize is None:
        V = study.samples
        cut = reference_chunks(study, V, max(1, workers))
        tasks = len(cut)
        task_rows = max((b - a for a, b in cut), default=1) * angles
        models = {"none": 0, "all": V, "best": min(study.count, V), "worst": min(study.count, V)}[study.verify]
        mj_chunks = chunks(models, MUJOCO_CHUNK, parts=8)
        mj_chunk, mj_tasks = max((b - a for a, b in mj_chunks), default=0), len(mj_chunks)
        client = V * ((P + C) * 8.0 * 3 + (P + C + 6) * TABLE_BYTES_PER_VALUE + 120.0)
        what = f"{study.method} study of {V:,} variants"
    else:
        b = budget(study)
        V = b.evaluations
        per_gen = b.per_generation
        tasks = b.generations * max(1, math.ceil(per_gen * angles / CHUNK_ROWS))
        task_rows = min(per_gen * angles, CHUNK_ROWS)
        # The variants a generation's task holds: the engine cuts it into equal chunks, a
        # multiple of the workers in number (Evaluator.rows).
        cap = max(1, CHUNK_ROWS // angles)
        task_variants = -(-per_gen // (lanes * max(1, -(-per_gen // (lanes * cap)))))
        models = b.verified
        mj_chunk = mj_tasks = 1  # the winner and each design of a front are verified one at a time
        # A generation's rows (values, metrics), the archive of every candidate (values, metrics,
        # objective, violation, reason) and its table as it is written.
        client = per_gen * (P + C) * 8.0 * 4 + b.candidates * ((P + C + 4) * (8.0 * 2 + TABLE_BYTES_PER_VALUE) + 120.0)
        what = b.describe()
    steps = clock(study) if models else Clock(0, 0.0)
    cal = calibration or calibrate(study, mujoco=models > 4)
    mj_bytes = mujoco_bytes(study, mj_chunk, steps.most)
    if study.optimize is None:  # the MuJoCo tasks run where the reference's did, after them
        task_bytes = max(task_rows * cal.row_bytes, mj_bytes)
        at_once = max(min(lanes, tasks) * task_rows * cal.row_bytes, min(lanes, mj_tasks) * mj_bytes)
        memory = max(at_once, client + (0 if workers else task_bytes))
    else:  # the designs are verified here, after the search
        task_bytes = task_rows * cal.row_bytes
        memory = max(lanes * task_bytes, client + (0 if workers else task_bytes), client + mj_bytes)
    memory += PROCESS_BYTES * (1 + workers)
    # A model's seconds: building it and its steps (the calibration's model scales the rule to
    # this machine).
    measured = cal.model_steps or _steps.verify_steps(mech.period, mech.speed)
    scale = (
        cal.model_seconds / (MUJOCO_BUILD_S + measured / MUJOCO_STEPS_PER_S)
        if math.isfinite(cal.model_seconds)
        else 1.0
    )
    model_s = scale * (MUJOCO_BUILD_S + steps.mean / MUJOCO_STEPS_PER_S)
    # MuJoCo's models run side by side: a task per worker, or in this process on rollout's
    # threads (one per core); an optimization verifies its designs one by one.
    if study.optimize is not None:
        side = mj_tasks
    else:
        side = min(lanes, mj_tasks) if workers else min(os.cpu_count() or 1, models)
    if study.optimize is None:
        row_s = polish_s = _in_tasks(study, cal, task_rows // angles)
    else:
        row_s = _in_tasks(study, cal, task_variants)
        # The polish's batches: timed on their own size where the calibration could, else
        # scaled like the search's to theirs.
        polish_s = cal.polish_row_seconds
        if math.isnan(polish_s):
            polish_s = _in_tasks(study, cal, polish_batch(P) * budget(study).samples)

    def seconds_of(searched: float, polished: float) -> float:
        """Wall seconds for ``searched`` variants of the engine's batches and ``polished`` of the
        polish's, run here one generation after another, then the MuJoCo models."""
        s = (
            searched * angles * row_s * 1.2 / min(lanes, max(1, tasks))
            + polished * angles * polish_s * 1.2
            + models * model_s / max(1, side)
        )
        return s + (CLUSTER_START_S if cluster else 0.0)

    if study.optimize is None:
        seconds = seconds_of(V, 0.0)
        least = most = seconds
        expected = V
    else:  # between a run that never settles and one on a smooth bowl (module docstring)
        b = budget(study)
        most_search, most_polish = b.runs * b.population * (b.generations + 1), b.runs * b.polish
        bowl = bowl or on_bowl(study)
        low_search, low_polish = (
            (min(bowl.search, most_search), min(bowl.polish, most_polish))
            if bowl.complete
            else (most_search, most_polish)
        )
        R, lam = b.samples, polish_batch(P)

        def run_seconds(searched: float, polished: float) -> float:
            # The reference's rows, and the runs' own work per batch (measured on the bowl).
            batches = searched / b.population + polished / lam
            return seconds_of(searched * R, polished * R) + batches * bowl.batch_seconds

        most = run_seconds(most_search, most_polish)
        if rehearsal is None and bowl.complete and most > WIDE * run_seconds(low_search, low_polish):
            rehearsal = rehearse(study, cal.row_seconds)
        mid_search, mid_polish = math.sqrt(low_search * most_search), math.sqrt(low_polish * most_polish)
        if rehearsal is not None:  # every run as long as the rehearsed one, or longer than it was seen
            seen_search = min(b.runs * rehearsal.search, most_search)
            seen_polish = min(b.runs * rehearsal.polish, most_polish)
            if rehearsal.complete:
                mid_search, mid_polish = seen_search, seen_polish
                low_search, low_polish = min(low_search, seen_search), min(low_polish, seen_polish)
            else:
                raised = seen_search + seen_polish > low_search + low_polish
                low_search, low_polish = max(low_search, seen_search), max(low_polish, seen_polish)
                if rehearsal.search >= b.population * study.optimize.stall:
                    # Still improving after more generations than the stall test waits: the
                    # run goes on as long as the objective gives, planned to its whole budget.
                    mid_search, mid_polish = most_search, most_polish
                else:  # too few generations seen to tell: between the raised least and the budget
                    mid_search, mid_polish = math.sqrt(low_search * most_search), math.sqrt(low_polish * most_polish)
        seconds = run_seconds(mid_search, mid_polish)
        least = run_seconds(low_search, low_polish)
        expected = round((mid_search + mid_polish) * R)
    return Plan(
        study=study.name,
        what=what,
        variants=V,
        angles=angles,
        tasks=tasks,
        workers=workers,
        mujoco_models=models,
        mujoco_steps=round(models * steps.mean),
        memory=memory,
        memory_limit=memory_limit() if limit is None else limit,
        seconds=seconds,
        seconds_least=least,
        seconds_most=most,
        expected_variants=expected,
        row_seconds=cal.row_seconds,
        row_bytes=cal.row_bytes,
        mujoco_model_seconds=model_s,
        calibration=cal,
        bowl=bowl,
        rehearsal=rehearsal,
        least_rehearsed=raised,
    )


def small(p: Plan, study: Study) -> bool:
    """Whether ``study`` runs faster in this process than on a local cluster: a sampled study
    whose work is shorter than the cluster's start, an optimization whose generations are each
    less than :data:`SMALL_GENERATION_S` of work."""
    if study.optimize is None:
        return p.variants * p.angles * p.row_seconds + p.mujoco_models * p.mujoco_model_seconds < CLUSTER_START_S
    return budget(study).per_generation * p.angles * p.row_seconds < SMALL_GENERATION_S
