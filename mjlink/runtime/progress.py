"""A study's progress on stderr: a bar on a terminal, a plain line at a steady pace elsewhere.

On a terminal: tqdm's bar per stage (variants, rate, time left), as before. Without one (CI, a
log file, ``nohup``) a bar's carriage returns are noise, and a bar that moves only when a chunk
ends may stay silent for minutes: a line is printed every :data:`EVERY_S` seconds, from a
thread of its own whatever the work is doing, with what is done, the rate and the time left
(``MJLINK_PROGRESS_SECONDS`` sets another interval), and one when a stage or run ends.
"""

from __future__ import annotations

import math
import os
import sys
import threading
import time
from collections.abc import Callable
from typing import Any, TextIO

EVERY_S = 10.0


def _interval() -> float:
    try:
        v = float(os.environ.get("MJLINK_PROGRESS_SECONDS", EVERY_S))
    except ValueError:
        return EVERY_S
    return v if math.isfinite(v) and v > 0 else EVERY_S


def _left(done: float, total: float, elapsed: float) -> str:
    if done <= 0 or total <= done:
        return ""
    s = elapsed / done * (total - done)
    return f", about {s:.0f} s left" if s < 90 else f", about {s / 60:.0f} min left"


class Lines:
    """Progress as plain lines (no terminal): :meth:`update` records, a thread prints.

    ``unit`` names what is counted ('variants', 'generations')."""

    def __init__(self, label: str, unit: str, stream: TextIO | None = None, every: float | None = None):
        self.label, self.unit = label, unit
        self.stream = stream or sys.stderr
        self.every = every or _interval()
        self.state: dict[str, Any] = {}
        self.t0 = time.monotonic()
        self.stop = threading.Event()
        self.lock = threading.Lock()
        self.thread = threading.Thread(target=self._loop, name="mjlink-progress", daemon=True)
        self.thread.start()

    def update(self, stage: str, done: float, total: float, extra: str = "") -> None:
        """Record a stage's progress; a stage that ends (another begins) gets its last line."""
        with self.lock:
            ended = self.state.get("stage") not in (None, stage) and "done" in self.state
        if ended:
            self._print()
        with self.lock:
            if self.state.get("stage") != stage:  # what was done before (resumed) is not this run's rate
                self.state = {"stage": stage, "start": time.monotonic(), "first": done}
            self.state.update(done=done, total=total, extra=extra)

    def _line(self) -> str | None:
        with self.lock:
            st = dict(self.state)
        if not st or "done" not in st:
            return None
        done, total = st["done"], st["total"]
        elapsed = max(time.monotonic() - st["start"], 1e-9)
        pct = f" ({done / total:.1%})" if total else ""
        rate = (done - st["first"]) / elapsed
        extra = f"; {st['extra']}" if st.get("extra") else ""
        return (
            f"mjlink: {self.label}: {st['stage']} {done:,.0f} of {total:,.0f} {self.unit}{pct}, "
            f"{rate:,.1f} {self.unit}/s{_left(done - st['first'], total - st['first'], elapsed)}{extra}"
        )

    def _print(self) -> None:
        line = self._line()
        if line:
            print(line, file=self.stream, flush=True)

    def _loop(self) -> None:
        while not self.stop.wait(self.every):
            self._print()

    def close(self) -> None:
        """Stop the thread, with the last stage's last line."""
        if not self.stop.is_set():
            self.stop.set()
            self._print()


def is_terminal(stream: TextIO | None = None) -> bool:
    s = stream or sys.stderr
    try:
        return s.isatty()
    except (AttributeError, ValueError):
        return False


def study_progress(label: str) -> tuple[Callable[[str, int, int], None], Callable[[], None]]:
    """A sampled study's progress callback (stage, variants done, variants in the stage) and
    its closer: bars on a terminal, lines elsewhere."""
    if not is_terminal():
        lines = Lines(label, "variants")
        return (lambda stage, done, total: lines.update(stage, done, total)), lines.close
    from tqdm import tqdm  # here: only on a terminal

    bars: dict[str, Any] = {}

    def update(stage: str, done: int, total: int) -> None:
        bar = bars.get(stage)
        if bar is None:
            name = "reference" if stage == "reference" else "MuJoCo   "
            bar = bars[stage] = tqdm(total=total, desc=name, unit="variant", file=sys.stderr, leave=True)
        bar.update(done - bar.n)

    def close() -> None:
        for b in bars.values():
            b.close()

    return update, close


def optimize_progress(label: str, sign: float) -> tuple[Callable[[str, int, int, float], None], Callable[[], None]]:
    """An optimization's progress callback (run, generation, generations, best so far) and its
    closer: a bar per run on a terminal, lines elsewhere. ``sign`` turns the minimized value
    into the objective as written (-1 for a maximization)."""

    def best_text(best: float) -> str:
        return f"best {sign * best:.6g}" if math.isfinite(best) else "no feasible design yet"

    if not is_terminal():
        lines = Lines(label, "generations")
        return (lambda name, gen, total, best: lines.update(name, gen, max(total, gen), best_text(best))), lines.close
    from tqdm import tqdm  # here: only on a terminal

    bars: dict[str, Any] = {}

    def update(name: str, gen: int, total: int, best: float) -> None:
        bar = bars.get(name)
        if bar is None:
            for b in bars.values():
                b.close()
            bar = bars[name] = tqdm(total=max(total, 1), desc=name[:40], unit="gen", file=sys.stderr, leave=True)
        if gen > bar.total:
            bar.total = gen
        bar.update(max(0, gen - bar.n))
        bar.set_postfix_str(best_text(best))

    def close() -> None:
        for b in bars.values():
            b.close()

    return update, close
