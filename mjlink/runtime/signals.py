"""A run ends cleanly on SIGINT and SIGTERM.

:func:`interruptible` makes SIGTERM raise :class:`Terminated` as SIGINT raises
KeyboardInterrupt, so that a terminated run cleans up (removes its staging folder, stops its
plot worker) like an interrupted one; :func:`uninterrupted` holds both back while a cleanup or
a publication runs, so that a second Ctrl-C cannot cut it in half.
"""

from __future__ import annotations

import functools
import signal
import sys
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any

__all__ = ["Terminated", "interruptible", "raise_if_signalled", "uninterrupted"]


class Terminated(BaseException):
    """SIGTERM arrived while :func:`interruptible` was in force. Like KeyboardInterrupt it is no
    Exception: only cleanups (``finally``, ``with``) run as it unwinds, which remove the staging
    folder and stop the plot worker. The command line exits 143 (128 + SIGTERM)."""


_signalled: list[int] = []  # SIGINT / SIGTERM received during the current interruptible run


def _interruption(signum: int) -> BaseException:
    return Terminated(f"terminated by signal {signum}") if signum == signal.SIGTERM else KeyboardInterrupt()


def _on_signal(signum: int, frame: object) -> None:
    if signum == signal.SIGTERM and signum in _signalled:
        return  # once: a second SIGTERM must not cut short the clean-up the first one started
    _signalled.append(signum)
    raise _interruption(signum)


def raise_if_signalled() -> None:
    """Raise the interruption of a signal that came during the current :func:`interruptible`,
    though the code it landed in swallowed it: a run so interrupted publishes nothing."""
    if _signalled:
        raise _interruption(_signalled[0])


def _main_thread() -> bool:
    return threading.current_thread() is threading.main_thread()


def _quiet_interruption(hook: Callable[[Any], Any], unraisable: Any) -> None:
    """An unraisable exception goes to ``hook`` unless it is the interruption itself."""
    if isinstance(unraisable.exc_value, KeyboardInterrupt | Terminated):
        return
    hook(unraisable)


@contextmanager
def interruptible() -> Iterator[None]:
    """Make SIGINT and SIGTERM end the body cleanly, whatever code they land in.

    For its duration (main thread only) SIGTERM raises :class:`Terminated`, as SIGINT raises
    KeyboardInterrupt, so that a terminated run cleans up like an interrupted one instead of
    dying in the middle of its work; a second SIGTERM is ignored while that happens. The
    signals are also recorded: code that catches the exception and fails otherwise (a C
    library's callback turning it into an ordinary error) or swallows it cannot hide it, since
    the body then ends with KeyboardInterrupt or Terminated all the same (chained to the other
    error), and :func:`staged_dir` publishes nothing once a signal came. Nothing changes in
    another thread, or for a signal whose handler is not Python's default (an embedding
    program's choice, an ignored signal, or an outer ``interruptible``).
    """
    install: dict[int, Any] = {}  # signal -> the handler to put back
    if _main_thread():
        if signal.getsignal(signal.SIGTERM) is signal.SIG_DFL:
            install[signal.SIGTERM] = signal.SIG_DFL
        if signal.getsignal(signal.SIGINT) is signal.default_int_handler:
            install[signal.SIGINT] = signal.default_int_handler
    if not install:
        yield
        return
    _signalled.clear()
    for sig in install:
        signal.signal(sig, _on_signal)
    # A signal that lands in code whose exceptions Python can only print (an import lock's
    # weakref callback, a __del__) would show as "Exception ignored ... Traceback" on stderr;
    # it is recorded above and re-raised when the body ends, so it is not printed there.
    before = sys.unraisablehook
    sys.unraisablehook = functools.partial(_quiet_interruption, before)
    try:
        yield
    except BaseException as e:
        if _signalled and not isinstance(e, KeyboardInterrupt | Terminated):
            raise _interruption(_signalled[0]) from e
        raise
    else:
        if _signalled:
            raise _interruption(_signalled[0])
    finally:
        sys.unraisablehook = before
        for sig, old in install.items():
            signal.signal(sig, old)
        _signalled.clear()


@contextmanager
def uninterrupted() -> Iterator[None]:
    """Hold SIGINT and SIGTERM back while the body runs (their Python handlers, in the main
    thread), so that a cleanup or a publication is not cut in half by a second Ctrl-C. A signal
    that came meanwhile is acted on when the body returns (its handler runs then: raises
    KeyboardInterrupt or :class:`Terminated`); if the body raised, that exception goes on and the
    signal is dropped, since the run is ending anyway."""
    if not _main_thread():
        yield
        return
    came: list[int] = []
    held: dict[int, Callable[[int, Any], Any]] = {}
    for sig in (signal.SIGINT, signal.SIGTERM):
        handler = signal.getsignal(sig)
        if callable(handler):
            held[sig] = handler
            signal.signal(sig, lambda signum, frame: came.append(signum))
    try:
        yield
    finally:
        for sig, handler in held.items():
            signal.signal(sig, handler)
    for signum in came[:1]:
        held[signum](signum, None)
