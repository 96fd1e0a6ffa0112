"""How a command is stopped: SIGTERM ends it as an error does, and a stop is never lost.

A command decorated with :func:`inertiafit.io.outputs.guard_outputs` runs inside
:func:`sigterm_ends`: SIGTERM raises ``SystemExit(143)`` where the command is, so every
``finally`` clause runs (staging folders removed, locks released). Two things can defeat that
exception, and this module closes both:

- Python ignores an exception raised in a weakref callback or a finaliser and goes on. The
  handler therefore also *records* the signal, and :func:`stop_point` ends the command for a
  recorded signal: the samplers call it between steps, the output folder before it writes its
  marker and swaps, the guard after the command returns. A swallowed SIGTERM can delay the
  end, never turn it into a success; Python's "Exception ignored" notice for it is not
  printed (it is not an error of the command, and the stop is not ignored).
- Code that calls back into a third-party loop which reports what it catches (emcee prints a
  traceback for any exception raised in the log density) runs its steps inside
  :func:`signals_deferred`, where SIGTERM and Ctrl-C are recorded and take effect at the next
  :func:`stop_point` (the samplers call it between steps, a few milliseconds apart).
"""

from __future__ import annotations

import functools
import signal
import sys
import threading
from collections.abc import Iterator
from contextlib import contextmanager

__all__ = ["signals_deferred", "signals_held", "sigterm_ends", "stop_point"]

#: Signals received by :func:`_stop` in this process that have not yet ended a command.
_RECEIVED: list[int] = []
#: Ctrl-C presses held by :func:`signals_deferred`.
_INTERRUPTS: list[int] = []
#: True inside :func:`signals_deferred`: the handlers record and do not raise.
_DEFERRED = [False]


def _main_thread() -> bool:
    return threading.current_thread() is threading.main_thread()


def _stop(signum: int, _frame: object) -> None:
    _RECEIVED.append(int(signum))
    if not _DEFERRED[0]:
        raise SystemExit(128 + signum)


def _hold_interrupt(signum: int, _frame: object) -> None:
    _INTERRUPTS.append(int(signum))


def stop_point() -> None:
    """End the command now if it was asked to stop and has not stopped yet.

    Raises ``KeyboardInterrupt`` for a Ctrl-C held by :func:`signals_deferred`, and
    ``SystemExit(128 + signal)`` for a SIGTERM received under :func:`sigterm_ends` (the
    exception its handler raised may have been swallowed). Does nothing otherwise.
    """
    if _INTERRUPTS:
        _INTERRUPTS.clear()
        raise KeyboardInterrupt
    if _RECEIVED:
        raise SystemExit(128 + _RECEIVED[0])


@contextmanager
def sigterm_ends() -> Iterator[None]:
    """SIGTERM raises ``SystemExit(143)`` in here (main thread only), so ``finally`` clauses run.

    Blocks nest; the outermost one forgets the signals recorded when it ends (the command it
    guarded has ended, by them or not), so a library caller's next command starts afresh.
    """
    if not _main_thread():
        yield
        return
    previous = signal.signal(signal.SIGTERM, _stop)
    outermost = previous is not _stop
    if outermost:
        _RECEIVED.clear()
        hook = sys.unraisablehook
        sys.unraisablehook = functools.partial(_quiet_about_stops, hook)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, signal.SIG_DFL if previous is None else previous)
        if outermost:
            sys.unraisablehook = hook
            _RECEIVED.clear()


def _quiet_about_stops(hook, unraisable) -> None:
    """``sys.unraisablehook`` silent for the stop :func:`_stop` raised (it is recorded)."""
    value = unraisable.exc_value
    if isinstance(value, SystemExit) and _RECEIVED and value.code == 128 + _RECEIVED[0]:
        return
    hook(unraisable)


@contextmanager
def signals_deferred() -> Iterator[None]:
    """SIGTERM and Ctrl-C are recorded in here and take effect at the next :func:`stop_point`.

    Only signals that would otherwise end the command are held: SIGTERM where
    :func:`sigterm_ends` handles it, Ctrl-C where Python's default handler does; others keep
    their handlers. A signal recorded in the block takes effect when it ends, at the latest.
    Main thread only (signals are delivered there); elsewhere the block changes nothing.
    """
    if not _main_thread():
        yield
        return
    held_int = signal.getsignal(signal.SIGINT) is signal.default_int_handler
    if held_int:
        signal.signal(signal.SIGINT, _hold_interrupt)
    was = _DEFERRED[0]
    _DEFERRED[0] = True
    try:
        yield
    finally:
        _DEFERRED[0] = was
        if held_int:
            signal.signal(signal.SIGINT, signal.default_int_handler)
    stop_point()


@contextmanager
def signals_held() -> Iterator[None]:
    """Ctrl-C and SIGTERM wait until the block is done (the renames of a swap)."""
    if not _main_thread():
        yield
        return
    pending: list[int] = []  # signal numbers
    watched = (signal.SIGINT, signal.SIGTERM)
    previous = {
        s: signal.signal(s, lambda signum, _f: pending.append(int(signum))) for s in watched
    }
    try:
        yield
    finally:
        for s, handler in previous.items():
            signal.signal(s, signal.SIG_DFL if handler is None else handler)
        for signum in dict.fromkeys(pending):
            signal.raise_signal(signum)
